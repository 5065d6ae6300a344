"""3D co-rotational two-node beam with a fibre section.

Formulation: Battini & Pacoste (2002), "Co-rotational beam elements with warping
effects in instability problems", CMAME 191, 1755-1789 (after Crisfield 1990 and
Crisfield 1997, vol. 2, ch. 17), without warping:

* global nodal unknowns: displacements and rotations stored as unit quaternions,
  updated with spatial spins (:mod:`harnesspipe.fe.rotation`);
* the co-rotated frame ``Rr = [r1 r2 r3]`` follows the chord and the mean of the
  nodal ``y`` axes; local rotations are ``theta_i = log(Rr^T R_i R0)``;
* local element: small-strain Bernoulli beam (linear axial, cubic Hermite bending)
  with ``u = l_n - l_0``, integrated by Gauss-Lobatto points along the length and
  the fibre section of :mod:`harnesspipe.fe.materials.fiber` at each point;
* ``f_g = B^T f_a`` and ``K_g = B^T K_a B + K_m`` with the geometric terms K_h
  (change of Ts^-1 with theta) and K_m (change of the frame) of Battini & Pacoste.

Local degrees of freedom ``q_l = (u, theta_1 (3), theta_2 (3))``; global per node
``(u_x, u_y, u_z, w_x, w_y, w_z)``.  History variables (signed and accumulated plastic
strain per element, Gauss point and fibre) are read from the committed arrays and
written to trial arrays; the caller commits them on a converged increment.

All work arrays are allocated once per assembly call, never per element.  The element
takes its section, material, history and work arrays as named groups
(:class:`FibreSection`, :class:`FibreMaterial`, :class:`FibreHistory`, :class:`BeamWork`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from harnesspipe.fe.materials.fiber import (FibreHistory, FibreMaterial, FibreSection,
                                            section_response)
from harnesspipe.fe.rotation import kh_matrix, log_matrix, quat_to_matrix, skew, ts_inv

NDOF_NODE = 6
NDOF_ELEM = 12
BANDWIDTH = 2 * NDOF_NODE - 1  # half bandwidth of a chain of two-node elements
STRAIN_DOFS = ((0, 0), (2, 5), (3, 6))  # local dofs of e0 (u; 2nd coefficient 0), kappa_y, kappa_z


class BeamMesh(NamedTuple):
    """Elements of one fibre section and material (:func:`assemble_beams`)."""
    X: np.ndarray           # (n_nodes, 3) initial positions
    conn: np.ndarray        # (n_el, 2) node ids
    R0: np.ndarray          # (n_el, 3, 3) initial element frames
    xi_g: np.ndarray        # (ng,) Gauss-Lobatto points along the element
    w_g: np.ndarray         # (ng,) their weights


class BeamElement(NamedTuple):
    """Reference of one element: end nodes ``X1, X2`` (3,), initial frame ``R0`` (3, 3),
    the Gauss-Lobatto rule ``xi_g, w_g`` (ng,) on [0, 1]."""
    X1: np.ndarray
    X2: np.ndarray
    R0: np.ndarray
    xi_g: np.ndarray
    w_g: np.ndarray


class NodePair(NamedTuple):
    """Current end nodes ``x1, x2`` (3,) and their quaternions ``q1, q2`` (4,)."""
    x1: np.ndarray
    x2: np.ndarray
    q1: np.ndarray
    q2: np.ndarray


class BeamWork(NamedTuple):
    """Work arrays of :func:`element_response`."""
    M33: np.ndarray         # (10, 3, 3) nodal and frame rotations, Ts^-1, K_h, work
    V3: np.ndarray          # (6, 3) local rotations, K_h moments, nodal positions
    v4: np.ndarray          # (4,) log_matrix work
    fl: np.ndarray          # (7,) local force
    Kl: np.ndarray          # (7, 7) local tangent
    fa: np.ndarray          # (7,) force conjugate to the local rotation vectors
    Ka: np.ndarray          # (7, 7) its tangent
    s: np.ndarray           # (3,) section resultants
    D: np.ndarray           # (3, 3) section tangent
    B: np.ndarray           # (3, 7) strain coefficients
    Gt: np.ndarray          # (3, 12) G^T
    Bg: np.ndarray          # (7, 12) B
    t12: np.ndarray         # (11, 12) tangent work
    W77: np.ndarray         # (7, 7) tangent work


@njit(cache=True, inline="always")
def beam_work():
    """A fresh :class:`BeamWork` (inlined: the caller sees the allocations)."""
    return BeamWork(np.empty((10, 3, 3)), np.empty((6, 3)), np.empty(4), np.empty(7),
                    np.empty((7, 7)), np.empty(7), np.empty((7, 7)), np.empty(3),
                    np.empty((3, 3)), np.empty((3, 7)), np.empty((3, 12)), np.empty((7, 12)),
                    np.empty((11, 12)), np.empty((7, 7)))


def lobatto_points(n_gauss: int = 3):
    """Gauss-Lobatto points and weights on [0, 1] (end points included)."""
    rules = {
        2: ([0.0, 1.0], [0.5, 0.5]),
        3: ([0.0, 0.5, 1.0], [1 / 6, 2 / 3, 1 / 6]),
        4: ([0.0, 0.5 - np.sqrt(5) / 10, 0.5 + np.sqrt(5) / 10, 1.0], [1 / 12, 5 / 12, 5 / 12, 1 / 12]),
        5: ([0.0, 0.5 - np.sqrt(21) / 14, 0.5, 0.5 + np.sqrt(21) / 14, 1.0],
            [1 / 20, 49 / 180, 16 / 45, 49 / 180, 1 / 20]),
    }
    if n_gauss not in rules:
        raise ValueError(f"n_gauss must be one of {sorted(rules)}, got {n_gauss}")
    xi, w = rules[n_gauss]
    return np.array(xi), np.array(w)


def initial_frames(X, conn, up=(0.0, 1.0, 0.0)):
    """Initial element frames R0 (columns e1 along the chord, e2 near ``up``)."""
    up = np.broadcast_to(np.asarray(up, dtype=float), (conn.shape[0], 3))
    e1 = X[conn[:, 1]] - X[conn[:, 0]]
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e3 = np.cross(e1, up)
    along = np.linalg.norm(e3, axis=1) < 1e-8          # chord along ``up``: use z instead
    e3[along] = np.cross(e1[along], [0.0, 0.0, 1.0])
    e3 /= np.linalg.norm(e3, axis=1)[:, None]
    return np.stack((e1, np.cross(e3, e1), e3), axis=2)


@njit(cache=True)
def corotated_frame(x1, x2, Rg1, Rg2, R0, Rr, qv):
    """Co-rotated frame Rr of the current chord; returns l_n.

    ``qv`` (3x3 work) receives the columns q1, q2, q = (q1+q2)/2 with q_i = R_i R0 e2.
    """
    ln = 0.0
    for i in range(3):
        Rr[i, 0] = x2[i] - x1[i]
        ln += Rr[i, 0] ** 2
    ln = np.sqrt(ln)
    for i in range(3):
        Rr[i, 0] /= ln
        a = 0.0
        b = 0.0
        for k in range(3):
            a += Rg1[i, k] * R0[k, 1]
            b += Rg2[i, k] * R0[k, 1]
        qv[i, 0] = a
        qv[i, 1] = b
        qv[i, 2] = 0.5 * (a + b)
    r1 = Rr[:, 0]
    q = qv[:, 2]
    Rr[0, 2] = r1[1] * q[2] - r1[2] * q[1]
    Rr[1, 2] = r1[2] * q[0] - r1[0] * q[2]
    Rr[2, 2] = r1[0] * q[1] - r1[1] * q[0]
    s = np.sqrt(Rr[0, 2] ** 2 + Rr[1, 2] ** 2 + Rr[2, 2] ** 2)
    for i in range(3):
        Rr[i, 2] /= s
    Rr[0, 1] = Rr[1, 2] * r1[2] - Rr[2, 2] * r1[1]
    Rr[1, 1] = Rr[2, 2] * r1[0] - Rr[0, 2] * r1[2]
    Rr[2, 1] = Rr[0, 2] * r1[1] - Rr[1, 2] * r1[0]
    return ln


@njit(cache=True)
def local_rotation(Rr, Rg, R0, Rbar, theta, work4):
    """Local rotation vector theta = log(Rr^T Rg R0)."""
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(3):
                t = 0.0
                for m in range(3):
                    t += Rg[k, m] * R0[m, j]
                s += Rr[k, i] * t
            Rbar[i, j] = s
    log_matrix(Rbar, theta, work4)


@njit(cache=True)
def local_bernoulli(u, th1, th2, l0, xi_g, w_g, sec, mat, elastic, hist, work):
    """Local force ``work.fl`` (7) and tangent ``work.Kl`` (7x7) of the small-strain
    Bernoulli element (section ``sec``, material ``mat``, history ``hist``:
    :class:`FibreSection`, :class:`FibreMaterial`, :class:`FibreHistory`; ``work`` a
    :class:`BeamWork`).

    Generalised strains at xi: e0 = u/l0, kappa_y = ((6xi-4) th1_y + (6xi-2) th2_y)/l0,
    kappa_z likewise with the z rotations; torsion elastic, GJ (th2_x - th1_x)/l0.
    ``work.B`` (3x7): ``B[a, :2]`` holds the nonzero coefficients of strain a at
    the local dofs ``STRAIN_DOFS[a]``, so fl = int B^T s and Kl = int B^T D B touch
    only the nonzero entries.
    """
    fl, Kl, s, D, B = work.fl, work.Kl, work.s, work.D, work.B
    for i in range(7):
        fl[i] = 0.0
        for j in range(7):
            Kl[i, j] = 0.0
    e0 = u / l0
    for g in range(xi_g.shape[0]):
        xi = xi_g[g]
        b1 = (6.0 * xi - 4.0) / l0
        b2 = (6.0 * xi - 2.0) / l0
        ky = b1 * th1[1] + b2 * th2[1]
        kz = b1 * th1[2] + b2 * th2[2]
        section_response(e0, ky, kz, sec, mat, elastic, hist, g, s, D)
        wl = w_g[g] * l0
        B[0, 0] = 1.0 / l0      # nonzero coefficients of B, at the dofs STRAIN_DOFS
        B[0, 1] = 0.0
        B[1, 0] = B[2, 0] = b1
        B[1, 1] = B[2, 1] = b2
        for a in range(3):
            for p in range(2):
                i = STRAIN_DOFS[a][p]
                ca = wl * B[a, p]
                fl[i] += ca * s[a]
                for b in range(3):
                    cab = ca * D[a, b]
                    for q in range(2):
                        Kl[i, STRAIN_DOFS[b][q]] += cab * B[b, q]
    kt = sec.GJ / l0
    torque = kt * (th2[0] - th1[0])
    fl[1] -= torque
    fl[4] += torque
    Kl[1, 1] += kt
    Kl[4, 4] += kt
    Kl[1, 4] -= kt
    Kl[4, 1] -= kt


@njit(cache=True)
def _g_matrix(Rr, qv, ln, Gt):
    """G^T (3x12) of Battini & Pacoste: d(spin of Rr, local) = G^T E^T dp; returns eta."""
    ql1 = 0.0
    ql2 = 0.0
    a11 = 0.0
    a12 = 0.0
    a21 = 0.0
    a22 = 0.0
    for k in range(3):
        ql1 += Rr[k, 0] * qv[k, 2]
        ql2 += Rr[k, 1] * qv[k, 2]
        a11 += Rr[k, 0] * qv[k, 0]
        a12 += Rr[k, 1] * qv[k, 0]
        a21 += Rr[k, 0] * qv[k, 1]
        a22 += Rr[k, 1] * qv[k, 1]
    eta = ql1 / ql2
    for i in range(3):
        for j in range(12):
            Gt[i, j] = 0.0
    Gt[0, 2] = eta / ln
    Gt[0, 3] = 0.5 * a12 / ql2
    Gt[0, 4] = -0.5 * a11 / ql2
    Gt[0, 8] = -eta / ln
    Gt[0, 9] = 0.5 * a22 / ql2
    Gt[0, 10] = -0.5 * a21 / ql2
    Gt[1, 2] = 1.0 / ln
    Gt[1, 8] = -1.0 / ln
    Gt[2, 1] = -1.0 / ln
    Gt[2, 7] = 1.0 / ln
    return eta


@njit(cache=True)
def _b_matrix(Rr, Gt, Bg):
    """B (7x12) = [r ; P E^T] mapping global variations to (u, w1_bar, w2_bar)."""
    for j in range(12):
        Bg[0, j] = 0.0
    for i in range(3):
        Bg[0, i] = -Rr[i, 0]
        Bg[0, 6 + i] = Rr[i, 0]
    for node in range(2):
        for i in range(3):
            for blk in range(4):
                for j in range(3):
                    s = 0.0
                    for k in range(3):
                        p = -Gt[i, 3 * blk + k]
                        if (blk == 1 and node == 0) or (blk == 3 and node == 1):
                            if k == i:
                                p += 1.0
                        s += p * Rr[j, k]
                    Bg[1 + 3 * node + i, 3 * blk + j] = s


@njit(cache=True)
def element_response(ref, cur, sec, mat, elastic, hist, want_tangent, fg, Kg, work):
    """Global internal force ``fg`` (12) and, if ``want_tangent``, tangent ``Kg`` (12x12).

    ``ref`` the element's :class:`BeamElement`, ``cur`` its current :class:`NodePair`;
    ``sec`` a :class:`FibreSection`, ``mat`` a :class:`FibreMaterial`, ``elastic`` skips
    the return map, ``hist`` a :class:`FibreHistory` (trial arrays written); ``work`` a
    :class:`BeamWork`.
    """
    X1, X2, R0, xi_g, w_g = ref
    x1, x2, q1, q2 = cur
    M33, V3, v4, fl, Kl, fa, Ka, s, D, B, Gt, Bg, t12, W77 = work
    Rg1 = M33[0]
    Rg2 = M33[1]
    Rr = M33[2]
    qv = M33[3]
    Rbar = M33[4]
    T1 = M33[5]
    T2 = M33[6]
    H = M33[7]
    Sn = M33[8]
    wk = M33[9]
    th1 = V3[0]
    th2 = V3[1]
    quat_to_matrix(q1, Rg1)
    quat_to_matrix(q2, Rg2)
    ln = corotated_frame(x1, x2, Rg1, Rg2, R0, Rr, qv)
    l0 = np.sqrt((X2[0] - X1[0]) ** 2 + (X2[1] - X1[1]) ** 2 + (X2[2] - X1[2]) ** 2)
    local_rotation(Rr, Rg1, R0, Rbar, th1, v4)
    local_rotation(Rr, Rg2, R0, Rbar, th2, v4)
    local_bernoulli(ln - l0, th1, th2, l0, xi_g, w_g, sec, mat, elastic, hist, work)
    ts_inv(th1, T1)
    ts_inv(th2, T2)
    # f_a = B_a^T f_l with B_a = diag(1, Ts^-1(th1), Ts^-1(th2))
    fa[0] = fl[0]
    for i in range(3):
        a = 0.0
        b = 0.0
        for k in range(3):
            a += T1[k, i] * fl[1 + k]
            b += T2[k, i] * fl[4 + k]
        fa[1 + i] = a
        fa[4 + i] = b
    eta = _g_matrix(Rr, qv, ln, Gt)
    _b_matrix(Rr, Gt, Bg)
    for j in range(12):
        acc = 0.0
        for i in range(7):
            acc += Bg[i, j] * fa[i]
        fg[j] = acc
    if not want_tangent:
        return
    _tangent_a(Kl, T1, T2, th1, th2, fl, Ka, H, wk, V3[2], W77)
    _tangent_global(Ka, Bg, Rr, qv, Gt, fa, ln, eta, Kg, Sn, Rbar, t12)


@njit(cache=True)
def _tangent_a(Kl, T1, T2, th1, th2, fl, Ka, H, wk, v, W):
    """K_a = B_a^T K_l B_a + diag(0, K_h(th1, m1), K_h(th2, m2)), B_a = diag(1, T1, T2).

    ``W`` (7x7) is work; the products use the block structure of B_a.
    """
    for i in range(7):  # W = K_l B_a
        W[i, 0] = Kl[i, 0]
        for j in range(3):
            a = 0.0
            b = 0.0
            for k in range(3):
                a += Kl[i, 1 + k] * T1[k, j]
                b += Kl[i, 4 + k] * T2[k, j]
            W[i, 1 + j] = a
            W[i, 4 + j] = b
    for j in range(7):  # K_a = B_a^T W
        Ka[0, j] = W[0, j]
        for i in range(3):
            a = 0.0
            b = 0.0
            for k in range(3):
                a += T1[k, i] * W[1 + k, j]
                b += T2[k, i] * W[4 + k, j]
            Ka[1 + i, j] = a
            Ka[4 + i, j] = b
    for node in range(2):
        T = T1 if node == 0 else T2
        th = th1 if node == 0 else th2
        for k in range(3):
            v[k] = fl[1 + 3 * node + k]
        kh_matrix(th, v, T, wk, H)
        for i in range(3):
            for j in range(3):
                Ka[1 + 3 * node + i, 1 + 3 * node + j] += H[i, j]


@njit(cache=True)
def _tangent_global(Ka, Bg, Rr, qv, Gt, fa, ln, eta, Kg, Sn, EQ, t12):
    """K_g = B^T K_a B + D N - E Q G^T E^T - E d(G m)/dp  (after Battini & Pacoste 2002).

    The last term is the full variation of G at fixed moments (including the eta
    ratios), so the tangent is consistent also for large local rotations.
    """
    KB = t12[4:11]  # K_a B (7x12)
    for a in range(7):
        for j in range(12):
            acc = 0.0
            for b in range(7):
                acc += Ka[a, b] * Bg[b, j]
            KB[a, j] = acc
    for i in range(12):
        for j in range(12):
            acc = 0.0
            for a in range(7):
                acc += Bg[a, i] * KB[a, j]
            Kg[i, j] = acc
    # D N: D3 = (I - r1 r1^T)/l_n on the translational blocks
    N = fa[0]
    for i in range(3):
        for j in range(3):
            d = ((1.0 if i == j else 0.0) - Rr[i, 0] * Rr[j, 0]) / ln * N
            Kg[i, j] += d
            Kg[6 + i, 6 + j] += d
            Kg[i, 6 + j] -= d
            Kg[6 + i, j] -= d
    # n = P^T m_bar (12, local components), P = [[0 I 0 0]; [0 0 0 I]] - [G^T; G^T]
    nv = t12[0]
    for j in range(12):
        acc = 0.0
        for k in range(3):
            acc -= Gt[k, j] * (fa[1 + k] + fa[4 + k])
        nv[j] = acc
    for k in range(3):
        nv[3 + k] += fa[1 + k]
        nv[9 + k] += fa[4 + k]
    # E Q (12x3) with Q = [S(n1); S(n2); S(n3); S(n4)];  G^T E^T (3x12)
    GtEt = t12[1:4]
    for i in range(3):
        for blk in range(4):
            for j in range(3):
                acc = 0.0
                for k in range(3):
                    acc += Gt[i, 3 * blk + k] * Rr[j, k]
                GtEt[i, 3 * blk + j] = acc
    for blk in range(4):
        skew(nv[3 * blk:3 * blk + 3], Sn)
        for i in range(3):
            for j in range(3):
                acc = 0.0
                for k in range(3):
                    acc += Rr[i, k] * Sn[k, j]
                EQ[i, j] = acc
        for i in range(3):
            for c in range(12):
                acc = 0.0
                for k in range(3):
                    acc += EQ[i, k] * GtEt[k, c]
                Kg[3 * blk + i, c] -= acc
    _frame_curvature(Rr, qv, GtEt, ln, eta, fa, Bg, Kg)


@njit(cache=True)
def _local_components(Rr, qv, col):
    """Components (tuple) of the column ``col`` of qv in the frame Rr."""
    a = Rr[0, 0] * qv[0, col] + Rr[1, 0] * qv[1, col] + Rr[2, 0] * qv[2, col]
    b = Rr[0, 1] * qv[0, col] + Rr[1, 1] * qv[1, col] + Rr[2, 1] * qv[2, col]
    c = Rr[0, 2] * qv[0, col] + Rr[1, 2] * qv[1, col] + Rr[2, 2] * qv[2, col]
    return (a, b, c)


@njit(cache=True)
def _frame_curvature(Rr, qv, GtEt, ln, eta, fa, Bg, Kg):
    """Add -E d(G m)/dp, the change of G (through l_n and the eta ratios) at fixed m.

    m = m1_bar + m2_bar (local).  The local components ql, q1l, q2l of q, q1, q2 vary
    with the frame spin w_r = G^T E^T dp and the nodal spins w_i:
    d ql = S(ql) w_r - (S(q1l) w_1 + S(q2l) w_2)/2,  d qil = S(qil) (w_r - w_i).
    """
    m1 = fa[1] + fa[4]
    m2 = fa[2] + fa[5]
    m3 = fa[3] + fa[6]
    ql = _local_components(Rr, qv, 2)
    q1l = _local_components(Rr, qv, 0)
    q2l = _local_components(Rr, qv, 1)
    e11 = q1l[0] / ql[1]
    e12 = q1l[1] / ql[1]
    e21 = q2l[0] / ql[1]
    e22 = q2l[1] / ql[1]
    for c in range(12):
        wr0, wr1, wr2 = GtEt[0, c], GtEt[1, c], GtEt[2, c]
        w10 = w11 = w12 = w20 = w21 = w22 = 0.0
        if 3 <= c < 6:
            w10, w11, w12 = Rr[c - 3, 0], Rr[c - 3, 1], Rr[c - 3, 2]
        elif c >= 9:
            w20, w21, w22 = Rr[c - 9, 0], Rr[c - 9, 1], Rr[c - 9, 2]
        # first two components of the cross products a x b
        dq0 = (ql[1] * wr2 - ql[2] * wr1) - 0.5 * ((q1l[1] * w12 - q1l[2] * w11) + (q2l[1] * w22 - q2l[2] * w21))
        dq1 = (ql[2] * wr0 - ql[0] * wr2) - 0.5 * ((q1l[2] * w10 - q1l[0] * w12) + (q2l[2] * w20 - q2l[0] * w22))
        d10 = q1l[1] * (wr2 - w12) - q1l[2] * (wr1 - w11)
        d11 = q1l[2] * (wr0 - w10) - q1l[0] * (wr2 - w12)
        d20 = q2l[1] * (wr2 - w22) - q2l[2] * (wr1 - w21)
        d21 = q2l[2] * (wr0 - w20) - q2l[0] * (wr2 - w22)
        deta = (dq0 - eta * dq1) / ql[1]
        de11 = (d10 - e11 * dq1) / ql[1]
        de12 = (d11 - e12 * dq1) / ql[1]
        de21 = (d20 - e21 * dq1) / ql[1]
        de22 = (d21 - e22 * dq1) / ql[1]
        dinv = -Bg[0, c] / (ln * ln)      # d(1/l_n)
        g2 = m1 * deta / ln + (eta * m1 + m2) * dinv
        # d(G m) column c in local components, blocks (node-1 u, w, node-2 u, w)
        for i in range(3):
            Kg[i, c] -= Rr[i, 2] * g2 - Rr[i, 1] * m3 * dinv
            Kg[6 + i, c] -= Rr[i, 1] * m3 * dinv - Rr[i, 2] * g2
            Kg[3 + i, c] -= 0.5 * m1 * (Rr[i, 0] * de12 - Rr[i, 1] * de11)
            Kg[9 + i, c] -= 0.5 * m1 * (Rr[i, 0] * de22 - Rr[i, 1] * de21)


def band_width(conn) -> int:
    """Half bandwidth of the node-wise dof ordering for the connectivity ``conn``."""
    return NDOF_NODE * int(np.max(np.abs(conn[:, 1] - conn[:, 0]))) + NDOF_NODE - 1


@njit(cache=True)
def scatter_element(a, b, fe, Ke, want_tangent, f, band, bw):
    """Add an element vector (and matrix, in LAPACK band storage) of nodes a, b."""
    for i in range(12):
        gi = NDOF_NODE * (a if i < 6 else b) + i % 6
        f[gi] += fe[i]
        if want_tangent:
            for j in range(12):
                gj = NDOF_NODE * (a if j < 6 else b) + j % 6
                band[bw + gi - gj, gj] += Ke[i, j]


@njit(cache=True)
def assemble_beams(mesh, u, quat, sec, mat, elastic, hist, hist_trial, want_tangent, f, band,
                   bw):
    """Internal force ``f`` and (if ``want_tangent``) the tangent in band storage of the
    elements of ``mesh`` (:class:`BeamMesh`) at the nodal displacements ``u`` (n_nodes, 3)
    and rotations ``quat`` (n_nodes, 4), section ``sec`` (:class:`FibreSection`), material
    ``mat`` (:class:`FibreMaterial`, ``elastic``: no return map).

    ``band[bw + i - j, j] = K[i, j]`` (the layout of scipy.linalg.solve_banded).  History
    (2, n_el, ng, nf), rows signed plastic strain and accumulated plastic strain: the trial
    one is written to ``hist_trial``; the committed ``hist`` is only read.
    """
    X, conn, R0 = mesh.X, mesh.conn, mesh.R0
    f[:] = 0.0
    if want_tangent:
        band[:, :] = 0.0
    work = beam_work()
    fe = np.empty(12)
    Ke = np.zeros((12, 12))
    x1 = work.V3[4]
    x2 = work.V3[5]
    for e in range(conn.shape[0]):
        a = conn[e, 0]
        b = conn[e, 1]
        for i in range(3):
            x1[i] = X[a, i] + u[a, i]
            x2[i] = X[b, i] + u[b, i]
        element_response(BeamElement(X[a], X[b], R0[e], mesh.xi_g, mesh.w_g),
                         NodePair(x1, x2, quat[a], quat[b]), sec, mat, elastic,
                         FibreHistory(hist[0, e], hist[1, e], hist_trial[0, e], hist_trial[1, e]),
                         want_tangent, fe, Ke, work)
        scatter_element(a, b, fe, Ke, want_tangent, f, band, bw)


@njit(cache=True)
def element_mass_lumped(l0, rho, A, Ip, Iy, Iz, out):
    """Lumped mass diagonal (12): half the translational mass and half the rotary
    inertia of the slice, rho l0/2 (A, A, A, Ip, Iy, Iz), at each node."""
    h = 0.5 * rho * l0
    for node in range(2):
        o = 6 * node
        out[o] = out[o + 1] = out[o + 2] = h * A
        out[o + 3] = h * Ip
        out[o + 4] = h * Iy
        out[o + 5] = h * Iz


@njit(cache=True)
def element_mass_consistent(l0, rho, A, Ip, Rr, out, Ml):
    """Consistent mass (12x12) in global axes, M = E M_l E^T with E = diag(Rr x 4).

    M_l: linear axial/torsion shape functions and cubic Hermite bending functions of
    the local Bernoulli element (Przemieniecki 1968, ch. 11); rotary inertia of bending
    neglected.  ``Ml`` is a 12x12 work array.
    """
    Ml[:, :] = 0.0
    m = rho * A * l0
    for i, j, v in ((0, 0, 2.0), (0, 6, 1.0), (6, 6, 2.0)):   # axial
        Ml[i, j] = Ml[j, i] = m * v / 6.0
    for i, j, v in ((3, 3, 2.0), (3, 9, 1.0), (9, 9, 2.0)):   # torsion
        Ml[i, j] = Ml[j, i] = rho * Ip * l0 * v / 6.0
    L = l0
    # bending in x-y (v, theta_z) and x-z (w, theta_y = -w')
    for t, r, sg in ((1, 5, 1.0), (2, 4, -1.0)):
        a = m / 420.0
        ids = (t, r, t + 6, r + 6)
        vals = ((156.0, 22.0 * L * sg, 54.0, -13.0 * L * sg),
                (22.0 * L * sg, 4.0 * L * L, 13.0 * L * sg, -3.0 * L * L),
                (54.0, 13.0 * L * sg, 156.0, -22.0 * L * sg),
                (-13.0 * L * sg, -3.0 * L * L, -22.0 * L * sg, 4.0 * L * L))
        for p in range(4):
            for q in range(4):
                Ml[ids[p], ids[q]] = a * vals[p][q]
    for bi in range(4):
        for bj in range(4):
            for i in range(3):
                for j in range(3):
                    acc = 0.0
                    for k in range(3):
                        for l in range(3):
                            acc += Rr[i, k] * Ml[3 * bi + k, 3 * bj + l] * Rr[j, l]
                    out[3 * bi + i, 3 * bj + j] = acc
