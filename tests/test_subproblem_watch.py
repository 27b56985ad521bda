"""The watched sub-problem fit (`subproblems._Watch`): it keeps the best point the solver
itself would accept, and its chi-square floor never breaks on a non-finite linear model."""
from __future__ import annotations

import numpy as np

from stickslip_fitting.discovery.subproblems import _Watch


def _evaluate_with(J):
    def evaluate(z):
        return np.array([1.0, 2.0]) + z.sum(), J, True
    return evaluate


def test_a_non_finite_jacobian_is_not_kept():
    """A point whose residuals are finite but whose Jacobian is not (the solver rejects
    it) is not kept as the best point, and no eigendecomposition of it is attempted."""
    watch = _Watch(_evaluate_with(np.array([[np.nan, 1.0], [1.0, 1.0]])), 0.0, None,
                   np.zeros(2), 25)
    watch(np.zeros(2))
    assert watch.z is None and watch.cost == np.inf


def test_an_overflowing_normal_matrix_gives_no_floor():
    """A finite Jacobian whose normal matrix overflows is kept (the residuals are fine),
    with no chi-square floor (-inf: the fit is never judged hopeless from it)."""
    watch = _Watch(_evaluate_with(np.array([[1e200, 1.0], [1.0, 1.0]])), 0.0, None,
                   np.zeros(2), 25)
    watch(np.zeros(2))
    assert watch.cost == 5.0 and watch.floor == -np.inf


def test_a_finite_point_sets_the_floor():
    """A well-posed point: floor = cost - HOPE x the Gauss-Newton decrease (here the
    full cost, the residuals lying in the Jacobian's range)."""
    from stickslip_fitting.discovery.subproblems import HOPE

    watch = _Watch(_evaluate_with(np.eye(2)), 0.0, None, np.zeros(2), 25)
    watch(np.zeros(2))
    assert np.isclose(watch.floor, 5.0 - HOPE * 5.0)
