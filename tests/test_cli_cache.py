"""The `stickslip` command's persistent compilation cache (stickslip_jax.cli.console_main):
where it lives, how to turn it off, and that a run fills it and a second run reads it."""

import os
import subprocess
import sys

from stickslip_jax.cli import CACHE_ENV, compilation_cache_dir

SIMULATE = ["simulate", "--lubricant", "A", "--weight", "36", "--stiffness", "86.9",
            "--speed", "3", "--duration", "5", "--sample-rate", "200", "--seed", "1"]


def test_cache_directory_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.delenv(CACHE_ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert compilation_cache_dir() == os.path.join(str(tmp_path), "stickslip-jax")
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "mine"))
    assert compilation_cache_dir() == str(tmp_path / "mine")
    monkeypatch.setenv(CACHE_ENV, "")
    assert compilation_cache_dir() is None


def _run(tmp_path, cache, name):
    # keep every program, however fast it compiled (the default keeps those over 0.2 s)
    env = dict(os.environ, **{CACHE_ENV: cache, "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS": "0"})
    # the run prints how many compilations the persistent cache answered (JAX's event)
    code = ("import sys, jax.monitoring as m; hits = []; "
            "m.register_event_listener(lambda e, **k: hits.append(e) "
            "if e == '/jax/compilation_cache/cache_hits' else None); "
            "from stickslip_jax.cli import console_main; rc = console_main(); "
            "print('cache hits', len(hits)); sys.exit(rc)")
    cmd = [sys.executable, "-c", code] + SIMULATE + ["--out", str(tmp_path / name)]
    return subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)


def _hits(run):
    return int(run.stdout.rsplit("cache hits", 1)[1])


def test_a_run_fills_the_cache_and_the_next_reads_it(tmp_path):
    cache = tmp_path / "cache"
    first = _run(tmp_path, str(cache), "a.csv")
    assert first.returncode == 0, first.stderr
    entries = sorted(os.listdir(cache))
    assert entries  # compiled programs were written
    second = _run(tmp_path, str(cache), "b.csv")
    assert second.returncode == 0, second.stderr
    assert _hits(second) > _hits(first)  # and read back (the first run repeats a few itself)
    assert sorted(os.listdir(cache)) == entries  # same programs: nothing new written
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


def test_the_fit_programs_can_be_kept():
    """JAX keeps no program with a host callback (an `eqx.error_if` check) in its
    persistent cache: the features and trace residuals (the programs of every fit) have
    none, nor has the exact simulator, so a later process loads them."""
    import equinox as eqx
    import jax
    import jax.numpy as jnp

    import stickslip_jax as ss
    from stickslip_fitting.data.features import record_features
    from stickslip_fitting.data.synthetic import synthetic_campaign
    from stickslip_fitting.objectives.cycle_features import feature_data, feature_residuals
    from stickslip_fitting.objectives.trace import trace_data, trace_residuals
    from stickslip_fitting.params import CampaignParams, EmpiricalFriction
    from stickslip_jax.drives import ConstantSpeed
    from stickslip_jax.simulation import simulate_exact

    fr = ss.lubricant("A")
    recs = synthetic_campaign(fr, speed_fractions=(0.3,), cycles=3, seed=0)
    feats = [record_features(r) for r in recs]
    params = CampaignParams(EmpiricalFriction.from_friction(fr), jnp.zeros(len(recs)))

    def lowered(fn, *args):
        return jax.jit(fn).lower(*args).as_text()

    assert "callback" not in lowered(trace_residuals, params, trace_data(recs, feats))
    assert "callback" not in lowered(feature_residuals, params, feature_data(feats))
    # the simulator checks its concrete inputs on the host: no check inside its program
    sw = ss.Slideway(fr, 36.0, 86.9)
    assert "callback" not in lowered(lambda ts: simulate_exact(
        sw, ConstantSpeed(0.05), ts, max_events=4).deflection, jnp.linspace(0.0, 1.0, 10))
    # a run-time check is a callback in the lowered text: the test would see one
    assert "callback" in lowered(lambda x: eqx.error_if(x, x < 0, "negative"), jnp.ones(3))


TRACED = []
"""Calls of `_scaled` that traced it (a stored program runs without tracing)."""


def _scaled(x, factor):
    TRACED.append(factor)
    return {"y": x * factor, "n": 3}


def test_stored_programs_run_without_tracing_again(tmp_path):
    """With the store on, a program compiled once is loaded by a later caller (a new
    `stored_jit`, as in a new process) and run without tracing; the outputs, arrays and
    the rest, are those of `eqx.filter_jit`; another static argument is another program;
    with the store off nothing is written."""
    import equinox as eqx
    import jax.numpy as jnp
    import numpy as np

    from stickslip_jax import stored_programs

    x = jnp.arange(4.0)
    try:
        stored_programs.use(tmp_path)
        first = stored_programs.stored_jit(_scaled)(x, 2.0)
        assert len(TRACED) == 1 and len(os.listdir(tmp_path)) == 1
        second = stored_programs.stored_jit(_scaled)(x, 2.0)
        assert len(TRACED) == 1  # loaded, not traced
        expected = eqx.filter_jit(_scaled)(x, 2.0)
        for out in (first, second):
            assert out["n"] == 3
            np.testing.assert_array_equal(out["y"], expected["y"])
        stored_programs.stored_jit(_scaled)(x, 3.0)
        assert len(os.listdir(tmp_path)) == 2
        stored_programs.use(None)
        stored_programs.stored_jit(_scaled)(x, 4.0)
        assert len(os.listdir(tmp_path)) == 2
    finally:
        stored_programs.use(None)


def _checked(x):
    import equinox as eqx

    return eqx.error_if(x, x < 0, "negative entry")


def test_a_program_with_a_check_is_not_stored(tmp_path):
    """A program with a host callback (`eqx.error_if`) runs as `eqx.filter_jit`'s: its
    check still reports, and nothing is stored."""
    import jax.numpy as jnp
    import numpy as np
    import pytest

    from stickslip_jax import stored_programs

    try:
        stored_programs.use(tmp_path)
        checked = stored_programs.stored_jit(_checked)
        np.testing.assert_array_equal(checked(jnp.ones(2)), 1.0)
        with pytest.raises(Exception, match="negative entry"):
            checked(-jnp.ones(2))
        assert not os.listdir(tmp_path)
    finally:
        stored_programs.use(None)


def test_a_fit_from_stored_programs_gives_the_same_document(tmp_path):
    """`stickslip fit` keeps its solve and intervals' programs in the cache folder; a second
    run loads them (nothing new stored) and writes the same JSON document."""
    import glob

    files = sorted(glob.glob(os.path.join(os.path.dirname(__file__), "..", "data", "examples",
                                          "*.csv")))[:3]
    env = dict(os.environ, **{CACHE_ENV: str(tmp_path / "cache")})
    docs = []
    for name in ("a.json", "b.json"):
        run = subprocess.run([sys.executable, "-m", "stickslip_jax.cli", "fit", "-q", *files,
                              "--json", str(tmp_path / name)], env=env, capture_output=True,
                             text=True, timeout=600)
        assert run.returncode == 0, run.stderr
        docs.append((tmp_path / name).read_text())
        stored = sorted(os.listdir(tmp_path / "cache" / "programs"))
        assert stored
        if name == "a.json":
            first = stored
    assert stored == first
    assert docs[0] == docs[1]
