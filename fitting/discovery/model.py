r"""Trace model of a campaign for discovery: the smoothed simulator with every library effect.

A campaign enters as padded traces (`objectives.smooth.SmoothData`, [R records, N
samples], mm and s, `campaign_traces`). Each record must start at the end of a slip
(stick time 0): synthetic discovery records do, and `crop=Crop.SLIP_END` cuts a measured
record at its first detected slip end.

The model of record $r$ is `simulate_smooth` (`Settings`) of
`EffectSet.smooth_model(Slideway(friction, W_r, k_r))` driven at its drive speed $v_r$
(or its measured or programmed drive, `SmoothData.drive_knots`), started at rest at the
deflection $x_{0,r}$ (a per-record nuisance, first guessed by a line through the first
samples). Parameters: `DiscoveryParams` (friction logs, the `EffectSet`, the $x_0$).

**One compilation for every candidate.** `Problem.evaluate(z)` returns the whitened
residuals $(model - data)/\sigma$ and their Jacobian (forward mode through the solver)
over $z$ = [free friction coordinates, `n_slots` effect slots, the R offsets of $x_0$].
Which effect parameters the slots drive is a selection matrix passed as *data*, so the
base, every candidate and the score test run the same compiled function. Slots are in
units of each parameter's `SCALES`; the friction coordinates are apparent coefficients,
referred to W (`effects.LoadCoupling`).
"""

from __future__ import annotations

import dataclasses
import math

import diffrax as dfx
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree
from jaxtyping import Array, Float

import stickslip_jax as ss
from stickslip_jax.modes import Formulation
from stickslip_jax.simulation.parts import AbstractForceTerm
from stickslip_jax.simulation.smooth import simulate_smooth
from stickslip_jax.slips import robust_sigma

from ..modes import Crop, check_member
from ..objectives.smooth import SmoothData, pack_records, record_drive
from ..params import NAMES, EmpiricalFriction
from .effects import CANDIDATES, EffectSet, load_referred_friction
from .subproblems import AbstractProblem

__all__ = [
    "EFFECT_PARAMS",
    "DiscoveryParams",
    "Problem",
    "Settings",
    "campaign_traces",
    "simulate_campaign",
]

EFFECT_PARAMS: tuple[tuple[str, str], ...] = tuple(
    (name, p) for name in CANDIDATES for p in getattr(EffectSet(), name).PARAMS)
"""(effect, parameter) pairs in the order of the flat effect vector."""
_SCALES = tuple(s for name in CANDIDATES for s in getattr(EffectSet(), name).SCALES)


@dataclasses.dataclass(frozen=True)
class Settings:
    """Simulator settings of discovery fits (hashable: part of the compiled function).

    `smoothing`: dimensionless (1e-2: the stick creeps at 1 % of the drive speed, as in
    the synthetic campaigns); `rtol`/`atol` (mm, mm/s): 1e-6 keeps the forward-mode
    Jacobians within a few % of finite differences (at 1e-4 the traces are right, their
    derivatives not); `max_steps` per record; `solver`: an implicit diffrax solver class
    taking a `root_finder` (`dfx.Kvaerno3`, 4 or 5); `formulation` pinned, so that a new
    default of `simulate_smooth` cannot change discovery.
    """

    smoothing: float = 1e-2
    rtol: float = 1e-6
    atol: float = 1e-8
    max_steps: int = 8192
    solver: type[dfx.AbstractImplicitSolver] = dfx.Kvaerno5
    formulation: Formulation = Formulation.RIGID_STICK

    def make_solver(self):
        """The implicit diffrax solver `solver` with full Newton stages."""
        import optimistix as optx

        return self.solver(root_finder=optx.Newton(rtol=self.rtol, atol=self.atol))


class DiscoveryParams(eqx.Module):
    """friction (log coordinates, `params.EmpiricalFriction`), effects, x0 [R] mm."""

    friction: EmpiricalFriction
    effects: EffectSet
    x0: Float[Array, " R"]


def _start_level(t, x, n0):
    """Intercept at t[0] of a line through the first n0 samples (mm)."""
    a = np.polyfit(t[:n0] - t[0], x[:n0], 1)
    return float(a[1])


def _crop_at_first_slip_end(record):
    from ..data.features import record_features

    f = record_features(record)
    if not f.stick_slip or len(f.end_time) == 0:
        raise ValueError(f"{record.name or 'record'}: no stick-slip found ({f.message}); "
                         "discovery needs records with stick-slip cycles")
    # a little after the slip end, so that the slider has settled
    t_end = float(f.end_time[0]) + 0.1 * math.pi / f.omega0
    keep = record.time >= t_end
    return np.asarray(record.time[keep], float), record.deflection[keep]


def campaign_traces(records, *, crop: Crop = Crop.NONE) -> SmoothData:
    """Padded traces from records (module doc): `start_level` a line through the first
    samples, `sigma` the median of the records' robust noise (mm); `crop` a `Crop`
    (`Crop.NONE`: each record starts at a slip end).
    """
    check_member("crop", crop, Crop)
    if len(records) < 1:
        raise ValueError("discovery needs at least one record")
    times, xs, starts = [], [], []
    for rec in records:
        if crop is Crop.SLIP_END:
            t, x = _crop_at_first_slip_end(rec)
        else:
            t, x = np.asarray(rec.time, float), np.asarray(rec.deflection)
        t0, t = float(t[0]), t - t[0]
        if t.shape[0] < 16:
            raise ValueError(f"{rec.name or 'record'}: too few samples ({t.shape[0]}) left")
        times.append(t)
        xs.append(x)
        starts.append(t0)
    noise = float(np.median([robust_sigma(np.asarray(x, float)) for x in xs]))
    x0 = [_start_level(t, x, max(6, min(t.shape[0] // 40, 40))) for t, x in zip(times, xs)]
    return pack_records(records, times, xs, starts, x0, np.full(len(xs), noise))


def simulate_record(friction, effects: EffectSet, weight, stiffness, drive, x0, ts, mask,
                    settings: Settings, extra_force_terms: tuple = ()):
    """Model reading (mm) of one record on `ts` (s) driven by `drive` (`record_drive`),
    the solver success flag, the slider velocity (mm/s) and the sticking flags."""
    sw = ss.Slideway(friction, weight, stiffness)
    model = effects.smooth_model(sw, extra_force_terms)
    tr = simulate_smooth(model, drive, ts, smoothing=settings.smoothing,
                         rtol=settings.rtol, atol=settings.atol, max_steps=settings.max_steps,
                         initial_deflection=x0, mask=mask, solver=settings.make_solver(),
                         adjoint=dfx.ForwardMode(), formulation=settings.formulation)
    ok = tr.result == ss.simulation.SimulationResult.successful
    return tr.deflection, ok, tr.slider_velocity, tr.sticking


@eqx.filter_jit
def simulate_campaign(params: DiscoveryParams, traces: SmoothData, settings: Settings,
                      extra_force_terms: tuple = ()):
    """Model readings [R, N] (mm) and success flags [R] for every record."""
    fr = params.friction.friction()

    def one(args):
        w, k, v, kn, x0, t, m = args
        return simulate_record(fr, params.effects, w, k, record_drive(v, kn), x0, t, m,
                               settings, extra_force_terms)[:2]

    return jax.lax.map(one, (traces.weight, traces.stiffness, traces.speed,
                             traces.drive_knots, params.x0, traces.time, traces.mask))


def effects_to_vector(effects: EffectSet) -> Float[Array, " E"]:
    """Flat effect vector in SCALES units (order `EFFECT_PARAMS`)."""
    return jnp.stack([getattr(getattr(effects, n), p) / s
                      for (n, p), s in zip(EFFECT_PARAMS, _SCALES)])


def effects_from_vector(template: EffectSet, vec) -> EffectSet:
    """Inverse of `effects_to_vector` (the fixed shape settings come from `template`)."""
    return eqx.tree_at(lambda s: [getattr(getattr(s, n), p) for n, p in EFFECT_PARAMS],
                       template, [vec[i] * s for i, s in enumerate(_SCALES)])


def slot_matrix(effect: str | None, n_slots: int = 2) -> np.ndarray:
    """[E, n_slots] selection: slot j drives the j-th parameter of `effect` (None: none)."""
    S = np.zeros((len(EFFECT_PARAMS), n_slots))
    if effect is None:
        return S
    idx = [i for i, (n, _) in enumerate(EFFECT_PARAMS) if n == effect]
    if not idx:
        raise ValueError(f"unknown effect {effect!r}; choose from {', '.join(CANDIDATES)}")
    for j, i in enumerate(idx):
        S[i, j] = 1.0
    return S


TRACE_COUNT = {"evaluate": 0}
"""How many times the residual/Jacobian function was traced (tests check it is once
per campaign shape, whatever the candidate)."""


@eqx.filter_jit
def _evaluate(z_base, z_slots, z_extra, dx0, S, eff0, friction_static, effects_template,
              extra, traces, settings, sigma):
    """Whitened residuals [R, N], per-record Jacobians [R, N, nb + ns + ne + 1], success
    flags [R], and the model's slider velocity [R, N] (mm/s) and sticking flags [R, N]."""
    TRACE_COUNT["evaluate"] += 1
    nb, ns = z_base.shape[0], z_slots.shape[0]
    static, unravel = extra_parts(extra)

    def one(args):
        w, k, v, kn, x0g, dxr, t, m, d = args

        def f(q):
            zb, zs, ze, dx = q[:nb], q[nb:nb + ns], q[nb + ns:-1], q[-1]
            fr = combine_friction(zb, friction_static)
            eff = effects_from_vector(effects_template, eff0 + S @ zs)
            terms = () if extra is None else (eqx.combine(unravel(ze), static),)
            # friction coordinates are apparent (referred to W): see effects.LoadCoupling
            phys = load_referred_friction(fr.friction(), eff.load_coupling.kappa)
            model, ok, vel, stk = simulate_record(phys, eff, w, k, record_drive(v, kn),
                                                  x0g + dx, t, m, settings, terms)
            r = jnp.where(m, (model - d) / sigma, 0.0)
            return r, (r, ok, vel, stk)

        q0 = jnp.concatenate([z_base, z_slots, z_extra, dxr[None]])
        J, (r, ok, vel, stk) = jax.jacfwd(f, has_aux=True)(q0)
        return r, J, ok, vel, stk

    return jax.lax.map(one, (traces.weight, traces.stiffness, traces.speed,
                             traces.drive_knots, traces.start_level, dx0, traces.time,
                             traces.mask, traces.deflection))


def extra_parts(extra):
    """(static part, unravel of the flat arrays) of a force term `extra` (None: none)."""
    if extra is None:
        return None, None
    arrays, static = eqx.partition(extra, eqx.is_inexact_array)
    return static, ravel_pytree(arrays)[1]


def stack_records(r, J, mask) -> tuple[np.ndarray, np.ndarray]:
    """Residuals [M] and Jacobian [M, S + R] over the `mask`ed samples of per-record
    residuals `r` [R, N] and Jacobians `J` [R, N, S + 1] (S coordinates shared by the
    records, then the record's own offset dx0)."""
    R, _, P = J.shape
    rows = [J[i][mask[i]] for i in range(R)]
    Jfull = np.zeros((sum(x.shape[0] for x in rows), P - 1 + R))
    o = 0
    for i, block in enumerate(rows):
        Jfull[o:o + block.shape[0], :P - 1] = block[:, :-1]
        Jfull[o:o + block.shape[0], P - 1 + i] = block[:, -1]
        o += block.shape[0]
    return np.concatenate([r[i][mask[i]] for i in range(R)]), Jfull


def combine_friction(z_base, friction_static: EmpiricalFriction) -> EmpiricalFriction:
    """Friction with its leaves (log coordinates, `NAMES` order) taken from z_base."""
    return eqx.tree_at(lambda f: f.leaves(), friction_static,
                       [z_base[i] for i in range(len(NAMES))])


@dataclasses.dataclass
class Problem(AbstractProblem):
    """A campaign and a model structure: the `effect` the slots drive (None: none) and an
    `extra` force term whose arrays are fitted too (the learned correction's).

    `evaluate(z)` -> (residuals [M], Jacobian [M, P], ok) over the masked samples, with
    $z$ = [friction logs (`NAMES`), slots, the extra term's arrays
    (flat), dx0 (R)]. The Problems of a campaign without an extra term share one compiled
    function (`effect` only changes the data matrix S).
    """

    traces: SmoothData
    friction0: EmpiricalFriction
    effects0: EffectSet
    effect: str | None = None
    settings: Settings = Settings()
    n_slots: int = 2
    sigma: float | None = None
    extra: AbstractForceTerm | None = None

    def __post_init__(self):
        self.S = jnp.asarray(slot_matrix(self.effect, self.n_slots))
        self.eff0 = effects_to_vector(self.effects0)
        if self.sigma is None:
            self.sigma = float(self.traces.sigma[0])
        self._mask = np.asarray(self.traces.mask)
        self._trajectories = {}  # z bytes -> (model, velocity, sticking) [R, N] of evaluate
        arrays = eqx.filter(self.extra, eqx.is_inexact_array)
        self.extra0 = (np.zeros(0) if self.extra is None
                       else np.asarray(ravel_pytree(arrays)[0]))

    @property
    def n_records(self) -> int:
        return int(self.traces.time.shape[0])

    @property
    def n_base(self) -> int:
        return len(NAMES)

    @property
    def n_params(self) -> int:
        return self.n_base + self.n_slots + self.extra0.size + self.n_records

    def z0(self, base_z=None) -> np.ndarray:
        """The start: the friction's, no effect, the extra term's arrays and no offset, or
        the coordinates of `base_z` (a Problem's without an extra term) with the term's."""
        nb, ns = self.n_base, self.n_slots
        if base_z is None:
            fb = [float(x) for x in self.friction0.leaves()]
            base_z = np.concatenate([fb, np.zeros(ns), np.zeros(self.n_records)])
        return np.concatenate([base_z[:nb + ns], self.extra0, base_z[nb + ns:]])

    def active(self) -> np.ndarray:
        """Which coordinates of z are fitted (unused slots are not)."""
        act = np.ones(self.n_params, bool)
        used = np.asarray(self.S).sum(axis=0) > 0
        act[self.n_base: self.n_base + self.n_slots] = used
        return act

    def split(self, z):
        """z's friction, slot, extra-term and offset coordinates."""
        cut = np.cumsum([self.n_base, self.n_slots, self.extra0.size])
        return tuple(jnp.asarray(p) for p in np.split(np.asarray(z, float), cut))

    def evaluate(self, z):
        zb, zs, ze, dx0 = self.split(z)
        try:
            r, J, ok, vel, stk = _evaluate(zb, zs, ze, dx0, self.S, self.eff0, self.friction0,
                                           self.effects0, self.extra, self.traces,
                                           self.settings, jnp.asarray(self.sigma))
        except eqx.EquinoxRuntimeError:
            # a wild trial point (a diverging implicit stage): reject it, never crash
            return np.full(1, np.inf), np.full((1, self.n_params), np.nan), False
        r, J, ok = np.asarray(r), np.asarray(J), np.asarray(ok)
        model = np.asarray(self.traces.deflection) + r * self.sigma
        if len(self._trajectories) >= 8:  # the latest few: LM's accepted point is among them
            self._trajectories.pop(next(iter(self._trajectories)))
        self._trajectories[np.asarray(z, float).tobytes()] = (model, np.asarray(vel),
                                                              np.asarray(stk))
        return *stack_records(r, J, self._mask), bool(np.all(ok))

    def params(self, z) -> DiscoveryParams:
        zb, zs, _, dx0 = self.split(z)
        fr = combine_friction(zb, self.friction0)
        eff = effects_from_vector(self.effects0, self.eff0 + self.S @ zs)
        return DiscoveryParams(fr, eff, self.traces.start_level + dx0)

    def extra_term(self, z):
        """The extra force term at z."""
        static, unravel = extra_parts(self.extra)
        return eqx.combine(unravel(self.split(z)[2]), static)

    def trajectories(self, z):
        """(model reading [R, N] mm, slider velocity [R, N] mm/s, sticking [R, N]) at z,
        from the latest evaluations when z was one of them (no new compilation: the
        same compiled function as `evaluate`)."""
        key = np.asarray(z, float).tobytes()
        if key not in self._trajectories:
            _, _, ok = self.evaluate(np.asarray(z, float))
            if key not in self._trajectories:
                raise ValueError("the simulator failed at these parameters")
        return self._trajectories[key]

    def record_residuals(self, z) -> list[np.ndarray]:
        """Unwhitened residuals data - model (mm) per record (masked samples only)."""
        model, _, _ = self.trajectories(z)
        d, m = np.asarray(self.traces.deflection), self._mask
        return [d[i][m[i]] - model[i][m[i]] for i in range(self.n_records)]
