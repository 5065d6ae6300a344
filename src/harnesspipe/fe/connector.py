"""Bushing connector of the branch break-out joint (Sec. 5, eqs. 14-15).

Two nodes joined by three translational and three rotational springs acting on
their relative displacement and rotation, expressed in the connector frame
(axis 1 along the branch).  Stiffnesses from the effective TWB properties by
eq. 14 with the aspect ratio lambda = l / r:

    k = E A / (lambda l),   k_beta = E I / (lambda l),   k_theta = G J / (lambda l)

The two transverse translational stiffnesses are not given by eq. 14; they are
taken as the shear analogue G A / (lambda l) (assumption, documented in config).
Damping is stiffness proportional, C = alpha K (eq. 15), so the connector is a
Kelvin-Voigt element: f = K (d + alpha d_dot).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


def bushing_stiffness(E: float, G: float, r: float, l: float) -> np.ndarray:
    """Diagonal stiffnesses [k, k_s, k_s, k_theta, k_beta, k_beta] of eq. 14.

    Order: axial, two transverse translations, torsion, two bending rotations.
    A = pi r^2, I = pi r^4 / 4, J = pi r^4 / 2 of the circumscribing circle.
    """
    if min(E, G, r, l) <= 0.0:
        raise ValueError(f"bushing_stiffness: E, G, r, l must be > 0 (got {E}, {G}, {r}, {l})")
    lam_l = (l / r) * l
    A, I, J = math.pi * r**2, math.pi * r**4 / 4.0, math.pi * r**4 / 2.0
    return np.array([E * A, G * A, G * A, G * J, E * I, E * I]) / lam_l


@njit(cache=True)
def connector_force(d, d_dot, k_diag, alpha, f):
    """f = K d + alpha K d_dot (eqs. 14-15) for relative motion d in the connector frame."""
    for i in range(6):
        f[i] = k_diag[i] * (d[i] + alpha * d_dot[i])
