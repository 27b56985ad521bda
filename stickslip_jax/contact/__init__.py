"""Contact and microsqueeze model of chapter 7: surfaces, boundary lubrication, eq (28).

- `surfaces`: `Surface`, `SurfacePair`, `surface_pair`, `symmetric_pair` (Table 10, eqs 29-32, xi).
- `boundary`: `BoundaryContact`, `load_shares`, `static_coefficient`, `film_from_mu_s`,
  `final_approach`, `approach_for`, `static_limit` (eqs 13-15, 33-35).
- `microsqueeze`: `MicrosqueezeStatic` (an `AbstractStaticFriction`), `microsqueeze_curve`
  (diffrax solve of eq 28).
- `bridge`: `fit_kato` (eq (1) parameters of a microsqueeze curve).
- `profile`: `estimate_surface` (H_max, R, z, D from a measured 1-D profile).
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
