"""Stage 8, branching harness (Sec. 5): joint damping alpha of eq. 15.

Calibrate alpha on the in-plane pull test (bounded 1-D search), then predict with
no refit: the elastic joint (alpha = 0) on the in-plane test -- the paper's
discrepancy -- and the out-of-plane test (Fig. 20) at the calibrated alpha.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from harnesspipe.calibrate.branch import fit_alpha
from harnesspipe.calibrate.objective import l2_error, objective_key, relative_l2_error
from harnesspipe.config import ConfigError
from harnesspipe.models import branch
from harnesspipe.report import plots
from harnesspipe.stages.common import read_fit, write_csv, write_fit, write_shapes
from harnesspipe.stages.data import read_prepared

SHAPES_AT = (10.0, 25.0, 50.0)  # crosshead travels of the marker frames


def model_options(settings: dict) -> dict:
    return {k: settings[k] for k in ("properties", "geometry", "n_steps", "dt_min", "stroke", "rate")}


def with_fitted_properties(settings: dict, fits: dict[str, Path]) -> dict:
    """``settings`` with E, sigma_y, K, n of the cases in ``fits`` (case -> fit.json of eq. 13
    + simplex on that case's hi-fi virtual test) in place of the config's estimates; the
    radius stays the config's.  Sec. 5: the 38-wire CWB and the TWBs get their properties
    the way Sec. 4.3 gives the CWBs theirs."""
    props = {c: dict(v) for c, v in settings["properties"].items()}
    for case, path in fits.items():
        if case not in props:
            raise ConfigError(f"{path}: case {case!r} is not one of branch.properties {sorted(props)}")
        fitted = read_fit(path)["parameters"]
        props[case].update({k: float(fitted[k]) for k in ("E", "sigma_y", "K", "n")})
    return {**settings, "properties": props}


def _write(outdir: Path, item: str, ref, alpha: float, settings: dict, load_case: str,
           nfev: int, converged: bool, t0: float, extra: dict) -> dict:
    """Curve and shapes of the model at ``alpha`` against the prepared test ``ref``; the wall
    time is from ``t0`` (perf_counter) to the end of this run."""
    curve, shapes = branch.simulate(load_case, alpha, return_shapes=True, shape_at=SHAPES_AT,
                                    **model_options(settings))
    wall_s = time.perf_counter() - t0
    write_shapes(outdir, shapes)  # the model's x, y, z (z out of plane); the report picks the markers' axis
    F_model = np.interp(ref.grid, curve["displacement_mm"], curve["force_N"])
    path = write_fit(outdir, stage="branch", item=item, test_id=ref.test_id,
                     parameters={"alpha": alpha}, error_l2=l2_error(ref.mean, F_model),
                     error_rel=relative_l2_error(ref.mean, F_model), nfev=nfev, converged=converged,
                     wall_s=wall_s, curve=curve,
                     extra={"load_case": load_case, "properties": settings["properties"], **extra})
    plots.save(plots.fit_figure(ref, curve, title=item, label=f"Y-harness ROM, alpha = {alpha:.3g}"),
               outdir / "fit.png")
    return read_fit(path)


def calibrate(reference: Path, settings: dict, outdir: Path, damping_csv: Path) -> dict:
    """alpha from the in-plane test; writes the fit artefacts and damping.csv."""
    ref = read_prepared(reference)
    t0 = time.perf_counter()
    res = fit_alpha(ref.grid, ref.mean, bounds=tuple(settings["alpha_bounds"]),
                    xatol=settings["alpha_xatol"], load_case="inplane", log_path=Path(outdir) / "trace.h5",
                    key=objective_key(ref.grid, ref.mean, settings), **model_options(settings))
    fit = _write(Path(outdir), "in-plane pull: alpha calibrated", ref, res["alpha"], settings, "inplane",
                 res["nfev"], True, t0, {"role": "calibration"})
    write_csv(damping_csv, pd.DataFrame({"parameter": ["alpha"], "value": [res["alpha"]]}))
    return fit


def predict(reference: Path, settings: dict, outdir: Path, load_case: str, alpha: float,
            item: str, role: str) -> dict:
    """The model at a given alpha against a test, with no refit."""
    ref = read_prepared(reference)
    t0 = time.perf_counter()
    return _write(Path(outdir), item, ref, alpha, settings, load_case, 1, True, t0, {"role": role})


def read_alpha(damping_csv: Path) -> float:
    frame = pd.read_csv(damping_csv)
    return float(frame.loc[frame["parameter"] == "alpha", "value"].iloc[0])
