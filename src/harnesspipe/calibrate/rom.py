"""Effective beam properties of a CWB from a three-point curve (Sec. 4.3).

eq. 13 gives E_eff and a first sigma_Y; the simplex of Sec. 3.2 (initial guess
plus 5 % per component) then fits the hardening parameters named in
``settings["rom"]["simplex_parameters"]`` -- (K, n) in the paper, (sigma_Y, K, n)
by default here (see :mod:`harnesspipe.calibrate.eq13` for why) -- of a beam
model of the same test, minimising the l2 force error of eq. 4 on the
abscissa it is given (the stage gives every measured row).

``settings`` (built from the config by the Snakemake rule):
``r_o``, ``supports``, ``mu`` (roller friction), ``three_point`` (span, overhang, deflection),
``rom`` (linear_window, yield_deflection, simplex_parameters, simplex, initial_guess),
``mesh`` (ROM resolution) and ``maxfev``.

Model-consistent E (``rom.model_consistent_E``): eq. 13 is beam theory for ideal
supports; the beam model on roller pins, sampled on the same grid, returns a
slightly different eq. 13 slope for the same E (0.1-1 %).  Because the elastic
response is linear in E, one elastic run at E_eq13 gives the exact correction
E = E_eq13^2 / E_eq13(model).  This matters: sigma_Y is weakly identified by
the curve, and a 0.6 % bias in E moves the fitted sigma_Y by tens of percent.

Simplex coordinates (``rom.simplex_space``): with ``power_law`` the simplex moves
(sigma_Y, K, n) themselves, as printed in the paper.  These are strongly
correlated along a three-point curve (a lower sigma_Y is nearly undone by a
smaller n), and Nelder-Mead then stalls in a narrow valley (measured: sigma_Y
off by 10-100 % from noise-free curves).  With ``flow_stress`` (default) it moves
the eq. 2 flow stresses s_i = sigma_Y + K eps_i^n at three plastic strains
``rom.reference_strains`` eps_0 < eps_1 < eps_2 in geometric progression
(ratio q) -- the same family of curves, mapped one to one, with

    n = ln((s_2 - s_1) / (s_1 - s_0)) / ln q,   K = (s_1 - s_0) / (eps_0^n (q^n - 1)),
    sigma_Y = s_0 - K eps_0^n,

for s_0 < s_1 < s_2 with n > 0 and sigma_Y > 0.  With sigma_Y fixed (paper's
(K, n) fit) the last two strains are used.  The initial simplex is still the
initial guess plus 5 % per coordinate, and sigma_Y, K, n are reported.

Elastoplastic window (``rom.consistent_E_model: elastoplastic``, default): eq. 13's window
(:mod:`harnesspipe.calibrate.eq13`) grows while the curve stays within three noise sigmas of
its secant line; under load-cell noise it runs into the onset of yield where that bends the
curve gradually (the coarse-taped sets, n = 0.43), the data's slope drops, and a correction
with the elastic model leaves E about two of its own standard errors low on every noisy
twin, the hardening compensating (bench/RESULTS.md, "Interval coverage of the ROM stage").
So after the simplex E is made consistent with the model *at the fitted hardening*: E is
the root of the estimating equation

    k_data = k_model(E, sigma_Y, K, n),   k the eq. 13 slope over the data's window,

together with the hardening's least squares on every row, by Gauss-Newton steps from the
simplex's point on the directions of the hardening the rows' noise resolves
(:func:`elastoplastic_window`).  Refitting the hardening fully at each E instead -- by
Gauss-Newton or by the simplex -- walks sigma_Y down the flat valley of (sigma_Y, K, n)
to its boundary on the fabric sets' shipped data (E moved by 0.1 %), where no interval
means anything: the curve does not determine that walk.
On a curve whose window ends before yield (a noise-free curve) this is the elastic
correction; E keeps eq. 13's meaning -- the initial slope -- whatever the model cannot
follow later on.  ``elastic``: the correction with the elastic model alone, before the
simplex (the previous estimator).  fit.json keeps eq. 13's own E (``E_eq13``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harnesspipe import rom
from harnesspipe.calibrate import eq13, profile, uncertainty
from harnesspipe.calibrate.hardening import flow_stresses, hardening_from_three, hardening_from_two
from harnesspipe.calibrate.objective import l2_error, objective_key
from harnesspipe.calibrate.simplex import FitResult, nelder_mead

SHAPE_DEFLECTIONS = (0.0, 10.0, 20.0, 30.0)  # bent-shape frames kept with a fit
# The literature guess of the hardening can be off by a factor of two or more; a
# bounded 1-D search on a common factor of the start coordinates first puts the
# simplex at the right level, so it does not chase it into the boundary of the
# admissible set (measured: sigma_Y -> 0 for the half-lap set without it).
START_SCALING = (0.25, 4.0)
E_TOL = 1e-6        # the elastoplastic window's steps end when no ln p moves by more than this ...
E_ITERATIONS = 10   # ... or after this many
MAX_STEP = 0.5      # ... each moving no ln p by more than this
RESOLVED = 1.0      # ... and only along directions of ln h the rows determine to this standard error


@dataclass
class RomFit:
    parameters: dict          # E, sigma_y, K, n
    E_eq13: float
    sigma_y_eq13: float
    result: FitResult         # the simplex's
    refine_runs: int = 0      # model runs of the elastoplastic window after it

    @property
    def nfev(self) -> int:
        """Model runs of the whole fit."""
        return self.result.nfev + self.refine_runs


def simulate(params: dict, settings: dict, return_shapes: bool = False):
    """ROM three-point curve for effective properties ``params`` (E, sigma_y, K, n)."""
    tp = settings["three_point"]
    return rom.three_point(E=params["E"], sigma_y=params["sigma_y"], K=params["K"], n=params["n"],
                           radius=settings["r_o"], supports=settings["supports"], span=tp["span"],
                           overhang=tp["overhang"], deflection=tp["deflection"], mu=settings["mu"],
                           return_shapes=return_shapes, shape_at=SHAPE_DEFLECTIONS,
                           **settings["mesh"])


def simulate_on(u, params: dict, settings: dict) -> np.ndarray:
    """ROM force of ``params`` on the deflection grid ``u``."""
    curve = simulate(params, settings)
    return np.interp(u, curve["deflection_mm"], curve["force_N"])


def effective_modulus(u, F, settings) -> tuple[float, float]:
    """(E used by the model, E of eq. 13); they differ only with model_consistent_E."""
    span, r_o, rs = settings["three_point"]["span"], settings["r_o"], settings["rom"]
    slope, u_lin = eq13.linear_part(u, F, span, rs["linear_window"])
    E_eq13 = eq13.modulus_from_slope(slope, span, r_o)
    if not rs["model_consistent_E"]:
        return E_eq13, E_eq13
    tp = settings["three_point"]
    elastic = rom.three_point(E=E_eq13, radius=r_o, supports=settings["supports"], span=span,
                              overhang=tp["overhang"], deflection=tp["deflection"], mu=settings["mu"],
                              elastic=True, **settings["mesh"])
    F_model = np.interp(u, elastic["deflection_mm"], elastic["force_N"])
    E_model = eq13.modulus_from_slope(eq13.slope_up_to(u, F_model, u_lin), span, r_o)
    return E_eq13 * E_eq13 / E_model, E_eq13


class Coordinates:
    """Map between the simplex coordinates and (sigma_y, K, n) (see module docstring)."""

    def __init__(self, rs: dict, sigma_y_eq13: float):
        self.fit_sigma_y = "sigma_y" in rs["simplex_parameters"]
        self.flow = rs["simplex_space"] == "flow_stress"
        strains = tuple(rs["reference_strains"])
        self.eps_ref = strains if self.fit_sigma_y else strains[1:]
        self.sigma_y = sigma_y_eq13
        if self.flow:
            self.names = [f"s_{i}" for i in range(len(self.eps_ref))]
        else:
            self.names = (["sigma_y"] if self.fit_sigma_y else []) + ["K", "n"]

    def start(self, K0, n0) -> list[float]:
        if self.flow:
            return list(flow_stresses(self.sigma_y, K0, n0, self.eps_ref))
        return ([self.sigma_y] if self.fit_sigma_y else []) + [K0, n0]

    def hardening(self, x):
        """(sigma_y, K, n) of simplex point x, or None outside the admissible set."""
        if self.flow:
            if self.fit_sigma_y:
                return hardening_from_three(tuple(x), self.eps_ref)
            return hardening_from_two(self.sigma_y, tuple(x), self.eps_ref)
        p = (*x,) if self.fit_sigma_y else (self.sigma_y, *x)
        return p if min(p) > 0.0 else None


def elastoplastic(rs: dict) -> bool:
    """Whether the fit's E takes the elastoplastic window (module docstring)."""
    return bool(rs["model_consistent_E"]) and rs["consistent_E_model"] == "elastoplastic"


def hardening_names(rs: dict) -> list[str]:
    """The parameters the ROM stage fits by least squares on the curve (the simplex's)."""
    return [k for k in ("sigma_y", "K", "n") if k in rs["simplex_parameters"]]


def simplex_at(E: float, u, F, settings: dict, start: dict, **options) -> tuple[dict, FitResult]:
    """(parameters, search) of the simplex of Sec. 3.2 on the hardening of ``settings["rom"]``
    at a given E against F(u), from the hardening of ``start`` (sigma_Y held at its value
    there when the simplex does not fit it); ``options`` to
    :func:`harnesspipe.calibrate.simplex.nelder_mead` (its xatol, fatol, restarts and the
    budget ``maxfev`` from the settings)."""
    rs = settings["rom"]
    coords = Coordinates(rs, start["sigma_y"])

    def params_of(x):
        sigma_y, K, n = coords.hardening(x)
        return {"E": E, "sigma_y": sigma_y, "K": K, "n": n}

    def objective(x):
        if coords.hardening(x) is None:
            return np.inf  # outside the admissible set: rejected
        try:
            return l2_error(F, simulate_on(u, params_of(x), settings))
        except (RuntimeError, ArithmeticError):  # failed simulation: a rejected point, logged as NaN
            return np.nan

    res = nelder_mead(objective, coords.start(start["K"], start["n"]), coords.names,
                      xatol=rs["simplex"]["xatol"], fatol=rs["simplex"]["fatol"],
                      maxfev=settings["maxfev"], restarts=rs["simplex"]["restarts"], **options)
    return params_of(res.x), res


def window_weights(u, F, settings: dict) -> np.ndarray:
    """w_i = u_i on the rows of eq. 13's window of F(u), 0 elsewhere: the slope through the
    origin over the window is w^T F / w^T u."""
    u = np.asarray(u, dtype=float)
    rs = settings["rom"]
    u_lin = eq13.linear_part(u, F, settings["three_point"]["span"], rs["linear_window"])[1]
    return np.where((u > 0.0) & (u <= u_lin), u, 0.0)


def window_row(J: np.ndarray, w: np.ndarray, P: np.ndarray | None = None) -> np.ndarray:
    """d ln E / dF of the window's estimating equation w^T (F - F(p)) = 0 with the hardening
    by least squares, linearised (J = dF / d ln p over E, then the hardening; P the hardening's
    pseudo-inverse, by default on the directions the curve determines at all):
    G = w^T Q / (w^T Q J_E), Q = I - J_h P.  For a model elastic over the window
    (w^T J_h = 0, J_E = F) it is eq. 13's own gradient
    (:func:`harnesspipe.calibrate.eq13.log_modulus_gradient`)."""
    J_h = J[:, 1:]
    if P is None:
        P = uncertainty.determined_pseudo_inverse(J_h)
    wQ = w - (w @ J_h) @ P if J_h.shape[1] else w
    return wQ / float(wQ @ J[:, 0])


def elastoplastic_window(u, F, params: dict, settings: dict) -> tuple[dict, int]:
    """(parameters, model runs): E from the data's eq. 13 slope with the model at the
    hardening, the hardening by least squares (module docstring), from the simplex's
    ``params``: Gauss-Newton steps in ln p on the joint equations, d_E = G r
    (:func:`window_row`), d_h = P (r - J_E d_E), r = F - F(p), P the hardening's
    pseudo-inverse on the directions of ln h the rows' noise resolves to a standard error
    below RESOLVED (:func:`harnesspipe.calibrate.uncertainty.determined_pseudo_inverse`),
    no ln p moved by more than MAX_STEP, until none moves by more than E_TOL.  The steps so
    leave the flat valley of (sigma_Y, K, n) -- which the data do not determine -- where the
    simplex left it.  ``params`` themselves where the data's slope already matches the
    model's to E_TOL (a window that ends before yield: the elastic correction was exact) or
    the model fails on the way."""
    u, F = np.asarray(u, dtype=float), np.asarray(F, dtype=float)
    w = window_weights(u, F, settings)
    names = ["E", *hardening_names(settings["rom"])]
    noise = eq13.noise_level(F)
    runs = 0

    def force(p: dict) -> np.ndarray:
        nonlocal runs
        runs += 1
        return simulate_on(u, p, settings)

    p = dict(params)
    try:
        r = F - force(p)
        if abs(w @ r) < E_TOL * abs(w @ F):
            return p, runs
        for _ in range(E_ITERATIONS):
            J = uncertainty.log_sensitivities(force, p, names)
            P = uncertainty.determined_pseudo_inverse(J[:, 1:], noise / RESOLVED)
            d_E = float(window_row(J, w, P) @ r)
            d = np.concatenate([[d_E], P @ (r - J[:, 0] * d_E)])
            d *= min(1.0, MAX_STEP / max(np.abs(d).max(), 1e-300))
            p = {**p, **{k: p[k] * float(np.exp(dk)) for k, dk in zip(names, d)}}
            r = F - force(p)
            if np.abs(d).max() < E_TOL:
                break
    except (RuntimeError, ArithmeticError, ValueError):
        return dict(params), runs
    return (p, runs) if np.all(np.isfinite(r)) else (dict(params), runs)


def elastoplastic_log_modulus_gradient(u, F, params: dict, settings: dict) -> np.ndarray:
    """d ln E / dF_i of the elastoplastic window's E on the rows of F(u), the window held
    (:func:`window_row` at ``params``)."""
    u, F = np.asarray(u, dtype=float), np.asarray(F, dtype=float)
    names = ["E", *hardening_names(settings["rom"])]
    J = uncertainty.log_sensitivities(lambda p: simulate_on(u, p, settings), params, names)
    return window_row(J, window_weights(u, F, settings))


def fit(u, F, settings: dict, log_path=None) -> RomFit:
    """Calibrate (E, sigma_Y, K, n) of the effective beam against the curve F(u)."""
    u, F = np.asarray(u, dtype=float), np.asarray(F, dtype=float)
    span, r_o, rs = settings["three_point"]["span"], settings["r_o"], settings["rom"]
    E, E_eq13 = effective_modulus(u, F, settings)
    sigma_y_eq13 = eq13.yield_stress(u, F, span, r_o, rs["yield_deflection"])
    start = {"sigma_y": sigma_y_eq13, **rs["initial_guess"]}
    params, res = simplex_at(E, u, F, settings, start, start_scaling=START_SCALING,
                             log_path=log_path, key=objective_key(u, F, settings))
    if not elastoplastic(rs):
        return RomFit(params, E_eq13, sigma_y_eq13, res)
    params, runs = elastoplastic_window(u, F, params, settings)
    return RomFit(params, E_eq13, sigma_y_eq13, res, runs)


def fit_uncertainty(u, replicates, params: dict, settings: dict) -> dict:
    """fit.json's uncertainty entries of a fit ``params`` to the mean of the measured
    ``replicates`` (n x N forces on the rows ``u``;
    :func:`harnesspipe.calibrate.uncertainty.fit_summary`): the replicate sandwich with E
    (and sigma_Y when the simplex does not fit it) by eq. 13 on each replicate -- E with
    the fit's model-consistent factor -- and the simplex's parameters by least squares;
    the Fisher standard errors (of this estimator: E from the mean's rows in eq. 13's window
    -- by eq. 13, or by the elastoplastic window's estimating equation
    (:func:`elastoplastic_log_modulus_gradient`) --, sigma_Y when not fitted by eq. 13, the
    others fitted to what they leave),
    correlations and chi-square of all four; ``interval95``
    (:func:`harnesspipe.calibrate.profile.fit_intervals`: profile-likelihood intervals of the
    poorly determined simplex parameters, E held at eq. 13's value).  All None
    without replicates (a hi-fi reference is one deterministic curve: its residual is
    model error, not noise)."""
    if replicates is None:
        return dict.fromkeys(("standard_error", "standard_error_dof", "replicate_correlation",
                              "fisher", "chi_square", "band_N", "band_replicate_N",
                              "interval95"))
    u, R = np.asarray(u, dtype=float), np.atleast_2d(np.asarray(replicates, dtype=float))
    span, r_o, rs = settings["three_point"]["span"], settings["r_o"], settings["rom"]
    F_mean = R.mean(axis=0)
    fitted = hardening_names(rs)
    closed_form = {}
    if elastoplastic(rs):
        gradients = {"E": elastoplastic_log_modulus_gradient(u, F_mean, params, settings)}
    else:
        gradients = {"E": eq13.log_modulus_gradient(u, F_mean, span, rs["linear_window"])}
    if "sigma_y" not in rs["simplex_parameters"]:
        gradients["sigma_y"] = eq13.log_yield_stress_gradient(u, F_mean, span, rs["yield_deflection"])
        if len(R) >= 2:
            closed_form["sigma_y"] = [eq13.yield_stress(u, Fk, span, r_o, rs["yield_deflection"])
                                      for Fk in R]
    if len(R) >= 2:
        def eq13_modulus(force):
            return eq13.effective_modulus(u, force, span, r_o, rs["linear_window"])
        factor = params["E"] / eq13_modulus(F_mean)
        closed_form["E"] = [factor * eq13_modulus(Fk) for Fk in R]

    def curve(p: dict) -> np.ndarray:
        return simulate_on(u, p, settings)
    summary = uncertainty.fit_summary(curve, params, fitted, u, R, closed_form, gradients)
    summary["interval95"] = profile.fit_intervals(curve, params, fitted, u, R, summary["fisher"])
    return summary
