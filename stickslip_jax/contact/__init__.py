"""Contact and microsqueeze model of chapter 7: surfaces, boundary lubrication, eq (28).

Modules: `surfaces` (Table 10, eqs 29-32, xi), `boundary` (eqs 13-15, 33-35),
`microsqueeze` (eq 28 as a static-friction law and its diffrax solve), `bridge` (eq (1)
fitted to a microsqueeze curve) and `profile` (a surface's numbers from a measured profile).
"""

from .boundary import (BoundaryContact, FilmEstimate, approach_for, film_from_mu_s, final_approach,
                       load_shares, static_coefficient, static_limit)
from .bridge import KatoFit, default_stick_times, fit_kato
from .microsqueeze import Kinematics, MicrosqueezeSolution, MicrosqueezeStatic, microsqueeze_curve
from .profile import SurfaceEstimate, estimate_surface, synthetic_profile
from .surfaces import (MODEL_APPARENT_AREA, MODEL_CONTACT_PRESSURE, MODEL_SLIDER_WEIGHT, Surface,
                       SurfacePair, surface_pair, symmetric_pair)

__all__ = ["MODEL_APPARENT_AREA", "MODEL_CONTACT_PRESSURE", "MODEL_SLIDER_WEIGHT",
           "BoundaryContact", "FilmEstimate", "KatoFit", "SurfaceEstimate", "Kinematics",
           "MicrosqueezeSolution", "MicrosqueezeStatic", "Surface", "SurfacePair", "approach_for",
           "default_stick_times", "estimate_surface", "fit_kato", "synthetic_profile",
           "film_from_mu_s", "final_approach", "load_shares", "microsqueeze_curve",
           "static_coefficient", "static_limit", "surface_pair", "symmetric_pair"]
