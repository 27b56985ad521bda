"""Execute the notebooks and store their outputs (figures included) in the committed
`notebooks/NN_*.ipynb`, which the documentation site renders without running them
(mkdocs-jupyter, `execute: false`).

    .venv/bin/python docs/execute_notebooks.py            # all notebooks, full size
    .venv/bin/python docs/execute_notebooks.py --small 03 # STICKSLIP_SMALL=1, only 03_*

The source of each notebook is its jupytext twin `notebooks/NN_*.py` (what the tests run
headless); the .ipynb is rewritten from it with the outputs of this run. Needs the
`[test]` extra (jupytext, nbclient, ipykernel). Prints the time of each notebook.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
SETUP = "import matplotlib\nmatplotlib.rcParams['figure.dpi'] = 72"
"""Run before the notebook's own cells (and not stored): the inline figures' resolution."""


def execute(path: pathlib.Path, timeout: int) -> float:
    """Run the jupytext notebook `path` in a fresh kernel (cwd: the repository root, as
    the tests run it) and write `path.with_suffix('.ipynb')` with its outputs; seconds."""
    import jupytext
    from nbclient import NotebookClient

    import nbformat

    nb = jupytext.read(path)
    # a first cell, removed again below: inline figures at 72 dpi keep the stored
    # notebooks small (their PNGs are base64 in the .ipynb)
    setup = nbformat.v4.new_code_cell(SETUP)
    nb.cells.insert(0, setup)
    t0 = time.perf_counter()
    NotebookClient(nb, timeout=timeout, kernel_name="python3",
                   resources={"metadata": {"path": str(ROOT)}}).execute()
    seconds = time.perf_counter() - t0
    nb.cells.remove(setup)
    for cell in nb.cells:  # reproducible files: no run counters or timings
        cell.get("metadata", {}).pop("execution", None)
    jupytext.write(nb, path.with_suffix(".ipynb"))
    return seconds


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("only", nargs="*", help="notebook number prefixes (default: all)")
    parser.add_argument("--small", action="store_true",
                        help="STICKSLIP_SMALL=1: the notebooks' small grids and samples")
    parser.add_argument("--timeout", type=int, default=1800, help="seconds per cell")
    args = parser.parse_args(argv)
    paths = sorted(NOTEBOOKS.glob("[0-9][0-9]_*.py"))
    if args.only:
        paths = [p for p in paths if any(p.name.startswith(o) for o in args.only)]
    # the kernel inherits this environment: Jupyter's inline backend (not Agg); the PNGs
    # the notebooks also save go to their default folder notebooks/figures (git-ignored)
    os.environ.pop("MPLBACKEND", None)
    os.environ.pop("STICKSLIP_FIGDIR", None)
    if args.small:
        os.environ["STICKSLIP_SMALL"] = "1"
    else:
        os.environ.pop("STICKSLIP_SMALL", None)
    total = 0.0
    for path in paths:
        seconds = execute(path, args.timeout)
        total += seconds
        size = path.with_suffix(".ipynb").stat().st_size / 1024
        print(f"{path.stem}: {seconds:.0f} s, {size:.0f} KiB", flush=True)
    print(f"{len(paths)} notebook(s) in {total:.0f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
