"""The finite-rotation bushing of the branch break-out joint (Sec. 5, eqs. 14-15).

Two nodes joined by three translational and three rotational springs acting on their
relative displacement and rotation in the connector frame (axis 1 along the branch).
Stiffnesses (:func:`bushing_stiffness`) from the effective TWB properties by eq. 14
with the aspect ratio lambda = l / r:

    k = E A / (lambda l),   k_beta = E I / (lambda l),   k_theta = G J / (lambda l)

The two transverse translational stiffnesses are not given by eq. 14; they are
taken as the shear analogue G A / (lambda l) (assumption, documented in config).
Damping is stiffness proportional, C = alpha K (eq. 15), so the connector is a
Kelvin-Voigt element: s = K (d + alpha d_dot).

Kinematics (:func:`bushing_response`; :func:`bushing_forces` assembles every bushing).  Node ``a`` carries the connector frame ``E0`` (columns:
axis 1 along the break-out TWB, axes 2 and 3 across it), which rotates with the
node.  The six relative motions, in that frame, are

    d_t = E0^T (R_a^T (x_b - x_a) - (X_b - X_a))      (translations)
    d_r = E0^T log(R_a^T R_b)                          (rotations: torsion, two bendings)

so a rigid motion of the pair strains nothing, also for finite rotations (the
Cartesian and flexion-torsion measures of a bushing).  The rate ``d_dot`` comes from the Newmark relations of
the time integrator applied to d itself,

    d_dot = c_d (d - d_n) + c_v d_dot_n + c_a d_ddot_n,

which equals B v for small motions and stays objective for large ones; the
coefficients are the integrator's (``harnesspipe.fe.solvers.newmark``).  Hence
ds/dd = (1 + alpha c_d) K.  Nodal forces are f = B^T s with
B = dd/d(x_a, w_a, x_b, w_b) (spatial spins w); the tangent is B^T (ds/dd) B plus
the geometric terms of R_a and of the log map (``kh_matrix``).  The damping
force's dependence on the displacement through B in the tangent is exact because
the rate is a function of d only.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from harnesspipe.fe.assembly.band import scatter_pair
from harnesspipe.fe.rotation import kh_matrix, log_matrix, quat_to_matrix, skew, ts_inv


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


class Bushings(NamedTuple):
    """The bushings of a model: node pairs ``pairs`` (nb, 2) = (a, b), reference
    separations ``dX`` = X_b - X_a (nb, 3), connector frames ``E0`` (nb, 3, 3), eq. 14
    stiffnesses ``k_diag`` (nb, 6) and the eq. 15 damping coefficient ``alpha``."""
    pairs: np.ndarray
    dX: np.ndarray
    E0: np.ndarray
    k_diag: np.ndarray
    alpha: float


class BushingState(NamedTuple):
    """Relative motions of the bushings: ``committed`` (3, nb, 6) d, d_dot, d_ddot at the
    last step, ``trial`` (2, nb, 6) d, d_dot of the current iterate."""
    committed: np.ndarray
    trial: np.ndarray


class BushingWork(NamedTuple):
    """Scratch of :func:`bushing_response`, allocated once per :func:`bushing_forces`."""
    M33: np.ndarray         # (13, 3, 3) rotations, Ts^-1, B's blocks, geometric terms
    V3: np.ndarray          # (8, 3) vectors
    v4: np.ndarray          # (4,) log_matrix work
    s: np.ndarray           # (6,) connector forces
    B: np.ndarray           # (6, 12) dd/d(x_a, w_a, x_b, w_b)
    fe: np.ndarray          # (12,) nodal force
    Ke: np.ndarray          # (12, 12) tangent


@njit(cache=True)
def bushing_work():
    """A fresh :class:`BushingWork`."""
    return BushingWork(np.empty((13, 3, 3)), np.empty((8, 3)), np.empty(4), np.empty(6),
                       np.empty((6, 12)), np.empty(12), np.empty((12, 12)))


@njit(cache=True)
def _mat_t_vec(R, v, out):
    """out = R^T v (3)."""
    for i in range(3):
        out[i] = R[0, i] * v[0] + R[1, i] * v[1] + R[2, i] * v[2]


@njit(cache=True)
def _mat_vec(R, v, out):
    """out = R v (3)."""
    for i in range(3):
        out[i] = R[i, 0] * v[0] + R[i, 1] * v[1] + R[i, 2] * v[2]


@njit(cache=True)
def bushing_forces(bushings, x, quat, rates, state, f, band, bw):
    """Add every bushing's nodal force to ``f`` and its tangent to ``band`` (LAPACK band
    storage, half bandwidth ``bw``); the trial relative motions into ``state.trial``.
    ``x`` (n_nodes, 3) current positions, ``quat`` (n_nodes, 4) nodal quaternions, ``rates``
    the step's Newmark coefficients (:class:`harnesspipe.fe.solvers.newmark.Rates`)."""
    work = bushing_work()
    for k in range(bushings.pairs.shape[0]):
        bushing_response(k, bushings, x, quat, rates, state, work)
        scatter_pair(bushings.pairs[k, 0], bushings.pairs[k, 1], work.fe, work.Ke, f, band, bw)


@njit(cache=True)
def bushing_response(k, bushings, x, quat, rates, state, work):
    """Relative motion ``d``, its rate ``d_dot`` (into ``state.trial[:, k]``), nodal force
    ``work.fe`` (12) and tangent ``work.Ke`` of bushing ``k``.

    The connector state at the last step is ``state.committed[:, k]``; node blocks of f
    and K: (x_a, w_a, x_b, w_b).
    """
    a, b = bushings.pairs[k, 0], bushings.pairs[k, 1]
    dX, E0, k_diag, alpha = bushings.dX[k], bushings.E0[k], bushings.k_diag[k], bushings.alpha
    d_n, d_dot_n, d_ddot_n = state.committed[0, k], state.committed[1, k], state.committed[2, k]
    d, d_dot = state.trial[0, k], state.trial[1, k]
    Ra, Rb, Rrel, Tinv = work.M33[0], work.M33[1], work.M33[2], work.M33[3]
    theta, dx, rel, tmp = work.V3[0], work.V3[1], work.V3[2], work.V3[3]
    g, m, tm, h = work.V3[4], work.V3[5], work.V3[6], work.V3[7]
    s, f = work.s, work.fe
    quat_to_matrix(quat[a], Ra)
    quat_to_matrix(quat[b], Rb)
    for i in range(3):
        for j in range(3):
            Rrel[i, j] = Ra[0, i] * Rb[0, j] + Ra[1, i] * Rb[1, j] + Ra[2, i] * Rb[2, j]
    log_matrix(Rrel, theta, work.v4)
    for i in range(3):
        dx[i] = x[b, i] - x[a, i]
    _mat_t_vec(Ra, dx, rel)
    for i in range(3):
        rel[i] -= dX[i]
    _mat_t_vec(E0, rel, tmp)
    d[:3] = tmp
    _mat_t_vec(E0, theta, tmp)
    d[3:] = tmp
    for i in range(6):
        d_dot[i] = rates.c_d * (d[i] - d_n[i]) + rates.c_v * d_dot_n[i] + rates.c_a * d_ddot_n[i]
        s[i] = k_diag[i] * (d[i] + alpha * d_dot[i])
    # global force of the translational springs g = R_a E0 s_t, moment m = E0 s_r
    _mat_vec(E0, s[:3], tmp)
    _mat_vec(Ra, tmp, g)
    _mat_vec(E0, s[3:], m)
    ts_inv(theta, Tinv)
    _mat_t_vec(Tinv, m, tm)              # Ts^-T m
    _mat_vec(Ra, tm, h)                  # moment on node b
    for i in range(3):
        f[i] = -g[i]
        f[6 + i] = g[i]
        f[9 + i] = h[i]
        f[3 + i] = -h[i]
    f[3] += g[1] * dx[2] - g[2] * dx[1]  # + g x dx on node a
    f[4] += g[2] * dx[0] - g[0] * dx[2]
    f[5] += g[0] * dx[1] - g[1] * dx[0]
    _bushing_tangent(E0, k_diag, 1.0 + alpha * rates.c_d, work)


@njit(cache=True)
def _bushing_tangent(E0, k_diag, rate_factor, work):
    """K = B^T (1 + alpha c_d) K_eq14 B + geometric terms (see module docstring), from the
    rotations, vectors and moments :func:`bushing_response` left in ``work``."""
    Ra, Tinv = work.M33[0], work.M33[3]
    P, Q, W, Sdx, PS, Sg, Kh, Sh, M = (work.M33[4], work.M33[5], work.M33[6], work.M33[7],
                                       work.M33[8], work.M33[9], work.M33[10], work.M33[11],
                                       work.M33[12])
    theta, dx, g, m, h = work.V3[0], work.V3[1], work.V3[4], work.V3[5], work.V3[7]
    B, K = work.B, work.Ke
    # B rows: d_t = P (dxb - dxa) - P S(dx)^T dwa ... with P = E0^T Ra^T;
    #         d_r = Q (dwb - dwa), Q = E0^T Ts^-1 Ra^T
    for i in range(3):
        for j in range(3):
            P[i, j] = E0[0, i] * Ra[j, 0] + E0[1, i] * Ra[j, 1] + E0[2, i] * Ra[j, 2]
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += E0[k, i] * (Tinv[k, 0] * Ra[j, 0] + Tinv[k, 1] * Ra[j, 1]
                                   + Tinv[k, 2] * Ra[j, 2])
            Q[i, j] = acc
    skew(dx, Sdx)
    for i in range(3):                   # P S(dx): d_t = P (dxb - dxa) + P S(dx) dwa
        for j in range(3):
            PS[i, j] = P[i, 0] * Sdx[0, j] + P[i, 1] * Sdx[1, j] + P[i, 2] * Sdx[2, j]
    B[:, :] = 0.0
    for i in range(3):
        for j in range(3):
            B[i, j] = -P[i, j]
            B[i, 3 + j] = PS[i, j]
            B[i, 6 + j] = P[i, j]
            B[3 + i, 3 + j] = -Q[i, j]
            B[3 + i, 9 + j] = Q[i, j]
    for i in range(12):
        for j in range(12):
            acc = 0.0
            for a in range(6):
                if B[a, i] != 0.0 and B[a, j] != 0.0:
                    acc += B[a, i] * k_diag[a] * B[a, j]
            K[i, j] = rate_factor * acc
    # geometric terms of the translational springs
    skew(g, Sg)
    for i in range(3):
        for j in range(3):
            K[6 + i, 3 + j] -= Sg[i, j]
            K[i, 3 + j] += Sg[i, j]
            K[3 + i, 6 + j] += Sg[i, j]
            K[3 + i, j] -= Sg[i, j]
            K[3 + i, 3 + j] += Sdx[i, 0] * Sg[0, j] + Sdx[i, 1] * Sg[1, j] + Sdx[i, 2] * Sg[2, j]
    # geometric terms of the rotational springs: dh = -S(h) dwa + Ra Kh Ra^T (dwb - dwa)
    kh_matrix(theta, m, Tinv, M, Kh)
    for i in range(3):
        for j in range(3):
            W[i, j] = Kh[i, 0] * Ra[j, 0] + Kh[i, 1] * Ra[j, 1] + Kh[i, 2] * Ra[j, 2]
    skew(h, Sh)
    for i in range(3):
        for j in range(3):
            G = Ra[i, 0] * W[0, j] + Ra[i, 1] * W[1, j] + Ra[i, 2] * W[2, j]
            K[9 + i, 9 + j] += G
            K[9 + i, 3 + j] -= G + Sh[i, j]
            K[3 + i, 9 + j] -= G
            K[3 + i, 3 + j] += G + Sh[i, j]
