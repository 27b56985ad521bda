"""The product speaks only of itself: no development history in its text.

README, docs, the packages, tests, benchmarks, notebooks and CI scripts say what the
software does and why. Which round of work built something, which issue asked for it and
what an earlier build did belong in git's commit messages (a CHANGELOG of user-visible
changes per release is not walked here). Each pattern below is one way such history gets
written; each failure lists file:line and the text around the match.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import tomllib

ROOT = Path(__file__).resolve().parents[1]

AREAS = ("README.md", "mkdocs.yml", "pyproject.toml", "docs", "stickslip_jax", "fitting",
         "tests", "benchmarks", "notebooks", ".ci")
"""What is walked, relative to the repository root (a folder: every text file in it)."""

SKIP_PARTS = {"__pycache__", ".ipynb_checkpoints", ".pytest_cache", ".hypothesis"}
SKIP_SUFFIXES = {".png", ".jpg", ".jpeg", ".gif", ".svg", ".pdf", ".nc", ".npz", ".npy",
                 ".pyc", ".gz", ".zip", ".h5"}
THIS = Path(__file__).resolve()

EXAMPLES = Path(__file__).with_name("product_text.toml")
"""The patterns and the sentences that pin them down (a data file, so that this module
holds none of the words it looks for)."""
_DATA = tomllib.loads(EXAMPLES.read_text(encoding="utf-8"))
PATTERNS = {name: re.compile(pattern, re.I if ignore_case else 0)
            for name, (pattern, ignore_case) in _DATA["patterns"].items()}
"""Name -> pattern of development history. `test_patterns_tell_history_from_prose`
pins down what each must catch and what it must leave alone."""


def _files():
    for area in AREAS:
        path = ROOT / area
        if path.is_file():
            yield path
        elif path.is_dir():
            for f in sorted(path.rglob("*")):
                if (f.is_file() and f.resolve() not in (THIS, EXAMPLES.resolve())
                        and f.suffix.lower() not in SKIP_SUFFIXES
                        and not SKIP_PARTS.intersection(f.parts)
                        and not any(p.endswith(".egg-info") for p in f.parts)):
                    yield f


def history(text: str) -> list[tuple[int, str, str]]:
    """(line number, pattern name, the text around the match) for every match."""
    hits = []
    for i, line in enumerate(text.splitlines(), 1):
        for name, pattern in PATTERNS.items():
            for m in pattern.finditer(line):
                hits.append((i, name, line[max(0, m.start() - 50):m.end() + 50].strip()))
    return hits


def _area(path: Path) -> str:
    return path.relative_to(ROOT).parts[0]


@pytest.mark.parametrize("area", AREAS)
def test_no_development_history(area):
    if not (ROOT / area).exists():
        pytest.skip(f"{area} is not in this checkout")
    found = []
    for f in (f for f in _files() if _area(f) == area):
        try:
            text = f.read_text(encoding="utf-8")
        except UnicodeDecodeError:  # a binary file under another suffix
            continue
        found += [f"{f.relative_to(ROOT)}:{i}: [{name}] {snippet}"
                  for i, name, snippet in history(text)]
    assert not found, ("development history in the product (say what the code does and "
                       "why; history goes in commit messages):\n" + "\n".join(found))


def test_the_walk_reaches_every_area():
    """Every area that exists contributes files (a walk that silently finds nothing would
    pass everything)."""
    areas = {_area(f) for f in _files()}
    for area in ("README.md", "docs", "stickslip_jax", "fitting", "tests", "benchmarks",
                 "notebooks"):
        assert area in areas, area
    assert THIS not in {f.resolve() for f in _files()}
    assert any(f.suffix == ".ipynb" for f in _files())


HISTORY = _DATA["history"]
"""Sentences of development history, each of which a pattern must catch."""

PROSE = _DATA["prose"]
"""Legitimate text (code and physics) that no pattern may match."""


@pytest.mark.parametrize("sentence", HISTORY)
def test_patterns_catch_history(sentence):
    assert history(sentence), sentence


@pytest.mark.parametrize("sentence", PROSE)
def test_patterns_tell_history_from_prose(sentence):
    assert not history(sentence), history(sentence)
