"""Figures out of the report's drawing functions: `finish_figure` saves one (atomically)
and closes it, `interruptible` draws in a worker thread so that a Ctrl-C reaches a command
at once. Shared by `report.plots`, `report.posterior_plots` and the commands."""

from __future__ import annotations

from stickslip_jax.output import save_figure

__all__ = ["finish_figure", "interruptible", "pyplot"]


def pyplot():
    """matplotlib.pyplot, imported on first use (the user's backend, as it is)."""
    import matplotlib.pyplot as plt  # the user's backend, as it is

    return plt


def interruptible(draw, *args, **kwargs):
    """`draw(*args, **kwargs)` in a worker thread while this thread waits, so that a Ctrl-C
    reaches a command at once (compiling and rendering run in C code, which Python
    interrupts only when it returns). Returns what `draw` returns, raises what it raises;
    interrupted, the worker's output is never renamed into place."""
    import threading

    box: dict = {}

    def work():
        try:
            box["value"] = draw(*args, **kwargs)
        except BaseException as exc:  # noqa: BLE001 - raised again in the caller's thread
            box["error"] = exc

    worker = threading.Thread(target=work, name="stickslip-figure", daemon=True)
    worker.start()
    while worker.is_alive():
        worker.join(0.05)
    if "error" in box:
        raise box["error"]
    return box.get("value")


def finish_figure(fig, path, dpi):
    """Save `fig` to `path` (atomically) and close it when a `path` is given; return the
    figure either way."""
    if path is not None:
        save_figure(fig, str(path), dpi=dpi)
        pyplot().close(fig)
    return fig
