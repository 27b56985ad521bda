"""Shared test set-up: x64, a PRNG key fixture, a tree comparison helper, and JAX's
persistent compilation cache for the test run.

The compiled programs of a run are kept in `.pytest_cache/d/jax-compilation` (JAX's
persistent compilation cache, programs that took over `CACHE_MIN_COMPILE_S` to
compile): the two processes of `pytest -n 2` load each other's programs instead of both
compiling them, and a later run loads them all (`pytest --cache-clear` empties it).
`STICKSLIP_TEST_CACHE_DIR` chooses another folder, or an empty value turns it off. The
`stickslip` commands the tests start as subprocesses get the same folder through
`STICKSLIP_CACHE_DIR` (the command's own cache variable), never the user's cache.

Under `pytest -n 2` without the slow tests, each worker takes whole test modules
(`pytest_xdist_make_scheduler`), the longest first (`LONG_MODULES`): a module's fixtures
(its fitted campaigns and discoveries) are built once, not once on each worker, and the
two workers end together; modules that compile the same programs run on one worker
(`SHARED_PROGRAMS`); a module that releases the compiled programs runs first
(`FIRST_MODULES`). `--dist` on the command line chooses another distribution.

A run without the slow tests (`-m 'not slow'`, the default) compiles with LLVM's
optimisation level 0 (`TEST_XLA_FLAGS`): it spends most of its time compiling the
package's programs, most of them run a few times, so cheaper machine code beats faster
machine code. The programs (XLA's HLO, its fusions and its arithmetic) are the ones users
run; only the backend's code generation differs, and with it the last bits of rounding,
as they differ between the users' CPUs (AVX2 or AVX-512, fused multiply-adds or not).
No test's verdict rests on those bits: an adaptive solve is compared within its accuracy,
a finite difference within its estimated error. The slow checks (long campaigns, bound by
running, not compiling) keep XLA's default level, and an `XLA_FLAGS` that names
`--xla_backend_optimization_level` itself is kept (`=2`: the default level in any run).
"""

import os

import jax

jax.config.update("jax_enable_x64", True)

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import matplotlib  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

matplotlib.use("Agg")

QUICK_MODULES = ("test_code_size", "test_layering", "test_import_graph", "test_product_text",
                 "test_units", "test_friction", "test_tables", "test_contact_boundary",
                 "test_contact_surfaces", "test_lsq", "test_lsq_pieces", "test_steady")
"""Modules whose tests are marked `quick` (`pytest -m quick`): the source checks and the
model's unit tests (friction laws, tables, contact, the least-squares solver, the steady
state), without fits, discovery or subprocess commands. A test of theirs marked `slow`
is not marked `quick` (`-m quick` replaces the default `-m 'not slow'`)."""

LONG_MODULES = ("test_real_world_records", "test_json_keys", "test_cli_steady",
                "test_logging", "test_design_netcdf", "test_cli_design", "test_mcmc",
                "test_smooth_objective", "test_notebooks", "test_smooth", "test_drives",
                "test_microsqueeze", "test_fit_microsqueeze", "test_exact_campaign",
                "test_sequential_discovery", "test_normal_load", "test_friction_laws",
                "test_exact", "test_short_sticks", "test_limit_cycle", "test_api",
                "test_cycle_discovery", "test_api_results", "test_experiment_design",
                "test_cli_tracebacks", "test_cycle_model")
"""Test modules that take longest in the default run, longest first (each module's
seconds summed from `pytest -n 2 --durations=200`, or single-process `--durations=0`
for the modules whose tests changed since; a module of `SHARED_PROGRAMS` right after
the module it runs with; test_mcmc's and test_api's by their groups' CPU time): they run
first, so that under `pytest -n 2` the short modules fill the end of both workers."""

FIRST_MODULES = ("test_programs",)
"""Modules that run before the others (before `LONG_MODULES`): test_programs releases
JAX's compiled programs (`stickslip_jax.programs.release_programs`, `jax.clear_caches`),
which in a process that holds the suite's programs costs the release itself and the
recompilation of any program a later module shares (measured cold: test_programs 7.5 s
of CPU time in a process of its own, 14.7 s after 71 other modules in one process)."""

SHARED_PROGRAMS = {
    **dict.fromkeys(("test_cli_steady", "test_logging", "test_design_netcdf",
                     "test_cli_design"), "test_json_keys"),
    **dict.fromkeys(("test_cycle_discovery", "test_api_results"), "test_json_keys"),
    **dict.fromkeys(("test_smooth_objective", "test_combined", "test_trace_objective",
                     "test_fit_figure", "test_plots_legends", "test_laplace_jacobian",
                     "test_cli_fit", "test_rigs", "test_params", "test_scipy_reference"),
                    "test_mcmc"),
    **dict.fromkeys(("test_cli_fit_law", "test_cli_loss", "test_mcmc_outputs",
                     "test_one_record", "test_output_safety", "test_tolerance_design",
                     "test_unknowns", "test_real_data"), "test_api"),
}
"""Modules that run on the worker of another (module -> that module) under `pytest -n 2`:
they run the same commands or fits at the same design points and shapes, so the later
modules find the first's compiled programs in memory. Measured in one process at load
10-13: test_json_keys's `steady --damping-ratio 0.05 --tolerance 1um` took 220 s,
test_cli_steady's runs with --damping-ratio 0.05 and with --tolerance after it 3.8 and
0.8 s; test_logging's plan, fit and mcmc took 0.1, 3.1 and 0.9 s after test_json_keys's,
14.9, 6.6 and 12.4 s in a process of their own; test_design_netcdf's cycle map 9.7 s
after json_keys's design, 17.3 s without, and test_cli_design's same map 0.1 s after it;
the synthetic campaign of lubricant A at speed fractions 0.05 and 0.3 (4 cycles, padded
to 40,000 samples) with its features and trace fits 78 s the first time, 5 s for another
seed. Cold, load 4-7: test_mcmc and the six modules after test_fit_figure (campaigns on
that padded length) took 89.6 s of CPU time in one process, 138.4 s in seven processes
sharing the persistent cache; test_api and the six modules of its group that fit the
shipped campaign (`data/examples`) 62.3 s in one process, 104.3 s in seven. Programs with
host callbacks (the `eqx.error_if` checks of traced values: lineax's in the implicit
gradients of the stiff solvers, a microsqueeze law's unless built with
`check_traced=False`) are not kept in the persistent cache, so only the one process
shares them. test_cycle_discovery, test_json_keys and test_api_results read one discovery
of the clean campaign (`clean_discovery_run`), run once on their worker: test_api_results
checks that the API calls the command's discovery engine with the command's records and
base, and gives the command's document from its result. test_unknowns and test_real_data
read one `stickslip fit` of the shipped measured records (`real_records_fit`), which
test_api fits through the API."""

CACHE_MIN_COMPILE_S = 0.1
"""Programs that compiled faster than this are not kept (reading one back costs about
as much)."""


@pytest.fixture
def getkey():
    keys = iter(jax.random.split(jax.random.PRNGKey(0), 10_000))
    return lambda: next(keys)


def tree_allclose(a, b, rtol=1e-10, atol=1e-12):
    la, ta = jax.tree_util.tree_flatten(eqx.filter(a, eqx.is_array))
    lb, tb = jax.tree_util.tree_flatten(eqx.filter(b, eqx.is_array))
    if ta != tb:
        return False
    return all(np.allclose(np.asarray(x), np.asarray(y), rtol=rtol, atol=atol) for x, y in zip(la, lb))


@pytest.fixture
def allclose_tree():
    return tree_allclose


@pytest.fixture(scope="package")  # the tests directory: built once for the run
def clean_discovery_paths(tmp_path_factory):
    """`record_files.clean_discovery_files` (the clean campaign, an irregular record, a
    file that is not a record), written once for the test run."""
    from record_files import clean_discovery_files

    return clean_discovery_files(tmp_path_factory.mktemp("clean_discovery"))


@pytest.fixture(scope="package")  # the tests directory: built once for the run
def clean_discovery_run(clean_discovery_paths, tmp_path_factory):
    """`stickslip discover FILES --json OUT --learn` on `clean_discovery_paths`, run once
    for the test run: {"rc": exit code, "document": the JSON document, "out": printed
    text, "err": stderr text, "call": (records, base, result) of the command's one call of
    `discovery.engine.discover`}."""
    import contextlib
    import io
    import json

    import stickslip_fitting.discovery.engine as engine

    from stickslip_jax.cli import main

    calls = []

    def recorded(records, base, **kw):
        result = run(records, base, **kw)
        calls.append((records, base, result))
        return result

    run = engine.discover
    out_json = tmp_path_factory.mktemp("clean_discovery_json") / "d.json"
    out, err = io.StringIO(), io.StringIO()
    with pytest.MonkeyPatch.context() as mp, contextlib.redirect_stdout(out), \
            contextlib.redirect_stderr(err):
        mp.setattr(engine, "discover", recorded)
        rc = main(["discover", *clean_discovery_paths, "--json", str(out_json), "--learn"])
    assert len(calls) == 1
    return dict(rc=rc, document=json.loads(out_json.read_text()), out=out.getvalue(),
                err=err.getvalue(), call=calls[0])


@pytest.fixture(scope="package")  # the tests directory: built once for the run
def clean_discovery(clean_discovery_run):
    """`clean_discovery_run` as (exit code, JSON document, printed text, stderr text):
    read by test_cycle_discovery (its answer), test_json_keys (its keys) and
    test_api_results (the document `stickslip_fitting.discover` gives on the same files)."""
    run = clean_discovery_run
    return run["rc"], run["document"], run["out"], run["err"]


@pytest.fixture(scope="package")  # the tests directory: built once for the run
def real_records_fit(tmp_path_factory):
    """`stickslip fit data/real/*.csv --json --plot --quiet`, run once for the test run:
    its printed table, JSON document, figure file and the figure it drew. Read by
    test_unknowns (the table and figure) and test_real_data (the document)."""
    import contextlib
    import io
    import json
    import pathlib

    import stickslip_fitting.report.plots as plots

    from stickslip_jax.cli import main

    real = sorted(str(p) for p in
                  (pathlib.Path(__file__).parents[1] / "data" / "real").glob("*.csv"))
    d = tmp_path_factory.mktemp("real_records_fit")
    out, png = d / "fit.json", d / "fit.png"
    drawn = []
    original = plots.fit_figure

    def keep(*args, **kwargs):
        drawn.append(original(*args, **kwargs))
        return drawn[-1]

    buf = io.StringIO()
    with pytest.MonkeyPatch.context() as mp, contextlib.redirect_stdout(buf):
        mp.setattr(plots, "fit_figure", keep)
        code = main(["fit", *real, "--json", str(out), "--plot", str(png), "--quiet"])
    assert code == 0 and len(drawn) == 1
    return buf.getvalue(), json.loads(out.read_text()), png, drawn[0]


def _compilation_cache(config) -> str:
    """The test run's persistent compilation cache folder ("" for off; module doc)."""
    path = os.environ.get("STICKSLIP_TEST_CACHE_DIR")
    if path is None:  # off when pytest runs without its cache (-p no:cacheprovider)
        cache = getattr(config, "cache", None)
        path = str(cache.mkdir("jax-compilation")) if cache is not None else ""
    return path


TEST_XLA_FLAGS = "--xla_backend_optimization_level=0"
"""XLA flags of a run without the slow tests (module doc), added to the environment's
`XLA_FLAGS` before the backend starts; subprocess commands inherit them, so their programs
match the cache's."""


def pytest_configure(config):
    flags = os.environ.get("XLA_FLAGS", "")
    if ((config.option.markexpr or "").strip() == "not slow"
            and "xla_backend_optimization_level" not in flags):
        os.environ["XLA_FLAGS"] = f"{flags} {TEST_XLA_FLAGS}".strip()
    path = _compilation_cache(config)
    os.environ["STICKSLIP_CACHE_DIR"] = path  # subprocess commands: the same folder
    if path:
        jax.config.update("jax_compilation_cache_dir", path)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", CACHE_MIN_COMPILE_S)
    jnp.zeros(())  # initialise the backend once, with x64 on


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.path.stem in QUICK_MODULES and item.get_closest_marker("slow") is None:
            item.add_marker(pytest.mark.quick)
    rank = {stem: i for i, stem in enumerate(FIRST_MODULES + LONG_MODULES)}
    items.sort(key=lambda item: rank.get(item.path.stem, len(rank)))  # stable: file order kept


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """Whole modules per worker, in collection order (module doc), for a run without the
    slow tests; None (xdist's own choice: test by test) when the command line names
    `--dist` or the run takes the slow tests (long campaigns, each on its own)."""
    named = any(a.startswith(("--dist", "-d")) for a in config.invocation_params.args)
    if named or "not slow" not in (config.option.markexpr or ""):
        return None
    from xdist.scheduler import LoadFileScheduling

    class ModuleScheduling(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            """A test's work unit: its module's, or the module it shares programs with
            (`SHARED_PROGRAMS`)."""
            path = super()._split_scope(nodeid)
            stem = path.rpartition("/")[2].removesuffix(".py")
            host = SHARED_PROGRAMS.get(stem)
            return path if host is None else f"{path[:-len(stem) - 3]}{host}.py"

    config.option.loadscopereorder = False  # keep LONG_MODULES first
    return ModuleScheduling(config, log)
