"""Named parameter sets of the paper: `lubricant("A")`, `static_law("howe", "A")`.

- `lubricant(name, table=6)`: eq (1) + eq (3) with Table 6 (lubricants A, C); the
  kinetic parameters are only in Table 6, so `table=4` and `table=9` (chapter 7,
  lubricants A-D) borrow `delta`, `n` from `kinetic_from` (default Table 6 lubricant A).
- `static_law(law, lubricant)`: a Table 3 law for lubricant A or C.
- `experimental_conditions()`: the (W, k) pairs of Table 1.
"""

from __future__ import annotations

from .friction import (DerjaguinStatic, Friction, HoweStatic, KatoKinetic, KatoStatic,
                       OkamuraStatic, PowerLawStatic)
from .tables import load_table

STATIC_LAWS = ("kato", "howe", "derjaguin", "power_law", "okamura")


def kato_static(name: str, table: int = 6) -> KatoStatic:
    """Eq (1) parameters of lubricant `name` from Table 4, 6 or 9."""
    if table not in (4, 6, 9):
        raise ValueError(f"eq (1) parameters are in Tables 4, 6 and 9, not {table}")
    r = load_table(table).row(name)  # unknown name: MissingRowError, a ValueError
    return KatoStatic(mu_s=r.mu_s, mu_d=r.mu_d, gamma=r.gamma, m=r.m)


def kato_kinetic(name: str) -> KatoKinetic:
    """Eq (3) parameters (delta, n) of lubricant `name` from Table 6."""
    r = load_table(6).row(name)  # unknown name: MissingRowError, a ValueError
    return KatoKinetic(delta=r.delta, n=r.n)


def lubricants(table: int = 6) -> tuple[str, ...]:
    """Names of the lubricants with eq (1) parameters in `table`."""
    return tuple(str(r[0]) for r in load_table(table).rows)


def lubricant(name: str, table: int = 6, kinetic_from: str = "A") -> Friction:
    """Friction (eq 1 + eq 3) of a lubricant of the paper.

    Raises `ValueError` naming the available lubricants if `name` is unknown.
    """
    if table not in (4, 6, 9):
        raise ValueError(f"eq (1) parameters are in Tables 4, 6 and 9, not {table}")
    names = lubricants(table)
    if name not in names:
        raise ValueError(
            f"unknown lubricant {name!r} for Table {table}; available: {', '.join(names)}")
    static = kato_static(name, table)
    kin_name = name if table == 6 else kinetic_from
    return Friction(static=static, kinetic=kato_kinetic(kin_name))


def static_law(law: str, lubricant_name: str = "A"):
    """A static-friction law with its Table 3 (or, for `kato`, Table 4) parameters."""
    if law == "kato":
        return kato_static(lubricant_name, 4)
    if law not in STATIC_LAWS:
        raise ValueError(f"unknown static law {law!r}; available: {', '.join(STATIC_LAWS)}")
    rows = load_table(3).rows_where(law=law, lubricant=lubricant_name)
    if not rows:
        raise ValueError(f"Table 3 has no {law!r} parameters for lubricant {lubricant_name!r}")
    r = rows[0]
    if law in ("howe", "okamura"):  # mu_s, mu_d and a rate C (Table 3's C1)
        return {"howe": HoweStatic, "okamura": OkamuraStatic}[law](r.mu_s, r.mu_d, r.C1)
    return {"derjaguin": DerjaguinStatic, "power_law": PowerLawStatic}[law](
        mu_d=r.mu_d, C1=r.C1, C2=r.C2)


def experimental_conditions() -> tuple[tuple[float, float], ...]:
    """The (slider weight W in kgf, stiffness k in kgf/mm) pairs of Table 1 (W_i with k_i)."""
    t = load_table(1)
    return tuple((r.slider_weight, r.stiffness) for r in t.rows)

