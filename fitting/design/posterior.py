r"""Friction-parameter samples: eq (1) + eq (3) parameters as a batched `Friction`.

A sample is a `Friction(KatoStatic(...), KatoKinetic(...))` whose six leaves are arrays
of draws (shape ``(S,)``). Files read by `load_samples`:

- CSV with a header naming the columns ``mu_s, mu_d, gamma, m, delta, n`` (any order,
  other columns ignored, ``#`` comment lines allowed), one draw per row;
- JSON, any of
  ``{"samples": {"mu_s": [...], ..., "n": [...]}}`` (columns),
  ``{"samples": [{"mu_s": ..., ...}, ...]}`` (rows),
  ``{"parameters": ["mu_s", ...], "samples": [[...], ...]}`` (a matrix, one draw per row;
  ``"names"`` for ``"parameters"``: `stickslip mcmc --json`), or the same without the
  ``"samples"`` wrapper or under ``"posterior"``; parameters held fixed come from an
  optional ``"fixed": {"delta": 67, "n": 1}`` object next to the samples.

`plan_sources` reads the estimate and prior of `stickslip plan` from such a sample, a
posterior summary, a prior JSON or a lubricant name, with the records already measured.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from collections.abc import Mapping
from pathlib import Path

import jax
import numpy as np

from stickslip_jax import Friction, KatoKinetic, KatoStatic

from ..params import NAMES as PARAMETERS
from ..params import EmpiricalFriction
from .campaign import Campaign


def log_params(friction: Friction) -> np.ndarray:
    """$u = \\log$ of the six eq (1) + eq (3) parameters, in the order of `PARAMETERS`."""
    return np.asarray(EmpiricalFriction.from_friction(friction).log_values())


def friction_from_params(params: Mapping[str, object]) -> Friction:
    """`Friction` of eq (1) + eq (3) from a mapping with the six `PARAMETERS` (arrays allowed)."""
    missing = [p for p in PARAMETERS if p not in params]
    if missing:
        raise ValueError(f"friction parameters missing: {', '.join(missing)} (need {PARAMETERS})")
    g = {p: np.asarray(params[p], dtype=float) for p in PARAMETERS}
    f = Friction(KatoStatic(mu_s=g["mu_s"], mu_d=g["mu_d"], gamma=g["gamma"], m=g["m"]),
                 KatoKinetic(delta=g["delta"], n=g["n"]))
    return jax.tree_util.tree_map(np.asarray, f)


def friction_params(friction: Friction) -> dict[str, np.ndarray]:
    """The six eq (1) + eq (3) parameters of a Kato `Friction`, as NumPy arrays."""
    if not isinstance(friction.static, KatoStatic) or not isinstance(friction.kinetic, KatoKinetic):
        raise ValueError("friction must use KatoStatic (eq 1) and KatoKinetic (eq 3)")
    s, k = friction.static, friction.kinetic
    vals = (s.mu_s, s.mu_d, s.gamma, s.m, k.delta, k.n)
    return {p: np.asarray(v) for p, v in zip(PARAMETERS, vals)}


def sample_size(sample: Friction) -> int:
    """Number of draws S of a sample (leaves of shape (S,))."""
    shapes = {np.shape(x) for x in jax.tree_util.tree_leaves(sample)}
    if len(shapes) != 1 or len(next(iter(shapes))) != 1:
        raise ValueError(f"a sample needs every parameter of shape (S,), got {sorted(shapes)}")
    return next(iter(shapes))[0]


def _from_columns(cols: Mapping[str, object], source: str, fixed=None) -> Friction:
    cols = {p: _numbers(v, f"{source}: {p}") for p, v in cols.items() if p in PARAMETERS}
    for p, value in (fixed or {}).items():
        if p in PARAMETERS and p not in cols:
            value = _numbers(value, f"{source}: 'fixed' {p}")
            if value.size != 1:
                raise ValueError(f"{source}: 'fixed' {p} must be one number, got {value.size}")
            sizes = [a.size for a in cols.values()]
            cols[p] = np.full(sizes[0] if sizes else 1, value[0])
    missing = [p for p in PARAMETERS if p not in cols]
    if missing:
        raise ValueError(f"{source}: sample lacks column(s) {', '.join(missing)}; need {PARAMETERS}")
    arrays = {p: cols[p] for p in PARAMETERS}
    sizes = {a.shape for a in arrays.values()}
    if len(sizes) != 1 or len(next(iter(sizes))) != 1 or next(iter(sizes))[0] == 0:
        raise ValueError(f"{source}: every parameter needs the same number (>0) of draws")
    for p, a in arrays.items():
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{source}: column {p} has non-finite draws")
    check_domain(arrays, source)
    return friction_from_params(arrays)


def _numbers(value, what: str) -> np.ndarray:
    """`value` as a 1-D float array; a ValueError naming `what` for null, text or ragged
    lists."""
    if value is None:
        raise ValueError(f"{what}: null, not a number; give its value")
    try:
        out = np.atleast_1d(np.asarray(value, dtype=float))
    except (TypeError, ValueError):
        raise ValueError(f"{what}: expected numbers, got {str(value)[:60]}; write every draw "
                         "as a number") from None
    if out.ndim != 1:
        raise ValueError(f"{what}: expected a list of numbers, got shape {out.shape}")
    return out


def check_domain(values: Mapping[str, np.ndarray], source: str) -> None:
    """ValueError unless every draw lies in the model's domain: every parameter positive
    and mu_s > mu_d (eqs 1, 3). Names how many draws fail which condition."""
    arrays = {p: np.atleast_1d(np.asarray(values[p], float)) for p in PARAMETERS}
    n = arrays["mu_s"].size
    bad = np.zeros(n, bool)
    parts = []
    for p in PARAMETERS:
        neg = arrays[p] <= 0
        if neg.any():
            parts.append(f"{p} <= 0 in {int(neg.sum())}")
            bad |= neg
    order = arrays["mu_s"] <= arrays["mu_d"]
    if order.any():
        parts.append(f"mu_s <= mu_d in {int(order.sum())}")
        bad |= order
    if parts:
        raise ValueError(f"{source}: {int(bad.sum())} of {n} draws lie outside the model's "
                         f"domain ({'; '.join(parts)}): every parameter must be positive and "
                         "mu_s > mu_d")


def summary_from_json(obj) -> dict[str, tuple[float, float]] | None:
    """``{name: (median, sd)}`` from a posterior *summary* such as `stickslip mcmc --json`
    writes (``{"parameters": {"mu_s": {"median": .., "sd": ..}, ...}}``), else None."""
    params = obj.get("parameters") if isinstance(obj, Mapping) else None
    if not isinstance(params, Mapping) or not params:
        return None
    if not all(isinstance(v, Mapping) and "median" in v and "sd" in v for v in params.values()):
        return None
    return {str(k): (float(v["median"]), float(v["sd"])) for k, v in params.items()}


def samples_from_json(obj, source: str = "JSON", fixed=None) -> Friction:
    """A sample from a parsed JSON object in one of the layouts of the module docstring
    (`fixed`: the values of parameters held fixed, where the object does not say)."""
    if isinstance(obj, Mapping) and "samples" not in obj and summary_from_json(obj):
        raise ValueError(
            f"{source}: a posterior summary (median, sd per parameter) without draws; "
            "propagation needs the draws (a 'samples' matrix, see stickslip_fitting.design.posterior); "
            "`stickslip plan` accepts this summary as a prior")
    if isinstance(obj, Mapping):
        fixed = obj.get("fixed", fixed)
        if fixed is not None and not isinstance(fixed, Mapping):
            raise ValueError(f"{source}: 'fixed' must be an object of parameter values")
        names = obj.get("parameters", obj.get("names"))
        for key in ("samples", "posterior", "draws"):
            if key in obj:
                inner = obj[key]
                if isinstance(inner, Mapping) or names is None:
                    return samples_from_json(inner, source, fixed)
                names = list(names)
                try:
                    mat = np.asarray(inner, dtype=float)
                except (TypeError, ValueError):
                    mat = np.empty(0)  # null, text, or rows of different lengths
                if mat.ndim != 2 or mat.shape[1] != len(names):
                    raise ValueError(f"{source}: samples must be a (draws, {len(names)}) matrix")
                return _from_columns({n: mat[:, i] for i, n in enumerate(names)}, source, fixed)
        return _from_columns({k: v for k, v in obj.items() if k in PARAMETERS}, source, fixed)
    if isinstance(obj, list) and obj and isinstance(obj[0], Mapping):
        return _from_columns({p: [row[p] for row in obj if p in row] for p in PARAMETERS
                              if any(p in row for row in obj)}, source, fixed)
    raise ValueError(f"{source}: not a sample (see stickslip_fitting.design.posterior for the layouts)")


def samples_from_csv(text: str, source: str = "CSV") -> Friction:
    """A sample from CSV text with a header row naming the parameters."""
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    reader = csv.DictReader(io.StringIO("\n".join(lines)))
    if reader.fieldnames is None:
        raise ValueError(f"{source}: empty CSV")
    names = [f.strip() for f in reader.fieldnames]
    rows = [[row[f] for f in reader.fieldnames] for row in reader]
    try:
        mat = np.asarray(rows, dtype=float).reshape(len(rows), len(names))
    except ValueError as exc:
        raise ValueError(f"{source}: non-numeric entry ({exc})") from None
    return _from_columns({n: mat[:, i] for i, n in enumerate(names)}, source)


def load_samples(path) -> Friction:
    """Read a posterior sample (CSV or JSON, see the module docstring) as a batched Friction."""
    path = Path(path)
    text = path.read_text()
    if path.suffix.lower() == ".json" or text.lstrip().startswith(("{", "[")):
        return samples_from_json(_json(text, path), str(path))
    return samples_from_csv(text, str(path))


def _json(text: str, path):
    """The JSON document `text` of the file `path`; a ValueError naming the file."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: invalid JSON ({exc})") from None


def save_samples(sample: Friction, path) -> None:
    """Write a sample as CSV (columns `PARAMETERS`)."""
    params = friction_params(sample)
    mat = np.column_stack([np.atleast_1d(params[p]) for p in PARAMETERS])
    np.savetxt(path, mat, delimiter=",", header=",".join(PARAMETERS), comments="", fmt="%.17g")


def _number(value, source, key: str) -> float:
    """A JSON value as a finite float, or a ValueError naming the file and the key."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if isinstance(value, bool) or not math.isfinite(x):
        raise ValueError(f"{source}: {key} is {json.dumps(value)[:40]}; give a finite number")
    return x


def _estimate(values: dict, source, key: str) -> np.ndarray:
    """The parameters of `values` (prior means, posterior medians) as a vector, each a
    number inside the law's physical range (its MCMC prior support): the design's
    estimate; a ValueError naming the file, key and range otherwise."""
    missing = [p for p in PARAMETERS if p not in values]
    if missing:
        raise ValueError(f"{source}: {key} lacks {', '.join(missing)} (held fixed in the "
                         "fit?); write a prior JSON with all six")
    out = np.array([_number(values[p], source, f"{key} {p}") for p in PARAMETERS])
    for p, v in zip(PARAMETERS, out):
        lo, hi = EmpiricalFriction.PRIOR_BOUNDS[p]
        if not lo <= v <= hi:
            raise ValueError(f"{source}: {key} {p} = {v:.4g} lies outside the physical "
                             f"range {lo:g}-{hi:g} of {p}; a design at such an estimate "
                             "means nothing: give an estimate inside the range")
    return out


def _sd_vector(sd, source) -> np.ndarray:
    """A prior's 'sd' (one number, or one per parameter) as a vector in `PARAMETERS` order."""
    if isinstance(sd, (int, float)) and not isinstance(sd, bool):
        return np.full(len(PARAMETERS), _number(sd, source, "prior 'sd'"))
    if isinstance(sd, dict):
        missing = [p for p in PARAMETERS if p not in sd]
        if missing:
            raise ValueError(f"{source}: prior 'sd' lacks {', '.join(missing)}")
        return np.array([_number(sd[p], source, f"prior 'sd' {p}") for p in PARAMETERS])
    raise ValueError(f"{source}: prior 'sd' must be a number or an object by parameter")


def plan_sources(sources, table: int = 6, prior_sd: float = 0.5):
    """(estimate u, prior sd of u, existing `Campaign` or None, description)
    of `stickslip plan`'s sources (its RECORDS-OR-PRIOR, named in the errors): a
    lubricant name of Table `table`, a posterior summary, a prior JSON or a posterior
    sample, and record files already measured; `prior_sd` where the source gives none."""
    from stickslip_jax.lubricants import lubricant, lubricants

    estimate = sd = None
    desc = []
    records = []
    for src in sources:
        path = Path(src)
        if not path.exists():
            if src in lubricants(table):
                if estimate is not None:
                    raise ValueError("RECORDS-OR-PRIOR: give only one lubricant, prior or sample")
                estimate = log_params(lubricant(src, table=table))
                desc.append(f"lubricant {src} (Table {table})")
                continue
            raise ValueError(f"RECORDS-OR-PRIOR: {src!r} is neither a file nor a lubricant "
                             f"({', '.join(lubricants(table))})")
        if not path.is_file():
            raise ValueError(f"RECORDS-OR-PRIOR: {src} is not a regular file (a folder, a "
                             "named pipe or a device); give a record, prior or sample file")
        head = path.read_text(errors="replace")[:200].lstrip()
        if head.startswith("# stickslip-record"):
            from stickslip_jax.records import read_record

            if any(os.path.samefile(path, r.source) for r in records):
                raise ValueError(f"RECORDS-OR-PRIOR: {src} is named twice; give each "
                                 "record once")
            records.append(read_record(path))
            continue
        if estimate is not None:
            raise ValueError("RECORDS-OR-PRIOR: give only one lubricant, prior or sample")
        obj = _json(path.read_text(), path) if path.suffix.lower() == ".json" else None
        summary = summary_from_json(obj) if obj is not None else None
        if summary is not None and "samples" not in obj:
            med = _estimate({p: v[0] for p, v in summary.items()}, path,
                            "the posterior summary's median")
            check_domain(dict(zip(PARAMETERS, med)), f"{path} (posterior medians)")
            estimate = np.log(med)
            # sd of log(parameter) ~ sd / median (a relative error)
            sd = np.maximum(np.array([_number(summary[p][1], path, f"sd {p}")
                                      for p in PARAMETERS]) / med, 1e-6)
            desc.append(f"posterior summary {path.name}")
        elif isinstance(obj, dict) and "mean" in obj:
            if not isinstance(obj["mean"], dict):
                raise ValueError(f"{path}: prior 'mean' must be an object by parameter")
            vals = _estimate(obj["mean"], path, "prior 'mean'")
            check_domain(dict(zip(PARAMETERS, vals)), f"{path} (prior means)")
            estimate = np.log(vals)
            if "sd" in obj:
                sd = _sd_vector(obj["sd"], path)
            desc.append(f"prior {path.name}")
        else:
            try:
                p = friction_params(load_samples(path))
                logs = np.log(np.column_stack([np.asarray(p[k], float) for k in PARAMETERS]))
            except (TypeError, ValueError, KeyError) as exc:
                if str(exc).startswith(str(path)):
                    raise
                raise ValueError(f"{path}: not a posterior sample of {', '.join(PARAMETERS)} "
                                 f"with one number per draw ({str(exc)[:80]})") from None
            estimate = logs.mean(axis=0)
            sd = logs.std(axis=0, ddof=1) if logs.shape[0] > 1 else None
            desc.append(f"posterior sample {path.name} ({logs.shape[0]} draws)")
    if estimate is None:
        raise ValueError("RECORDS-OR-PRIOR: give a lubricant name, a prior JSON or a "
                         "posterior sample for the parameter estimate (records alone are not enough)")
    if sd is None:
        if not prior_sd > 0:
            raise ValueError("--prior-sd: must be positive")
        sd = np.full(len(PARAMETERS), prior_sd)
    if not np.all(np.isfinite(sd) & (sd > 0)):
        raise ValueError("prior sd must be finite and positive for every parameter")
    existing = None
    if records:
        from stickslip_jax.records.campaign import count_once

        records = count_once(records)  # the same run under two names counts once
        existing = Campaign(np.array([r.weight for r in records]),
                            np.array([r.stiffness for r in records]),
                            np.array([r.nominal_drive_speed for r in records]))
        desc.append(f"{len(records)} existing record(s)")
    return estimate, sd, existing, "; ".join(desc)
