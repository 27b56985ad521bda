"""The `stickslip` command line: one subcommand per module.

Each subcommand lives in its own module exposing `NAME`, `HELP`,
`add_arguments(parser)` and `run(args) -> int`. The model package's own subcommands
are listed here (`SUBCOMMANDS`); other packages add theirs through the entry-point group
`stickslip.commands` (`COMMAND_GROUP`: the identification package `fitting` registers
fit, mcmc, design, plan, discover and pitch in pyproject.toml), so this layer never
names the layers built on it. Errors a user can fix are printed as one line on stderr
with exit code 2 (`stickslip --debug COMMAND ...` shows the full traceback instead); a
command that ran but whose answer is unreliable (a fit that did not converge) exits 3.
"""

from __future__ import annotations

import argparse
import importlib
import re
import os
import sys

SUBCOMMANDS = ("stickslip_jax.commands.steady", "stickslip_jax.commands.simulate",
               "stickslip_jax.commands.plot", "stickslip_jax.commands.import_raw")
"""The model package's subcommands (modules)."""

COMMAND_GROUP = "stickslip.commands"
"""Entry-point group through which other packages register subcommand modules."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit code 2
        self.exit(2, f"{self.prog}: error: {message}\n")


def registered() -> list[str]:
    """Module names of every subcommand: `SUBCOMMANDS`, then the `COMMAND_GROUP` entry
    points of the installed distributions (in their declared order)."""
    from importlib.metadata import entry_points

    names = list(SUBCOMMANDS)
    for ep in entry_points(group=COMMAND_GROUP):
        if ep.value not in names:
            names.append(ep.value)
    return names


def _name_and_help(module: str) -> tuple[str, str] | None:
    """`NAME` and `HELP` of a subcommand module read from its source without importing it
    (its header up to `HELP`'s assignment); None where they are not plain literals."""
    import ast
    from importlib.util import find_spec

    try:
        with open(find_spec(module).origin, encoding="utf-8") as f:
            src = f.read()
        head = ast.parse(src[:src.index("\n\n", src.index("\nHELP = "))]).body
        found = {t.id: ast.literal_eval(node.value) for node in head
                 if isinstance(node, ast.Assign) for t in node.targets
                 if isinstance(t, ast.Name) and t.id in ("NAME", "HELP")}
        return found["NAME"], found["HELP"]
    except (AttributeError, ImportError, KeyError, OSError, SyntaxError, TypeError, ValueError):
        return None


def _version() -> str:
    """The installed distribution's version (importlib.metadata), or 'unknown'."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("stickslip-jax")
    except PackageNotFoundError:
        return "unknown (not installed)"


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The `stickslip` parser. With `command` given (`main`: the first word of the command
    line, '' for none), only that subcommand's module is imported; the others are listed
    with their one-line help read from their source."""
    parser = _Parser(
        prog="stickslip",
        description="Stick-slip on machine-tool slideways (Kato et al.): analysis, simulation, "
        "identification and design. Units: kgf, mm, s unless an argument says otherwise.")
    parser.add_argument("--version", action="version", version=f"stickslip {_version()}")
    parser.add_argument("--debug", action="store_true",
                        help="show the full Python traceback of an error instead of one line "
                        "(give it before the command: stickslip --debug fit ...)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in registered():
        head = None if command is None else _name_and_help(name)
        if head is not None and head[0] != command:
            sub.add_parser(head[0], help=head[1], description=head[1])
            continue
        mod = importlib.import_module(name)
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.HELP)
        mod.add_arguments(p)
        p.set_defaults(run_command=mod.run)
    return parser


_NEGATIVE = re.compile(r"^-[0-9.][0-9.:eE+-]*(\s.*)?$")


def _join_negative_values(argv: list[str]) -> list[str]:
    """`--speed -10:60:5` -> `--speed=-10:60:5`: argparse would take a value that starts
    with '-' (a negative number or grid) for an option and answer "expected one
    argument"; joined, the command itself says what is wrong with the value."""
    out, i = [], 0
    while i < len(argv):
        tok = argv[i]
        if (tok.startswith("--") and "=" not in tok and i + 1 < len(argv)
                and _NEGATIVE.match(argv[i + 1])):
            out.append(f"{tok}={argv[i + 1]}")
            i += 2
            continue
        out.append(tok)
        i += 1
    return out


def main(argv=None, *, prepare=None) -> int:
    """Parse `argv` and run the command; `prepare()`, if given, runs once the arguments
    are parsed and a command will run (`console_main`: JAX's compilation cache), so
    `--help` and usage errors never import JAX. Progress goes through the `stickslip`
    logger (`stickslip_jax.logs`): stage lines on stderr with the time since this call,
    off with the command's `--quiet`, details with `--debug`."""
    import time

    start = time.time()
    argv = _join_negative_values(list(sys.argv[1:] if argv is None else argv))
    parser = build_parser(next((a for a in argv if not a.startswith("-")), ""))
    args = parser.parse_args(argv)
    if not getattr(args, "run_command", None):
        parser.print_help()
        return 2
    if prepare is not None:
        prepare()
    from .logs import configure, logger
    from .output import interrupted, json_owns_stdout, outputs_together

    configure(args.command, quiet=bool(getattr(args, "quiet", False)), debug=args.debug,
              start=start)
    logger.debug(f"arguments: {' '.join(argv)}")

    try:
        # `--json -`: stdout carries only the JSON document; the table goes to stderr
        # and every output is renamed into place at the end, all or none
        with json_owns_stdout(getattr(args, "json", None) == "-"), outputs_together():
            code = int(args.run_command(args) or 0)
        if interrupted():  # a Ctrl-C swallowed on the way (module output)
            raise KeyboardInterrupt
        return code
    except (ValueError, FileNotFoundError) as exc:
        if args.debug:
            raise
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        print(f"stickslip {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # stdout closed early (`stickslip fit ... | head`): not an error of ours
        sys.stderr.close()
        return 141
    except OSError as exc:
        # the system refused a read or write (full disk, permissions): one line naming the
        # file; the output was written atomically, so the previous file is still there
        if args.debug:
            raise
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"stickslip {args.command}: error: {where}{exc.strerror or exc}; nothing was "
              "written over (free space or fix the permissions, then run again)",
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        # outputs are written atomically: an interrupt leaves no partial file
        print(f"stickslip {args.command}: interrupted", file=sys.stderr)
        return 130


CACHE_ENV = "STICKSLIP_CACHE_DIR"
"""Environment variable: where `stickslip` keeps compiled programs between runs
(default ~/.cache/stickslip-jax, or under $XDG_CACHE_HOME); set it empty to turn the
cache off."""


def compilation_cache_dir() -> str | None:
    """The persistent compilation cache directory of the `stickslip` command (None: off)."""
    path = os.environ.get(CACHE_ENV)
    if path is None:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        path = os.path.join(base, "stickslip-jax")
    return path or None


def _persistent_cache() -> None:
    """JAX's persistent compilation cache in `compilation_cache_dir()` (if on), and the
    fit's programs stored in its `programs` folder (`stored_programs`: loaded without
    tracing them again)."""
    path = compilation_cache_dir()
    if path:
        import jax
        from jax.experimental.compilation_cache import compilation_cache

        from . import stored_programs

        jax.config.update("jax_compilation_cache_dir", path)
        stored_programs.use(os.path.join(path, "programs"))
        if "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS" not in os.environ:
            jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
        # an import may already have compiled (and so settled the cache without a
        # directory): start it again with the directory
        compilation_cache.reset_cache()


def console_main() -> int:
    """Entry point of the `stickslip` command: `main` with JAX's persistent compilation
    cache on, so a later run on a campaign of the same layout (records, cycles and
    samples are padded to buckets) loads the compiled fit instead of compiling it again.
    Every program is kept, the small ones of the feature extraction too (together about
    1 s of a run's compilation; JAX's `JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS` sets a
    minimum compile time instead)."""
    # the command writes figures to files: a non-interactive backend unless the user
    # chose one (library plotting functions never switch it themselves)
    os.environ.setdefault("MPLBACKEND", "Agg")
    from .output import catch_interrupts

    catch_interrupts()
    try:
        code = main(prepare=_persistent_cache)
    except KeyboardInterrupt:  # before a subcommand started (imports, parsing)
        print("stickslip: interrupted", file=sys.stderr)
        code = 130
    if code == 130:
        # interrupted: the outputs are settled (written whole or not at all); leave without
        # the interpreter's shutdown, which can crash ("pure virtual method called",
        # SIGSEGV) when the Ctrl-C landed while jaxlib was being imported
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(130)
    return code


if __name__ == "__main__":
    sys.exit(console_main())
