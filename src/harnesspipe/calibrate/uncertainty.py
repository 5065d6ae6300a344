"""How well a force curve determines the parameters fitted to it.

The asymptotic (Gauss-Newton) covariance of a least-squares estimate: near the
fit p*, the model curve is linear in the parameters, F(p) ~ F(p*) + J d with
d = ln p - ln p* and J_ij = dF_i / d ln p_j, and with independent force errors
of variance s^2 per grid point

    Cov(ln p) = s^2 (J^T J)^-1 .

With s^2 the known variance of independent Gaussian noise, evaluated at the
truth, this is the Cramer-Rao bound of the linearised problem: no unbiased
estimator from the same curve does better.  With s^2 = ||r||^2 / (N - m) (r the
fit residual, N points, m parameters) it is the usual standard error of a
nonlinear regression on one noisy curve.

A fit to the mean of n >= 2 replicate curves: errors correlated along the curve
(specimen scatter) usually make the spread larger than that, so the replicates
themselves are used ("sandwich"): each replicate's deviation from the mean is
mapped to a parameter deviation, and

    Cov(ln p) = sum_k d_k d_k^T / (n (n - 1)) ,

the covariance of the mean's estimate, on n - 1 degrees of freedom (three
replicates: two, a rough figure).  Parameters the calibration takes from a closed
form (eq. 3, eq. 13) are evaluated on each replicate (their d_k directly); the
least-squares ones take d_k = (J^T J)^-1 J^T (F_k - F_mean - J_c d_c,k), i.e.
what is left after the closed-form parameters have moved the curve.

Standard errors are in ln p: 0.05 means "+-5 %"; above ~0.3 the linear picture is
rough, and above 1 (a factor e either way) the parameter is simply not determined
by the curve.

Fisher standard errors of a fit to the mean of n specimens on their measured rows
(:func:`fit_statistics`): Cov(ln p) = s_mean^2 (J^T J)^-1 with the variance of the
mean's row noise s_mean^2 = sum_k s_k^2 / n^2, and each specimen's load-cell noise
s_k^2 read off its own rows (:func:`row_noise_variance`), not off the fit.  The fit
residual would fold the model's misfit into the noise (and a chi-square against it
is 1 by construction); the specimens' scatter about their mean curve holds their
parameter scatter, which is smooth and correlated along the curve, not white noise:
that is what the replicate sandwich above is for.  The Fisher figure is therefore the
uncertainty of the parameters *of the tested specimens* (the load-cell noise alone),
the sandwich that of the population they are drawn from.  The chi-square of the mean's
residual against s_mean^2 (:func:`chi_square`) says whether the model reproduces the
mean curve to within the noise.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import stats

LOG_STEP = 0.01       # central-difference step in ln p
SINGULAR = 1e-7       # singular value of J below this times the largest: direction not determined
OUTLIER = 4.0        # row-noise estimate: chord residuals beyond this many robust scales are kinks
CHI2_ALPHA = 0.01    # chi-square check: a residual this unlikely under the noise alone fails
BOUNDARY = 1e-6       # a column of J this small against the largest: the parameter sits at ~0
SHARE = 1e-3          # a parameter with a larger share in such a direction is not determined either


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


def _pseudo_inverse(J: np.ndarray, floor: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(J^T J)^-1 J^T on the directions the curve determines (SVD of J: singular values
    below SINGULAR times the largest, or below ``floor``, are left out), V and the mask of
    the kept directions."""
    U, sv, Vt = np.linalg.svd(J, full_matrices=False)
    keep = sv > max(SINGULAR * sv.max(), floor)
    return (Vt[keep].T / sv[keep]) @ U[:, keep].T, Vt.T, keep


def determined_pseudo_inverse(J: np.ndarray, floor: float = 0.0) -> np.ndarray:
    """J^+ on the directions the curve determines (those :func:`estimator_map` keeps), and
    of those only the ones with a singular value above ``floor``: with J = dF / d ln p and
    row noise s, floor = s / c keeps the directions of ln p the rows determine to a standard
    error below c."""
    return _pseudo_inverse(J, floor)[0]


def _blank_undetermined(cov: np.ndarray, V: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Infinite variance for every parameter with a share in the undetermined subspace (the
    norm of its row of V over those directions above SHARE; smaller ones are round-off of a
    direction that is, in exact arithmetic, the axis of another parameter)."""
    touched = np.linalg.norm(V[:, ~keep], axis=1) > SHARE
    cov = cov.copy()
    cov[touched, :] = np.inf
    cov[:, touched] = np.inf
    return cov


def log_covariance(J: np.ndarray, variance: float) -> np.ndarray:
    """``variance * (J^T J)^-1``; directions the curve does not see get an infinite variance."""
    P, V, keep = _pseudo_inverse(J)
    cov = variance * P @ P.T
    return _blank_undetermined(0.5 * (cov + cov.T), V, keep)   # symmetric to the last digit


def prediction_band(J: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """Standard deviation of the fitted curve, Var F_i = J_i C J_i^T (delta method: the
    parameter covariance C of ln p propagated through J_ij = dF_i / d ln p_j)."""
    J = np.atleast_2d(np.asarray(J, dtype=float))
    return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", J, np.asarray(cov, dtype=float), J), 0.0))


def flow_stress_band(params: dict, names: list[str], cov: np.ndarray, eps_p) -> tuple[np.ndarray, np.ndarray]:
    """(sigma, its standard deviation) of eq. 2, sigma = sigma_Y + K eps_p^n, at ``eps_p``, by
    the delta method from Cov(ln p) over ``names``: Var sigma = g C g^T with the gradient
    in ln p  g = (d/d ln sigma_Y, d/d ln K, d/d ln n) = (sigma_Y, K eps^n, K eps^n n ln eps)
    (zero for the other names, e.g. E)."""
    eps = np.asarray(eps_p, dtype=float)
    hard = params["K"] * eps ** params["n"]
    grad = {"sigma_y": np.full_like(eps, params["sigma_y"]), "K": hard,
            "n": hard * params["n"] * np.log(eps)}
    G = np.column_stack([grad.get(k, np.zeros_like(eps)) for k in names])
    return params["sigma_y"] + hard, prediction_band(G, cov)


def residual_variance(residual: np.ndarray, n_parameters: int) -> float:
    """s^2 = ||r||^2 / (N - m), the per-point error variance left by a fit."""
    r = np.asarray(residual, dtype=float)
    dof = r.size - n_parameters
    if dof <= 0:
        raise ValueError(f"{r.size} points cannot give an error variance for {n_parameters} parameters")
    return float(r @ r) / dof


def _replicate_deviations(J: np.ndarray, replicates: np.ndarray,
                          closed_form: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(D, V, keep): D (n x m) each replicate's deviation from the mean in ln p -- the
    closed-form parameters' own (first c columns of ``J``), the least-squares map of what
    they leave for the rest -- and V, keep of the least-squares part's SVD."""
    R = np.asarray(replicates, dtype=float)
    if R.ndim != 2 or R.shape[0] < 2 or R.shape[1] != J.shape[0]:
        raise ValueError(f"replicates must be (n >= 2, {J.shape[0]}), got {R.shape}")
    C = np.zeros((R.shape[0], 0)) if closed_form is None else np.asarray(closed_form, dtype=float)
    d_c = C - C.mean(axis=0)
    c = d_c.shape[1]
    dev = (R - R.mean(axis=0)) - d_c @ J[:, :c].T       # what the fitted parameters must explain
    P, V, keep = _pseudo_inverse(J[:, c:])
    return np.hstack([d_c, dev @ P.T]), V, keep


def replicate_log_covariance(J: np.ndarray, replicates: np.ndarray,
                             closed_form: np.ndarray | None = None) -> np.ndarray:
    """Sandwich covariance of ln p for a fit to the mean of ``replicates`` (n x N), n >= 2.

    ``closed_form`` (n x c): ln of the parameters the calibration takes from a closed form,
    evaluated on each replicate; they are the first c columns of ``J`` and of the result."""
    D, V, keep = _replicate_deviations(J, replicates, closed_form)
    n, c = D.shape[0], D.shape[1] - V.shape[0]
    cov = D.T @ D / (n * (n - 1))
    cov[c:, c:] = _blank_undetermined(cov[c:, c:], V, keep)
    return cov


def replicate_band(J: np.ndarray, replicates: np.ndarray,
                   closed_form: np.ndarray | None = None) -> np.ndarray:
    """Standard deviation of the fitted curve under the replicate sandwich (arguments as
    :func:`replicate_log_covariance`): Var F_i = J_i C J_i^T with C = sum_k d_k d_k^T /
    (n (n - 1)) on the directions the curve determines (one it does not see does not move
    the curve), i.e. sum_k (J_i d_k)^2 / (n (n - 1)).  When the replicates' deviations lie
    in the model's tangent space, J d_k is the deviation itself and this is the standard
    error of the replicates' mean force at each row."""
    D = _replicate_deviations(J, replicates, closed_form)[0]
    n = D.shape[0]
    return np.sqrt(np.sum((D @ J.T) ** 2, axis=0) / (n * (n - 1)))


def _closed_form_logs(closed_form: dict, names: list[str]) -> np.ndarray | None:
    """n x c: ln of each closed-form parameter of ``names`` on each replicate (None if none)."""
    return np.log(np.column_stack([closed_form[n] for n in names])) if names else None


def _fit_covariance(curve, params: dict, fitted: list[str], reference, replicates,
                    closed_form: dict | None):
    """(names, Cov(ln p), J, ln of the closed-form parameters or None) of
    :func:`fit_covariance`; J None on a boundary (covariance all infinite); None on failure."""
    closed_form = closed_form or {}
    multi = replicates is not None and len(replicates) >= 2
    cf_names = list(closed_form) if multi else []
    names = cf_names + [n for n in fitted if n not in cf_names]
    try:
        J = log_sensitivities(curve, params, names)
    except (RuntimeError, ArithmeticError):
        return None
    if not np.all(np.isfinite(J)):
        return None
    norms = np.linalg.norm(J, axis=0)
    if norms.min() < BOUNDARY * norms.max():
        return names, np.full((len(names), len(names)), np.inf), None, None
    if multi:
        C = _closed_form_logs(closed_form, cf_names)
        return names, replicate_log_covariance(J, replicates, C), J, C
    try:
        residual = np.asarray(reference, dtype=float) - np.asarray(curve(params))
        return names, log_covariance(J, residual_variance(residual, len(names))), J, None
    except (RuntimeError, ArithmeticError, ValueError):
        return None


def fit_covariance(curve: Callable[[dict], np.ndarray], params: dict, fitted: list[str],
                   reference: np.ndarray, replicates: np.ndarray | None = None,
                   closed_form: dict | None = None) -> tuple[list[str], np.ndarray] | None:
    """(names, Cov(ln p)) behind :func:`fit_standard_errors` (same arguments and cases; a fit
    on a boundary gives an all-infinite covariance)."""
    found = _fit_covariance(curve, params, fitted, reference, replicates, closed_form)
    return None if found is None else found[:2]


def fit_standard_errors(curve: Callable[[dict], np.ndarray], params: dict, fitted: list[str],
                        reference: np.ndarray, replicates: np.ndarray | None = None,
                        closed_form: dict | None = None) -> dict | None:
    """Standard errors of ln p of a calibration at ``params`` (None: not determined).

    ``fitted``: the parameters found by least squares on the curve ``reference``;
    ``closed_form``: name -> value on each replicate, for the parameters taken from a closed
    form (eq. 3, eq. 13).  With two or more ``replicates`` (whose mean ``reference`` is,
    on the same grid) the sandwich form, else the fit residual of the single curve (all of
    ``fitted``; closed-form parameters then get none).  ``curve(p)`` returns the model
    force on the reference grid.

    A fit on the boundary of the admissible set (a parameter driven to ~0, whose ln p no
    longer moves the curve) has no linearised standard errors: all are None.  When a
    perturbed simulation fails (RuntimeError, ArithmeticError) or returns non-finite
    forces, or a single curve has no more points than parameters, there are no errors at
    all: the result is None.  Their degrees of freedom: :func:`error_dof`."""
    found = fit_covariance(curve, params, fitted, reference, replicates, closed_form)
    if found is None:
        return None
    names, cov = found
    return dict(zip(names, _finite_or_none(np.sqrt(np.diag(cov)))))


def error_dof(n_points: int, fitted: list[str], replicates: np.ndarray | None = None) -> int:
    """Degrees of freedom of the errors of :func:`fit_standard_errors`: n - 1 for the mean of
    n >= 2 replicates, else the single curve's points less its fitted parameters."""
    if replicates is not None and len(replicates) >= 2:
        return len(replicates) - 1
    return n_points - len(fitted)


def row_noise_variance(u, F) -> float:
    """Variance of the independent noise on the rows of one measured curve F(u).

    Each interior row against the chord of its neighbours (spacings h1, h2):
    e_i = F_i - (h2 F_(i-1) + h1 F_(i+1)) / (h1 + h2) has variance
    s^2 (1 + (h1^2 + h2^2) / (h1 + h2)^2) for noise of variance s^2 (3/2 s^2 on a
    uniform grid), while a smooth curve leaves only O(h^2 F'').  The normalised e_i are
    first scaled robustly (median |e| / 0.6745, the normal's median absolute value); those
    beyond OUTLIER times that scale -- rows at a kink of the curve (yield, contact) -- are
    left out, and s^2 is the mean square of the rest (about twice as efficient as the
    median alone: ~5 % in s from 600 rows)."""
    u, F = np.asarray(u, dtype=float), np.asarray(F, dtype=float)
    if u.shape != F.shape or u.size < 5:
        raise ValueError(f"need matching u and F with at least 5 rows, got {u.shape} and {F.shape}")
    h1, h2 = np.diff(u)[:-1], np.diff(u)[1:]
    if np.any(h1 <= 0.0) or np.any(h2 <= 0.0):
        raise ValueError("the rows' abscissa must increase strictly")
    e = (F[1:-1] - (h2 * F[:-2] + h1 * F[2:]) / (h1 + h2)) / np.sqrt(1.0 + (h1**2 + h2**2) / (h1 + h2) ** 2)
    scale = np.median(np.abs(e)) / stats.norm.ppf(0.75)
    return float(np.mean(e[np.abs(e) <= OUTLIER * scale] ** 2))


def chi_square(residual, variance: float, n_parameters: int, alpha: float = CHI2_ALPHA) -> dict:
    """chi^2 = ||r||^2 / s^2 of a fit residual r against the noise variance s^2, on
    N - m degrees of freedom: chi2, dof, chi2_per_dof, p_value (probability of a
    larger chi^2 from the noise alone) and pass (p_value >= alpha)."""
    r = np.asarray(residual, dtype=float)
    dof = r.size - n_parameters
    if dof <= 0 or not variance > 0.0:
        raise ValueError(f"no chi-square for {r.size} rows, {n_parameters} parameters, "
                         f"noise variance {variance}")
    chi2 = float(r @ r) / variance
    p = float(stats.chi2.sf(chi2, dof))
    return {"chi2": chi2, "dof": int(dof), "chi2_per_dof": chi2 / dof, "p_value": p,
            "pass": bool(p >= alpha)}


def correlation(cov: np.ndarray) -> list[list[float | None]]:
    """Correlation matrix of a covariance (None where a variance is infinite or zero)."""
    sd = np.sqrt(np.diag(cov))
    ok = np.isfinite(sd) & (sd > 0.0)
    return [[float(cov[i, j] / (sd[i] * sd[j])) if ok[i] and ok[j] else None
             for j in range(len(sd))] for i in range(len(sd))]


def _finite_or_none(values) -> list[float | None]:
    return [float(v) if np.isfinite(v) else None for v in values]


def estimator_map(J: np.ndarray, names: list[str], gradients: dict | None = None):
    """(M, touched): the linearised estimator d ln p = M e (m x N) of the parameters ``names``
    for a small change e of the fitted curve's rows (J = dF / d ln p over ``names``), and the
    mask of the parameters the curve does not determine.  Least squares for all:
    M = (J^T J)^+ J^T.  A parameter in ``gradients`` (name -> d ln p / dF on the rows) is
    taken from a closed form (eq. 13): its row of M is that gradient, and the least-squares
    ones fit what it leaves, M_f = (J_f^T J_f)^+ J_f^T (I - J_c G).  Cov(ln p) = s^2 M M^T
    for rows with independent noise of variance s^2."""
    gradients = gradients or {}
    closed = np.array([n in gradients for n in names])
    G = np.array([gradients[n] for n in names if n in gradients]).reshape(-1, J.shape[0])
    P, V, keep = _pseudo_inverse(J[:, ~closed])
    M = np.zeros((len(names), J.shape[0]))
    M[closed] = G
    M[~closed] = P - (P @ J[:, closed]) @ G
    touched = np.zeros(len(names), dtype=bool)
    touched[~closed] = np.linalg.norm(V[:, ~keep], axis=1) > SHARE
    return M, touched


def fit_statistics(curve: Callable[[dict], np.ndarray], params: dict, names: list[str],
                   u, replicates, gradients: dict | None = None) -> dict | None:
    """Fisher standard errors, correlation and chi-square of a fit ``params`` to the mean of
    ``replicates`` (n x N forces on the measured rows ``u``); ``curve(p)``: the model's force
    on ``u``; ``names``: every parameter the data set, by least squares or, those in
    ``gradients`` (name -> d ln p / dF on the rows of the mean), by a closed form: the
    covariance is that of the estimator (:func:`estimator_map`): s_mean^2 M M^T.

    Returns {"noise_sigma_N": s of one specimen's rows (rms over the specimens),
    "names", "standard_error": {name: SE of ln p or None}, "correlation": matrix,
    "chi_square": :func:`chi_square` of the mean's residual, "band_N": the standard deviation
    of the fitted curve on ``u`` (:func:`prediction_band` with the covariance on the directions
    the curve determines: an undetermined one does not move the curve)} or None when a perturbed
    simulation fails or the fit sits on a boundary (as :func:`fit_standard_errors`)."""
    R = np.atleast_2d(np.asarray(replicates, dtype=float))
    if R.shape[1] != np.size(u):
        raise ValueError(f"replicates must be (n, {np.size(u)}), got {R.shape}")
    s2 = np.array([row_noise_variance(u, Fk) for Fk in R])
    variance = float(s2.sum()) / R.shape[0] ** 2
    try:
        J = log_sensitivities(curve, params, names)
        residual = R.mean(axis=0) - np.asarray(curve(params))
    except (RuntimeError, ArithmeticError):
        return None
    if not (np.all(np.isfinite(J)) and np.all(np.isfinite(residual))):
        return None
    norms = np.linalg.norm(J, axis=0)
    if norms.min() < BOUNDARY * norms.max():
        return None
    M, touched = estimator_map(J, list(names), gradients)
    cov = variance * M @ M.T
    cov = 0.5 * (cov + cov.T)                     # symmetric to the last digit
    band = prediction_band(J, cov)                # on the determined directions: finite
    cov[touched, :] = np.inf
    cov[:, touched] = np.inf
    return {"noise_sigma_N": float(np.sqrt(s2.mean())), "names": list(names), "band_N": band,
            "standard_error": dict(zip(names, _finite_or_none(np.sqrt(np.diag(cov))))),
            "correlation": correlation(cov),
            "chi_square": chi_square(residual, variance, len(names))}


def fit_summary(curve: Callable[[dict], np.ndarray], params: dict, fitted: list[str], u,
                replicates, closed_form: dict | None = None, gradients: dict | None = None) -> dict:
    """Everything fit.json says about the uncertainty of a fit ``params`` to the mean of
    ``replicates`` (n x N forces on the measured rows ``u``; ``curve(p)``: model force on u):

    * ``standard_error``, ``standard_error_dof``, ``replicate_correlation``: the replicate
      sandwich (:func:`fit_covariance`; ``fitted`` by least squares, ``closed_form`` name ->
      value on each replicate), or the single curve's residual;
    * ``fisher``, ``chi_square``: :func:`fit_statistics` over every parameter in ``params``
      (``gradients``: those of the closed-form ones on the rows of the mean);
    * ``band_N``: the Fisher standard deviation of the fitted curve on ``u``, and
      ``band_replicate_N`` that of the replicate sandwich (:func:`replicate_band`; None
      without replicates or on a boundary): arrays, for the stage to put beside its curve,
      not into fit.json.
    Entries that cannot be computed are None."""
    R = np.atleast_2d(np.asarray(replicates, dtype=float))
    reps = R if len(R) >= 2 else None
    found = _fit_covariance(curve, params, fitted, R.mean(axis=0), reps, closed_form)
    stats_ = fit_statistics(curve, params, list(params), u, R, gradients)
    out = {"standard_error": None, "standard_error_dof": error_dof(R.shape[1], fitted, reps),
           "replicate_correlation": None, "fisher": None, "chi_square": None, "band_N": None,
           "band_replicate_N": None}
    if found is not None:
        names, cov, J, C = found
        out["standard_error"] = dict(zip(names, _finite_or_none(np.sqrt(np.diag(cov)))))
        out["replicate_correlation"] = {"names": names, "matrix": correlation(cov)}
        if reps is not None and J is not None:
            out["band_replicate_N"] = replicate_band(J, reps, C)
    if stats_ is not None:
        out["chi_square"] = stats_.pop("chi_square")
        out["band_N"] = stats_.pop("band_N")
        out["fisher"] = stats_
    return out


Z95 = float(stats.norm.ppf(0.975))   # half-width of a 95 % band in standard deviations
FLOW_POINTS = 25                      # plastic strains of fit.json's flow-stress band


def fisher_covariance(fisher: dict | None) -> np.ndarray | None:
    """Cov(ln p) of fit.json's ``fisher`` entry, C_jk = se_j se_k corr_jk (None if any
    standard error or correlation is missing: a parameter the curve does not determine)."""
    if not fisher:
        return None
    se = [fisher["standard_error"].get(k) for k in fisher["names"]]
    corr = fisher["correlation"]
    if any(v is None for v in se) or any(c is None for row in corr for c in row):
        return None
    se = np.asarray(se, dtype=float)
    return np.asarray(corr, dtype=float) * np.outer(se, se)


def curve_bands(summary: dict, params: dict, u, curve, strains) -> tuple[object, dict]:
    """The report's bands of a fit, from :func:`fit_summary`'s ``summary`` (its ``band_N`` and
    ``band_replicate_N`` on the rows ``u`` are popped): ``curve`` (displacement_mm, force_N)
    with the columns

    * ``band_N``: the Fisher 95 % half-width Z95 sd(F) (load-cell noise: the tested
      specimens' curve),
    * ``band_replicate_N``: the replicate sandwich's 95 % half-width t sd(F), t Student's
      quantile on ``standard_error_dof`` (4.30 for three specimens: the population's mean
      curve; the spread of one new specimen is sqrt(n + 1) times wider),

    interpolated from the rows onto the curve's grid (NaN outside the rows or where the
    summary has none), and fit.json's ``flow_stress`` {eps_p, sigma, band}: eq. 2 and its
    95 % half-width (:func:`flow_stress_band` with :func:`fisher_covariance`; band None when
    that is missing) at FLOW_POINTS plastic strains spaced geometrically over ``strains``'
    span.  No model runs: J is the one :func:`fit_statistics` and the sandwich computed."""
    curve = curve.copy()
    x = np.asarray(curve["displacement_mm"], dtype=float)
    dof = summary.get("standard_error_dof")
    quantiles = {"band_N": Z95,
                 "band_replicate_N": float(stats.t.ppf(0.975, dof)) if dof else np.nan}
    for column, q in quantiles.items():
        sd = summary.pop(column, None)
        curve[column] = (np.full(x.size, np.nan) if sd is None
                         else q * np.interp(x, u, sd, left=np.nan, right=np.nan))
    eps = np.geomspace(min(strains), max(strains), FLOW_POINTS)
    fisher = summary.get("fisher")
    cov = fisher_covariance(fisher)
    names = fisher["names"] if fisher else ["sigma_y", "K", "n"]
    sigma, sd = flow_stress_band(params, names, np.zeros((len(names),) * 2) if cov is None else cov, eps)
    flow = {"eps_p": [float(f"{e:.4g}") for e in eps], "sigma": [float(f"{s:.6g}") for s in sigma],
            "band": None if cov is None else [float(f"{Z95 * d:.4g}") for d in sd]}
    return curve, flow
