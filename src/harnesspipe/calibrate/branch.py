"""Calibration of the break-out joint damping alpha (Sec. 5, eq. 15) on the in-plane pull test.

The paper calibrates alpha "via a parametric study"; here a bounded 1-D search
(Brent's bounded method, scipy ``minimize_scalar``) minimises the l2 force error of
eq. 4 between the measured mean curve and the Y-harness ROM, on the measured
displacement grid.  Every evaluation (alpha, error, wall time) is kept in the trace
and, with ``log_path``, in the HDF5 evaluation log of :mod:`harnesspipe.calibrate.simplex`
(replayed on a rerun with the same ``key``).
"""
from __future__ import annotations

import time

import numpy as np
from scipy.optimize import minimize_scalar

from harnesspipe.calibrate.objective import l2_error, on_grid
from harnesspipe.calibrate.simplex import EvaluationLog
from harnesspipe.models import branch


def fit_alpha(u, F, *, bounds=(0.0, 1.0), xatol=1e-3, properties=None, load_case="inplane",
              log_path=None, key="", **model_options) -> dict:
    """Best alpha for the force curve ``(u, F)``; returns alpha, error_l2, nfev, trace.

    ``model_options`` go to :func:`harnesspipe.models.branch.simulate` (e.g. ``n_steps``,
    ``rate``, ``mesh``); the simulated curve is interpolated onto ``u``.
    """
    u, F = np.asarray(u, dtype=float), np.asarray(F, dtype=float)
    lo, hi = bounds
    if not (0.0 <= lo < hi):
        raise ValueError(f"bounds must satisfy 0 <= low < high, got {bounds}")
    if u.shape != F.shape or u.size < 2:
        raise ValueError(f"u and F must be equal-length curves, got {u.shape} and {F.shape}")
    log = EvaluationLog(log_path, ["alpha"], key)

    def error(alpha: float) -> float:
        x = np.array([alpha])
        hit = log.lookup(x)
        if hit is not None:
            log.append(x, hit[1], hit[2])
            return hit[1]
        t0 = time.perf_counter()
        curve = branch.simulate(load_case, alpha, properties, **model_options)
        err = l2_error(F, on_grid(curve["displacement_mm"], curve["force_N"], u))
        log.append(x, err, time.perf_counter() - t0)
        return err

    res = minimize_scalar(error, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
    trace = log.frame().rename(columns={"error": "error_l2"})
    return {"alpha": float(res.x), "error_l2": float(res.fun), "nfev": len(trace), "trace": trace}
