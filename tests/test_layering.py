"""The package's layering: data flow one way, no private names across
modules, subcommands registered from the fitting side, no probing of parameter classes.

Read from the source with `ast`, so these fail the moment a shortcut comes back."""

from __future__ import annotations

import ast
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGES = ("stickslip_jax", "fitting")


def _modules(*packages):
    for pkg in packages:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            yield path, ast.parse(path.read_text(), filename=str(path))


def _imports(tree):
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module != "__future__":
            yield node, node.module or "", [a.name for a in node.names], node.level
        elif isinstance(node, ast.Import):
            yield node, None, [a.name for a in node.names], 0


def test_no_private_name_imported_across_modules():
    bad = []
    for path, tree in _modules(*PACKAGES):
        for node, module, names, _ in _imports(tree):
            if module is None:
                continue
            for n in names:
                if n.startswith("_") and not n.startswith("__"):
                    bad.append(f"{path.relative_to(ROOT)}:{node.lineno}: {module}.{n}")
    assert not bad, "private names imported from other modules:\n" + "\n".join(bad)


def _package_of(path: pathlib.Path) -> list[str]:
    """Dotted package of a source file as installed (fitting/ is stickslip_fitting)."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    parts[0] = {"fitting": "stickslip_fitting"}.get(parts[0], parts[0])
    return parts[:-1] if parts[-1] != "__init__" else parts[:-1]


def _absolute(path, module, level):
    """The absolute dotted module of an import (relative ones resolved from `path`)."""
    if level == 0:
        return module.split(".")
    pkg = _package_of(path)
    base = pkg[: len(pkg) - (level - 1)]
    return base + (module.split(".") if module else [])


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def test_no_private_module_imported_from_outside_its_package():
    """A module whose name starts with an underscore is private to the package that holds
    it (and that package's subpackages): the fitting side uses only public modules of the
    model package."""
    bad = []
    for path, tree in _modules(*PACKAGES):
        here = _package_of(path)
        for node, module, names, level in _imports(tree):
            paths = ([_absolute(path, module, level)] if module is not None or level
                     else [n.split(".") for n in names])
            if module is not None or level:  # `from pkg import _module`
                paths += [paths[0] + [n] for n in names if _private(n)]
            for parts in paths:
                i = next((i for i, part in enumerate(parts) if _private(part)), None)
                if i is not None and here[:i] != parts[:i]:
                    bad.append(f"{path.relative_to(ROOT)}:{node.lineno}: {'.'.join(parts[:i + 1])}")
    assert not bad, "private modules imported from outside their package:\n" + "\n".join(bad)


DOCUMENTED_UNDERSCORE = {"os._exit"}
"""Standard-library functions whose documented public name starts with an underscore."""


def test_no_private_attribute_of_an_imported_module():
    """`module._name` (or `getattr(module, "_name")`) on an imported module or object is
    the import of a private name by another route."""
    bad = []
    for path, tree in _modules(*PACKAGES):
        bound = set()
        for _, module, names, _ in _imports(tree):
            bound.update(n.split(".")[0] for n in names)
        for node in ast.walk(tree):
            for alias in getattr(node, "names", ()) if isinstance(
                    node, (ast.Import, ast.ImportFrom)) else ():
                if alias.asname:
                    bound.add(alias.asname)
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and _private(node.attr):
                root = node.value
                while isinstance(root, ast.Attribute):
                    root = root.value
                if (isinstance(root, ast.Name) and root.id in bound
                        and ast.unparse(node) not in DOCUMENTED_UNDERSCORE):
                    bad.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
            elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                  and node.func.id == "getattr" and len(node.args) >= 2
                  and isinstance(node.args[1], ast.Constant)
                  and isinstance(node.args[1].value, str) and _private(node.args[1].value)):
                bad.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    assert not bad, "private attributes of imported names:\n" + "\n".join(bad)


def test_model_package_never_imports_fitting():
    bad = []
    for path, tree in _modules("stickslip_jax"):
        for node, module, names, level in _imports(tree):
            mods = names if module is None else [module]
            if level == 0 and any(m.split(".")[0] in ("fitting", "stickslip_fitting")
                                  for m in mods):
                bad.append(f"{path.relative_to(ROOT)}:{node.lineno}")
        text = path.read_text()
        assert '"stickslip_fitting.' not in text and '"fitting.' not in text, (
            f"{path.relative_to(ROOT)} names a fitting module")
    assert not bad, "stickslip_jax imports the fitting package:\n" + "\n".join(bad)


def test_no_probing_of_parameter_classes():
    """Generic code reads the friction-parameter family's class variables; hasattr on
    parameters (the old way to tell the laws apart) must not come back."""
    bad = []
    for path, tree in _modules("fitting"):
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                    and node.func.id == "hasattr":
                bad.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not bad, "hasattr probing in fitting/:\n" + "\n".join(bad)


def test_installed_under_the_project_namespace():
    """The folder is fitting/, the import name stickslip_fitting (a bare top-level
    `fitting` in site-packages would clash with another distribution of that name)."""
    import stickslip_fitting
    import stickslip_fitting.solve.fit as fit_module

    assert pathlib.Path(stickslip_fitting.__file__).parent.name == "fitting"
    assert fit_module.__name__ == "stickslip_fitting.solve.fit"
    text = (ROOT / "pyproject.toml").read_text()
    assert 'stickslip_fitting = "fitting"' in text


def test_fitting_commands_registered_by_entry_points():
    from stickslip_jax import cli

    names = cli.registered()
    assert not any(n.startswith(("fitting.", "stickslip_fitting.")) for n in cli.SUBCOMMANDS)
    for cmd in ("fit", "mcmc", "design", "plan", "discover", "pitch"):
        assert f"stickslip_fitting.commands.{cmd}" in names, (
            f"{cmd}: not registered (entry point group {cli.COMMAND_GROUP}; reinstall "
            "the package after editing pyproject.toml)")


@pytest.mark.parametrize("law", ["EmpiricalFriction", "MicrosqueezeFriction"])
def test_parameter_laws_are_final_subclasses(law):
    import stickslip_fitting.microsqueeze_params as msp
    import stickslip_fitting.params as params

    cls = getattr(params, law, None) or getattr(msp, law)
    assert issubclass(cls, params.AbstractFrictionParams)
    for var in ("MODEL", "NAMES", "UNITS", "LEAVES", "SHAPE_NAMES", "PRIOR_BOUNDS", "REGION"):
        assert hasattr(cls, var), f"{law}.{var} missing"
    assert set(cls.LEAVES) == set(cls.NAMES) == set(cls.UNITS)
    assert set(cls.NAMES) <= set(cls.PRIOR_BOUNDS)


def test_public_api_resolves():
    import stickslip_fitting

    for name in stickslip_fitting.__all__:
        assert getattr(stickslip_fitting, name) is not None, name


def test_every_package_is_installed():
    """pyproject lists the packages by hand (the fitting/ folder is renamed on install):
    a new subpackage must be added there, or a wheel would lack it."""
    import tomllib

    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
                 ["packages"])
    found = set()
    for pkg, name in (("stickslip_jax", "stickslip_jax"), ("fitting", "stickslip_fitting")):
        for init in (ROOT / pkg).rglob("__init__.py"):
            rel = init.parent.relative_to(ROOT / pkg).parts
            found.add(".".join((name, *rel)))
    assert found == listed, f"not listed: {sorted(found - listed)}; gone: {sorted(listed - found)}"


def test_library_plots_keep_the_backend_and_return_the_figure():
    """Plotting functions keep the user's backend (never switch it to Agg) and return
    the Figure. Source check: no matplotlib.use in the library's plotting modules."""
    for rel in ("fitting/report/plots.py", "fitting/discovery/plots.py"):
        text = (ROOT / rel).read_text()
        assert "matplotlib.use(" not in text, rel
    import numpy as np
    from matplotlib.figure import Figure

    from stickslip_fitting.report.plots import corner_plot

    fig = corner_plot(np.random.default_rng(0).normal(size=(200, 2)), ["a", "b"])
    assert isinstance(fig, Figure)
    import matplotlib.pyplot as plt

    plt.close(fig)
