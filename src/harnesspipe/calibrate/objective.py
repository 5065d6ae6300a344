"""Force-error norms of eq. 4 and the identity of an objective."""
from __future__ import annotations

import hashlib
import json

import numpy as np


def l2_error(f_exp, f_fe) -> float:
    """||F_exp - F_FE||_2 on a common displacement grid (eq. 4)."""
    f_exp = np.asarray(f_exp, dtype=float)
    f_fe = np.asarray(f_fe, dtype=float)
    if f_exp.shape != f_fe.shape:
        raise ValueError(f"force vectors differ in length: {f_exp.shape} vs {f_fe.shape}")
    return float(np.linalg.norm(f_exp - f_fe))


def relative_l2_error(f_exp, f_fe) -> float:
    """l2 error divided by ||F_exp||_2 (a size-independent figure for reports)."""
    return l2_error(f_exp, f_fe) / max(float(np.linalg.norm(f_exp)), 1e-300)


def on_grid(u_sim, f_sim, u_grid):
    """Simulated force interpolated onto the measurement grid (NaN outside its range)."""
    return np.interp(u_grid, u_sim, f_sim, left=np.nan, right=np.nan)


def objective_key(u, F, settings) -> str:
    """Identity of an objective: its settings and reference curve (for log replay)."""
    h = hashlib.sha256(json.dumps(settings, sort_keys=True).encode())
    h.update(np.ascontiguousarray(u, dtype=float).tobytes())
    h.update(np.ascontiguousarray(F, dtype=float).tobytes())
    return h.hexdigest()[:16]
