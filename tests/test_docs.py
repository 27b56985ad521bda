"""The documentation: the README for new users (short, its commands run on shipped files
with options the commands have), the site's navigation and links, and its generated parts
(the paper-to-code map read from the docstrings, the figures the README and the site show,
the notebooks' stored outputs). `mkdocs build --strict` itself runs in `.ci/run` with the
`[docs]` extra."""

from __future__ import annotations

import importlib
import importlib.util
import json
import os
import pathlib
import re
import shlex

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
    assert {pathlib.Path(p).stem for p in shown} >= {"fit"}
    home = (DOCS / "index.md").read_text(encoding="utf-8")
    on_home = re.findall(r"!\[[^\]]*\]\((images/[^)]+\.png)\)", home)
    assert {pathlib.Path(p).stem for p in on_home} >= {"fit", "discover", "design_map"}
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


# --- the README and the commands shown in it and on the pages ----------------------------

README = ROOT / "README.md"
README_MAX_LINES = 250
FENCE = re.compile(r"^```(?:bash|sh|shell|console)[^\n]*\n(.*?)^```", re.S | re.M)
OUTPUT_OPTIONS = {"--json", "--plot", "--out", "--csv", "--chain", "--netcdf", "--corner"}
YOUR_FILES = re.compile(r"#\s*your files", re.I)
PATH_SUFFIXES = (".csv", ".json", ".txt", ".nc", ".png", ".mat", ".tsv")


def shell_commands(text: str) -> list[tuple[str, bool]]:
    """Every `stickslip ...` command line in the fenced shell blocks of a Markdown text
    (continuation lines joined; a leading `.venv/bin/` dropped), with whether it is
    marked `# your files` (it needs files the repository does not ship)."""
    found = []
    for block in FENCE.findall(text):
        for line in re.sub(r"\s*\\\n\s*", " ", block).splitlines():
            line = line.strip()
            for prefix in (".venv/bin/", "$ "):
                line = line.removeprefix(prefix)
            if line.startswith("stickslip "):
                found.append((line, bool(YOUR_FILES.search(line))))
    return found


def _words(command: str) -> list[str]:
    return shlex.split(command, comments=True)


def _is_path(word: str) -> bool:
    """A word that names a file or folder: no spaces, not an option, not a value with a
    unit (those start with a digit), and a file suffix or a folder separator."""
    if not word or word[0] in "-0123456789" or any(c.isspace() for c in word):
        return False
    return word.endswith(PATH_SUFFIXES) or "/" in word


def missing_files(commands: list[str]) -> list[tuple[str, str]]:
    """(command, path) for each input path of the commands that exists neither in the
    repository (glob patterns expanded) nor as an output of an earlier command."""
    made, missing = set(), []
    for command in commands:
        words = _words(command)
        for i, word in enumerate(words):
            if i and words[i - 1] in OUTPUT_OPTIONS:
                made.add(word)
                continue
            if not _is_path(word) or word in made:
                continue
            if not (sorted(ROOT.glob(word)) if any(c in word for c in "*?[") else
                    (ROOT / word).exists()):
                missing.append((command, word))
    return missing


def test_shell_command_parser():
    text = ("```bash\nstickslip fit data/examples/*.csv --json fit.json \\\n    --plot f.png\n"
            ".venv/bin/stickslip design --posterior fit.json --speed \"5 um/s\"  # a note\n"
            "stickslip import raw.txt --out r.csv   # your files\npython x.py\n```\n")
    commands = shell_commands(text)
    assert [c for c, _ in commands] == [
        "stickslip fit data/examples/*.csv --json fit.json --plot f.png",
        'stickslip design --posterior fit.json --speed "5 um/s"  # a note',
        "stickslip import raw.txt --out r.csv   # your files"]
    assert [mine for _, mine in commands] == [False, False, True]
    assert missing_files([c for c, mine in commands if not mine]) == []  # fit.json made first
    assert missing_files(["stickslip fit data/nowhere/*.csv", "stickslip plot nowhere.csv",
                          "stickslip steady --speed 1um/s --weight 36"]) == [
        ("stickslip fit data/nowhere/*.csv", "data/nowhere/*.csv"),
        ("stickslip plot nowhere.csv", "nowhere.csv")]


def test_readme_is_short():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, (
        f"README.md has {len(lines)} lines; it is the page a new user reads first: move "
        f"reference material to docs/ (at most {README_MAX_LINES} lines)")


def _documents():
    return [README, *sorted(DOCS.glob("*.md")), *sorted((DOCS / "commands").glob("*.md"))]


@pytest.mark.parametrize("path", _documents(), ids=lambda p: str(p.relative_to(ROOT)))
def test_commands_use_files_that_exist(path):
    """Every `stickslip` command shown runs on files the repository ships (or that an
    earlier command on the same page writes), unless it is marked `# your files`."""
    commands = [c for c, mine in shell_commands(path.read_text(encoding="utf-8")) if not mine]
    assert missing_files(commands) == []


def test_readme_shows_commands_and_the_two_setup_commands():
    text = README.read_text(encoding="utf-8")
    commands = [c for c, mine in shell_commands(text) if not mine]
    assert len(commands) >= 5
    assert ("python3 -m venv .venv && .venv/bin/pip install -q -e \".[test]\" && "
            ".venv/bin/stickslip fit data/examples/*.csv") in text
    test_command = ("python3 -m venv .venv && .venv/bin/pip install -q -e \".[test]\" && "
                    ".venv/bin/python -m pytest -n 2 -q")
    assert test_command in text
    # CI runs the README's test command
    assert test_command in (ROOT / ".ci" / "run").read_text(encoding="utf-8")


def _options_of(parser) -> dict[str, set[str]]:
    import argparse

    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {name: {opt for action in p._actions for opt in action.option_strings}
            for name, p in sub.choices.items()}


@pytest.mark.parametrize("path", _documents(), ids=lambda p: str(p.relative_to(ROOT)))
def test_commands_use_options_the_commands_have(path):
    """Every subcommand and `--option` shown is one `stickslip` has (the parser is built
    without running anything), so a renamed option cannot linger in the docs."""
    from stickslip_jax.cli import build_parser

    options = _options_of(build_parser())
    wrong = []
    for command, _ in shell_commands(path.read_text(encoding="utf-8")):
        words = [w for w in _words(command)[1:] if w != "--debug"]
        if not words or words[0].startswith("-"):  # stickslip --help, --version
            continue
        name = words[0]
        if name not in options:
            wrong.append((command, name))
            continue
        for word in words[1:]:
            if word.startswith("--") and word.split("=")[0] not in options[name]:
                wrong.append((command, word))
    assert wrong == []


def _nav_pages(nav) -> list[str]:
    pages = []
    for item in nav:
        for value in (item.values() if isinstance(item, dict) else [item]):
            pages += _nav_pages(value) if isinstance(value, list) else [value]
    return pages


def _nav() -> list[str]:
    """The pages of mkdocs.yml's nav (read as text: the file holds no anchors or tags
    in the nav, so the indentation-based list is all there is to parse)."""
    text = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    nav = text[text.index("\nnav:"):]
    return re.findall(r"^\s*-\s*(?:[^:\n]+:\s*)?(\S+\.(?:md|ipynb))\s*$", nav, re.M)


def test_every_page_is_in_the_nav_and_every_nav_page_exists():
    nav = _nav()
    assert "index.md" in nav and "validation.md" in nav and "benchmarks.md" in nav
    generated = {"paper-map.md"}  # made by docs/hooks.py at build time
    for page in nav:
        assert page in generated or (DOCS / page).is_file(), page
    pages = {str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md")}
    assert pages - set(nav) == set(), "pages not reachable from the nav"


def test_readme_links_resolve():
    text = README.read_text(encoding="utf-8")
    links = re.findall(r"\]\(((?!https?:)[^)#\s]+)(?:#[^)]*)?\)", text)
    assert links
    for link in links:
        assert (ROOT / link).exists(), link


def test_pages_link_to_pages_that_exist():
    """Relative links between pages (mkdocs --strict checks them too; this is the cheap
    check that runs with the tests)."""
    for page in DOCS.rglob("*.md"):
        for link in re.findall(r"\]\(((?!https?:|mailto:)[^)#\s]+\.md)(?:#[^)]*)?\)",
                               page.read_text(encoding="utf-8")):
            target = (page.parent / link).resolve()
            assert target.is_file() or target.name == "paper-map.md", (page, link)


def _readme_python_blocks() -> list[str]:
    text = README.read_text(encoding="utf-8")
    return re.findall(r"^```python\n(.*?)^```", text, re.S | re.M)


def _sandbox(tmp_path):
    """A folder whose data/ is the repository's, so that the README's relative paths
    read the shipped files and its outputs (fit.png, ...) land in the folder."""
    (tmp_path / "data").symlink_to(ROOT / "data", target_is_directory=True)
    return tmp_path


@pytest.mark.slow
@pytest.mark.parametrize("command", [c for c, mine in shell_commands(README.read_text(
    encoding="utf-8")) if not mine], ids=lambda c: c[:60])
def test_readme_commands_run(command, tmp_path):
    """Each command of the README runs on the shipped files and exits 0."""
    import subprocess
    import sys

    env = dict(os.environ, PATH=f"{pathlib.Path(sys.executable).parent}{os.pathsep}"
               f"{os.environ.get('PATH', '')}")
    proc = subprocess.run(["bash", "-c", command], cwd=_sandbox(tmp_path), env=env,
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]


@pytest.mark.slow
@pytest.mark.parametrize("code", _readme_python_blocks(), ids=lambda c: c.split("\n")[0][:40])
def test_readme_python_runs(code, tmp_path):
    """The README's Python example runs as shown, on the shipped files."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", code], cwd=_sandbox(tmp_path),
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]


# --- the benchmarks page and the script that writes it ------------------------------------

def _report():
    spec = importlib.util.spec_from_file_location("bench_report", ROOT / "benchmarks" / "report.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_benchmark_report_knows_every_script_and_the_page_has_its_section():
    report = _report()
    scripts = {p.stem for p in (ROOT / "benchmarks").glob("*.py")}
    helpers = {"report", "scipy_reference", "design_worker"}
    assert set(report.BENCHMARKS) == scripts - helpers
    page = (DOCS / "benchmarks.md").read_text(encoding="utf-8")
    for name in report.BENCHMARKS:
        begin, end = report.markers(name)
        assert page.count(begin) == 1 and page.count(end) == 1, name
        assert page.index(begin) < page.index(end), name
    assert set(report.FAST) <= set(report.BENCHMARKS)


def test_benchmark_report_replaces_one_section_and_adds_missing_ones():
    report = _report()
    page = ("# Benchmarks\n\n<!-- report.py:begin records -->\nold figures\n"
            "<!-- report.py:end records -->\n\ntext after\n")
    new = report.update_page(page, "records", "new figures\n```text\nx\n```")
    assert "old figures" not in new and "new figures" in new and new.endswith("text after\n")
    assert new.count("report.py:begin records") == 1
    added = report.update_page(new, "fit", "fit figures")
    assert added.startswith(new.rstrip("\n")) and "## `benchmarks/fit.py`" in added
    assert "<!-- report.py:begin fit -->\nfit figures\n<!-- report.py:end fit -->" in added
    host = {"cpu": "CPU", "cores": "2", "platform": "p", "python": "3", "jax": "j",
            "jaxlib": "l", "devices": "cpu"}
    facts = {"date": "d", "command": "python benchmarks/records.py", "wall_s": 1.0,
             "load_before": "1", "load_after": "2"}
    block = report.section("records", "table\n", facts, host)
    assert "| CPU | CPU |" in block and "| cores | 2 |" in block and "table" in block


@pytest.mark.parametrize("path", _documents(), ids=lambda p: str(p.relative_to(ROOT)))
def test_repository_files_named_exist(path):
    """A test, script, data file or module the text names (`tests/test_x.py`, ...) is there."""
    named = re.findall(r"\b((?:tests|benchmarks|docs|data|notebooks|stickslip_jax|fitting)"
                       r"/[\w./-]+\.(?:py|csv|json|md|txt))\b", path.read_text(encoding="utf-8"))
    assert [n for n in named if not (ROOT / n).exists()] == []
