"""The record plan as one call (`stickslip_fitting.api.plan.plan_records`): the plan
`stickslip plan` prints and writes, and errors naming the keyword."""

from __future__ import annotations

import json

import pytest
import stickslip_fitting as sf
from stickslip_fitting.api.design import parse_grid
from stickslip_fitting.api.plan import RecordPlan, plan_records
from stickslip_fitting.modes import DesignCriterion
from stickslip_jax.cli import main

AXES = ([11.3, 36.0, 53.2], [27.3, 86.9, 128.5],
        parse_grid("0.0022:92:12:log", "speed", "mm/min", "speeds"))
"""The command's default candidates in the package's units (kgf, kgf/mm, mm/s)."""


def test_plan_records_is_the_command(capsys):
    assert sf.plan_records is plan_records and sf.RecordPlan is RecordPlan
    plan = plan_records(["A"], *AXES, budget=2)
    assert isinstance(plan, RecordPlan) and plan.criterion is DesignCriterion.D
    assert main(["plan", "A", "--budget", "2", "--json"]) == 0
    printed = capsys.readouterr()  # with --json to stdout, the table goes to stderr
    assert json.loads(plan.to_json()) == json.loads(printed.out)
    assert printed.err.endswith(str(plan) + "\n") and plan.n_candidates == 3 * 3 * 12
    assert [r.stick_slip_expected for r in plan.records] == [
        r["stick_slip_expected"] for r in plan.report["records"]]


@pytest.mark.parametrize("kw, word", [
    (dict(budget=0), "budget"), (dict(criterion="E"), "criterion"),
    (dict(repeats=False, budget=200), "budget"),
])
def test_plan_records_errors_name_the_keyword(kw, word):
    with pytest.raises(ValueError, match=f"^{word}"):
        plan_records(["A"], *AXES, **kw)
