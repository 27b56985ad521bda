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
# # 06 Pitching and yawing of the slider with stick-slip (chapter 6)
#
# The spring force $F = kx$ acts at the drive point, height $h$ above the slide surface and
# offset $l$ from the centre of gravity, while the friction resultant acts at the neutral
# points $h_{Mv}$, $l_{Mh}$. The moments $F(h - h_{Mv})$ and $F(l - l_{Mh})$ tilt the
# slider through a compliance; the squeeze of the lubricant makes the tilt lag the moment
# with a time constant proportional to the viscosity. One linear model, driven by the
# spring-force history, gives the rise $\varepsilon_u$ during the stick and the recovery
# $\varepsilon_d$ after the slip (section 6.3).
#
# The slider here is `default_model()`: **illustrative** parameters with the layout of
# Fig 42 (the paper's figures are lost, so nothing below is fitted to them). What the
# notebook shows is the paper's *trends* and where they come from.

# %%
import os
from pathlib import Path

import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np

import stickslip_jax as ss
from stickslip_jax import pitching as pt
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.simulation import simulate_exact

SMALL = os.environ.get("STICKSLIP_SMALL") == "1"
FIGDIR = Path(os.environ.get("STICKSLIP_FIGDIR", Path("notebooks") / "figures"))
FIGDIR.mkdir(parents=True, exist_ok=True)

friction = ss.lubricant("A")
W, K = jnp.asarray(36.0), jnp.asarray(86.9)  # Table 1: W2, k2
model = pt.default_model()
D = pt.PAPER_DRIVE_POINTS
speeds_mm_min = np.geomspace(0.01, 45.0, 8 if SMALL else 30)
speeds = jnp.asarray(speeds_mm_min / 60.0)  # mm/s
UM = 1e3  # mm -> um


def save(fig, name):
    fig.tight_layout()
    fig.savefig(FIGDIR / f"06_{name}.png", dpi=100)


# %% [markdown]
# ## Fig 47: one record, the static line $\varepsilon_s$ and the lagging tilt
# The exact simulator gives the spring force; the tilt at point 1 follows the static line
# only slowly, recovers after each drop, and climbs again with the next stick.

# %%
slideway = ss.Slideway(friction, W, K)
ts = jnp.linspace(0.0, 12.0, 601 if SMALL else 2401)
x = simulate_exact(slideway, ConstantSpeed(3.0 / 60), ts).deflection
tr = pt.tilt_history(model, ts, K * x, D["C2"])
lever1 = float(model.points.positions[0] - model.pitch.pivot)
fig, ax = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
ax[0].plot(ts, K * x, "k")
ax[0].set_ylabel("spring force F [kgf]")
ax[1].plot(ts, UM * tr.static_pitch * lever1, "--", label=r"$\varepsilon_s$ (no lag)")
ax[1].plot(ts, UM * tr.displacement[:, 0], label="point 1 (lagged)")
ax[1].set(xlabel="time [s]", ylabel="vertical displacement [um]")
ax[1].legend()
save(fig, "fig47_record")

# %% [markdown]
# ## Figs 48-49: $\varepsilon'$ and $\Delta\varepsilon$ against speed for C1, C2, C3
# $\varepsilon'$ falls with speed because $F_0 = \mu_0(T_1) W$ falls as the stick shortens
# (eq 1) and the lag keeps the slider from reaching it; $\Delta\varepsilon$ falls faster,
# because the lag filters the swing once the cycle is short against $\tau$. $v_p$ (where
# $\Delta\varepsilon < 5\%$ of $\varepsilon'$) lies well below $v_0 = v_c$, where the
# stick-slip ends. C1 lies below $M_v$: its tilt is reversed and small.

# %%
fig, ax = plt.subplots(1, 2, figsize=(10, 4))
for name in ("C1", "C2", "C3"):
    s = pt.tilt_against_speed(model, friction, W, K, speeds, D[name])
    for i, mk in ((0, "-"), (2, "--")):
        ax[0].semilogx(speeds_mm_min, UM * s.points.peak[:, i], mk, label=f"{name} point {i + 1}")
    ax[1].semilogx(speeds_mm_min, UM * s.points.variation[:, 0], label=f"{name} point 1")
crit = pt.critical_pitch_speed(model, friction, W, K, D["C2"])
for a in ax:
    a.axvline(60 * float(crit.v_0), color="grey", ls=":", label="$v_0 = v_c$")
ax[1].axvline(60 * float(crit.v_p), color="r", ls=":", label="$v_p$ (C2)")
ax[0].set(xlabel="v [mm/min]", ylabel=r"$\varepsilon'$ [um]")
ax[1].set(xlabel="v [mm/min]", ylabel=r"$\Delta\varepsilon$ [um]")
ax[0].legend(fontsize=7)
ax[1].legend(fontsize=7)
save(fig, "fig48_49_speed")
print(f"v_p = {60 * float(crit.v_p):.3g} mm/min, v_0 = {60 * float(crit.v_0):.3g} mm/min")

# %% [markdown]
# ## Fig 51: viscosity
# Same friction law (lubricant A), viscosities of Table 7's oils scaled from A's; the time
# constant grows with $\eta$. $\Delta\varepsilon$ drops much more than $\varepsilon'$. (The
# paper's lubricants also differ in friction, which moves $v_0$ and so $v_p$; that part is
# not in this comparison.)

# %%
fig, ax = plt.subplots(1, 2, figsize=(10, 4))
for name, cst in (("A1", 54), ("A2", 195), ("A3", 460), ("C", 1010)):
    m = model.with_viscosity(pt.ETA_A * cst / 195.4)
    s = pt.tilt_against_speed(m, friction, W, K, speeds, D["C2"])
    ax[0].semilogx(speeds_mm_min, UM * s.points.peak[:, 0], label=f"{name} ({cst} cSt)")
    ax[1].semilogx(speeds_mm_min, UM * s.points.variation[:, 0], label=f"{name} ({cst} cSt)")
ax[0].set(xlabel="v [mm/min]", ylabel=r"$\varepsilon'$ [um]")
ax[1].set(xlabel="v [mm/min]", ylabel=r"$\Delta\varepsilon$ [um]")
ax[1].legend()
save(fig, "fig51_viscosity")

# %% [markdown]
# ## Figs 52-53: against drive height, with $F_0$ as parameter
# Linear in $h - h_{Mv}$, zero at $M_v$, reversed below it; larger for larger $F_0$ (the
# three slider weights of Table 1 at their stiffnesses).

# %%
heights = jnp.linspace(0.0, 80.0, 17)
v03 = jnp.asarray([0.3 / 60])
fig, ax = plt.subplots(1, 2, figsize=(10, 4))
for w, k in ss.experimental_conditions():
    tm = pt.variation_map(model, friction, jnp.asarray(w), jnp.asarray(k), v03, heights)
    f0 = float(pt.steady_force_cycle(friction, w, k, v03[0]).f0)
    ax[0].plot(heights, UM * tm.peak[0], label=f"F0 = {f0:.1f} kgf")
    ax[1].plot(heights, UM * tm.variation[0], label=f"F0 = {f0:.1f} kgf")
for a in ax:
    a.axvline(float(model.pitch.neutral), color="grey", ls=":")
    a.set_xlabel("drive height h [mm]")
ax[0].set_ylabel(r"$\varepsilon'$ point 1 [um]")
ax[1].set_ylabel(r"$\Delta\varepsilon$ point 1 [um]")
ax[0].legend()
save(fig, "fig52_53_height")

# %% [markdown]
# ## Figs 54-56: the rise $\varepsilon_u$ and the recovery $\varepsilon_d$
# $\varepsilon_u$ against the spring force lies below the static line, more so at higher
# speed (faster force rise $kv$) and higher viscosity; $\varepsilon_d$ takes longer to
# recover as the viscosity rises.

# %%
fig, ax = plt.subplots(1, 2, figsize=(10, 4))
lag = model.pitch.lag
gain = float(model.pitch.compliance * (D["C2"].height - model.pitch.neutral)) * lever1 * UM
f_end = 12.0
for v_mm_min in (0.3, 3.0, 30.0):
    rate = float(K) * v_mm_min / 60.0  # kgf/s
    t = jnp.linspace(0.0, f_end / rate, 200)
    ax[0].plot(rate * t, gain * pt.rise_curve(lag, rate, t), label=f"v = {v_mm_min} mm/min")
ax[0].plot([0, f_end], [0, gain * f_end], "k--", label=r"$\varepsilon_s$")
ax[0].set(xlabel="spring force F [kgf]", ylabel=r"$\varepsilon_u$ point 1 [um]")
ax[0].legend()
t = jnp.linspace(0.0, 8.0, 200)
for name, cst in (("A1", 54), ("A2", 195), ("C", 1010)):
    ax[1].plot(t, gain * pt.recovery_curve(lag, 5.0, t, cst / 195.4), label=name)
ax[1].set(xlabel="time after the drop [s]", ylabel=r"$\varepsilon_d$ point 1 [um]")
ax[1].legend()
save(fig, "fig54_56_rise_recovery")

# %% [markdown]
# ## Figs 60-62: yawing
# Points 4 and 5 move in opposite directions; the yaw lag is long (weak sideways restoring
# moment), so $\Delta\varepsilon$ is much smaller than $\varepsilon'$. $\varepsilon'$ is
# proportional to $l - l_{Mh}$ and changes sign at $M_h$.

# %%
fig, ax = plt.subplots(1, 2, figsize=(10, 4))
for name in ("V", "C2", "F"):
    s = pt.tilt_against_speed(model, friction, W, K, speeds, D[name])
    ax[0].semilogx(speeds_mm_min, UM * s.points.peak[:, 3], label=f"{name} point 4")
    ax[0].semilogx(speeds_mm_min, UM * s.points.variation[:, 3], ":",
                   label=rf"{name} $\Delta\varepsilon$")
ax[0].set(xlabel="v [mm/min]", ylabel="yaw displacement [um]")
ax[0].legend(fontsize=7)
offsets = jnp.linspace(-40.0, 40.0, 9)
ymap = pt.variation_map(model, friction, W, K, v03, offsets, point="yaw_4")
ax[1].plot(offsets, UM * ymap.peak[0], "o-")
ax[1].axvline(float(model.yaw.neutral), color="grey", ls=":", label="$M_h$")
ax[1].axhline(0.0, color="k", lw=0.5)
ax[1].set(xlabel="drive offset l [mm]", ylabel=r"$\varepsilon'$ point 4 [um]")
ax[1].legend()
save(fig, "fig60_62_yaw")

# %% [markdown]
# ## Fig 63 and design: the drive point of least tilt, and a map of $\Delta\varepsilon$
# `best_drive_point` projects $(h_{Mv}, l_{Mh})$ onto the feasible box (C1* of the paper);
# there the moments vanish and so does the tilt at every speed.

# %%
best = pt.best_drive_point(model, height_range=(20.0, 70.0), offset_range=(-40.0, 40.0))
print(f"C1* = (h, l) = ({float(best.drive.height):.3g}, {float(best.drive.offset):.3g}) mm")
fig, ax = plt.subplots(1, 2, figsize=(10, 4))
for name, d in (("C1", D["C1"]), ("C1*", best.drive)):
    s = pt.tilt_against_speed(model, friction, W, K, speeds, d)
    ax[0].semilogx(speeds_mm_min, UM * np.abs(s.points.peak[:, 0]), label=f"{name} pitch (pt 1)")
    ax[0].semilogx(speeds_mm_min, UM * np.abs(s.points.peak[:, 3]), "--",
                   label=f"{name} yaw (pt 4)")
ax[0].set(xlabel="v [mm/min]", ylabel=r"$|\varepsilon'|$ [um]")
ax[0].legend(fontsize=7)
hmap = pt.variation_map(model, friction, W, K, speeds, heights)
im = ax[1].pcolormesh(np.asarray(heights), speeds_mm_min, UM * np.asarray(hmap.variation),
                      shading="auto")
ax[1].set_yscale("log")
ax[1].set(xlabel="drive height h [mm]", ylabel="v [mm/min]",
          title=r"$\Delta\varepsilon$ point 1 [um]")
fig.colorbar(im, ax=ax[1], label=r"$\Delta\varepsilon$ point 1 [um]")
save(fig, "fig63_design")
