"""Programs compiled in a background thread, one XLA compilation at a time.

The discovery model (`stickslip_fitting.discovery.cycle_model.CycleModel.warm`) and the
trace fit (`stickslip_fitting.fit`) compile their large programs in a background thread
while the caller works: XLA compiles without the GIL, so compilation overlaps the
caller's run time. Two XLA compilations *at the same time* in one process are not safe
with the jaxlib this project runs on: a segmentation fault in `backend_compile_and_load`
in both threads (the main thread compiling a small eager operation of the host
Levenberg-Marquardt loop, the background thread the discovery model's residuals) killed
a test worker once in about 60 discovery campaigns (session 20). So every XLA
compilation of the process goes through one gate (`serialise_compilation`): one at a
time, and a compilation the caller's thread waits for goes before the background
thread's next one (it still waits for the one in progress).

`compile_in_background(jobs)` runs the jobs (callables that compile a program, usually
by calling it once) in order in one background thread behind that gate, and returns a
future per job. Where the gate cannot be installed (a jax without the internal function
it wraps), the jobs run at once in the caller's thread: slower, never concurrent.
"""

from __future__ import annotations

import concurrent.futures
import threading

__all__ = ["compilations", "compile_in_background", "serialise_compilation"]


class _Gate:
    """One compilation at a time; foreground threads before background ones."""

    def __init__(self):
        self._cv = threading.Condition()
        self._busy = False
        self._foreground_waiting = 0
        self._local = threading.local()
        self.compilations = 0  # how many passed the gate (tests: the gate is in the path)

    @property
    def background(self) -> bool:
        return getattr(self._local, "background", False)

    def mark_background(self):
        self._local.background = True

    def run(self, compile_, *args, **kwargs):
        background = self.background
        with self._cv:
            if not background:
                self._foreground_waiting += 1
            try:
                while self._busy or (background and self._foreground_waiting):
                    self._cv.wait()
            finally:
                if not background:
                    self._foreground_waiting -= 1
            self._busy = True
            self.compilations += 1
        try:
            return compile_(*args, **kwargs)
        finally:
            with self._cv:
                self._busy = False
                self._cv.notify_all()


_GATE = _Gate()
_INSTALLED: list[bool] = []
_INSTALL_LOCK = threading.Lock()


def serialise_compilation() -> bool:
    """Route every XLA compilation of this process through one gate (module doc);
    idempotent. Returns False where jax's compile function is not where this expects it
    (nothing installed: the caller must then not compile in a second thread)."""
    with _INSTALL_LOCK:
        if not _INSTALLED:
            try:
                from jax._src import compiler
                original = compiler.backend_compile_and_load
            except (ImportError, AttributeError):
                _INSTALLED.append(False)
            else:
                def gated(*args, **kwargs):
                    return _GATE.run(original, *args, **kwargs)

                gated.__wrapped__ = original
                compiler.backend_compile_and_load = gated
                _INSTALLED.append(True)
        return _INSTALLED[0]


def compilations() -> int:
    """XLA compilations of this process that passed the gate so far."""
    return _GATE.compilations


def compile_in_background(jobs: dict) -> dict:
    """Run `jobs` ({key: callable}) in order in one background thread behind the
    compilation gate (module doc); returns {key: Future}. Wait for a job's future before
    the caller uses its program (a call while it is still compiling compiles it a second
    time). Without the gate the jobs run now, in this thread."""
    if not serialise_compilation():
        futures = {}
        for key, job in jobs.items():
            f = concurrent.futures.Future()
            try:
                f.set_result(job())
            except Exception as e:  # noqa: BLE001 - handed to the caller via the future
                f.set_exception(e)
            futures[key] = f
        return futures

    def background(job):
        def run():
            _GATE.mark_background()
            return job()
        return run

    pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="stickslip-compile")
    futures = {key: pool.submit(background(job)) for key, job in jobs.items()}
    pool.shutdown(wait=False)
    return futures
