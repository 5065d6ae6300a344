"""One four-node finite-strain shell element (6 DOFs per node): reference data, kinematics,
material point update, internal force, MITC4 transverse shear, drilling penalty and the
central-difference tangent; the mesh and its assembly are :mod:`harnesspipe.fe.elements.shell`.

Formulation (total Lagrangian, continuum-based / degenerated solid shell):

* Geometry x(xi, eta, zeta) = sum_a N_a (x_a + zeta h/2 d_a) with nodal directors
  d_a = Q_a D_a; the nodal rotations Q_a are updated multiplicatively by the
  spin increments that are the rotational DOFs (Simo & Vu-Quoc 1986; Belytschko,
  Liu & Moran 2000, Sec. 9.3-9.5).
* In-plane strain at each of 2 x 2 x 5 Gauss points (5 through the thickness as in
  the paper): the right Cauchy-Green tensor C in a local orthonormal frame, its
  logarithm E_H = 1/2 ln C (closed-form 2 x 2 spectral decomposition), J2 plane
  stress on E_H with additive plastic strain (Eterovic & Bathe 1990; Miehe, Apel &
  Lambrecht 2002) and the second Piola-Kirchhoff stress S = T : dE_H/dE.
* Transverse shear: MITC4 assumed natural strains tied at the edge midpoints
  (Dvorkin & Bathe 1984), elastic with kappa_s = 5/6, as in Abaqus shells.
* Full 2 x 2 in-plane integration has no hourglass modes, so the hourglass
  control that the paper's reduced-integration Abaqus shell needs is not
  required here; MITC4 removes transverse shear locking.
* Drilling rotation: penalty tying each nodal triad to the polar rotation of the
  element centre (a finite-rotation form of Hughes & Brezzi 1989; energy
  1/2 k_d omega^2, k_d = DRILL_FACTOR G h0 A), the rotational "hourglass"
  control of the paper's Sec. 3.2; it vanishes for any rigid motion and any
  homogeneous stretch, so the patch tests hold exactly.
* Thickness: h = h0 exp(eps_33), eps_33 the element mean of the material's
  through-thickness strain (plastic incompressibility + elastic Poisson), updated
  once per converged step; reference volumes use h0.
* Materials (``mat[MAT_KIND]``): J2 plasticity with eq. 2 hardening
  (``MAT_J2``, ``mat`` = (E, nu, sigma_y, K, n, 0); a 5-vector without the kind is
  read as J2 too) or the orthotropic elastic plane-stress law of eq. 12 for the
  fabric tube (``MAT_ORTHOTROPIC``, ``mat`` = (E1, E2, nu12, G12, 0, 1)).  The
  orthotropic law acts on the Hencky strain in material axes that are fixed in the
  reference configuration (Lagrangian, they convect with the material): direction 1
  is a per-element vector projected onto the shell's tangent plane at each Gauss
  point (default: the element's local x axis e1 at its centre), stored as
  (cos, sin) of its angle from the Gauss point's e1.  Eq. 12 gives no transverse
  moduli, so the transverse shear modulus (G13 = G23) is taken as G12 (the fabric's
  only shear modulus; with kappa_s = 5/6 as for J2) and the drilling penalty uses
  G12 too; nor does it give out-of-plane Poisson ratios, so the thickness of an
  orthotropic shell is kept at h0 (eps_33 = 0 in the history).

The internal force is analytical; the element tangent is its central finite
difference with respect to nodal translations and spins, which contains the
return mapping and is therefore the consistent (algorithmic) tangent to
O(h^2) (Miehe 1996; Perez-Foguet, Rodriguez-Ferran & Huerta 2000).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from harnesspipe.fe.materials.plane_stress import (STATE_SIZE, J2Material, j2_plane_stress,
                                                   orthotropic_plane_stress,
                                                   orthotropic_plane_stress_stiffness)

N_THICKNESS = 5
ZETA, ZETA_W = np.polynomial.legendre.leggauss(N_THICKNESS)
GP = 1.0 / np.sqrt(3.0)
XI_GP = np.array([[-GP, -GP], [GP, -GP], [GP, GP], [-GP, GP]])
XI_NODE = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
# MITC4 tying points: eps_xi_zeta at (0, -1), (0, 1); eps_eta_zeta at (-1, 0), (1, 0)
TYING = np.array([[0.0, -1.0], [0.0, 1.0], [-1.0, 0.0], [1.0, 0.0]])
SHEAR_CORRECTION = 5.0 / 6.0
DRILL_FACTOR = 1.0e-3
FD_STEP = 1.0e-6  # relative perturbation of the central-difference tangent
MAT_KIND = 5  # index of the material kind in ``mat``
MAT_J2, MAT_ORTHOTROPIC = 0, 1


class ElementRef(NamedTuple):
    """Reference data of one element: :func:`reference_element`'s inverse Jacobians
    (4, N_THICKNESS, 3, 3), volume weights (4, N_THICKNESS) and tying-point shear strains
    (4,), :func:`material_axes`' axes (4, N_THICKNESS, 2), the thickness ``h0`` and the
    material row ``mat``."""
    Jinv: np.ndarray
    dV: np.ndarray
    shear_ref: np.ndarray
    axes: np.ndarray
    h0: float
    mat: np.ndarray


class Perturbed(NamedTuple):
    """Scratch of the central differences (:func:`element_tangent`, :func:`drilling`): the
    element's forces at +h and -h (4, 6), its perturbed nodes, directors and drilling
    vectors (4, 3), the rotation axis (3,) and a trial history (4 N_THICKNESS, STATE_SIZE)."""
    f_plus: np.ndarray
    f_minus: np.ndarray
    x: np.ndarray
    d: np.ndarray
    r: np.ndarray
    axis: np.ndarray
    state: np.ndarray


class DrillWork(NamedTuple):
    """Scratch of :func:`drilling`: d omega/dq (4, 24), omega and its two perturbed
    values (4,), three 3-vectors and a (4, 3) block of :func:`_drill_strains`."""
    grad: np.ndarray
    omega: np.ndarray
    om_p: np.ndarray
    om_m: np.ndarray
    w3a: np.ndarray
    w3b: np.ndarray
    w3c: np.ndarray
    w43: np.ndarray


@njit(cache=True)
def material_kind(mat):
    """MAT_J2 or MAT_ORTHOTROPIC (a 5-vector ``mat`` is J2)."""
    if mat.shape[0] > MAT_KIND and mat[MAT_KIND] == MAT_ORTHOTROPIC:
        return MAT_ORTHOTROPIC
    return MAT_J2


@njit(cache=True)
def shear_modulus(mat):
    """Transverse shear (and drilling) modulus: E / (2 (1 + nu)) for J2, G12 for eq. 12."""
    if material_kind(mat) == MAT_ORTHOTROPIC:
        return mat[3]
    return mat[0] / (2.0 * (1.0 + mat[1]))


@njit(cache=True)
def shape(xi, eta, N, dN):
    """Bilinear shape functions and their natural derivatives dN[a] = (dN/dxi, dN/deta)."""
    for a in range(4):
        sa, ta = XI_NODE[a, 0], XI_NODE[a, 1]
        N[a] = 0.25 * (1.0 + sa * xi) * (1.0 + ta * eta)
        dN[a, 0] = 0.25 * sa * (1.0 + ta * eta)
        dN[a, 1] = 0.25 * ta * (1.0 + sa * xi)


@njit(cache=True)
def _cross(a, b, out):
    """out = a x b (3-vectors)."""
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit(cache=True)
def rotate(v, axis, angle, out):
    """Rodrigues rotation of ``v`` by ``angle`` about the unit vector ``axis``."""
    c, s = np.cos(angle), np.sin(angle)
    k_dot_v = axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2]
    kx = axis[1] * v[2] - axis[2] * v[1]
    ky = axis[2] * v[0] - axis[0] * v[2]
    kz = axis[0] * v[1] - axis[1] * v[0]
    out[0] = v[0] * c + kx * s + axis[0] * k_dot_v * (1.0 - c)
    out[1] = v[1] * c + ky * s + axis[1] * k_dot_v * (1.0 - c)
    out[2] = v[2] * c + kz * s + axis[2] * k_dot_v * (1.0 - c)


@njit(cache=True)
def rotation_matrix(theta, R):
    """exp of the skew matrix of the rotation vector ``theta`` (Rodrigues)."""
    angle = np.sqrt(theta[0] ** 2 + theta[1] ** 2 + theta[2] ** 2)
    R[:, :] = 0.0
    for i in range(3):
        R[i, i] = 1.0
    if angle < 1e-300:
        return
    k0, k1, k2 = theta[0] / angle, theta[1] / angle, theta[2] / angle
    c, s = np.cos(angle), np.sin(angle)
    k = (k0, k1, k2)
    for i in range(3):
        for j in range(3):
            R[i, j] = c * (1.0 if i == j else 0.0) + (1.0 - c) * k[i] * k[j]
    R[0, 1] -= s * k2
    R[0, 2] += s * k1
    R[1, 0] += s * k2
    R[1, 2] -= s * k0
    R[2, 0] -= s * k1
    R[2, 1] += s * k0


@njit(cache=True)
def _local_jacobian(X, D, h0, xi, eta, zeta, N, dN, G, J):
    """J[k, i] = e_k . G_i in the local frame (e1 along G_xi, e3 along the director);
    returns e1."""
    shape(xi, eta, N, dN)
    G[:, :] = 0.0
    for a in range(4):
        for i in range(3):
            G[i, 0] += dN[a, 0] * (X[a, i] + zeta * 0.5 * h0 * D[a, i])
            G[i, 1] += dN[a, 1] * (X[a, i] + zeta * 0.5 * h0 * D[a, i])
            G[i, 2] += N[a] * 0.5 * h0 * D[a, i]
    e3 = G[:, 2] / np.sqrt(np.sum(G[:, 2] ** 2))
    e1 = G[:, 0].copy()
    e1 -= np.dot(e1, e3) * e3
    e1 /= np.sqrt(np.sum(e1 ** 2))
    e2 = np.empty(3)
    _cross(e3, e1, e2)
    for i in range(3):
        J[0, i] = e1[0] * G[0, i] + e1[1] * G[1, i] + e1[2] * G[2, i]
        J[1, i] = e2[0] * G[0, i] + e2[1] * G[1, i] + e2[2] * G[2, i]
        J[2, i] = e3[0] * G[0, i] + e3[1] * G[1, i] + e3[2] * G[2, i]
    return e1


@njit(cache=True)
def reference_element(X, D, h0, Jinv, dV, shear_ref, Jc, T0):
    """Constant reference data of one element; returns its area.

    ``X`` (4, 3) nodes, ``D`` (4, 3) nodal directors.  Writes ``Jinv`` (4, 5, 3, 3),
    the inverse local Jacobians at the Gauss points, ``dV`` (4, 5) Gauss weights
    times reference volume, ``shear_ref`` (4,) G_i . G_zeta at the MITC4 tying
    points, ``Jc`` (3, 3) the inverse local Jacobian at the centre and ``T0`` (4, 3)
    the centre's e1 projected normal to each nodal director (drilling reference).
    """
    N = np.empty(4)
    dN = np.empty((4, 2))
    J = np.empty((3, 3))
    G = np.empty((3, 3))
    area = 0.0
    for g in range(4):
        for z in range(N_THICKNESS):
            _local_jacobian(X, D, h0, XI_GP[g, 0], XI_GP[g, 1], ZETA[z], N, dN, G, J)
            detJ = np.linalg.det(J)
            Jinv[g, z] = np.linalg.inv(J)
            dV[g, z] = detJ * ZETA_W[z]
            if z == N_THICKNESS // 2:
                area += detJ / (0.5 * h0)
    e1 = _local_jacobian(X, D, h0, 0.0, 0.0, 0.0, N, dN, G, J)
    Jc[:, :] = np.linalg.inv(J)
    for a in range(4):
        T = e1 - np.dot(e1, D[a]) * D[a]
        T0[a] = T / np.sqrt(np.sum(T ** 2))
    for p in range(4):
        shape(TYING[p, 0], TYING[p, 1], N, dN)
        col = 0 if p < 2 else 1
        gi = np.zeros(3)
        gz = np.zeros(3)
        for a in range(4):
            gi += dN[a, col] * X[a]
            gz += N[a] * 0.5 * h0 * D[a]
        shear_ref[p] = np.dot(gi, gz)
    return area


@njit(cache=True)
def material_axes(X, D, h0, a1, axes):
    """Material direction 1 of one element at its Gauss points: ``axes`` (4, 5, 2) =
    (cos, sin) of the angle from the local e1 to ``a1`` (3,) projected onto the
    tangent plane (normal e3); ``a1`` = 0 selects the local e1 at the element centre."""
    N = np.empty(4)
    dN = np.empty((4, 2))
    J = np.empty((3, 3))
    G = np.empty((3, 3))
    e2 = np.empty(3)
    a = a1.copy()
    if np.sum(a * a) == 0.0:
        a[:] = _local_jacobian(X, D, h0, 0.0, 0.0, 0.0, N, dN, G, J)
    for g in range(4):
        for z in range(N_THICKNESS):
            e1 = _local_jacobian(X, D, h0, XI_GP[g, 0], XI_GP[g, 1], ZETA[z], N, dN, G, J)
            e3 = G[:, 2] / np.sqrt(np.sum(G[:, 2] ** 2))
            _cross(e3, e1, e2)
            c, s = np.dot(a, e1), np.dot(a, e2)
            r = np.sqrt(c * c + s * s)
            if r < 1e-8 * np.sqrt(np.sum(a * a)):
                raise ValueError("material direction 1 is normal to the shell")
            axes[g, z, 0] = c / r
            axes[g, z, 1] = s / r


@njit(cache=True)
def _spectral(C11, C22, C12):
    """Eigenvalues c1 >= c2 and the angle of the first eigenvector of a sym. 2 x 2."""
    mean = 0.5 * (C11 + C22)
    rad = np.sqrt((0.5 * (C11 - C22)) ** 2 + C12 * C12)
    angle = 0.5 * np.arctan2(2.0 * C12, C11 - C22)
    return mean + rad, mean - rad, angle


@njit(cache=True)
def _hencky(C11, C22, C12, eps):
    """(eps_11, eps_22, gamma_12) of E_H = 1/2 ln C; returns (c1, c2, cos, sin)."""
    c1, c2, angle = _spectral(C11, C22, C12)
    co, si = np.cos(angle), np.sin(angle)
    l1, l2 = 0.5 * np.log(c1), 0.5 * np.log(c2)
    eps[0] = l1 * co * co + l2 * si * si
    eps[1] = l1 * si * si + l2 * co * co
    eps[2] = 2.0 * (l1 - l2) * co * si
    return c1, c2, co, si


@njit(cache=True)
def _second_piola(sig, c1, c2, co, si):
    """S = T : dE_H/dE for T = (T11, T22, T12); returns (S11, S22, S12)."""
    t11 = co * co * sig[0] + 2.0 * co * si * sig[2] + si * si * sig[1]
    t22 = si * si * sig[0] - 2.0 * co * si * sig[2] + co * co * sig[1]
    t12 = -co * si * sig[0] + (co * co - si * si) * sig[2] + co * si * sig[1]
    if abs(c1 - c2) > 1e-10 * c1:
        ratio = (np.log(c1) - np.log(c2)) / (c1 - c2)
    else:
        ratio = 1.0 / c1
    s11, s22, s12 = t11 / c1, t22 / c2, t12 * ratio
    S11 = co * co * s11 - 2.0 * co * si * s12 + si * si * s22
    S22 = si * si * s11 + 2.0 * co * si * s12 + co * co * s22
    S12 = co * si * s11 + (co * co - si * si) * s12 - co * si * s22
    return S11, S22, S12


@njit(cache=True)
def work_arrays():
    """Scratch arrays of :func:`element_force`, allocated once per assembly."""
    return (np.empty(4), np.empty((4, 2)), np.empty((3, 3)), np.empty((2, 3)), np.empty((2, 3)),
            np.empty(3), np.empty(3), np.empty((3, 3)), np.empty(4), np.empty((4, 4)),
            np.empty(3), np.empty(3), np.empty(4), np.empty((4, 3)), np.empty((4, 3)),
            np.empty((3, 3)))


@njit(cache=True)
def perturbed_arrays():
    """A :class:`Perturbed`, allocated once per assembly."""
    return Perturbed(np.empty((4, 6)), np.empty((4, 6)), np.empty((4, 3)), np.empty((4, 3)),
                     np.empty((4, 3)), np.empty(3), np.empty((4 * N_THICKNESS, STATE_SIZE)))


@njit(cache=True)
def drill_arrays():
    """A :class:`DrillWork`, allocated once per assembly."""
    return DrillWork(np.empty((4, 24)), np.empty(4), np.empty(4), np.empty(4), np.empty(3),
                     np.empty(3), np.empty(3), np.empty((4, 3)))


@njit(cache=True)
def element_force(x, d, ref, h, state_old, state_new, fe, work):
    """Internal force ``fe`` (4, 6) (forces, moments) of one element.

    ``x`` (4, 3) current nodes, ``d`` (4, 3) current directors, ``ref`` its
    :class:`ElementRef` (``mat`` = (E, nu, sigma_y, K, n[, MAT_J2]) or
    (E1, E2, nu12, G12, 0, MAT_ORTHOTROPIC); the material axes are read by the
    orthotropic law only), ``h`` its current thickness, history (4 * 5, STATE_SIZE),
    ``work`` from :func:`work_arrays`.
    """
    Jinv, dV, shear_ref, axes, h0, mat = ref
    j2 = J2Material(mat[0], mat[1], mat[2], mat[3], mat[4])
    G = shear_modulus(mat)
    ortho = material_kind(mat) == MAT_ORTHOTROPIC
    N, dN, g, f, P, eps, sig, Dm, w4, w44, tmp, mom, gam, gi_t, gz_t, Do = work
    if ortho:
        orthotropic_plane_stress_stiffness(mat[0], mat[1], mat[2], mat[3], Do)
    fe[:, :] = 0.0
    # MITC4 covariant transverse shear at the tying points (director length h0)
    for p in range(4):
        shape(TYING[p, 0], TYING[p, 1], N, dN)
        col = 0 if p < 2 else 1
        gi_t[p] = 0.0
        gz_t[p] = 0.0
        for a in range(4):
            for i in range(3):
                gi_t[p, i] += dN[a, col] * x[a, i]
                gz_t[p, i] += N[a] * 0.5 * h0 * d[a, i]
        gam[p] = np.dot(gi_t[p], gz_t[p]) - shear_ref[p]
    for gp in range(4):
        xi, eta = XI_GP[gp, 0], XI_GP[gp, 1]
        shape(xi, eta, N, dN)
        for z in range(N_THICKNESS):
            zc = 0.5 * h * ZETA[z]
            g[:, :] = 0.0
            for a in range(4):
                for i in range(3):
                    g[0, i] += dN[a, 0] * (x[a, i] + zc * d[a, i])
                    g[1, i] += dN[a, 1] * (x[a, i] + zc * d[a, i])
                    g[2, i] += N[a] * 0.5 * h * d[a, i]
            Ji = Jinv[gp, z]
            for l in range(2):
                for i in range(3):
                    f[l, i] = g[0, i] * Ji[0, l] + g[1, i] * Ji[1, l] + g[2, i] * Ji[2, l]
            C11 = np.dot(f[0], f[0])
            C22 = np.dot(f[1], f[1])
            C12 = np.dot(f[0], f[1])
            c1, c2, co, si = _hencky(C11, C22, C12, eps)
            k = gp * N_THICKNESS + z
            if ortho:
                orthotropic_plane_stress(eps, axes[gp, z, 0], axes[gp, z, 1], Do, 1.0, sig)
                for i in range(STATE_SIZE):
                    state_new[k, i] = state_old[k, i]
            else:
                j2_plane_stress(eps, state_old[k], j2, sig, Dm, state_new[k], w4, w44)
            S11, S22, S12 = _second_piola(sig, c1, c2, co, si)
            for i in range(3):
                P[0, i] = S11 * f[0, i] + S12 * f[1, i]
                P[1, i] = S12 * f[0, i] + S22 * f[1, i]
            w = dV[gp, z]
            for a in range(4):
                b0 = dN[a, 0] * Ji[0, 0] + dN[a, 1] * Ji[1, 0]
                b1 = dN[a, 0] * Ji[0, 1] + dN[a, 1] * Ji[1, 1]
                m0 = zc * b0 + 0.5 * h * N[a] * Ji[2, 0]
                m1 = zc * b1 + 0.5 * h * N[a] * Ji[2, 1]
                for i in range(3):
                    fe[a, i] += w * (b0 * P[0, i] + b1 * P[1, i])
                    tmp[i] = w * (m0 * P[0, i] + m1 * P[1, i])
                _cross(d[a], tmp, mom)
                for i in range(3):
                    fe[a, 3 + i] += mom[i]
        # transverse shear at this in-plane point, constant through the thickness
        Ji = Jinv[gp, N_THICKNESS // 2]
        vol = 0.0
        for z in range(N_THICKNESS):
            vol += dV[gp, z]
        g_xi = 0.5 * (1.0 - eta) * gam[0] + 0.5 * (1.0 + eta) * gam[1]
        g_eta = 0.5 * (1.0 - xi) * gam[2] + 0.5 * (1.0 + xi) * gam[3]
        for kk in range(2):
            a_xi = Ji[0, kk] * Ji[2, 2]
            a_eta = Ji[1, kk] * Ji[2, 2]
            tau = vol * SHEAR_CORRECTION * G * (a_xi * g_xi + a_eta * g_eta)
            weights = (a_xi * 0.5 * (1.0 - eta), a_xi * 0.5 * (1.0 + eta),
                       a_eta * 0.5 * (1.0 - xi), a_eta * 0.5 * (1.0 + xi))
            for p in range(4):
                _shear_variation(p, weights[p] * tau, d, gi_t[p], gz_t[p], h0, fe, N, dN, tmp)


@njit(cache=True)
def _shear_variation(p, coef, d, gi, gz, h0, fe, N, dN, tmp):
    """Add coef * d(g_i . g_zeta)/dq at tying point ``p`` to ``fe``."""
    shape(TYING[p, 0], TYING[p, 1], N, dN)
    col = 0 if p < 2 else 1
    for a in range(4):
        for i in range(3):
            fe[a, i] += coef * dN[a, col] * gz[i]
        _cross(d[a], gi, tmp)
        for i in range(3):
            fe[a, 3 + i] += coef * 0.5 * h0 * N[a] * tmp[i]


@njit(cache=True)
def _drill_strains(x, d, r, Jc, omega, f0, f1, t, w43):
    """omega_a = (r_a x p) . d_a: the angle between the nodal triad vector r_a and p,
    the element's reference direction e1 turned by the polar rotation of the
    in-plane deformation gradient at the element centre."""
    f0[:] = 0.0
    f1[:] = 0.0
    for a in range(4):
        for i in range(3):
            dxi = 0.25 * XI_NODE[a, 0] * x[a, i]
            deta = 0.25 * XI_NODE[a, 1] * x[a, i]
            f0[i] += dxi * Jc[0, 0] + deta * Jc[1, 0]
            f1[i] += dxi * Jc[0, 1] + deta * Jc[1, 1]
    normal, p, rp = w43[0], w43[1], w43[2]
    for i in range(3):
        normal[i] = d[0, i] + d[1, i] + d[2, i] + d[3, i]
    c1_len = np.sqrt(f0[0] ** 2 + f0[1] ** 2 + f0[2] ** 2)
    _cross(normal, f0, t)                       # in-plane, normal to c1 = f0/|f0|
    t_dot = np.dot(t, f0) / (c1_len * c1_len)
    for i in range(3):
        t[i] -= t_dot * f0[i]
    t_len = np.sqrt(t[0] ** 2 + t[1] ** 2 + t[2] ** 2)
    for i in range(3):
        t[i] /= t_len
    alpha = np.arctan2(-np.dot(f0, f1) / c1_len, c1_len + np.dot(t, f1))
    ca, sa = np.cos(alpha), np.sin(alpha)
    for i in range(3):
        p[i] = ca * f0[i] / c1_len + sa * t[i]
    for a in range(4):
        _cross(r[a], p, rp)
        omega[a] = np.dot(rp, d[a])


@njit(cache=True)
def drilling(x, d, r, Jc, k_d, fe, ke, pert, dw):
    """Drilling penalty 1/2 k_d sum omega_a^2: adds its force to ``fe`` (4, 6) and its
    Gauss-Newton tangent k_d grad^T grad to ``ke`` (24, 24); grad = d omega/dq by
    central differences (the neglected omega d2(omega) term vanishes with omega).
    ``r`` (4, 3) the nodal drilling vectors, ``Jc`` the centre's reference Jacobian,
    scratch ``pert`` (:class:`Perturbed`) and ``dw`` (:class:`DrillWork`)."""
    xp, dp, rp, axis = pert.x, pert.d, pert.r, pert.axis
    grad, omega, om_p, om_m, w3a, w3b, w3c, w43 = dw
    scale = 0.0
    for a in range(4):
        for i in range(3):
            scale = max(scale, abs(x[a, i] - x[0, i]))
    hu = FD_STEP * scale
    _drill_strains(x, d, r, Jc, omega, w3a, w3b, w3c, w43)
    for j in range(24):
        a, c = j // 6, j % 6
        for sign in (1.0, -1.0):
            xp[:, :] = x
            dp[:, :] = d
            rp[:, :] = r
            if c < 3:
                xp[a, c] += sign * hu
            else:
                axis[:] = 0.0
                axis[c - 3] = 1.0
                rotate(d[a], axis, sign * FD_STEP, dp[a])
                rotate(r[a], axis, sign * FD_STEP, rp[a])
            _drill_strains(xp, dp, rp, Jc, om_p if sign > 0 else om_m, w3a, w3b, w3c, w43)
        step = 2.0 * (hu if c < 3 else FD_STEP)
        for b in range(4):
            grad[b, j] = (om_p[b] - om_m[b]) / step
    for j in range(24):
        for b in range(4):
            fe[j // 6, j % 6] += k_d * omega[b] * grad[b, j]
        for i in range(24):
            for b in range(4):
                ke[i, j] += k_d * grad[b, i] * grad[b, j]


@njit(cache=True)
def element_tangent(x, d, ref, h, state_old, active, ke, pert, work):
    """Central-difference tangent ``ke`` (24, 24) of :func:`element_force`; columns of
    inactive DOFs (``active[j] == False``, held fixed) are left zero.  Central, not
    forward, differences: the O(h) error of the latter spoils Newton on thin shells,
    whose bending stiffness is orders of magnitude below the membrane one.  Scratch
    ``pert`` (:class:`Perturbed`), ``work`` from :func:`work_arrays`."""
    fp, fm, xp, dp, axis, scratch = pert.f_plus, pert.f_minus, pert.x, pert.d, pert.axis, pert.state
    scale = 0.0
    for a in range(4):
        for i in range(3):
            scale = max(scale, abs(x[a, i] - x[0, i]))
    hu = FD_STEP * max(scale, 1e-12)
    ke[:, :] = 0.0
    for j in range(24):
        if not active[j]:
            continue
        a, c = j // 6, j % 6
        for sign in (1.0, -1.0):
            xp[:, :] = x
            dp[:, :] = d
            if c < 3:
                xp[a, c] += sign * hu
            else:
                axis[:] = 0.0
                axis[c - 3] = 1.0
                rotate(d[a], axis, sign * FD_STEP, dp[a])
            element_force(xp, dp, ref, h, state_old, scratch, fp if sign > 0 else fm, work)
        step = 2.0 * (hu if c < 3 else FD_STEP)
        for b in range(4):
            for i in range(6):
                ke[6 * b + i, j] = (fp[b, i] - fm[b, i]) / step
