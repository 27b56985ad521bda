r"""Bridge between the microsqueeze model and the empirical law, eq (1).

The paper (Figs 82, 84, 95) fits $\mu_0 = \mu_s - (\mu_s - \mu_d)\exp(-\gamma T_1^m)$ to
theoretical $\mu_0 \sim T_1$ curves to read how $\mu_s$, $\gamma$ and $m$ depend on
$t_b$, $\eta$ and $\xi_1\xi_2$. `fit_kato` does that by least squares on a log-spaced
grid of stick times (default 0.01-1000 s, the range of Figs 66 and 76), keeping
$\mu_d$ equal to the law's and fitting $(\mu_s, \log\gamma, \log m)$ with the
project's one least-squares verb (`stickslip_jax.lsq.least_squares`). It is jit/vmap
safe (vmap over a batch of laws gives the trend curves in one call).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, Float

from ..friction import AbstractStaticFriction, KatoStatic
from ..lsq import least_squares

Scalar = Float[Array, ""]


class KatoFit(eqx.Module):
    """Result of `fit_kato`: the fitted `KatoStatic` law, the RMS residual in mu over the
    grid, and the optimistix `result` code."""

    law: KatoStatic
    rms: Scalar
    result: optx.RESULTS


def default_stick_times(n: int = 41, lo: float = 1e-2, hi: float = 1e3) -> Array:
    """Log-spaced stick times (s) used by `fit_kato`."""
    return jnp.geomspace(lo, hi, n)


@eqx.filter_jit
def fit_kato(law: AbstractStaticFriction, stick_time: Float[Array, " n"] | None = None, *,
             rtol: float = 1e-10, atol: float = 1e-12, max_steps: int = 256,
             fix_mu_s: bool = False) -> KatoFit:
    r"""Fit eq (1), $(\mu_s, \gamma, m)$ with $\mu_d$ = `law.mu_d`, to `law` on `stick_time`
    (s, default `default_stick_times()`). Returns a `KatoFit` (dimensionless mu_s, m;
    gamma in s$^{-m}$). With `fix_mu_s=True`, $\mu_s$ is held at `law.asymptote()` (the
    theoretical $\mu_0(T_1 \to \infty)$) and only $\gamma$, $m$ are fitted."""
    T1 = default_stick_times() if stick_time is None else jnp.asarray(stick_time, dtype=float)
    target = law(T1)
    mu_d = jnp.asarray(law.mu_d, dtype=float)

    mu_inf = jnp.asarray(law.asymptote(), dtype=float)

    def model(p):
        mu_s = mu_inf if fix_mu_s else p[0]
        return KatoStatic(mu_s=mu_s, mu_d=mu_d, gamma=jnp.exp(p[1]), m=jnp.exp(p[2]))

    def residual(p, _):
        return model(p)(T1) - target

    # start: mu_s from the last point; gamma from the time of half rise; m = 0.5
    mu_end = target[-1]
    half = mu_d + 0.5 * (mu_end - mu_d)
    T_half = jnp.exp(jnp.interp(half, target, jnp.log(T1)))
    m0 = 0.5
    gamma0 = jnp.log(2.0) / T_half**m0
    p0 = jnp.stack([mu_inf if fix_mu_s else mu_end, jnp.log(gamma0), jnp.log(m0)])
    sol = least_squares(residual, p0, rtol=rtol, atol=atol, max_steps=max_steps)
    fitted = model(sol.params)
    rms = jnp.sqrt(jnp.mean(residual(sol.params, None) ** 2))
    return KatoFit(law=fitted, rms=rms, result=sol.result)
