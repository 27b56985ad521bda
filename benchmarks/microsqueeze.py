"""Benchmark: microsqueeze mu_0(T1) curves (eq 28) in JAX/diffrax against SciPy LSODA.

Cases (lubricant A, S1G1, Table 11), timed after compilation:
1. one curve on 200 log-spaced stick times (0.01-1000 s);
2. a batch of N (h_e, Q) pairs (default 1000) on the same grid: `jax.vmap` of the
   diffrax solve, and of the tabulated `MicrosqueezeStatic.__call__`;
baseline: `scipy.integrate.solve_ivp(method="LSODA")` on da/dt (eq 28 with eq 13) in a
Python loop, rtol 1e-8. Prints times, speed-up ratios and the largest |mu_0| difference.

    python benchmarks/microsqueeze.py [--small] [--pairs N]
"""

from __future__ import annotations

import argparse
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from scipy.integrate import solve_ivp

import stickslip_jax  # noqa: F401  (x64)
from stickslip_jax.contact import MicrosqueezeStatic, microsqueeze_curve


def best_of(fn, repeat):
    out, best = None, np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        out = jax.block_until_ready(fn())
        best = min(best, time.perf_counter() - t)
    return out, best


_kinematics = eqx.filter_jit(lambda law: law.kinematics())


def scipy_inputs(law: MicrosqueezeStatic) -> tuple[float, ...]:
    """Plain floats for the SciPy baseline (computed outside the timed loop)."""
    kin = _kinematics(law)
    c = law.contact
    return tuple(
        float(v) for v in (kin.K, kin.a_d, c.W, c.p_m, c.C1, c.C2, c.C3, law.t_b, law.h_e, law.eta, law.Q)
    )


def scipy_curve(inputs: tuple[float, ...], T: np.ndarray) -> np.ndarray:
    """Reference: integrate da/dt = W_s(a) (h_e - t_b - a)^3 / (eta Q) with LSODA."""
    K, a_d, W, p_m, C1, C2, C3, t_b, h_e, eta, Q = inputs

    def rhs(t, y):
        a = y[0]
        W_s = W - p_m * K * ((1 - C2) * a**3 + C2 * (a + t_b) ** 3)
        return [W_s * max(h_e - t_b - a, 0.0) ** 3 / (eta * Q)]

    sol = solve_ivp(rhs, (0.0, T[-1]), [a_d], method="LSODA", t_eval=T, rtol=1e-8, atol=1e-15)
    a = sol.y[0]
    return (C1 * p_m * K * a**3 + C3 * C2 * p_m * K * ((a + t_b) ** 3 - a**3)) / W


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--small", action="store_true", help="quick smoke run (50 pairs)")
    ap.add_argument("--pairs", type=int, default=None, help="batch size (default 1000, 50 with --small)")
    args = ap.parse_args(argv)
    n_pairs = args.pairs or (50 if args.small else 1000)
    repeat = 2 if args.small else 3

    T = jnp.geomspace(0.01, 1000.0, 200)
    Tn = np.asarray(T)
    base = MicrosqueezeStatic.from_table11("A")
    rng = np.random.default_rng(0)
    h_e = jnp.asarray(rng.uniform(0.83e-3, 0.95e-3, n_pairs))  # h_e > t_b + a_s = 0.818e-3
    Q = jnp.asarray(rng.uniform(5.0, 150.0, n_pairs))
    batch = jax.vmap(lambda h, q: eqx.tree_at(lambda m: (m.h_e, m.Q), base, (h, q)))(h_e, Q)

    one = jax.jit(lambda law: microsqueeze_curve(law, T, rtol=1e-8, atol=1e-10).mu_0)
    many = jax.jit(jax.vmap(lambda law: microsqueeze_curve(law, T, rtol=1e-8, atol=1e-10).mu_0))
    many_fast = jax.jit(jax.vmap(lambda law: law(T)))
    one(base).block_until_ready(), many(batch).block_until_ready(), many_fast(batch).block_until_ready()

    mu_one, t_one = best_of(lambda: one(base), repeat * 5)
    mu_many, t_many = best_of(lambda: many(batch), repeat)
    mu_fast, t_fast = best_of(lambda: many_fast(batch), repeat)

    inputs_one = scipy_inputs(base)
    t = time.perf_counter()
    ref_one = scipy_curve(inputs_one, Tn)
    t_sp_one = time.perf_counter() - t
    inputs = [scipy_inputs(eqx.tree_at(lambda m: (m.h_e, m.Q), base, (h_e[i], Q[i]))) for i in range(n_pairs)]
    t = time.perf_counter()
    ref_many = np.stack([scipy_curve(inp, Tn) for inp in inputs])
    t_sp_many = time.perf_counter() - t

    rows = [
        ("one curve, 200 T1", "diffrax (jit)", t_one, t_sp_one, np.max(np.abs(np.asarray(mu_one) - ref_one))),
        (f"{n_pairs} (h_e, Q), 200 T1", "diffrax (vmap)", t_many, t_sp_many, np.max(np.abs(np.asarray(mu_many) - ref_many))),
        (f"{n_pairs} (h_e, Q), 200 T1", "tabulated law (vmap)", t_fast, t_sp_many, np.max(np.abs(np.asarray(mu_fast) - ref_many))),
    ]
    print(f"device: {jax.devices()[0].platform}; SciPy baseline: solve_ivp LSODA in a loop, rtol 1e-8")
    print(f"{'case':<26} {'method':<22} {'jax [s]':>10} {'scipy [s]':>10} {'speed-up':>9} {'max|dmu|':>9}")
    for case, method, tj, ts, err in rows:
        print(f"{case:<26} {method:<22} {tj:10.4g} {ts:10.4g} {ts / tj:8.1f}x {err:9.1e}")


if __name__ == "__main__":
    main()
