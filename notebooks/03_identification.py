# %% [markdown]
# # 03 Identification: friction parameters from a campaign of records
#
# A synthetic campaign (exact simulator, lubricant A, noise 0.5 um) stands in for
# measured records. We extract the stick-slip cycle features, fit the six parameters
# of eqs (1) and (3) jointly with optimistix, read the Laplace uncertainty and the
# identifiability report, sample the posterior with emcee, and plot.

# %%
import os
from pathlib import Path

import stickslip_jax as ss
from stickslip_fitting.data.features import record_features
from stickslip_fitting.solve.fit import fit_features
from stickslip_fitting.uncertainty.mcmc import run_mcmc
from stickslip_fitting.report.plots import corner_plot, fit_figure
from stickslip_fitting.data.synthetic import synthetic_campaign, truth_values
from stickslip_fitting.uncertainty.laplace import laplace

SMALL = os.environ.get("STICKSLIP_SMALL") == "1"
FIG = Path(os.environ.get("STICKSLIP_FIGDIR", "notebooks/figures"))
FIG.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## Campaign: three springs (three slip times T2) x speeds below v_c

# %%
friction = ss.lubricant("A")
records = synthetic_campaign(friction, speed_fractions=(0.05, 0.3) if SMALL else (0.02, 0.05, 0.15, 0.4),
                             cycles=3 if SMALL else 6, seed=0, pad_to=40_000 if SMALL else 0)
features = [record_features(r) for r in records]
for f in features:
    print(f"{f.name:28s} cycles {len(f.peak)}  T1 {f.stick_time[f.complete].mean():7.3f} s  "
          f"mu_0 {f.mu_0[f.complete].mean():.4f}  mu_m {f.mu_m[f.complete].mean():.4f}  "
          f"noise {f.noise * 1e3:.2f} um")

# %% [markdown]
# ## Joint fit and Laplace uncertainty

# %%
fit = fit_features(features)
unc = laplace(fit)
truth = truth_values(friction)
for row in unc.table():
    ci = row["ci95"]
    print(f"{row['name']:6s} {row['value']:10.5g}  95 % [{ci[0]:.5g}, {ci[1]:.5g}]  truth {truth[row['name']]:g}")
print("chi2/dof", round(fit.reduced_chi2, 3))
for w in unc.warnings:
    print("warning:", w)

# %% [markdown]
# ## Identifiability: the same lubricant at one speed with Table 1's springs (one k/W)

# %%
one = synthetic_campaign(friction, conditions=ss.experimental_conditions(), speed_fractions=(0.1,),
                         cycles=3, seed=1, pad_to=40_000 if SMALL else 0)
fit1 = fit_features([record_features(r) for r in one])
unc1 = laplace(fit1)
print("not identifiable:", [n for n, ok in unc1.identifiable.items() if not ok])
for w in unc1.warnings[:3]:
    print("warning:", w)
print("Fisher eigenvalues (log coordinates):", unc1.fisher_eigenvalues)

# %% [markdown]
# ## Posterior with emcee

# %%
mc = run_mcmc(fit, walkers=16 if SMALL else 32, steps=150 if SMALL else 4000, seed=0)
for name, s in mc.summary().items():
    print(f"{name:6s} median {s['median']:.5g} sd {s['sd']:.3g} tau {s['tau_steps']:.0f} ESS {s['ess']:.0f}")
print(mc.prior)
print(mc.warnings)

# %% [markdown]
# ## Figures: traces with the fitted model, mu_0(T1) with its band, mu_m(T2), corner plot

# %%
# the functions return their Figure (shown below in Jupyter); saved as PNG too
fig_fit = fit_figure(fit, unc, records)
fig_fit.savefig(FIG / "03_fit.png", dpi=110)
fig_corner = corner_plot(mc.samples, mc.names, truth=truth)
fig_corner.savefig(FIG / "03_corner.png", dpi=110)
print("figures in", FIG)
