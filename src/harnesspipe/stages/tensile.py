"""Stage 2, component tensile fits (Sec. 3.2): Table 2.

Closed and open tubes: Nelder-Mead on (E, sigma_Y, K, n) of the tube model.
Fabric: eq. 3 for (E, sigma_Y) on the linear region as the start, then Nelder-Mead
on all four (:func:`harnesspipe.calibrate.tensile.calibrate_fabric`).  Every objective
reads every measured row (the model interpolated onto them).
The measured crosshead travel is mapped to the model's displacement (half of it
for the tubes' symmetric half model, Sec. 3.2).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from harnesspipe.calibrate import tensile as tcal
from harnesspipe.calibrate.objective import l2_error, objective_key, relative_l2_error
from harnesspipe.calibrate.profile import fit_intervals
from harnesspipe.calibrate.uncertainty import curve_bands, fit_summary
from harnesspipe.models import tensile as tmodel
from harnesspipe.report import plots
from harnesspipe.stages.common import read_fit, write_csv, write_fit
from harnesspipe.stages.data import read_prepared

TABLE2_COLUMNS = ["component", "E", "sigma_y", "K", "n"]


def fit_component(component: str, reference: Path, settings: dict, outdir: Path) -> dict:
    """Calibrate one covering on every measured row; write fit.json, curve.csv, trace.h5
    and fit.png.  fit.json holds, besides the parameters, their uncertainty
    (:func:`harnesspipe.calibrate.uncertainty.fit_summary`), their 95 % intervals ``interval95``
    (:func:`harnesspipe.calibrate.profile.fit_intervals`) and ``rows``, the number of
    measured rows fitted, and ``flow_stress`` (eq. 2 and its 95 % band over the plastic
    strains of the flow-stress coordinates); curve.csv the fitted curve's 95 % half-widths
    ``band_N`` (Fisher) and ``band_replicate_N`` (replicate sandwich)
    (:func:`harnesspipe.calibrate.uncertainty.curve_bands`)."""
    outdir = Path(outdir)
    ref = read_prepared(reference)
    scale = tmodel.crosshead_scale(component)
    u_rows, F_rows = ref.rows()
    measured = pd.DataFrame({"displacement_mm": u_rows / scale, "force_N": F_rows.mean(axis=0)})
    common = {"preset": settings["preset"], "nu": settings["nu"], "xatol": settings["xatol"],
              "fatol": settings["fatol"], "maxfev": settings["maxfev"],
              "log_path": outdir / "trace.h5", "key": objective_key(u_rows, F_rows, settings)}
    t0 = time.perf_counter()
    if component == "fabric_tube":
        params, fit = tcal.calibrate_fabric(measured, initial=settings["initial"], **common)
        extra = {"u_dev": params.pop("u_dev")}
        geometry = {"elongation": float(measured["displacement_mm"].max())}
    else:
        params, fit = tcal.calibrate_tube(component, measured, initial=settings["initial"],
                                          pitch=settings["pitch"], **common)
        extra = {}
        geometry = {"pitch": settings["pitch"]}
    wall_s = time.perf_counter() - t0

    def simulate(p: dict) -> pd.DataFrame:
        sim = tmodel.simulate(component, p["E"], p["sigma_y"], p["K"], p["n"], settings["nu"],
                              preset=settings["preset"], **geometry)
        return pd.DataFrame({"displacement_mm": scale * sim["displacement_mm"], "force_N": sim["force_N"]})

    def on_rows(p: dict) -> np.ndarray:
        c = simulate(p)
        return np.interp(u_rows, c["displacement_mm"], c["force_N"])
    extra.update(fit_summary(on_rows, params, list(TABLE2_COLUMNS[1:]), u_rows, F_rows))
    extra["interval95"] = fit_intervals(on_rows, params, list(TABLE2_COLUMNS[1:]), u_rows, F_rows,
                                        extra["fisher"])
    extra["rows"] = int(u_rows.size)
    strains = tcal.FABRIC_STRAINS if component == "fabric_tube" else tcal.TUBE_STRAINS
    curve, extra["flow_stress"] = curve_bands(extra, params, u_rows, simulate(params), strains)
    F_fit, F_mean = on_rows(params), F_rows.mean(axis=0)
    path = write_fit(outdir, stage="tensile", item=component, test_id=ref.test_id, parameters=params,
                     error_l2=l2_error(F_mean, F_fit), error_rel=relative_l2_error(F_mean, F_fit),
                     nfev=fit.nfev, converged=fit.converged, wall_s=wall_s,
                     curve=curve, extra=extra)
    plots.save(plots.fit_figure(ref, curve, title=f"{component}: tensile model at fitted values",
                                xlabel="crosshead displacement [mm]", label="FE (fitted)"),
               outdir / "fit.png")
    return read_fit(path)


def table2(fit_paths: list[Path], out_csv: Path) -> pd.DataFrame:
    """results/tensile/table2.csv: component,E,sigma_y,K,n (DESIGN sec. 5)."""
    rows = [{"component": f["item"], **f["parameters"]} for f in map(read_fit, fit_paths)]
    frame = pd.DataFrame(rows, columns=TABLE2_COLUMNS)
    write_csv(out_csv, frame)
    return frame
