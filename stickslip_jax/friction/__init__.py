"""Friction laws: static friction against stick time (eq 1, Table 3) and mean kinetic friction (eq 3)."""

from .kinetic import AbstractKineticFriction, Friction, KatoKinetic
from .static import (
    AbstractStaticFriction,
    DerjaguinStatic,
    HoweStatic,
    KatoStatic,
    OkamuraStatic,
    PowerLawStatic,
)

__all__ = [
    "AbstractKineticFriction",
    "AbstractStaticFriction",
    "DerjaguinStatic",
    "Friction",
    "HoweStatic",
    "KatoKinetic",
    "KatoStatic",
    "OkamuraStatic",
    "PowerLawStatic",
]
