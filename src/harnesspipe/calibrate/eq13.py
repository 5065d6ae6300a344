"""Closed forms of eq. 13: effective modulus and yield stress from a three-point curve.

    E_eff = F L^3 / (48 u I),     sigma_Y = F_2% L / (pi r_o^3),     I = pi r_o^4 / 4

L is the support span, r_o the bundle's outer radius and F_2% the force at
u = 0.02 L (Sec. 4.3).

How the linear part is chosen (E_eff): the slope F/u is the least-squares fit
of a line through the origin (the small-deflection elastic response of the
three-point test) to the points with 0 < u <= u_lin.  The window starts at
``window`` * L (1 % of the span by default) and grows point by point while the
curve stays on its line: it stops before the first point at which some
point of the window deviates from the window's line by more than
max(NOISE_SIGMAS * noise, LINEAR_TOL * F).  The noise is estimated from the
curve itself, from the median absolute second difference of F (robust against
the curvature of a smooth curve).  A longer window averages out load-cell
noise (a 1.27 mm window on the shipped data misses E by up to 6 %); the
stopping rule keeps plasticity and geometric stiffening out of it.  The same
u_lin is applied to the beam model's own curve for the model-consistent
correction (:mod:`harnesspipe.calibrate.rom`).  At least ``min_points`` points
must fall in the first window; otherwise the curve is too coarse.

Note on sigma_Y: where the curve is still linear at u = 0.02 L, eq. 13 returns
sigma_Y = 0.24 E r_o / L whatever the true yield stress; Table 3's closed-tube
set, for instance, yields only at 5.7 % of the span.  The ROM stage therefore
uses eq. 13's sigma_Y as the starting point of the simplex and, by default,
refines it together with (K, n) (config ``rom.simplex_parameters``).  At least ``min_points`` points must fall in the
window; otherwise the curve is too coarse and an error says so.
"""
from __future__ import annotations

import math

import numpy as np


def second_moment(r_o: float) -> float:
    """I = pi r_o^4 / 4 of a solid circular section."""
    return math.pi * r_o**4 / 4.0


NOISE_SIGMAS = 3.0   # a deviation from the line beyond this many noise sigmas ends the linear part
LINEAR_TOL = 1e-3    # ... and beyond this fraction of the force (noise-free curves)


def _slope(u, F, mask) -> float:
    return float(np.dot(u[mask], F[mask]) / np.dot(u[mask], u[mask]))


def noise_level(F) -> float:
    """Standard deviation of white noise on F from its second differences (robust, MAD)."""
    d2 = np.diff(np.asarray(F, dtype=float), 2)
    if d2.size < 3:
        return 0.0
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


def linear_part(u, F, span: float, window: float = 0.01, min_points: int = 3) -> tuple[float, float]:
    """(slope through the origin, end u_lin) of the linear part of F(u) (module docstring)."""
    u = np.asarray(u, dtype=float)
    F = np.asarray(F, dtype=float)
    first = (u > 0.0) & (u <= window * span * (1.0 + 1e-9))
    if first.sum() < min_points:
        raise ValueError(f"eq. 13: only {int(first.sum())} points with 0 < u <= {window * span:.3g} mm "
                         f"(window {window} x span {span}); need {min_points} in the linear part")
    noise = noise_level(F)
    u_lin = float(u[first].max())
    for u_end in np.sort(u[u > u_lin]):
        mask = (u > 0.0) & (u <= u_end)
        k = _slope(u, F, mask)
        limit = np.maximum(NOISE_SIGMAS * noise, LINEAR_TOL * np.abs(F[mask]))
        if np.any(np.abs(F[mask] - k * u[mask]) > limit):
            break
        u_lin = float(u_end)
    return _slope(u, F, (u > 0.0) & (u <= u_lin)), u_lin


def linear_slope(u, F, span: float, window: float = 0.01, min_points: int = 3) -> float:
    """Slope through the origin of the linear part of F(u) (see :func:`linear_part`)."""
    return linear_part(u, F, span, window, min_points)[0]


def slope_up_to(u, F, u_lin: float) -> float:
    """Least-squares slope through the origin on 0 < u <= u_lin (a given linear part)."""
    u = np.asarray(u, dtype=float)
    return _slope(u, np.asarray(F, dtype=float), (u > 0.0) & (u <= u_lin))


def modulus_from_slope(slope: float, span: float, r_o: float) -> float:
    """E_eff = (F/u) L^3 / (48 I) (eq. 13)."""
    return slope * span**3 / (48.0 * second_moment(r_o))


def effective_modulus(u, F, span: float, r_o: float, window: float = 0.01) -> float:
    """E_eff of eq. 13 with F/u the slope of the linear part."""
    return modulus_from_slope(linear_slope(u, F, span, window), span, r_o)


def log_modulus_gradient(u, F, span: float, window: float = 0.01) -> np.ndarray:
    """d ln E_eff / dF_i of :func:`effective_modulus` on the rows of F(u), its linear part
    held: the slope through the origin k = sum u_i F_i / sum u_i^2 over 0 < u_i <= u_lin
    gives u_i / (k sum u_j^2) on those rows and 0 elsewhere (the Fisher covariance of the
    closed-form E, :func:`harnesspipe.calibrate.uncertainty.estimator_map`)."""
    u, F = np.asarray(u, dtype=float), np.asarray(F, dtype=float)
    k, u_lin = linear_part(u, F, span, window)
    rows = (u > 0.0) & (u <= u_lin)
    return np.where(rows, u / (k * np.dot(u[rows], u[rows])), 0.0)


def log_yield_stress_gradient(u, F, span: float, fraction: float = 0.02) -> np.ndarray:
    """d ln sigma_Y / dF_i of :func:`yield_stress`: the linear-interpolation weights of the
    two rows around u = fraction * L over the force there."""
    u, F = np.asarray(u, dtype=float), np.asarray(F, dtype=float)
    u_star = fraction * span
    weights = np.array([np.interp(u_star, u, row) for row in np.eye(u.size)])
    return weights / force_at(u, F, u_star)


def force_at(u, F, u_star: float) -> float:
    """Force at deflection ``u_star`` by linear interpolation (u must cover it)."""
    u = np.asarray(u, dtype=float)
    if not (u[0] <= u_star <= u[-1]):
        raise ValueError(f"eq. 13: the curve spans u = {u[0]:g}..{u[-1]:g} mm, "
                         f"it must reach {u_star:g} mm")
    return float(np.interp(u_star, u, F))


def yield_stress(u, F, span: float, r_o: float, fraction: float = 0.02) -> float:
    """sigma_Y = F_2% L / (pi r_o^3), F_2% the force at u = fraction * L (eq. 13)."""
    return force_at(u, F, fraction * span) * span / (math.pi * r_o**3)
