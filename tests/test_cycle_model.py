"""The per-cycle discovery model (`stickslip_fitting.discovery.cycle_model`): with every effect at
zero it is the exact simulator restarted in every window (the trace objective); its
Jacobian matches finite differences; the sensor kernels are normalised."""

from __future__ import annotations

import equinox as eqx
import numpy as np
import pytest

import independent_records as ir
from stickslip_fitting.discovery.cycle_effects import FAMILIES, Shape, family
from stickslip_fitting.discovery.cycle_model import CycleModel, kernel_cdf, drift_origins


def _model(last_duration, seed0=0, imp=ir.Imperfections()):
    """(model, features fit, data, trace simulation, sd) of a 3-record campaign of the
    independent generator (lubricant A), weighted as the discovery workflow does."""
    from stickslip_jax.records import Record

    from stickslip_fitting.data.campaign import screen_records
    from stickslip_fitting.solve.fit import fit_features
    from stickslip_fitting.objectives.trace import trace_data

    recs = []
    for i, (W, k, v, T) in enumerate(((36.0, 86.9, 5.0, 12.0), (20.0, 27.3, 10.0, 12.0),
                                      (36.0, 86.9, 10.0, last_duration))):
        tr = ir.simulate(ir.LUBRICANT_A, weight=W, stiffness=k, speed_mm_min=v, duration=T,
                         rate_hz=1000.0, seed=seed0 + i, imp=imp)
        recs.append(Record(time=tr.time, deflection=tr.deflection, stiffness=k, weight=W,
                           drive_speed=v / 60.0, note=str(i)))
    c = screen_records(recs)
    fit = fit_features(c.features)
    data = trace_data(c.records, c.features, drive_fix=False)
    sim, sd = _simulation_and_sd(fit.params, data)
    return CycleModel(data, drift_origins(c.records), sd, len(c.records)), fit, data, sim, sd


@eqx.filter_jit
def _simulation_and_sd(params, data):
    """The trace simulation and the samples' standard errors as one program: run
    operation by operation they compile 115 small programs (measured: 7.7 s of CPU time
    cold against 3.1 s)."""
    from stickslip_fitting.objectives.trace import trace_sd, trace_simulation

    sim = trace_simulation(params, data)
    return sim, trace_sd(params, data, sim.slider_velocity)


@pytest.fixture(scope="module")
def setup():
    model, fit, data, sim, sd = _model(6.0)
    z = model.z0(fit.params.friction, np.asarray(fit.params.offset))
    return model, z, fit, data, sim, np.asarray(sd)


def test_base_equals_exact_trace(setup):
    model, z, fit, data, sim, sd = setup
    r, _, ok = model.residuals(z)
    off = np.asarray(fit.params.offset)[np.asarray(data.record)][:, None]
    exact = ((np.asarray(data.deflection) - off - np.asarray(sim.deflection)) / sd)
    exact = exact.ravel()[model.mask]
    assert ok[np.asarray(data.mask).any(1)].all()
    # in standard errors of the samples: RK4 + Hermite against the closed-form slip
    assert np.max(np.abs(r - exact)) < 1e-3


@pytest.mark.parametrize("name", ["viscous_damping", "stribeck", "rate_state",
                                  "drive_speed_drift", "friction_drift", "load_coupling",
                                  "gauge_drift"])
def test_jacobian_matches_finite_differences(setup, name):
    model, z, *_ = setup
    cols = model.cols(family(name))[:2]  # (rate_state: a and b; friction_drift: r_s, r_d)
    cols = np.concatenate([[0, 3], cols])
    shape = Shape()
    z1 = z.copy()
    z1[cols[2:]] = 0.5  # away from zero: the derivative of a present effect
    _assert_jacobian_matches_fd(model, z1, cols, shape, name)


def _assert_jacobian_matches_fd(model, z1, cols, shape, name="", sensor=False):
    """The model's Jacobian columns against central differences (step 1e-5)."""
    r, J, ok = model.evaluate(z1, cols, shape, sensor)
    for j, c in enumerate(cols):
        h = 1e-5
        zp, zm = z1.copy(), z1.copy()
        zp[c] += h
        zm[c] -= h
        fd = (model.residuals(zp, shape, sensor)[0]
              - model.residuals(zm, shape, sensor)[0]) / (2 * h)
        scale = max(np.abs(fd).max(), 1e-9)
        # samples next to an event may sit on either side of it in the two evaluations
        close = np.abs(J[:, j] - fd) <= 1e-4 * scale
        assert close.mean() > 0.999, (name, c, close.mean())


@pytest.mark.parametrize("order", [1, 2])
def test_sensor_jacobian_matches_finite_differences(setup, order):
    """With the sensor kernel (its spectrum computed per record and shared by the
    record's windows): the delay's column and a friction column against central
    differences."""
    model, z, *_ = setup
    col = model.cols(family("sensor_lowpass"))
    z1 = z.copy()
    z1[col] = 1.0  # ms (the family's scale): away from zero, where its derivative is 0
    _assert_jacobian_matches_fd(model, z1, np.concatenate([[0], col]), Shape(order=order),
                                "sensor_lowpass", sensor=True)


def test_per_record_columns_match_finite_differences(setup):
    """The gauge offsets and a per-record family's coefficients share one tangent across
    records (`CycleModel._tangents`); each record's column is nonzero on its own samples
    only and matches central differences."""
    model, z, *_ = setup
    drive = model.cols(family("drive_periodic_error"))
    cols = np.concatenate([np.arange(6, model.n_base), drive[[0, 4, 9]]])
    z1 = z.copy()
    z1[drive] = 0.2
    _assert_jacobian_matches_fd(model, z1, cols, Shape(), "per-record")
    _, J, _ = model.evaluate(z1, cols)
    rec = model._record
    for j, g in enumerate([0, 1, 2, 0, 1, 2]):
        assert np.all(J[rec != g, j] == 0.0) and np.any(J[rec == g, j] != 0.0)


def test_window_rows_group_the_rows_of_each_window(setup):
    """Every row of a window reads the window's one stick-and-slip solution."""
    from stickslip_fitting.discovery.cycle_model import window_rows

    model, *_ = setup
    win = np.asarray(model.data.window)
    first, slot = window_rows(model.data)
    np.testing.assert_array_equal(win[first][slot], win)
    assert np.all(np.diff(win[first]) > 0)
    assert np.all(first == [np.flatnonzero(win == w)[0] for w in win[first]])
    assert first.size < win.size  # the campaign has windows longer than one row


@pytest.mark.parametrize("order, zeta", [(1, 1.0), (2, 1.0), (2, 0.7), (2, 0.4)])
def test_sensor_kernel_has_mean_tau(order, zeta):
    s = np.linspace(0, 1.0, 1000001)  # zeta 0.4 decays at 2 zeta^2 / tau = 32 /s
    cdf = np.asarray(kernel_cdf(s, 0.01, order, zeta))
    assert cdf[0] == 0 and abs(cdf[-1] - 1) < 1e-7
    mean = np.sum(1 - cdf) * (s[1] - s[0])  # E[s] = integral of the survival function
    assert abs(mean - 0.01) < 1e-5


@pytest.mark.parametrize("zeta", [0.4, 0.7, 0.999, 1.0])
def test_second_order_kernel_is_scipys_step_response(zeta):
    """Against SciPy's step response of w_n^2 / (s^2 + 2 zeta w_n s + w_n^2), w_n = 2 zeta / tau."""
    from scipy import signal

    tau = 0.004
    wn = 2 * zeta / tau
    s = np.linspace(0, 0.05, 2001)
    _, ref = signal.step(([wn * wn], [1.0, 2 * zeta * wn, wn * wn]), T=s)
    assert np.max(np.abs(np.asarray(kernel_cdf(s, tau, 2, zeta)) - ref)) < 1e-6


@pytest.fixture(scope="module")
def sensor_campaign():
    """A campaign of the independent generator read through a second-order sensor (40 Hz,
    damping ratio 0.7, lfilter on an 8x finer grid): the model's base fitted with the
    sensor's mean delay free, from the truth. The records' lengths are `setup`'s, so the
    two campaigns share the model's compiled programs (measured: the delay within 0.7 %,
    mean squared residual 0.99)."""
    from stickslip_fitting.discovery.subproblems import SubProblem

    imp = ir.Imperfections(sensor_order=2, sensor_hz=40.0, sensor_zeta=0.7)
    model, fit, *_ = _model(6.0, seed0=10, imp=imp)
    tau = 2 * 0.7 / (2 * np.pi * 40.0)  # the sensor's mean delay (s)
    col = model.cols(family("sensor_lowpass"))
    z = model.z0(fit.params.friction, np.asarray(fit.params.offset))
    z[col] = tau / 1e-3
    cols = np.concatenate([np.arange(model.n_base), col])
    shape = Shape(order=2, zeta=0.7)
    sub = SubProblem(model, z, cols, shape, True)
    res = sub.solve(z[cols], max_evals=20)
    return model, sub.full(res.z), shape, tau


def test_second_order_sensor_of_an_independent_generator_is_fitted(sensor_campaign):
    """The model with the generator's kernel recovers its mean delay and fits to the noise;
    without the previous slip's tail (the gauge still settling when a window starts) the
    windows' first samples miss by several standard errors, in a record's first window
    (no previous window: its own slip stands for the one before) as in the later ones."""
    import jax

    from stickslip_fitting.discovery import cycle_model as cm

    model, z, shape, tau = sensor_campaign
    fitted = z[model.cols(family("sensor_lowpass"))][0] * 1e-3
    assert abs(fitted - tau) < 0.05 * tau, (fitted, tau)
    r = model.residuals(z, shape, sensor=True)[0]
    assert np.mean(r ** 2) < 1.05
    mask = np.asarray(model.data.mask)
    early = np.arange(mask.shape[1])[None, :] < 10
    later = cm.previous_rows(model.data) >= 0
    no_tail = CycleModel.__new__(CycleModel)
    no_tail.__dict__.update(model.__dict__)
    no_tail._prev = (jax.device_put(np.full(mask.shape[0], -1)), *model._prev[1:])
    r0 = no_tail.residuals(z, shape, sensor=True)[0]
    for rows in (later, ~later & mask.any(1)):
        first = (early & rows[:, None])[mask]
        assert first.sum() >= 10
        assert np.mean(r[first] ** 2) < 2.0
        assert np.mean(r0[first] ** 2) > 3 * np.mean(r[first] ** 2)



def test_sensor_tail_starts_where_features_place_the_slip():
    """The gauge's settling from the previous slip starts where the features time that
    slip as read, not the kernel's mean delay before it: a slip rounded by the sensor is
    timed later by the features' half-sine fit (0.6 ms more at 20 Hz, damping ratio
    0.7). At the generator's truth the first 10 ms of every window after a previous one
    then fit to the noise; with the tail at the mean delay they read 0.45 um too high
    (0.9 x the noise), a remainder discovery gave to damping or load coupling. The
    windows have `setup`'s shapes (rows, samples), so the sensor's program is shared."""
    from stickslip_jax.records import Record

    from stickslip_fitting.data.campaign import screen_records
    from stickslip_fitting.objectives.trace import trace_data
    from stickslip_fitting.params import EmpiricalFriction
    from stickslip_fitting.discovery import cycle_model as cm

    imp = ir.Imperfections(sensor_order=2, sensor_hz=20.0, sensor_zeta=0.7)
    recs = []
    for i, (W, k, v, T) in enumerate(((36.0, 86.9, 5.0, 12.0), (20.0, 27.3, 10.0, 12.0),
                                      (36.0, 86.9, 10.0, 6.0))):
        tr = ir.simulate(ir.LUBRICANT_A, weight=W, stiffness=k, speed_mm_min=v, duration=T,
                         rate_hz=1000.0, seed=30 + i, imp=imp)
        recs.append(Record(time=tr.time, deflection=tr.deflection, stiffness=k, weight=W,
                           drive_speed=v / 60.0, note=str(i)))
    c = screen_records(recs)
    # a rounded slip's tail looks like a re-slip to the features: discovery keeps those
    data = trace_data(c.records, c.features, drive_fix=False, keep_reslips=True)
    mask = np.asarray(data.mask)
    model = CycleModel(data, drift_origins(c.records), np.ones(mask.shape), len(c.records))
    f = ir.LUBRICANT_A
    z = model.z0(EmpiricalFriction.from_values(f.mu_s, f.mu_d, f.gamma, f.m, f.delta, f.n),
                 np.zeros(len(c.records)))
    z[model.cols(family("sensor_lowpass"))] = 2 * 0.7 / (2 * np.pi * 20.0) / 1e-3  # ms
    r = model.residuals(z, Shape(order=2, zeta=0.7), sensor=True)[0]  # mm (sd 1 mm)
    since = np.asarray(data.time) - np.asarray(data.start_time)[:, None]
    early = ((since < 0.010) & (cm.previous_rows(data) >= 0)[:, None])[mask]
    assert early.sum() > 300
    noise = imp.noise_mm  # the mean's standard error: 0.05 x the noise
    assert abs(np.mean(r[early])) < 0.2 * noise, np.mean(r[early])
    assert np.sqrt(np.mean(r[early] ** 2)) < 1.1 * noise

def test_tail_sources(setup):
    """A window after a previous one owes that window's slip, begun at its measured
    breakaway; a record's first window owes its own slip, begun its measured length
    before the window's start."""
    from stickslip_fitting.discovery import cycle_model as cm

    model, *_ = setup
    d = model.data
    prev = cm.previous_rows(d)
    rows, began = cm.tail_sources(d)
    t0, T1 = np.asarray(d.start_time), np.asarray(d.stick_time)
    later = prev >= 0
    assert later.any() and (~later).any()
    np.testing.assert_array_equal(rows[later], prev[later])
    np.testing.assert_allclose(began[later], t0[prev[later]] + T1[prev[later]])
    rec, win = np.asarray(d.record), np.asarray(d.window)
    for i in np.flatnonzero(~later):
        same = (rec == rec[i]) & (win == win[i])
        assert rows[i] == np.flatnonzero(same)[0]
        end = np.asarray(d.time)[same][np.asarray(d.mask)[same]].max()
        assert began[i] == pytest.approx(t0[i] - (end - t0[i] - T1[i]))
        assert began[i] < t0[i]


@pytest.mark.parametrize("order", [1, 2])
def test_sensor_changes_the_trace_at_second_order(setup, order):
    """The restart state is a reading, so a pure delay is invisible in the per-cycle
    model: the sensor's change grows like tau^2 (the slips' rounding), not like tau."""
    model, z, *_ = setup
    col = model.cols(family("sensor_lowpass"))
    r0 = model.residuals(z)[0]
    size = []
    for tau in (0.5, 1.0):  # ms (the family's scale)
        z1 = z.copy()
        z1[col] = tau
        size.append(np.linalg.norm(model.residuals(z1, Shape(order=order), sensor=True)[0] - r0))
    assert 0.15 < size[0] / size[1] < 0.4, size


def test_sensor_filter_equals_scipy_lfilter(setup):
    """Against a first-order filter run by SciPy on the model's own noise-free trace,
    sampled 20x finer (away from window starts, where the filter's history is unknown)."""
    from scipy import signal

    model, z, *_ = setup
    data = model.data
    mask = np.asarray(data.mask)
    row = int(np.argmax(mask.sum(1)))
    col = model.cols(family("sensor_lowpass"))
    tau = 3e-3
    z1 = z.copy()
    z1[col] = tau / 1e-3
    sd = np.asarray(model.sd)[row][mask[row]]
    x = np.asarray(data.deflection)[row][mask[row]]
    conv = x - model.residuals(z1, Shape(order=1), sensor=True)[0][
        _row_slice(model, row)] * sd
    plain = x - model.residuals(z)[0][_row_slice(model, row)] * sd
    t = np.asarray(data.time)[row][mask[row]]
    fine = np.linspace(t[0], t[-1], 20 * t.size)
    # the slider's clock starts tau earlier (the restart state is a reading)
    xf = np.interp(fine + tau, t, plain)
    dt = fine[1] - fine[0]
    b, a = signal.bilinear([1.0], [tau, 1.0], fs=1 / dt)
    yf = signal.lfilter(b, a, xf, zi=signal.lfilter_zi(b, a) * xf[0])[0]
    ref = np.interp(t, fine, yf)
    keep = (t > t[0] + 10 * tau) & (t < t[-1] - 2 * tau)
    assert np.max(np.abs(conv - ref)[keep]) < 2e-4  # mm; the slip is ~0.3 mm


def _row_slice(model, row):
    mask = np.asarray(model.data.mask)
    start = int(mask[:row].sum())
    return slice(start, start + int(mask[row].sum()))


def test_unphysical_values_are_named():
    f = family("viscous_damping")
    assert f.unphysical(np.array([-0.01])) and "c" in f.unphysical(np.array([-0.01]))
    assert f.unphysical(np.array([0.01])) is None
    assert "lifts" in family("load_coupling").unphysical(np.array([2.0]))
    assert {f.name for f in FAMILIES} >= {"viscous_damping", "stribeck", "sensor_lowpass",
                                          "drive_periodic_error", "friction_drift"}


def test_rate_and_state_signs(setup):
    """Dieterich-Ruina in the slip: the evolution effect (b > 0, friction falling as the
    contact renews) lengthens the slip; the direct effect (a > 0, friction rising with
    speed) shortens it; the stick before the breakaway is unchanged."""
    model, z, *_ = setup
    a_col, b_col = model.cols(family("rate_state"))
    mask = np.asarray(model.data.mask)
    _, yd, _ = model.residuals(z)
    row = int(np.argmax([(mask[i] & (yd[i] > 0)).any() for i in range(len(mask))]))
    sl = _row_slice(model, row)
    sd = np.asarray(model.sd)[row][mask[row]]
    x = np.asarray(model.data.deflection)[row][mask[row]]

    def reading(**coef):
        z1 = z.copy()
        for col, v in ((a_col, coef.get("a", 0.0)), (b_col, coef.get("b", 0.0))):
            z1[col] = v / 1e-3
        return x - model.residuals(z1)[0][sl] * sd

    base, weak, strong = reading(), reading(b=0.005), reading(a=0.005)
    before = ~(yd[row][mask[row]] > 0).cumsum().astype(bool)
    assert np.allclose(weak[before], base[before]) and np.allclose(strong[before], base[before])
    # the deepest point of the slip (the window ends where the measured slip ends)
    assert weak.min() < base.min() - 1e-4 < strong.min() - 2e-4  # mm


def test_rational_stribeck_form(setup):
    """The rational (Hess-Soom) Stribeck curve 1/(1 + (v/v_s)^p) - 1: equal to the
    exponential form where v << v_s, different at v ~ v_s, and its Jacobian matches
    finite differences. Every form is 0 at rest: where v << v_s the drop b
    changes nothing, so mu_m of eq (3) stays the friction the slip starts against."""
    model, z, *_ = setup
    col = model.cols(family("stribeck"))[0]
    z1 = z.copy()
    z1[col] = 0.5
    base = model.residuals(z, Shape(vs=1e9, p=2.0))[0]
    far = [model.residuals(z1, Shape(vs=1e9, p=2.0, form=f))[0]
           for f in ("exp", "rational", "log", "linear")]
    for r in far:  # (whitened; the stop's interpolation moves by rounding only)
        assert np.max(np.abs(r - base)) < 1e-6, np.max(np.abs(r - base))
    near = [model.residuals(z1, Shape(vs=5.0, p=2.0, form=f))[0] for f in ("exp", "rational")]
    assert np.max(np.abs(near[0] - near[1])) > 1e-3
    _assert_jacobian_matches_fd(model, z1, np.array([0, col]),
                                Shape(vs=5.0, p=2.0, form="rational"), "rational")


def test_damping_ratio_form_is_a_dashpot_per_record(setup):
    """Viscous damping's ratio form (one damping ratio zeta, c = 2 zeta sqrt(k m) in each
    record): on each record's rows it equals the dashpot form with that record's c; the
    setup's two sliders differ in sqrt(k m), so one dashpot cannot be both; its Jacobian
    matches finite differences."""
    from stickslip_jax.units import G_MM_S2

    model, z, fit, data, *_ = setup
    col = model.cols(family("viscous_damping"))[0]
    scale = family("viscous_damping").scales[0]
    zeta = 0.1
    z1 = z.copy()
    z1[col] = zeta / scale
    ratio = model.residuals(z1, Shape(damping="ratio"))[0]
    L = np.asarray(data.mask).shape[1]
    rec = np.repeat(np.asarray(data.record), L)[model.mask]
    W = np.repeat(np.asarray(data.weight), L)[model.mask]
    k = np.repeat(np.asarray(data.stiffness), L)[model.mask]
    dashpots = set()
    for g in np.unique(rec):
        rows = rec == g
        c = 2.0 * zeta * np.sqrt(k[rows][0] * W[rows][0] / G_MM_S2)
        dashpots.add(round(c, 6))
        z2 = z.copy()
        z2[col] = c / scale
        dashpot = model.residuals(z2, Shape())[0]
        np.testing.assert_allclose(ratio[rows], dashpot[rows], atol=1e-9)
    assert len(dashpots) > 1
    _assert_jacobian_matches_fd(model, z1, np.array([0, col]), Shape(damping="ratio"),
                                "damping ratio")


def test_shared_screw_maps_amplitude_and_phases(setup):
    """The screw refit with one amplitude per harmonic and a phase per record
    (`subproblems.SharedScrewProblem`): its model coordinates are A cos(phi), A sin(phi) per
    record, its residuals those of the per-record model at those coefficients, and its
    chain-rule Jacobian matches finite differences."""
    from stickslip_fitting.discovery.subproblems import SharedScrewProblem, SubProblem

    model, z, *_ = setup
    G = model.n_records
    fam = family("drive_periodic_error")
    base = np.arange(model.n_base)
    cols = np.concatenate([base, model.cols(fam)])
    shape = Shape(pitch=2.0)
    shared = SharedScrewProblem(model, z.copy(), cols, shape, False, None, base.size)
    phases1 = np.linspace(0.3, 2.0, G)
    w = np.concatenate([z[base], [2.0, 0.5], phases1, -phases1])  # 2 um and 0.5 um
    coef = shared.full(w)[model.cols(fam)].reshape(G, 4)
    np.testing.assert_allclose(np.hypot(coef[:, 0], coef[:, 1]), 2.0)
    np.testing.assert_allclose(np.hypot(coef[:, 2], coef[:, 3]), 0.5)
    np.testing.assert_allclose(np.arctan2(coef[:, 1], coef[:, 0]), phases1)
    r, J, _ = shared.evaluate(w)
    plain = SubProblem(model, z.copy(), cols, shape)
    np.testing.assert_allclose(r, plain.evaluate(shared.full(w)[cols])[0])
    for j in (0, 1, base.size, base.size + 2 + G - 1):
        h = 1e-5
        wp, wm = w.copy(), w.copy()
        wp[j] += h
        wm[j] -= h
        fd = (shared.evaluate(wp)[0] - shared.evaluate(wm)[0]) / (2 * h)
        close = np.abs(J[:, j] - fd) <= 1e-4 * max(np.abs(fd).max(), 1e-9)
        assert close.mean() > 0.999, (j, close.mean())
    start = SharedScrewProblem.start(coef.ravel(), G)
    np.testing.assert_allclose(start[:2], [2.0, 0.5])
    np.testing.assert_allclose(start[2:2 + G], phases1)


def test_breakaway_offsets_put_the_breakaways_at_the_measured_stick_times(setup):
    """At the fitted friction the offsets are the fitted ones (to a few um); at another
    friction (mu_s 10 % higher) the fitted offsets put the model's slips away from the
    measured ones, `breakaway_offsets` puts them back (residual near the noise's)."""
    from stickslip_fitting.params import EmpiricalFriction

    model, z, fit, *_ = setup
    R = model.n_records
    off = model.breakaway_offsets(z[:6], np.zeros(R))
    np.testing.assert_allclose(off, z[6:model.n_base], atol=3e-3)
    v = np.asarray(EmpiricalFriction(*[float(x) for x in z[:6]]).values())
    z2 = z.copy()
    z2[:6] = np.asarray(model.z0(EmpiricalFriction.from_values(1.1 * v[0], *v[1:]),
                                 np.zeros(R))[:6])
    r_old = model.residuals(z2)[0]
    z2[6:model.n_base] = model.breakaway_offsets(z2[:6], z2[6:model.n_base])
    r_new = model.residuals(z2)[0]
    assert np.mean(r_new ** 2) < 0.1 * np.mean(r_old ** 2), (np.mean(r_new ** 2),
                                                              np.mean(r_old ** 2))


def test_stick_terms_move_the_breakaway(setup):
    """A lost motion of the drive (the stick term min(v s, L)/L with coefficient -L) holds
    the stick line back by min(v s, L) and delays every slip by L/v / (1 - W mu_0'/(k v))
    (eq (1) is met later on a line shifted down by L; 1.1-1.25 L/v on these records;
    windows end at the measured slip end, so only the 10 mm/min records, L/v = 12 ms,
    keep their delayed slip); the stick terms' Jacobian columns match central
    differences."""
    from stickslip_fitting.discovery.cycle_effects import STICK_SCALE, STICK_TERMS

    model, z, *_ = setup
    cols = model.layout.stick_cols()
    lost = cols[STICK_TERMS.index("stick_lost2um")]
    z1 = z.copy()
    z1[lost] = -0.002 / STICK_SCALE
    (r0, yd0, _), (r1, yd1, ok) = model.residuals(z), model.residuals(z1)
    assert ok[model._real_rows].all()
    d = model.data
    t, win, mask = np.asarray(d.time), np.asarray(d.window), np.asarray(d.mask)
    delays = []
    for w in np.unique(win):
        rows = win == w
        tt, m0, m1 = (a[rows][mask[rows]] for a in (t, yd0 > 0, yd1 > 0))
        if m0.any() and m1.any():
            v = float(np.asarray(d.speed)[rows][0])
            delays.append((tt[m1].min() - tt[m0].min()) * v / 0.002)
    assert len(delays) > 10 and 1.0 < np.median(delays) < 1.4, delays
    pair = cols[[STICK_TERMS.index("stick_creep30ms"), STICK_TERMS.index("stick_lost4um")]]
    z2 = z.copy()
    z2[pair] = 2.0
    _assert_jacobian_matches_fd(model, z2, np.r_[[0, 3], pair], Shape(), "stick")


def test_stick_terms_left_out_only_where_they_add_nothing(setup):
    """The programs without the stick terms (`CycleModel._stick`: their coefficients zero
    and not differentiated) give the residuals and Jacobian of the full model: at the
    features' friction the base columns agree with those of a call that differentiates a
    stick term too (the full program; another program, so the last digits of some
    samples differ: 1e-12 relative); a non-zero coefficient or a stick column selects
    the full program."""
    model, z, *_ = setup
    stick = model.layout.stick_cols()
    base = np.arange(model.n_base)
    assert not model._stick(z, base)
    assert model._stick(z, np.r_[base, stick[:1]])
    z1 = z.copy()
    z1[stick[-1]] = 0.5
    assert model._stick(z1, base)
    r, J, ok = model.evaluate(z, base)
    r_full, J_full, ok_full = model.evaluate(z, np.r_[base, stick[:1]])
    assert ok and ok_full
    np.testing.assert_allclose(r, r_full, rtol=1e-9, atol=1e-12 * np.abs(r).max())
    np.testing.assert_allclose(J, J_full[:, :base.size], rtol=1e-9,
                               atol=1e-12 * np.abs(J).max())
