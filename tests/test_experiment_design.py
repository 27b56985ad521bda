"""Experiment design (fitting.design.experiment): Fisher information against finite
differences, the greedy D-optimal choice, and the synthetic-campaign comparison: the
chosen records identify the friction parameters better than an even spread."""

import jax
import numpy as np
import pytest

import stickslip_jax as ss
from fitting.design import (
    Campaign,
    Noise,
    candidate_grid,
    even_design,
    fisher_information,
    greedy_design,
    laplace_fit,
    log_params,
    observables,
    record_information,
    simulate_observations,
)
from stickslip_jax.units import from_mm_per_min

BUDGET = 6
PRIOR_SD = 0.5


@pytest.fixture(scope="module")
def truth():
    return log_params(ss.lubricant("A"))


@pytest.fixture(scope="module")
def guess(truth):
    # the planner only knows a rough estimate (about 10 % off in every parameter)
    return truth + 0.1 * np.random.default_rng(0).standard_normal(6)


@pytest.fixture(scope="module")
def candidates():
    return candidate_grid([11.3, 36.0, 53.2], [27.3, 86.9, 128.5],
                          from_mm_per_min(np.geomspace(0.0022, 92.0, 12)))


def test_fisher_information_matches_finite_differences(truth):
    camp = Campaign(np.array([36.0, 11.3, 53.2]), np.array([86.9, 27.3, 128.5]),
                    from_mm_per_min(np.array([1.0, 0.01, 500.0])))
    noise = Noise()
    info = np.asarray(record_information(truth, camp, noise))
    assert info.shape == (3, 6, 6)
    for i in range(3):
        w, k, v = (float(np.asarray(x)[i]) for x in (camp.weight, camp.stiffness, camp.speed))
        _, mask = observables(truth, w, k, v)
        h = 1e-6
        jac = np.stack([(np.asarray(observables(truth + h * e, w, k, v)[0])
                         - np.asarray(observables(truth - h * e, w, k, v)[0])) / (2 * h)
                        for e in np.eye(6)], axis=1)
        wts = np.asarray(mask) / np.asarray(noise.sigma()) ** 2
        np.testing.assert_allclose(info[i], jac.T @ (wts[:, None] * jac), rtol=1e-5, atol=1e-6)
    # the third record slides smoothly (500 mm/min > v_c): only mu_m = mu_d is observed
    assert np.asarray(observables(truth, 53.2, 128.5, from_mm_per_min(500.0))[1]).tolist() == [0, 0, 0, 1]
    np.testing.assert_allclose(fisher_information(truth, camp, noise), info.sum(0), rtol=1e-12)


def test_greedy_choice_maximises_log_det(guess, candidates):
    plan = greedy_design(guess, candidates, 2, prior_sd=PRIOR_SD)
    info = np.asarray(record_information(guess, candidates))
    prec = np.eye(6) / PRIOR_SD**2
    first = np.argmax([np.linalg.slogdet(prec + I)[1] for I in info])
    assert plan.indices[0] == first
    second = np.argmax([np.linalg.slogdet(prec + info[first] + I)[1] for I in info])
    assert plan.indices[1] == second
    assert np.all(np.diff(plan.log_det) > 0)
    assert np.all(plan.sd_after < plan.sd_before)
    with pytest.raises(ValueError, match="budget"):
        greedy_design(guess, candidates, 0)


def test_d_optimal_campaign_beats_even_spread(truth, guess, candidates):
    noise = Noise()
    chosen = greedy_design(guess, candidates, BUDGET, noise=noise, prior_sd=PRIOR_SD).campaign
    even = even_design(candidates, BUDGET)
    assert len(chosen) == len(even) == BUDGET
    sds = {"chosen": [], "even": []}
    errors = {"chosen": [], "even": []}
    for rep in range(3):
        key = jax.random.PRNGKey(rep)
        for name, camp in (("chosen", chosen), ("even", even)):
            y, mask = simulate_observations(truth, camp, noise, key)
            fit = laplace_fit(y, mask, camp, noise, guess, PRIOR_SD)
            assert np.all(np.isfinite(np.asarray(fit.sd)))
            sds[name].append(float(np.mean(fit.sd)))
            errors[name].append(float(np.sqrt(np.mean((np.asarray(fit.value) - truth) ** 2))))
    # mean posterior sd (over the six parameters, relative units) is smaller in every
    # noise realisation
    assert all(c < e for c, e in zip(sds["chosen"], sds["even"])), sds
    assert np.mean(sds["chosen"]) < 0.95 * np.mean(sds["even"]), sds
