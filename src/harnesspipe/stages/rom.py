"""Stage 7, ROM extraction (Sec. 4.3): eq. 13 closed forms, then Nelder-Mead.

For one CWB case: E_eff and a first sigma_Y from eq. 13 on the reference curve
(the measured mean, or the hi-fi virtual test once it exists: config
``rom.reference``), then the simplex of Sec. 3.2 on the hardening parameters
(``rom.simplex_parameters``) of a beam model of the same three-point test,
minimising the l2 force error of eq. 4 on the reference grid.
"""
from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

from harnesspipe import rom
from harnesspipe.calibrate import eq13
from harnesspipe.calibrate.objective import l2_error, relative_l2_error
from harnesspipe.calibrate.simplex import nelder_mead
from harnesspipe.report import plots
from harnesspipe.stages.common import read_fit, write_csv, write_fit, write_shapes
from harnesspipe.stages.data import read_prepared

TABLE3_COLUMNS = ["case", "E", "sigma_y", "K", "n", "reference"]


SHAPE_DEFLECTIONS = (0.0, 10.0, 20.0, 30.0)  # frames written for ParaView and the report


def simulate(params: dict, settings: dict, return_shapes: bool = False):
    """ROM three-point curve for effective properties ``params`` (E, sigma_y, K, n)."""
    tp = settings["three_point"]
    return rom.three_point(E=params["E"], sigma_y=params["sigma_y"], K=params["K"], n=params["n"],
                           radius=settings["r_o"], supports=settings["supports"], span=tp["span"],
                           overhang=tp["overhang"], deflection=tp["deflection"],
                           return_shapes=return_shapes, shape_at=SHAPE_DEFLECTIONS,
                           **settings["mesh"])


def _objective_key(u, F, settings) -> str:
    h = hashlib.sha256(json.dumps(settings, sort_keys=True).encode())
    h.update(np.ascontiguousarray(u).tobytes() + np.ascontiguousarray(F).tobytes())
    return h.hexdigest()[:16]


def fit_case(case: str, reference: Path, settings: dict, outdir: Path) -> dict:
    """Calibrate the effective properties of one case; write fit.json, curve.csv, trace.h5, fit.png."""
    outdir = Path(outdir)
    ref = read_prepared(reference)
    u, F = ref.grid, ref.mean
    span, r_o = settings["three_point"]["span"], settings["r_o"]
    rs = settings["rom"]
    E = eq13.effective_modulus(u, F, span, r_o, rs["linear_window"])
    sigma_y_eq13 = eq13.yield_stress(u, F, span, r_o, rs["yield_deflection"])
    fixed = {"E": E, "sigma_y": sigma_y_eq13}
    names = list(rs["simplex_parameters"])
    start = {"sigma_y": sigma_y_eq13, **rs["initial_guess"]}

    def params_of(x):
        return {**fixed, **dict(zip(names, x))}

    def objective(x):
        if np.any(np.asarray(x) <= 0.0):
            return np.inf  # outside the admissible set: rejected
        try:
            curve = simulate(params_of(x), settings)
        except RuntimeError:  # non-converged simulation: a rejected point, logged as NaN
            return np.nan
        return l2_error(F, np.interp(u, curve["deflection_mm"], curve["force_N"]))

    t0 = time.perf_counter()
    res = nelder_mead(objective, [start[k] for k in names], names, xatol=rs["simplex"]["xatol"],
                      fatol=rs["simplex"]["fatol"], maxfev=settings["maxfev"],
                      log_path=outdir / "trace.h5", key=_objective_key(u, F, settings))
    best = params_of(res.x)
    curve, shapes = simulate(best, settings, return_shapes=True)
    curve = curve.rename(columns={"deflection_mm": "displacement_mm"})
    write_shapes(outdir, shapes)
    F_fit = np.interp(u, curve["displacement_mm"], curve["force_N"])
    path = write_fit(outdir, stage="rom", item=case, test_id=ref.test_id,
                     parameters={k: best[k] for k in ("E", "sigma_y", "K", "n")},
                     error_l2=l2_error(F, F_fit), error_rel=relative_l2_error(F, F_fit),
                     nfev=res.nfev, converged=res.converged, wall_s=time.perf_counter() - t0,
                     curve=curve, extra={"sigma_y_eq13": sigma_y_eq13, "reference": settings["reference"],
                                         "fitted": names})
    plots.save(plots.fit_figure(ref, curve, title=f"{case}: ROM at fitted properties",
                                xlabel="deflection [mm]", label="ROM (fitted)"), outdir / "fit.png")
    return read_fit(path)


def table3(fit_paths: list[Path], out_csv: Path) -> pd.DataFrame:
    """Collect the fitted effective properties of every case (DESIGN sec. 5 columns)."""
    rows = []
    for p in fit_paths:
        fit = read_fit(p)
        rows.append({"case": fit["item"], **fit["parameters"], "reference": fit["reference"]})
    frame = pd.DataFrame(rows, columns=TABLE3_COLUMNS)
    write_csv(out_csv, frame)
    return frame
