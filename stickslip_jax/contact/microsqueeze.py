r"""Time dependence of static friction by the microsqueeze effect (paper section 7.2.3-7.2.4).

The squeeze film between the approaching asperities carries (eq 28, with the cube that
the OCR lost, NOTES.md item 4)

$$W_s = \frac{\eta Q}{(h_e - t_b - a)^3}\,\frac{da}{dt},$$

and eq (13) gives $W_s(a) = W - p_m A_m(a) - p_b A_b(a)$, so the approach obeys

$$\frac{da}{dt} = f(a) = \frac{W_s(a)\,(h_e - t_b - a)^3}{\eta Q}, \qquad a(0) = a_d,$$

with $a_d$ the approach at which $\mu_0(a_d) = \mu_d$ (eq 15). The approach rises towards
$a_{end} = \min(a_s, h_e - t_b)$ ($a_s$: $W_s = 0$, eq 33); the stick time $T_1$ maps
to $\mu_0(T_1) = \mu_0(a(T_1))$ (eq 15). Units: $\eta$ kgf s/mm$^2$, $Q$ mm$^4$,
$h_e$, $t_b$, $a$ mm, $W$ kgf, $T_1$ s.

**Transformed variable.** Both ends of the motion are singular ($f \to 0$ at
$a_{end}$, a simple root at $a_s$ or a triple root at $h_e - t_b$), so the state is the
log-gap $s = -\log\{(a_{end} - a)/(a_{end} - a_d)\} \in [0, \infty)$, and
$dt/ds = (a_{end} - a)/f(a)$ is evaluated in factored form (no cancellation): it tends
to a constant at a simple root and grows like $e^{2s}$ at the triple root, smooth in
both cases. $s$ is capped at `S_CAP` = 36 inside the rate (the gap is then $10^{-16}$ of
its initial value), so nothing overflows or turns into NaN for any stick time.

Two solvers share that integrand:

- `microsqueeze_curve(law, T1)`: diffrax integrates $s$ in log-time; the reference.
- `MicrosqueezeStatic.__call__(T1)`: the law used by simulators and fitters. It
  tabulates $t(s)$ by composite 3-point Gauss-Legendre quadrature of $dt/ds$ on a
  fixed $s$ grid (vectorised, no loop, about 400 rate evaluations) and inverts it by a
  cubic Hermite interpolation of $\log s$ against $\log t$ with exact slopes. The cost
  per call is fixed and small, it is jit/vmap/grad safe for scalar or array $T_1$, and
  because the table is rebuilt from the fields at each call, `eqx.tree_at` on `h_e`,
  `Q`, ... is always consistent (no stale cache). It agrees with the diffrax solution
  to better than 2e-5 in $\mu_0$ (tests/test_microsqueeze.py; 6e-6 for lubricant D).
"""

from __future__ import annotations

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..friction import AbstractStaticFriction
from ..numerics import as_float, is_concrete
from ..tables import load_table
from .boundary import BoundaryContact, approach_for, film_from_mu_s, final_approach, static_coefficient
from .surfaces import SurfacePair, surface_pair

Scalar = Float[Array, ""]

#: Cap on the log-gap inside the rate: beyond it the approach equals a_end to 1e-16.
S_CAP = 36.0
_S_MIN = 1e-6  # first tabulation node (the motion is linear in t there)
_GL_X = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
_GL_W = np.array([5.0, 8.0, 5.0]) / 9.0


def _s_nodes(n_small: int, n_large: int) -> np.ndarray:
    """Tabulation nodes in s: 0, geometric on [1e-6, 1], then uniform on [1, S_CAP]."""
    small = np.geomspace(_S_MIN, 1.0, n_small, endpoint=False)
    large = np.linspace(1.0, S_CAP, n_large)
    return np.concatenate([[0.0], small, large])


class Kinematics(eqx.Module):
    r"""Derived quantities of a microsqueeze law (all lengths in mm).

    `K` area factor (mm$^{-1}$, eq 31), `a_d` start ($\mu_0 = \mu_d$), `a_s` ($W_s = 0$),
    `gap_limit` $= h_e - t_b$, `a_end` $= \min(a_s, h_e - t_b)$, `span` $= a_{end} - a_d$,
    `d_s` $= a_s - a_{end}$, `d_g` $= h_e - t_b - a_{end}$ (one of the two is 0).
    """

    K: Scalar
    a_d: Scalar
    a_s: Scalar
    gap_limit: Scalar
    a_end: Scalar
    span: Scalar
    d_s: Scalar
    d_g: Scalar


class MicrosqueezeStatic(AbstractStaticFriction):
    r"""Static friction from the microsqueeze model, eqs (13)-(15), (28)-(33).

    A drop-in `AbstractStaticFriction`: `law(T1)` returns $\mu_0(T_1)$ (dimensionless)
    for stick times in s (scalar or array; $T_1 = 0$ gives `mu_d`), and is
    jit/vmap/grad safe with respect to every field.

    Fields: `pair` (`SurfacePair`), `contact` (`BoundaryContact`: W, p_m, C1-C3),
    `t_b` adsorbed film thickness (mm), `eta` viscosity (kgf s/mm$^2$), `h_e` effective
    initial film thickness (mm), `Q` squeeze factor (mm$^4$), `mu_d` (dimensionless).

    Physically impossible concrete parameters raise `ValueError` at construction
    (naming which); traced values are checked with `eqx.error_if` when used (a host
    callback: the program stays out of the compilation cache) unless `check_traced` is
    False, for callers that keep them inside the law's domain (the fitting's parameters).

    ```python
    >>> law = MicrosqueezeStatic.from_table11("A")
    >>> law(jnp.array([0.0, 1.0, 100.0]))      # mu_d, ..., close to mu_s = 0.450
    ```
    """

    pair: SurfacePair
    contact: BoundaryContact
    t_b: Scalar = eqx.field(converter=as_float)
    eta: Scalar = eqx.field(converter=as_float)
    h_e: Scalar = eqx.field(converter=as_float)
    Q: Scalar = eqx.field(converter=as_float)
    mu_d: Scalar = eqx.field(converter=as_float)
    n_small: int = eqx.field(static=True, default=32)
    n_large: int = eqx.field(static=True, default=96)
    check_traced: bool = eqx.field(static=True, default=True)

    def __check_init__(self):
        values = (self.t_b, self.eta, self.h_e, self.Q, self.mu_d)
        if not is_concrete(*values) or not is_concrete(*jax.tree_util.tree_leaves((self.pair, self.contact))):
            return
        for name in ("eta", "Q", "h_e"):
            v = np.asarray(getattr(self, name))
            if not np.all(np.isfinite(v)) or np.any(v <= 0):
                raise ValueError(f"MicrosqueezeStatic: {name} must be finite and > 0, got {v}")
        t_b = np.asarray(self.t_b)
        if not np.all(np.isfinite(t_b)) or np.any(t_b < 0):
            raise ValueError(f"MicrosqueezeStatic: t_b must be finite and >= 0, got {t_b}")
        kin = _unchecked_kinematics(self)
        mu_0_at_contact = np.asarray(_mu_at(self, 0.0))
        if np.any(np.asarray(kin.a_d) < 0):
            raise ValueError(
                f"MicrosqueezeStatic: mu_d = {np.asarray(self.mu_d)} is below mu_0(a=0) = "
                f"{mu_0_at_contact} (the film alone already gives more friction); raise mu_d or lower t_b"
            )
        if np.any(np.asarray(self.h_e) <= np.asarray(self.t_b + kin.a_d)):
            raise ValueError(
                f"MicrosqueezeStatic: h_e = {np.asarray(self.h_e)} mm must exceed t_b + a_d = "
                f"{np.asarray(self.t_b + kin.a_d)} mm (a_d: approach at which mu_0 = mu_d)")
        if np.any(np.asarray(kin.a_s) <= np.asarray(kin.a_d)):
            raise ValueError(
                f"MicrosqueezeStatic: mu_d = {np.asarray(self.mu_d)} must be below the static limit "
                f"mu_0(a_s) = {np.asarray(_mu_at(self, kin.a_s))}"
            )

    @classmethod
    def from_table11(cls, lubricant: str, pair: SurfacePair | str = "S1G1", contact=None, **kw):
        r"""Lubricant `lubricant` (A-G) of Table 11 on surface pair `pair`: $\eta$, $h_e$, $Q$,
        $\mu_d$ as printed and $t_b$ recomputed from the printed $\mu_s$ (eqs 31-35)."""
        r = load_table(11).row(lubricant)
        return cls.from_mu_s(r.mu_s, mu_d=r.mu_d, eta=r.eta, h_e=r.h_e, Q=r.Q, pair=pair, contact=contact, **kw)

    @classmethod
    def from_mu_s(cls, mu_s, *, mu_d, eta, h_e, Q, pair: SurfacePair | str = "S1G1", contact=None, **kw):
        r"""A law whose film thickness $t_b$ is deduced from $\mu_s$ (eqs 33-35)."""
        pair = surface_pair(pair) if isinstance(pair, str) else pair
        contact = BoundaryContact() if contact is None else contact
        t_b = film_from_mu_s(pair, contact, mu_s).t_b
        return cls(pair=pair, contact=contact, t_b=t_b, eta=eta, h_e=h_e, Q=Q, mu_d=mu_d, **kw)

    def kinematics(self, check: bool = True) -> Kinematics:
        """Start, end and span of the approach (mm); with `check` and `check_traced`,
        `eqx.error_if` guards."""
        a_d = approach_for(self.pair, self.contact, self.mu_d, self.t_b)
        a_s = final_approach(self.pair, self.contact, self.t_b)
        gap_limit = self.h_e - self.t_b
        if check and self.check_traced:
            a_d = eqx.error_if(a_d, a_d < 0, "MicrosqueezeStatic: mu_d is below mu_0(a=0) (film-only friction)")
            a_d = eqx.error_if(a_d, gap_limit <= a_d, "MicrosqueezeStatic: h_e <= t_b + a_d (no squeeze film left)")
            a_d = eqx.error_if(a_d, a_s <= a_d, "MicrosqueezeStatic: mu_d is not below mu_0(a_s)")
            a_d = eqx.error_if(a_d, (self.eta <= 0) | (self.Q <= 0), "MicrosqueezeStatic: eta and Q must be > 0")
        a_end = jnp.minimum(a_s, gap_limit)
        return Kinematics(K=self.pair.area_factor, a_d=a_d, a_s=a_s, gap_limit=gap_limit,
                          a_end=a_end, span=a_end - a_d, d_s=a_s - a_end, d_g=gap_limit - a_end)

    def approach(self, s, kin: Kinematics):
        """Approach a (mm) at log-gap s."""
        return kin.a_end - kin.span * jnp.exp(-s)

    def dt_ds(self, s, kin: Kinematics):
        r"""$dt/ds = (a_{end} - a)/f(a)$ in s, from eq (28) with eq (13), factored:
        $W_s = p_m K (a_s - a)\,q(a)$ with $q > 0$ (no cancellation near $a_s$)."""
        s = jnp.minimum(s, S_CAP)
        gap = kin.span * jnp.exp(-s)
        a = kin.a_end - gap
        t = self.t_b
        C2 = self.contact.C2
        a_s = kin.a_s
        u, u_s = a + t, a_s + t
        q = (1.0 - C2) * (a_s**2 + a_s * a + a**2) + C2 * (u_s**2 + u_s * u + u**2)
        pmK = self.contact.p_m * kin.K
        return self.eta * self.Q / (pmK * q * (kin.d_g + gap) ** 3) * (gap / (kin.d_s + gap))

    def mu_at(self, s, kin: Kinematics):
        """mu_0 (eq 15) at log-gap s."""
        return static_coefficient(self.pair, self.contact, self.approach(s, kin), self.t_b)

    def asymptote(self) -> Scalar:
        r"""$\mu_0(T_1 \to \infty) = \mu_0(a_{end})$: $\mu_s$ when $h_e - t_b \ge a_s$."""
        kin = self.kinematics()
        return static_coefficient(self.pair, self.contact, kin.a_end, self.t_b)

    def static_limit(self) -> Scalar:
        r"""$\mu_s = \mu_0(a_s)$ (eq 33-35), whether or not the squeeze film lets a reach $a_s$."""
        kin = self.kinematics()
        return static_coefficient(self.pair, self.contact, kin.a_s, self.t_b)

    def table(self):
        """Tabulated (s_k, t_k, dt/ds_k), k >= 1, by composite Gauss-Legendre quadrature."""
        kin = self.kinematics()
        s = jnp.asarray(_s_nodes(self.n_small, self.n_large))
        lo, hi = s[:-1], s[1:]
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        pts = mid[:, None] + half[:, None] * jnp.asarray(_GL_X)[None, :]
        pieces = half * jnp.sum(jnp.asarray(_GL_W)[None, :] * self.dt_ds(pts, kin), axis=1)
        t = jnp.cumsum(pieces)
        return kin, s[1:], t, self.dt_ds(s[1:], kin)

    def __call__(self, stick_time: Float[ArrayLike, "..."]) -> Float[Array, "..."]:
        return _evaluate(self, jnp.asarray(stick_time, dtype=float))

    def _evaluate(self, T1):
        kin, s, t, dtds = self.table()
        x, y = jnp.log(t), jnp.log(s)
        slope = t / (s * dtds)  # d log s / d log t
        positive = T1 > 0
        T_safe = jnp.where(positive, T1, t[0])
        lx = jnp.log(T_safe)
        j = jnp.clip(jnp.searchsorted(x, lx) - 1, 0, x.shape[0] - 2)
        x0, x1, y0, y1, m0, m1 = x[j], x[j + 1], y[j], y[j + 1], slope[j], slope[j + 1]
        h = x1 - x0
        u = (lx - x0) / h
        h00 = (1 + 2 * u) * (1 - u) ** 2
        h10 = u * (1 - u) ** 2
        h01 = u**2 * (3 - 2 * u)
        h11 = u**2 * (u - 1)
        log_s = h00 * y0 + h10 * h * m0 + h01 * y1 + h11 * h * m1
        s_of_t = jnp.exp(log_s)
        s_of_t = jnp.where(T_safe <= t[0], s[0] * T_safe / t[0], s_of_t)
        s_of_t = jnp.where(T_safe >= t[-1], s[-1], s_of_t)
        mu = self.mu_at(s_of_t, kin)
        return jnp.where(positive, mu, self.mu_d)


@eqx.filter_jit
def _evaluate(law: MicrosqueezeStatic, T1):
    # jitted so that eager calls compile once; inlined when called inside an outer jit
    return law._evaluate(T1)


@eqx.filter_jit
def _unchecked_kinematics(law: MicrosqueezeStatic) -> Kinematics:
    return law.kinematics(check=False)


@eqx.filter_jit
def _mu_at(law: MicrosqueezeStatic, a):
    return static_coefficient(law.pair, law.contact, a, law.t_b)


class MicrosqueezeSolution(eqx.Module):
    """Output of `microsqueeze_curve`: `stick_time` (s), `approach` (mm), `mu_0` (-),
    the diffrax `result` code (`diffrax.RESULTS.successful` when the solve succeeded) and
    `num_steps` accepted by the adaptive solver."""

    stick_time: Float[Array, " n"]
    approach: Float[Array, " n"]
    mu_0: Float[Array, " n"]
    result: diffrax.RESULTS
    num_steps: Array


def _rhs(tau, s, law_kin):
    law, kin = law_kin
    return jnp.exp(tau) / law.dt_ds(s, kin)


@eqx.filter_jit
def microsqueeze_curve(law: MicrosqueezeStatic, stick_time: Float[ArrayLike, " n"], *,
                       rtol: float = 1e-10, atol: float = 1e-12, max_steps: int = 4096,
                       adjoint: diffrax.AbstractAdjoint | None = None) -> MicrosqueezeSolution:
    r"""$\mu_0(T_1)$ of the microsqueeze model by integrating eq (28) with diffrax.

    Integrates the log-gap $s$ against $\tau = \log t$ (Tsit5, PID control with
    `rtol`/`atol` on s) from $t_0 = 10^{-8}\,dt/ds(0)$ (where $s = 10^{-8}$, the motion
    is linear before it) and saves at the requested stick times (s; any order,
    $T_1 = 0$ gives $\mu_d$). Differentiable through the solve with respect to every
    field of `law` (reverse mode by default; pass `adjoint=diffrax.ForwardMode()` for
    `jax.jacfwd`, cheaper to compile for a few parameters). A solver failure is
    reported in `result`, not hidden.
    """
    T1 = jnp.atleast_1d(jnp.asarray(stick_time, dtype=float))
    kin = law.kinematics()
    rate0 = law.dt_ds(jnp.zeros(()), kin)
    s0 = 1e-8
    t0 = s0 * rate0
    order = jnp.argsort(T1)
    Ts = T1[order]
    tau_save = jnp.log(jnp.maximum(Ts, t0))
    tau0 = jnp.log(t0)
    tau1 = jnp.maximum(tau_save[-1], tau0 + 1.0)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(_rhs), diffrax.Tsit5(), t0=tau0, t1=tau1, dt0=None,
        y0=jnp.asarray(s0), args=(law, kin), saveat=diffrax.SaveAt(ts=tau_save),
        stepsize_controller=diffrax.PIDController(rtol=rtol, atol=atol),
        max_steps=max_steps, throw=False,
        adjoint=diffrax.RecursiveCheckpointAdjoint() if adjoint is None else adjoint)
    s_sorted = jnp.where(Ts < t0, Ts / rate0, sol.ys)
    s_out = jnp.empty_like(s_sorted).at[order].set(s_sorted)
    a = law.approach(s_out, kin)
    mu = jnp.where(T1 > 0, law.mu_at(s_out, kin), law.mu_d)
    a = jnp.where(T1 > 0, a, kin.a_d)
    return MicrosqueezeSolution(T1, a, mu, sol.result, sol.stats["num_accepted_steps"])
