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

ROOT = Path(__file__).resolve().parents[1]

AREAS = ("README.md", "mkdocs.yml", "pyproject.toml", "docs", "stickslip_jax", "fitting",
         "tests", "benchmarks", "notebooks", ".ci")
"""What is walked, relative to the repository root (a folder: every text file in it)."""

SKIP_PARTS = {"__pycache__", ".ipynb_checkpoints", ".pytest_cache", ".hypothesis"}
SKIP_SUFFIXES = {".png", ".jpg", ".jpeg", ".gif", ".svg", ".pdf", ".nc", ".npz", ".npy",
                 ".pyc", ".gz", ".zip", ".h5"}
THIS = Path(__file__).resolve()  # holds the patterns themselves

PATTERNS = {
    "a numbered session of work": re.compile(r"\bsessions?[- ]\d", re.I),
    "an issue number": re.compile(r"\bissues?[- ]#?\d", re.I),
    "an issue cited as #N": re.compile(r"(?:(?<=[\s(])|^)#\d{1,4}(?=[\s),:]|$)"),
    "an issue's wording": re.compile(r"\bissue's\b", re.I),
    "a numbered round of work": re.compile(
        r"(?<!reweighting )(?<!screening )\bround \d+\b|\brounds? of work\b", re.I),
    "a numbered stop": re.compile(r"\bstop \d", re.I),
    "an earlier build or session": re.compile(
        r"\b(?:an? |the )?(?:earlier|previous|last|this) (?:session|build)'?s?\b", re.I),
    "a change note": re.compile(r"\(was: |\buntil (?:issue|session|round)\b", re.I),
}
"""Name -> pattern of development history. `test_patterns_tell_history_from_prose`
pins down what each must catch and what it must leave alone."""


def _files():
    for area in AREAS:
        path = ROOT / area
        if path.is_file():
            yield path
        elif path.is_dir():
            for f in sorted(path.rglob("*")):
                if (f.is_file() and f.resolve() != THIS and f.suffix.lower() not in SKIP_SUFFIXES
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


HISTORY = [
    "README, session 21: the crash was the memory-map limit",
    "Session 20 removed this, blaming the thread",
    "the slow tests did, session-20)",
    "sessions 12 to 14 (8 of 10)",
    "JSON keys renamed by issue 20 keep old aliases",
    "\"\"\"Issue 21, messages that did not help",
    "Shared helpers of the issue-21 command-line tests",
    "the vectorised pitch scan (#18)",
    "see #7 for the discussion",
    "The issue's targets at these sizes",
    "after round 3 of the review",
    "two rounds of work later",
    "in CI too (stop 33).",
    "an earlier build of this solver printed intervals",
    "before this session's anchoring",
    "refuses an empty campaign by name (was: max() arg is an empty sequence)",
    "`fit --eta` took kgf*s/mm^2 until issue 17",
]
"""Sentences of development history, each of which a pattern must catch."""

PROSE = [
    "Each round freezes the weights at the previous round's optimum.",
    "two or three reweighting rounds reach the fixed point",
    "the first reweighting round 1 starts at the data",
    "the screening round 2 stops early",
    "int(round(duration * rate)) + 1",
    "np.round(x / 1e-3) * 1e-3",
    "round trips of the record format",
    "color='#1f77b4', edgecolor='#000000', fill '#333'; border: 1px solid #333;",
    "x = values[0]  #0-based; ax.plot(x, y, 'k#')",
    "see https://github.com/google/jax/issues/1234 for XLA's map limit",
    "README anchor [Records](#records); heading ## 3. Units",
    "Markdown list item #1.5 and x#2",
    "the chi2 drop (was -1200) after the polish",
    "the last sample before the stick; the drive stops 2 s later",
    "an issue the user can fix, printed as one line",
    "LM stops earlier at convergence",
    "every session of the notebook kernel",
    "NOTES.md item 3; Table 6, Fig 34",
]
"""Legitimate text (code and physics) that no pattern may match."""


@pytest.mark.parametrize("sentence", HISTORY)
def test_patterns_catch_history(sentence):
    assert history(sentence), sentence


@pytest.mark.parametrize("sentence", PROSE)
def test_patterns_tell_history_from_prose(sentence):
    assert not history(sentence), history(sentence)
