"""The documentation's generated parts (issue 20, item 5): the paper-to-code map read from
the docstrings, the figures the README and the site show, the notebooks' stored outputs.
(`mkdocs build --strict` itself runs in `.ci/run` with the `[docs]` extra.)"""

from __future__ import annotations

import importlib
import importlib.util
import json
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _paper_map():
    spec = importlib.util.spec_from_file_location("paper_map", DOCS / "paper_map.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_citations_are_read_with_ranges_and_lists():
    pm = _paper_map()
    c = pm.citations("eqs (5)-(7), (11) at drive speed; Table 6 and Figs 34/35; eq 12")
    assert c == {"eq": {"5", "6", "7", "11", "12"}, "table": {"6"}, "fig": {"34", "35"}}
    assert pm.citations("eq (1) + eq (3) with Table 6")["eq"] == {"1", "3"}
    assert pm.citations("Tables 1-4, 6")["table"] == {"1", "2", "3", "4", "6"}
    assert pm.citations("no citation here: equal (3) steps")["eq"] == set()


def test_paper_map_lists_the_implementations():
    pm = _paper_map()
    m = pm.paper_map()
    names = {kind: {n: {name for name, _ in rows} for n, rows in table.items()}
             for kind, table in m.items()}
    assert "stickslip_jax.friction.static.KatoStatic" in names["eq"]["1"]
    assert "stickslip_jax.friction.kinetic.KatoKinetic" in names["eq"]["3"]
    assert "stickslip_jax.steady.critical_speed" in names["eq"]["12"]
    assert "stickslip_jax.lubricants.kato_static" in names["table"]["9"]  # "Table 4, 6 or 9"
    text = pm.markdown()
    assert text.startswith("# Paper-to-code map") and "### eq (6)" in text
    assert "### Table 1" in text and "### Fig 34" in text


def test_paper_map_objects_exist():
    """Every object the map names can be imported (the map reads the source, not the
    installed package: a name it invents would be a broken page)."""
    pm = _paper_map()
    names = {name for table in pm.paper_map().values() for rows in table.values()
             for name, _ in rows}
    assert len(names) > 50
    for name in sorted(names):
        parts = name.split(".")
        for i in range(len(parts), 0, -1):  # the longest importable module prefix
            try:
                obj = importlib.import_module(".".join(parts[:i]))
                break
            except ImportError:
                continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)


IMAGES = ("fit", "discover", "design_map", "mcmc_corner", "record", "pitch", "fit_batch")


@pytest.mark.parametrize("name", IMAGES)
def test_figures_exist_and_are_small(name):
    path = DOCS / "images" / f"{name}.png"
    assert path.is_file(), "run: .venv/bin/python docs/make_figures.py"
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert path.stat().st_size < 400 * 1024


def test_readme_and_pages_show_existing_figures():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    shown = re.findall(r"!\[[^\]]*\]\((docs/images/[^)]+\.png)\)", readme)
    assert {pathlib.Path(p).stem for p in shown} >= {"fit", "discover", "design_map"}
    for p in shown:
        assert (ROOT / p).is_file(), p
    for page in DOCS.rglob("*.md"):
        for link in re.findall(r"!\[[^\]]*\]\(([^)]+\.png)\)", page.read_text(encoding="utf-8")):
            assert (page.parent / link).resolve().is_file(), (page, link)


@pytest.mark.parametrize("path", sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb")),
                         ids=lambda p: p.stem)
def test_notebooks_are_stored_with_their_figures(path):
    """The site renders the stored outputs (mkdocs-jupyter, execute: false)."""
    nb = json.loads(path.read_text(encoding="utf-8"))
    images = sum("image/png" in out.get("data", {}) for cell in nb["cells"]
                 for out in cell.get("outputs", []))
    assert images > 0, (f"{path.name} has no stored figure: run "
                        f".venv/bin/python docs/execute_notebooks.py {path.name[:2]}")
