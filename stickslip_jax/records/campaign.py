"""Campaigns: the record files a spec names (files, folders, globs), read together with the
unreadable ones set aside, and the checks that records belong in one fit."""

from __future__ import annotations

import dataclasses
import glob as _glob
import os
from collections.abc import Iterable
from pathlib import Path

from .errors import RecordError
from .grammar import MAX_FILE_BYTES
from .parse import read_record
from .record import Record


def record_paths(spec) -> list[Path]:
    """The record files a campaign spec names (files, folders, globs; `read_campaign`)."""
    return _expand(spec)


def _expand(spec) -> list[Path]:
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
            out.extend(_expand(item))
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


def read_campaign_files(spec, *, max_bytes: int = MAX_FILE_BYTES) -> CampaignFiles:
    """Read a campaign as `read_campaign` does, but a file whose content cannot be read (a
    summary table in the folder, a logger's long gap, a NaN cell) is listed in
    `unreadable` instead of stopping the campaign: the other records can still be fitted.
    A path that does not exist, a file named twice or a copy of another file's content
    still raises `RecordError` (the campaign as given is wrong)."""
    import hashlib

    files = _expand(spec)
    if not files:
        raise RecordError("the campaign is empty; give at least one record file")
    seen, contents = {}, {}
    for f in files:
        key = os.path.realpath(f)
        if key in seen:
            raise RecordError(f"named twice in the campaign (also as {seen[key]})", f)
        seen[key] = str(f)
    records, unreadable = [], []
    for f in files:
        digest = hashlib.sha256()
        with open(f, "rb") as fh:  # in blocks: a file over `max_bytes` is refused below
            for block in iter(lambda: fh.read(1 << 20), b""):
                digest.update(block)
        digest = digest.hexdigest()
        if digest in contents:
            raise RecordError(f"the same content as {contents[digest]}: a copy would count "
                              "its record twice; give each record once", f)
        contents[digest] = str(f)
        try:
            records.append(read_record(f, max_bytes=max_bytes))
        except RecordError as err:
            unreadable.append(err)
    return CampaignFiles(records, unreadable)


def read_campaign(spec, *, max_bytes: int = MAX_FILE_BYTES) -> list[Record]:
    """Read a campaign: a file, a directory (its *.csv, sorted), a glob, or a list of these.

    Files are returned in the order given (sorted within a directory or glob); a file
    named twice, or two files with the same content (a copy under another name would
    count its record twice), is an error. Raises `RecordError` for the first bad file
    (`read_campaign_files` lists the bad files and reads the rest).
    """
    got = read_campaign_files(spec, max_bytes=max_bytes)
    got.check(strict=True)
    return got.records


def check_campaign(
    records, *, same: Iterable[str] = ("lubricant", "surface"), strict: bool = True
) -> list[str]:
    """Problems with fitting `records` together: a field of `same` that differs between them.

    A field missing (None) in some records but given in others is a problem too. Returns
    the list of messages (empty when fine); with `strict` raises `RecordError` instead
    when there is any.
    """
    records = list(records)
    problems = []
    for field in same:
        groups: dict[object, list[str]] = {}
        for i, r in enumerate(records):
            value = getattr(r, field)
            groups.setdefault(value, []).append(r.name or f"record {i}")
        if len(groups) > 1:
            parts = "; ".join(
                f"{'not given' if v is None else repr(v)} in {', '.join(n)}"
                for v, n in groups.items()
            )
            problems.append(
                f"the campaign mixes {field}s ({parts}); fit records of one {field} together"
            )
    if strict and problems:
        raise RecordError(" | ".join(problems))
    return problems
