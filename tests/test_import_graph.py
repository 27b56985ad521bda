"""The import graph of `stickslip_jax` and `stickslip_fitting` has no circle: following a
module's imports never leads back to it. In a circle the order in which the modules run
at import decides whether a name exists yet, and two modules that need each other are one
concern split in two, or a lower layer calling an upper one (the package's data flow runs
one way: docs/architecture.md).

Read from the source with `ast`: every `import` and `from ... import` of the two packages,
relative ones resolved, a name that is a module counted as that module; imports under
`if TYPE_CHECKING:` (never run) are left out. Neither the imports at module level nor
those inside functions (run when the function is called) close a circle."""

from __future__ import annotations

import ast
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGES = {"stickslip_jax": "stickslip_jax", "fitting": "stickslip_fitting"}
"""Source folder -> import name (the folder fitting/ installs as stickslip_fitting)."""


def modules() -> dict[str, tuple[pathlib.Path, bool]]:
    """{dotted name: (source file, is a package)} of every module of the two packages."""
    out = {}
    for folder, name in PACKAGES.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = [name, *path.relative_to(ROOT / folder).with_suffix("").parts]
            package = parts[-1] == "__init__"
            out[".".join(parts[:-1] if package else parts)] = (path, package)
    return out


def _statements(tree, deferred: bool):
    """The nodes of `tree` that run: at module level only (`deferred` False) or also inside
    functions; never the body of an `if TYPE_CHECKING:`."""
    stack = list(tree.body)
    while stack:
        node = stack.pop()
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            stack.extend(node.orelse)
            continue
        if not deferred and isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef,
                                              ast.Lambda)):
            continue
        yield node
        stack.extend(ast.iter_child_nodes(node))


def imported(tree, name: str, package: bool, known, *, deferred: bool) -> set[str]:
    """The modules among `known` that module `name` (a package when `package`) imports."""
    here = name.split(".") if package else name.split(".")[:-1]
    out = set()
    for node in _statements(tree, deferred):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module != "__future__":
            base = (here[:len(here) - node.level + 1] if node.level else [])
            base = ".".join(base + (node.module.split(".") if node.module else []))
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base
                       for a in node.names]
        else:
            continue
        for target in targets:
            while target and target not in known:  # a name inside a module: the module
                target = target.rpartition(".")[0]
            if target and target != name:
                out.add(target)
    return out


def graph(*, deferred: bool) -> dict[str, set[str]]:
    """{module: the modules it imports} over the two packages."""
    known = modules()
    return {name: imported(ast.parse(path.read_text(encoding="utf-8"), filename=str(path)),
                           name, package, known, deferred=deferred)
            for name, (path, package) in known.items()}


def circles(edges: dict[str, set[str]]) -> set[frozenset[str]]:
    """The strongly connected sets of more than one module (Tarjan's algorithm)."""
    index, low, stack, on, out = {}, {}, [], set(), set()

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = set()
            while not group or w != v:
                w = stack.pop()
                on.discard(w)
                group.add(w)
            if len(group) > 1:
                out.add(frozenset(group))

    for v in list(edges):
        if v not in index:
            visit(v)
    return out


def test_module_level_imports_close_no_circle():
    found = circles(graph(deferred=False))
    assert not found, "import circles at module level:\n" + "\n".join(
        " <-> ".join(sorted(c)) for c in found)


def test_imports_inside_functions_close_no_circle():
    found = circles(graph(deferred=True))
    assert not found, "import circles (through imports inside functions):\n" + "\n".join(
        " <-> ".join(sorted(c)) for c in found)


def test_the_reader_resolves_imports_and_finds_a_planted_circle():
    """The checks can fail: relative, absolute and name imports resolve to the modules
    they load, a function's import counts only as deferred, and a circle through three
    modules (with a branch into it) is found."""
    known = {"p", "p.a", "p.b", "p.sub", "p.sub.c", "p.t"}
    source = ("from . import a\nfrom .sub.c import thing\nimport p.b\nimport numpy\n"
              "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from p import t\n"
              "def f():\n    import p.sub\n")
    tree = ast.parse(source)
    assert imported(tree, "p.x", False, known, deferred=False) == {"p.a", "p.sub.c", "p.b"}
    assert imported(tree, "p", True, known, deferred=True) == {"p.a", "p.sub.c", "p.b",
                                                              "p.sub"}
    assert imported(tree, "p.sub.c", False, known, deferred=False) == {"p.sub", "p.b"}
    planted = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert circles(planted) == {frozenset({"a", "b", "c"})}
    assert circles({"a": {"b"}, "b": set()}) == set()
