"""Regimes of the steady analysis (stickslip_jax.steady.restick_failure, SteadyState.regime)
against the exact simulator: where a slip cannot end in a stick the simulator shows double
slips (cycles with no stick between them), and only there."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

import stickslip_jax as ss
from stickslip_jax.drives import ConstantSpeed
from stickslip_jax.simulation import simulate_exact
from stickslip_jax.steady import RESTICK_FAILURE, STEADY_SLIDING, STICK_SLIP

# (lubricant, W kgf, k kgf/mm): both sides of exp(-delta T2^n) = 1/2 for A and C
POINTS = [("A", 36.0, 86.9), ("A", 11.3, 128.5), ("A", 36.0, 27.3), ("C", 11.3, 86.9),
          ("C", 36.0, 86.9), ("C", 36.0, 27.3)]


def _double_slips(lub, W, k, v, t1):
    sw = ss.Slideway(ss.lubricant(lub), W, k)
    horizon = 6.0 * t1 + 10.0  # the start-up stick and several steady cycles
    tr = simulate_exact(sw, ConstantSpeed(v), jnp.linspace(0.0, horizon, 2001), max_events=120)
    st = np.asarray(tr.cycles.stick_time)[np.asarray(tr.cycles.valid)]
    assert st.size >= 3, (lub, W, k)
    return bool(np.any(st[1:] <= 1e-9))  # after the first (start-up) stick


@pytest.mark.parametrize("lub, W, k", POINTS)
def test_restick_failure_agrees_with_the_exact_simulator(lub, W, k):
    v = 0.5 / 60.0  # 0.5 mm/min: below every point's v_c
    s = ss.steady_state(ss.lubricant(lub), W, k, v)
    assert int(s.regime) != STEADY_SLIDING
    assert (int(s.regime) == RESTICK_FAILURE) == _double_slips(lub, W, k, v,
                                                               float(s.stick_time))


def test_regime_codes_and_cli(capsys):
    from stickslip_jax.cli import main

    out = ss.steady_map(ss.lubricant("C"), 11.3, 86.9, jnp.array([1.0, 100.0]) / 60.0)
    assert [ss.REGIMES[int(r)] for r in out.regime] == ["re-stick failure", "steady sliding"]
    assert main(["steady", "--lubricant", "C", "--weight", "11.3", "--stiffness", "86.9",
                 "--speed", "1", "100"]) == 0
    text = capsys.readouterr().out
    assert "double" in text and "re-stick failure" in text and "double slips" in text
    ok = ss.steady_state(ss.lubricant("A"), 36.0, 86.9, 5.0 / 60.0)
    assert int(ok.regime) == STICK_SLIP
