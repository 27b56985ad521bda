r"""Mode options as small string-valued enums (no JAX import: the command parsers use them).

Each mode is a `str`-valued `enum.Enum` (`AbstractMode`), so a plain string works wherever
a member does: `SlipTime("paper") is SlipTime.PAPER`, `SlipTime.PAPER == "paper"`, and it
hashes like its string (a jit cache or an equinox static field sees one value whichever
form came in). A mode is validated once where it enters (`SlipTime.parse(value)`, a
ValueError naming the choices, or `type=SlipTime` on the command line).

- `SlipTime`: the $T_2$ put into the mean kinetic friction, eq (3).
- `GaugeOffset`: how the fits treat a record's gauge zero.
- `Formulation`: the smoothed simulator's equations (`stickslip_jax.simulation.smooth`).

The fitting package's modes are in `stickslip_fitting.modes`, built on `AbstractMode`.
"""

from __future__ import annotations

import enum
import re

__all__ = ["AbstractMode", "Formulation", "GaugeOffset", "SlipTime"]


class AbstractMode(str, enum.Enum):
    """Base of the string-valued modes: equal to, hashed, printed and formatted like its
    value. Subclasses list the members."""

    __hash__ = str.__hash__
    __format__ = str.__format__

    def __str__(self) -> str:
        return self.value

    @classmethod
    def choices(cls) -> tuple[str, ...]:
        """The values, in order (for `choices=` and error messages)."""
        return tuple(m.value for m in cls)

    @classmethod
    def option(cls) -> str:
        """The argument's name in error messages: the class name in snake case unless a
        subclass names it otherwise."""
        return re.sub(r"(?<!^)(?=[A-Z])", "_", cls.__name__).lower()

    @classmethod
    def parse(cls, value, name: str | None = None):
        """`value` (a member or its string) as a member; a ValueError naming the argument
        (`name`, default `option()`) and the choices otherwise."""
        try:
            return cls(value)
        except ValueError:
            raise ValueError(f"{name or cls.option()} must be one of {cls.choices()}, "
                             f"got {value!r}") from None


class SlipTime(AbstractMode):
    r"""The slip time $T_2$ in eq (3), $\mu_m = \mu_d + (\mu_0 - \mu_d)(1 - e^{-\delta T_2^n})
    /(\delta T_2^n)$ (units: s).

    - `PAPER` ("paper"): $T_2 = \pi/\omega_0$, the paper's eq (7).
    - `SELF_CONSISTENT` ("self_consistent"): the actual slip duration, which itself depends
      on $\mu_m$ (a scalar root solve; only the exact simulator and the features
      objective have it).
    """

    PAPER = "paper"
    SELF_CONSISTENT = "self_consistent"


class GaugeOffset(AbstractMode):
    """How the fits treat a record's gauge zero (the deflection the gauge reads at rest).

    - `ZERO` ("zero"): trust the gauge zero; no offset is fitted.
    - `START` ("start"): each record starts with the spring relaxed; its first plateau
      gives the offset, which is fitted as a nuisance parameter per record.
    """

    ZERO = "zero"
    START = "start"


class Formulation(AbstractMode):
    """The equations of the smoothed simulator (`stickslip_jax.simulation.smooth`, whose
    module docstring gives them).

    - `RIGID_STICK` ("rigid_stick"): the friction force switched in by the stick weight
      (stiff: an implicit solver, Kvaerno5).
    - `VELOCITY` ("velocity"): friction as a smooth function of the slider velocity
      (stiff; gradients verified for smoothing >= 0.03).
    - `LATCH` ("latch", the default): a resting slider latched until the applied force
      exceeds static friction; not stiff (explicit Tsit5), 45-60 times cheaper than
      `RIGID_STICK` on the benchmark campaign.
    """

    RIGID_STICK = "rigid_stick"
    VELOCITY = "velocity"
    LATCH = "latch"
