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
# the strain-gauge zero drifts during each record. `stickslip_fitting.discovery.discover` fits the
# paper's model to the full traces, looks at where the residuals disagree, ranks a
# library of candidate effects by a score test, refits the best ones and names the
# effect that lowers BIC enough, or answers "none".
# With `STICKSLIP_SMALL=1` the campaign has 4 records instead of 12.

# %%
import os

import matplotlib.pyplot as plt

from stickslip_fitting.discovery import discover
from stickslip_fitting.discovery.plots import plot_discovery
from stickslip_fitting.discovery.synthetic import hidden_effect_campaign
from stickslip_jax.lubricants import lubricant

small = os.environ.get("STICKSLIP_SMALL") == "1"
figdir = os.environ.get("STICKSLIP_FIGDIR", os.path.join("notebooks", "figures"))
os.makedirs(figdir, exist_ok=True)
kw = dict(conditions=((36.0, 86.9), (12.4, 40.0)), speed_fractions=(0.26, 0.36),
          cycles=3) if small else {}
records = hidden_effect_campaign(lubricant("A"), effect="gauge_drift", values={"rate": 4e-3},
                                 seed=3, **kw)
print(len(records), "records; hidden effect:", records[0].truth["effect"],
      records[0].truth["effect_values"])

# %% [markdown]
# ## Run the workflow

# %%
result = discover(records, top=2 if small else 3, max_evals=30 if small else 80)
print("effect:", result.effect, "| confidence:", result.confidence)
print(f"base fit: {result.base_fit.n_evals} evaluations, converged: {result.base_fit.converged}")
print(result.explanation)
print(f"gap {result.gap_before * 1e3:.3f} um -> {result.gap_after * 1e3:.3f} um "
      f"(noise {result.noise * 1e3:.3f} um)")

# %% [markdown]
# ## Where did the base model disagree? Residuals by phase, and the candidate ranking

# %%
for phase, s in result.residuals_before.phases.items():
    print(f"{phase:12s} before {s['rms'] * 1e3:6.3f} um  after "
          f"{result.residuals_after.phases[phase]['rms'] * 1e3:6.3f} um  (n = {s['n']})")
print("misspecification test p before / after:", result.test_before["p_value"],
      result.test_after["p_value"])
for c in result.candidates:
    print(f"{c['name']:22s} score {c['score']:10.1f}  dBIC {c['delta_criterion']}")

# %% [markdown]
# ## Base parameters before and after adding the effect (truth from the records)

# %%
truth = records[0].truth["friction"]
for k, v in result.parameters_after.items():
    print(f"{k:22s} truth {truth.get(k, float('nan')):10.4g} before "
          f"{result.parameters_before.get(k, float('nan')):10.4g} after {v:10.4g}")

# %%
path = os.path.join(figdir, "05_missing_physics.png")
fig = plot_discovery(result)  # the Figure, shown here
fig.savefig(path, dpi=110)
print("figure:", path)
