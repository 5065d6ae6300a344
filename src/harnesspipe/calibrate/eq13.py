"""Closed forms of eq. 13: effective modulus and yield stress from a three-point curve.

    E_eff = F L^3 / (48 u I),     sigma_Y = F_2% L / (pi r_o^3),     I = pi r_o^4 / 4

L is the support span, r_o the bundle's outer radius and F_2% the force at
u = 0.02 L (Sec. 4.3).

How the linear part is chosen (E_eff): the slope F/u is the least-squares fit of
a line through the origin to the points with 0 < u <= ``window`` * L (default
1 % of the span, half the deflection at which eq. 13 places the yield point).
A straight line through the origin is the small-deflection elastic response of
the three-point test, so fitting the slope rather than a single secant averages
out load-cell noise; the window is short enough that neither plasticity nor
geometric stiffening has set in: for every parameter set of Table 3 the elastic
limit of the beam, u = sigma_Y L^2 / (12 E r_o), lies beyond 1.6 % of the span.

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


def linear_slope(u, F, span: float, window: float = 0.01, min_points: int = 3) -> float:
    """Least-squares slope through the origin of F(u) on 0 < u <= window * span."""
    u = np.asarray(u, dtype=float)
    F = np.asarray(F, dtype=float)
    mask = (u > 0.0) & (u <= window * span * (1.0 + 1e-9))
    if mask.sum() < min_points:
        raise ValueError(f"eq. 13: only {int(mask.sum())} points with 0 < u <= {window * span:.3g} mm "
                         f"(window {window} x span {span}); need {min_points} in the linear part")
    return float(np.dot(u[mask], F[mask]) / np.dot(u[mask], u[mask]))


def effective_modulus(u, F, span: float, r_o: float, window: float = 0.01) -> float:
    """E_eff = (F/u) L^3 / (48 I) with F/u the slope of the linear part (eq. 13)."""
    return linear_slope(u, F, span, window) * span**3 / (48.0 * second_moment(r_o))


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
