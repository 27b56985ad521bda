r"""A campaign of records, screened record by record before any fitting.

Every record is read, its cycles extracted (`data.features`), and it gets a status:
`used` (enough complete cycles; fitted), `no_stick_slip` (no slip found at all: steady
sliding, or stick-slip too small for the noise; information about the boundary, not an
error), `set_aside` (slips found, but too few complete cycles passed the checks; the
reason names what failed) or `unreadable` (the reason names the line and the fix).

The fit goes on with the used records (at least `min_records` of them); `strict=True`
refuses a campaign with any record not used. Screening only reads the records. Units:
kgf, mm, s.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from stickslip_jax.records import (Record, RecordError, check_campaign, read_campaign_files,
                                   record_paths)
from stickslip_jax.rigs import rig_quantities

from .features import RecordFeatures, record_features

__all__ = ["USED", "NO_STICK_SLIP", "SET_ASIDE", "UNREADABLE", "ONE_RECORD_HOLDS", "Campaign",
           "FitCampaign", "RecordStatus", "find_truth", "load_campaign", "one_record_holds",
           "read_fit_campaign", "screen_records"]

USED, NO_STICK_SLIP, SET_ASIDE, UNREADABLE = "used", "no_stick_slip", "set_aside", "unreadable"


@dataclasses.dataclass(frozen=True)
class RecordStatus:
    """The screening of one record: `status`, the `reason` when not used, the slips found
    (`cycles`), complete cycles, cycles left out by reason, spikes replaced, the noise
    (mm), the run's W (kgf), k (kgf/mm), v (mm/s), normal load N (kgf, None: N = W) and a
    rotational rig's conditions (`stickslip_jax.rigs.rig_quantities`)."""

    name: str
    status: str
    reason: str | None
    cycles: int
    complete_cycles: int
    left_out: dict
    spikes: int
    noise: float
    weight: float
    stiffness: float
    drive_speed: float
    notes: tuple[str, ...] = ()
    normal_load: float | None = None
    rig: dict = dataclasses.field(default_factory=dict)

    @classmethod
    def unreadable(cls, err: RecordError) -> RecordStatus:
        """The status of a file that could not be read: named by its file name (with the
        extension: it is not a record); its run (W, k, v, noise) unknown (NaN)."""
        nan = float("nan")
        reason = (f"line {err.line}: " if err.line is not None else "") + err.reason
        return cls(name=Path(err.path).name if err.path else "?", status=UNREADABLE,
                   reason=reason, cycles=0, complete_cycles=0, left_out={}, spikes=0,
                   noise=nan, weight=nan, stiffness=nan, drive_speed=nan)

    def to_json(self) -> dict:
        return {"name": self.name, "status": self.status, "reason": self.reason,
                "cycles": self.cycles, "complete_cycles": self.complete_cycles,
                "cycles_left_out": dict(self.left_out), "spikes_replaced": self.spikes,
                "noise_mm": self.noise, "weight_kgf": self.weight,
                "stiffness_kgf_per_mm": self.stiffness,
                "drive_speed_mm_per_min": self.drive_speed * 60.0,
                "notes": list(self.notes), **self.rig,
                **({} if self.normal_load is None else {"normal_load_kgf": self.normal_load})}


@dataclasses.dataclass(frozen=True)
class Campaign:
    """Screened campaign: `records`/`features` of the used records (same order), the
    `screening` of every record in the order given, the records not used, and the files
    read (`inputs`; empty for `Record` objects)."""

    records: list[Record]
    features: list[RecordFeatures]
    screening: list[RecordStatus]
    not_used: list[tuple[Record, RecordFeatures]]
    inputs: tuple[str, ...] = ()

    @property
    def warnings(self) -> list[str]:
        return [f"{s.name}: {s.status.replace('_', ' ')} ({s.reason}); not fitted"
                for s in self.screening if s.status != USED]

    @property
    def notes(self) -> list[str]:
        """What reading and cycle extraction did to each record (resampling, dialect,
        drive correction, spikes replaced, cycles left out)."""
        out = []
        for s in self.screening:
            out += [f"{s.name}: {n}" for n in s.notes]
            if s.spikes:
                out.append(f"{s.name}: {s.spikes} impulsive spike samples replaced")
            if s.status == USED and s.left_out:
                why = ", ".join(f"{c} {k}" for k, c in s.left_out.items())
                out.append(f"{s.name}: cycles left out: {why}")
        held = one_record_holds(self)
        if held:
            out.append(
                f"one record: {', '.join(f'{k} = {v:g}' for k, v in held.items())} held at "
                f"lubricant {held_lubricant(self)}'s values (Table 6): one stick time and one "
                "slip time determine mu_s and mu_d only with the rise of eq (1) and the decay "
                "of eq (3) given (--fix NAME=VALUE holds another value; records at other "
                "speeds and springs fit them)")
        return out


_STICK = "one stick time cannot give the rise of mu_0 with stick time (eq 1)"
_SLIP = "one slip time cannot give the decay of mu_k with slip time (eq 3)"
ONE_RECORD_HOLDS = {"gamma": _STICK, "m": _STICK, "delta": _SLIP, "n": _SLIP}
"""What one record cannot determine, with the reason, held by a fit of a single record
(`one_record_holds`); records at other speeds and springs determine them."""


def held_lubricant(campaign: Campaign) -> str:
    """The paper's lubricant whose Table 6 values hold `ONE_RECORD_HOLDS`: the record's
    when it is one of them, else A."""
    from stickslip_jax.lubricants import lubricants

    name = campaign.records[0].lubricant if campaign.records else None
    return name if name in lubricants(6) else "A"


def one_record_holds(campaign: Campaign) -> dict[str, float]:
    """{name: value} a fit of a campaign of one used record holds (`ONE_RECORD_HOLDS` at
    Table 6's values, `held_lubricant`), so that mu_s and mu_d get intervals; {} for
    a campaign of several records."""
    if len(campaign.records) != 1:
        return {}
    from stickslip_jax.lubricants import lubricant

    f = lubricant(held_lubricant(campaign))
    values = {"gamma": f.static.gamma, "m": f.static.m, "delta": f.kinetic.delta,
              "n": f.kinetic.n}
    return {k: float(values[k]) for k in ONE_RECORD_HOLDS}


def _status(f: RecordFeatures, record: Record | None = None) -> RecordStatus:
    if f.stick_slip:
        status, reason = USED, None
    elif len(f.peak) == 0 and f.message and f.message.startswith("no stick-slip"):
        status, reason = NO_STICK_SLIP, f.message
    else:
        status, reason = SET_ASIDE, f.message
    return RecordStatus(
        name=f.name, status=status, reason=reason, cycles=int(len(f.peak)),
        complete_cycles=f.n_complete if f.stick_slip else 0, left_out=dict(f.left_out),
        spikes=int(f.spikes), noise=float(f.noise), weight=f.weight, stiffness=f.stiffness,
        drive_speed=f.drive_speed, normal_load=f.normal_load,
        rig=rig_quantities(record) if record is not None else {},
        notes=tuple(record.notes if record is not None else ())
        + ((f.drive_note,) if f.drive_note else ())
        + ((f.noise_note,) if f.noise_note else ()))


def screen_records(records: list[Record], *, min_records: int = 2,
                   strict: bool = False, unreadable=()) -> Campaign:
    """Extract every record's cycles and keep the records with usable stick-slip.

    `unreadable`: the `RecordError`s of the campaign's files that could not be read
    (`read_campaign_files`), listed in the screening after the records (status
    UNREADABLE). Raises ValueError (one line naming the records) when fewer than
    `min_records` remain, or, with `strict`, when any record is not used."""
    features = [record_features(r) for r in records]
    screening = ([_status(f, r) for f, r in zip(features, records)]
                 + [RecordStatus.unreadable(e) for e in unreadable])
    used = [i for i, s in enumerate(screening) if s.status == USED]
    bad = [f"{s.name}: {s.reason}" for s in screening if s.status != USED]
    if strict and bad:
        raise ValueError("no usable stick-slip in " + " | ".join(bad)
                         + " (remove these records, or leave out --strict to fit the rest)")
    if len(used) < min_records:
        raise ValueError(
            f"only {len(used)} of {len(screening)} records have usable stick-slip (a fit "
            f"needs {min_records}): " + (" | ".join(bad) if bad else ""))
    return Campaign(
        records=[records[i] for i in used], features=[features[i] for i in used],
        screening=screening,
        not_used=[(records[i], features[i]) for i in range(len(records)) if i not in used])


def load_campaign(specs, *, min_records: int | None = 2, strict: bool = False) -> Campaign:
    """Read record files, directories or globs (or take `Record` objects), check they form
    one campaign (one lubricant) and screen them (`screen_records`). A file that cannot be
    read is listed as UNREADABLE and the rest are fitted (`strict`: its error is raised, as
    is the only file's). `min_records` None: 1 for a single record (`one_record_holds`),
    else 2. Raises ValueError naming what to fix."""
    specs, inputs = list(specs), ()
    if specs and all(isinstance(s, Record) for s in specs):
        records, unreadable = specs, ()
    else:
        paths = record_paths(specs)
        files = read_campaign_files(paths)
        records, unreadable, inputs = files.records, files.unreadable, tuple(map(str, paths))
        files.check(strict)
    if min_records is None:
        min_records = 1 if len(records) + len(unreadable) == 1 else 2
    if len(records) + len(unreadable) < min_records:
        raise ValueError(
            f"a campaign needs at least {min_records} records (got {len(records)}): one run "
            "cannot separate the six friction parameters; give records at several speeds")
    check_campaign(records, same=("lubricant",))
    campaign = screen_records(records, min_records=min_records, strict=strict,
                              unreadable=unreadable)
    return dataclasses.replace(campaign, inputs=inputs)


@dataclasses.dataclass(frozen=True)
class FitCampaign:
    """What the data step hands a campaign fit (`read_fit_campaign`), each part computed
    once: the screened `campaign`, the `holds` of a campaign of one record
    (`one_record_holds`), the records' `truth` (`find_truth`), the campaign's `notes`
    and the JSON of each record's screening."""

    campaign: Campaign
    holds: dict[str, float]
    truth: dict[str, float] | None
    notes: tuple[str, ...]
    screening: list[dict]


def read_fit_campaign(specs, names, *, one_record: bool = True,
                      strict: bool = False) -> FitCampaign:
    """`load_campaign` for a fit of the law whose parameters are `names`: a campaign of one
    record is fitted when `one_record` (with its holds), else two records at least."""
    campaign = load_campaign(specs, min_records=None if one_record else 2, strict=strict)
    return FitCampaign(campaign, one_record_holds(campaign), find_truth(campaign.records, names),
                       tuple(campaign.notes), [s.to_json() for s in campaign.screening])


def find_truth(records, names=None) -> dict[str, float] | None:
    """The friction parameters the records were made from, if all carry the same truth."""
    from ..params import NAMES

    NAMES = tuple(names or NAMES)  # noqa: N806

    def dig(d):
        if not isinstance(d, dict):
            return None
        if isinstance(d.get("static"), dict) and isinstance(d.get("kinetic"), dict):
            d = {**d, **d["static"], **d["kinetic"]}  # stickslip simulate's layout
        if all(n in d for n in NAMES):
            try:
                return {n: float(d[n]) for n in NAMES}
            except (TypeError, ValueError):
                return None
        for v in d.values():
            got = dig(v)
            if got:
                return got
        return None

    truths = [dig(r.truth) for r in records]
    if not truths or any(t is None for t in truths) or any(t != truths[0] for t in truths):
        return None
    return truths[0]
