"""Discovery's compiled programs are built only when a stage needs them (`cycle_model`)."""

from __future__ import annotations

import threading

from stickslip_fitting.discovery.cycle_model import Later


def test_a_later_program_compiles_only_once_asked_for():
    calls = []
    started = threading.Event()

    def compile_(x):
        started.set()
        calls.append(x)
        return 2 * x

    later = Later(compile_, 3)
    assert not started.wait(0.05) and calls == []  # nothing runs until a stage asks
    assert later.start() is later
    assert later.result() == 6 and calls == [3]
    assert later.start().result() == 6 and calls == [3]  # once, however often asked


def test_a_cancelled_program_is_never_started_but_still_answers():
    calls = []
    later = Later(lambda: calls.append(1) or "program")
    assert later.cancel()
    later.start()
    assert calls == []
    assert later.result() == "program" and calls == [1]  # asked for after all: run then
