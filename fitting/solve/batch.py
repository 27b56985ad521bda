r"""Batches of campaign fits, spread over processes (`jax.distributed`) or run in one.

A batch is a list of campaigns (each a record folder, glob or list of files, as `stickslip
fit` takes them) and one function that fits a campaign and returns a JSON-ready dict.
`fit_batch` gives every process its share, runs it, and exchanges the results so that
every process ends with the whole batch in the order given. With one process it is a
plain loop.

- **Shares** (`shares`): campaigns dealt largest first (bytes of their record files, a
  proxy of fit time) to the least loaded process, so one big campaign does not leave the
  others idle; every process computes the same shares without communicating.
- **Exchange** (`exchange`): each process's results as JSON bytes, gathered with
  `jax.experimental.multihost_utils.process_allgather`.
- **Failures stay local**: a `ValueError` (no usable stick-slip, a bad file) gives status
  "failed", any other exception "error"; the other campaigns go on, and every process
  still reaches the exchange (a process that stopped would leave the others waiting).

Units are those of the fits (kgf, mm, s); `seconds` is the wall time of one campaign.
"""

from __future__ import annotations

import dataclasses
import json
import os
import time
from typing import Callable, Sequence

import numpy as np

__all__ = ["BatchEntry", "BatchResult", "FITTED", "NOT_CONVERGED", "FAILED", "ERROR",
           "campaign_name", "exchange", "fit_batch", "shares"]

FITTED, NOT_CONVERGED, FAILED, ERROR = "fitted", "not_converged", "failed", "error"


@dataclasses.dataclass(frozen=True)
class BatchEntry:
    """One campaign of a batch: its `name` and `spec` (what was given), `status` (FITTED,
    NOT_CONVERGED, FAILED or ERROR), the fit's `report` (None unless fitted, converged or
    not), the `message` of a failure, the wall time `seconds` and the `process` that ran it."""

    index: int
    name: str
    spec: object
    status: str
    report: dict | None
    message: str | None
    seconds: float
    process: int

    def to_json(self) -> dict:
        spec = self.spec if isinstance(self.spec, str) else [str(s) for s in self.spec]
        return {"campaign": self.name, "spec": spec, "status": self.status,
                "message": self.message, "wall_time_s": self.seconds, "process": self.process,
                "result": self.report}


@dataclasses.dataclass(frozen=True)
class BatchResult:
    """Every campaign of the batch in the order given (`entries`), the number of processes
    that shared it, and the wall time of this process (s)."""

    entries: tuple[BatchEntry, ...]
    processes: int
    seconds: float

    def count(self, status: str) -> int:
        return sum(e.status == status for e in self.entries)

    @property
    def all_fitted(self) -> bool:
        return all(e.status == FITTED for e in self.entries)


def campaign_name(spec) -> str:
    """A short name of a campaign spec: a folder's name, a glob or file as given, the first
    file of a list with "+N"."""
    if isinstance(spec, (str, os.PathLike)):
        return os.path.basename(os.path.normpath(str(spec))) or str(spec)
    spec = [str(s) for s in spec]
    if not spec:
        raise ValueError("a campaign of the batch names no records")
    return campaign_name(spec[0]) + (f"+{len(spec) - 1}" if len(spec) > 1 else "")


def _files(spec) -> tuple[list, int]:
    """The record files of `spec` and their bytes (none and 0 when they cannot be listed:
    the fit will say why)."""
    from stickslip_jax.records import RecordError, record_paths

    try:
        paths = list(record_paths(spec))
        return paths, sum(p.stat().st_size for p in paths)
    except (RecordError, OSError):
        return [], 0


def shares(sizes: Sequence[float], n_processes: int) -> list[list[int]]:
    """Indices of the campaigns each of `n_processes` fits: largest first to the least
    loaded process (ties: the lower process, then the earlier campaign), so the shares are
    the same on every process. Each share is in the batch's order."""
    if not (isinstance(n_processes, int) and n_processes >= 1):
        raise ValueError(f"n_processes must be a positive integer, got {n_processes!r}")
    load = [0.0] * n_processes
    out: list[list[int]] = [[] for _ in range(n_processes)]
    for i in sorted(range(len(sizes)), key=lambda i: (-float(sizes[i]), i)):
        p = min(range(n_processes), key=lambda q: (load[q], q))
        out[p].append(i)
        load[p] += max(float(sizes[i]), 1.0)
    return [sorted(s) for s in out]


def exchange(local: dict[int, dict]) -> dict[int, dict]:
    """Every process's `local` results ({campaign index: JSON-ready dict}) on every
    process (module doc); with one process, `local` itself."""
    import jax

    if jax.process_count() == 1:
        return dict(local)
    from jax.experimental import multihost_utils

    blob = np.frombuffer(json.dumps({str(k): v for k, v in local.items()}).encode(),
                         dtype=np.uint8)
    lengths = np.asarray(multihost_utils.process_allgather(np.array([blob.size]))).reshape(-1)
    padded = np.zeros(int(lengths.max()), dtype=np.uint8)
    padded[:blob.size] = blob
    rows = np.asarray(multihost_utils.process_allgather(padded))
    out: dict[int, dict] = {}
    for row, n in zip(rows.reshape(len(lengths), -1), lengths):
        out.update({int(k): v for k, v in json.loads(bytes(row[:int(n)]).decode()).items()})
    return out


def fit_batch(specs: Sequence, fit_one: Callable[[object], dict], *,
              outputs: dict[str, str | None] | None = None,
              progress: Callable[[str], None] | None = None) -> BatchResult:
    """Fit every campaign of `specs` (module doc). `fit_one(spec)` fits one campaign and
    returns {"converged": bool, ...} (JSON-ready: the `stickslip fit --json` report); a
    ValueError it raises marks the campaign FAILED, any other exception ERROR.
    `outputs` ({option: path}, `stickslip_jax.output.check_outputs`) are checked against
    every campaign's files before any campaign is fitted: a clash found in one campaign's
    fit would fail it alone and let the batch write over a record. `progress(line)` gets
    one line per campaign done on this process."""
    import jax

    specs = list(specs)
    if not specs:
        raise ValueError("the batch has no campaigns; give at least one folder or glob")
    names = [campaign_name(s) for s in specs]
    files = [_files(s) for s in specs]
    from stickslip_jax.logs import logger
    from stickslip_jax.output import check_outputs

    check_outputs(outputs or {}, [p for paths, _ in files for p in paths])
    pid, n_proc = jax.process_index(), jax.process_count()
    logger.info(f"fitting {len(specs)} campaigns on {n_proc} process(es)...")
    mine = shares([size for _, size in files], n_proc)[pid]
    start = time.perf_counter()
    local: dict[int, dict] = {}
    for j, i in enumerate(mine):
        t0 = time.perf_counter()
        report, message = None, None
        try:
            report = fit_one(specs[i])
            status = FITTED if report.get("converged", True) else NOT_CONVERGED
        except ValueError as exc:
            status, message = FAILED, str(exc).splitlines()[0] if str(exc) else "ValueError"
        except Exception as exc:  # noqa: BLE001 (one campaign must not stop the batch)
            status, message = ERROR, f"{type(exc).__name__}: {exc}"
        seconds = time.perf_counter() - t0
        local[i] = {"status": status, "report": report, "message": message,
                    "seconds": seconds, "process": pid}
        if progress is not None:
            what = message if message else status.replace("_", " ")
            progress(f"campaign {j + 1}/{len(mine)} of this process ({names[i]}): {what} "
                     f"in {seconds:.1f} s")
    every = exchange(local)
    missing = [names[i] for i in range(len(specs)) if i not in every]
    if missing:  # pragma: no cover (a process left the job early)
        raise RuntimeError(f"no result came back for {', '.join(missing)}")
    entries = tuple(BatchEntry(index=i, name=names[i], spec=specs[i], **every[i])
                    for i in range(len(specs)))
    return BatchResult(entries=entries, processes=n_proc, seconds=time.perf_counter() - start)
