"""Friction laws: static friction against stick time (eq 1, Table 3) and mean kinetic friction
(eq 3); other base laws: rate-and-state (rate_state.py) and logarithmic aging (log_aging.py)."""

from .kinetic import AbstractKineticFriction, Friction, KatoKinetic
from .log_aging import AbstractVelocityKinetic, LogAgingStatic, LogVelocityKinetic
from .rate_state import (AbstractStateEvolution, AgingLaw, RateStateKinetic, SlipLaw,
                         rate_state_friction)
from .static import (AbstractStaticFriction, DerjaguinStatic, HoweStatic, KatoStatic, OkamuraStatic,
                     PowerLawStatic)

__all__ = ["AbstractKineticFriction", "AbstractStateEvolution", "AbstractVelocityKinetic",
           "AgingLaw", "LogAgingStatic", "LogVelocityKinetic", "RateStateKinetic", "SlipLaw",
           "rate_state_friction", "AbstractStaticFriction", "DerjaguinStatic", "Friction",
           "HoweStatic", "KatoKinetic", "KatoStatic", "OkamuraStatic", "PowerLawStatic"]
