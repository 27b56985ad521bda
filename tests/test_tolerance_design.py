"""Design to a tolerance (`stickslip_fitting.design.tolerance`, `stickslip design
--max-amplitude`): on the shipped campaign's posterior, the stiffness it proposes keeps the
exact simulator's settled amplitude below the tolerance in at least the asked share of
the draws."""

from __future__ import annotations

import json
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stickslip_jax.cli import main

EXAMPLES = sorted(str(p) for p in (Path(__file__).parents[1] / "data/examples").glob("*.csv"))


@pytest.fixture(scope="module")
def posterior(tmp_path_factory):
    out = tmp_path_factory.mktemp("post") / "posterior.json"
    assert main(["mcmc", *EXAMPLES, "--walkers", "16", "--steps", "400", "--draws", "400",
                 "--seed", "3", "--json", str(out), "--quiet"]) == 0
    return out


@pytest.mark.slow
def test_tolerance_design_meets_on_the_posterior(posterior, tmp_path, capsys):
    out = tmp_path / "design.json"
    assert main(["design", "--posterior", str(posterior), "--weight", "36",
                 "--stiffness", "100:1000:10", "--speed", "5", "--max-amplitude", "1um",
                 "--json", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "k needed [kgf/mm]" in text
    tol = json.loads(out.read_text())["tolerance"]
    assert tol["max_amplitude_mm"] == pytest.approx(1e-3) and tol["meet"] == 0.95
    (row,) = tol["required_stiffness"]
    assert row["converged"] and row["probability"] >= 0.95
    k = row["stiffness_kgf_mm"]
    # the grid's probabilities rise with k and cross 0.95 at the proposed stiffness
    p = np.asarray(tol["probability_met"])[0, :, 0]
    ks = np.linspace(100, 1000, 10)
    assert np.all(np.diff(p) >= 0)
    assert np.all(p[ks > 1.02 * k] >= 0.95) and np.all(p[ks < 0.98 * k] < 0.95)

    # independent check: the exact event-driven simulator, run to its settled cycle, for
    # every draw at (36 kgf, k, 5 mm/min)
    from stickslip_fitting.design import load_samples
    from stickslip_fitting.design.exact import exact_point

    sample = load_samples(posterior)
    amp = jax.vmap(lambda f: exact_point(f, jnp.asarray(36.0), jnp.asarray(k),
                                         jnp.asarray(5.0 / 60.0), n_cycles=30).amplitude)(sample)
    share = float(np.mean(np.asarray(amp) <= 1e-3 * (1 + 1e-6)))
    assert share >= 0.95, share


def test_required_stiffness_against_bisection_on_one_draw():
    import stickslip_jax as ss
    from stickslip_fitting.design.tolerance import required_stiffness
    from stickslip_jax.limit_cycle import limit_cycle

    fr = ss.lubricant("A")
    sample = jax.tree_util.tree_map(lambda x: jnp.asarray(x, float)[None], fr)
    d = required_stiffness(sample, 36.0, 5.0 / 60.0, 0.005, meet=0.5)
    assert d.converged
    np.testing.assert_allclose(float(limit_cycle(fr, 36.0, d.stiffness, 5.0 / 60.0).amplitude),
                               0.005, rtol=1e-8)
    with pytest.raises(ValueError, match="--meet"):
        required_stiffness(sample, 36.0, 0.1, 0.005, meet=1.5)
