"""`stickslip mcmc`'s posterior outputs: the corner plot drawn by the
`corner` package, the full chain as arviz InferenceData netCDF (`--chain`), arviz's
ESS / R-hat with the ensemble caveat, and the one-line error without the
`[posterior]` extra. One short run on the shipped example campaign is shared."""

from __future__ import annotations

import contextlib
import io
import json
import pathlib
import sys
import warnings

import numpy as np
import pytest

from stickslip_jax.cli import main

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLES = sorted(str(p) for p in (ROOT / "data" / "examples").glob("*.csv"))
WALKERS, STEPS = 16, 200
BURN = STEPS // 4
NAMES = ["mu_s", "mu_d", "gamma", "m", "delta", "n"]
EXTRA = 'pip install "stickslip-jax[posterior]"'


def _arviz():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        import arviz

    return arviz


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """One `stickslip mcmc` with --json, --chain and --plot; `corner.corner` spied on."""
    import corner
    import matplotlib

    out = tmp_path_factory.mktemp("mcmc")
    paths = {"json": out / "m.json", "chain": out / "chain.nc", "plot": out / "corner.png"}
    calls = []
    real = corner.corner

    def spy(*args, **kwargs):
        fig = real(*args, **kwargs)
        calls.append((args, kwargs, fig))
        return fig

    backend = matplotlib.get_backend()
    text = io.StringIO()
    with pytest.MonkeyPatch.context() as mp, contextlib.redirect_stdout(text):
        mp.setattr(corner, "corner", spy)
        rc = main(["mcmc", *EXAMPLES, "--steps", str(STEPS), "--walkers", str(WALKERS),
                   "--quiet", "--json", str(paths["json"]), "--chain", str(paths["chain"]),
                   "--plot", str(paths["plot"])])
    return dict(rc=rc, out=out, paths=paths, calls=calls, text=text.getvalue(),
                backend_before=backend, backend_after=matplotlib.get_backend(),
                doc=json.loads(paths["json"].read_text()))


def test_chain_opens_with_arviz_and_gives_the_json_means(run):
    assert run["rc"] == 0
    az = _arviz()
    idata = az.from_netcdf(str(run["paths"]["chain"]))
    post, doc = idata.posterior, run["doc"]
    assert list(post.data_vars) == NAMES == doc["names"]
    # chain = walker, draw = step after burn-in (numbered from the burn-in on)
    assert post.sizes["chain"] == WALKERS and post.sizes["draw"] == STEPS - BURN
    assert int(post["draw"][0]) == BURN and int(post["draw"][-1]) == STEPS - 1
    for name in NAMES:
        assert float(post[name].mean()) == pytest.approx(doc["parameters"][name]["mean"],
                                                         rel=1e-12)
        assert float(post[name].median()) == pytest.approx(
            doc["parameters"][name]["median"], rel=1e-12)
        assert post[name].attrs["units"] == doc["parameters"][name]["unit"]
    lp = idata.sample_stats["lp"]
    assert lp.shape == (WALKERS, STEPS - BURN) and np.all(np.isfinite(lp.values))
    attrs = post.attrs
    assert float(attrs["likelihood_scale"]) == pytest.approx(doc["likelihood_scale"])
    assert attrs["objective"] == doc["objective"] and attrs["loss"] == doc["loss"]
    assert json.loads(attrs["units"])["gamma"] == "s^-m"
    assert int(attrs["walkers"]) == WALKERS and int(attrs["burn"]) == BURN
    assert "not independent chains" in attrs["note"]
    names = json.loads(attrs["record_names"])
    assert names == doc["record_names"] == json.loads(attrs["records"])  # old name, 1 release
    assert names == [r["name"] for r in doc["records_screened"] if r["status"] == "used"]


def test_chain_written_atomically(run):
    # written through a temporary file renamed over the target: none is left behind
    assert sorted(p.name for p in run["out"].iterdir()) == ["chain.nc", "corner.png", "m.json"]


def test_corner_plot_made_by_corner(run):
    from matplotlib.figure import Figure

    assert len(run["calls"]) == 1
    (samples,), kwargs, fig = run["calls"][0]
    assert isinstance(fig, Figure) and len(fig.axes) == len(NAMES) ** 2
    assert np.asarray(samples).shape == (WALKERS * (STEPS - BURN), len(NAMES))
    assert kwargs["quantiles"] == [0.16, 0.5, 0.84]
    assert kwargs["labels"] == ["mu_s [-]", "mu_d [-]", "gamma [s^-m]", "m [-]", "delta [s^-n]",
                                "n [-]"]
    truth = json.loads((ROOT / "data" / "examples" / "truth.json").read_text())["friction"]
    expected = {**truth["static"], **truth["kinetic"]}
    assert kwargs["truths"] == pytest.approx([expected[n] for n in NAMES])
    assert run["backend_after"] == run["backend_before"]
    assert run["paths"]["plot"].stat().st_size > 10_000


def test_arviz_summary_printed_with_the_caveat(run):
    text = run["text"]
    assert "ESS bulk" in text and "ESS tail" in text and "R-hat" in text
    assert "not independent chains" in text
    table = text[text.index("ESS bulk"):].splitlines()[1:1 + len(NAMES)]
    assert [line.split()[0] for line in table] == NAMES
    for line in table:
        ess_bulk, ess_tail, rhat = map(float, line.split()[1:4])
        assert ess_bulk > 0 and ess_tail > 0 and rhat > 0.9


def test_library_corner_plot_returns_a_figure_with_units():
    import matplotlib
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    from stickslip_fitting.report.plots import corner_plot

    backend = matplotlib.get_backend()
    x = np.random.default_rng(0).normal([1.0, 2.0], 0.1, size=(500, 2))
    fig = corner_plot(x, ["h_e", "Q"], units={"h_e": "mm", "Q": "mm^4"}, truth={"Q": 2.0})
    assert isinstance(fig, Figure) and len(fig.axes) == 4
    labels = {ax.get_xlabel() for ax in fig.axes} - {""}
    assert labels == {"h_e [mm]", "Q [mm^4]"}
    assert matplotlib.get_backend() == backend
    plt.close(fig)


def test_missing_arviz_is_a_one_line_error(monkeypatch, tmp_path, capsys):
    from stickslip_fitting.uncertainty.mcmc import import_arviz

    monkeypatch.setitem(sys.modules, "arviz", None)  # `import arviz` raises ImportError
    with pytest.raises(ImportError, match=r"\[posterior\]"):
        import_arviz()
    # checked before the fit: one line naming the option and the extra, exit 2
    code = main(["mcmc", *EXAMPLES[:3], "--chain", str(tmp_path / "c.nc"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "--chain" in err[0] and EXTRA in err[0]
    assert not (tmp_path / "c.nc").exists()


def test_without_arviz_the_run_goes_on_without_its_summary(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "arviz", None)
    out = tmp_path / "m.json"
    assert main(["mcmc", *EXAMPLES[:4], "--steps", "20", "--walkers", "12", "--quiet",
                 "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "ESS bulk" not in text and "median" in text and out.exists()


@pytest.mark.parametrize("clash", ["input", "json"])
def test_chain_path_is_checked_before_the_work(tmp_path, clash, capsys):
    rec = tmp_path / "run.csv"
    rec.write_bytes(pathlib.Path(EXAMPLES[0]).read_bytes())
    before = rec.read_bytes()
    target = str(rec) if clash == "input" else str(tmp_path / "same.out")
    extra = [] if clash == "input" else ["--json", target]
    code = main(["mcmc", str(rec), "--chain", target, *extra])
    err = capsys.readouterr().err
    assert code == 2 and "--chain" in err
    assert rec.read_bytes() == before
