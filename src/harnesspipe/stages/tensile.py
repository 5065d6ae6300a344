"""Stage 2, component tensile fits (Sec. 3.2): Table 2.

Closed and open tubes: Nelder-Mead on (E, sigma_Y, K, n) of the tube model.
Fabric: eq. 3 for (E, sigma_Y) on the linear region, then Nelder-Mead on (K, n).
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
from harnesspipe.calibrate.uncertainty import error_dof, fit_standard_errors
from harnesspipe.models import tensile as tmodel
from harnesspipe.report import plots
from harnesspipe.stages.common import read_fit, write_csv, write_fit
from harnesspipe.stages.data import read_prepared

TABLE2_COLUMNS = ["component", "E", "sigma_y", "K", "n"]


def fit_component(component: str, reference: Path, settings: dict, outdir: Path) -> dict:
    """Calibrate one covering; write fit.json, curve.csv, trace.h5 and fit.png."""
    outdir = Path(outdir)
    ref = read_prepared(reference)
    scale = tmodel.crosshead_scale(component)
    measured = pd.DataFrame({"displacement_mm": ref.grid / scale, "force_N": ref.mean})
    common = {"preset": settings["preset"], "nu": settings["nu"], "xatol": settings["xatol"],
              "fatol": settings["fatol"], "maxfev": settings["maxfev"],
              "log_path": outdir / "trace.h5"}
    t0 = time.perf_counter()
    if component == "fabric_tube":
        params, fit = tcal.calibrate_fabric(measured, initial=settings["initial"], **common)
        extra = {"u_dev": params.pop("u_dev")}
        geometry = {"elongation": float(measured["displacement_mm"].max())}
    else:
        params, fit = tcal.calibrate_tube(component, measured, initial=settings["initial"],
                                          pitch=settings["pitch"],
                                          key=objective_key(ref.grid, ref.mean, settings), **common)
        extra = {}
        geometry = {"pitch": settings["pitch"]}

    def simulate(p: dict) -> pd.DataFrame:
        sim = tmodel.simulate(component, p["E"], p["sigma_y"], p["K"], p["n"], settings["nu"],
                              preset=settings["preset"], **geometry)
        return pd.DataFrame({"displacement_mm": scale * sim["displacement_mm"], "force_N": sim["force_N"]})

    def on_grid(p: dict) -> np.ndarray:
        c = simulate(p)
        return np.interp(ref.grid, c["displacement_mm"], c["force_N"])
    wall_s = time.perf_counter() - t0
    extra.update(_standard_errors(component, on_grid, params, ref, measured["displacement_mm"]))
    curve = simulate(params)
    F_fit = np.interp(ref.grid, curve["displacement_mm"], curve["force_N"])
    path = write_fit(outdir, stage="tensile", item=component, test_id=ref.test_id, parameters=params,
                     error_l2=l2_error(ref.mean, F_fit), error_rel=relative_l2_error(ref.mean, F_fit),
                     nfev=fit.nfev, converged=fit.converged, wall_s=wall_s,
                     curve=curve, extra=extra)
    plots.save(plots.fit_figure(ref, curve, title=f"{component}: tensile model at fitted values",
                                xlabel="crosshead displacement [mm]", label="FE (fitted)"),
               outdir / "fit.png")
    return read_fit(path)


def _standard_errors(component: str, on_grid, params: dict, ref, displacement) -> dict:
    """``standard_error`` and ``standard_error_dof`` of a fit (fit.json): the fabric's E and
    sigma_Y by eq. 3 on each replicate (none when a replicate has no linear region), every
    other parameter by least squares (:func:`fit_standard_errors`)."""
    replicates = ref.replicates()
    fitted, closed_form = list(TABLE2_COLUMNS[1:]), {}
    if component == "fabric_tube":
        fitted = ["K", "n"]
        if len(replicates) >= 2:
            try:
                closed_form = tcal.fabric_closed_form(displacement, replicates)
            except ValueError:
                return {"standard_error": None, "standard_error_dof": None}
    return {"standard_error": fit_standard_errors(on_grid, params, fitted, ref.mean, replicates,
                                                  closed_form),
            "standard_error_dof": error_dof(len(ref.grid), fitted, replicates)}


def table2(fit_paths: list[Path], out_csv: Path) -> pd.DataFrame:
    """results/tensile/table2.csv: component,E,sigma_y,K,n (DESIGN sec. 5)."""
    rows = [{"component": f["item"], **f["parameters"]} for f in map(read_fit, fit_paths)]
    frame = pd.DataFrame(rows, columns=TABLE2_COLUMNS)
    write_csv(out_csv, frame)
    return frame
