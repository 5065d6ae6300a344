"""How well a force curve determines the parameters fitted to it.

The asymptotic (Gauss-Newton) covariance of a least-squares estimate: near the
fit p*, the model curve is linear in the parameters, F(p) ~ F(p*) + J d with
d = ln p - ln p* and J_ij = dF_i / d ln p_j, and with independent force errors
of variance s^2 per grid point

    Cov(ln p) = s^2 (J^T J)^-1 .

With s^2 the known noise variance this is the Cramer-Rao bound: no unbiased
estimator from the same curve does better.  With s^2 = ||r||^2 / (N - m) (r the
fit residual, N points, m parameters) it is the usual standard error of a
nonlinear regression.  Errors correlated along the curve (specimen scatter in a
mean of a few specimens) make the true spread larger than this figure; with
n >= 2 replicate curves the sandwich form carries them: each replicate's
deviation from the mean is mapped to a parameter deviation by the linearised
least-squares solution d_k = (J^T J)^-1 J^T (F_k - F_mean), and

    Cov(ln p) = sum_k d_k d_k^T / (n (n - 1))

is the covariance of the mean's estimate (few replicates give a rough figure:
with three, it rests on two degrees of freedom).

Standard errors are given in ln p: 0.05 means "+-5 %"; above ~0.3 the linear
picture no longer holds and the parameter is simply not determined by the curve.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

LOG_STEP = 0.01       # central-difference step in ln p
SINGULAR = 1e-14      # (J^T J) eigenvalue below this times the largest: direction not determined
BOUNDARY = 1e-6      # a column of J this small against the largest: the parameter sits at ~0
SHARE = 1e-3          # a parameter with a larger eigenvector component in such a direction is too


def log_sensitivities(curve: Callable[[dict], np.ndarray], params: dict, names: list[str],
                      h: float = LOG_STEP) -> np.ndarray:
    """J (N x m): central differences of ``curve(params)`` in ln p of each name in ``names``."""
    columns = []
    for name in names:
        up, down = dict(params), dict(params)
        up[name] = params[name] * np.exp(h)
        down[name] = params[name] * np.exp(-h)
        columns.append((np.asarray(curve(up)) - np.asarray(curve(down))) / (2.0 * h))
    return np.column_stack(columns)


def _undetermined(JtJ: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eigen-decomposition of J^T J and the mask of the directions the curve determines."""
    lam, V = np.linalg.eigh(JtJ)
    return lam, V, lam > SINGULAR * max(lam.max(), 0.0)


def _blank_undetermined(cov: np.ndarray, V: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Infinite variance for every parameter with a share in an undetermined direction (an
    eigenvector component above SHARE; smaller ones are round-off of a direction that is, in
    exact arithmetic, the axis of another parameter)."""
    touched = np.any(np.abs(V[:, ~keep]) > SHARE, axis=1)
    cov = cov.copy()
    cov[touched, :] = np.inf
    cov[:, touched] = np.inf
    return cov


def log_covariance(J: np.ndarray, variance: float) -> np.ndarray:
    """``variance * (J^T J)^-1``; directions the curve does not see get an infinite variance."""
    lam, V, keep = _undetermined(J.T @ J)
    cov = variance * (V[:, keep] / lam[keep]) @ V[:, keep].T
    return _blank_undetermined(cov, V, keep)


def residual_variance(residual: np.ndarray, n_parameters: int) -> float:
    """s^2 = ||r||^2 / (N - m), the per-point error variance left by a fit."""
    r = np.asarray(residual, dtype=float)
    dof = r.size - n_parameters
    if dof <= 0:
        raise ValueError(f"{r.size} points cannot give an error variance for {n_parameters} parameters")
    return float(r @ r) / dof


def replicate_log_covariance(J: np.ndarray, replicates: np.ndarray) -> np.ndarray:
    """Sandwich covariance of ln p for a fit to the mean of ``replicates`` (n x N), n >= 2."""
    R = np.asarray(replicates, dtype=float)
    if R.ndim != 2 or R.shape[0] < 2 or R.shape[1] != J.shape[0]:
        raise ValueError(f"replicates must be (n >= 2, {J.shape[0]}), got {R.shape}")
    lam, V, keep = _undetermined(J.T @ J)
    D = (V[:, keep] / lam[keep]) @ V[:, keep].T @ J.T @ (R - R.mean(axis=0)).T
    return _blank_undetermined(D @ D.T / (R.shape[0] * (R.shape[0] - 1)), V, keep)


def fit_standard_errors(curve: Callable[[dict], np.ndarray], params: dict, names: list[str],
                        reference: np.ndarray, replicates: np.ndarray | None = None) -> dict | None:
    """Standard errors of ln p of the parameters ``names`` fitted at ``params`` to the curve
    ``reference``: from the replicates' scatter (sandwich) when there are two or more, from
    the fit residual otherwise.  ``curve(p)`` returns the model force on the reference grid.

    A fit on the boundary of the admissible set (a parameter driven to ~0, whose ln p no
    longer moves the curve) has no linearised standard errors: all are infinite.  When a
    perturbed simulation fails (RuntimeError, ArithmeticError), there are none: None."""
    try:
        J = log_sensitivities(curve, params, names)
    except (RuntimeError, ArithmeticError):
        return None
    norms = np.linalg.norm(J, axis=0)
    if norms.min() < BOUNDARY * norms.max():
        return dict.fromkeys(names, float("inf"))
    if replicates is not None and len(replicates) >= 2:
        cov = replicate_log_covariance(J, replicates)
    else:
        residual = np.asarray(reference, dtype=float) - np.asarray(curve(params))
        cov = log_covariance(J, residual_variance(residual, len(names)))
    return {name: float(np.sqrt(v)) for name, v in zip(names, np.diag(cov))}
