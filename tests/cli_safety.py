"""Shared helpers of the command-line safety tests (test_cli_data_loss, _wrong_answers,
_tracebacks, _messages): run a `stickslip` command on copies of the shipped records in a
scratch folder and check, besides its exit code, that no input changed (SHA-256 before
and after) and that no output but the expected one exists (no partial file, no temporary
file left behind)."""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

from stickslip_jax.cli import main

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted(ROOT.joinpath("data", "examples").glob("*.csv"))
TRUTH = ROOT / "data" / "examples" / "truth.json"


def sha256(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def snapshot(folder) -> dict[str, str]:
    """{path relative to `folder`: SHA-256} of every file below it (hidden ones too)."""
    folder = Path(folder)
    return {str(p.relative_to(folder)): sha256(p) for p in sorted(folder.rglob("*"))
            if p.is_file()}


def copy_records(folder, records=EXAMPLES) -> list[Path]:
    """Copies of `records` in `folder` (the commands never see data/ itself)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for p in records:
        q = folder / Path(p).name
        shutil.copy(p, q)
        out.append(q)
    return out


def run_checked(argv, capsys, folder, code: int, new=()) -> tuple[str, str]:
    """Run `stickslip argv` (in this process) and assert: the exit code is `code`, every
    file of `folder` is unchanged, and the only files added there are `new` (paths relative
    to `folder`). Returns (stdout, stderr)."""
    before = snapshot(folder)
    got = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert got == code, f"exit {got}, expected {code}; stderr: {err[-2000:]}"
    after = snapshot(folder)
    changed = [p for p, h in before.items() if after.get(p) != h]
    assert not changed, f"inputs changed or removed: {changed}"
    added = set(after) - set(before)
    assert added == set(map(str, new)), f"outputs {sorted(added)}, expected {sorted(new)}"
    return out, err


def one_line(err: str, *names: str) -> str:
    """The single stderr line of an error, which must name each of `names`."""
    lines = err.strip().splitlines()
    assert len(lines) == 1, lines
    assert "Traceback" not in err
    for n in names:
        assert n in lines[0], (n, lines[0])
    return lines[0]


def interrupt(argv, ready: str | None, wait: float, cwd, timeout: float = 240.0,
              took: list | None = None, prelude: str = ""):
    """Run `python -m stickslip_jax.cli argv` in `cwd`, send SIGINT `wait` seconds after a
    stderr line containing `ready` (None: after the start), and return (returncode,
    stdout, stderr); `took` gets the seconds from the SIGINT to the exit, `prelude` is
    Python run before the command."""
    # `python -m stickslip_jax.cli`, with Python's own Ctrl-C handler put back: a test run
    # started in the background inherits SIGINT ignored, and Python keeps it so
    start = (prelude + "import runpy, signal, sys; signal.signal(signal.SIGINT, "
             "signal.default_int_handler); sys.argv[0] = 'stickslip'; "
             "runpy.run_module('stickslip_jax.cli', run_name='__main__', alter_sys=True)")
    proc = subprocess.Popen(
        [sys.executable, "-c", start, *map(str, argv)], cwd=cwd,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env=dict(os.environ, STICKSLIP_CACHE_DIR=""))
    t0 = time.time()
    seen = []
    while ready is not None and time.time() - t0 < timeout:
        line = proc.stderr.readline()
        if not line and proc.poll() is not None:
            break
        seen.append(line)
        if ready in line:
            break
    assert ready is None or any(ready in s for s in seen), "".join(seen) + proc.stderr.read()
    time.sleep(wait)
    proc.send_signal(signal.SIGINT)
    sent = time.time()
    stdout, stderr = proc.communicate(timeout=timeout)
    if took is not None:
        took.append(time.time() - sent)
    return proc.returncode, stdout, "".join(seen) + stderr
