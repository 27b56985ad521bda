r"""Where does a fitted model disagree with the records? Residuals by phase, by variable,
in frequency, and a calibrated misspecification test.

`analyse_residuals(residuals, traces, model_velocity, sticking, sigma)` takes the
residuals data - model (mm, one array per record, masked samples only) and the fitted
model's slider velocity and sticking flags, and returns a `ResidualReport`:

- **phases**: each sample is *stick*, *breakaway* (the last `edge` samples of a stick
  before a slip and the first `edge` samples of the slip), *slip*, or *end of slip*
  (the last `edge` samples of a slip and the first `edge` of the next stick); per
  phase the RMS, the mean and the number of samples (mm).
- **bins** of the residual RMS and mean against the model slip velocity (mm/s), the
  drive position (mm), the time within the record (fraction of its length), and per
  record against drive speed (mm/s) and W/k (mm).
- **spectrum**: the periodogram of the residuals averaged over records (against
  frequency in Hz), its peak, and the fraction of residual power below a tenth of the
  Nyquist frequency (white noise: 0.1).
- **misspecification test** (`misspecification_test`): residuals are cut into windows
  of `window` consecutive samples; if they are white noise the window means carry only
  noise and $F = \frac{w\sum_b \bar r_b^2 / B}{\sum (r - \bar r_b)^2/(N-B)}$ follows an
  $F(B, N-B)$ distribution (exactly for i.i.d. Gaussian noise; fitted parameters make
  the test slightly conservative). Any smooth structure the model misses raises the
  window means. The p-value is calibrated on campaigns with no hidden effect in
  `tests/test_discovery_workflow.py`. The noise level does not have to be known.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.stats

__all__ = ["PHASES", "ResidualReport", "analyse_residuals", "misspecification_test",
           "phase_labels"]

PHASES = ("stick", "breakaway", "slip", "end_of_slip")


def phase_labels(sticking: np.ndarray, edge: int = 2) -> np.ndarray:
    """Phase index (into `PHASES`) of every sample from the model's sticking flags."""
    s = np.asarray(sticking, bool)
    n = s.shape[0]
    lab = np.where(s, 0, 2)
    starts = np.flatnonzero(s[:-1] & ~s[1:]) + 1  # first slipping sample
    ends = np.flatnonzero(~s[:-1] & s[1:]) + 1  # first sticking sample after a slip
    for i in starts:
        lab[max(i - edge, 0): min(i + edge, n)] = 1
    for i in ends:
        lab[max(i - edge, 0): min(i + edge, n)] = 3
    return lab


def misspecification_test(residuals: list[np.ndarray], window: int = 5) -> dict:
    """Window-means F test (module docstring): {"F", "df1", "df2", "p_value", "window"}."""
    means, within, n_tot, n_win = [], 0.0, 0, 0
    for r in residuals:
        r = np.asarray(r, float)
        nb = r.shape[0] // window
        if nb < 1:
            continue
        blocks = r[: nb * window].reshape(nb, window)
        m = blocks.mean(axis=1)
        means.append(m)
        within += float(np.sum((blocks - m[:, None]) ** 2))
        n_tot += nb * window
        n_win += nb
    if n_win < 2:
        raise ValueError("too few samples for the misspecification test")
    between = window * float(np.sum(np.concatenate(means) ** 2))
    df1, df2 = n_win, n_tot - n_win
    F = (between / df1) / (within / df2)
    return {"F": F, "df1": df1, "df2": df2, "p_value": float(scipy.stats.f.sf(F, df1, df2)),
            "window": window}


def _binned(x, r, edges):
    idx = np.clip(np.digitize(x, edges) - 1, 0, len(edges) - 2)
    out = []
    for b in range(len(edges) - 1):
        sel = idx == b
        if np.any(sel):
            out.append({"low": float(edges[b]), "high": float(edges[b + 1]),
                        "rms": float(np.sqrt(np.mean(r[sel] ** 2))),
                        "mean": float(np.mean(r[sel])), "n": int(sel.sum())})
    return out


@dataclasses.dataclass
class ResidualReport:
    """Residual summaries (mm unless stated); see the module docstring."""

    rms: float
    noise: float
    phases: dict
    by_slip_velocity: list
    by_drive_position: list
    by_time: list
    by_record: list
    spectrum: dict
    test: dict

    @property
    def p_value(self) -> float:
        return self.test["p_value"]

    def worst_phase(self) -> str:
        """The phase whose RMS exceeds the noise most (relative)."""
        return max(self.phases, key=lambda p: self.phases[p]["rms"] if self.phases[p]["n"] else 0)

    def to_json(self) -> dict:
        return dataclasses.asdict(self)


def analyse_residuals(residuals, traces, model_velocity, sticking, *, sigma=None,
                      window: int = 5, bins: int = 8, edge: int = 2) -> ResidualReport:
    """`ResidualReport` of per-record residuals (data - model, mm, masked samples).

    `traces` the padded traces (`model.campaign_traces`); `model_velocity`, `sticking`
    [R, N] from the fitted model (`simulate_campaign(..., full=True)`); `sigma` the noise
    estimate (mm).
    """
    mask = np.asarray(traces.mask)
    time = np.asarray(traces.time)
    speed = np.asarray(traces.speed)
    wk = np.asarray(traces.weight) / np.asarray(traces.stiffness)
    vel = np.asarray(model_velocity)
    stk = np.asarray(sticking)
    all_r, all_v, all_u, all_tf, all_ph = [], [], [], [], []
    by_record = []
    for i, r in enumerate(residuals):
        m = mask[i]
        t = time[i][m]
        all_r.append(r)
        all_v.append(vel[i][m])
        all_u.append(speed[i] * t)
        all_tf.append((t - t[0]) / max(t[-1] - t[0], 1e-12))
        all_ph.append(phase_labels(stk[i][m], edge))
        by_record.append({"record": i, "drive_speed": float(speed[i]), "W_over_k": float(wk[i]),
                          "rms": float(np.sqrt(np.mean(r ** 2))), "mean": float(np.mean(r))})
    r = np.concatenate(all_r)
    v = np.concatenate(all_v)
    u = np.concatenate(all_u)
    tf = np.concatenate(all_tf)
    ph = np.concatenate(all_ph)
    phases = {}
    for k, name in enumerate(PHASES):
        sel = ph == k
        phases[name] = {"rms": float(np.sqrt(np.mean(r[sel] ** 2))) if sel.any() else 0.0,
                        "mean": float(np.mean(r[sel])) if sel.any() else 0.0, "n": int(sel.sum())}
    vmax = max(float(np.max(np.abs(v))), 1e-9)
    # spectrum: mean periodogram over records, on a common frequency grid
    dt = float(np.median(np.diff(time[0][mask[0]])))
    nfft = 256
    power = np.zeros(nfft // 2 + 1)
    for x in all_r:
        seg = x[: (len(x) // nfft) * nfft].reshape(-1, nfft) if len(x) >= nfft else (
            np.pad(x, (0, nfft - len(x)))[None, :])
        power += np.mean(np.abs(np.fft.rfft(seg - seg.mean(axis=1, keepdims=True), axis=1))
                         ** 2, axis=0)
    freq = np.fft.rfftfreq(nfft, dt)
    low = freq <= 0.1 * freq[-1]
    spectrum = {"frequency_hz": freq.tolist(), "power": (power / len(all_r)).tolist(),
                "peak_hz": float(freq[1:][np.argmax(power[1:])]),
                "low_frequency_fraction": float(power[low].sum() / max(power.sum(), 1e-300))}
    return ResidualReport(
        rms=float(np.sqrt(np.mean(r ** 2))),
        noise=float(sigma) if sigma is not None else float("nan"),
        phases=phases,
        by_slip_velocity=_binned(np.abs(v), r, np.linspace(0.0, vmax * (1 + 1e-9), bins + 1)),
        by_drive_position=_binned(u, r, np.linspace(0.0, float(u.max()) * (1 + 1e-9), bins + 1)),
        by_time=_binned(tf, r, np.linspace(0.0, 1.0 + 1e-9, bins + 1)),
        by_record=by_record,
        spectrum=spectrum,
        test=misspecification_test(all_r, window),
    )
