"""The answer by its form (`discovery.sparse`), within stage 7 (`learn.conclude`): when the
gap is unexplained, or a family is named with low confidence, the sparse form of the
base residual is fitted; it answers ("sparse_form") when it is found and leaves less
than the family named, unless one of its terms is that family's own form
(`sparse.LIBRARY_FORMS`: the form then confirms the family; measured: a Stribeck drop (b
0.015) on 12 records, 1.003 against the Stribeck curve's 1.026 x the noise, and a
damping ratio of 0.15, 4 records, whose form, a force along the slider velocity beside
two creep terms that nearly cancel, left 1.017 x the noise against the dashpot's 1.040).
Several effects that the sequential search confirmed one by one (each by its own test,
refit and confirmation level) and that describe the records to within `explained_gap` x
the noise together are the answer: a form that leaves a slightly smaller gap does not
replace them (measured: damping 0.3 and a 12 um screw error on C, 4 records, both named
and kept, and a three-term form of the base residual answered for them, 1.054 -> 1.020 x
the noise)."""

from __future__ import annotations

from ..decision import rms_gap
from ..sparse import LIBRARY_FORMS, SparseForm, fit_sparse_form
from .state import Fits

__all__ = ["form_text", "outside_form"]


def outside_form(fx: Fits, effect: str, confidence: str, gap_after: float,
                 several: bool = False) -> tuple[SparseForm | None, bool]:
    """The sparse form where the answer asks for one (module doc), else None, and
    whether it answers; `several`: the answer holds several confirmed effects."""
    base = fx.base
    if (effect == "none" or (effect != "unexplained" and confidence == "high")
            or (several and gap_after <= fx.opts.explained_gap * base.noise)):
        return None, False
    use, samples = base.described, getattr(base, "samples", None)
    within = (samples[use],) if samples is not None else ()

    def gap(r):  # as the answer's gaps: over the records described, the samples they stand for
        return rms_gap(r[use], base.sd[use], *within)

    form = fit_sparse_form(base.model, base.z, base.r, base.fit.J[:base.n], base.noise,
                           use, gap=gap)
    # the selection's choice of the family's own form confirms the family, whether or not
    # the refit leaves that term beyond its errors (collinear terms take its share there:
    # a damping ratio of 0.2 on C, seed 101: its slip-velocity term refitted to -0.7 standard
    # errors beside a creep and a stick-phase term)
    holds_named = any(effect in LIBRARY_FORMS.get(name, ()) for name in form.selected)
    return form, form.found and (effect == "unexplained"
                                 or (form.gap_after < gap_after and not holds_named))


def form_text(form: SparseForm, named: str) -> str:
    """The answer in words: the form, the gaps, and the family it outdoes."""
    um = 1e3
    return (f"A form outside the library: {form.formula}. Refitted with the base "
            f"parameters it lowers the residual RMS from {form.gap_before * um:.3g} um to "
            f"{form.gap_after * um:.3g} um (noise {form.noise * um:.3g} um), closing "
            f"{100 * form.closes:.0f} % of its excess"
            + ("" if named == "unexplained" else
               f"; more than the best library family, {named}") + ".")
