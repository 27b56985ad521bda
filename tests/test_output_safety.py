"""Nothing the user gave us is overwritten or lost.

Every output path is checked before any work starts (an input record, a folder, a
missing folder, two options naming one file), and files are written atomically (a
failure while writing leaves the previous file, and no temporary file). The command-line
cases live in one module per family: tests/test_cli_data_loss.py,
test_cli_wrong_answers.py, test_cli_tracebacks.py and test_cli_messages.py; here the
writer itself, strict JSON, exit codes 1 and 3 and the schema version."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import pytest

from stickslip_jax.cli import main
from stickslip_jax import output as _output

EXAMPLES = sorted(Path(__file__).resolve().parents[1].joinpath("data", "examples").glob("*.csv"))


def _hash(p) -> str:
    return hashlib.sha256(Path(p).read_bytes()).hexdigest()


@pytest.fixture
def camp(tmp_path):
    out = []
    for p in EXAMPLES[:3]:
        q = tmp_path / p.name
        q.write_bytes(p.read_bytes())
        out.append(q)
    return out


def test_two_options_naming_one_file_are_refused(camp, tmp_path, capsys):
    same = str(tmp_path / "out.json")
    before = [_hash(p) for p in camp]
    assert main(["fit", *map(str, camp), "--json", same, "--plot", same]) == 2
    assert "same file" in capsys.readouterr().err
    assert [_hash(p) for p in camp] == before and not Path(same).exists()


def test_failed_write_keeps_the_previous_file(tmp_path, monkeypatch):
    target = tmp_path / "result.json"
    target.write_text('{"previous": true}')

    def boom(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError):
        _output.write_json(str(target), {"new": 1})
    assert json.loads(target.read_text()) == {"previous": True}
    assert [p.name for p in tmp_path.iterdir()] == ["result.json"]  # no temporary left


def test_swallowed_interrupt_still_stops_the_output(tmp_path, monkeypatch):
    """A Ctrl-C can land in one of JAX's garbage-collector callbacks, where Python prints
    "Exception ignored" and goes on: `simulate` would then finish, write its record and
    exit 0. The handler records the interrupt, so no output is renamed into place and
    the command exits 130 (`cli.main`)."""
    monkeypatch.setattr(_output, "_INTERRUPTED", False)
    try:
        _output._on_sigint(2, None)  # the handler, its KeyboardInterrupt swallowed
    except KeyboardInterrupt:
        pass
    assert _output.interrupted()
    target = tmp_path / "result.json"
    with pytest.raises(KeyboardInterrupt):
        _output.write_json(str(target), {"new": 1})
    assert list(tmp_path.iterdir()) == []  # neither the output nor a temporary file


def test_swallowed_interrupt_prints_no_traceback(monkeypatch):
    """The swallowed Ctrl-C is not reported as "Exception ignored ... Traceback"; any
    other unraisable exception still reaches the previous hook."""
    import sys
    import types

    seen = []
    hook = _output._unraisable(seen.append)
    monkeypatch.setattr(_output, "_INTERRUPTED", True)
    hook(types.SimpleNamespace(exc_type=KeyboardInterrupt))
    hook(types.SimpleNamespace(exc_type=RuntimeError))
    assert [u.exc_type for u in seen] == [RuntimeError]
    assert sys.unraisablehook is not hook  # installed only by the command (catch_interrupts)


def test_json_is_strict():
    text = json.dumps(_output.strict_json({"a": float("nan"), "b": [1.0, float("inf")]}),
                      allow_nan=False)
    assert json.loads(text) == {"a": None, "b": [1.0, None]}


def test_outputs_get_the_usual_permissions(tmp_path):
    """Atomic writes go through a private temporary file; the output must still get the
    permissions a plain `open` gives (or keep those of the file it replaces)."""
    umask = os.umask(0o022)
    try:
        new = tmp_path / "new.json"
        _output.write_json(str(new), {"a": 1})
        assert new.stat().st_mode & 0o777 == 0o644
        old = tmp_path / "old.json"
        old.write_text("{}")
        old.chmod(0o640)
        _output.write_json(str(old), {"a": 2})
        assert old.stat().st_mode & 0o777 == 0o640
    finally:
        os.umask(umask)


def test_debug_shows_the_traceback(tmp_path, capsys):
    """A ValueError is one line without a traceback; `--debug` shows the traceback."""
    missing = str(tmp_path / "nowhere.csv")
    assert main(["fit", missing]) == 2
    assert "Traceback" not in capsys.readouterr().err
    with pytest.raises((ValueError, FileNotFoundError)):
        main(["--debug", "fit", missing])


def test_a_fit_that_did_not_converge_exits_3(monkeypatch, capsys):
    """A fit that did not converge exits 3, not 0, and says so."""
    import dataclasses

    import stickslip_fitting.commands.fit as fit_command

    real = fit_command.fit_from_args

    def not_converged(args, **kwargs):
        result = real(args, **kwargs)
        return dataclasses.replace(result, report={**result.report, "converged": False})

    monkeypatch.setattr(fit_command, "fit_from_args", not_converged)
    assert main(["fit", *map(str, EXAMPLES)]) == 3
    assert "did not converge" in capsys.readouterr().err


def test_every_json_carries_the_schema_version(tmp_path, capsys):
    """Every JSON output carries the schema version."""
    from stickslip_jax.output import SCHEMA_VERSION

    assert main(["steady", "--weight", "36", "--stiffness", "86.9", "--speed", "5",
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["schema_version"] == SCHEMA_VERSION
    out = tmp_path / "f.json"
    assert main(["fit", *map(str, EXAMPLES), "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert list(doc)[0] == "schema_version" and doc["schema_version"] == SCHEMA_VERSION


