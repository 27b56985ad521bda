"""Design maps as xarray Datasets and NetCDF files (`stickslip design --netcdf OUT.nc`).

`map_dataset(res, attrs)` turns a map (`api.design.DesignStudy.maps`) into an
`xarray.Dataset` with dimensions ``W`` (kgf), ``k`` (kgf/mm) and ``v`` (mm/min), one
variable per quantity with ``units`` and ``long_name``, ``regime`` as a CF flag
variable, the posterior's credible bands along ``band`` and, with ``--max-amplitude``,
``probability_met`` and the inverse design per (W, v). `write_netcdf(path, ds)` writes
it atomically: NetCDF-4 through h5netcdf when installed, else NetCDF-3 through SciPy.
xarray is the optional extra ``[netcdf]`` (`import_xarray`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["NETCDF_EXTRA", "VARIABLES", "import_xarray", "map_dataset", "write_netcdf"]

NETCDF_EXTRA = 'pip install "stickslip-jax[netcdf]"'
"""How to install xarray for `--netcdf`."""

VARIABLES = (  # (key in the map, variable, factor from internal units, units, long name,
    #             column of the long CSV map: the JSON key)
    ("amplitude", "amplitude", 1.0, "mm", "stick-slip amplitude a (eq 5)", "amplitude_mm"),
    ("amplitude_ratio", "amplitude_ratio", 1.0, "1", "a k / W", "amplitude_ratio"),
    ("frequency", "frequency", 1.0, "Hz", "stick-slip frequency f", "frequency_hz"),
    ("frequency_ratio", "frequency_ratio", 1.0, "1", "f / f0", "frequency_ratio"),
    ("stick_time", "stick_time", 1.0, "s", "stick time T1", "stick_time_s"),
    ("critical_speed", "v_c", 60.0, "mm/min", "critical speed v_c (eq 12)",
     "critical_speed_mm_per_min"),
    ("probability", "probability_stick_slip", 1.0, "1",
     "posterior probability of stick-slip", "probability_stick_slip"),
    ("stick_slip", "stick_slip", 1, "1", "stick-slip (1) or not (0)", "stick_slip"),
    ("converged", "converged", 1, "1", "the solve or simulation converged (1)", "converged"),
)

BANDS = (("amplitude_band", "amplitude_band", 1.0, "mm", "amplitude credible band",
          "amplitude_band_mm"),
         ("critical_speed_band", "v_c_band", 60.0, "mm/min", "v_c credible band",
          "critical_speed_band_mm_per_min"))


def import_xarray(option: str | None = None):
    """The xarray module, or `MissingExtra` (an ImportError and a one-line command-line
    error) naming `NETCDF_EXTRA`, prefixed by the command-line `option` that needs it."""
    from ..uncertainty.mcmc import import_extra

    return import_extra("xarray", NETCDF_EXTRA, option)


def map_dataset(res: dict, attrs: dict | None = None):
    """The map `res` (module doc) as an `xarray.Dataset`; `attrs`: global attributes
    (strings and numbers: method, source, ...)."""
    from stickslip_jax.steady import REGIMES

    xr = import_xarray()
    axes = res["axes"]
    dims = ("W", "k", "v")
    coords = {
        "W": ("W", np.asarray(axes["weight"], float), {"units": "kgf",
                                                         "long_name": "slider weight W"}),
        "k": ("k", np.asarray(axes["stiffness"], float), {"units": "kgf/mm",
                                                            "long_name": "drive stiffness k"}),
        "v": ("v", np.asarray(axes["speed"], float) * 60.0, {"units": "mm/min",
                                                               "long_name": "drive speed v"})}
    data = {}
    for key, name, factor, units, long, _ in VARIABLES:
        if key in res:
            x = np.asarray(res[key])
            x = x.astype(np.int8) if x.dtype == bool else x * factor
            data[name] = (dims, x, {"units": units, "long_name": long})
    if "regime" in res:
        data["regime"] = (dims, np.asarray(res["regime"]).astype(np.int8), {
            "long_name": "regime", "flag_values": np.arange(len(REGIMES), dtype=np.int8),
            "flag_meanings": " ".join(r.replace(" ", "_") for r in REGIMES)})
    for key, name, factor, units, long, _ in BANDS:
        if key in res:
            data[name] = (dims + ("band",), np.asarray(res[key]) * factor,
                          {"units": units, "long_name": long})
    if "band" in {d for v in data.values() for d in v[0]}:
        coords["band"] = ("band", np.asarray(["lower", "median", "upper"]))
    tol = res.get("tolerance")
    if tol is not None:
        data["probability_met"] = (dims, np.asarray(tol["probability_met"], float), {
            "units": "1", "long_name": "probability that the limit cycle's amplitude "
            f"stays <= {tol['max_amplitude_mm']:g} mm"})
        w_index = {float(x): i for i, x in enumerate(coords["W"][1])}
        v_index = {round(float(x), 9): i for i, x in enumerate(coords["v"][1])}
        need = np.full((coords["W"][1].size, coords["v"][1].size), np.nan)
        prob = np.full_like(need, np.nan)
        for row in tol["required_stiffness"]:
            i = w_index[float(row["weight_kgf"])]
            j = v_index[round(float(row["drive_speed_mm_per_min"]), 9)]
            k = row["stiffness_kgf_per_mm"]
            need[i, j] = np.nan if k is None else k
            prob[i, j] = row["probability"]
        data["required_stiffness"] = (("W", "v"), need, {
            "units": "kgf/mm", "long_name": f"stiffness meeting the tolerance with "
            f"probability {tol['meet']:g} (NaN: not found)"})
        data["probability_at_required_stiffness"] = (("W", "v"), prob, {"units": "1"})
    ds = xr.Dataset(data, coords=coords)
    for name, value in (attrs or {}).items():
        if value is not None:
            ds.attrs[name] = value if isinstance(value, (int, float, str)) else str(value)
    if tol is not None:
        ds.attrs.update(max_amplitude_mm=float(tol["max_amplitude_mm"]),
                        meet=float(tol["meet"]), draws=int(tol["draws"]))
    return ds


def write_netcdf(path: str, ds) -> None:
    """Write `ds` to `path` atomically (a temporary file renamed over it): NetCDF-4 with
    h5netcdf if installed, else NetCDF-3 (SciPy)."""
    from stickslip_jax.output import write_atomic

    try:
        import h5netcdf  # noqa: F401

        engine = "h5netcdf"
    except ImportError:
        engine = "scipy"
    write_atomic(path, lambda tmp: ds.to_netcdf(tmp, engine=engine))
