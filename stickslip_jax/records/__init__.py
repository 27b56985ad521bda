r"""Measured records: one run of the slideway read from (and written to) a CSV file.

A record is the spring deflection $x(t)$ (or the spring force $F = kx$) sampled at a
uniform step, with the run's conditions: stiffness $k$, slider weight $W$ and the drive
(a constant speed $v$, a piecewise-constant speed program, or a measured drive
displacement $u(t)$). Everything is held in the internal units kgf, mm, s; the file may
use any unit that `stickslip_jax.units` knows, converted on the way in.

File format (UTF-8, version 1; the full description is docs/records.md)::

    # stickslip-record: 1
    # drive_speed: 1.0 mm/min
    # stiffness: 86.9 kgf/mm
    # slider_weight: 36.0 kgf
    time [s],deflection [mm]
    0.000,0.1203

Header lines are `# key: value`, quantities `number unit` (no unit is guessed); the keys,
columns, drives and clock rules are in docs/records.md.

Reading never guesses and never crashes: every problem is one `RecordError` (a
`ValueError`) whose message names the file, the line and what to fix. Writing with the
defaults (internal units, `repr` precision) then reading gives the record back exactly.

Modules: `record` (the `Record` type and its checks), `sampling` (the clock), `drive`
(drive programs), `quantities` (units), `dialects` (bytes to lines, cell dialects), `rows`
(data rows), `parse` and `write` (one file), `campaign` (campaigns), `dataframe` (pandas),
`grammar` (the format's constants) and `errors` (`RecordError`).
"""

from __future__ import annotations

from .campaign import (CampaignFiles, check_campaign, read_campaign, read_campaign_files,
                       record_paths)
from .drive import format_drive_program, parse_drive_program, program_position, program_speed
from .errors import RecordError
from .grammar import FORMAT_VERSION, KNOWN_KEYS, MAX_FILE_BYTES, RESERVED_COLUMNS
from .parse import parse_record, read_record
from .quantities import channel_dimension, unit_dimension
from .record import Record
from .sampling import (EPOCH_SECONDS, JITTER_MIN_SAMPLES, JITTER_RTOL, JITTER_STAMP, JITTER_STEP,
                       MISSING_RUN, MISSING_SHARE, TIME_STEP_RTOL, jittered_clock, missing_samples,
                       time_step_deviation)
from .write import format_record, write_record

__all__ = [
    "JITTER_RTOL", "JITTER_STAMP", "JITTER_STEP", "MISSING_RUN", "MISSING_SHARE",
    "JITTER_MIN_SAMPLES", "EPOCH_SECONDS", "FORMAT_VERSION", "MAX_FILE_BYTES", "TIME_STEP_RTOL",
    "KNOWN_KEYS", "RESERVED_COLUMNS",
    "RecordError", "unit_dimension", "channel_dimension",
    "jittered_clock", "missing_samples", "time_step_deviation", "Record",
    "program_speed", "program_position", "parse_drive_program", "format_drive_program",
    "parse_record", "read_record", "format_record", "write_record",
    "record_paths", "CampaignFiles", "read_campaign_files", "read_campaign", "check_campaign"]
