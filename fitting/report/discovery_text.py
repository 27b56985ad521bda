"""What `stickslip discover` and `stickslip_fitting.discover` say: the printed answer
(`answer_text`: the effects named, the explanation, the gap, the candidate and parameter
tables) and the JSON document (`json_document`) of a `discovery.result.Discovery`."""

from __future__ import annotations

from ..modes import DiscoveryBase

__all__ = ["JSON_ALIASES", "answer_text", "candidate_table", "json_document", "named_effects",
           "parameter_table", "smooth_candidate_table"]


def named_effects(result) -> tuple[list[str], list[str]]:
    """What an answer names: (the effect and the effects the records cannot tell from it,
    the further effects the sequential search kept after it, in order). The command
    prints them as "a or b + c"; `CampaignDiscovery.named` lists them. Only the per-cycle
    base searches on after its first effect (its `steps`)."""
    steps = result.steps if result.BASE is DiscoveryBase.CYCLE else ()
    kept = [s["effect"] for s in steps if s["kept"]]
    return [result.effect] + [r["name"] for r in result.indistinguishable_from], kept[1:]


def answer_text(result) -> str:
    """What the command prints: the answer (with the families the records cannot tell
    from it), the explanation, the gap against the noise and the two tables."""
    r = result
    alternatives, further = named_effects(r)
    joint = " + ".join([" or ".join(alternatives)] + further)
    table = candidate_table if r.BASE is DiscoveryBase.CYCLE else smooth_candidate_table
    return "\n".join([
        f"effect: {joint} (confidence {r.confidence})"
        + (": these records cannot tell them apart" if r.indistinguishable_from else ""),
        r.explanation,
        f"gap (residual RMS): {r.gap_before * 1e3:.3f} um -> {r.gap_after * 1e3:.3f} um; "
        f"noise {r.noise * 1e3:.3f} um", table(r.candidates), parameter_table(r)])


def smooth_candidate_table(candidates) -> str:
    """The smooth base's candidate table: each effect's score and the refit's BIC change."""
    lines = [f"{'candidate':22s} {'score':>10s} {'dBIC':>10s}"]
    for c in candidates:
        d = "-" if c["delta_criterion"] is None else f"{c['delta_criterion']:.1f}"
        lines.append(f"{c['name']:22s} {c['score']:10.1f} {d:>10s}")
    return "\n".join(lines)


JSON_ALIASES = {"noise_mm": "noise", "gap_before_mm": "gap_before", "gap_after_mm": "gap_after"}
"""JSON keys under the one unit convention -> their old names, written beside them."""


def json_document(result) -> dict:
    """The result's JSON (`to_json()`), versioned, the noise and gaps keyed with "_mm" at
    every depth (the learned correction's and the sparse form's gaps too)."""
    from stickslip_jax.output import versioned

    return versioned(_renamed(result.to_json(), {old: new for new, old in JSON_ALIASES.items()}),
                     JSON_ALIASES)


def _renamed(obj, names: dict[str, str]):
    """`obj` with each dict key in `names` renamed (not where the new key is there too)."""
    if isinstance(obj, list):
        return [_renamed(v, names) for v in obj]
    if not isinstance(obj, dict):
        return obj
    return {(names[k] if k in names and names[k] not in obj else k): _renamed(v, names)
            for k, v in obj.items()}


def parameter_table(result) -> str:
    """The parameter table (`report.rows.ParameterEstimate` rows): unit, value before and
    after, standard error after, "-" for a value the data do not determine, and a note
    (why, "at upper bound 1"); a line says when the final fit kept the base's friction."""
    from .rows import note_text, text_table, value_text

    before = {e.name: e.to_json() for e in result.estimates_before}
    rows = []
    for e in result.estimates():
        entry, b = e.to_json(), before.get(e.name)
        note = note_text(entry) or (b is not None and note_text(b) and "before: "
                                    + note_text(b)) or ""
        rows.append([e.name, e.unit or "-", "-" if b is None else value_text(b),
                     value_text(entry), "-" if entry["value"] is None or entry["stderr"] is
                     None else format(entry["stderr"], ".2g"), note])
    out = text_table(["parameter", "unit", "before", "after", "std err", "note"], rows,
                     align="llrrrl")
    after = {e.name: e.value for e in result.estimates_after}
    if (result.effect_of and before and after
            and all(after.get(e.name) == e.value for e in result.estimates_before)):
        out += ("\nfriction parameters unchanged by the refit: the final fit kept the base "
                "fit's values")
    return out


def candidate_table(candidates) -> str:
    """The cycle base's candidate table (its footer says what the columns mean) and how
    many families are significant by each test."""
    from ..discovery.stages.state import SIGNIFICANT_BY
    from .rows import text_table

    def p_text(p):
        if p is None or p != p:
            return "-"
        return "<1e-300" if p < 1e-300 else format(p, ".2g")  # 0: below double precision

    rows = []
    for c in candidates:
        d = "-" if c["chi2_drop"] is None else f"{c['chi2_drop']:.1f}"
        if c["unphysical"]:
            d += " unphysical"
        predicted = c.get("chi2_drop_predicted")
        rows.append([c["name"], c["shape"] or "-", f"{c['score']:.2f}",
                     p_text(c["score_p_value"]), p_text(c.get("family_wise_p_value")),
                     p_text(c.get("per_sample_p_value")),
                     "-" if predicted is None else format(predicted, ".3g"),
                     c.get("significant_by") or "no", d])
    n = sum(bool(c.get("significant")) for c in candidates)
    wise = sum(c.get("significant_by") == "family-wise" for c in candidates)
    return (text_table(["family", "shape", "F", "p", "p family-wise", "p per-sample",
                        "predicted drop", "significant", "chi2 drop"], rows,
                       align="llrrrrrrr")
            + f"\n{n} of {len(candidates)} families significant: {wise} family-wise, "
              f"{n - wise} per-sample; "
            + "; ".join(f"{k}: {v}" for k, v in SIGNIFICANT_BY.items())
            + "\np: the robust window test of the family; p family-wise: over every "
              "family-shape test; p per-sample and predicted drop: the per-sample score "
              "test and the chi-square drop it predicts; chi2 drop: the refit's (0.0: the "
              "refit did not lower it)")
