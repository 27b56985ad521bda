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
# # 05 Missing physics: what is the paper's model leaving out?
#
# A campaign of records is made with a hidden effect the paper's model does not have:
# the strain-gauge zero drifts during each record. One call, `stickslip_fitting.discover`,
# fits the paper's model to the records, looks at where the residuals disagree, ranks a
# library of candidate effects by a score test, refits the best ones and names the
# effect that lowers BIC enough, or answers "none". Here it runs on the smoothed
# simulator over whole records (`SmoothBase`, as `stickslip discover --base smooth`);
# without `base` it uses the per-cycle model of `stickslip discover`.
#
# Units: deflections in mm in the package, printed in um; the drift rate in mm/s.
# With `STICKSLIP_SMALL=1` the campaign has 4 shorter records instead of 12.

# %%
import os
from pathlib import Path

import pandas as pd

import stickslip_fitting as sf
from stickslip_fitting.discovery.synthetic import hidden_effect_campaign
from stickslip_jax.lubricants import lubricant

# %matplotlib inline

SMALL = os.environ.get("STICKSLIP_SMALL") == "1"
FIG = Path(os.environ.get("STICKSLIP_FIGDIR", "notebooks/figures"))
FIG.mkdir(parents=True, exist_ok=True)
pd.set_option("display.width", 120)
kw = dict(conditions=((36.0, 86.9), (12.4, 40.0)), speed_fractions=(0.26, 0.36),
          cycles=3) if SMALL else {}
records = hidden_effect_campaign(lubricant("A"), effect="gauge_drift", values={"rate": 4e-3},
                                 seed=3, **kw)
print(len(records), "records; hidden effect:", records[0].truth["effect"],
      records[0].truth["effect_values"], "(rate in mm/s)")

# %% [markdown]
# ## Run the workflow: one call
#
# `print(found)` is the answer as `stickslip discover` prints it: the effect named, its
# confidence, the residual gap to the noise before and after, and the candidate table.

# %%
found = sf.discover(records, base=sf.SmoothBase(top=2 if SMALL else 3,
                                                max_evals=30 if SMALL else 80))
print(found)

# %% [markdown]
# ## The candidates as a table
#
# One row per effect of the library: the score test at the base fit (statistic, p-value,
# degrees of freedom) and, for the refitted ones, the change of BIC and the
# likelihood-ratio p-value; `named` marks the effect of the answer.

# %%
found.summary()

# %% [markdown]
# ## Where did the base model disagree? Residual RMS by phase of the cycle

# %%
res = found.result
for phase, s in res.residuals_before.phases.items():
    print(f"{phase:12s} before {s['rms'] * 1e3:6.3f} um  after "
          f"{res.residuals_after.phases[phase]['rms'] * 1e3:6.3f} um  (n = {s['n']})")
print("misspecification test p before / after:", res.test_before["p_value"],
      res.test_after["p_value"])

# %% [markdown]
# ## Base parameters before and after adding the effect, beside the truth of the records
#
# Units: mu_s, mu_d, m, n dimensionless; gamma s^-m; delta s^-n; gauge_drift.rate mm/s.

# %%
truth = records[0].truth["friction"]
pd.DataFrame({"truth": {k: truth.get(k) for k in res.parameters_after},
              "before": res.parameters_before, "after": res.parameters_after})

# %% [markdown]
# ## Figure (as `stickslip discover --plot`)

# %%
fig = found.plot()  # the Figure, shown below in Jupyter; saved as PNG too
fig.savefig(FIG / "05_missing_physics.png", dpi=110)
print("figure:", FIG / "05_missing_physics.png")
fig
