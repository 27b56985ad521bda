r"""What a simulator returns: `Trace` (sampled x(t)), `Cycles` (one row per stick-slip cycle)
and the `SimulationResult` code.

Units: time s, deflection mm, slider velocity mm/s, friction coefficients dimensionless.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int


class SimulationResult(eqx.Enumeration):
    """Outcome of a simulation; anything but `successful` means the trace is not trustworthy."""

    successful = ""
    max_events_reached = (
        "the exact simulator ran out of events (max_events) before the last sample time; "
        "the rest of the trace continues the last phase. Raise max_events.")
    solver_failed = "the ODE solver of the smoothed simulator failed (step budget or step size)"


class Cycles(eqx.Module):
    r"""Per-cycle table of a trace (cycle i = the stick that ends at breakaway i + its slip).

    - `breakaway_time` (s): end of the stick, start of the slip (point B of Fig 6).
    - `peak` (mm): deflection $x_2$ at breakaway; `trough` (mm): $x_1$ when the slip ends.
    - `stick_time` $T_1$ and `slip_time` $T_2$ (s): durations; `slip_time` is the actual
      duration of the slip, `model_slip_time` the $T_2$ put into eq (3).
    - `mu_0` = $\mu_0(T_1)$ (eq 1), `mu_m` (eq 3): friction of the cycle.
    - `restick_failed`: the slip ended with $k x_1 > \mu_0(0) W = \mu_d W$, so the slider
      could not stick and slipped on at once (the next cycle has $T_1 = 0$).
    - `valid`: the cycle is complete (breakaway and slip end inside the simulated time).
      Rows past the last cycle hold zeros and `valid = False`.
    """

    breakaway_time: Float[Array, "... C"]
    peak: Float[Array, "... C"]
    trough: Float[Array, "... C"]
    stick_time: Float[Array, "... C"]
    slip_time: Float[Array, "... C"]
    model_slip_time: Float[Array, "... C"]
    mu_0: Float[Array, "... C"]
    mu_m: Float[Array, "... C"]
    restick_failed: Bool[Array, "... C"]
    valid: Bool[Array, "... C"]

    def amplitude(self) -> Float[Array, "... C"]:
        r"""Half the peak-to-peak swing of each cycle, $(x_2 - x_1)/2$ in mm (eq 5)."""
        return jnp.where(self.valid, 0.5 * (self.peak - self.trough), 0.0)


class Trace(eqx.Module):
    r"""A simulated record: spring deflection x(t) and slider velocity on the sample times.

    - `time` (s), `deflection` x (mm), `slider_velocity` $\dot y$ (mm/s), `sticking`
      (True while the slider rests; for the smoothed simulator: $\dot y$ below the
      smoothing scale), `mask` (False on padding samples of a batch).
    - `cycles`: the per-cycle table (`Cycles`; None where the exact simulator was asked
      for none, `cycle_table=False`); the smoothed simulator estimates it from
      the sampled trace (`valid` only for cycles it resolved).
    - `steady_sliding`: the slider stopped sticking (a slip ended above $\mu_d W/k$ or
      could not end), that is the run is not regular stick-slip.
    - `result`: a `SimulationResult`; `num_events`: events used (exact simulator) or
      solver steps (smoothed simulator).
    """

    time: Float[Array, "... N"]
    deflection: Float[Array, "... N"]
    slider_velocity: Float[Array, "... N"]
    sticking: Bool[Array, "... N"]
    mask: Bool[Array, "... N"]
    cycles: Cycles | None
    steady_sliding: Bool[Array, "..."]
    result: SimulationResult
    num_events: Int[Array, "..."]

    def limit_cycle(self, last: int = 2):
        """Mean amplitude (mm) and stick time (s) of the last `last` valid cycles (NumPy)."""
        valid = np.asarray(self.cycles.valid)
        idx = np.flatnonzero(valid)[-last:]
        amp = np.asarray(self.cycles.amplitude())[idx]
        t1 = np.asarray(self.cycles.stick_time)[idx]
        return float(amp.mean()), float(t1.mean())


def pad_series(times_list, values_list):
    """`pad_times` for records with their values: `(times [B, N], values [B, N],
    mask [B, N])`, each record's values padded with its last value."""
    ts, mask = pad_times(times_list)
    data = np.zeros(ts.shape)
    for i, x in enumerate(values_list):
        x = np.asarray(x, dtype=float)
        data[i, : x.size] = x
        data[i, x.size:] = x[-1]
    return ts, jnp.asarray(data), mask


def pad_times(times_list):
    """Stack sample-time arrays of different lengths for `jax.vmap`.

    Pads each array by repeating its last time (so the simulated horizon is unchanged)
    and returns `(times [B, N], mask [B, N])` with `mask` False on the padding.
    """
    arrays = [np.asarray(t, dtype=float) for t in times_list]
    if not arrays or any(a.ndim != 1 or a.size < 1 for a in arrays):
        raise ValueError("pad_times: give a non-empty list of non-empty 1-D time arrays")
    n = max(a.size for a in arrays)
    out = np.stack([np.concatenate([a, np.full(n - a.size, a[-1])]) for a in arrays])
    mask = np.stack([np.arange(n) < a.size for a in arrays])
    return jnp.asarray(out), jnp.asarray(mask)
