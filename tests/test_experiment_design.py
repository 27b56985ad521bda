"""Experiment design (stickslip_fitting.design.experiment): Fisher information against finite
differences, the greedy D-optimal choice, and the synthetic-campaign comparison: the
chosen records identify the friction parameters better than an even spread."""

import jax
import numpy as np
import optimistix as optx
import pytest

import stickslip_jax as ss
from stickslip_fitting.design import (
    Campaign,
    Noise,
    candidate_grid,
    even_design,
    fisher_information,
    greedy_design,
    laplace_fit,
    log_params,
    observables,
    posterior_sd,
    record_information,
    sequential_campaign,
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
    # below v_c but the slider cannot restick (exp(-delta T2^n) > 1/2 for W = 11.3, k = 128.5):
    # the record slides smoothly, as the exact simulator does
    s = ss.steady_state(ss.lubricant("A"), 11.3, 128.5, from_mm_per_min(0.01))
    assert bool(s.stick_slip)
    y, mask = observables(truth, 11.3, 128.5, from_mm_per_min(0.01))
    assert np.asarray(mask).tolist() == [0, 0, 0, 1]
    np.testing.assert_allclose(y[3], 0.21, rtol=1e-12)  # mu_d of lubricant A


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
    # Sequential D-optimal design, as `stickslip plan` is used: a pilot of 3 evenly
    # spread records, then 3 records chosen one at a time at the current fit. Compared
    # with an even spread of the same 6 records on the same synthetic truth.
    noise = Noise()
    even = even_design(candidates, BUDGET)
    pilot = even_design(candidates, 3)
    sds = {"chosen": [], "even": []}
    for rep in range(3):
        key = jax.random.PRNGKey(100 + rep)
        camp, fit = sequential_campaign(truth, guess, candidates, pilot, BUDGET - 3, key,
                                        noise=noise, prior_sd=PRIOR_SD)
        assert len(camp) == BUDGET
        y, mask = simulate_observations(truth, even, noise, key)
        fit_even = laplace_fit(y, mask, even, noise, guess, PRIOR_SD)
        for name, f in (("chosen", fit), ("even", fit_even)):
            assert f.result == optx.RESULTS.successful
            assert np.all(np.isfinite(np.asarray(f.sd)))
            sds[name].append(float(np.mean(f.sd)))
    # mean posterior sd (over the six parameters, relative units) is smaller in every
    # noise realisation
    assert all(c < e for c, e in zip(sds["chosen"], sds["even"])), sds
    assert np.mean(sds["chosen"]) < 0.95 * np.mean(sds["even"]), sds


def test_one_shot_plan_is_only_as_good_as_its_estimate(truth, guess, candidates):
    # The local design's weakness, documented: predicted at the truth, the D-optimal
    # campaign planned at the truth beats the even spread, the one planned at a 10 %-off
    # estimate does not (records near regime boundaries are misjudged).
    prec0 = np.eye(6) / PRIOR_SD**2

    def predicted(camp):
        return np.mean(posterior_sd(prec0 + np.asarray(fisher_information(truth, camp))))

    even = predicted(even_design(candidates, BUDGET))
    oracle = predicted(greedy_design(truth, candidates, BUDGET, prior_sd=PRIOR_SD).campaign)
    rough = predicted(greedy_design(guess, candidates, BUDGET, prior_sd=PRIOR_SD).campaign)
    assert oracle < 0.85 * even
    assert rough > oracle
