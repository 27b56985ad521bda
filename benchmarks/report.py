"""Run benchmark scripts and write their printed tables into docs/benchmarks.md.

    python benchmarks/report.py                       # the fast benchmarks (FAST)
    python benchmarks/report.py simulate fit          # these benchmarks
    python benchmarks/report.py --all                 # every benchmark (tens of minutes)
    python benchmarks/report.py steady_map --small    # smoke run: each script's --small
    python benchmarks/report.py --list                # what there is, and which are fast

Each benchmark is run as its own process (`python benchmarks/NAME.py`, from the
repository root, with the Python that runs this script), one after the other, so that
one benchmark's compiled programs and threads do not slow the next. Its standard output
(the tables) goes into the benchmark's section of the page, between the lines
`<!-- report.py:begin NAME -->` and `<!-- report.py:end NAME -->`, with the command, its
wall time and the machine: CPU model, cores, load average before and after, date (UTC),
Python, JAX and jaxlib versions and JAX's backend and devices. Sections of benchmarks not
run keep what they hold. A section without markers is added at the end of the page.

Timings depend on the machine and on what else runs on it: read a figure together with
the load average next to it. A benchmark that fails leaves its section as it was; the
report prints its error output and exits with status 1.
"""

from __future__ import annotations

import argparse
import datetime
import importlib.metadata
import os
import pathlib
import platform
import re
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
HERE = ROOT / "benchmarks"
PAGE = ROOT / "docs" / "benchmarks.md"

# name: (what it measures, fast: a full-size run takes well under a minute on 2 cores)
BENCHMARKS: dict[str, tuple[str, bool]] = {
    "steady_map": ("steady analysis over a 10^6-point (W, k, v) map against a SciPy brentq loop", True),
    "microsqueeze": ("microsqueeze mu_0(T1) curves (diffrax, tabulated) against SciPy LSODA", True),
    "records": ("reading record files (MB/s), fast path against the checked parser", True),
    "simulate": ("exact and smoothed simulators on a 12-record campaign against SciPy", False),
    "fit": ("campaign fits (features, trace) against SciPy least_squares; emcee", False),
    "mcmc": ("mcmc with the trace likelihood on the shipped campaign against emcee on NumPy", False),
    "design": ("design maps (steady, exact) against SciPy; 1 and 2 processes", False),
    "fit_batch": ("a batch of campaign fits in 1 and 2 processes", False),
    "discover": ("the discovery workflow on a 12-record campaign, by stage", False),
}
FAST = tuple(name for name, (_, fast) in BENCHMARKS.items() if fast)
# scripts that accept --small (a smoke run)
SMALL = ("steady_map", "microsqueeze", "records", "simulate", "fit", "design", "discover")


def _cpu_model() -> str:
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _version(dist: str) -> str:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def _jax_devices(python: str) -> str:
    """JAX's backend and devices, asked of a fresh process (as the benchmarks see them)."""
    code = "import jax; print(jax.default_backend(), [str(d) for d in jax.devices()])"
    try:
        out = subprocess.run([python, "-c", code], capture_output=True, text=True,
                             timeout=120, cwd=ROOT)
        return out.stdout.strip() or out.stderr.strip().splitlines()[-1]
    except (OSError, subprocess.TimeoutExpired, IndexError) as exc:
        return f"unknown ({exc})"


def _load() -> str:
    try:
        return "{:.2f} {:.2f} {:.2f}".format(*os.getloadavg())
    except OSError:
        return "unknown"


def machine(python: str) -> dict[str, str]:
    return {
        "cpu": _cpu_model(),
        "cores": str(os.cpu_count()),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "jax": _version("jax"),
        "jaxlib": _version("jaxlib"),
        "devices": _jax_devices(python),
    }


def run_one(name: str, extra: list[str], python: str) -> tuple[int, str, str, dict]:
    """Run one benchmark; return (exit status, stdout, stderr, facts of the run)."""
    cmd = [python, str(HERE / f"{name}.py"), *extra]
    facts = {"load_before": _load(),
             "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    facts["wall_s"] = time.perf_counter() - start
    facts["load_after"] = _load()
    facts["command"] = " ".join(["python", f"benchmarks/{name}.py", *extra])
    return proc.returncode, proc.stdout, proc.stderr, facts


def section(name: str, out: str, facts: dict, host: dict) -> str:
    """The generated block of one benchmark (without its marker lines)."""
    lines = [
        f"Regenerated by `python benchmarks/report.py {name}` on {facts['date']}:",
        f"`{facts['command']}` ran for {facts['wall_s']:.0f} s.",
        "",
        "| machine | |",
        "|---|---|",
        f"| CPU | {host['cpu']} |",
        f"| cores | {host['cores']} |",
        f"| load average (1, 5, 15 min) before / after | {facts['load_before']} / {facts['load_after']} |",
        f"| platform | {host['platform']} |",
        f"| Python, JAX, jaxlib | {host['python']}, {host['jax']}, {host['jaxlib']} |",
        f"| JAX backend and devices | {host['devices']} |",
        "",
        "```text",
        out.rstrip("\n"),
        "```",
    ]
    return "\n".join(lines)


def markers(name: str) -> tuple[str, str]:
    return f"<!-- report.py:begin {name} -->", f"<!-- report.py:end {name} -->"


def update_page(text: str, name: str, block: str) -> str:
    """Replace the block between NAME's markers, or add a section at the end."""
    begin, end = markers(name)
    pattern = re.compile(re.escape(begin) + r"\n.*?" + re.escape(end), re.S)
    new = f"{begin}\n{block}\n{end}"
    if pattern.search(text):
        return pattern.sub(lambda _: new, text, count=1)
    what = BENCHMARKS.get(name, ("", False))[0]
    return text.rstrip("\n") + f"\n\n## `benchmarks/{name}.py`\n\n{what}.\n\n{new}\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("names", nargs="*", metavar="NAME",
                    help=f"benchmarks to run (default: the fast ones, {', '.join(FAST)})")
    ap.add_argument("--all", action="store_true", help="run every benchmark")
    ap.add_argument("--small", action="store_true",
                    help="pass --small to the scripts that take it (a smoke run)")
    ap.add_argument("--page", type=pathlib.Path, default=PAGE,
                    help="the page to write (default docs/benchmarks.md)")
    ap.add_argument("--list", action="store_true", help="list the benchmarks and stop")
    args = ap.parse_args(argv)

    if args.list:
        for name, (what, fast) in BENCHMARKS.items():
            print(f"{name:13s} {'fast' if fast else 'slow'}  {what}")
        return 0
    names = list(BENCHMARKS) if args.all else (args.names or list(FAST))
    unknown = [n for n in names if n not in BENCHMARKS]
    if unknown:
        ap.error(f"unknown benchmark {', '.join(unknown)}; choose from {', '.join(BENCHMARKS)}")
    if not args.page.is_file():
        ap.error(f"{args.page} does not exist")

    python = sys.executable
    host = machine(python)
    print(f"machine: {host['cpu']}, {host['cores']} cores, JAX {host['jax']} ({host['devices']})")
    failed = []
    for name in names:
        extra = ["--small"] if args.small and name in SMALL else []
        print(f"running {name} ...", flush=True)
        rc, out, err, facts = run_one(name, extra, python)
        if rc != 0:
            failed.append(name)
            print(f"{name} failed (exit {rc}) after {facts['wall_s']:.0f} s; its section is "
                  f"unchanged. Its error output ends:\n{err[-3000:]}", file=sys.stderr)
            continue
        print(out.rstrip("\n"))
        page = args.page.read_text(encoding="utf-8")  # re-read: one section at a time
        args.page.write_text(update_page(page, name, section(name, out, facts, host)),
                             encoding="utf-8")
        print(f"{name}: {facts['wall_s']:.0f} s, written to {args.page}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
