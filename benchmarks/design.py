"""Benchmark: design maps (stickslip_fitting.design) with the steady analysis and the exact simulator.

1. A 1,000,000-point steady map (`design_map`, eqs 5-7 and 12) over random W, k, v and
   friction parameters (lubricant A's parameters, each perturbed per point: a map over a
   posterior-like sample), timed after compilation, points/s.
2. A 10,000-point map with the exact event-driven simulator (`method="exact"`: eight
   stick-slip cycles per point (N_CYCLES), the last one taken as the limit cycle), after
   compilation, points/s.
3. The same model with a SciPy event-driven baseline written here (closed-form stick,
   `brentq` for the breakaway, `solve_ivp` (DOP853) with a stop event for each slip),
   over a subset of the same points, run in this process: points/s, the speed ratio
   and the agreement of the limit-cycle amplitudes.
4. Processes: a 100,000-point map (`--process-method`, default `exact`: the event-driven
   simulator, the costliest kernel; `cycle` and `steady` cost so little per point that
   the all-gather dominates) in 1 and in 2 CPU processes on localhost joined by
   `jax.distributed` (`stickslip_jax.distributed.initialize`; each process runs
   `benchmarks/design_worker.py`, the map split over both processes' devices and
   all-gathered, as in tests/test_distributed.py), points/s after compilation, the
   parallel efficiency rate_2 / (2 rate_1), and a projection for N hosts.

    python benchmarks/design.py            # full size
    python benchmarks/design.py --small    # smoke run (10^4 steady, 500 exact, 10 SciPy,
                                           # 5,000 points per process run)
    python benchmarks/design.py --no-processes   # parts 1-3 only
"""

from __future__ import annotations

import argparse
import json
import math
import socket
import subprocess
import sys
import time
from pathlib import Path

import jax
import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import stickslip_jax as ss
from stickslip_fitting.design import design_map, friction_from_params, friction_params
from stickslip_fitting.design.exact import N_CYCLES
from stickslip_jax.steady import RESTICK_FAILURE, STEADY_SLIDING, STICK_SLIP
from stickslip_jax.units import G_MM_S2, from_mm_per_min


def points(n, seed=0, spread=0.1):
    """n random design points: W 10-60 kgf, k 20-150 kgf/mm, v 0.01-60 mm/min (log), and
    lubricant A's parameters times exp(spread * N(0, 1))."""
    rng = np.random.default_rng(seed)
    w = rng.uniform(10.0, 60.0, n)
    k = rng.uniform(20.0, 150.0, n)
    v = from_mm_per_min(10 ** rng.uniform(-2.0, math.log10(60.0), n))
    p = friction_params(ss.lubricant("A"))
    p = {name: x * np.exp(spread * rng.standard_normal(n)) for name, x in p.items()}
    return friction_from_params(p), w, k, v


def scipy_limit_cycle(p, W, k, v, n_cycles=N_CYCLES):
    """(amplitude in mm, regime) of the last of `n_cycles` cycles of the paper's model,
    SciPy events; the regime as `stickslip_jax.steady.REGIMES` indexes it.

    Start at rest with x = 0. Stick: x = x_s + v tau until k x = W mu_0(tau) (eq 1),
    solved with brentq. Slip: M y'' = k (x_b + v t - y) - mu_m W (eq 2 with eq 3 at
    T2 = pi/omega0), integrated by solve_ivp until the slider velocity returns to 0.
    If the spring force is then above mu_d W (re-stick failure) the slider slips again at
    once from rest with mu_d; the re-slip belongs to the same cycle (as in the exact map),
    whose amplitude runs from the breakaway to the end of the last slip.
    """
    mu_s, mu_d, gamma, m, delta, n = (p[q] for q in ("mu_s", "mu_d", "gamma", "m", "delta", "n"))
    M = W / G_MM_S2
    omega = math.sqrt(k / M)
    t2 = math.pi / omega
    x_s, amp, regime = 0.0, 0.0, STEADY_SLIDING

    def mu0(tau):
        return mu_d + (mu_s - mu_d) * -math.expm1(-gamma * tau**m) if tau > 0 else mu_d

    def slip(x_b, mum):
        """Deflection where a slip from rest at deflection x_b under mum ends: the root of
        the slider's velocity between its maximum and its minimum (events on the
        acceleration; a velocity event alone misses the shallow crossing of a small
        re-slip, whose velocity dips below zero by ~ (omega d)^2 / v)."""

        def rhs(t, z):
            return [z[1], (k * (x_b + v * t - z[0]) - mum * W) / M]

        def accel(t, z):
            return rhs(t, z)[1]

        def fastest(t, z):
            return accel(t, z)

        fastest.direction = -1
        accel.terminal, accel.direction = True, 1  # the velocity's minimum
        sol = solve_ivp(rhs, (0.0, 4 * t2), [0.0, 0.0], method="DOP853", rtol=1e-10,
                        atol=1e-13, events=[fastest, accel], first_step=t2 * 1e-3,
                        dense_output=True)
        t_max, t_min = sol.t_events[0][0], sol.t_events[1][0]
        if sol.sol(t_min)[1] > 0:
            return None  # the slider does not stop
        t_end = brentq(lambda t: sol.sol(t)[1], t_max, t_min, xtol=1e-15, rtol=1e-15)
        return x_b + v * t_end - sol.sol(t_end)[0]

    for _ in range(n_cycles):
        hi = (mu_s * W / k - x_s) / v + 1e-12
        tau = brentq(lambda t, x_s=x_s: k * (x_s + v * t) - W * mu0(t), 0.0, hi,
                     xtol=1e-14, rtol=1e-14)
        x_b = x_s + v * tau
        m0 = mu0(tau)
        x_s = slip(x_b, mu_d + (m0 - mu_d) * math.exp(-delta * t2**n))
        regime = STICK_SLIP
        for _ in range(4):  # re-slips from rest with mu_d while k x > mu_d W
            if x_s is None or k * x_s <= mu_d * W:
                break
            x_s, regime = slip(x_s, mu_d), RESTICK_FAILURE
        if x_s is None or k * x_s > mu_d * W:
            return 0.0, STEADY_SLIDING  # the slider does not stop
        amp = 0.5 * (x_b - x_s)
    return amp, regime


def timed(fn, repeat):
    best = math.inf
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def free_port() -> int:
    """A free TCP port on localhost (the jax.distributed coordinator of part 4)."""
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def process_rate(n_processes, n_points, method, repeat):
    """Points/s of a `n_points` map computed by `n_processes` local CPU processes joined by
    `jax.distributed` (benchmarks/design_worker.py), after compilation: n_points over the
    slowest process's best time. Returns (rate, seconds, checksum, cores kept busy by all
processes together)."""
    worker = Path(__file__).with_name("design_worker.py")
    port = str(free_port())
    procs = [subprocess.Popen([sys.executable, str(worker), str(i), str(n_processes), port,
                               str(n_points), method, str(repeat)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for i in range(n_processes)]
    outs = [p.communicate(timeout=1800) for p in procs]
    runs = []
    for p, (out, err) in zip(procs, outs):
        if p.returncode != 0:
            raise RuntimeError(f"design_worker.py failed:\n{err[-3000:]}")
        runs.append(json.loads(out.strip().splitlines()[-1]))
    seconds = max(r["seconds"] for r in runs)
    return n_points / seconds, seconds, runs[0]["checksum"], sum(r["cores_busy"] for r in runs)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--small", action="store_true", help="quick smoke run")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--chunk-size", type=int, default=262_144)
    ap.add_argument("--process-method", default="exact", choices=("steady", "exact", "cycle"),
                    help="map method of the 1- and 2-process runs (default exact)")
    ap.add_argument("--no-processes", action="store_true",
                    help="leave out part 4 (the 1- and 2-process runs)")
    ap.add_argument("--hosts", default="1,2,4,8,16,64",
                    help="host counts of the projection (comma-separated)")
    args = ap.parse_args(argv)
    n_steady, n_exact, n_scipy = (10_000, 500, 10) if args.small else (1_000_000, 10_000, 200)
    print(f"devices: {jax.devices()}")

    f, w, k, v = points(n_steady)
    chunk = min(args.chunk_size, n_steady)
    design_map(f, w, k, v, chunk_size=chunk)  # compile
    t_steady, m = timed(lambda: design_map(f, w, k, v, chunk_size=chunk), args.repeat)

    fe, we, ke, ve = points(n_exact, seed=1)
    chunk_e = min(args.chunk_size, n_exact)
    design_map(fe, we, ke, ve, method="exact", chunk_size=chunk_e)  # compile
    t_exact, mx = timed(lambda: design_map(fe, we, ke, ve, method="exact", chunk_size=chunk_e),
                        args.repeat)

    params = friction_params(fe)
    t = time.perf_counter()
    ref, ref_regime = np.array([scipy_limit_cycle({q: float(x[i]) for q, x in params.items()},
                                                  we[i], ke[i], ve[i])
                                for i in range(n_scipy)]).T
    t_scipy = time.perf_counter() - t
    sub = np.asarray(mx.amplitude[:n_scipy])
    both = (ref > 0) & (sub > 0)
    rel = np.max(np.abs(sub[both] - ref[both]) / ref[both]) if both.any() else float("nan")
    agree = np.mean(ref_regime == np.asarray(mx.regime[:n_scipy]))
    n_double = int(np.sum(ref_regime == RESTICK_FAILURE))

    rate_s, rate_e, rate_ref = n_steady / t_steady, n_exact / t_exact, n_scipy / t_scipy
    print(f"{'map':<36}{'points':>10}{'time [s]':>11}{'points/s':>12}")
    print(f"{'steady (jit+vmap, chunked)':<36}{n_steady:>10}{t_steady:>11.3f}{rate_s:>12.4g}")
    print(f"{'exact simulator (jit+vmap)':<36}{n_exact:>10}{t_exact:>11.3f}{rate_e:>12.4g}")
    print(f"{'SciPy event-driven baseline':<36}{n_scipy:>10}{t_scipy:>11.3f}{rate_ref:>12.4g}")
    print(f"exact map / SciPy speed ratio: {rate_e / rate_ref:.0f}x")
    print(f"stick-slip in {np.mean(m.stick_slip) * 100:.1f} % (steady), "
          f"{np.mean(mx.stick_slip) * 100:.1f} % (exact) of the points; converged: "
          f"{int(m.converged.sum())}/{n_steady} (steady), {int(mx.converged.sum())}/{n_exact} "
          "(exact: last two cycles within 1e-3)")
    print(f"SciPy vs exact map on {n_scipy} points ({n_double} with re-stick failure): same "
          f"regime {agree * 100:.0f} %, max relative amplitude difference {rel:.2e}")

    if args.no_processes:
        return
    # 4. the same map in 1 and 2 processes joined by jax.distributed (localhost)
    n_proc_points = 5_000 if args.small else 100_000
    rate1, t1, sum1, cores1 = process_rate(1, n_proc_points, args.process_method, args.repeat)
    rate2, t2, sum2, cores2 = process_rate(2, n_proc_points, args.process_method, args.repeat)
    eff = rate2 / (2.0 * rate1)
    print(f"\n{args.process_method} map across processes (jax.distributed, CPU, localhost; "
          f"{n_proc_points} points, after compilation):")
    import os

    print(f"{'processes':<36}{'points':>10}{'time [s]':>11}{'points/s':>12}"
          f"{'cores busy':>12}")
    print(f"{'1':<36}{n_proc_points:>10}{t1:>11.3f}{rate1:>12.4g}{cores1:>12.2f}")
    print(f"{'2':<36}{n_proc_points:>10}{t2:>11.3f}{rate2:>12.4g}{cores2:>12.2f}")
    print(f"(cores busy: CPU time / wall time of the map, all processes; this machine has "
          f"{os.cpu_count()} cores: where one process already keeps them busy (XLA runs "
          "the vmapped kernel on several threads), a second process on the same cores cannot "
          "add speed; a second host adds its own cores)")
    print(f"speed-up 2 / 1: {rate2 / rate1:.2f}x, parallel efficiency {eff * 100:.0f} %; "
          f"same map: {'yes' if sum1 == sum2 else 'NO'} (amplitude sums {sum1!r}, {sum2!r})")
    print("projection for N hosts (assumption: each host adds one process's rate times the "
          "measured 2-process efficiency, rate_N = N rate_1 eff; the all-gather of the "
          "result is taken to stay as cheap as on localhost, so this is an upper bound for "
          "maps whose points cost less than the network):")
    print(f"{'hosts':<36}{'points/s':>12}")
    for n in (int(x) for x in args.hosts.split(",")):
        print(f"{n:<36}{(rate1 if n == 1 else n * rate1 * eff):>12.4g}")


if __name__ == "__main__":
    main()
