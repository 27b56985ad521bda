"""Campaigns: the record files a spec names (files, folders, globs), read together with the
unreadable ones set aside, and the checks that records belong in one fit."""

from __future__ import annotations

import dataclasses
import glob as _glob
import os
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from .errors import RecordError
from .grammar import MAX_FILE_BYTES
from .parse import read_record
from .record import Record


def record_paths(spec) -> list[Path]:
    """The record files a campaign spec names (files, folders, globs; `read_campaign`)."""
    if isinstance(spec, (str, os.PathLike)):
        p = Path(spec)
        if p.is_dir():
            files = sorted(q for q in p.glob("*.csv") if q.is_file())
            if not files:
                raise RecordError("directory has no *.csv record files", p)
            return files
        if p.exists():
            return [p]
        if any(ch in str(spec) for ch in "*?["):
            files = sorted(Path(q) for q in _glob.glob(str(spec)) if Path(q).is_file())
            if not files:
                raise RecordError("no file matches this pattern", spec)
            return files
        raise RecordError("no such file or directory; check the path", spec)
    if isinstance(spec, Iterable):
        out = []
        for item in spec:
            if not isinstance(item, (str, os.PathLike)):
                raise RecordError(f"campaign entries must be paths, got {item!r}")
            out.extend(record_paths(item))
        return out
    raise RecordError(f"a campaign is a path, a glob or a list of them, got {spec!r}")


@dataclasses.dataclass(frozen=True)
class CampaignFiles:
    """What reading a campaign's files gave (`read_campaign_files`): the `records` read, in
    the order given, and the `unreadable` files, each as the `RecordError` that names the
    file, the line and the fix (`.path`, `.line`, `.reason`)."""

    records: list[Record]
    unreadable: list[RecordError]

    def check(self, strict: bool = False) -> None:
        """Raise the first unreadable file's error when `strict` or when no file could be
        read (a campaign of one bad file is that file's error); otherwise they are set
        aside by the caller."""
        if self.unreadable and (strict or not self.records):
            raise self.unreadable[0]


def _data_key(record: Record) -> str:
    """A digest of what a fit uses of a record: its samples and its rig's conditions, so
    the same run re-saved (another separator, decimal commas, line ends, note) has the same
    key and a different run another."""
    import hashlib

    h = hashlib.sha256()
    for a in (record.time, record.deflection, record.drive):
        h.update(b"-" if a is None else np.ascontiguousarray(a, dtype=np.float64).tobytes())
    h.update(repr((record.stiffness, record.weight, record.drive_speed,
                   record.drive_program, record.lubricant, record.surface)).encode())
    return h.hexdigest()


def count_once(records: list[Record]) -> list[Record]:
    """The records with the same data counted once: the first keeps a note naming the
    others (a copy under another name would count its run twice)."""
    first: dict[str, int] = {}
    out: list[Record] = []
    for r in records:
        key = _data_key(r)
        if key not in first:
            first[key] = len(out)
            out.append(r)
            continue
        k = first[key]
        out[k] = dataclasses.replace(out[k], notes=out[k].notes + (
            f"{r.source or r.name} holds the same data: counted once",))
    return out


def read_campaign_files(spec, *, max_bytes: int = MAX_FILE_BYTES,
                        same: Iterable[str] | None = ("lubricant", "surface")) -> CampaignFiles:
    """Read a campaign as `read_campaign` does, but a file whose content cannot be read (a
    summary table in the folder, a logger's long gap, a NaN cell) is listed in
    `unreadable` instead of stopping the campaign: the other records can still be fitted.
    Files with the same data (a copy, or the run re-saved by a spreadsheet) count once,
    with a note on the one kept. A path that does not exist or a file named twice still
    raises `RecordError` (the campaign as given is wrong), and so do records of another
    rig (`rig_problems`) or of another value of a field in `same` where given (`same=None`:
    no such check)."""
    files = record_paths(spec)
    if not files:
        raise RecordError("the campaign is empty; give at least one record file")
    seen = {}
    for f in files:
        key = os.path.realpath(f)
        if key in seen:
            raise RecordError(f"named twice in the campaign (also as {seen[key]})", f)
        seen[key] = str(f)
    records, unreadable = [], []
    for f in files:
        try:
            records.append(read_record(f, max_bytes=max_bytes))
        except RecordError as err:
            unreadable.append(err)
    records = count_once(records)
    if same is not None:
        problems = [p for field in same for p in
                    _mixed([r for r in records if getattr(r, field) is not None], field)]
        if problems + rig_problems(records):
            raise RecordError(" | ".join(problems + rig_problems(records)))
    return CampaignFiles(records, unreadable)


RIG_SPAN = 20.0
"""Largest factor between a record's slider weight (or spring stiffness) and the
campaign's median: the paper's rigs span 11.3-53.2 kgf and 27.3-128.5 kgf/mm (a factor
4.7); a 30.7 g paper slider on a 168 N/m spring is another rig (a factor of 1000)."""


def rig_problems(records) -> list[str]:
    """Records of another rig than the campaign's: slider weight or stiffness more than
    `RIG_SPAN` from the median, or a rotational rig (`friction_radius`) among linear ones;
    each message names the records that differ."""
    records = list(records)
    if len(records) < 2:
        return []
    problems = []
    for field, unit in (("weight", "kgf"), ("stiffness", "kgf/mm")):
        values = np.array([float(getattr(r, field)) for r in records])
        mid = float(np.median(values))
        odd = [i for i, v in enumerate(values) if max(v / mid, mid / v) > RIG_SPAN]
        if odd:
            names = ", ".join(f"{records[i].name} ({values[i]:.4g} {unit})" for i in odd)
            problems.append(f"{names}: {field} more than {RIG_SPAN:g} times the campaign's "
                            f"median {mid:.4g} {unit}: another rig; fit it as a campaign of "
                            "its own")
    rotary = [r.name for r in records if getattr(r, "friction_radius", None) is not None]
    if 0 < len(rotary) < len(records):
        problems.append(f"{', '.join(rotary)}: a rotational rig among linear records; fit "
                        "each rig as a campaign of its own")
    return problems


def _mixed(records, field: str) -> list[str]:
    """The message for records that differ in `field`, the fewest first (the odd ones)."""
    groups: dict[object, list[str]] = {}
    for i, r in enumerate(records):
        groups.setdefault(getattr(r, field), []).append(r.name or f"record {i}")
    if len(groups) < 2:
        return []
    parts = "; ".join(f"{'not given' if v is None else repr(v)} in {', '.join(n)}"
                      for v, n in sorted(groups.items(), key=lambda g: len(g[1])))
    return [f"the campaign mixes {field}s ({parts}); fit records of one {field} together"]


def read_campaign(spec, *, max_bytes: int = MAX_FILE_BYTES) -> list[Record]:
    """Read a campaign: a file, a directory (its *.csv, sorted), a glob, or a list of these.

    Files are returned in the order given (sorted within a directory or glob); a file
    named twice is an error, files with the same data count once (with a note). Raises
    `RecordError` for the first bad file (`read_campaign_files` lists the bad files and
    reads the rest)."""
    got = read_campaign_files(spec, max_bytes=max_bytes, same=None)
    got.check(strict=True)
    return got.records


def check_campaign(
    records, *, same: Iterable[str] = ("lubricant", "surface"), strict: bool = True) -> list[str]:
    """Problems with fitting `records` together: a field of `same` that differs between
    them (a field missing, None, in some records but given in others too), or records of
    another rig (`rig_problems`). Returns the list of messages (empty when fine); with
    `strict` raises `RecordError` instead when there is any."""
    records = list(records)
    problems = [p for field in same for p in _mixed(records, field)] + rig_problems(records)
    if strict and problems:
        raise RecordError(" | ".join(problems))
    return problems
