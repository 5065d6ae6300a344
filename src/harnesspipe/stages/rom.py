"""Stage 7, ROM extraction (Sec. 4.3): one CWB case per call, then Table 3.

The reference curve is the measured mean (``rom.reference: measured``) or, once
the hi-fi stage exists, its virtual test (``hifi``).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from harnesspipe.calibrate import rom as rom_fit
from harnesspipe.calibrate.objective import l2_error, relative_l2_error
from harnesspipe.calibrate.uncertainty import curve_bands
from harnesspipe.config import ConfigError
from harnesspipe.report import plots
from harnesspipe.stages.common import read_fit, write_csv, write_fit, write_shapes
from harnesspipe.stages.data import read_prepared

TABLE3_COLUMNS = ["case", "E", "sigma_y", "K", "n", "reference"]


def reference_curve(path: Path, settings: dict):
    """``(u, forces, test_id, source)`` of the curve the ROM is fitted to: every measured row
    of a prepared test (``.h5``, ``rom.reference: measured``; forces n_specimens x n_rows,
    fitted through their mean) or a hi-fi virtual test's ``curve.csv`` resampled to a
    uniform grid (``rom.reference: hifi``; forces 1 x n); ``source`` is the prepared test
    or the hi-fi curve."""
    path = Path(path)
    kind = "hifi" if path.suffix == ".csv" else "measured"
    if kind != settings["reference"]:
        raise ConfigError(f"{path}: a {kind} reference, but rom.reference is {settings['reference']!r}")
    if kind == "hifi":
        from harnesspipe.stages.hifi_chain import resample
        curve = pd.read_csv(path)
        grid, F = resample(curve, settings["three_point"]["deflection"], source=str(path))
        return grid, np.asarray(F, dtype=float)[None, :], f"hifi:{path.parent.name}", curve
    ref = read_prepared(path)
    u, F = ref.rows()
    return u, F, ref.test_id, ref


def fit_case(case: str, reference: Path, settings: dict, outdir: Path) -> dict:
    """Calibrate one case; write fit.json, curve.csv, trace.h5, shapes (CSV, VTU) and fit.png.
    fit.json holds, besides the parameters, their uncertainty
    (:func:`harnesspipe.calibrate.rom.fit_uncertainty`), ``rows``, the rows fitted, and
    ``flow_stress`` (eq. 2 and its 95 % band over ``rom.reference_strains``' span); curve.csv
    the fitted curve's 95 % half-widths ``band_N`` (Fisher) and ``band_replicate_N`` (replicate
    sandwich; NaN on a hi-fi reference) (:func:`harnesspipe.calibrate.uncertainty.curve_bands`)."""
    outdir = Path(outdir)
    u, forces, test_id, source = reference_curve(reference, settings)
    F_ref = forces.mean(axis=0)
    t0 = time.perf_counter()
    result = rom_fit.fit(u, F_ref, settings, log_path=outdir / "trace.h5")
    wall_s = time.perf_counter() - t0
    replicates = forces if settings["reference"] == "measured" else None
    uncertainty = rom_fit.fit_uncertainty(u, replicates, result.parameters, settings)
    curve, shapes = rom_fit.simulate(result.parameters, settings, return_shapes=True)
    curve = curve.rename(columns={"deflection_mm": "displacement_mm"})
    curve, flow = curve_bands(uncertainty, result.parameters, u, curve,
                              settings["rom"]["reference_strains"])
    write_shapes(outdir, shapes)
    F_fit = np.interp(u, curve["displacement_mm"], curve["force_N"])
    path = write_fit(outdir, stage="rom", item=case, test_id=test_id,
                     parameters={k: result.parameters[k] for k in ("E", "sigma_y", "K", "n")},
                     error_l2=l2_error(F_ref, F_fit), error_rel=relative_l2_error(F_ref, F_fit),
                     nfev=result.nfev, converged=result.result.converged,
                     wall_s=wall_s, curve=curve,
                     extra={"E_eq13": result.E_eq13, "sigma_y_eq13": result.sigma_y_eq13,
                            "reference": settings["reference"],
                            "fitted": rom_fit.hardening_names(settings["rom"]),
                            "rows": int(u.size), **uncertainty, "flow_stress": flow})
    title = f"{case}: ROM at fitted properties"
    if settings["reference"] == "hifi":
        fig = plots.hifi_rom_figure(source, curve, title=title, label="hi-fi virtual test")
    else:
        fig = plots.fit_figure(source, curve, title=title, xlabel="deflection [mm]", label="ROM (fitted)")
    plots.save(fig, outdir / "fit.png")
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
