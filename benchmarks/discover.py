"""Benchmark: discovery on campaigns of the independent generator, time split by step.

    .venv/bin/python benchmarks/discover.py [--base cycle|smooth] [--small] [--effect NAME]
                                            [--cold-only] [--campaign NAME ...]
                                            [--scaling samples|cycles] [--quick]
                                            [--cache DIR]

`--base cycle` (default, the per-cycle model of `stickslip discover`): campaigns from the
independent SciPy generator (`tests/independent_records.py`; 3 (W, k) x 4 speeds, noise
0.5 um), `discover_cycles` timed by stage, compilation included (a fresh process), each
against its target (the ratio printed), with the machine's load and the CPU seconds of
every stage (the process's, all its threads: on a machine shared with other jobs the
wall-clock time grows with the load, the CPU time much less), its calls of the model
and their seconds, and JAX's compilation seconds (`_Spent`):

- `damping`: lubricant A, about 7 cycles per record at 2 kHz (0.5 M samples), a damping
  ratio of 0.1 hidden; with a second, warm run of the same campaign in the same process
  (run time alone) and one warm `fit --objective trace` of it as the baseline (unless
  `--cold-only`). Target 60 s;
- `screw`: lubricant A with a 6 um lead-screw error (2 mm pitch), 0.5 M samples;
- `drift_c`: lubricant C with long sticks (26 cycles at 4 kHz: 1.7 M samples) and a
  friction drift (mu_s -1e-4/s, mu_d -5e-5/s);
- `two`: two effects at once (a damping ratio of 0.1 and a 4 um screw error), 0.4 M
  samples. Target 120 s each (the small one, `--small`: 30 s).

`--campaign` picks them (default `damping`; `all`: the four). `--scaling samples`: the
screw campaign at 0.25, 0.5, 1 and 2 M samples (the sampling rate 1, 2, 4, 8 kHz, the
cycles fixed), `--scaling cycles`: at about 0.5 M samples with 3.5, 7 and 14 cycles per
record (the rate halved as the cycles double), each in a fresh process (cold); printed
as a table of wall and CPU times and their ratios to the first row (target: flat in
samples within 1.5x, judged on the CPU time). `--small`: every campaign and scaling row
with 4 records (2 (W, k) x 2 speeds); `--quick`: 4 records and the scaling's first two
rows only. `--cache DIR`: JAX's persistent compilation cache and the stored programs in
DIR, as the `stickslip` command keeps them (`stickslip_jax.cli.compilation_cache_dir`):
a second run on a campaign of the same layout loads the compiled programs instead of
compiling them (a user's later campaigns), the first fills DIR.

The cost rests on: the sticks binned to the statistics the model needs (`thinning`: a
window's cost grows with its events, not with its samples), far from the data the refits
stopped once they cannot win (`refit.CANNOT_WIN`; by the Gauss-Newton decrease left,
`subproblems.HOPE`, or by their recent pace over the budget left, `subproblems.PACE`),
or not made where their start already says so (`refit.cannot_win`: the sensor's refit
and its program), a close refit that is restarted continued only where no restart
improves it, in a later search only the leading refit continued and restarted
(`sharpen`), the compressed Jacobian (an
evaluation's last tangent block 4 wide where its tangents fit, `cycle_model.BLOCK`), the
stick terms compiled into the sparse form's programs only (`CycleModel._stick`: 38 % of
an evaluation and half of a program's compilation without them), the
FFT sensor kernel, the vectorised pitch scan, a window's slip solved once for all its
rows and rendered at its unpadded samples only, the weights as one compiled program, the host Levenberg-Marquardt update in NumPy,
and the model's programs compiled in a warm-up thread while the campaign is prepared:
three of them (the Jacobian block without and with the sensor kernel, whose spectrum is
computed once per record; the sensor's residuals; the other residuals run the Jacobian
block with a zero tangent block), with XLA's classic CPU emitter (`fit.COMPILER_OPTIONS`);
the sensor's Jacobian block only once a refit with the sensor may come (`CycleModel.warm`),
the 4-wide block once 64 evaluations of 9-12 tangents padded their last call (screw
refits: about 9 s CPU to compile, each such evaluation then 8 + 4 tangents, not 16).
Run with `JAX_LOG_COMPILES=1` to see each program's compilation time.

`--base smooth`, the whole-record workflow:
Builds a synthetic campaign (lubricant A, 3 (W, k) x 4 speeds, 3 cycles per record,
500 Hz, noise 0.5 um) with a hidden effect (default viscous damping, c = 0.01
kgf*s/mm), runs `stickslip_fitting.discovery.discover` and prints the time of every step
(compilation included: the first evaluation of the compiled residual/Jacobian function
happens in `base_fit`). The baseline in the same process is one evaluation of the
campaign's residuals and Jacobian after compilation, so the table also reads as
"workflow cost in Jacobian evaluations". `--small`: a 4-record campaign.
Target: the 12-record workflow under 5 minutes.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))


def _load() -> str:
    with open("/proc/loadavg") as fh:
        return "load " + " ".join(fh.read().split()[:3]) + f" on {os.cpu_count()} cores"


def _cache(path):
    """The `stickslip` command's persistent compilation cache and program store in
    `path` (module doc, `--cache`); None: off."""
    if path:
        import jax
        from jax.experimental.compilation_cache import compilation_cache

        from stickslip_jax import stored_programs

        jax.config.update("jax_compilation_cache_dir", path)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
        stored_programs.use(os.path.join(path, "programs"))
        compilation_cache.reset_cache()


def campaigns():
    """name -> (description, generator keywords, target s)."""
    import independent_records as ir

    P, I = ir.Physics, ir.Imperfections  # noqa: E741
    screw = I(screw_amp_mm=0.006, screw_pitch_mm=2.0)
    return {
        "damping": ("lubricant A, damping ratio 0.1", dict(
            friction=ir.LUBRICANT_A, physics=P(damping_ratio=0.1), seed=5, cycles=7.0,
            rate_hz=2000.0), 60.0),
        "screw": ("lubricant A, 6 um lead-screw error", dict(
            friction=ir.LUBRICANT_A, imp=screw, seed=3, cycles=7.0, rate_hz=2000.0), 120.0),
        "drift_c": ("lubricant C, long sticks, friction drift", dict(
            friction=ir.LUBRICANT_C, physics=P(drift_mu_s=-1e-4, drift_mu_d=-5e-5), seed=7,
            cycles=26.0, rate_hz=4000.0), 120.0),
        "two": ("lubricant A, damping ratio 0.1 and a 4 um screw error", dict(
            friction=ir.LUBRICANT_A, physics=P(damping_ratio=0.1),
            imp=I(screw_amp_mm=0.004, screw_pitch_mm=2.0), seed=9, cycles=6.0,
            rate_hz=2000.0), 120.0),
    }


def _make(kw, small):
    import independent_records as ir

    kw = dict(kw)
    friction = kw.pop("friction")
    if small:
        kw.update(runs=ir.RUNS[:2], speeds=(5.0, 10.0))
    return ir.campaign(friction, **kw)


class _Spent:
    """Since the last stage line: the model's calls from the discovery's thread (Jacobian
    blocks and residuals, `CycleModel.evaluate` / `residuals`: their number and wall
    seconds) and JAX's compilation (tracing, lowering, XLA; wall seconds in any thread,
    the warm-up thread's included). Installed once per process."""

    calls, call_s, compile_s = 0, 0.0, 0.0
    _on = False

    @classmethod
    def install(cls):
        if cls._on:
            return
        import threading

        import jax

        from stickslip_fitting.discovery.cycle_model import CycleModel

        def timed(fn):
            def call(*a, **k):
                if threading.current_thread() is not threading.main_thread():
                    return fn(*a, **k)
                t = time.perf_counter()
                try:
                    return fn(*a, **k)
                finally:
                    cls.calls += 1
                    cls.call_s += time.perf_counter() - t
            return call

        def compiled(event, seconds, **_):
            if event.startswith("/jax/core/compile/"):
                cls.compile_s += seconds

        CycleModel.evaluate = timed(CycleModel.evaluate)
        CycleModel.residuals = timed(CycleModel.residuals)
        jax.monitoring.register_event_duration_secs_listener(compiled)
        cls._on = True

    @classmethod
    def take(cls) -> tuple[int, float, float]:
        out = cls.calls, cls.call_s, cls.compile_s
        cls.calls, cls.call_s, cls.compile_s = 0, 0.0, 0.0
        return out


def _discover(recs, label, progress=True):
    """(result, wall seconds, CPU seconds, CPU seconds by stage) of one discovery, its
    stage lines printed with their CPU seconds, the model's calls and the compilation
    (`_Spent`). CPU time is the process's, every thread (the compilation thread too): on
    a machine shared with other jobs it is the figure that does not grow with the load."""
    from stickslip_fitting.discovery.cycle_workflow import discover_cycles

    cpu = {}
    last = [time.process_time()]
    _Spent.install()
    _Spent.take()

    def line(text):  # a stage's line: "name: what it found (s)"
        now = time.process_time()
        stage, spent = text.split(":")[0], now - last[0]
        cpu[stage] = cpu.get(stage, 0.0) + spent
        last[0] = now
        calls, call_s, compile_s = _Spent.take()
        if progress:
            print(f"  {label}: {text} [{spent:.1f} s CPU; {calls} model calls "
                  f"{call_s:.1f} s, compiling {compile_s:.1f} s]", flush=True)

    t, c = time.perf_counter(), time.process_time()
    res = discover_cycles(recs, progress=line)
    return res, time.perf_counter() - t, time.process_time() - c, cpu


def _answer(res) -> str:
    return (f"{res.effect} ({res.confidence}); gap {res.gap_before * 1e3:.3f} -> "
            f"{res.gap_after * 1e3:.3f} um, noise {res.noise * 1e3:.3f} um")


def cycle(args):
    from stickslip_fitting.data.campaign import screen_records
    from stickslip_fitting.modes import Objective
    from stickslip_fitting.solve.fit import fit_features

    table = campaigns()
    names = list(table) if "all" in args.campaign else args.campaign
    small = args.small or args.quick
    for name in names:
        what, kw, target = table[name]
        target = 30.0 if small else target
        t = time.perf_counter()
        recs = _make(kw, small)
        n = sum(r.n_samples for r in recs)
        print(f"campaign {name}: {len(recs)} records, {n} samples, {what}; made in "
              f"{time.perf_counter() - t:.1f} s (independent generator); {_load()}",
              flush=True)
        res, total, cpu, by_stage = _discover(recs, name)
        print(f"answer: {_answer(res)}; {_load()}")
        if name == "damping" and not args.cold_only:
            warm = _discover(recs, name, progress=False)[0].timings
            c = screen_records(recs)
            t = time.perf_counter()
            fit_features(c.features, records=c.records, objective=Objective.TRACE)
            t_fit = time.perf_counter() - t
            print(f"{'stage':12s} {'cold s':>9s} {'x trace fit':>12s} {'warm s':>9s}")
            for k, v in res.timings.items():
                print(f"{k:12s} {v:9.1f} {v / t_fit:12.1f} {warm.get(k, float('nan')):9.1f}")
            print(f"{'trace fit':12s} {t_fit:9.1f} {1.0:12.1f}  (fit --objective trace, warm)")
        else:
            print("  ".join(f"{k} {v:.1f}" for k, v in res.timings.items()))
        print("CPU s: " + "  ".join(f"{k} {v:.1f}" for k, v in by_stage.items()))
        print(f"{name}: {total:.1f} s cold ({cpu:.1f} s CPU), {total / target:.2f} x the "
              f"target of {target:.0f} s: {'met' if total < target else 'MISSED'}",
              flush=True)


def _timed(kw, small, cache=None):
    """(samples, windows, seconds, CPU seconds, answer) of one discovery (run in a fresh
    process; `cache`: `--cache`)."""
    _cache(cache)
    recs = _make(kw, small)
    res, total, cpu, _ = _discover(recs, "", progress=False)
    return (sum(r.n_samples for r in recs), int(res.model.data.window.max()) + 1, total,
            cpu, _answer(res))


def scaling(args):
    """Discovery time against samples (the rate) or cycles (module doc); every row cold,
    in a fresh process."""
    import concurrent.futures
    import multiprocessing

    _, kw, _ = campaigns()["screw"]
    if args.scaling == "samples":
        rows = [(f"{r / 1000:g} kHz", dict(kw, rate_hz=r)) for r in (1000, 2000, 4000, 8000)]
    else:
        rows = [(f"{c:g} cycles", dict(kw, cycles=c, rate_hz=2000.0 * 7.0 / c))
                for c in (3.5, 7.0, 14.0)]
    rows = rows[:2] if args.quick else rows
    out = []
    for label, kw_ in rows:
        with concurrent.futures.ProcessPoolExecutor(
                1, mp_context=multiprocessing.get_context("spawn")) as pool:
            n, windows, total, cpu, answer = pool.submit(
                _timed, kw_, args.small or args.quick, args.cache).result()
        out.append((label, n, windows, total, cpu))
        print(f"{label}: {n} samples, {windows} windows, {total:.1f} s ({cpu:.1f} s CPU); "
              f"{answer}; {_load()}", flush=True)
    print(f"{'':14s} {'samples':>9s} {'windows':>8s} {'seconds':>8s} {'ratio':>6s} "
          f"{'CPU s':>8s} {'ratio':>6s}")
    for label, n, w, s_, c in out:
        print(f"{label:14s} {n:9d} {w:8d} {s_:8.1f} {s_ / out[0][3]:6.2f} {c:8.1f} "
              f"{c / out[0][4]:6.2f}")
    worst = max(c for *_, c in out) / out[0][4]
    if args.scaling == "samples":
        print(f"largest / smallest CPU time: {worst:.2f} (target <= 1.5 over "
              f"{out[-1][1] / out[0][1]:.1f}x the samples): {'met' if worst <= 1.5 else 'MISSED'}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", choices=("cycle", "smooth"), default="cycle")
    ap.add_argument("--small", action="store_true", help="4 records instead of 12")
    ap.add_argument("--effect", default="viscous_damping")
    ap.add_argument("--cold-only", action="store_true",
                    help="(--base cycle) skip the second, warm run of the workflow")
    ap.add_argument("--campaign", nargs="+", default=["damping"],
                    choices=("damping", "screw", "drift_c", "two", "all"))
    ap.add_argument("--scaling", choices=("samples", "cycles"),
                    help="the time against samples or cycles (instead of --campaign)")
    ap.add_argument("--quick", action="store_true",
                    help="4 records, and the scaling's first two rows only")
    ap.add_argument("--cache", metavar="DIR",
                    help="the stickslip command's persistent compilation cache in DIR")
    args = ap.parse_args(argv)
    _cache(args.cache)
    if args.base == "cycle":
        return scaling(args) if args.scaling else cycle(args)

    from stickslip_fitting.discovery import discover
    from stickslip_fitting.discovery.synthetic import hidden_effect_campaign
    from stickslip_jax.lubricants import lubricant

    sizes = {"viscous_damping": {"c": 0.01}, "stribeck": {"b": 0.005},
             "drive_periodic_error": {"a_sin": 4e-4, "a_cos": 2e-4},
             "sensor_lowpass": {"time_constant": 2e-3}, "friction_drift": {"rate": 1e-3},
             "gauge_drift": {"rate": 2e-3}, "load_coupling": {"kappa": 0.2},
             "rate_state": {"b": 0.005}}
    kw = {}
    if args.small:
        kw = dict(conditions=((36.0, 86.9), (12.4, 40.0)), speed_fractions=(0.26, 0.36))
    t = time.perf_counter()
    recs = hidden_effect_campaign(lubricant("A"), effect=args.effect,
                                  values=sizes[args.effect], seed=5, **kw)
    t_make = time.perf_counter() - t
    res = discover(recs)
    t = time.perf_counter()
    for _ in range(3):
        res.base_problem.evaluate(res.base_fit.z)
    t_eval = (time.perf_counter() - t) / 3
    n = sum(r.n_samples for r in recs)
    print(f"campaign: {len(recs)} records, {n} samples, hidden {args.effect}; "
          f"made in {t_make:.1f} s")
    print(f"answer: {res.effect} ({res.confidence}); gap {res.gap_before * 1e3:.3f} -> "
          f"{res.gap_after * 1e3:.3f} um, noise {res.noise * 1e3:.3f} um")
    print(f"{'step':20s} {'seconds':>9s} {'x one evaluation':>17s}")
    for k, v in res.timings.items():
        print(f"{k:20s} {v:9.1f} {v / t_eval:17.1f}")
    print(f"{'one evaluation':20s} {t_eval:9.2f} {1.0:17.1f}  (residuals + Jacobian, "
          "baseline)")
    print(f"base fit evaluations: {res.base_fit.n_evals} (converged: "
          f"{res.base_fit.converged}); chosen model's fit: {res.final_fit.n_evals} "
          f"(converged: {res.final_fit.converged}); target total < 300 s: "
          f"{'met' if res.timings['total'] < 300 else 'MISSED'}")


if __name__ == "__main__":
    main()
