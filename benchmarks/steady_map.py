"""Benchmark: a (W, k, v) map of the steady stick-slip amplitude and v_c (chapter 5).

JAX: `jit(vmap(steady_state))` over N points (default 100 x 100 x 100 = 1,000,000), timed
after compilation (best of `--repeat`). Baseline, in the same process: a Python loop of
SciPy `brentq` on eq (6) + the corrected eq (12) over a random subset (default 10,000
points). Prints a table with the per-point time ratio (wall, and CPU time of this
process, every thread: on a shared machine the CPU times vary less) and the agreement on
the subset.

    python benchmarks/steady_map.py            # full size
    python benchmarks/steady_map.py --small    # quick smoke run (10^4 map, 500 brentq)
"""

from __future__ import annotations

import argparse
import math
import time

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from scipy.optimize import brentq

import stickslip_jax as ss
from stickslip_jax.units import G_MM_S2, from_mm_per_min


def scipy_point(W, k, v, p):
    """Amplitude (mm) and v_c (mm/s) at one point from eq (6)/(12), solved with brentq."""
    mu_s, mu_d, gamma, m, delta, n = p
    t0 = math.pi * math.sqrt(W / (G_MM_S2 * k))
    kin = -math.expm1(-delta * t0**n)

    def rhs(t1):
        return (mu_s - mu_d) * -math.expm1(-gamma * t1**m) * kin

    vc = 2 * W / (k * t0) * rhs(t0)
    if v >= vc:
        return 0.0, vc
    t1 = brentq(lambda t: k * v * t / (2 * W) - rhs(t), t0, 2 * W * (mu_s - mu_d) / (k * v),
                xtol=1e-300, rtol=4 * np.finfo(float).eps)
    return v * t1 / 2, vc


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--small", action="store_true", help="10^4-point map, 500 brentq points")
    ap.add_argument("--lubricant", default="A", choices=("A", "C"))
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    side, n_ref = (22, 500) if args.small else (100, 10_000)

    friction = ss.lubricant(args.lubricant)
    s, kin = friction.static, friction.kinetic
    p = tuple(float(x) for x in (s.mu_s, s.mu_d, s.gamma, s.m, kin.delta, kin.n))
    w = np.linspace(5.0, 60.0, side)  # kgf
    k = np.linspace(20.0, 140.0, side)  # kgf/mm
    v = from_mm_per_min(np.geomspace(0.0022, 92.0, side))  # mm/s, Table 1 range
    W, K, V = (x.ravel() for x in np.meshgrid(w, k, v, indexing="ij"))
    n = W.size

    @jax.jit
    def amp_vc(friction, W, K, V):
        def one(W, K, V):
            r = ss.steady_state(friction, W, K, V)
            return r.amplitude, r.critical_speed, r.result == optx.RESULTS.successful

        return jax.vmap(one)(W, K, V)

    Wj, Kj, Vj = jnp.asarray(W), jnp.asarray(K), jnp.asarray(V)
    t = time.perf_counter()
    jax.block_until_ready(amp_vc(friction, Wj, Kj, Vj))
    t_compile = time.perf_counter() - t
    times = []
    for _ in range(args.repeat):
        t, c = time.perf_counter(), time.process_time()
        a, vc, res = jax.block_until_ready(amp_vc(friction, Wj, Kj, Vj))
        times.append((time.perf_counter() - t, time.process_time() - c))
    t_jax, c_jax = min(times)
    a, vc, res = np.asarray(a), np.asarray(vc), np.asarray(res)

    idx = np.random.default_rng(0).choice(n, size=n_ref, replace=False)
    t, c = time.perf_counter(), time.process_time()
    ref = np.array([scipy_point(W[i], K[i], V[i], p) for i in idx])
    t_ref, c_ref = time.perf_counter() - t, time.process_time() - c

    stick = ref[:, 0] > 0
    err_a = np.max(np.abs(a[idx][stick] - ref[stick, 0]) / ref[stick, 0])
    err_vc = np.max(np.abs(vc[idx] - ref[:, 1]) / ref[:, 1])
    assert np.all(a[idx][~stick] == 0.0)

    per_jax, per_ref = t_jax / n, t_ref / n_ref
    print(f"steady map, lubricant {args.lubricant}: W 5-60 kgf x k 20-140 kgf/mm x "
          f"v 0.0022-92 mm/min; {jax.devices()[0].platform}, x64")
    print(f"{'method':<28}{'points':>10}{'total [s]':>12}{'per point [us]':>16}{'ratio':>8}"
          f"{'CPU [s]':>10}{'CPU ratio':>11}")
    print(f"{'scipy brentq loop':<28}{n_ref:>10,}{t_ref:>12.3f}{per_ref * 1e6:>16.3f}{1.0:>8.1f}"
          f"{c_ref:>10.3f}{1.0:>11.1f}")
    print(f"{'jax jit(vmap) (compiled)':<28}{n:>10,}{t_jax:>12.3f}{per_jax * 1e6:>16.4f}"
          f"{per_ref / per_jax:>8.1f}{c_jax:>10.3f}{(c_ref / n_ref) / (c_jax / n):>11.1f}")
    print(f"compile {t_compile:.2f} s; stick-slip at {np.mean(a > 0):.1%} of points; "
          f"non-converged {int(np.sum(~res))}")
    print(f"agreement on the subset: max rel. error a {err_a:.1e}, v_c {err_vc:.1e}")
    if not args.small:
        print(f"target: full map < 2 s -> {'met' if t_jax < 2.0 else 'NOT met'} ({t_jax:.3f} s "
              f"wall, {c_jax:.3f} s CPU)")


if __name__ == "__main__":
    main()
