"""Penalty contact of beam elements with rigid cylinders, with regularised Coulomb friction.

Geometry.  The beam is a tube of radius ``r_beam`` around its centreline; a rigid
cylinder has an axis through ``centre`` along the unit vector ``axis`` and radius
``R``.  The gap is the distance of the centreline from the axis minus ``R + r_beam``.
The centreline of each co-rotational element is its local cubic (Hermite)
interpolation of the nodal rotations, so the closest point slides smoothly along
the beam instead of jumping from node to node (beam-to-rigid-surface contact,
Wriggers 2006, ch. 11, with the closest point found by Newton on the element
parameter xi in [0, 1]).  A closest point at an element end is counted once: by the
element it is interior to, or at a kink by the element after the node.

Transfer.  The contact point moves with the nodal variations through the linear
Bernoulli interpolation in the co-rotated frame: axial part linear, transverse part
Hermite cubic (H1, l H2, H3, l H4) in the nodal translations and spins.  This ``T``
(3x12) is exact for rigid motions; the element force is ``T^T f``.

Tangent.  The element's contact force depends on its 12 nodal variables also
through T, the co-rotated frame and the closest-point parameter (the point slides
along the beam).  The consistent element tangent is therefore taken by forward
differences of the element force (perturbed translations, spatial spins applied as
in the nodal update; closest point found again each time), which keeps Newton
quadratic (the tangent ``T^T C T`` at a frozen T and contact point converged only
linearly, about 0.03 per iteration).

Normal law: ``p = k_n max(-g, 0)`` (two-sided near the surface for a loaded cylinder,
see ACTIVE_GAP).  Friction (optional, mu > 0): tangential
penalty ``k_t`` in the plane normal to the axis, trial ``f_t = f_t,old + k_t dg_t``
with ``dg_t`` the tangential slip of the material point since the last converged
increment, return to ``|f_t| = mu p`` when it slips.  The tangential history is
kept per (cylinder, element) and committed by the caller; when the contact point
crosses a node its stick force restarts at zero (immaterial once sliding).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from harnesspipe.fe.elements.beam import corotated_frame, local_rotation, scatter_element
from harnesspipe.fe.rotation import quat_mul, quat_to_matrix, rotate_spatial, rotvec_from_quat

NEWTON_IT = 20
# Active set frozen per increment: a cylinder that carried load at the last converged
# increment (``bilateral``) acts on its closest points as a two-sided spring while the
# gap is below ACTIVE_GAP * (R + r_beam).  An iterate that overshoots the surface then
# keeps its support and Newton stays quadratic; the caller releases a cylinder whose
# converged reaction turns tensile and repeats the increment.
ACTIVE_GAP = 1.0e-2
FAR, INTERIOR, AT_START, AT_END = 0, 1, 2, 3
FD_STEP = 1.0e-7   # forward-difference step of the contact tangent (relative to r_beam / 1 rad)


@njit(cache=True)
def centreline(xi, x1, Rr, ln, th1, th2, X, dX, ddX):
    """Point, first and second xi-derivative of the element's cubic centreline."""
    h2 = xi * (1.0 - xi) ** 2
    h4 = -xi * xi * (1.0 - xi)
    d2 = 1.0 - 4.0 * xi + 3.0 * xi * xi
    d4 = -2.0 * xi + 3.0 * xi * xi
    dd2 = -4.0 + 6.0 * xi
    dd4 = -2.0 + 6.0 * xi
    v = ln * (h2 * th1[2] + h4 * th2[2])
    w = -ln * (h2 * th1[1] + h4 * th2[1])
    dv = ln * (d2 * th1[2] + d4 * th2[2])
    dw = -ln * (d2 * th1[1] + d4 * th2[1])
    ddv = ln * (dd2 * th1[2] + dd4 * th2[2])
    ddw = -ln * (dd2 * th1[1] + dd4 * th2[1])
    for i in range(3):
        X[i] = x1[i] + xi * ln * Rr[i, 0] + v * Rr[i, 1] + w * Rr[i, 2]
        dX[i] = ln * Rr[i, 0] + dv * Rr[i, 1] + dw * Rr[i, 2]
        ddX[i] = ddv * Rr[i, 1] + ddw * Rr[i, 2]


@njit(cache=True)
def _perp(v, axis, out):
    """Component of v normal to the unit vector ``axis``."""
    d = v[0] * axis[0] + v[1] * axis[1] + v[2] * axis[2]
    for i in range(3):
        out[i] = v[i] - d * axis[i]


@njit(cache=True)
def closest_point(x1, Rr, ln, th1, th2, centre, axis, X, dX, ddX, dp, tp):
    """Parameter xi in [0, 1] of the centreline point closest to the cylinder axis.

    Minimises phi = |P (X(xi) - C)|^2 / 2 by Newton with the root kept in [0, 1].
    Returns (xi, status): INTERIOR (a minimum inside), AT_START / AT_END (clamped at an
    end, distance growing into the element) or FAR (a maximum).
    """
    # start from the projection of the axis point on the chord
    for i in range(3):
        dp[i] = centre[i] - x1[i]
    _perp(dp, axis, dp)
    _perp(Rr[:, 0], axis, tp)
    den = tp[0] ** 2 + tp[1] ** 2 + tp[2] ** 2
    xi = (dp[0] * tp[0] + dp[1] * tp[1] + dp[2] * tp[2]) / (ln * den) if den > 0.0 else 0.5
    xi = min(max(xi, 0.0), 1.0)
    for _ in range(NEWTON_IT):
        centreline(xi, x1, Rr, ln, th1, th2, X, dX, ddX)
        for i in range(3):
            dp[i] = X[i] - centre[i]
        _perp(dp, axis, dp)
        _perp(dX, axis, tp)
        g1 = dp[0] * dX[0] + dp[1] * dX[1] + dp[2] * dX[2]
        g2 = tp[0] ** 2 + tp[1] ** 2 + tp[2] ** 2 + dp[0] * ddX[0] + dp[1] * ddX[1] + dp[2] * ddX[2]
        if g2 <= 0.0:
            g2 = tp[0] ** 2 + tp[1] ** 2 + tp[2] ** 2
        step = -g1 / g2
        xi_new = min(max(xi + step, 0.0), 1.0)
        if abs(xi_new - xi) < 1e-13:
            xi = xi_new
            break
        xi = xi_new
    centreline(xi, x1, Rr, ln, th1, th2, X, dX, ddX)
    for i in range(3):
        dp[i] = X[i] - centre[i]
    _perp(dp, axis, dp)
    _perp(dX, axis, tp)
    slope = dp[0] * dX[0] + dp[1] * dX[1] + dp[2] * dX[2]
    curv = tp[0] ** 2 + tp[1] ** 2 + tp[2] ** 2 + dp[0] * ddX[0] + dp[1] * ddX[1] + dp[2] * ddX[2]
    if xi <= 0.0 and slope >= 0.0:
        return xi, AT_START
    if xi >= 1.0 and slope <= 0.0:
        return xi, AT_END
    if curv <= 0.0:  # a distance maximum (the beam wraps the cylinder): not a contact point
        return xi, FAR
    return xi, INTERIOR


@njit(cache=True)
def transfer_matrix(xi, Rr, ln, T):
    """T (3x12): variation of the contact point from the element's nodal variations."""
    l1, l3 = 1.0 - xi, xi
    h1 = 1.0 - 3.0 * xi * xi + 2.0 * xi ** 3
    h3 = 3.0 * xi * xi - 2.0 * xi ** 3
    h2 = ln * xi * (1.0 - xi) ** 2
    h4 = -ln * xi * xi * (1.0 - xi)
    for i in range(3):
        for j in range(3):
            rr = Rr[i, 0] * Rr[j, 0]
            pp = (1.0 if i == j else 0.0) - rr
            T[i, j] = l1 * rr + h1 * pp
            T[i, 6 + j] = l3 * rr + h3 * pp
    # w x r1 = -S(r1) w
    r = Rr[:, 0]
    for blk, h in ((3, h2), (9, h4)):
        T[0, blk + 0] = 0.0
        T[0, blk + 1] = h * r[2]
        T[0, blk + 2] = -h * r[1]
        T[1, blk + 0] = -h * r[2]
        T[1, blk + 1] = 0.0
        T[1, blk + 2] = h * r[0]
        T[2, blk + 0] = h * r[1]
        T[2, blk + 1] = -h * r[0]
        T[2, blk + 2] = 0.0


@njit(cache=True)
def _increment(x1, x2, x1c, x2c, qa, qb, qac, qbc, dp, qw, tv):
    """Nodal increments since the committed state (translations, spatial rotation vectors)."""
    for i in range(3):
        dp[i] = x1[i] - x1c[i]
        dp[6 + i] = x2[i] - x2c[i]
    for node in range(2):
        q = qa if node == 0 else qb
        qc = qac if node == 0 else qbc
        # q_inc = q * conj(q_c)
        qw[0] = qc[0]
        qw[1] = -qc[1]
        qw[2] = -qc[2]
        qw[3] = -qc[3]
        quat_mul(q, qw, qw)
        rotvec_from_quat(qw, tv)
        for i in range(3):
            dp[6 * node + 3 + i] = tv[i]


@njit(cache=True)
def _element_geometry(x1, x2, qa, qb, R0, M, th1, th2, q4):
    """Co-rotated frame (into M[2]) and local rotations of the element; returns l_n."""
    quat_to_matrix(qa, M[0])
    quat_to_matrix(qb, M[1])
    ln = corotated_frame(x1, x2, M[0], M[1], R0, M[2], M[3])
    local_rotation(M[2], M[0], R0, M[4], th1, q4)
    local_rotation(M[2], M[1], R0, M[4], th2, q4)
    return ln


@njit(cache=True)
def _closest_points(X0, conn, R0, u, quat, centre, axis, reach, status, xis, M, V, q4):
    """Closest point (xis) and its status on every element near one cylinder."""
    x1, x2, th1, th2, X, dX, ddX, wp, wt = V[0], V[1], V[2], V[3], V[4], V[5], V[6], V[7], V[8]
    for e in range(conn.shape[0]):
        a, b = conn[e, 0], conn[e, 1]
        for i in range(3):
            x1[i] = X0[a, i] + u[a, i]
            x2[i] = X0[b, i] + u[b, i]
        status[e] = FAR
        if _segment_distance(x1, x2, centre, axis, wp, wt) > reach + 0.5 * _norm_diff(x1, x2):
            continue
        ln = _element_geometry(x1, x2, quat[a], quat[b], R0[e], M, th1, th2, q4)
        xis[e], status[e] = closest_point(x1, M[2], ln, th1, th2, centre, axis, X, dX, ddX, wp, wt)


@njit(cache=True)
def element_contact(x1, x2, qa, qb, x1c, x2c, qac, qbc, R0, centre, centre_c, axis, reach,
                    bilateral, k_n, mu, k_t, ft_old, fe, M, V, q4, T, dp, two_sided=False):
    """Contact force of one element on one cylinder, as a residual ``fe`` (12).

    Inputs are the current end points and nodal quaternions and their committed
    values (for the frictional slip).  The closest point is searched on this element
    (clamped to it).  Returns ``(active, p, f_t)``; ``V[12]`` holds the force vector
    ``-p n + f_t t`` (the negative of the force on the beam).  ``two_sided`` keeps the
    contact active whatever the gap (the branch differentiated by the tangent).
    """
    th1, th2, X, dX, ddX, wp, wt = V[2], V[3], V[4], V[5], V[6], V[7], V[8]
    nvec, tvec, dc, fvec = V[9], V[10], V[11], V[12]
    Rr = M[2]
    ln = _element_geometry(x1, x2, qa, qb, R0, M, th1, th2, q4)
    xi, _ = closest_point(x1, Rr, ln, th1, th2, centre, axis, X, dX, ddX, wp, wt)
    centreline(xi, x1, Rr, ln, th1, th2, X, dX, ddX)
    for i in range(3):
        wp[i] = X[i] - centre[i]
    _perp(wp, axis, wp)
    d = np.sqrt(wp[0] ** 2 + wp[1] ** 2 + wp[2] ** 2)
    gap = d - reach
    if gap > (ACTIVE_GAP * reach if bilateral else 0.0) and not two_sided:
        fe[:] = 0.0
        return False, 0.0, 0.0
    for i in range(3):
        nvec[i] = wp[i] / d
    tvec[0] = axis[1] * nvec[2] - axis[2] * nvec[1]
    tvec[1] = axis[2] * nvec[0] - axis[0] * nvec[2]
    tvec[2] = axis[0] * nvec[1] - axis[1] * nvec[0]
    transfer_matrix(xi, Rr, ln, T)
    p = -k_n * gap if (gap < 0.0 or bilateral or two_sided) else 0.0
    f_t = 0.0
    if mu > 0.0:
        _increment(x1, x2, x1c, x2c, qa, qb, qac, qbc, dp, q4, wt)
        for i in range(3):
            dc[i] = centre[i] - centre_c[i]
        f_t = _friction(T, dp, dc, tvec, ft_old, p, mu, k_t)
    for i in range(3):
        fvec[i] = -p * nvec[i] + f_t * tvec[i]
    for j in range(12):
        fe[j] = T[0, j] * fvec[0] + T[1, j] * fvec[1] + T[2, j] * fvec[2]
    return True, p, f_t


@njit(cache=True)
def _element_tangent(x1, x2, qa, qb, x1c, x2c, qac, qbc, R0, centre, centre_c, axis, reach,
                     bilateral, k_n, mu, k_t, ft_old, fe, Ke, M, V, q4, T, dp, xp, qp, fp):
    """Ke = d fe / d(nodal translations, spins) by forward differences (see module doc).

    The perturbed states keep the contact active (the active branch's derivative,
    also when the gap is about zero).
    """
    for j in range(12):
        node = j // 6
        k = j % 6
        for i in range(3):
            xp[0, i] = x1[i]
            xp[1, i] = x2[i]
        for i in range(4):
            qp[0, i] = qa[i]
            qp[1, i] = qb[i]
        if k < 3:
            h = FD_STEP * reach
            xp[node, k] += h
        else:
            h = FD_STEP
            for i in range(3):
                dp[i] = h if i == k - 3 else 0.0
            rotate_spatial(qp[node], dp[:3], q4)
        element_contact(xp[0], xp[1], qp[0], qp[1], x1c, x2c, qac, qbc, R0, centre, centre_c,
                        axis, reach, bilateral, k_n, mu, k_t, ft_old, fp, M, V, q4, T, dp, True)
        for i in range(12):
            Ke[i, j] = (fp[i] - fe[i]) / h


@njit(cache=True)
def assemble_contact(X0, conn, R0, u, quat, u_c, quat_c, centres, centres_c, axes, radii,
                     bilateral, r_beam, k_n, mu, k_t, ft_c, ft_t, want_tangent, f, band, bw,
                     reactions, pressures, status, xis):
    """Add the contact residual (and tangent) of all cylinders to ``f`` (and ``band``).

    ``f`` is a resistance (internal minus external): contact forces enter with a minus
    sign.  ``reactions[c]`` receives the total force of the beam on cylinder c.
    ``ft_t[c, e]`` receives the trial tangential force; ``ft_c`` is only read.
    ``status``/``xis`` (n_elements) are work arrays.
    """
    M = np.empty((6, 3, 3))
    V = np.empty((13, 3))
    W = np.empty((4, 3))
    q4 = np.empty(4)
    T = np.empty((3, 12))
    dp = np.empty(12)
    fe = np.empty(12)
    fp = np.empty(12)
    Ke = np.empty((12, 12))
    xp = np.empty((2, 3))
    qp = np.empty((2, 4))
    x1, x2, x1c, x2c = W[0], W[1], W[2], W[3]
    fvec = V[12]
    reactions[:, :] = 0.0
    pressures[:] = 0.0
    ft_t[:, :] = 0.0
    ne = conn.shape[0]
    for c in range(centres.shape[0]):
        axis = axes[c]
        reach = radii[c] + r_beam
        _closest_points(X0, conn, R0, u, quat, centres[c], axis, reach, status, xis, M, V, q4)
        for e in range(ne):
            if not _counted(status, e, ne):
                continue
            a, b = conn[e, 0], conn[e, 1]
            for i in range(3):
                x1[i] = X0[a, i] + u[a, i]
                x2[i] = X0[b, i] + u[b, i]
                x1c[i] = X0[a, i] + u_c[a, i]
                x2c[i] = X0[b, i] + u_c[b, i]
            active, p, f_t = element_contact(
                x1, x2, quat[a], quat[b], x1c, x2c, quat_c[a], quat_c[b], R0[e], centres[c],
                centres_c[c], axis, reach, bilateral[c], k_n, mu, k_t, ft_c[c, e], fe, M, V, q4,
                T, dp)
            if not active:
                continue
            ft_t[c, e] = f_t
            for i in range(3):
                reactions[c, i] += fvec[i]
            pressures[c] += p
            if want_tangent:
                _element_tangent(x1, x2, quat[a], quat[b], x1c, x2c, quat_c[a], quat_c[b], R0[e],
                                 centres[c], centres_c[c], axis, reach, bilateral[c], k_n, mu,
                                 k_t, ft_c[c, e], fe, Ke, M, V, q4, T, dp, xp, qp, fp)
            scatter_element(a, b, fe, Ke, want_tangent, f, band, bw)


@njit(cache=True)
def _friction(T, dp, dc, tvec, ft_old, p, mu, k_t):
    """Return mapping of the tangential force f_t (stick: elastic trial; slip: mu p)."""
    slip = 0.0
    for i in range(3):
        acc = 0.0
        for j in range(12):
            acc += T[i, j] * dp[j]
        slip += tvec[i] * (acc - dc[i])
    trial = ft_old + k_t * slip
    limit = mu * p
    if abs(trial) <= limit:
        return trial
    return limit if trial > 0.0 else -limit


@njit(cache=True)
def _counted(status, e, ne):
    """Whether the closest point found on element e is counted (once per location)."""
    s = status[e]
    if s == INTERIOR:
        return True
    if s == AT_START:  # a kink at the start node, or the free start of the beam
        return e == 0 or status[e - 1] == AT_END
    if s == AT_END:
        return e == ne - 1
    return False


@njit(cache=True)
def _norm_diff(a, b):
    """|a - b| of two 3-vectors."""
    return np.sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2)


@njit(cache=True)
def _segment_distance(x1, x2, centre, axis, w1, w2):
    """Distance of the chord x1-x2 from the cylinder axis (a cheap pre-selection)."""
    for i in range(3):
        w1[i] = x1[i] - centre[i]
        w2[i] = x2[i] - x1[i]
    _perp(w1, axis, w1)
    _perp(w2, axis, w2)
    den = w2[0] ** 2 + w2[1] ** 2 + w2[2] ** 2
    s = 0.0
    if den > 0.0:
        s = -(w1[0] * w2[0] + w1[1] * w2[1] + w1[2] * w2[2]) / den
        s = min(max(s, 0.0), 1.0)
    return np.sqrt((w1[0] + s * w2[0]) ** 2 + (w1[1] + s * w2[1]) ** 2 + (w1[2] + s * w2[2]) ** 2)
