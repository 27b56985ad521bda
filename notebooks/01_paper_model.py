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
# # 01 · The paper's model: friction laws and steady stick-slip (chapters 3-5)
#
# Kato, Sato, Yamaguchi and Matsubayashi describe stick-slip on a scraped cast-iron
# slideway with two empirical laws: static friction against stick time, eq (1),
# $\mu_0 = \mu_s - (\mu_s-\mu_d)e^{-\gamma T_1^m}$, and the mean kinetic friction of a
# slip, eq (3), $\mu_m = \mu_d + (\mu_0-\mu_d)e^{-\delta T_2^n}$. Chapter 5 combines
# them into the stick time of eq (6), the amplitude of eq (5) and the critical speed
# of eq (12) (in its corrected form, eq (6) at $T_1 = T_2 = T_0$; docs/model.md). This
# notebook redraws the paper's calculated curves: Figs 16/17, 32/33 (+ frequency), 34
# (phase plane), 36 and 37-41.
#
# Units: kgf, mm, s inside the package; speeds are plotted in mm/min like the paper.
# `STICKSLIP_SMALL=1` shrinks the grids; figures go to `$STICKSLIP_FIGDIR`
# (default `notebooks/figures/`).

# %%
import os
import sys
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np

import stickslip_jax as ss
from stickslip_jax.lubricants import STATIC_LAWS
from stickslip_jax.units import from_mm_per_min, mm_per_min

SMALL = os.environ.get("STICKSLIP_SMALL") == "1"
FIGDIR = Path(os.environ.get("STICKSLIP_FIGDIR") or Path("notebooks") / "figures")
FIGDIR.mkdir(parents=True, exist_ok=True)
N = 40 if SMALL else 200  # points per curve


def save(fig, name):
    fig.tight_layout()
    fig.savefig(FIGDIR / f"01_{name}.png", dpi=90 if SMALL else 130)
    if "ipykernel" not in sys.modules:  # in Jupyter the figure stays open and is shown
        plt.close(fig)


LUBS = {name: ss.lubricant(name) for name in ("A", "C")}  # Table 6
CONDITIONS = ss.experimental_conditions()  # Table 1 (W_i, k_i)
W2, K2 = 36.0, 86.9

# %% [markdown]
# ## Static friction against stick time: Table 3 laws (Fig 16) and eq (1) (Fig 17)

# %%
t1 = jnp.logspace(-2, 3, N)
fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
for ax, lub in zip(axes, ("A", "C")):
    for law, style in zip(STATIC_LAWS, ("-", "--", "-.", ":", (0, (5, 1)))):
        f = ss.static_law(law, lub)  # 'kato' = eq (1) with Table 4, the others Table 3
        ax.semilogx(t1, f(t1), linestyle=style, label=law if law != "kato" else "eq (1), Table 4")
    ax.set_title(f"lubricant {lub}")
    ax.set_xlabel("stick time $T_1$ [s]")
    ax.grid(alpha=0.3)
axes[0].set_ylabel(r"static friction $\mu_0$ [-]")
axes[0].legend()
save(fig, "fig16_17_static_laws")
for lub in ("A", "C"):
    f = ss.static_law("kato", lub)
    print(f"lubricant {lub}: mu_0(0.1 s) = {float(f(0.1)):.3f}, "
          f"mu_0(100 s) = {float(f(100.0)):.3f}")

# %% [markdown]
# ## Amplitude and frequency against drive speed (Figs 32, 33 and the frequency curves)
#
# Figs 32 and 33 vary the weight at $k_2 = 86.9$ kgf/mm and the stiffness at
# $W_2 = 36$ kgf. Above $v_c$ there is no stick-slip (a = 0, drawn as the curve's end).

# %%
v_mm_min = np.geomspace(0.0022, 92.0, N)
v = jnp.asarray(from_mm_per_min(v_mm_min))
weights = [w for w, _ in CONDITIONS]
stiffnesses = [k for _, k in CONDITIONS]
cases = {"Fig 32 (k = 86.9 kgf/mm)": [(w, K2, f"W = {w} kgf") for w in weights],
         "Fig 33 (W = 36 kgf)": [(W2, k, f"k = {k} kgf/mm") for k in stiffnesses]}
fig, axes = plt.subplots(2, 4, figsize=(16, 7), sharex=True)
for col, (lub, (title, curves)) in enumerate(
    [(lub, case) for lub in ("A", "C") for case in cases.items()]
):
    for W, K, label in curves:
        r = ss.steady_map(LUBS[lub], W, K, v)
        ok = np.asarray(r.stick_slip)
        axes[0, col].semilogx(v_mm_min[ok], np.asarray(r.amplitude_ratio)[ok], label=label)
        axes[1, col].loglog(v_mm_min[ok], np.asarray(r.frequency_ratio)[ok], label=label)
    axes[0, col].set_title(f"lubricant {lub}, {title}", fontsize=9)
    axes[1, col].set_xlabel("drive speed v [mm/min]")
    for ax in axes[:, col]:
        ax.grid(alpha=0.3, which="both")
axes[0, 0].set_ylabel("amplitude ratio $ak/W$ [-]")
axes[1, 0].set_ylabel("frequency ratio $f/f_0$ [-]")
for ax in axes[0]:  # each column varies W or k: its own legend
    ax.legend(fontsize=8)
save(fig, "fig32_33_amplitude_frequency")

r = ss.steady_map(LUBS["A"], W2, K2, from_mm_per_min(jnp.asarray([0.01, 1.0, 10.0])))
print("lubricant A, W = 36 kgf, k = 86.9 kgf/mm: v [mm/min] = 0.01, 1, 10 ->",
      "ak/W =", np.round(np.asarray(r.amplitude_ratio), 4),
      " f/f0 =", np.round(np.asarray(r.frequency_ratio), 5))

# %% [markdown]
# ## Slip phase plane, eq (11) (Fig 34 style)
#
# During the slip the spring deflection runs half a circle in the plane
# $(\dot x/\omega_0, x)$: from $\mu_0 W/k$ to $(2\mu_m-\mu_0)W/k$; the stick (not drawn)
# climbs back along $\dot x \approx 0$.

# %%
fig, ax = plt.subplots(figsize=(5, 4))
for v_ in (0.1, 1.0, 10.0):
    r = ss.steady_state(LUBS["A"], W2, K2, from_mm_per_min(v_))
    tr = ss.slip_trajectory(LUBS["A"], W2, K2, r.stick_time)
    ax.plot(tr.velocity_over_omega0, tr.deflection, label=f"v = {v_} mm/min")
ax.set_xlabel(r"$\dot x/\omega_0$ [mm]")
ax.set_ylabel("x [mm]")
ax.set_title("lubricant A, W = 36 kgf, k = 86.9 kgf/mm", fontsize=9)
ax.legend(fontsize=8)
ax.grid(alpha=0.3)
save(fig, "fig34_phase_plane")

# %% [markdown]
# ## Critical speed against natural frequency (Fig 36)
#
# With $T_0 = 1/(2f_0)$ and $W/k = g T_0^2/\pi^2$, the corrected eq (12) depends on
# W and k only through $f_0$, and falls as $f_0$ rises.

# %%
k_range = jnp.linspace(10.0, 200.0, N)
fig, ax = plt.subplots(figsize=(5, 4))
for lub, fr in LUBS.items():
    f0 = np.asarray(ss.natural_angular_frequency(W2, k_range)) / (2 * np.pi)
    vc_fn = jax.vmap(ss.critical_speed, in_axes=(None, None, 0))
    vc = mm_per_min(np.asarray(vc_fn(fr, W2, k_range)))
    ax.loglog(f0, vc, label=f"lubricant {lub}")
    for W, K in CONDITIONS:  # the Table 1 systems
        ax.plot(float(ss.natural_angular_frequency(W, K)) / (2 * np.pi),
                mm_per_min(float(ss.critical_speed(fr, W, K))), "k.", ms=4,
                label="Table 1 systems" if lub == "C" and (W, K) == CONDITIONS[0] else None)
ax.set_xlabel("natural frequency $f_0$ [Hz]")
ax.set_ylabel("critical speed $v_c$ [mm/min]")
ax.legend()
ax.grid(alpha=0.3, which="both")
save(fig, "fig36_vc_f0")
for lub, fr in LUBS.items():
    print(f"v_c, lubricant {lub}, W = 36 kgf, k = 86.9 kgf/mm: "
          f"{mm_per_min(float(ss.critical_speed(fr, W2, K2))):.2f} mm/min")

# %% [markdown]
# ## Critical speed against each friction parameter (Figs 37-41)
#
# Lubricant A at W = 36 kgf, k = 86.9 kgf/mm, one parameter varied at a time with
# `eqx.tree_at`, the whole sweep under `vmap`.

# %%
base = LUBS["A"]
sweeps = [
    (r"$\mu_s-\mu_d$ [-] (Fig 37)", lambda f: f.static.mu_s, np.linspace(0.22, 0.9, N), 0.21),
    (r"$\gamma$ [s$^{-m}$] (Fig 38)", lambda f: f.static.gamma, np.geomspace(0.01, 5.0, N), 0.0),
    ("$m$ [-] (Fig 39)", lambda f: f.static.m, np.linspace(0.1, 1.5, N), 0.0),
    (r"$\delta$ [s$^{-n}$] (Fig 40)", lambda f: f.kinetic.delta, np.geomspace(1.0, 500.0, N), 0.0),
    ("$n$ [-] (Fig 41)", lambda f: f.kinetic.n, np.linspace(0.2, 1.5, N), 0.0),
]
fig, axes = plt.subplots(1, 5, figsize=(18, 3.6), sharey=True)
for ax, (label, where, values, offset) in zip(axes, sweeps):
    batch = jax.vmap(lambda x, where=where: eqx.tree_at(where, base, x))(jnp.asarray(values))
    vc = eqx.filter_vmap(lambda f: ss.critical_speed(f, W2, K2))(batch)
    ax.plot(values - offset, mm_per_min(np.asarray(vc)))
    ax.set_xlabel(label)
    ax.grid(alpha=0.3)
    trend = "rises" if vc[-1] > vc[0] else "falls"
    lo, hi = mm_per_min(float(vc[0])), mm_per_min(float(vc[-1]))
    print(f"v_c {trend} with {label}: {lo:.3g} -> {hi:.3g} mm/min")
axes[0].set_ylabel("critical speed $v_c$ [mm/min]")
save(fig, "fig37_41_vc_parameters")
print("figures in", FIGDIR)
