"""Axisymmetric finite-strain shell of revolution (2 nodes, DOFs u_r, u_z, theta).

Kinematics: Reissner-type shell of revolution with an inextensible director
(Simo, Fox & Rifai 1990 in axisymmetric form; Wriggers 2008, Sec. 9.4).  A fibre
at height z = zeta h/2 above the meridian has the principal stretches

    lambda_s     = (x' . t + z phi') / (X' . T + z0 Phi')     (meridian)
    lambda_theta = (r + z cos phi) / (R + z0 cos Phi)          (hoop)

with x' the meridian tangent per unit reference length, d = (cos phi, sin phi)
the director in the (r, z) plane and t = dd/dphi.  The logarithmic strains
ln(lambda) enter the plane-stress J2 kernel (Hencky strain with additive plastic
strain, Eterovic & Bathe 1990), whose stress is work-conjugate to them.  The
transverse shear gamma = x' . d - X' . D is elastic (kappa_s = 5/6), as in
Abaqus shells.  One Gauss point along the meridian, ``N_THICKNESS`` Gauss points
through the thickness.  The thickness h follows the through-thickness strain of
the material (plastic incompressibility + elastic Poisson) and is updated once
per converged load step; the reference volume uses h0 (total Lagrangian).

Internal force and its exact (consistent) derivative are assembled analytically.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from harnesspipe.fe.materials.plane_stress import (EPS33, STATE_SIZE, J2Material,
                                                   j2_plane_stress)

N_THICKNESS = 5
ZETA, ZETA_W = np.polynomial.legendre.leggauss(N_THICKNESS)
SHEAR_CORRECTION = 5.0 / 6.0
DOF_PER_NODE = 3


@njit(cache=True)
def _element(X, Phi, ue, h0, h, mat, state_old, state_new, fe, ke, work):
    """Internal force ``fe`` (6,) and tangent ``ke`` (6, 6) of one element, integrated
    over the thickness at the Gauss points ``ZETA`` with weights ``ZETA_W``.

    ``X`` (2, 2) reference (R, Z) of the nodes, ``Phi`` (2,) reference director
    angles, ``ue`` (6,) nodal (u_r, u_z, theta).  ``mat`` = (E, nu, sigma_y, K, n).
    ``work`` holds preallocated scratch arrays.
    """
    zeta, zeta_w = ZETA, ZETA_W
    j2 = J2Material(mat[0], mat[1], mat[2], mat[3], mat[4])
    E, nu = j2.E, j2.nu
    eps, sig, D, w4, w44, Ba, Bb, Bg = work
    dX0, dX1 = X[1, 0] - X[0, 0], X[1, 1] - X[0, 1]
    L0 = np.sqrt(dX0 * dX0 + dX1 * dX1)
    Phi_m = 0.5 * (Phi[0] + Phi[1])
    A_mid = (-dX0 * np.sin(Phi_m) + dX1 * np.cos(Phi_m)) / L0
    Gamma0 = (dX0 * np.cos(Phi_m) + dX1 * np.sin(Phi_m)) / L0
    dPhi = (Phi[1] - Phi[0]) / L0
    R = 0.5 * (X[0, 0] + X[1, 0])
    # current meridian
    xp0 = (dX0 + ue[3] - ue[0]) / L0
    xp1 = (dX1 + ue[4] - ue[1]) / L0
    phi = Phi_m + 0.5 * (ue[2] + ue[5])
    dphi = dPhi + (ue[5] - ue[2]) / L0
    r = R + 0.5 * (ue[0] + ue[3])
    c, s = np.cos(phi), np.sin(phi)
    xt = -xp0 * s + xp1 * c   # x' . t,  t = (-sin, cos)
    xd = xp0 * c + xp1 * s    # x' . d,  d = (cos, sin)
    fe[:] = 0.0
    ke[:, :] = 0.0
    G = E / (2.0 * (1.0 + nu))
    for k in range(zeta.size):
        z0 = 0.5 * h0 * zeta[k]
        zc = 0.5 * h * zeta[k]
        A = A_mid + z0 * dPhi
        Bref = R + z0 * np.cos(Phi_m)
        a = xt + zc * dphi
        b = r + zc * c
        eps[0] = np.log(a / A)
        eps[1] = np.log(b / Bref)
        eps[2] = 0.0
        j2_plane_stress(eps, state_old[k], j2, sig, D, state_new[k], w4, w44)
        dV = 2.0 * np.pi * Bref * A * L0 * 0.5 * h0 * zeta_w[k]
        Ba[0], Ba[1], Ba[3], Ba[4] = s / L0, -c / L0, -s / L0, c / L0
        Ba[2] = -0.5 * xd - zc / L0
        Ba[5] = -0.5 * xd + zc / L0
        Bb[0], Bb[1], Bb[3], Bb[4] = 0.5, 0.0, 0.5, 0.0
        Bb[2] = Bb[5] = -0.5 * zc * s
        for i in range(6):
            gs, gt = Ba[i] / a, Bb[i] / b
            fe[i] += dV * (sig[0] * gs + sig[1] * gt)
            for j in range(6):
                hs, ht = Ba[j] / a, Bb[j] / b
                ke[i, j] += dV * (gs * (D[0, 0] * hs + D[0, 1] * ht) + gt * (D[1, 0] * hs + D[1, 1] * ht)
                                  - sig[0] * gs * hs - sig[1] * gt * ht)
        # second derivatives of a and b (only x-phi and phi-phi pairs are non-zero)
        for p in range(2):
            sign = -1.0 if p == 0 else 1.0
            for m in range(2):
                d_comp = c if m == 0 else s
                for q in (2, 5):
                    v = dV * sig[0] / a * (-sign) * d_comp / (2.0 * L0)
                    ke[3 * p + m, q] += v
                    ke[q, 3 * p + m] += v
        for p in (2, 5):
            for q in (2, 5):
                ke[p, q] += dV * (sig[0] / a * (-0.25 * xt) + sig[1] / b * (-0.25 * zc * c))
    # transverse shear, elastic, one point
    gamma = xd - Gamma0
    V = 2.0 * np.pi * R * L0 * h0
    ksG = SHEAR_CORRECTION * G
    Bg[0], Bg[1], Bg[3], Bg[4] = -c / L0, -s / L0, c / L0, s / L0
    Bg[2] = Bg[5] = 0.5 * xt
    for i in range(6):
        fe[i] += V * ksG * gamma * Bg[i]
        for j in range(6):
            ke[i, j] += V * ksG * Bg[i] * Bg[j]
    for p in range(2):
        sign = -1.0 if p == 0 else 1.0
        for m in range(2):
            t_comp = -s if m == 0 else c
            for q in (2, 5):
                v = V * ksG * gamma * sign * t_comp / (2.0 * L0)
                ke[3 * p + m, q] += v
                ke[q, 3 * p + m] += v
    for p in (2, 5):
        for q in (2, 5):
            ke[p, q] += V * ksG * gamma * (-0.25 * xd)


@njit(cache=True)
def assemble(X, Phi, conn, u, h0, h, mat, state_old, state_new, K, f):
    """Dense global tangent ``K`` and internal force ``f`` of an axisymmetric mesh.

    ``X`` (n_nodes, 2), ``Phi`` (n_nodes,), ``conn`` (n_el, 2), ``u`` (3 n_nodes,),
    ``h`` (n_el,) current thickness, ``state_*`` (n_el, N_THICKNESS, STATE_SIZE).
    """
    K[:, :] = 0.0
    f[:] = 0.0
    Xe = np.empty((2, 2))
    Phie = np.empty(2)
    ue = np.empty(6)
    fe = np.empty(6)
    ke = np.empty((6, 6))
    dofs = np.empty(6, dtype=np.int64)
    work = (np.empty(3), np.empty(3), np.empty((3, 3)), np.empty(4), np.empty((4, 4)),
            np.empty(6), np.empty(6), np.empty(6))
    for e in range(conn.shape[0]):
        for a in range(2):
            node = conn[e, a]
            Xe[a, 0], Xe[a, 1] = X[node, 0], X[node, 1]
            Phie[a] = Phi[node]
            for i in range(3):
                dofs[3 * a + i] = 3 * node + i
                ue[3 * a + i] = u[3 * node + i]
        _element(Xe, Phie, ue, h0, h[e], mat, state_old[e], state_new[e], fe, ke, work)
        for i in range(6):
            f[dofs[i]] += fe[i]
            for j in range(6):
                K[dofs[i], dofs[j]] += ke[i, j]


@njit(cache=True)
def updated_thickness(h0, state):
    """Element thickness h0 exp(mean eps_33 over the thickness points)."""
    n_el, nz = state.shape[0], state.shape[1]
    h = np.empty(n_el)
    for e in range(n_el):
        m = 0.0
        for k in range(nz):
            m += state[e, k, EPS33]
        h[e] = h0 * np.exp(m / nz)
    return h


def new_state(n_elements: int) -> np.ndarray:
    """Zero history for every thickness point of every element."""
    return np.zeros((n_elements, N_THICKNESS, STATE_SIZE))


class AxisymShell:
    """Mesh, configuration and history of an axisymmetric shell, as a
    :class:`harnesspipe.fe.solvers.static_dense.System` (DOFs u_r, u_z, theta per node)."""

    def __init__(self, X, Phi, conn, h0, E, nu, sigma_y, K, n):
        self.X = np.ascontiguousarray(X, dtype=float)
        self.Phi = np.ascontiguousarray(Phi, dtype=float)
        self.conn = np.ascontiguousarray(conn, dtype=np.int64)
        self.h0 = float(h0)
        self.mat = np.array([E, nu, sigma_y, K, n], dtype=float)
        self.n_dof = DOF_PER_NODE * self.X.shape[0]
        self.u = np.zeros(self.n_dof)
        self._u_converged = self.u.copy()
        self.h = np.full(self.conn.shape[0], self.h0)
        self.state = new_state(self.conn.shape[0])
        self._trial = self.state.copy()
        self._K = np.zeros((self.n_dof, self.n_dof))
        self._f = np.zeros(self.n_dof)

    def tangent_and_force(self):
        assemble(self.X, self.Phi, self.conn, self.u, self.h0, self.h, self.mat,
                 self.state, self._trial, self._K, self._f)
        return self._K, self._f

    def advance(self, du):
        self.u += du

    def accept(self):
        self.state[...] = self._trial
        self._u_converged[:] = self.u
        self.h = updated_thickness(self.h0, self.state)

    def reject(self):
        self.u[:] = self._u_converged
