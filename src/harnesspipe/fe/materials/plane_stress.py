"""Plane-stress material kernels for shells: J2 plasticity (eqs. 1-2) and the
orthotropic elastic law of eq. 12.

J2 plasticity with the power-law hardening of eq. 2 under plane stress
(sigma_33 = 0) is integrated by the 3D radial return (Simo & Hughes 1998,
Box 3.1; de Souza Neto et al. 2008, Sec. 7.3) with the through-thickness strain
eps_33 as an extra unknown, solved by Newton iteration so that sigma_33 = 0
(de Borst 1991, "The zero-normal-stress condition in plane-stress and shell
elastoplasticity").  The plane-stress consistent tangent is the 3D consistent
tangent (de Souza Neto eq. 7.120) statically condensed on sigma_33 = 0.

The kernels work on small strains or, unchanged, on logarithmic (Hencky) strains
with additive plastic strain (Eterovic & Bathe 1990; Miehe, Apel & Lambrecht
2002), which is how the shell elements use them at finite strain.

Conventions: in-plane strain ``eps = (eps_11, eps_22, gamma_12)`` with
engineering shear; stress ``sig = (sigma_11, sigma_22, sigma_12)``; tangent
``D = d sig / d eps`` (3 x 3).  History per material point, ``STATE_SIZE``
values: plastic strain tensor components (11, 22, 33, 12), the effective plastic
strain eps_bar_p of eq. 2 and the total through-thickness strain eps_33.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from harnesspipe.fe.materials.hardening import positive_pow, return_map_from

STATE_SIZE = 6
P11, P22, P33, P12, EPS_BAR_P, EPS33 = range(STATE_SIZE)
SIGMA33_TOL = 1.0e-11  # relative tolerance on sigma_33 = 0
SIGMA33_MAXIT = 30


class J2Material(NamedTuple):
    """Eqs. 1-2: Young's modulus, Poisson's ratio and the hardening law
    sigma_y + K eps_bar_p^n."""
    E: float
    nu: float
    sigma_y: float
    K: float
    n: float


@njit(cache=True, inline="always")
def _elastic_constants(E, nu):
    """Shear and bulk moduli."""
    return E / (2.0 * (1.0 + nu)), E / (3.0 * (1.0 - 2.0 * nu))


@njit(cache=True, inline="always")
def _radial_return(a, eps_bar_p, sa, G, kappa, mat, out4, D4, want_tangent):
    """3D radial return for an elastic trial strain with eps_13 = eps_23 = 0.

    ``a`` = (a11, a22, a33, a12) are trial elastic strains (tensor components), ``G`` and
    ``kappa`` the shear and bulk moduli, ``mat`` the :class:`J2Material`, ``sa = eps_bar_p**n`` (stored
    history: the flow stress needs no power).  Writes the stress (11, 22, 33, 12) to
    ``out4`` and the consistent tangent in Voigt form (rows/cols 11, 22, 33, 12; the 12
    column acts on the engineering shear) to ``D4`` -- with ``want_tangent`` False only
    its entry (33, 33), which the sigma_33 = 0 iteration needs.  Returns (d eps_bar_p,
    n11, n22, n33, n12, sa_new) with n the unit normal s_trial/|s_trial| (zero when
    elastic) and ``sa_new = (eps_bar_p + d eps_bar_p)**n``.
    """
    a11, a22, a33, a12 = a
    tr = a11 + a22 + a33
    m = tr / 3.0
    s11 = 2.0 * G * (a11 - m)
    s22 = 2.0 * G * (a22 - m)
    s33 = 2.0 * G * (a33 - m)
    s12 = 2.0 * G * a12
    norm_s = np.sqrt(s11 * s11 + s22 * s22 + s33 * s33 + 2.0 * s12 * s12)
    q_trial = np.sqrt(1.5) * norm_s
    dg, H, sa_new = return_map_from(q_trial, 3.0 * G, eps_bar_p, sa, mat.sigma_y, mat.K, mat.n)
    theta = 1.0
    theta_bar = 0.0
    n11 = n22 = n33 = n12 = 0.0
    if dg > 0.0:
        theta = 1.0 - 3.0 * G * dg / q_trial
        theta_bar = 1.0 / (1.0 + H / (3.0 * G)) - (1.0 - theta)
        n11, n22, n33, n12 = s11 / norm_s, s22 / norm_s, s33 / norm_s, s12 / norm_s
    p = kappa * tr
    out4[0] = p + theta * s11
    out4[1] = p + theta * s22
    out4[2] = p + theta * s33
    out4[3] = theta * s12
    if not want_tangent:
        D4[2, 2] = kappa + 2.0 * G * theta * (1.0 - 1.0 / 3.0) - 2.0 * G * theta_bar * n33 * n33
        return dg, n11, n22, n33, n12, sa_new
    nv = (n11, n22, n33, n12)
    for i in range(4):
        for j in range(4):
            dev = (1.0 if i == j else 0.0) - (1.0 / 3.0 if i < 3 and j < 3 else 0.0)
            if i == 3 and j == 3:
                dev = 0.5
            vol = kappa if i < 3 and j < 3 else 0.0
            D4[i, j] = vol + 2.0 * G * theta * dev - 2.0 * G * theta_bar * nv[i] * nv[j]
    return dg, n11, n22, n33, n12, sa_new


@njit(cache=True)
def j2_plane_stress(eps, state_old, mat, sig, D, state_new, work4, work44):
    """J2 plane-stress update with eq. 2 hardening (``mat`` a :class:`J2Material`).

    ``eps`` (3,) total in-plane strain, ``state_old``/``state_new`` (STATE_SIZE,)
    history before/after, ``sig`` (3,) and ``D`` (3, 3) outputs, ``work4`` (4,)
    and ``work44`` (4, 4) scratch (passed in so that no allocation happens).
    Returns the effective plastic strain increment.
    """
    ep = state_old[EPS_BAR_P]
    sa = positive_pow(ep, mat.n) if (ep > 0.0 and mat.K != 0.0) else 0.0
    return j2_plane_stress_from(eps, state_old, sa, mat, sig, D, state_new, work4, work44,
                                True)[0]


@njit(cache=True, inline="always")
def j2_plane_stress_from(eps, state_old, sa, mat, sig, D, state_new, work4, work44,
                         want_tangent):
    """:func:`j2_plane_stress` from a stored ``sa = eps_bar_p**n`` (history of the caller:
    no power for the flow stress), the tangent ``D`` formed only if ``want_tangent``
    (an explicit update needs none).  Returns ``(d eps_bar_p, sa_new)``."""
    E, nu, sigma_y, K = mat.E, mat.nu, mat.sigma_y, mat.K
    G, kappa = _elastic_constants(E, nu)
    a11 = eps[0] - state_old[P11]
    a22 = eps[1] - state_old[P22]
    a12 = 0.5 * eps[2] - state_old[P12]
    # elastic plane-stress guess for the through-thickness elastic strain
    a33 = -nu / (1.0 - nu) * (a11 + a22)
    scale = sigma_y + K * sa + E * 1e-12
    dg = 0.0
    sa_new = sa
    for _ in range(SIGMA33_MAXIT):
        dg, n11, n22, n33, n12, sa_new = _radial_return((a11, a22, a33, a12),
                                                        state_old[EPS_BAR_P], sa, G, kappa, mat,
                                                        work4, work44, want_tangent)
        if abs(work4[2]) <= SIGMA33_TOL * scale:
            break
        a33 -= work4[2] / work44[2, 2]
    root = np.sqrt(1.5)
    state_new[P11] = state_old[P11] + dg * root * n11
    state_new[P22] = state_old[P22] + dg * root * n22
    state_new[P33] = state_old[P33] + dg * root * n33
    state_new[P12] = state_old[P12] + dg * root * n12
    state_new[EPS_BAR_P] = state_old[EPS_BAR_P] + dg
    state_new[EPS33] = a33 + state_old[P33]  # a33 is the trial elastic strain
    sig[0], sig[1], sig[2] = work4[0], work4[1], work4[3]
    if want_tangent:
        idx = (0, 1, 3)
        c33 = work44[2, 2]
        for i in range(3):
            for j in range(3):
                D[i, j] = work44[idx[i], idx[j]] - work44[idx[i], 2] * work44[2, idx[j]] / c33
    return dg, sa_new


@njit(cache=True, inline="always")
def orthotropic_plane_stress_stiffness(E1, E2, nu12, G12, D):
    """Inverse of the eq. 12 compliance [[1/E1, -nu12/E1, 0], [-nu12/E1, 1/E2, 0],
    [0, 0, 1/G12]] (material axes 1 = warp, 2 = weft), written to ``D`` (3, 3)."""
    nu21 = nu12 * E2 / E1
    det = 1.0 - nu12 * nu21
    D[:, :] = 0.0
    D[0, 0] = E1 / det
    D[1, 1] = E2 / det
    D[0, 1] = D[1, 0] = nu12 * E2 / det
    D[2, 2] = G12


def fabric_shear_modulus(E1: float, E2: float, nu12: float) -> float:
    """G12 = 0.5 (E1 + E2) / (2 (1 + nu12)) as chosen in Sec. 4.2.2."""
    return 0.5 * (E1 + E2) / (2.0 * (1.0 + nu12))


@njit(cache=True, inline="always")
def orthotropic_plane_stress(eps, c, s, Dmat, r_c, sig):
    """Eq. 12 stress for an in-plane strain given in a frame (e1, e2) whose material
    direction 1 is ``c e1 + s e2`` (c = cos, s = sin of the angle from e1 to axis 1).

    ``eps`` (3,) strain (eps_11, eps_22, gamma_12) in the (e1, e2) frame, ``Dmat``
    (3, 3) from :func:`orthotropic_plane_stress_stiffness` (material axes); writes
    ``sig`` (3,) in the (e1, e2) frame: sig = T^T Dmat T eps with T the engineering
    strain rotation, i.e. the stress that is work-conjugate to ``eps``.

    ``r_c`` in (0, 1]: a woven fabric's yarns buckle in compression, so along a yarn
    direction whose strain is compressive (material axes, m_11 < 0 or m_22 < 0) the
    diagonal stiffness is scaled by ``r_c``.  The stress is the gradient of the
    piecewise-quadratic energy 1/2 k_1 D_11 m_11^2 + 1/2 k_2 D_22 m_22^2 + D_12 m_11 m_22
    + 1/2 D_66 g_12^2 (k_i = 1 or r_c): continuous, with a symmetric tangent; the caller
    scales the Poisson coupling in ``Dmat`` by r_c (nu12 r_c) so that the energy stays
    convex in every quadrant.  ``r_c = 1`` is eq. 12 as written.
    """
    cc, ss, cs = c * c, s * s, c * s
    m11 = cc * eps[0] + ss * eps[1] + cs * eps[2]
    m22 = ss * eps[0] + cc * eps[1] - cs * eps[2]
    m12 = 2.0 * cs * (eps[1] - eps[0]) + (cc - ss) * eps[2]
    k1 = 1.0 if m11 >= 0.0 else r_c
    k2 = 1.0 if m22 >= 0.0 else r_c
    t11 = k1 * Dmat[0, 0] * m11 + Dmat[0, 1] * m22 + Dmat[0, 2] * m12
    t22 = Dmat[1, 0] * m11 + k2 * Dmat[1, 1] * m22 + Dmat[1, 2] * m12
    t12 = Dmat[2, 0] * m11 + Dmat[2, 1] * m22 + Dmat[2, 2] * m12
    sig[0] = cc * t11 + ss * t22 - 2.0 * cs * t12
    sig[1] = ss * t11 + cc * t22 + 2.0 * cs * t12
    sig[2] = cs * (t11 - t22) + (cc - ss) * t12
