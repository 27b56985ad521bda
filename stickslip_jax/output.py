"""Output files of the commands: checked before any work, written atomically, never over an input.

- `check_outputs(outputs, inputs)`: every output path is writable (its folder exists and
  is a folder, the path is not a folder), differs from every input file (same file by
  `os.path.samefile` or by resolved path) and from the other outputs; raises ValueError
  naming the option and the fix. Call it before the work starts.
- `write_text(path, text)`, `write_json(path, obj)`, `save_figure(fig, path)`,
  `write_atomic(path, write)` (any writer, e.g. a netCDF file): write to a
  temporary file in the target folder and rename it over the target, so a full disk or
  an interrupt leaves the previous file (or none), never half a file. `path` "-" writes
  JSON/text to stdout.
- JSON is strict (`strict_json`): a NaN or infinity is written as null, and the document
  gets a key "null_reasons" ({"results[0].critical_speed_mm_min": "not defined for these
  inputs (NaN)", ...}) saying where each such null is and why.
- `catch_interrupts()`: the `stickslip` command's Ctrl-C handler. It records the interrupt
  before raising KeyboardInterrupt, so an interrupt that lands where Python swallows
  exceptions (a garbage-collector callback of JAX, a `__del__`) is still honoured: no
  output is renamed into place afterwards, and the command exits 130.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys
import tempfile

__all__ = [
    "catch_interrupts", "check_outputs", "interrupted", "json_owns_stdout", "outputs_together",
    "save_figure", "strict_json", "write_atomic", "write_json", "write_text"]


def _same(a: str, b: str) -> bool:
    """The same file (both exist), else the same resolved path."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


FIGURE_FORMATS = frozenset(("png", "pdf", "svg", "svgz", "eps", "ps", "jpg", "jpeg", "tif",
                            "tiff", "webp", "pgf"))
"""The file extensions a figure option (`--plot`) takes: matplotlib's formats."""


def check_outputs(outputs: dict[str, str | None], inputs=()) -> None:
    """`outputs`: {option name (e.g. "--json"): path or None}; `inputs`: paths of the
    files the command reads. Raises ValueError (module doc)."""
    seen = {}
    for option, path in outputs.items():
        if path is None or path == "-":
            continue
        if path == "":
            raise ValueError(f"{option}: empty file name; give a path such as result.json")
        if os.path.isdir(path):
            raise ValueError(f"{option}: {path} is a folder; give a file name inside it")
        folder = os.path.dirname(os.path.abspath(path))
        if os.path.exists(folder) and not os.path.isdir(folder):
            raise ValueError(f"{option}: {os.path.dirname(path)} is a file, not a folder; "
                             "give a path in a folder")
        if not os.path.isdir(folder):
            raise ValueError(f"{option}: the folder {os.path.dirname(path) or '.'} does not "
                             "exist; create it first")
        if not os.access(folder, os.W_OK):
            raise ValueError(f"{option}: cannot write in {folder} (permission denied)")
        for src in inputs:
            if _same(path, str(src)):
                raise ValueError(f"{option}: {path} is one of the input records; it would be "
                                 "overwritten. Choose another output name")
        for other, p in seen.items():
            if _same(p, path):
                raise ValueError(f"{option} and {other} name the same file {path}")
        ext = os.path.splitext(path)[1].lower().lstrip(".")
        if any(w in option for w in ("plot", "figure", "corner")) and ext and (
                ext not in FIGURE_FORMATS):
            raise ValueError(f"{option}: cannot draw a figure as .{ext}; end the name in "
                             f"one of .{', .'.join(sorted(FIGURE_FORMATS))}")
        seen[option] = path


NULL_REASONS = "null_reasons"
"""Key of a JSON document that lists, for each value written as null because it was NaN or
infinite, its place and why (`strict_json`'s `reasons`)."""


def _explained(obj):
    """`strict_json(obj)`, and a document (dict) with nulls made of NaN or infinity gets
    `NULL_REASONS` (a bare null would not say whether a value is missing or undefined)."""
    reasons: dict[str, str] = {}
    out = strict_json(obj, reasons if isinstance(obj, dict) else None)
    if reasons:
        out[NULL_REASONS] = {**out.get(NULL_REASONS, {}), **reasons}
    return out


def strict_json(obj, reasons: dict[str, str] | None = None, where: str = ""):
    """`obj` with every NaN or infinity replaced by None (strict JSON has neither); each
    one's place (`where` the place of `obj`) and why are added to `reasons` when given."""
    if isinstance(obj, float):
        if not math.isfinite(obj) and reasons is not None:
            reasons[where] = ("not defined for these inputs (NaN)" if math.isnan(obj) else
                              ("infinite" if obj > 0 else "minus infinite") + " for these inputs")
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: strict_json(v, reasons, f"{where}.{k}" if where else str(k))
                for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [strict_json(v, reasons, f"{where}[{i}]") for i, v in enumerate(obj)]
    return obj


def _mode(path: str) -> int:
    """Permissions for a new output: the replaced file's, else what `open` would give
    (0o666 less the umask); `tempfile.mkstemp` itself creates files readable by the
    owner only."""
    try:
        return os.stat(path).st_mode & 0o7777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


_JSON_STDOUT = None
"""The real stdout while `json_owns_stdout` moves the command's other output to stderr."""


@contextlib.contextmanager
def json_owns_stdout(active: bool):
    """With `active` (the command's `--json` is "-"; `stickslip_jax.cli` wraps every command
    in it): inside, `print` goes to stderr and only `write_text("-", ...)` /
    `write_json("-", ...)` reach the stdout of entry, so `... --json - | jq` reads one
    document."""
    global _JSON_STDOUT
    if not active:
        yield
        return
    previous, _JSON_STDOUT = _JSON_STDOUT, sys.stdout
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        _JSON_STDOUT = previous


_INTERRUPTED = False


def interrupted() -> bool:
    """True once `catch_interrupts`'s handler has seen a Ctrl-C in this process."""
    return _INTERRUPTED


def _on_sigint(signum, frame):
    global _INTERRUPTED
    _INTERRUPTED = True
    raise KeyboardInterrupt


def _unraisable(previous):
    """sys.unraisablehook that stays quiet about the recorded Ctrl-C (Python would print
    "Exception ignored in ... Traceback" for it) and passes anything else on."""
    def hook(unraisable):
        if _INTERRUPTED and issubclass(unraisable.exc_type, KeyboardInterrupt):
            return
        previous(unraisable)
    return hook


def catch_interrupts() -> None:
    """Install the SIGINT handler that records the interrupt (module doc) and a
    sys.unraisablehook that does not print a swallowed one; main thread only."""
    import signal

    signal.signal(signal.SIGINT, _on_sigint)
    sys.unraisablehook = _unraisable(sys.unraisablehook)


def write_text(path: str, text: str) -> None:
    """Write `text` to `path` atomically (module doc); "-" prints it (to the stdout that
    `json_owns_stdout` kept, if any)."""
    if path == "-":
        out = _JSON_STDOUT if _JSON_STDOUT is not None else sys.stdout
        out.write(text)
        out.flush()
        return

    def write(tmp):
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    _replace(path, ".tmp", write)


def _replace(path: str, suffix: str, write) -> None:
    """`write(tmp)` to a temporary file in `path`'s folder, then rename it over `path`
    with the usual permissions; on any failure (full disk, Ctrl-C) the temporary file is
    removed and `path` is untouched. Inside `outputs_together` the temporary file is
    listed from its creation, so that a Ctrl-C while another thread writes it (a figure
    drawn apart, `stickslip_fitting.report.plots.interruptible`) removes it too."""
    if _INTERRUPTED:  # a Ctrl-C that something swallowed: no output after it
        raise KeyboardInterrupt
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".stickslip-", suffix=suffix, dir=folder)
    os.close(fd)
    pending = _PENDING
    if pending is not None:  # inside `outputs_together`: renamed with the others
        pending.append((tmp, path))
    try:
        write(tmp)
        os.chmod(tmp, _mode(path))
        if _INTERRUPTED:
            raise KeyboardInterrupt
        if pending is None:
            os.replace(tmp, path)
    except BaseException as exc:
        if pending is not None and (tmp, path) in pending:
            pending.remove((tmp, path))
        if os.path.exists(tmp):
            os.unlink(tmp)
        if isinstance(exc, OSError) and exc.errno is not None:
            # name the output, not the temporary file
            raise OSError(exc.errno, f"cannot write ({exc.strerror})", path) from exc
        raise


_PENDING: list[tuple[str, str]] | None = None
"""(temporary file, target) of the outputs written inside `outputs_together`."""


@contextlib.contextmanager
def outputs_together():
    """The outputs written inside (`write_text`, `write_json`, `save_figure`,
    `write_atomic`) stay temporary files until the block ends without an exception; then
    all are renamed into place, otherwise (an error, a Ctrl-C) all are removed: a command's
    outputs are one transaction, all or none (`stickslip_jax.cli` runs every command in
    one)."""
    global _PENDING
    if _PENDING is not None:  # nested: the outer block renames
        yield
        return
    _PENDING = []
    try:
        yield
        if _INTERRUPTED:
            raise KeyboardInterrupt
        for tmp, path in _PENDING:
            try:
                os.replace(tmp, path)
            except OSError as exc:  # name the output, not the temporary file
                raise OSError(exc.errno, f"cannot write ({exc.strerror})", path) from exc
    finally:
        for tmp, _ in _PENDING:
            if os.path.exists(tmp):
                os.unlink(tmp)
        _PENDING = None


def write_atomic(path: str, write, suffix: str | None = None) -> None:
    """`write(tmp)` writes the file at the temporary path `tmp` (in `path`'s folder, ending
    in `suffix`, default `path`'s extension); it is then renamed over `path` (module doc):
    for outputs written by other libraries (a netCDF file written by xarray)."""
    _replace(path, os.path.splitext(path)[1] if suffix is None else suffix, write)


def check_memory(what: str, option: str, n_bytes: float, fraction: float = 0.5,
                 advice: str = "use a smaller one") -> None:
    """ValueError naming `option` when `what` needs more than `fraction` of this machine's
    memory (`n_bytes`, an estimate): refuse before allocating instead of failing later;
    `advice` ends the message (how to make it smaller)."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover (not POSIX)
        total = 16 * 2**30
    if n_bytes > fraction * total:
        raise ValueError(f"{option}: {what} needs about {n_bytes / 2**30:.3g} GiB, more than "
                         f"{fraction:.0%} of this machine's {total / 2**30:.3g} GiB; {advice}")


SCHEMA_VERSION = 1
"""Version of the JSON documents the commands write (the key "schema_version" of each):
raised when a key changes meaning or goes away; new keys do not raise it."""

UNIT_SUFFIXES = {"_kgf": "kgf", "_mm": "mm", "_um": "um", "_s": "s", "_hz": "Hz",
                 "_mm_per_min": "mm/min", "_mm_per_s": "mm/s", "_kgf_per_mm": "kgf/mm",
                 "_pa_s": "Pa*s"}
"""The JSON key convention: a quantity with a unit ends in its unit, compound units with
`_per_` (`stiffness_kgf_per_mm`, `drive_speed_mm_per_min`); a dimensionless quantity
(`amplitude_ratio`, `frequency_ratio`, `mu_s`) has no suffix. Rows of parameter estimates
(`parameters.NAME`) carry their unit in a `unit` field instead (the names are the paper's
symbols). One key per quantity in every command (`tests/test_json_keys.py`)."""


def _with_aliases(obj, aliases: dict[str, str], used: dict[str, str]):
    if isinstance(obj, list):
        return [_with_aliases(v, aliases, used) for v in obj]
    if not isinstance(obj, dict):
        return obj
    out = {}
    for key, value in obj.items():
        value = _with_aliases(value, aliases, used)
        out[key] = value
        old = aliases.get(key)
        if old is not None and old not in obj:
            out[old] = value
            used[old] = key
    return out


def versioned(doc: dict, aliases: dict[str, str] | None = None) -> dict:
    """`doc` with "schema_version" first (what every command's JSON carries).

    `aliases` {new key: old key}: a key renamed to the one-key-per-quantity convention
    (`UNIT_SUFFIXES`) is also written under its old name, beside the new one at every
    depth, for one release; the document then lists the old names it carries under
    "deprecated_keys" {old: new}. The aliases go away with schema_version 2."""
    if not aliases:
        return {"schema_version": SCHEMA_VERSION, **doc}
    used: dict[str, str] = {}
    body = _with_aliases(doc, aliases, used)
    out = {"schema_version": SCHEMA_VERSION, **body}
    if used:
        out["deprecated_keys"] = dict(sorted(used.items()))
    return out


def dumps(obj, **kwargs) -> str:
    """Strict JSON text of `obj` (NaN and infinities as null): what every command prints."""
    return json.dumps(_explained(obj), allow_nan=False, **kwargs)


def write_json(path: str, obj, indent: int | None = 2) -> None:
    """Strict JSON (`strict_json`), indented by `indent` (None: one line), atomically."""
    write_text(path, dumps(obj, indent=indent) + "\n")


def save_figure(fig, path: str, **kwargs) -> None:
    """`fig.savefig` to a temporary file in the target folder, renamed over `path`."""
    _replace(path, os.path.splitext(path)[1] or ".png", lambda tmp: fig.savefig(tmp, **kwargs))
