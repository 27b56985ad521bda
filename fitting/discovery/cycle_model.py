r"""The per-cycle model with effects: the discovery base (`cycle_workflow`).

Same windows as the trace objective (`stickslip_fitting.objectives.trace`): cycle $j$ of a record
runs from the measured end of slip $j-1$ to the measured end of slip $j$, the slider at
rest at the measured slip-end level. Nothing accumulates from cycle to cycle, so a long
record's slips cannot drift away from the data. With every effect at zero this is the
paper's model (chapters 2-5) and equals `trace_objective.trace_simulation` (tested);
the effects of `cycle_effects` enter as parts of it:

- **stick** (closed form): the deflection follows the drive,
  $x(t) = x_0 + u(t) - u(t_0)$, with the drive $u$ of the drive effects (screw error,
  speed drift); breakaway where $k x = N \mu_0(T_1)$ (eq 1) with $N = N_0 + \kappa k x$
  ($N_0$ the record's normal load, W unless it gives one; load coupling $\kappa$) and
  $\mu_s$, $\mu_d$ shifted by friction drift; found by a bracketed
  Newton iteration whose last step carries the derivative (implicit function theorem);
- **slip** (RK4, fixed step, `N_STEPS` over 2.5 $\pi/\omega_0$):
  $m\ddot y = k x - N(\mu_m + b_S s(\dot y/v_s) + a \ln(1 + \dot y/V_\mathrm{ref})
  + b \ln(\theta/\theta_b)) - c\dot y$ with the Dieterich-Ruina state $\theta$ (aging
  law $\dot\theta = 1 - \dot y\theta/D_c$, $\theta_b = T_1 + D_c/V_\mathrm{ref}$ at the
  breakaway, `DR_V_REF`) and the Stribeck curve $s(w) = e^{-w^p}$, $-\ln(1 + w)$ or $-w$,
  $x = x_b + \dot u(t_b)(t - t_b) - y$, $\mu_m$ from eq (3) with $T_2 = \pi/\omega_0$ (eq 7);
  the slider stops where $\dot y$ first returns to 0 (interpolated), and sticks again;
- **measurement**: the gauge reads $c_r + (K * x)(t) + r_g (t - t_\mathrm{mid})$ with gauge
  drift $r_g$ and a low-pass kernel $K$ of mean delay $\tau$ (order 1 or 2, `kernel_cdf`).
  With $x = L - D$ (stick line $L$, slip displacement $D$: 0 before breakaway, $y$ in the
  slip, $y_\mathrm{stop}$ after), $K * L = L(t - \tau)$ (exact for a steady drive) and
  $K * D$ is a discrete convolution on the RK4 grid with the kernel's bin masses, over
  `TAIL_STEPS` nodes (the slip and the gauge's settling). The gauge still settles from
  the previous slip when a window starts: that tail's decay after $t_0$ is added
  (`previous_rows`), the slip placed where the features put its breakaway as read: their
  half-sine centre (`_centre`) less half the duration they give it (`_slip_time`, an
  undamped slip's). A damped slip is not symmetric: at a damping ratio of 0.2 that
  centre comes 0.077/omega_0 (0.23-0.67 ms on the campaigns' sliders) before the middle
  of the slip, so placing the slip by the model's own centre of it put every tail that
  much early: with a 20 Hz sensor at its truth a damping ratio of 0.2 refitted to 0 (12
  records, seed 610); placed so, to 0.21. A
  window without a previous one takes its own slip's tail, placed where the slip before
  began (`tail_sources`: without it the first windows of a 7 Hz sensor missed by 30 um,
  60 times the noise). The measured restart state is itself a
  reading, so the slider's clock starts at $t_0 - \tau$: a pure delay is invisible, and
  the sensor changes the shape of the slips (second order in $\tau$; the score test
  probes it with a secant). With `sensor=False` the parameter is ignored.

Between the RK4 nodes the slip is a cubic Hermite interpolant (error ~(h omega_0)^4).
Residuals are whitened by the trace objective's standard errors (`trace_sd`, held
fixed). Units: mm, s, kgf, kgf/mm, mm/s.

Coordinates `z`: the 6 `EmpiricalFriction` logs, one gauge offset per record (mm), the
effect parameters over their `SCALES` in `FAMILIES` order (per-record families:
record-major), then the stick terms' coefficients over `STICK_SCALE`
(`cycle_effects.stick_terms`). `CycleModel.evaluate` gives residuals and the Jacobian of
any coordinates (forward mode, `BLOCK` tangents per compiled call; a record's rows depend
only on its own offset and per-record coefficients, so those share one tangent: the base
model's 6 + R columns cost 7 tangents). The stick terms are compiled in only where a
call needs them (`CycleModel._stick`: the sparse form's fits).
"""

from __future__ import annotations

import concurrent.futures
import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..objectives.trace import TraceData
from ..params import EmpiricalFriction
from ..solve.fit import COMPILER_OPTIONS
from .cycle_effects import (DAMPING_FORMS, FAMILIES, STICK_SCALE, STICK_TERMS, STRIBECK_FORMS,
                            Family, Shape)
from .cycle_slip import (N_STEPS, TAIL_STEPS, Effects, kernel_cdf, kernel_spectrum,
                         read_sample, slip_grid, solve_window)
from .later import Later

__all__ = ["BLOCK", "CycleModel", "Later", "N_STEPS", "TAIL_STEPS", "kernel_cdf",
           "per_sample", "previous_rows", "tail_sources", "window_rows"]

BLOCK = 8
"""Tangents per compiled forward-mode call (`CycleModel.evaluate`). Without the sensor, once
64 evaluations padded their last call (its compilation, ~9 s CPU, pays back over hundreds), a
call of at most `BLOCK // 2` takes that width (a call costs about its width: 11 tangents as
8 + 4, not 16; the lanes are identical)."""


class _Layout(eqx.Module):
    """Where each family's parameters live in the full coordinate vector (static)."""

    n_records: int = eqx.field(static=True)
    starts: tuple = eqx.field(static=True)  # ((family name, first index), ...)

    def first(self, name: str) -> int:
        return dict(self.starts)[name]

    @property
    def n_base(self) -> int:
        return 6 + self.n_records

    @property
    def size(self) -> int:
        return self.n_base + sum(f.n_params(self.n_records) for f in FAMILIES) + len(STICK_TERMS)

    def stick_cols(self) -> np.ndarray:
        """The stick terms' coordinates (the last `len(STICK_TERMS)`)."""
        return np.arange(self.size - len(STICK_TERMS), self.size)

    def cols(self, fam: Family) -> np.ndarray:
        a = self.first(fam.name)
        return np.arange(a, a + fam.n_params(self.n_records))


def _layout(n_records: int) -> _Layout:
    start, a = [], 6 + n_records
    for f in FAMILIES:
        start.append((f.name, a))
        a += f.n_params(n_records)
    return _Layout(n_records, tuple(start))


def _effects_of(layout: _Layout, theta, record):
    """Natural effect values for one row (`record`: its record index)."""
    def one(name, j=0):
        return theta[layout.first(name) - layout.n_base + j]

    a = layout.first("drive_periodic_error") - layout.n_base
    drive = jax.lax.dynamic_slice(theta, (a + 4 * record,), (4,))
    return Effects(c=one("viscous_damping"), b_st=one("stribeck"), a_rs=one("rate_state"),
                b_rs=one("rate_state", 1),
                drive=drive, s=one("drive_speed_drift"), tau=one("sensor_lowpass"),
                r_s=one("friction_drift"), r_d=one("friction_drift", 1),
                r_g=one("gauge_drift"), kappa=one("load_coupling"),
                stick=theta[theta.shape[0] - len(STICK_TERMS):])


def _model(z, scales, shape, sensor, stick, data: TraceData, tref, prev, layout: _Layout,
           idx):
    """(gauge reading incl. offset [n], slider velocity [N, L] (0 at the padding), ended [N]:
    the row's window broke away, its slip ended on its grid and its reads are finite)
    at the samples `idx` (flat indices of the unpadded entries of [N, L]). `prev`:
    ([N] the row whose slip's tail the gauge still owes at the window's start, or -1;
    [N] where that slip began, s) (`tail_sources`), then ([W] the first row of every
    window; [N] every row's window among them) (`window_rows`): a window's stick and
    slip are solved once (`solve_window`) and read at each of its samples (`read_sample`),
    the unpadded ones only (the padding: up to a third of a thinned campaign's entries).
    `sensor`, `stick` (static): the kernel convolution, the stick terms (`cycle_slip`)."""
    prev, began, first, slot = prev
    tref, tstart = tref[0], tref[1]
    nat = z * scales
    fr = EmpiricalFriction(*[nat[i] for i in range(6)]).friction()
    offset = nat[6:layout.n_base]
    theta = nat[layout.n_base:]
    x0 = data.start_level - offset[data.record]

    def one_window(rec, W, k, v, t0, x0, T1m, poly, N0):
        eff = _effects_of(layout, theta, rec)
        return solve_window(fr, eff, shape, sensor, W, k, v, t0, x0, T1m, tref[rec], tstart[rec],
                     poly, N0, wf[rec], stick)

    wf = jnp.zeros((layout.n_records, 1))
    if sensor:
        # the kernel's spectrum depends on the slip grid (a record's W and k) and the
        # sensor alone: computed per record, not per window
        h = slip_grid(jnp.zeros(layout.n_records).at[data.record].set(data.weight),
                  jnp.ones(layout.n_records).at[data.record].set(data.stiffness))[2]
        tau = jnp.maximum(_effects_of(layout, theta, 0).tau, 1e-7)
        wf = jax.vmap(kernel_spectrum, in_axes=(0, None, None, None))(h, tau, shape[4],
                                                                        shape[5])
    slips = jax.vmap(one_window)(*(a[first] for a in (
        data.record, data.weight, data.stiffness, data.speed, data.start_time, x0,
        data.stick_time, data.drive_poly, data.normal_load)))

    N, L = data.time.shape
    row = idx // L
    rec_e = data.record[row]

    def one_sample(s, rec, v, tw, poly, ts):
        sl = jax.tree.map(lambda a: a[s] if a.ndim == 1 else a, slips)  # grids: whole
        eff = _effects_of(layout, theta, rec)
        return read_sample(sl, s, eff, shape, sensor, v, tref[rec], tw, poly, ts, stick)

    read, yd = jax.vmap(one_sample)(slot[row], rec_e, data.speed[row],
                                    data.start_time[row], data.drive_poly[row],
                                    data.time.ravel()[idx])
    bad = jnp.zeros(N, bool).at[row].max(~jnp.isfinite(read))
    ended = slips.ended[slot] & ~bad
    yd = jnp.zeros(N * L).at[idx].set(yd).reshape(N, L)
    if sensor:
        # the gauge still settles from the previous slip when a window starts: the
        # measured restart level is the settled stick line (`features`: the plateau
        # after the slip), so the reading is that line plus what the gauge still owes
        # (placed at the previous slip's measured breakaway less how late the features
        # put it as read, `Slip.delay`: the model's breakaway may miss it by
        # the stick time's scatter; at tau instead, 0.6 ms late at 20 Hz, +0.5..1.3 um
        # at every window's start, noise 0.5 um, taken up by damping or load coupling)
        p = slot[jnp.maximum(prev, 0)][row]  # per sample: the window of that slip
        E = slips.F[:, -1:] - slips.F  # [W, TAIL_STEPS]: what each slip still owes after it
        s_ = (data.time.ravel()[idx] - (began[row] - slips.delay[p])) / slips.h[p]
        j = jnp.clip(jnp.floor(s_), 0, TAIL_STEPS - 2).astype(jnp.int32)
        f = jnp.clip(s_ - j, 0.0, 1.0)
        owed = jnp.where((s_ >= 0) & (s_ <= TAIL_STEPS - 1),
                         (1 - f) * E[p, j] + f * E[p, j + 1], 0.0)
        read = read + jnp.where(prev[row] >= 0, owed, 0.0)
    return read + offset[rec_e], yd, ended


def per_sample(data: TraceData, *fields: str) -> list[np.ndarray]:
    """The row attributes `fields` of `data` at its masked samples (flat, row by row)."""
    mask = np.asarray(data.mask)
    return [np.broadcast_to(np.asarray(getattr(data, f))[:, None], mask.shape)[mask]
            for f in fields]


def window_rows(data: TraceData) -> tuple[np.ndarray, np.ndarray]:
    """([W] the first row of every cycle window of `data`, in order; [N] the position of
    every row's window among them). The rows of one window share its restart state
    (`trace_data`), so its stick and slip are solved once."""
    win = np.asarray(data.window)
    _, first, slot = np.unique(win, return_index=True, return_inverse=True)
    return first.astype(np.int32), slot.astype(np.int32)


def previous_rows(data: TraceData) -> np.ndarray:
    """[N]: for every row, the first row of the previous cycle window of its record
    (its slip ends where this window starts), or -1 (first window, or a cycle left out
    between them)."""
    rec = np.asarray(data.record)
    win = np.asarray(data.window)
    prev = np.full(rec.shape, -1)
    first = {}
    for i, (r, w) in enumerate(zip(rec, win)):
        first.setdefault((int(r), int(w)), i)
    for i, (r, w) in enumerate(zip(rec, win)):
        j = first.get((int(r), int(w) - 1))
        if j is not None:
            prev[i] = j
    return prev


def tail_sources(data: TraceData) -> tuple[np.ndarray, np.ndarray]:
    """Where the gauge's settling at each window's start comes from (module doc):
    ([N] the first row of the window whose slip the gauge still settles from, or -1 if
    the window holds no slip; [N] the measured time that slip began, s). After a
    previous window of the record: that window and its measured breakaway
    (start time + stick time). Otherwise (a record's first window, a cycle left out
    before it) the window's own slip, placed its measured length before the start."""
    prev = previous_rows(data)
    rec = np.asarray(data.record)
    win = np.asarray(data.window)
    t0 = np.asarray(data.start_time, float)
    T1 = np.asarray(data.stick_time, float)
    t = np.where(np.asarray(data.mask), np.asarray(data.time, float), -np.inf)
    first, end = {}, {}
    for i, (r, w) in enumerate(zip(rec, win)):
        key = (int(r), int(w))
        first.setdefault(key, i)
        end[key] = max(end.get(key, -np.inf), float(t[i].max()))
    rows = prev.copy()
    began = np.zeros(len(rec))
    for i, (r, w) in enumerate(zip(rec, win)):
        if prev[i] >= 0:
            began[i] = t0[prev[i]] + T1[prev[i]]
            continue
        key = (int(r), int(w))
        length = end[key] - (t0[i] + T1[i])  # the window's own slip, as measured
        if np.isfinite(length) and length > 0:
            rows[i] = first[key]
            began[i] = t0[i] - length
    return rows, began


@eqx.filter_jit(compiler_options=COMPILER_OPTIONS)
def _value(z, scales, shape, sensor, stick, data, tref, prev, sd, layout, idx):
    read, yd, ok = _model(z, scales, shape, sensor, stick, data, tref, prev, layout, idx)
    return (data.deflection.ravel()[idx] - read) / sd.ravel()[idx], yd, ok


@eqx.filter_jit(compiler_options=COMPILER_OPTIONS)
def _value_and_block(z, T, scales, shape, sensor, stick, data, tref, prev, sd, layout, idx):
    """(r [n], J [n, B], ok [N], slider velocity [N, L]): the residuals of the samples
    `idx` (flat indices of the unpadded samples) and their derivatives along the B
    tangents T [size, B]."""
    def f(zz):
        read, yd, ok = _model(zz, scales, shape, sensor, stick, data, tref, prev, layout, idx)
        return (data.deflection.ravel()[idx] - read) / sd.ravel()[idx], (ok, yd)

    def col(t):
        return jax.jvp(f, (z,), (t,), has_aux=True)

    # the primal does not depend on the tangent: computed once, not per column
    r, J, (ok, yd) = jax.vmap(col, in_axes=1, out_axes=(None, -1, None))(T)
    return r, J, ok, yd


class CycleModel:
    """The per-cycle model of one campaign (module doc): residuals and Jacobians.

    `data`: the `TraceData` windows (without the features' drive correction: a drive
    error stays for the drive effects to explain); `tref`: `drift_origins`; `sd`:
    per-sample standard errors [N, L] (mm).
    """

    def __init__(self, data: TraceData, tref: np.ndarray, sd, n_records: int):
        self.data = data
        self.tref = jax.device_put(np.asarray(tref, float))
        self.sd = jax.device_put(np.asarray(sd, float))
        self._prev = tuple(jax.device_put(a) for a in (*tail_sources(data),
                                                      *window_rows(data)))
        self.layout = _layout(n_records)
        self.scales = np.ones(self.layout.size)
        for f in FAMILIES:
            reps = n_records if f.per_record else 1
            self.scales[self.layout.cols(f)] = np.tile(f.scales, reps)
        self.scales[self.layout.stick_cols()] = STICK_SCALE
        self._scales = jax.device_put(self.scales)
        self.mask = np.asarray(data.mask).ravel()
        self._record = per_sample(data, "record")[0]
        self._idx = jax.device_put(np.flatnonzero(self.mask).astype(np.int32))
        self._real_rows, self._grouped, self._tails = np.asarray(data.mask).any(1), {}, 0
        # every record's samples: one contiguous span of the residuals (`trace_data`'s order)
        self._span = np.zeros((n_records, 2), int)
        for g in range(n_records):
            where = np.flatnonzero(self._record == g)
            if where.size:
                if where[-1] - where[0] + 1 != where.size:
                    raise ValueError("CycleModel: a record's samples are not contiguous "
                                     "in the cycle windows (trace_data order)")
                self._span[g] = where[0], where[-1] + 1
        self.n_records = n_records

    @property
    def n_base(self) -> int:
        return self.layout.n_base

    def cols(self, fam: Family) -> np.ndarray:
        return self.layout.cols(fam)

    @staticmethod
    @functools.lru_cache(maxsize=256)
    def _shape(shape: Shape):
        return jnp.asarray([shape.vs, shape.p, shape.length, shape.pitch, shape.order,
                            shape.zeta, float(STRIBECK_FORMS.index(shape.form)),
                            float(DAMPING_FORMS.index(shape.damping))])

    def z0(self, friction: EmpiricalFriction, offsets) -> np.ndarray:
        z = np.zeros(self.layout.size)
        z[:6] = [float(x) for x in (friction.log_mu_d, friction.log_gap, friction.log_gamma,
                                    friction.log_m, friction.log_delta, friction.log_n)]
        z[6:self.n_base] = np.asarray(offsets, float)
        return z

    def breakaway_offsets(self, logs, current) -> np.ndarray:
        """[R]: the gauge offset of every record (mm) that puts the paper's breakaway at
        the measured stick times at the friction `logs` (the six `EmpiricalFriction`
        coordinates): the median over the record's windows of the measured breakaway
        reading (start level + v T1) minus the breakaway deflection $N \\mu_0(T_1)/k$
        (eq 1). A fit's offsets belong to its friction: with another friction the model's
        breakaways fall outside the windows, where the residual no longer depends on the
        offset (measured: a Stribeck drop of 0.2 on A refitted from the true friction
        with the bent base's offsets, 3.48 um, noise 0.5 um; with these, 0.508 um).
        `current`: kept for a record without a window."""
        d = self.data
        has = np.asarray(d.mask).any(1)
        static = EmpiricalFriction(*[float(x) for x in logs]).friction().static
        T1 = np.asarray(d.stick_time, float)
        x_b = (np.asarray(d.normal_load) * np.asarray(static(jnp.asarray(T1)))
               / np.asarray(d.stiffness))
        est = np.asarray(d.start_level) + np.asarray(d.speed) * T1 - x_b
        rec, win = np.asarray(d.record), np.asarray(d.window)
        out = np.array(current, float)
        for g in range(self.n_records):
            sel = has & (rec == g)
            _, first = np.unique(win[sel], return_index=True)
            if first.size:
                out[g] = float(np.median(est[sel][first]))
        return out

    def warm(self) -> dict:
        """Compile the programs of `evaluate` and of `residuals` with the sensor in a
        background thread while the caller works (XLA compiles without the GIL; 1.5-5 s
        each on 0.4 M samples), in the order discovery needs them; the sensor's Jacobian
        program (a refit with the sensor, which many campaigns never make) from its first
        `start()` or `result()` (`Later`). Returns {("evaluate" | "residuals", sensor):
        Future}; wait for a future before the program's first call (a call while it
        compiles compiles it again)."""
        z = np.zeros(self.layout.size)
        pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="stickslip-warm")
        futures = {("residuals", False): pool.submit(self.evaluate, z, [0])}
        futures["evaluate", False] = futures["residuals", False]  # one program
        futures["residuals", True] = pool.submit(self.residuals, z, sensor=True)
        futures["evaluate", True] = Later(self.evaluate, z, [0], sensor=True)
        pool.shutdown(wait=False)
        return futures

    def residuals(self, z, shape: Shape = Shape(), sensor: bool = False):
        """(whitened residuals flat [n], slider velocity [N, L], ended [N]: the row's window
        broke away and its slip ended on its grid, `cycle_slip`); `sensor`: the
        kernel convolution. Without it, `evaluate`'s program with no tangent (few calls:
        a program of their own took 7 s of CPU to compile to save 0.04 s a call); with it
        (the secant probes: 48 calls) a program of its own."""
        stick = self._stick(z, ())
        if sensor:
            r, yd, ended = _value(jnp.asarray(z), self._scales, self._shape(shape), True,
                                  stick, self.data, self.tref, self._prev, self.sd,
                                  self.layout, self._idx)
            return np.asarray(r), np.asarray(yd), np.asarray(ended)
        r, _, ended, yd = self._block(jnp.asarray(z), np.zeros((self.layout.size, 1)),
                                      self._shape(shape), False, stick)
        return np.asarray(r), np.asarray(yd), np.asarray(ended)

    def _stick(self, z, cols) -> bool:
        """Whether the model at z needs its stick terms: a stick coefficient is non-zero
        in z or among the columns `cols` differentiated. Without them (every fit but the
        sparse form's) the programs leave the terms out: each sample's 17 stick columns
        and their derivatives took 38 % of an 8-tangent evaluation (63 -> 39 ms CPU on
        the 12-record screw campaign, 26,310 samples) and half of its compilation (10.7
        -> 4.9 s CPU); the same residuals, since the terms add zero."""
        sc = self.layout.stick_cols()
        return bool(np.any(np.asarray(z)[sc] != 0) or np.any(np.isin(cols, sc)))

    def _block(self, zj, part, sh, sensor: bool, stick: bool):
        """`_value_and_block` along the tangents `part`, padded to its width (`BLOCK`; the
        stick terms' calls, few, keep the full width: one program of their own, not two)."""
        narrow = part.shape[1] <= BLOCK // 2 and not sensor and not stick and self._tails > 64
        T = np.zeros((self.layout.size, BLOCK // 2 if narrow else BLOCK))
        T[:, :part.shape[1]] = part
        return _value_and_block(zj, jax.device_put(T), self._scales, sh, bool(sensor),
                                bool(stick), self.data, self.tref, self._prev, self.sd, self.layout,
                                self._idx)

    def _tangents(self, cols):
        """Group `cols` into tangents (module doc: the same per-record coordinate of every
        record shares one, exact since a record's rows see only their own). Returns (T
        [size, n_tangents], tangent of each col, record of each col or -1)."""
        lay = self.layout
        per = {lay.first(f.name): (f.name, len(f.params), f.n_params(self.n_records))
               for f in FAMILIES if f.per_record}
        keys, tangent, record = {}, [], []
        for c in cols:
            key, rec = ("col", c), -1
            if 6 <= c < lay.n_base:
                key, rec = ("offset", 0), c - 6
            for a, (name, k, size) in per.items():
                if a <= c < a + size:
                    key, rec = (name, (c - a) % k), (c - a) // k
            tangent.append(keys.setdefault(key, len(keys)))
            record.append(rec)
        T = np.zeros((lay.size, len(keys)))
        T[cols, tangent] = 1.0
        return T, np.asarray(tangent, int), np.asarray(record, int)

    def evaluate(self, z, cols, shape: Shape = Shape(), sensor: bool = False):
        """(r [n], J [n, len(cols)], ok) at z (module doc, `_tangents`); ok: every window
        broke away and its slip ended on its grid (`cycle_slip`)."""
        cols = np.asarray(cols, int)
        if (key := cols.tobytes()) not in self._grouped:
            self._grouped[key] = self._tangents(cols)
        (T_all, tangent, record), blocks, ok = self._grouped[key], [], True
        sh, zj, stick = self._shape(shape), jnp.asarray(z), self._stick(z, cols)
        for a in range(0, max(T_all.shape[1], 1), BLOCK):
            part = T_all[:, a:a + BLOCK]
            self._tails += part.shape[1] <= BLOCK // 2 and not sensor and a > 0  # `BLOCK`
            r, J_, ended, _ = self._block(zj, part, sh, sensor, stick)
            blocks.append(np.asarray(J_)[:, :part.shape[1]])
            ok = ok and bool(np.all(np.asarray(ended)[self._real_rows]))
        Jt = blocks[0] if len(blocks) == 1 else np.concatenate(blocks, axis=1)
        J = np.zeros((Jt.shape[0], cols.size), order="F")  # each column written, read at once
        for i, (t, g) in enumerate(zip(tangent, record)):  # a record's coefficient: its rows
            a, b = self._span[g] if g >= 0 else (0, Jt.shape[0])
            J[a:b, i] = Jt[a:b, t]
        return np.asarray(r), J, ok


def drift_origins(records) -> np.ndarray:
    """[2, R]: the middle of every record's time span (s: the origin of the drive speed
    drift and the gauge drift) and its start (s: the origin of the friction drift)."""
    return np.array([[0.5 * (float(r.time[0]) + float(r.time[-1])) for r in records],
                     [float(r.time[0]) for r in records]])

