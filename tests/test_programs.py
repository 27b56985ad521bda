"""Compiled programs released near the memory-map limit (stickslip_jax.programs): a
process that compiles many programs (many campaigns) must not reach the kernel's cap,
where XLA's compiler kills the process (measured: segmentation fault at 65,530 maps)."""

from __future__ import annotations

import sys

import jax
import jax.numpy as jnp
import pytest

from stickslip_jax.programs import map_limit, maps_in_use, release_programs

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc is Linux")


def _compile_some(n: int):
    f = jax.jit(lambda x: jnp.sin(x) @ jnp.cos(x).T + jnp.fft.rfft(x, axis=1).real.sum())
    for i in range(n):
        f(jnp.ones((i + 1, 5))).block_until_ready()
    return f


@linux
def test_compiled_programs_hold_maps_and_their_release_frees_them():
    f = _compile_some(30)
    before = maps_in_use()
    assert before is not None and map_limit() is not None
    out = release_programs(0.5, limit=before)  # "near the limit": over half of it
    assert out.released and out.maps_before == before and out.limit == before
    # 30 programs of about 18 maps each are gone (measured 4101 -> 520 for 200)
    assert out.maps_after < before - 200, out
    # and they compile again on use
    assert float(f(jnp.ones((3, 5))).sum()) == pytest.approx(
        float((jnp.sin(jnp.ones((3, 5))) @ jnp.cos(jnp.ones((3, 5))).T).sum()
              + 9.0 * jnp.fft.rfft(jnp.ones((3, 5)), axis=1).real.sum()))


@linux
def test_nothing_released_below_the_fraction():
    _compile_some(3)
    before = maps_in_use()
    out = release_programs(0.5, limit=4 * before)
    assert not out.released and out.maps_before == out.maps_after
    assert maps_in_use() >= before - 5  # the programs are still there


def test_a_fraction_outside_zero_to_one_is_refused():
    with pytest.raises(ValueError, match="fraction"):
        release_programs(0.0)


def test_the_campaign_verbs_release_first(monkeypatch):
    """fit_features and discover_cycles check the maps before anything else (a campaign
    that is refused still checked them)."""
    from stickslip_fitting.solve import fit as fit_module
    from stickslip_fitting.discovery import cycle_workflow, engine

    calls = []
    spy = lambda *a, **k: calls.append(1) or release_programs(1.0)  # noqa: E731
    monkeypatch.setattr(fit_module, "release_programs", spy)
    monkeypatch.setattr(engine, "release_programs", spy)
    with pytest.raises(ValueError, match="no records to fit"):
        fit_module.fit_features([])
    assert len(calls) == 1
    with pytest.raises(ValueError, match="usable stick-slip"):
        cycle_workflow.discover_cycles([])
    assert len(calls) == 2
