"""stickslip_jax: differentiable stick-slip model of machine-tool slideways.

Implements Kato, Sato, Yamaguchi and Matsubayashi, "Stick-slip motion and
characteristics of friction in machine tool slideway". Internal units: kgf, mm, s
(see `stickslip_jax.units`). Importing the package enables `jax_enable_x64`.
"""

import jax

jax.config.update("jax_enable_x64", True)

from . import units  # noqa: E402
from .friction import (  # noqa: E402
    AbstractKineticFriction,
    AbstractStaticFriction,
    DerjaguinStatic,
    Friction,
    HoweStatic,
    KatoKinetic,
    KatoStatic,
    OkamuraStatic,
    PowerLawStatic,
)
from .lubricants import experimental_conditions, lubricant, static_law  # noqa: E402
from .steady import (  # noqa: E402
    REGIMES,
    SteadyState,
    restick_failure,
    critical_speed,
    natural_angular_frequency,
    slip_time,
    slip_trajectory,
    steady_map,
    steady_state,
)
from .slideway import Slideway  # noqa: E402
from .tables import load_table  # noqa: E402

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
    "Slideway",
    "SteadyState",
    "critical_speed",
    "experimental_conditions",
    "load_table",
    "lubricant",
    "natural_angular_frequency",
    "slip_time",
    "slip_trajectory",
    "static_law",
    "steady_map",
    "steady_state",
    "units",
    "REGIMES",
    "restick_failure",
]
