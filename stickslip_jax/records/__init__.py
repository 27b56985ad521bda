r"""Measured records: one run of the slideway read from (and written to) a CSV file.

A record is the spring deflection $x(t)$ (or the spring force $F = kx$) sampled at a
uniform step, with the run's conditions: stiffness $k$, slider weight $W$ and the drive
(a constant speed $v$, a piecewise-constant speed program, or a measured drive
displacement $u(t)$). Everything is held in the internal units kgf, mm, s; the file may
use any unit that `stickslip_jax.units` knows, converted on the way in.

File format (UTF-8, version 1)::

    # stickslip-record: 1
    # drive_speed: 1.0 mm/min
    # stiffness: 86.9 kgf/mm
    # slider_weight: 36.0 kgf
    # lubricant: A
    # surface: S1G1
    time [s],deflection [mm]
    0.000,0.1203
    0.001,0.1204

- The first line is `# stickslip-record: 1`. Header lines are `# key: value` with a
  lowercase key; quantities are `number unit` (`86.9 kgf/mm`, `852 N/mm`); a bare
  number is an error (no unit is guessed).
- Required: `stiffness`; `slider_weight` or `slider_mass` (in kg: W = m g, so 1 kg
  weighs 1 kgf); a `time` column; a `deflection` or a `force` column (x = F/k); and at
  least one drive: `drive_speed`, `drive_program` or a `drive` column. When several
  are given, the drive is the `drive` column, else the `drive_program`, else
  `drive_speed` (which then stays as the nominal speed).
- `drive_program: 0 s 1 mm/min; 30 s 0 mm/min; 60 s 1 mm/min` lists segments
  `start-time speed` separated by `;`: the speed holds from its start time to the next
  start (the last holds for ever). A hold is speed 0. Starts increase strictly, speeds
  are >= 0; before the first start the drive rests. The drive displacement is
  $u(t) = \int_0^t v(s)\,ds$ (zero at t = 0, like `drive_speed`'s $u = vt$).
- Optional: `lubricant`, `surface`, `note` (one line of free text), `truth: {json}`
  (parameters a synthetic record was made from), any other `key: value` (kept as
  raw text), and more columns `name [unit]` (e.g. `pitch_1 [um]`; `[-]` for a pure
  number) stored in `Record.channels` in internal units.
- Data rows: one number per column, `.` as decimal point. Time must increase strictly
  and be uniform: every step within `TIME_STEP_RTOL` (1e-3) of the mean step.
  Blank lines are ignored; `#` lines after the column row are an error.
- Files over `MAX_FILE_BYTES` (200 MB) are refused.

Reading never guesses and never crashes: every problem is one `RecordError` (a
`ValueError`) whose message names the file, the line and what to fix. Writing with the
defaults (internal units, `repr` precision) then reading gives the record back exactly.

The package's modules, by job: `record` (the `Record` type and its checks), `sampling`
(the clock: even steps, jitter, dropped samples, epoch stamps), `drive` (drive
programs), `quantities` (units of quantities and columns), `dialects` (bytes to lines,
cell dialects), `rows` (the data rows), `parse` (reading a file), `write` (writing one),
`campaign` (reading campaigns), `dataframe` (pandas DataFrames both ways), `grammar`
(the format's constants and regular expressions) and `errors` (`RecordError`).
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
