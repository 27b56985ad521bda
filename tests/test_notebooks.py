"""Every notebook's jupytext twin (`notebooks/NN_*.py`) runs headless, top to bottom, at small size.

Notebooks read `STICKSLIP_SMALL=1` to shrink their grids and sample counts.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.py"))
SLOW = {"01_paper_model", "02_contact_microsqueeze", "03_identification", "04_design",
        "05_missing_physics", "06_pitching", "07_real_records", "08_rotational_rigs"}
"""The longest notebooks at small size (04_design: 56 s of CPU time; 02 and 06: 31 and
24 s on the quiet 2-core machine, compiling most of it; 03 and 07: 22 and 18 s with an
empty compilation cache, load 10-19; 01 and 08: 22 s together, empty cache, load 10), their
functions each checked by their own modules (04: test_experiment_design,
test_inverse_design, test_design_maps; 02: test_microsqueeze, test_contact_boundary,
test_contact_surfaces; 06: test_pitching; 03's fit, summary, plot and posterior: test_api,
test_api_results, test_one_record; 07's fit of the measured records with their screening
and steady-record lines: test_real_data, its Student-t fit: test_losses, test_cli_loss;
01's static laws of Tables 3 and 4, steady maps, slip trajectory and critical speeds
against the natural frequency and the friction parameters (Figs 36-41): test_friction,
test_tables, test_steady; 08's rotational records, their rig units and the fit of a
rotational campaign with a normal load: test_rigs, test_normal_load): run with the slow
tests (`.ci/run` runs all the notebooks in a step of their own), keeping the default suite
short."""


@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.slow) if p.stem in SLOW
                                  else p for p in NOTEBOOKS], ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_headless(path, tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg", STICKSLIP_SMALL="1", STICKSLIP_FIGDIR=str(tmp_path))
    if os.environ.get("STICKSLIP_CACHE_DIR"):  # the test run's compilation cache (conftest)
        env.update(JAX_COMPILATION_CACHE_DIR=os.environ["STICKSLIP_CACHE_DIR"],
                   JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS="0.1")
    proc = subprocess.run(
        [sys.executable, str(path)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-4000:]


def test_each_notebook_has_ipynb_twin():
    for path in NOTEBOOKS:
        assert path.with_suffix(".ipynb").exists(), f"{path.name} has no .ipynb twin (jupytext --to ipynb)"


def test_each_stored_notebook_holds_the_outputs_of_its_source():
    """The published .ipynb (rendered by the docs without running it) was executed from
    its .py source as it stands (docs/execute_notebooks.py): the same code cells, and the
    figures stored with them."""
    jupytext = pytest.importorskip("jupytext", reason="jupytext (the [test] extra) is not installed")
    for path in NOTEBOOKS:
        source = [c.source for c in jupytext.read(path).cells if c.cell_type == "code"]
        stored = [c for c in jupytext.read(path.with_suffix(".ipynb")).cells if c.cell_type == "code"]
        assert [c.source for c in stored] == source, (
            f"{path.with_suffix('.ipynb').name} was not executed from {path.name} as it stands: "
            f"run .venv/bin/python docs/execute_notebooks.py {path.name[:2]}")
        images = [o for c in stored for o in c.get("outputs", []) if "image/png" in o.get("data", {})]
        assert images, f"{path.with_suffix('.ipynb').name} stores no figure"
