"""The one typed parameter row (`stickslip_fitting.report.rows`): intervals from log or Gaussian
coordinates, JSON subsets, and the discovery results' dicts derived from their rows."""

from __future__ import annotations

import dataclasses

import numpy as np

from stickslip_fitting.report.rows import Z95, DiscoveryEstimates, ParameterEstimate


def test_from_log_and_from_normal():
    e = ParameterEstimate.from_log("gamma", "s^-m", np.log(2.0), 0.1)
    assert np.isclose(e.value, 2.0) and np.isclose(e.stderr, 0.2) and e.log_sd == 0.1
    assert np.allclose(e.ci95, (2.0 * np.exp(-Z95 * 0.1), 2.0 * np.exp(Z95 * 0.1)))
    g = ParameterEstimate.from_normal("h", "mm", 30.0, 2.0)
    assert g.ci95 == (30.0 - Z95 * 2.0, 30.0 + Z95 * 2.0) and g.log_sd is None
    bare = ParameterEstimate.from_normal("mu_d", "-", 0.2)
    assert bare.stderr is None and bare.ci95 is None
    assert g.to_json(("value", "stderr", "unit")) == {"value": 30.0, "stderr": 2.0, "unit": "mm"}
    assert list(g.to_json()) == ["value", "stderr", "ci95", "unit", "identifiable", "fixed",
                                 "reason", "at_bound"]


@dataclasses.dataclass
class _Result(DiscoveryEstimates):
    estimates_before: list
    estimates_after: list
    effect_estimates: list
    effect_of: str = ""


def test_discovery_dicts_come_from_the_rows():
    units = {"mu_s": "-", "mu_d": "-"}
    res = _Result(DiscoveryEstimates.value_rows({"mu_s": 0.3, "mu_d": 0.2}, units),
                  DiscoveryEstimates.value_rows({"mu_s": 0.31, "mu_d": 0.21}, units),
                  [ParameterEstimate.from_normal("rate", "mm/s", 1e-3, 2e-4)], "drift")
    assert res.parameters_before == {"mu_s": 0.3, "mu_d": 0.2}
    assert res.parameters_after == {"mu_s": 0.31, "mu_d": 0.21, "drift.rate": 1e-3}
    assert res.effect_size == {"rate": {"value": 1e-3, "stderr": 2e-4, "unit": "mm/s"}}
