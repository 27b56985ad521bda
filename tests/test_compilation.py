"""One XLA compilation at a time (stickslip_jax.compilation): the gate never lets two
compilations overlap, a waiting foreground compilation goes before the background
thread's next one, and programs compiled in the background are reused."""

from __future__ import annotations

import threading
import time

import jax
import jax.numpy as jnp
import numpy as np

from stickslip_jax import compilation
from stickslip_jax.compilation import compile_in_background, serialise_compilation


def test_the_gate_serialises_and_puts_the_foreground_first():
    gate = compilation._Gate()
    log, running = [], []

    def compile_(name, seconds):
        running.append(name)
        assert len(running) == 1, running  # never two at once
        log.append(name)
        time.sleep(seconds)
        running.remove(name)
        return name

    def background():
        gate.mark_background()
        for i in range(3):
            gate.run(compile_, f"background {i}", 0.2)

    th = threading.Thread(target=background)
    th.start()
    time.sleep(0.05)  # the background's first compilation is under way
    assert gate.run(compile_, "foreground", 0.01) == "foreground"
    th.join()
    # the foreground waited for the one in progress only, not for the queue behind it
    assert log == ["background 0", "foreground", "background 1", "background 2"]


def test_programs_compiled_in_the_background_are_reused():
    """Also: jax's compilations still pass through the gate (a jax that compiled past it
    would compile in two threads at once again)."""
    assert serialise_compilation()
    f = jax.jit(lambda x: jnp.sin(x) * 3.0 + jnp.cumsum(x))
    x = np.linspace(0.0, 1.0, 37)
    before_gate = compilation.compilations()
    futures = compile_in_background({"f": lambda: f(x)})
    futures["f"].result()
    assert compilation.compilations() > before_gate
    before = f._cache_size()
    np.testing.assert_allclose(f(x), np.sin(x) * 3.0 + np.cumsum(x))
    assert f._cache_size() == before  # no second compilation


def test_compilation_errors_reach_the_caller():
    def fails():
        raise ValueError("bad program")

    fut = compile_in_background({"x": fails})["x"]
    try:
        fut.result()
    except ValueError as e:
        assert "bad program" in str(e)
    else:
        raise AssertionError("the error was lost")
