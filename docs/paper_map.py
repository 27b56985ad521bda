"""The paper-to-code map: which module, class or function cites which equation, table and
figure of Kato et al. in its docstring, read from the source (`ast`, nothing imported).

The documentation build calls `markdown()` (`docs/hooks.py`), so the page always matches
the code; `python docs/paper_map.py` prints the same Markdown.
"""

from __future__ import annotations

import ast
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGES = {"stickslip_jax": ROOT / "stickslip_jax", "stickslip_fitting": ROOT / "fitting"}
"""Import name -> folder (the identification package lives in fitting/)."""

_EQ = re.compile(r"\beqs?\.?\s*((?:\(?\d+[a-z]?\)?"
                 r"(?:\s*(?:,|and|or|-|–|to|/|\+)\s*(?:eq\.?\s*)?)?)+)", re.I)
_TABLE = re.compile(r"\bTables?\s+((?:\d+(?:\s*(?:,|and|or|-|–|/)\s*)?)+)")
_FIG = re.compile(r"\bFigs?\.?\s+((?:\d+(?:\s*(?:,|and|or|-|–|/)\s*)?)+)")
_NUM = re.compile(r"(\d+)([a-z]?)")


def _numbers(text: str) -> list[str]:
    """"(5)-(7), (11)" -> ["5", "6", "7", "11"]; "34/35" -> ["34", "35"]."""
    out: list[str] = []
    tokens = re.findall(r"\d+[a-z]?|-|–|to", text)
    i = 0
    while i < len(tokens):
        tok = tokens[i]
        if tok in ("-", "–", "to"):
            i += 1
            continue
        if (i + 2 < len(tokens) and tokens[i + 1] in ("-", "–", "to")
                and tok.isdigit() and tokens[i + 2].isdigit()
                and 0 < int(tokens[i + 2]) - int(tok) <= 20):
            out += [str(n) for n in range(int(tok), int(tokens[i + 2]) + 1)]
            i += 3
            continue
        out.append(tok)
        i += 1
    return out


def citations(doc: str) -> dict[str, set[str]]:
    """{"eq": {...}, "table": {...}, "fig": {...}} cited in the text `doc`."""
    found = {"eq": set(), "table": set(), "fig": set()}
    for kind, pattern in (("eq", _EQ), ("table", _TABLE), ("fig", _FIG)):
        for m in pattern.finditer(doc):
            found[kind].update(_numbers(m.group(1)))
    return found


def _first_line(doc: str) -> str:
    line = " ".join(doc.strip().split("\n\n")[0].split())
    line = line.replace("|", "\\|")
    return line if len(line) <= 160 else line[:157] + "..."


def objects():
    """(dotted name, docstring) of every module and every public class, function, method
    and documented module attribute of the packages."""
    for package, folder in PACKAGES.items():
        for path in sorted(folder.rglob("*.py")):
            rel = path.relative_to(folder).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            module = ".".join([package, *parts])
            if any(p.startswith("_") and p != "__init__" for p in rel.parts):
                continue
            tree = ast.parse(path.read_text(encoding="utf-8"))
            doc = ast.get_docstring(tree)
            if doc:
                yield module, doc
            yield from _members(tree.body, module)


def _members(body, prefix):
    for i, node in enumerate(body):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            if node.name.startswith("_"):
                continue
            name = f"{prefix}.{node.name}"
            doc = ast.get_docstring(node)
            if doc:
                yield name, doc
            if isinstance(node, ast.ClassDef):
                yield from _members(node.body, name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)) and i + 1 < len(body):
            nxt = body[i + 1]
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if (isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant)
                    and isinstance(nxt.value.value, str)):
                for t in targets:
                    if isinstance(t, ast.Name) and not t.id.startswith("_"):
                        yield f"{prefix}.{t.id}", nxt.value.value


def paper_map() -> dict[str, dict[str, list[tuple[str, str]]]]:
    """{"eq"|"table"|"fig": {number: [(object, first line of its docstring), ...]}}."""
    out: dict[str, dict[str, list[tuple[str, str]]]] = {"eq": {}, "table": {}, "fig": {}}
    for name, doc in objects():
        for kind, numbers in citations(doc).items():
            for n in numbers:
                out[kind].setdefault(n, []).append((name, _first_line(doc)))
    return out


def _key(n: str):
    m = _NUM.match(n)
    return (int(m.group(1)), m.group(2)) if m else (10**6, n)


TITLES = {"eq": "Equations", "table": "Tables", "fig": "Figures"}
LABEL = {"eq": "eq ({})", "table": "Table {}", "fig": "Fig {}"}


def markdown() -> str:
    """The page: one table per equation, table and figure of the paper."""
    m = paper_map()
    lines = [
        "# Paper-to-code map",
        "",
        "Which part of the code cites which equation, table and figure of Kato, Sato, "
        "Yamaguchi and Matsubayashi, *Stick-slip motion and characteristics of friction in "
        "machine tool slideway*. The page is generated when the site is built "
        "(`docs/paper_map.py` reads every docstring of `stickslip_jax` and "
        "`stickslip_fitting`), so it follows the code. An object is listed under every "
        "number its docstring cites: the implementation and the places that use or compare "
        "with it.",
        "",
        "Counts: " + ", ".join(f"{len(m[k])} {TITLES[k].lower()}" for k in TITLES) + ".",
        "",
    ]
    for kind, title in TITLES.items():
        lines += [f"## {title}", ""]
        for n in sorted(m[kind], key=_key):
            lines += [f"### {LABEL[kind].format(n)}", "", "| code | docstring (first paragraph) |",
                      "|---|---|"]
            seen = set()
            for name, first in m[kind][n]:
                if name in seen:
                    continue
                seen.add(name)
                lines.append(f"| `{name}` | {first} |")
            lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.stdout.write(markdown())
