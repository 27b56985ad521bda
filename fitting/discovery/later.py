"""`Later`: a call compiled in a thread of its own once it is known to be needed (the
per-cycle model's programs that only some campaigns use, `CycleModel.warm`)."""

from __future__ import annotations

import concurrent.futures

__all__ = ["Later"]


class Later:
    """A `Future` of a call that starts, in a thread of its own, at its first `start()`
    or `result()` (a program only some campaigns need, compiled while the caller works
    once it is known to be needed); `cancel()` before that: never started."""

    def __init__(self, fn, *args, **kwargs):
        self._call, self._future, self._cancelled = (fn, args, kwargs), None, False

    def start(self) -> Later:
        if self._future is None and not self._cancelled:
            fn, args, kwargs = self._call
            pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="stickslip-warm")
            self._future = pool.submit(fn, *args, **kwargs)
            pool.shutdown(wait=False)
        return self

    def result(self):
        if self._future is None and self._cancelled:  # asked for after all: run here
            fn, args, kwargs = self._call
            return fn(*args, **kwargs)
        return self.start()._future.result()

    def cancel(self) -> bool:
        if self._future is None:
            self._cancelled = True
            return True
        return self._future.cancel()
