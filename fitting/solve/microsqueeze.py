r"""Campaign fit of the microsqueeze model: mu_s, mu_d, h_e, Q, delta, n.

`fit_microsqueeze(features, eta=..., pair="S1G1")` runs the multi-start fit of the
empirical model (`solve.fit.fit_features`) with `MicrosqueezeFriction` in place of
`EmpiricalFriction`; `uncertainty.laplace` gives the intervals of h_e (mm) and Q
(mm$^4$) like those of gamma and m.

Starts ("features first"): mu_d, mu_s from the measured per-cycle $\mu_m$, $\mu_0$ (as
for the empirical model); a grid of margins $h_e - t_b - a_d$ = (0.5, 1.2, 3) x
$(a_s - a_d)$; for each, the Q at which the law reaches half of its rise at the median
measured stick time (the law's time scale is proportional to $\eta Q$), times (0.2, 1,
5); delta from $\delta T_2 \in \{0.3, 1.5\}$ and n = 1. Units: eta kgf s/mm$^2$, h_e mm,
Q mm$^4$, T in s.
"""

from __future__ import annotations

import itertools

import jax.numpy as jnp
import numpy as np

from stickslip_jax.contact import BoundaryContact, SurfacePair, surface_pair
from stickslip_jax.contact.boundary import approach_for, film_from_mu_s, final_approach
from stickslip_jax.modes import GaugeOffset
from stickslip_jax.tables import load_table

from ..data.features import RecordFeatures
from .fit import FitResult, fit_features, mu_levels
from ..microsqueeze_params import MicrosqueezeFriction
from ..modes import ModelModes

__all__ = ["default_eta", "fit_microsqueeze", "microsqueeze_starts"]


def default_eta(lubricant: str | None) -> float:
    """Viscosity (kgf s/mm^2) of `lubricant` in Table 11, or of lubricant A if unknown/None."""
    table = load_table(11)
    try:
        return float(table.row((lubricant or "A").strip()).eta)
    except (KeyError, ValueError, LookupError):
        return float(table.row("A").eta)


def _half_rise_time(law) -> float:
    """Stick time (s) at which the law's mu_0 is halfway between mu_d and its asymptote."""
    grid = np.geomspace(1e-8, 1e8, 161)
    mu = np.asarray(law(jnp.asarray(grid)))
    lo, hi = float(law.mu_d), float(mu[-1])
    return float(np.interp(0.5, (mu - lo) / max(hi - lo, 1e-300), grid))


def microsqueeze_starts(features: list[RecordFeatures], *, eta: float,
                        pair: SurfacePair | str = "S1G1", contact: BoundaryContact | None = None,
                        offsets=None) -> list[MicrosqueezeFriction]:
    """Starting points of the microsqueeze fit (module doc)."""
    pair = surface_pair(pair) if isinstance(pair, str) else pair
    contact = BoundaryContact() if contact is None else contact
    offsets = np.zeros(len(features)) if offsets is None else np.asarray(offsets)
    mu0, mum = mu_levels(features, offsets)
    c1, c3 = float(contact.C1), float(contact.C3)
    top = float(np.max(mu0))
    mu_s = min(max(top + 0.2 * (top - float(np.min(mum))), 1.05 * c3), 0.99 * c1)
    t_b = float(film_from_mu_s(pair, contact, mu_s).t_b)
    mu_film = float(contact.C2 * contact.C3 * contact.p_m * pair.area_factor * t_b**3 / contact.W)
    mu_d = min(max(0.9 * float(np.min(mum)), 1.5 * mu_film, 1e-3), 0.8 * mu_s)
    a_d = float(approach_for(pair, contact, mu_d, t_b))
    a_s = float(final_approach(pair, contact, t_b))
    t1 = np.concatenate([f.stick_time[f.complete] for f in features])
    t1_mid = float(np.median(t1)) if t1.size else 1.0
    t2 = float(np.median([np.pi / f.omega0 for f in features]))
    starts = []
    for frac in (0.5, 1.2, 3.0):
        h_e = t_b + a_d + frac * (a_s - a_d)
        unit = MicrosqueezeFriction.from_values(mu_s, mu_d, h_e, 1.0, 1.0, 1.0, eta=eta,
                                                pair=pair, contact=contact)
        q_match = t1_mid / _half_rise_time(unit.static_law())
        for qf, dt2 in itertools.product((0.2, 1.0, 5.0), (0.3, 1.5)):
            starts.append(unit.with_values(Q=q_match * qf, delta=dt2 / t2))
    return starts


def fit_microsqueeze(features: list[RecordFeatures], *, eta: float,
                     pair: SurfacePair | str = "S1G1", contact: BoundaryContact | None = None,
                     modes: ModelModes = ModelModes(), **kwargs) -> FitResult:
    """Fit mu_s, mu_d, h_e (mm), Q (mm^4), delta, n to a campaign's cycle features.

    `eta` (kgf s/mm^2), `pair` (name in Table 10 or a `SurfacePair`) and `contact` are
    given; `modes` and the other keywords as in `solve.fit.fit_features`.
    """
    if not (np.isfinite(eta) and eta > 0):
        raise ValueError(f"--eta: the viscosity must be positive and finite, got {eta}")
    from ..objectives.cycle_features import feature_data

    offsets0 = None
    if modes.offset is GaugeOffset.START:
        offsets0 = np.asarray(feature_data(features, offset_from_start=True).start_level)
    starts = microsqueeze_starts(features, eta=eta, pair=pair, contact=contact, offsets=offsets0)
    return fit_features(features, modes=modes, starts=starts, **kwargs)
