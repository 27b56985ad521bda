"""Messages that help: every error is one line that names the file or
the option and the fix; times are plain numbers; records in a spreadsheet's dialect (';',
tabs, decimal commas, quoted numbers, leading blank lines) are read; output paths are
checked before any work.

Each case asserts the exit code, that no input changed and that no output but the
expected one exists (`cli_safety.run_checked`)."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from cli_safety import EXAMPLES, copy_records, one_line, run_checked

REAL = Path(__file__).resolve().parents[1] / "data" / "real"

RECORD = EXAMPLES[10]  # k 86.9 kgf/mm, 30 mm/min: 501 samples, quick to plot


def _dialect(src, dst, kind):
    """`src` rewritten as a spreadsheet might save it."""
    lines = src.read_text().splitlines()
    out = []
    for ln in lines:
        if ln.startswith("#"):
            out.append(ln)
        elif kind == "semicolon":
            out.append(ln.replace(",", ";"))
        elif kind == "tab":
            out.append(ln.replace(",", "\t"))
        elif kind == "decimal comma":
            out.append(ln.replace(",", ";").replace(".", ","))
        elif kind == "quoted":
            out.append(",".join(f'"{c}"' for c in ln.split(",")))
        elif kind == "spaces":
            out.append(ln.replace(",", " "))
        else:
            out.append(ln)
    text = "\n".join(out) + "\n"
    dst.write_text("\n\n" + text if kind == "leading blank lines" else text)


@pytest.mark.parametrize("kind", ["semicolon", "tab", "decimal comma", "quoted",
                                  "leading blank lines"])
def test_spreadsheet_dialects_are_read(tmp_path, kind, capsys):
    """Semicolon and tab files, quoted numbers and a leading blank line (the docs say
    blank lines are ignored) are read, not refused as a bad column name or a bad row."""
    src = copy_records(tmp_path, [RECORD])[0]
    out, _ = run_checked(["plot", src, "--plot", tmp_path / "a.png"], capsys, tmp_path, 0,
                         new=["a.png"])
    bad = tmp_path / "bad.csv"
    _dialect(src, bad, kind)
    again, _ = run_checked(["plot", bad, "--plot", tmp_path / "b.png"], capsys, tmp_path, 0,
                           new=["b.png"])
    assert again.split(":", 1)[1] == out.split(":", 1)[1]  # the same samples and slips


def test_space_separated_columns_say_so(tmp_path, capsys):
    src = copy_records(tmp_path, [RECORD])[0]
    bad = tmp_path / "spaces.csv"
    _dialect(src, bad, "spaces")
    _, err = run_checked(["plot", bad, "--plot", tmp_path / "b.png"], capsys, tmp_path, 2)
    one_line(err, "spaces.csv", "line 8", "separate them")


def test_times_in_messages_are_plain_numbers(tmp_path, capsys):
    """Times in messages are plain numbers (`0.2 s`), never `np.float64(0.2) s`."""
    text = RECORD.read_text().splitlines()
    head = [ln for ln in text if not ln[:1].isdigit()]
    rows = [ln for ln in text if ln[:1].isdigit()][:50]
    rows[10], rows[11] = rows[11], rows[10]  # time goes back once
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(head + rows) + "\n")
    _, err = run_checked(["plot", bad, "--plot", tmp_path / "p.png"], capsys, tmp_path, 2)
    line = one_line(err, "bad.csv", "time does not increase", "sort the rows")
    assert "np.float64" not in line


@pytest.mark.parametrize("option", ["--speed", "--weight"])
def test_negative_grid_start_names_the_option(tmp_path, option, capsys):
    """`--speed -10:60:5` names the option and the fix, not argparse's 'expected one
    argument'."""
    args = {"--weight": "36", "--stiffness": "86.9", "--speed": "5", option: "-10:60:5"}
    _, err = run_checked(["design", *[x for kv in args.items() for x in kv], "--json"], capsys,
                         tmp_path, 2)
    line = one_line(err, option, "positive")
    assert "expected one argument" not in line


def test_mcmc_seed_out_of_range_names_the_option(tmp_path, capsys):
    records = copy_records(tmp_path, EXAMPLES[:3])
    _, err = run_checked(["mcmc", *records, "--seed", "-1"], capsys, tmp_path, 2)
    one_line(err, "--seed", "0 to 2**32 - 1")


@pytest.mark.parametrize("command", ["fit", "mcmc", "discover"])
def test_output_folder_is_checked_before_any_work(tmp_path, command, capsys):
    """The output folder is checked before any work, not after minutes of fitting."""
    records = copy_records(tmp_path, EXAMPLES)
    t0 = time.time()
    _, err = run_checked([command, *records, "--plot", tmp_path / "missing" / "fig.png"],
                         capsys, tmp_path, 2)
    one_line(err, "--plot", "missing", "create it first")
    assert time.time() - t0 < 30  # a fit of these records takes longer (with compilation)


@pytest.mark.parametrize("argv, names", [
    (["steady", "--weight", "36", "--stiffness", "86.9", "--speed", "5", "--lubricant", "Z"],
     ["--lubricant", "'Z'", "A, C"]),
    (["design", "--weight", "36", "--stiffness", "86.9", "--speed", "10:60:0"],
     ["--speed", "count must be >= 1", "e.g."]),
    (["design", "--weight", "36", "--stiffness", "86.9", "--speed", "5", "--level", "2"],
     ["--level", "between 0 and 1"]),
    (["simulate", "--lubricant", "A", "--weight", "36", "--stiffness", "86.9", "--speed",
      "10", "--duration", "1e9", "--out", "x.csv"], ["--duration", "shorten"]),
    (["plan", "nowhere.json"], ["nowhere.json", "neither a file nor a lubricant"]),
    (["plan", "A", "--budget", "0"], ["--budget", "1-1000"]),
    (["fit", "nowhere.csv"], ["nowhere.csv", "check the path"]),
    (["plot", "."], ["is a folder", "give one of its record files"]),
    (["discover", str(REAL), "--base", "smooth", "--loss", "student-t"],
     ["--loss student-t", "--base cycle"]),
    (["discover", str(REAL), "--loss", "cauchy"], ["--loss", "student-t:4"]),
])
def test_errors_name_the_option_or_file_and_the_fix(tmp_path, monkeypatch, argv, names,
                                                    capsys):
    monkeypatch.chdir(tmp_path)
    _, err = run_checked(argv, capsys, tmp_path, 2)
    one_line(err, *names)


def test_mcmc_walkers_are_checked_before_the_fit(tmp_path, capsys):
    """Too few walkers are refused before the fit (which takes minutes with --objective
    trace)."""
    records = copy_records(tmp_path, EXAMPLES)
    _, err = run_checked(["mcmc", *records, "--walkers", "3", "--fix", "n=1"], capsys,
                         tmp_path, 2)
    assert "fitting" not in err
    one_line(err, "--walkers", "at least 10 walkers", "5 free parameters")
