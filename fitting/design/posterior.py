r"""Friction-parameter samples: eq (1) + eq (3) parameters as a batched `Friction`.

A sample is a `Friction(KatoStatic(mu_s, mu_d, gamma, m), KatoKinetic(delta, n))` whose
six leaves are arrays of draws (shape ``(S,)``): gamma in s^-m, delta in s^-n, the
rest dimensionless. Files read by `load_samples`:

- CSV with a header naming the columns ``mu_s, mu_d, gamma, m, delta, n`` (any order,
  other columns ignored, ``#`` comment lines allowed), one draw per row;
- JSON, any of
  ``{"samples": {"mu_s": [...], ..., "n": [...]}}`` (columns),
  ``{"samples": [{"mu_s": ..., ...}, ...]}`` (rows),
  ``{"parameters": ["mu_s", ...], "samples": [[...], ...]}`` (a matrix, one draw per row;
  ``"names"`` is accepted for ``"parameters"``, the layout of `stickslip_fitting.uncertainty.mcmc.McmcResult`),
  or the same objects without the ``"samples"`` wrapper / under ``"posterior"``.
  Parameters that were held fixed (not sampled) come from an optional
  ``"fixed": {"delta": 67, "n": 1}`` object next to the samples.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Mapping
from pathlib import Path

import jax
import numpy as np

from stickslip_jax import Friction, KatoKinetic, KatoStatic

PARAMETERS = ("mu_s", "mu_d", "gamma", "m", "delta", "n")


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


def samples_from_json(obj, source: str = "JSON") -> Friction:
    """A sample from a parsed JSON object in one of the layouts of the module docstring."""
    return _from_json(obj, source, None)


def summary_from_json(obj) -> dict[str, tuple[float, float]] | None:
    """``{name: (median, sd)}`` from a posterior *summary* such as `stickslip mcmc --json`
    writes (``{"parameters": {"mu_s": {"median": .., "sd": ..}, ...}}``), else None."""
    params = obj.get("parameters") if isinstance(obj, Mapping) else None
    if not isinstance(params, Mapping) or not params:
        return None
    if not all(isinstance(v, Mapping) and "median" in v and "sd" in v for v in params.values()):
        return None
    return {str(k): (float(v["median"]), float(v["sd"])) for k, v in params.items()}


def _from_json(obj, source, fixed):
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
                    return _from_json(inner, source, fixed)
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
        try:
            obj = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path}: invalid JSON ({exc})") from None
        return samples_from_json(obj, str(path))
    return samples_from_csv(text, str(path))


def save_samples(sample: Friction, path) -> None:
    """Write a sample as CSV (columns `PARAMETERS`)."""
    params = friction_params(sample)
    mat = np.column_stack([np.atleast_1d(params[p]) for p in PARAMETERS])
    np.savetxt(path, mat, delimiter=",", header=",".join(PARAMETERS), comments="", fmt="%.17g")
