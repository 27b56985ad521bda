"""`stickslip steady`: steady stick-slip amplitude, frequency and critical speed (chapter 5)."""

from __future__ import annotations

import math

from .options import add_json_option, add_lubricant_options, add_slideway_options, quantity

NAME = "steady"
HELP = "steady stick-slip (eqs 5-7, 12) for a paper lubricant at given W, k and drive speeds"


def add_arguments(p):
    add_lubricant_options(p)
    add_slideway_options(p)
    p.add_argument("--speed", type=quantity("speed", "mm/min"), nargs="+", required=True,
                   help="drive speeds v (mm/min unless a unit is given, e.g. '10 um/s')")
    p.add_argument("--tolerance", type=quantity("length", "mm"), default=None,
                   help="also print the drive speed above which the time-domain limit "
                   "cycle's amplitude stays below this (mm unless a unit is given, e.g. "
                   "'1 um')")
    p.add_argument("--damping-ratio", type=float, default=None, metavar="ZETA",
                   help="also print the limit cycle with viscous damping ratio ZETA "
                   "(0 <= ZETA < 1, of the slider's own mode; e.g. 0.05): its amplitude, T1 "
                   "and f/f0, and the sharp boundary speed above which the damped model "
                   "slides steadily (stickslip_jax.limit_cycle.boundary_speed), beside eq "
                   "(12)'s v_c")
    add_json_option(p, "the results", bare=True)


JSON_ALIASES = {
    "drive_speed_mm_per_min": "speed_mm_min",
    "stiffness_kgf_per_mm": "stiffness_kgf_mm",
    "critical_speed_mm_per_min": "critical_speed_mm_min",
    "amplitude_ratio": "ak_over_W",
    "frequency_ratio": "f_over_f0",
    "max_amplitude_mm": "amplitude_mm",  # tolerance.amplitude_mm (results keep amplitude_mm)
}
"""JSON keys renamed to the one convention (`stickslip_jax.output.UNIT_SUFFIXES`) ->
their old names, still written beside them for one release (`deprecated_keys`)."""

COLUMNS = (("drive_speed_mm_per_min", "v [mm/min]"), ("stick_slip", "stick-slip"),
           ("stick_time_s", "T1 [s]"), ("slip_time_s", "T2 [s]"), ("amplitude_mm", "a [mm]"),
           ("amplitude_ratio", "ak/W [-]"), ("frequency_hz", "f [Hz]"),
           ("frequency_ratio", "f/f0 [-]"), ("critical_speed_mm_per_min", "v_c [mm/min]"),
           ("cycle_amplitude_mm", "a_cycle [mm]"), ("cycle_stick_time_s", "T1_cycle [s]"))

DAMPED_COLUMNS = (("damped_cycle_amplitude_mm", "a_damped [mm]"),
                  ("damped_cycle_stick_time_s", "T1_damped [s]"),
                  ("damped_cycle_frequency_ratio", "f/f0_damped [-]"))
"""Columns added by --damping-ratio: the damped limit cycle (0 above the boundary)."""


def _tolerance_speed(friction, args, out, s: float) -> float:
    """The drive speed (mm/min) above which the limit cycle's amplitude stays below
    --tolerance: 0 when it does at every speed (the amplitude at a speed far below v_c,
    the largest, is within it); a ValueError naming the option when it is not found.
    `s` = N/W: the cycle under the normal load N is the cycle at v/s, lengths times s."""
    import optimistix as optx

    from ..limit_cycle import limit_cycle, tolerance_speed
    from ..units import mm_per_min

    slow = 1e-6 * float(out.critical_speed[0])
    top = float(limit_cycle(friction, args.weight, args.stiffness, slow,
                            normal_load=args.normal_load).amplitude)
    if args.tolerance >= top:
        return 0.0
    try:
        v_tol, result = tolerance_speed(friction, args.weight, args.stiffness,
                                        args.tolerance / s)
    except Exception as exc:  # noqa: BLE001 - the solver's runtime error, said as the option's
        raise ValueError(f"--tolerance {args.tolerance:g} mm: no drive speed found "
                         f"({str(exc).splitlines()[0][:80]})") from None
    v = s * float(mm_per_min(v_tol))
    if result != optx.RESULTS.successful or not math.isfinite(v):
        raise ValueError(f"--tolerance {args.tolerance:g} mm: no drive speed found (the "
                         "solver did not converge from eq (12)'s v_c); give a larger "
                         f"tolerance (the largest amplitude is {top:.4g} mm)")
    return v


def run(args) -> int:
    import jax.numpy as jnp

    from ..lubricants import lubricant, lubricants
    from ..output import check_outputs
    from ..steady import REGIMES, RESTICK_FAILURE, steady_state
    from ..units import mm_per_min

    check_outputs({"--json": args.json})
    zeta = args.damping_ratio
    if zeta is not None and not 0 <= zeta < 1:
        raise ValueError(f"--damping-ratio: must lie in [0, 1), e.g. 0.05, got {zeta}")
    if args.lubricant not in lubricants(args.table):
        raise ValueError(f"--lubricant: unknown lubricant {args.lubricant!r}; "
                         f"Table {args.table} has {', '.join(lubricants(args.table))}")
    friction = lubricant(args.lubricant, table=args.table)
    load = args.normal_load
    # N/W for boundary_speed and tolerance_speed (no normal load): under N the motion at v
    # is the paper's (N = W) at v/s with lengths and speeds times s
    s = 1.0 if load is None else load / args.weight
    speeds = jnp.asarray(args.speed)
    import jax

    from ..limit_cycle import limit_cycle

    def each(law, **kw):  # `law` under the normal load at every drive speed
        return jax.vmap(lambda v: law(friction, args.weight, args.stiffness, v,
                                      normal_load=load, **kw))(speeds)

    out, cyc = each(steady_state), each(limit_cycle)
    rows = []
    for i, v in enumerate(args.speed):
        rows.append({
            "drive_speed_mm_per_min": mm_per_min(v),
            "regime": REGIMES[int(out.regime[i])],
            "stick_slip": bool(out.stick_slip[i]),
            "stick_time_s": float(out.stick_time[i]),
            "slip_time_s": float(out.slip_time[i]),
            "amplitude_mm": float(out.amplitude[i]),
            "amplitude_ratio": float(out.amplitude_ratio[i]),
            "frequency_hz": float(out.frequency[i]),
            "frequency_ratio": float(out.frequency_ratio[i]),
            "critical_speed_mm_per_min": float(mm_per_min(out.critical_speed[i])),
            # the time-domain model's limit cycle (fixed point of the one-cycle map)
            "cycle_amplitude_mm": max(0.0, float(cyc.amplitude[i])),  # no -1e-18 round-off
            "cycle_stick_time_s": float(cyc.stick_time[i]),
            "cycle_slip_time_s": float(cyc.slip_time[i]),
            "cycle_frequency_hz": float(cyc.frequency[i])})
    damped = None
    if zeta is not None:
        from ..limit_cycle import boundary_speed

        f0 = out.natural_frequency[0]
        dc = each(limit_cycle, damping_ratio=zeta)
        for i, r in enumerate(rows):  # 0 where the damped model slides steadily
            r.update({"damped_regime": REGIMES[int(dc.regime[i])],
                      "damped_cycle_amplitude_mm": max(0.0, float(dc.amplitude[i])),
                      "damped_cycle_stick_time_s": float(dc.stick_time[i]),
                      "damped_cycle_slip_time_s": float(dc.slip_time[i]),
                      "damped_cycle_frequency_hz": float(dc.frequency[i]),
                      "damped_cycle_frequency_ratio": float(dc.frequency[i] / f0)})
        # inf (no boundary: zeta = 0) becomes null with its reason in the JSON
        damped = s * float(mm_per_min(boundary_speed(friction, args.weight, args.stiffness,
                                                     zeta)))
    tol = None
    if args.tolerance is not None:
        tol = {"max_amplitude_mm": args.tolerance,
               "drive_speed_mm_per_min": _tolerance_speed(friction, args, out, s)}
    if args.json:
        from ..output import versioned, write_json

        write_json(args.json, versioned({
            "lubricant": args.lubricant,
            "table": args.table,
            "weight_kgf": args.weight,
            **({} if load is None else {"normal_load_kgf": load}),
            "stiffness_kgf_per_mm": args.stiffness,
            "natural_frequency_hz": float(out.natural_frequency[0]),
            "results": rows,
            "tolerance": tol,
            **({} if zeta is None else {"damping_ratio": zeta,
                                        "boundary_speed_mm_per_min": damped})}, JSON_ALIASES))
        if args.json != "-":  # with "-" the table below goes to stderr
            print(f"wrote {args.json}")
    print(f"lubricant {args.lubricant} (Table {args.table}), W = {args.weight:g} kgf, "
          + ("" if load is None else f"N = {load:g} kgf, ")
          + f"k = {args.stiffness:g} kgf/mm, f0 = {float(out.natural_frequency[0]):.4g} Hz")
    columns = COLUMNS + (DAMPED_COLUMNS if zeta is not None else ())
    widths = [max(len(h), 12) for _, h in columns]
    print("  ".join(h.rjust(w) for (_, h), w in zip(columns, widths)))
    for r in rows:
        cells = []
        for (key, _), w in zip(columns, widths):
            val = r[key]
            if key == "stick_slip" and r["regime"] == REGIMES[RESTICK_FAILURE]:
                val = "double"  # re-stick failure: see the note below
            elif isinstance(val, bool):
                val = "yes" if val else "no"
            cells.append((val if isinstance(val, str) else "-" if val is None
                          else f"{val:.5g}").rjust(w))
        print("  ".join(cells))
    print("a_cycle, T1_cycle: the limit cycle of the time-domain model (the exact "
          "simulator's; eq (6) at every speed): above v_c of eq (12) it keeps a smaller "
          "stick-slip, with no sharp end (stickslip_jax.limit_cycle)")
    if zeta is not None:
        v_c = rows[0]["critical_speed_mm_per_min"]
        where = (f"stick-slip ends sharply above v = {damped:.5g} mm/min (the boundary speed)"
                 if math.isfinite(damped) else
                 "no boundary speed (a limit cycle at every speed, as without damping)")
        print(f"damping ratio zeta = {zeta:g} (a_damped, T1_damped, f/f0_damped: its limit "
              f"cycle, 0 where it slides steadily): {where}; eq (12)'s v_c = {v_c:.5g} mm/min")
    if tol is not None:
        v_tol = tol["drive_speed_mm_per_min"]
        print(f"the limit cycle's amplitude stays below {tol['max_amplitude_mm'] * 1e3:.4g} um "
              + ("at every drive speed" if v_tol == 0.0 else f"above v = {v_tol:.5g} mm/min"))
    if any(int(r) == RESTICK_FAILURE for r in out.regime):
        print("double: re-stick failure, a slip ends with the spring force above mu_d W (exp(-delta "
              "T2^n) > 1/2), so the slider slips again at once (double slips); eqs (5)-(6) "
              "do not describe that motion, its amplitude and T1 above are not the motion's")
    return 0
