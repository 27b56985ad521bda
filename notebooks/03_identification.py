# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 03 Identification: friction parameters from a campaign of records
#
# A synthetic campaign (exact simulator, lubricant A, noise 0.5 um) stands in for
# measured records. One call, `stickslip_fitting.fit`, extracts the stick-slip cycle
# features, fits the six parameters of eqs (1) and (3) jointly, and reads the Laplace
# uncertainty and the identifiability report; `stickslip_fitting.sample` samples the
# posterior with emcee. Both return results with `summary()` (a pandas DataFrame),
# `plot()` and `to_json()`, as `stickslip fit` and `stickslip mcmc` print and write them.
#
# Units: friction coefficients dimensionless, gamma in s^-m, delta in s^-n, times in s.
# `STICKSLIP_SMALL=1` shrinks the campaign and the chain; figures go to
# `$STICKSLIP_FIGDIR` (default `notebooks/figures/`).

# %%
import os
from pathlib import Path

import pandas as pd

import stickslip_fitting as sf
import stickslip_jax as ss
from stickslip_fitting.data.features import record_features
from stickslip_fitting.data.synthetic import synthetic_campaign, truth_values

SMALL = os.environ.get("STICKSLIP_SMALL") == "1"
FIG = Path(os.environ.get("STICKSLIP_FIGDIR", "notebooks/figures"))
FIG.mkdir(parents=True, exist_ok=True)
pd.set_option("display.width", 120)

# %% [markdown]
# ## Campaign: three springs (three slip times T2) x drive speeds below v_c

# %%
friction = ss.lubricant("A")
records = synthetic_campaign(friction, speed_fractions=(0.05, 0.3) if SMALL else (0.02, 0.05, 0.15, 0.4),
                             cycles=3 if SMALL else 6, seed=0, pad_to=40_000 if SMALL else 0)
for f in (record_features(r) for r in records):
    print(f"{f.name:28s} cycles {len(f.peak)}  T1 {f.stick_time[f.complete].mean():7.3f} s  "
          f"mu_0 {f.mu_0[f.complete].mean():.4f}  mu_m {f.mu_m[f.complete].mean():.4f}  "
          f"noise {f.noise * 1e3:.2f} um")

# %% [markdown]
# ## Joint fit and Laplace uncertainty: one call
#
# `print(result)` is the table `stickslip fit` prints; `summary()` the same numbers as a
# DataFrame (value, standard error, 95 % interval, unit, identifiable), here beside the
# values the records were made from.

# %%
result = sf.fit(records)
print(result)
table = result.summary()
table["truth"] = pd.Series(truth_values(friction))
table[["value", "std_err", "low", "high", "unit", "identifiable", "truth"]]

# %% [markdown]
# ## Identifiability: the same lubricant at one speed with Table 1's springs (one k/W)
#
# With one slip time and one stick time the records cannot tell the parameters apart:
# the table prints "-" for each parameter they do not determine, and says why.

# %%
one = synthetic_campaign(friction, conditions=ss.experimental_conditions(), speed_fractions=(0.1,),
                         cycles=3, seed=1, pad_to=40_000 if SMALL else 0)
result1 = sf.fit(one)
print(result1)
print("Fisher eigenvalues (log coordinates):", result1.uncertainty.fisher_eigenvalues)

# %% [markdown]
# ## Posterior with emcee, started at the fit

# %%
post = sf.sample(result, walkers=16 if SMALL else 32, steps=150 if SMALL else 4000, seed=0)
print(post)

# %% [markdown]
# ## Figures
#
# The fit's figure (as `stickslip fit --plot`): every record's trace with the fitted
# model, the static friction mu_0 against the stick time T1 with its 95 % band, the mean
# kinetic friction mu_m against the slip time T2, the parameters with their units, and
# the residuals by record and phase. Then the corner plot of the posterior (as
# `stickslip mcmc --plot`), the truth marked in red.

# %%
fig_fit = result.plot()  # the Figure (shown below in Jupyter); saved as PNG too
fig_fit.savefig(FIG / "03_fit.png", dpi=110)

# %%
fig_corner = post.plot()
fig_corner.savefig(FIG / "03_corner.png", dpi=110)
print("figures in", FIG)
