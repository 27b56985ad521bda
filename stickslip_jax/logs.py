"""Progress and diagnostics of the `stickslip` commands through Python's `logging`.

The logger `stickslip` (`logger`) carries the stage lines of the long commands (INFO: what
runs now, what it found) and details (DEBUG). The command line (`stickslip_jax.cli.main`)
attaches one handler that writes to stderr with the time since the command started
(`stickslip fit [  0.9 s] fitting 12 records ...`), at level INFO by default, WARNING with the command's `--quiet`, DEBUG with `stickslip
--debug COMMAND`. Used as a library, the package prints nothing: an application that wants
the lines configures logging itself (`logging.basicConfig(level=logging.INFO)`).
Nothing here imports JAX.
"""

from __future__ import annotations

import logging
import sys
import time

__all__ = ["LOGGER_NAME", "configure", "logger"]

LOGGER_NAME = "stickslip"
logger = logging.getLogger(LOGGER_NAME)
"""The package's logger: stage lines at INFO, details at DEBUG."""


class _StderrHandler(logging.StreamHandler):
    """A handler writing to the *current* `sys.stderr` (a test's captured stream, or the
    stderr a command's `--json -` leaves for its table)."""

    def __init__(self):
        super().__init__(sys.stderr)

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value):  # StreamHandler.__init__ assigns it; the property decides
        pass


class _ElapsedFormatter(logging.Formatter):
    """`stickslip COMMAND [  t.t s] message`, t the seconds since `start`; levels other
    than INFO are named (`warning: ...`, `debug: ...`)."""

    def __init__(self, command: str, start: float):
        super().__init__()
        self.command, self.start = command, start

    def format(self, record: logging.LogRecord) -> str:
        elapsed = max(record.created - self.start, 0.0)
        level = "" if record.levelno == logging.INFO else f"{record.levelname.lower()}: "
        text = f"stickslip {self.command} [{elapsed:6.1f} s] {level}{record.getMessage()}"
        if record.exc_info:
            text += "\n" + self.formatException(record.exc_info)
        return text


_handler: _StderrHandler | None = None


def configure(command: str, *, quiet: bool = False, debug: bool = False,
              start: float | None = None) -> logging.Handler:
    """Send `logger`'s records to stderr for the command `command`: level DEBUG with
    `debug`, WARNING with `quiet`, else INFO; elapsed times from `start` (default now).
    Called once per command run (`stickslip_jax.cli.main`); a second call replaces the
    first's settings (one handler, never two)."""
    global _handler
    if _handler is None:
        _handler = _StderrHandler()
        logger.addHandler(_handler)
    _handler.setFormatter(_ElapsedFormatter(command, time.time() if start is None else start))
    logger.setLevel(logging.DEBUG if debug else logging.WARNING if quiet else logging.INFO)
    return _handler
