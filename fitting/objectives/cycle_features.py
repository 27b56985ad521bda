r"""Objectives: whitened residual vectors whose sum of squares is $-2\log$ likelihood.

**Features objective** (`feature_residuals`). The measurements of a record are its
stick plateaus (each level averages many samples, standard error $\sigma/\sqrt{N}$) and
its slip times (`data.features`). With the measured stick times $T_{1,j}$, the model
predicts for every complete cycle $j$ (gauge offset $c$):

- breakaway level $L_0(T_1) = c + (W/k)\,\mu_0(T_1)$, eq (1) (section 3.1);
- slip-end level $L_1(T_1) = c + (W/k)\,(2\mu_m - \mu_0)$, eq (5) with eq (3)
  $\mu_m = \mu_d + (\mu_0 - \mu_d)e^{-\delta T_2^n}$ and $T_2 = \pi/\omega_0$ (eq 7,
  `SlipTime.PAPER`) or the actual slip duration
  $\omega_0 T_2 = \pi + 2\arctan(v/(\omega_0 a))$ (`SlipTime.SELF_CONSISTENT`).

Two kinds of residual, each built from independent noise so that no measurement is
counted twice (restart per cycle: nothing accumulates from cycle to cycle):

1. *level*: the plateau after slip $j$, $x_{1,j}$, against the mean of its available
   predictions, $L_1(T_{1,j})$ (end of slip $j$) and $L_0(T_{1,j+1}) - \Delta u_{j+1}$
   (the breakaway of cycle $j+1$ minus the drive travel during that stick); divided by the
   plateau's standard error combined with the timing errors of the slips (which move
   $u(t_e)$ and the predicted levels through $T_1$).
2. *stick* (eq 6 cycle by cycle): the stick climbs from $x_{1,j}$ to $x_{2,j+1}$ with the
   drive, $L_0(T_{1,j+1}) - L_1(T_{1,j}) = \Delta u_{j+1}$; divided by the propagated
   timing error of the stick times ("effective variance" weights, held fixed in the
   derivative).

With `offset_from_start`, a record that starts with the spring relaxed adds the residual
(deflection at the first sample - c) / its standard error, which pins the gauge offset.

Units: levels in mm, times in s, W and N in kgf, k in kgf/mm.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from stickslip_jax.modes import SlipTime
from stickslip_jax.steady import slip_from_rest

from ..data.features import RecordFeatures
from ..modes import check_member
from ..params import CampaignParams

__all__ = ["FeatureData", "feature_data", "feature_residuals"]


class FeatureData(eqx.Module):
    """Cycle features of a campaign as padded arrays [R records, C cycles] (mm, s)."""

    weight: Float[Array, " R"]
    normal_load: Float[Array, " R"]
    """N in kgf, the load the friction coefficients multiply (W unless a record gives it)."""
    stiffness: Float[Array, " R"]
    omega0: Float[Array, " R"]
    t1: Float[Array, "R C"]
    t1_next: Float[Array, "R C"]
    t1_sd: Float[Array, "R C"]
    t1_next_sd: Float[Array, "R C"]
    trough: Float[Array, "R C"]
    trough_sd: Float[Array, "R C"]
    climb_next: Float[Array, "R C"]
    has_end: Bool[Array, "R C"]
    has_next: Bool[Array, "R C"]
    start_level: Float[Array, " R"]
    start_sd: Float[Array, " R"]
    use_start: Bool[Array, " R"]
    trough_shift: Float[Array, "R C"]
    """The trough of a slip symmetric about its centre less the measured one (mm; a drive
    whose speed changes during the slip, `RecordFeatures.trough_shift`; 0 under a steady
    drive)."""
    reslip: bool = eqx.field(static=True, default=True)
    """Model re-slips (`_levels`); False leaves that part out of the compiled program."""

    @property
    def n_records(self) -> int:
        return int(self.weight.shape[0])

    def n_residuals(self) -> int:
        """Number of residuals that carry data (the rest of the padded vector is zero)."""
        end, nxt = np.asarray(self.has_end), np.asarray(self.has_next)
        return int((end | nxt).sum() + (end & nxt).sum() + np.asarray(self.use_start).sum())


def feature_data(
    features: list[RecordFeatures], *, offset_from_start: bool = False, pad_cycles: int = 0,
    reslip: bool | None = None) -> FeatureData:
    """Stack the features of a campaign's records (see `FeatureData`).

    `pad_cycles`: pad the cycle axis to at least this length (one compilation for
    campaigns of different lengths). `reslip`: model re-slips; None: when at least half
    the slips of some record are measured as re-slips (`RecordFeatures.slipped_on`: a
    steady limit cycle re-slips every cycle or never, while noise flags the odd small
    fast slip; of 30 prior draws of the calibration the 3 that need the model are found,
    with one false positive). Without them the program is a third smaller (about 0.6 s
    less compilation on benchmarks/fit.py). ValueError for a record without usable
    stick-slip.
    """
    bad = [f"{f.name} ({f.message})" for f in features if not f.stick_slip]
    if bad:
        raise ValueError("records without usable stick-slip: " + "; ".join(bad))
    C = max(max(len(f.peak) for f in features), int(pad_cycles))
    C = -(-C // 8) * 8  # bucket to a multiple of 8: similar campaigns share one compilation
    R = len(features)

    def arr(fill=0.0, dtype=float):
        return np.full((R, C), fill, dtype=dtype)

    t1, t1n, t1sd, t1nsd = arr(1.0), arr(1.0), arr(1.0), arr(1.0)
    tr, trsd, climb, shift = arr(), arr(1.0), arr(), arr()
    has_end, has_next = arr(False, bool), arr(False, bool)
    start, start_sd, use_start = np.zeros(R), np.ones(R), np.zeros(R, bool)
    for r, f in enumerate(features):
        c = len(f.peak)
        comp = np.asarray(f.complete, bool)
        t1[r, :c] = np.where(comp, f.stick_time, 1.0)
        t1sd[r, :c] = np.where(comp, f.stick_time_sd, 1.0)
        has_end[r, :c] = comp
        tr[r, :c] = f.trough
        trsd[r, :c] = f.trough_sd
        shift[r, :c] = 0.0 if f.trough_shift is None else f.trough_shift
        nxt = np.zeros(c, bool)
        nxt[:-1] = comp[1:]
        has_next[r, :c] = nxt
        t1n[r, : c - 1] = np.where(comp[1:], f.stick_time[1:], 1.0)
        t1nsd[r, : c - 1] = np.where(comp[1:], f.stick_time_sd[1:], 1.0)
        climb[r, : c - 1] = f.peak[1:] - f.trough[:-1]
        if offset_from_start:
            if not math.isfinite(f.start_level):
                raise ValueError(
                    f"{f.name}: the record does not start in a stick, so its gauge offset "
                    "cannot be read from the first sample; drop --offset start")
            start[r], start_sd[r], use_start[r] = f.start_level, f.start_level_sd, True
    def j(x):  # device_put: jnp.asarray would compile a small program per shape
        return jax.device_put(np.asarray(x))

    return FeatureData(
        weight=j([f.weight for f in features]), normal_load=j([f.load for f in features]),
        stiffness=j([f.stiffness for f in features]),
        omega0=j([f.omega0 for f in features]),
        t1=j(t1), t1_next=j(t1n), t1_sd=j(t1sd), t1_next_sd=j(t1nsd), trough=j(tr),
        trough_sd=j(trsd), climb_next=j(climb), has_end=j(has_end), has_next=j(has_next),
        start_level=j(start), start_sd=j(start_sd), use_start=j(use_start),
        trough_shift=j(shift),
        reslip=(any(np.mean(f.slipped_on) >= 0.5 for f in features) if reslip is None
                else bool(reslip)))


SHIFT_ITERATIONS = 1
"""Iterations of the timing refinement of `stickslip_fitting.data.features` mirrored by `_reslip_shift`
(1, 2 and 8 agree to 3e-7 mm in the levels; each costs compilation)."""


def _centre_fit_gain() -> float:
    r"""$1 + \langle u^2\rangle/2$: how far the features' weighted centre fit moves past
    the crossing of an offset centre level (`_reslip_shift`).

    Near the centre, $u = \omega_0 (t - t_c)$, a level offset $d$ (in units of the
    radius) makes the arcsin estimate of the centre $-d + \sin\phi_c\,u^2/2 + O(u)$ odd
    terms; the weighted mean over the fit's window with weight
    $1 - s^2 \approx \cos^2 u$, $|s| < 0.75$, i.e. $|u| < \arcsin 0.75$, sets
    $\sin\phi_c = -d\,(1 + \langle u^2\rangle/2)$. Closed form of that mean."""
    a = math.asin(0.75)
    num = a**3 / 6.0 + (a * a / 4.0 - 0.125) * math.sin(2.0 * a) + a * math.cos(2.0 * a) / 4.0
    den = a / 2.0 + math.sin(2.0 * a) / 4.0
    return 1.0 + 0.5 * num / den


_CENTRE_FIT_GAIN = _centre_fit_gain()


def _reslip_shift(omega0, v, x2, c, x1_end, t2r):
    r"""Where `stickslip_fitting.data.features` times a slip with a re-slip (s, from the true breakaway).

    The features take every slip for one half cosine symmetric about its centre $t_c$
    (eq 11 with the drive) and refine $t_c$ by fitting
    $x = (x_2 + x_1)/2 - R\sin\omega_0(t - t_c)$ near the centre, with $x_1$ measured at
    $t_e = t_c + T_2/2$ on the stick line after the jump. After a re-slip that $x_1$ is
    the level after both slips, below the first slip's end $2c - x_2$, so the assumed
    centre level is too low and $t_c$, $t_b$, $t_e$ all come out late (by about 0.7 ms at
    1 kHz for a 14 ms slip). The centre fit, symmetric about its estimate, converges
    near where the exact first slip $x = c - R\sin\omega_0(t - t_m)$,
    $R^2 = (x_2 - c)^2 + (v/\omega_0)^2$, crosses the assumed centre level
    $(x_2 + x_1)/2$, a little past it (`_centre_fit_gain`); this mirrors that fixed point
    `SHIFT_ITERATIONS` times. Noise-free level error left at 1 kHz: 2.0e-6 mm (the
    crossing alone 3.8e-6, a 33-point quadrature of the weighted fit 1.4e-6 mm but 30x
    the cost of the whole features objective; no shift 1.9e-5 mm). Inputs: $\omega_0$ (1/s), v (mm/s),
    breakaway level $x_2$ and kinetic level $c = \mu_m W/k$ (mm), the level $x_1'$
    after the re-slip (mm) and the re-slip's duration $T_2'$ (s). Returns the measured
    breakaway time $t_b$ and the measured end minus the first slip's true end (both s;
    0 for a single slip)."""
    a = jnp.maximum(x2 - c, 1e-12)
    t2a = (jnp.pi + 2.0 * jnp.arctan(v / (omega0 * a))) / omega0
    radius = jnp.sqrt(a**2 + (v / omega0) ** 2)
    centre = 0.5 * t2a
    t_c, slip = centre, jnp.pi / omega0 + jnp.zeros_like(t2a)
    for _ in range(SHIFT_ITERATIONS):
        t_b, t_e = t_c - 0.5 * slip, t_c + 0.5 * slip
        x2_m = x2 + v * t_b
        x1_m = x1_end - v * (t2a + t2r - t_e)
        amp = jnp.maximum(0.5 * (x2_m - x1_m), 1e-12)
        slip = (jnp.pi + 2.0 * jnp.arctan(v / (omega0 * amp))) / omega0
        low = jnp.clip(_CENTRE_FIT_GAIN * (0.5 * (x2_m + x1_m) - c) / radius, -0.75, 0.75)
        t_c = centre - jnp.arcsin(low) / omega0
    return t_c - 0.5 * slip, t_c + 0.5 * slip - t2a


def _levels(friction, scale, offset, omega0, t1, climb_hint, slip_time, speed=None):
    r"""L0, L1 (mm) at stick time t1 for one record (eqs 1, 3, 5, 7), with re-slip.

    `t1` is the measured stick time (from the end of the previous slip's first half
    cosine to the breakaway) and L1 the slip-end level as `stickslip_fitting.data.features` measures
    it (the stick line after the slip extrapolated back to that end). A slip that ends
    above the zero-stick breakaway level, $k x_1 > \mu_0(0) W = \mu_d W$, cannot
    restick: the slider slips on from rest with $\mu_d$ (as `simulate_exact` does) for
    $\omega_0 T_2' = 2\pi - 2\arctan(\omega_0 e / v)$, $e = x_1 - \mu_d W/k$, and ends at
    $x_1' = 2\mu_d W/k - x_1$. The measured level is then $x_1' - v (T_2' - \Delta_e)$ and
    the measured breakaway level $x_2 + v \Delta_b$, with $\Delta_b$, $\Delta_e$ the late
    timing of such a double slip by the features (`_reslip_shift`); the true stick time
    is $T_1 - T_2'$ (the re-slip of the previous cycle of the same limit cycle, solved by
    a short fixed-point iteration; the timing shifts change it by under 1e-4 relative
    and are left out there). `speed`: drive speed v (mm/s; None: no re-slip modelled)."""

    def single(t):
        mu0 = friction.static(t)
        t2 = jnp.pi / omega0
        if slip_time == SlipTime.SELF_CONSISTENT:
            speed_sc = climb_hint / t
            for _ in range(4):
                mum = friction.kinetic(mu0, friction.mu_d, t2)
                amp = jnp.maximum((mu0 - mum) * scale, 1e-12)
                t2 = (jnp.pi + 2.0 * jnp.arctan(speed_sc / (omega0 * amp))) / omega0
        mum = friction.kinetic(mu0, friction.mu_d, t2)
        return mu0, mum

    mu0, mum = single(t1)
    if speed is None:
        return offset + scale * mu0, offset + scale * (2.0 * mum - mu0)

    def reslip(mu0, mum):
        e = scale * (2.0 * mum - mu0 - friction.mu_d)  # first slip's end above mu_d W/k
        on = e > 0
        t2r = slip_from_rest(jnp.where(on, e, 0.0), speed, omega0)
        return on, e, jnp.where(on, t2r, 0.0)

    for _ in range(3):
        _, _, t2r = reslip(mu0, mum)
        mu0, mum = single(jnp.maximum(t1 - t2r, 0.5 * t1))
    on, e, t2r = reslip(mu0, mum)
    l1_first = offset + scale * (2.0 * mum - mu0)
    x1_end = l1_first - 2.0 * e
    late_b, late_e = _reslip_shift(omega0, speed, offset + scale * mu0, offset + scale * mum,
                                   x1_end, t2r)
    l0 = offset + scale * mu0 + jnp.where(on, speed * late_b, 0.0)
    l1 = jnp.where(on, x1_end - speed * (t2r - late_e), l1_first)
    return l0, l1


def feature_residuals(
    params: CampaignParams, data: FeatureData, slip_time: SlipTime = SlipTime.PAPER,
    weights_at: CampaignParams | None = None) -> Float[Array, " N"]:
    """Whitened residuals of the features objective (module doc), shape (2 R C + R,)
    fixed by the data; padded entries are 0. `slip_time`: the $T_2$ of eq (3).
    `weights_at`: evaluate the effective-variance standard errors at these parameters
    (the fit freezes them for one Levenberg-Marquardt run, so that its Jacobian is the
    exact derivative of what it minimises).
    """
    check_member("slip_time", slip_time, SlipTime)
    ref = params if weights_at is None else weights_at
    friction, friction_ref = params.friction.friction(), ref.friction.friction()
    scale = data.normal_load / data.stiffness

    # drive speed of each record (climb over stick time, eq 6), for the re-slip
    speeds = (jnp.sum(jnp.where(data.has_next, data.climb_next, 0.0), axis=1)
              / jnp.maximum(jnp.sum(jnp.where(data.has_next, data.t1_next, 0.0), axis=1), 1e-300))

    def one(scale, offset, omega0, v, t1, t1n, t1sd, t1nsd, x1, x1sd, climb, he, hn, shift):
        def lv(fr, t):
            return _levels(fr, scale, offset, omega0, t, climb, slip_time,
                           speed=v if data.reslip else None)

        def slope(t):  # d(L0, L1)/dT1 at the weights' parameters
            return jax.jvp(lambda t: lv(friction_ref, t), (t,), (jnp.ones_like(t),))[1]

        # both stick times in one evaluation (half the program to trace and compile)
        both = jnp.stack([t1, t1n])
        (_, l0n), (l1, _) = lv(friction, both)
        l1 = l1 - shift  # the trough of the slip under the measured drive
        (_, dl0n), (dl1, _) = slope(both)
        pred_end = jnp.where(he, l1, 0.0)
        pred_next = jnp.where(hn, l0n - climb, 0.0)
        count = he.astype(float) + hn.astype(float)
        pred = (pred_end + pred_next) / jnp.maximum(count, 1.0)
        speed = climb / t1n
        # timing errors move x1 = u(t_e) - Y by v sd(t_e) and the predictions through T1
        var_pred = (jnp.where(he, (dl1 * t1sd) ** 2, 0.0)
                    + jnp.where(hn, ((dl0n - speed) * t1nsd) ** 2, 0.0)) / jnp.maximum(count, 1.0) ** 2
        level_sd = jnp.sqrt(x1sd**2 + 0.5 * (speed * t1nsd) ** 2 + var_pred)
        level_sd = jax.lax.stop_gradient(level_sd)
        level = jnp.where(count > 0, (x1 - pred) / level_sd, 0.0)
        sd = jnp.sqrt(((dl0n - speed) * t1nsd) ** 2 + (dl1 * t1sd) ** 2)
        sd = jax.lax.stop_gradient(jnp.maximum(sd, 1e-12))
        stick = jnp.where(he & hn, (l0n - l1 - climb) / sd, 0.0)
        return level, stick

    args = (data.t1, data.t1_next, data.t1_sd, data.t1_next_sd, data.trough, data.trough_sd,
            data.climb_next, data.has_end, data.has_next, data.trough_shift)
    per_cycle = jax.vmap(one, in_axes=(None, None, None, None) + (0,) * 10)
    level, stick = jax.vmap(per_cycle)(scale, params.offset, data.omega0, speeds, *args)
    start = jnp.where(data.use_start, (data.start_level - params.offset) / data.start_sd, 0.0)
    return jnp.concatenate([level.ravel(), stick.ravel(), start])
