# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 08 Rotational rigs and a normal load of their own
#
# Many stick-slip rigs turn instead of slide: a motor drives a flexible shaft (torsional
# stiffness $k_t$) whose end, of moment of inertia $J$, rubs on a stator at the friction
# radius $R$ under a normal load $N$ set by a dead weight or a spring, not by the
# inertia. Divided by $R$, its equation $J\ddot\theta = k_t(\varphi - \theta) - \mu N R$
# is the paper's slideway with $x = R\theta$, $k = k_t/R^2$, $M = J/R^2$ and the friction
# force $\mu N$ (`stickslip_jax.rigs`). Here the same campaign is written twice, once as a
# linear rig's records (mm, kgf/mm, kgf) and once in the torsional rig's own units (deg,
# N*m/rad, kg*m^2, N, rpm), read, fitted and reported: the answers are the same.

# %%
import os
import tempfile
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np

import stickslip_jax as ss
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.records import read_campaign, write_record
from stickslip_jax.rigs import rig_quantities, rotational_record
from stickslip_jax.simulation import pad_times, simulate_exact
from stickslip_jax.units import G_MM_S2, KGF_N
from stickslip_fitting.data.campaign import screen_records
from stickslip_fitting.data.synthetic import truth_values
from stickslip_fitting.modes import Padding
from stickslip_fitting.solve.fit import fit_features
from stickslip_fitting.uncertainty.laplace import laplace

SMALL = os.environ.get("STICKSLIP_SMALL") == "1"
FIG = Path(os.environ.get("STICKSLIP_FIGDIR", "notebooks/figures"))
FIG.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## The rig and its linear twin
#
# A shaft end of $J$ = 6e-4 kg m^2 rubbing at $R$ = 20 mm under $N$ = 40 N, with three
# shafts of 0.3, 0.6 and 1.2 N m/rad (natural frequencies of 22 to 45 rad/s), each run at
# two motor speeds below the critical speed. Lubricant A's friction laws (Table 6).

# %%
friction = ss.lubricant("A")
R, J, N_newton = 20.0, 6e-4, 40.0                 # mm, kg*m^2, N
k_t = (0.3, 0.6, 1.2)                              # N*m/rad
W = J * 1e6 / R ** 2                               # kgf: M = J/R^2 in kg weighs M kgf
N = N_newton / KGF_N                               # kgf
ks = [kt * 1e3 / KGF_N / R ** 2 for kt in k_t]     # kgf/mm
print(f"equivalent slideway: W = {W:.3g} kgf (inertia), N = {N:.3g} kgf (friction), "
      f"k = {', '.join(f'{k:.3g}' for k in ks)} kgf/mm")
print("natural frequencies [rad/s]:",
      ", ".join(f"{np.sqrt(G_MM_S2 * k / W):.1f}" for k in ks))


@eqx.filter_jit
def simulate(ks, vs, x0s, ts, mask):
    def one(k, v, x0, t, m):
        return simulate_exact(ss.Slideway(friction, W, k, normal_load=N), ConstantSpeed(v),
                              t, initial_deflection=x0, mask=m, max_events=40)

    return jax.vmap(one)(ks, vs, x0s, ts, mask)


plan, rate, rng = [], 500.0, np.random.default_rng(0)
for k in ks:
    for frac in ((0.05, 0.3) if SMALL else (0.03, 0.1, 0.3)):
        v = frac * float(ss.critical_speed(friction, W, k, N))
        st = ss.steady_state(friction, W, k, v, normal_load=N)
        x1 = (2 * float(st.mu_m) - float(st.mu_0)) * N / k   # slip end, eq (5) with N
        n = int((4 if SMALL else 6) * float(st.stick_time + st.slip_time) * rate) + 1
        plan.append((k, v, x1 - 1e-9, n))
times = [np.arange(p[3]) / rate for p in plan]
ts, mask = pad_times(times)
col = lambda i: jnp.asarray([p[i] for p in plan])  # noqa: E731
x = np.asarray(simulate(col(0), col(1), col(2), ts, mask).deflection)
noise = 0.02                                        # mm at the friction radius (1 mrad)
linear, rotational = [], []
for i, (k, v, _, n) in enumerate(plan):
    xi = x[i, :n] + rng.normal(0.0, noise, n)
    linear.append(ss.records.Record(time=times[i], deflection=xi, stiffness=k, weight=W,
                                    normal_load=N, drive_speed=v, lubricant="A",
                                    source=f"lin{i}.csv"))
    rotational.append(rotational_record(
        times[i], np.degrees(xi / R), angle_unit="deg",
        torsional_stiffness=f"{k * R ** 2 * KGF_N / 1e3!r} N*m/rad", inertia=f"{J!r} kg*m^2",
        normal_load=f"{N_newton!r} N", friction_radius=f"{R!r} mm",
        drive_speed=f"{v / R * 30 / np.pi!r} rpm", lubricant="A", source=f"rot{i}.csv"))

# %% [markdown]
# ## Two files per run
#
# The rotational file states the rig in its own units: the twist angle in degrees, the
# shaft's torsional stiffness, the inertia, the normal load, the friction radius and the
# motor speed in rpm. `write_record` writes the equivalent linear quantities and keeps the
# friction radius, so the file reads back exactly.

# %%
folder = Path(tempfile.mkdtemp())
rig_text = ("# stickslip-record: 1\n# friction_radius: 20 mm\n"
            f"# torsional_stiffness: {k_t[0]} N*m/rad\n# inertia: {J} kg*m^2\n"
            f"# normal_load: {N_newton} N\n"
            f"# drive_speed: {plan[0][1] / R * 30 / np.pi!r} rpm\n# lubricant: A\n"
            "time [s],angle [deg]\n"
            + "".join(f"{float(t)!r},{float(a)!r}\n"
                      for t, a in zip(times[0], np.degrees(linear[0].deflection / R))))
(folder / "rig0.csv").write_text(rig_text)
print(rig_text[:330], "...")
for i, rec in enumerate(linear):
    write_record(rec, folder / f"linear{i}.csv")
read_lin = read_campaign(sorted(folder.glob("linear*.csv")))
from_rig = read_campaign(folder / "rig0.csv")[0]
print("the rig's file reads as its linear twin:",
      np.allclose(from_rig.deflection, read_lin[0].deflection, rtol=1e-12),
      f"k = {from_rig.stiffness:.6g} kgf/mm, W = {from_rig.weight:.6g} kgf, "
      f"N = {from_rig.load:.6g} kgf")
print("in the rig's units:", {k: round(v, 6) for k, v in rig_quantities(from_rig).items()})

# %% [markdown]
# ## The same analysis on both rigs
#
# Screening, cycle extraction and the fit of eqs (1) and (3) run on the equivalent linear
# records; the friction coefficients and times do not depend on the coordinates.

# %%
fits = {}
for name, recs in (("linear", linear), ("rotational", rotational)):
    campaign = screen_records(recs)
    fit = fit_features(campaign.features, padding=Padding(cycles=8))
    fits[name] = (campaign, fit, laplace(fit))
print(f"{'':8s} {'linear':>22s} {'rotational':>22s}   truth")
truth = truth_values(friction)
for a, b in zip(fits["linear"][2].estimates(), fits["rotational"][2].estimates()):
    print(f"{a.name:8s} {a.value:10.4g} +- {a.stderr or 0:<9.2g} "
          f"{b.value:10.4g} +- {b.stderr or 0:<9.2g} {truth[a.name]:8.4g}")
va, vb = fits["linear"][1].values, fits["rotational"][1].values
print("largest relative difference between the two fits:",
      f"{max(abs(va[k] - vb[k]) / abs(va[k]) for k in va):.1e}")

# %% [markdown]
# ## Results in the rig's units
#
# Lengths come back as angles at the friction radius and friction forces as torques about
# the shaft: the breakaway torque $\mu_s N R$, the kinetic torque $\mu_d N R$, the noise of
# the angle sensor and each record's conditions (`rig_quantities`, also in the `fit`
# command's JSON screening).

# %%
campaign, fit, unc = fits["rotational"]
rig = rotational[0].rig
v = fit.values
print(f"breakaway torque mu_s N R = {v['mu_s'] * N_newton * R / 1e3:.4f} N*m, "
      f"kinetic torque mu_d N R = {v['mu_d'] * N_newton * R / 1e3:.4f} N*m")
print(f"angle noise {np.degrees(rig.to_rig(campaign.features[0].noise, 'length')) * 1e3:.3g} "
      f"mdeg (simulated {np.degrees(noise / R) * 1e3:.3g})")
for s in campaign.screening[:3]:
    row = s.to_json()
    print(f"{s.name}: k_t {row['torsional_stiffness_n_m_per_rad']:.3g} N*m/rad, "
          f"J {row['inertia_kg_m2']:.3g} kg*m^2, N {row['normal_load_kgf'] * KGF_N:.3g} N, "
          f"motor {row['drive_speed_rad_per_s']:.3g} rad/s, {s.complete_cycles} cycles")

# %%
fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.6))
r0 = rotational[0]
a1.plot(r0.time, np.degrees(rig.to_rig(r0.deflection, "length")), lw=0.8)
a1.set_xlabel("time [s]")
a1.set_ylabel("shaft twist [deg]")
a1.set_title("a rotational record in its own units")
for name, marker, colour in (("linear", "o", "C0"), ("rotational", "x", "C1")):
    t1s = np.concatenate([f.stick_time for f in fits[name][0].features])
    mu0 = np.concatenate([f.mu_0 for f in fits[name][0].features])
    a2.plot(t1s, mu0, marker, ms=5, mfc="none", color=colour, label=f"{name} rig")
t1 = np.logspace(-2, 1.5, 100)
a2.plot(t1, np.asarray(fits["rotational"][1].params.friction.friction().static(t1)), "k-",
        lw=1, label="fitted eq (1)")
a2.set_xscale("log")
a2.set_xlabel("stick time T1 [s]")
a2.set_ylabel("mu_0 = k x2 / N")
a2.legend()
fig.tight_layout()
fig.savefig(FIG / "08_rotational_rigs.png", dpi=90)
