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
# # 04 · Design studies: maps, uncertainty, inverse design and experiment design
#
# A machine-tool designer asks: with this lubricant, how stiff must the drive be (or
# how light the table) so that stick-slip disappears at my feed rate, and how large is
# it where it remains? A tribologist asks: which speeds and springs should I record to
# pin down the friction parameters? This notebook answers both with `stickslip_fitting.design`:
#
# 1. the trends of the paper's Figs 10-13 (amplitude and frequency against speed for
#    several weights and stiffnesses) as maps, with the stick-slip boundary v = v_c;
# 2. the steady map against the exact event-driven simulator;
# 3. a posterior sample pushed through a map: probability of stick-slip, v_c band;
# 4. inverse design: the minimum stiffness for a feed rate, checked on a grid;
# 5. experiment design: the D-optimal next records against an even spread.
#
# Units: kgf, mm, s inside; speeds in mm/min on the plots. `STICKSLIP_SMALL=1` shrinks
# the grids; figures go to `$STICKSLIP_FIGDIR` (default `notebooks/figures/`).

# %%
import os
from pathlib import Path

import jax
import matplotlib.pyplot as plt
import numpy as np

import stickslip_jax as ss
from stickslip_fitting.design import (
    Noise,
    candidate_grid,
    design_map,
    even_design,
    friction_from_params,
    friction_params,
    greedy_design,
    laplace_fit,
    log_params,
    maximum_weight,
    minimum_stiffness,
    outer,
    propagate,
    sequential_campaign,
    simulate_observations,
    PARAMETERS,
)
from stickslip_jax.units import from_mm_per_min, mm_per_min

SMALL = os.environ.get("STICKSLIP_SMALL") == "1"
FIGDIR = Path(os.environ.get("STICKSLIP_FIGDIR") or Path("notebooks") / "figures")
FIGDIR.mkdir(parents=True, exist_ok=True)
N = 24 if SMALL else 120  # grid points per axis


def save(fig, name):
    fig.tight_layout()
    fig.savefig(FIGDIR / f"{name}.png", dpi=110)
    plt.show() if os.environ.get("MPLBACKEND", "").lower() != "agg" else None
    plt.close(fig)


speeds_mm_min = np.geomspace(0.0022, 92.0, N)
speeds = from_mm_per_min(speeds_mm_min)

# %% [markdown]
# ## 1. Figs 10-13 as maps
#
# Figs 10/11 vary the slider weight at k = 86.9 kgf/mm; Figs 12/13 vary the stiffness at
# W = 36 kgf. As maps over (W or k) x v, ak/W and f/f0 show the paper's trends at a
# glance: ak/W grows with W and falls with k, the frequency approaches f0 near the
# critical speed, and the boundary v_c (white) moves to higher speed with W and to
# lower speed with k ("an increase of stiffness is equivalent to a decrease of weight").

# %%
weights = np.linspace(10.0, 60.0, N)
stiffs = np.linspace(20.0, 150.0, N)
fig, axs = plt.subplots(2, 4, figsize=(17, 7.5))
for row, lub in enumerate(("A", "C")):
    f = ss.lubricant(lub)
    W, V = outer(weights, speeds)
    m_w = design_map(f, W, 86.9, V)
    K, V2 = outer(stiffs, speeds)
    m_k = design_map(f, 36.0, K, V2)
    panels = [
        (m_w, weights, "W [kgf]", "amplitude_ratio", "ak/W [-]", "Fig 10"),
        (m_w, weights, "W [kgf]", "frequency_ratio", "f/f0 [-]", "Fig 11"),
        (m_k, stiffs, "k [kgf/mm]", "amplitude_ratio", "ak/W [-]", "Fig 12"),
        (m_k, stiffs, "k [kgf/mm]", "frequency_ratio", "f/f0 [-]", "Fig 13"),
    ]
    for ax, (m, y, ylabel, field, label, fig_name) in zip(axs[row], panels):
        z = getattr(m, field)
        mesh = ax.pcolormesh(speeds_mm_min, y, z, shading="auto", cmap="viridis")
        fig.colorbar(mesh, ax=ax, label=label)
        ax.contour(speeds_mm_min, y, np.log(m.critical_speed / speeds[None, :]), levels=[0],
                   colors="w", linewidths=1.5)
        ax.set_xscale("log")
        ax.set_xlabel("v [mm/min]")
        ax.set_ylabel(ylabel)
        ax.set_title(f"{fig_name} trend, lubricant {lub}: {label}", fontsize=9)
save(fig, "04_figs10_13_maps")

# The paper's trends, checked on the maps (lubricant A, slowest speed):
f_a = ss.lubricant("A")
W, V = outer(weights, speeds)
m_w = design_map(f_a, W, 86.9, V)
K, V2 = outer(stiffs, speeds)
m_k = design_map(f_a, 36.0, K, V2)
assert np.all(np.diff(m_w.amplitude_ratio[:, 0]) > 0), "ak/W rises with W (Fig 10)"
assert np.all(np.diff(m_k.amplitude_ratio[:, 0]) < 0), "ak/W falls with k (Fig 12)"
assert np.all(np.diff(m_w.critical_speed[:, 0]) > 0), "v_c rises with W"
assert np.all(np.diff(m_k.critical_speed[:, 0]) < 0), "v_c falls with k"
print("trends of Figs 10-13 hold on the maps")

# %% [markdown]
# ## 2. Steady analysis against the exact simulator
#
# The exact simulator (`method="exact"`) runs 8 stick-slip cycles per point from rest
# and reports the last one. Where the slider can restick after a slip
# ($e^{-\delta T_2^n} < 1/2$) its limit cycle has the steady amplitude of eq (5)-(6);
# for very light, stiff slides (small $T_2$) the trough of the slip lies above
# $\mu_d W/k$, the slider cannot stick again and the time-domain model slides on,
# although eq (6) has a solution. Above v_c the time-domain model still sticks briefly
# ($T_1 < T_2$), which the paper's criterion of eq (12) counts as the end of stick-slip.

# %%
n_ex = 10 if SMALL else 40
W, V = outer(np.linspace(10.0, 60.0, n_ex), from_mm_per_min(np.geomspace(0.01, 92.0, n_ex)))
st = design_map(f_a, W, 128.5, V)
ex = design_map(f_a, W, 128.5, V, method="exact")
both = st.stick_slip & ex.stick_slip
rel = np.abs(ex.amplitude[both] - st.amplitude[both]) / st.amplitude[both]
print(f"k = 128.5 kgf/mm: exact vs steady amplitude where both stick-slip: "
      f"max relative difference {rel.max():.2e} over {both.sum()} points")
fig, axs = plt.subplots(1, 2, figsize=(11, 4))
vm = mm_per_min(V[0])
for ax, m, name in zip(axs, (st, ex), ("steady analysis", "exact simulator")):
    mesh = ax.pcolormesh(vm, W[:, 0], m.amplitude * 1e3, shading="auto", cmap="magma")
    fig.colorbar(mesh, ax=ax, label="a [um]")
    ax.set_xscale("log")
    ax.set_xlabel("v [mm/min]")
    ax.set_ylabel("W [kgf]")
    ax.set_title(f"{name}, lubricant A, k = 128.5 kgf/mm", fontsize=9)
save(fig, "04_exact_vs_steady")

# %% [markdown]
# ## 3. A posterior sample through a map
#
# Here a synthetic "posterior" (lubricant A's parameters with 5 % log-normal scatter,
# as `stickslip mcmc` would give after fitting a few records) is pushed through a
# (W, k) map at a feed of 20 mm/min: the probability of stick-slip and the 90 % band of
# v_c. `stickslip_fitting.design.load_samples` reads the same sample from CSV or JSON.

# %%
rng = np.random.default_rng(0)
S = 64 if SMALL else 400
p_a = friction_params(f_a)
sample = friction_from_params({k: v * np.exp(0.05 * rng.standard_normal(S)) for k, v in p_a.items()})
feed = from_mm_per_min(20.0)
W, K = outer(weights, stiffs)
u = propagate(sample, W, K, feed, level=0.9)
fig, axs = plt.subplots(1, 2, figsize=(11, 4))
mesh = axs[0].pcolormesh(stiffs, weights, u.probability, shading="auto", cmap="coolwarm",
                         vmin=0, vmax=1)
fig.colorbar(mesh, ax=axs[0], label="P(stick-slip) [-]")
axs[0].contour(stiffs, weights, u.probability, levels=[0.05, 0.5, 0.95], colors="k",
               linewidths=[0.8, 1.5, 0.8])
axs[0].set_xlabel("k [kgf/mm]")
axs[0].set_ylabel("W [kgf]")
axs[0].set_title("probability of stick-slip at 20 mm/min (5/50/95 % contours)", fontsize=9)
i36 = np.argmin(np.abs(weights - 36.0))
band = mm_per_min(u.critical_speed[i36])
axs[1].fill_between(stiffs, band[:, 0], band[:, 2], alpha=0.3, label="90 % band")
axs[1].plot(stiffs, band[:, 1], label="median v_c")
axs[1].axhline(20.0, color="k", ls="--", lw=1, label="feed 20 mm/min")
axs[1].set_xlabel("k [kgf/mm]")
axs[1].set_ylabel("v_c [mm/min]")
axs[1].set_title(f"critical speed at W = {weights[i36]:.1f} kgf", fontsize=9)
axs[1].legend()
save(fig, "04_posterior_map")

# %% [markdown]
# ## 4. Inverse design: the minimum stiffness for a feed rate
#
# `minimum_stiffness` solves $v_c(W, k) = v$ (and, with a tolerance, $a(W, k, v) =$ tol)
# for $\log k$ with Newton's method, differentiating through the steady analysis. The
# brute-force check scans a fine grid of k with the steady map.

# %%
W0 = 36.0
feeds_mm_min = np.geomspace(2.0, 45.0, 6 if SMALL else 15)
k_grid = np.linspace(20.0, 2000.0, 4000 if SMALL else 40000)
k_smooth = [float(minimum_stiffness(f_a, W0, from_mm_per_min(fm)).value) for fm in feeds_mm_min]
k_tol = [float(minimum_stiffness(f_a, W0, from_mm_per_min(fm), 0.01).value) for fm in feeds_mm_min]
brute = []
for fm in feeds_mm_min:
    m = ss.steady_map(f_a, W0, k_grid, from_mm_per_min(fm))
    brute.append(k_grid[np.argmax(~np.asarray(m.stick_slip))])
err = np.max(np.abs(np.array(k_smooth) - np.array(brute)))
print(f"Newton vs grid (spacing {k_grid[1] - k_grid[0]:.3f} kgf/mm): max |difference| "
      f"{err:.3f} kgf/mm")
assert err <= k_grid[1] - k_grid[0]
# With an uncertain lubricant, vmap the inverse design over a posterior sample and
# take a high quantile: the stiffness that stops stick-slip with 95 % probability.
k_sample = jax.vmap(minimum_stiffness, in_axes=(0, None, None))(sample, W0, from_mm_per_min(10.0))
k_q = np.percentile(np.asarray(k_sample.value), [5, 50, 95])
print(f"minimum stiffness at 10 mm/min over the posterior sample: median {k_q[1]:.0f}, "
      f"90 % band {k_q[0]:.0f}-{k_q[2]:.0f} kgf/mm")
w_max = float(maximum_weight(f_a, 86.9, from_mm_per_min(10.0)).value)
print(f"heaviest slider that slides smoothly at 10 mm/min on k = 86.9 kgf/mm: {w_max:.2f} kgf")
fig, ax = plt.subplots(figsize=(6, 4))
ax.plot(feeds_mm_min, k_smooth, "o-", label="no stick-slip (v_c <= feed)")
ax.plot(feeds_mm_min, k_tol, "s-", label="or amplitude <= 10 um")
ax.plot(feeds_mm_min, brute, "k+", ms=10, label="brute-force grid")
ax.set_xscale("log")
ax.set_yscale("log")
ax.xaxis.set_minor_formatter(plt.NullFormatter())
ax.set_xlabel("feed rate [mm/min]")
ax.set_ylabel("minimum stiffness k [kgf/mm]")
ax.set_title(f"lubricant A, W = {W0} kgf", fontsize=9)
ax.legend()
save(fig, "04_inverse_design")

# %% [markdown]
# ## 5. Experiment design: which records identify the friction parameters?
#
# Each record (W, k, v) gives, from the steady analysis, $\log a$, $\log T_1$, $\mu_0$ and
# $\mu_m$ (noise 5 %, 5 %, 0.01, 0.01); a record above $v_c$, or where the slider cannot
# stick again after a slip, only gives $\mu_m = \mu_d$. The Fisher information of the
# log-parameters comes from `jax.jacfwd` through the model; `greedy_design` picks the
# records that maximise the determinant of the posterior precision (D-optimal).
#
# The design is *local*: it is only as good as the estimate it is computed at. We
# compare, on noisy synthetic records from the true lubricant A, six records chosen
#
# - in one shot at a rough estimate (10 % off, prior sd 0.5 in log),
# - sequentially: a pilot of 3 evenly spread records, then one record at a time at
#   the current fit (`sequential_campaign`; this is how `stickslip plan` is meant to
#   be used),
# - by an even spread (log-spaced speeds cycling through the Table 1 W, k pairs),
#
# each fitted with a Laplace fit (Levenberg-Marquardt + Gauss-Newton covariance).

# %%
truth = log_params(f_a)
guess = truth + 0.1 * np.random.default_rng(0).standard_normal(6)
cands = candidate_grid([11.3, 36.0, 53.2], [27.3, 86.9, 128.5],
                       from_mm_per_min(np.geomspace(0.0022, 92.0, 12)))
budget = 6
noise = Noise()
one_shot = greedy_design(guess, cands, budget, noise=noise, prior_sd=0.5).campaign
even = even_design(cands, budget)
pilot = even_design(cands, 3)
reps = 3 if SMALL else 20
sd = {"one-shot D-optimal": [], "sequential D-optimal": [], "even spread": []}
last = None
for r in range(reps):
    key = jax.random.PRNGKey(100 + r)
    last, fit = sequential_campaign(truth, guess, cands, pilot, budget - 3, key, noise=noise,
                                    prior_sd=0.5)
    sd["sequential D-optimal"].append(np.asarray(fit.sd))
    for name, camp in (("one-shot D-optimal", one_shot), ("even spread", even)):
        y, mask = simulate_observations(truth, camp, noise, key)
        sd[name].append(np.asarray(laplace_fit(y, mask, camp, noise, guess, 0.5).sd))
print("last sequential campaign (W kgf, k kgf/mm, v mm/min):")
for w_, k_, v_ in zip(last.weight, last.stiffness, last.speed):
    print(f"  {w_:6.1f} {k_:6.1f} {mm_per_min(v_):9.4g}")
mean_sd = {k: np.mean(v, axis=0) for k, v in sd.items()}
for k, v in mean_sd.items():
    print(f"{k:>21}: mean posterior sd (relative) {v.mean():.4f}")
fig, ax = plt.subplots(figsize=(7.5, 4))
x = np.arange(6)
for i, (k, v) in enumerate(mean_sd.items()):
    ax.bar(x + 0.27 * i - 0.27, v, 0.27, label=f"{k} (mean {v.mean():.3f})")
ax.set_xticks(x, PARAMETERS)
ax.set_ylabel("posterior sd of log(parameter) [-]")
ax.set_yscale("log")
ax.set_title(f"{budget} records, Laplace fits over {reps} noise realisations", fontsize=9)
ax.legend(fontsize=8)
save(fig, "04_experiment_design")
