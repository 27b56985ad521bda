"""Size limits of the package's code (`stickslip_jax/`, `fitting/`): no function longer
than 150 lines, no module longer than 800 lines. A function or module over the limit is
read in pieces or not at all; the limits keep each one readable in one sitting.

A function is named `path:Class.function` (nested functions by their enclosing names)
in the failure message; its length runs from its `def` to its last line."""

from __future__ import annotations

import ast
import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
PACKAGES = ("stickslip_jax", "fitting")
FUNCTION_LINES = 150
MODULE_LINES = 800


def _functions(node, prefix, path, out):
    for child in ast.iter_child_nodes(node):
        if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            name = f"{prefix}{child.name}"
            if not isinstance(child, ast.ClassDef):
                out[f"{path}:{name}"] = child.end_lineno - child.lineno + 1
            _functions(child, name + ".", path, out)
        else:
            _functions(child, prefix, path, out)


def sizes() -> dict[str, int]:
    """Lines of every function (`path:qualname`) and module (`path`) over its limit."""
    out = {}
    for package in PACKAGES:
        for file in sorted((ROOT / package).rglob("*.py")):
            path = file.relative_to(ROOT).as_posix()
            text = file.read_text(encoding="utf-8")
            functions = {}
            _functions(ast.parse(text, filename=path), "", path, functions)
            out.update({k: v for k, v in functions.items() if v > FUNCTION_LINES})
            if len(text.splitlines()) > MODULE_LINES:
                out[path] = len(text.splitlines())
    return out


def test_functions_and_modules_within_their_limits():
    over = sizes()
    assert not over, (f"over the limit ({FUNCTION_LINES} lines a function, {MODULE_LINES} a "
                      f"module): {over}")


def test_the_measure_counts_nested_functions_and_methods():
    source = "class A:\n    def f(self):\n        def g():\n            pass\n        return g\n"
    out = {}
    _functions(ast.parse(source), "", "m.py", out)
    assert out == {"m.py:A.f": 4, "m.py:A.f.g": 2}
