"""Unpadded campaign rendering of the exact simulator (`simulate_exact_campaign`): equals
per-record `simulate_exact`, compiles once, gradients flow, bad input is rejected."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stickslip_jax import Slideway, experimental_conditions, lubricant, steady_state
from stickslip_jax.drives import ConstantSpeed, SpeedProgram
from stickslip_jax.simulation import SimulationResult, simulate_exact, simulate_exact_campaign

LUB_A = lubricant("A")
TRACES = {"n": 0}


def _campaign(fr, Ws, ks, vs, ts, rec):
    TRACES["n"] += 1
    sw, dr = jax.vmap(lambda W, k, v: (Slideway(fr, W, k), ConstantSpeed(v)))(Ws, ks, vs)
    return simulate_exact_campaign(sw, dr, ts, rec, max_events=16)


@pytest.fixture(scope="module")
def campaign_fn():
    return eqx.filter_jit(_campaign)


@eqx.filter_jit
def _vmapped_single(sw, dr, ts, max_events):
    return jax.vmap(lambda s, d, t: simulate_exact(s, d, t, max_events=max_events))(sw, dr, ts)


def _padded(tss):
    """The records' times `tss` as one [B, n] array, each padded by its last time (the
    simulation runs to `max(ts)`, so the padding changes nothing), and where the real
    samples are."""
    n = max(t.size for t in tss)
    ts = jnp.asarray(np.stack([np.pad(t, (0, n - t.size), mode="edge") for t in tss]))
    return ts, jnp.asarray(np.stack([np.arange(n) < t.size for t in tss]))


def _per_record(sw, dr, tss, max_events):
    """`simulate_exact` record by record (batched `sw`, `dr`; times `tss`), vmapped over
    the padded records (`_padded`): one compiled program for records of every length."""
    return _vmapped_single(sw, dr, _padded(tss)[0], max_events)


def _records(speed_factors, cycles=4.5, rate=400.0):
    """Records of very different lengths: 2 W/k pairs x given fractions of v_c."""
    recs = []
    for W, k in experimental_conditions()[:2]:
        vc = float(steady_state(LUB_A, W, k, 1.0).critical_speed)
        for f in speed_factors:
            v = f * vc
            ss = steady_state(LUB_A, W, k, v)
            dur = cycles * float(ss.stick_time + ss.slip_time)
            recs.append((W, k, v, 0.01 + np.arange(int(dur * rate) + 1) / rate))
    return recs


def _flat(recs):
    ts = jnp.asarray(np.concatenate([r[3] for r in recs]))
    rec = jnp.asarray(np.concatenate([np.full(r[3].size, i) for i, r in enumerate(recs)]))
    cols = [jnp.asarray([r[j] for r in recs]) for j in range(3)]
    return cols, ts, rec


def test_campaign_equals_per_record_and_compiles_once(campaign_fn):
    recs = _records((0.02, 0.1, 0.3))
    (Ws, ks, vs), ts, rec = _flat(recs)
    assert max(r[3].size for r in recs) > 4 * min(r[3].size for r in recs)
    TRACES["n"] = 0
    tr = campaign_fn(LUB_A, Ws, ks, vs, ts, rec)
    assert tr.deflection.shape == ts.shape and tr.cycles.peak.shape[0] == len(recs)
    sw, dr = jax.vmap(lambda W, k, v: (Slideway(LUB_A, W, k), ConstantSpeed(v)))(Ws, ks, vs)
    refs = _per_record(sw, dr, [r[3] for r in recs], max_events=16)
    off = 0
    for i, (_, _, _, t) in enumerate(recs):
        ref = jax.tree_util.tree_map(lambda x: x[i], refs)
        sl, n = slice(off, off + t.size), t.size
        np.testing.assert_allclose(tr.deflection[sl], ref.deflection[:n], rtol=0, atol=1e-12)
        np.testing.assert_allclose(tr.slider_velocity[sl], ref.slider_velocity[:n], rtol=1e-9,
                                   atol=1e-9)
        np.testing.assert_array_equal(tr.sticking[sl], ref.sticking[:n])
        np.testing.assert_allclose(tr.cycles.peak[i], ref.cycles.peak, atol=1e-12)
        np.testing.assert_array_equal(tr.cycles.valid[i], ref.cycles.valid)
        assert ref.result == SimulationResult.successful
        assert int(tr.num_events[i]) == int(ref.num_events)
        assert int(np.sum(ref.cycles.valid)) >= 2  # the records really stick-slip
        off += t.size
    assert bool(jnp.all(tr.result == SimulationResult.successful))
    # new values of the same shapes: no retrace
    campaign_fn(LUB_A, Ws * 1.01, ks, vs * 0.9, ts + 0.5, rec)
    assert TRACES["n"] == 1


def test_speed_program_records():
    """Slide-hold-slide programs (several drive knots per record) render per record too."""
    W, k = experimental_conditions()[0]
    v = 0.05 * float(steady_state(LUB_A, W, k, 1.0).critical_speed)
    t1 = float(steady_state(LUB_A, W, k, v).stick_time)
    starts = jnp.asarray([[0.0, 2.5 * t1, 3.5 * t1], [0.0, 1.5 * t1, 4.0 * t1]])
    speeds = jnp.asarray([[v, 0.0, v], [v, 0.0, 2 * v]])
    tss = [np.linspace(0.0, 6.0 * t1, 1501), np.linspace(0.0, 8.0 * t1, 977)]
    dr = jax.vmap(SpeedProgram)(starts, speeds)
    sw = jax.vmap(lambda W, k: Slideway(LUB_A, W, k))(jnp.asarray([W, W]), jnp.asarray([k, k]))
    ts = jnp.asarray(np.concatenate(tss))
    rec = jnp.asarray(np.repeat([0, 1], [t.size for t in tss]))
    tr = eqx.filter_jit(simulate_exact_campaign)(sw, dr, ts, rec, max_events=24)
    refs = _per_record(sw, dr, tss, max_events=24)
    off = 0
    for i, t in enumerate(tss):
        np.testing.assert_allclose(tr.deflection[off:off + t.size],
                                   refs.deflection[i, :t.size], rtol=0, atol=1e-12)
        assert int(np.sum(refs.cycles.valid[i])) >= 2
        off += t.size


def test_gradient_matches_sum_of_per_record_gradients():
    recs = _records((0.1,), cycles=2.5, rate=200.0)
    (Ws, ks, vs), ts, rec = _flat(recs)

    def loss_campaign(fr):
        return jnp.sum(_campaign(fr, Ws, ks, vs, ts, rec).deflection ** 2)

    padded, real = _padded([r[3] for r in recs])

    def loss_single(fr):
        """The records' losses summed, each record simulated alone (vmapped over the padded
        records, the padding left out)."""
        sw, dr = jax.vmap(lambda W, k, v: (Slideway(fr, W, k), ConstantSpeed(v)))(Ws, ks, vs)
        x = jax.vmap(lambda s, d, t: simulate_exact(s, d, t, max_events=16).deflection)(
            sw, dr, padded)
        return jnp.sum(jnp.where(real, x, 0.0) ** 2)

    g1 = eqx.filter_jit(eqx.filter_grad(loss_campaign))(LUB_A)
    g2 = eqx.filter_jit(eqx.filter_grad(loss_single))(LUB_A)
    l1, l2 = jax.tree_util.tree_leaves(g1), jax.tree_util.tree_leaves(g2)
    assert any(float(jnp.abs(a)) > 0 for a in l1)
    for a, b in zip(l1, l2):
        np.testing.assert_allclose(a, b, rtol=1e-8, atol=1e-12)


def test_bad_input_is_rejected():
    sw = Slideway(LUB_A, 36.0, 86.9)
    ts = jnp.linspace(0.0, 1.0, 11)
    with pytest.raises(ValueError, match="batched"):
        simulate_exact_campaign(sw, ConstantSpeed(0.01), ts, jnp.zeros(11, int))
    swb, drb = jax.vmap(lambda W: (Slideway(LUB_A, W, 86.9), ConstantSpeed(0.01)))(
        jnp.asarray([36.0, 20.0]))
    with pytest.raises(ValueError, match="integer"):
        simulate_exact_campaign(swb, drb, ts, jnp.zeros(11))
    rec = jnp.asarray([0] * 5 + [1] * 6)
    bad = rec.at[2].set(1)
    with pytest.raises(Exception, match="non-decreasing with values"):
        simulate_exact_campaign(swb, drb, ts, bad)
    with pytest.raises(Exception, match="at least one sample"):
        simulate_exact_campaign(swb, drb, ts, jnp.zeros(11, int))
    with pytest.raises(Exception, match="within each record"):
        simulate_exact_campaign(swb, drb, ts.at[3].set(0.9), rec)
