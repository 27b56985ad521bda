r"""The one discovery pipeline: `discover(records, base)` takes a base model
(`AbstractBaseModel`: `cycle_workflow.CycleBase`, `workflow.SmoothBase`) through its
stages `prepare` -> `base_fit` -> `rank` -> `refit` -> `decide` -> `conclude`, each
handed the states before it; one `Clock` times them (`result.timings`, progress lines).

```python
from stickslip_fitting.discovery.engine import discover
from stickslip_fitting.discovery.workflow import SmoothBase

result = discover(records, SmoothBase(top=2), progress=print)
```
"""

from __future__ import annotations

import abc
from typing import ClassVar

import threadpoolctl

from stickslip_jax.programs import release_programs

from .result import Discovery
from .stages.state import Clock

__all__ = ["AbstractBaseModel", "discover"]


class AbstractBaseModel(abc.ABC):
    """A base model of discovery and its stages (module doc); subclasses are final frozen
    dataclasses whose fields are the stages' options."""

    NAME: ClassVar[str]
    """The base's name (`stickslip discover --base`, the document's "base")."""

    @abc.abstractmethod
    def prepare(self, records, clock: Clock):
        """The campaign as the fits need it, and their start."""

    @abc.abstractmethod
    def base_fit(self, prepared, clock: Clock):
        """The base model, no effect, fitted to the prepared records."""

    @abc.abstractmethod
    def rank(self, fitted, clock: Clock):
        """The score test of every candidate effect at the base fit."""

    @abc.abstractmethod
    def refit(self, ranked, clock: Clock):
        """The candidates the ranking lets through, refitted with the base."""

    @abc.abstractmethod
    def decide(self, ranked, refitted, clock: Clock):
        """The effects named (or none) and the final fit."""

    @abc.abstractmethod
    def conclude(self, ranked, refitted, decided, clock: Clock) -> Discovery:
        """The answer, its explanation, the learned correction where asked: the result."""


def discover(records, base: AbstractBaseModel, *, progress=None) -> Discovery:
    """Which effect does `base`'s model miss in `records`? `progress` is called with one
    line per finished stage."""
    # the host's linear algebra (Levenberg-Marquardt's J^T J, the score tests' projections)
    # on one BLAS thread: its tall, thin products gain nothing from a second thread, and
    # on a busy machine OpenBLAS's waiting threads made each product 20-40 times slower
    # (26 columns x 11,522 rows: 220-420 ms against 10 ms at load 14 on 2 cores)
    with threadpoolctl.threadpool_limits(1, user_api="blas"):
        # a process that runs many campaigns would reach its memory-map limit, and die in
        # XLA's compiler (`stickslip_jax.programs`)
        released = release_programs()
        clock = Clock(progress)
        if released.released:
            clock.say(f"memory: JAX's compiled programs dropped ({released.maps_before} -> "
                      f"{released.maps_after} memory maps, limit {released.limit})")
        ranked = base.rank(base.base_fit(base.prepare(records, clock), clock), clock)
        refitted = base.refit(ranked, clock)
        result = base.conclude(ranked, refitted, base.decide(ranked, refitted, clock), clock)
    clock.timings["total"] = sum(clock.timings.values())
    return result
