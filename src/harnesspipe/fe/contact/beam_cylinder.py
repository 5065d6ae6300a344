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

from typing import NamedTuple

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


class BeamChain(NamedTuple):
    """The beam elements, now and at the last converged increment."""
    X0: np.ndarray          # (n_nodes, 3) initial positions
    conn: np.ndarray        # (n_el, 2) node ids
    R0: np.ndarray          # (n_el, 3, 3) initial element frames
    u: np.ndarray           # (n_nodes, 3) displacements
    quat: np.ndarray        # (n_nodes, 4) nodal rotations
    u_c: np.ndarray         # (n_nodes, 3) the converged ones
    quat_c: np.ndarray      # (n_nodes, 4)


class Rollers(NamedTuple):
    """The rigid cylinders, now and at the last converged increment."""
    centres: np.ndarray     # (n_cyl, 3) a point of each axis
    centres_c: np.ndarray   # (n_cyl, 3) the converged ones
    axes: np.ndarray        # (n_cyl, 3) unit axes
    radii: np.ndarray       # (n_cyl,)
    bilateral: np.ndarray   # (n_cyl,) bool: loaded at the last converged increment


class ContactLaw(NamedTuple):
    """Normal penalty and friction of the beam on the cylinders."""
    r_beam: float           # the beam's radius around its centreline
    k_n: float              # normal penalty
    mu: float               # Coulomb friction (0: none)
    k_t: float              # tangential penalty


class ContactState(NamedTuple):
    """Friction history (per cylinder and element) and what an assembly reports."""
    ft_c: np.ndarray        # (n_cyl, n_el) committed tangential force (read)
    ft_t: np.ndarray        # (n_cyl, n_el) trial tangential force (written)
    reactions: np.ndarray   # (n_cyl, 3) force of the beam on each cylinder (written)
    pressures: np.ndarray   # (n_cyl,) sum of the normal forces (written)
    status: np.ndarray      # (n_el,) int64 work: where the closest point lies
    xis: np.ndarray         # (n_el,) work: its element parameter


class Ends(NamedTuple):
    """An element's end points and nodal rotations."""
    x1: np.ndarray          # (3,)
    x2: np.ndarray          # (3,)
    qa: np.ndarray          # (4,)
    qb: np.ndarray          # (4,)


class Roller(NamedTuple):
    """One cylinder as one element meets it."""
    centre: np.ndarray      # (3,)
    centre_c: np.ndarray    # (3,) at the last converged increment
    axis: np.ndarray        # (3,) unit
    reach: float            # R + r_beam
    bilateral: bool


class ContactWork(NamedTuple):
    """Work arrays of the element kernels, allocated once per assembly."""
    M: np.ndarray           # (6, 3, 3)
    V: np.ndarray           # (13, 3); V[12] the force vector of the last element_contact
    q4: np.ndarray          # (4,)
    T: np.ndarray           # (3, 12) transfer matrix
    dp: np.ndarray          # (12,)
    xp: np.ndarray          # (2, 3) perturbed ends (tangent)
    qp: np.ndarray          # (2, 4)
    fp: np.ndarray          # (12,) perturbed force


@njit(cache=True)
def _contact_work():
    """A fresh :class:`ContactWork`."""
    return ContactWork(np.empty((6, 3, 3)), np.empty((13, 3)), np.empty(4), np.empty((3, 12)),
                       np.empty(12), np.empty((2, 3)), np.empty((2, 4)), np.empty(12))


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
def _closest_points(beam, centre, axis, reach, state, work):
    """Closest point (``state.xis``) and its status on every element near one cylinder."""
    X0, conn, R0, u, quat = beam.X0, beam.conn, beam.R0, beam.u, beam.quat
    status, xis, M, V, q4 = state.status, state.xis, work.M, work.V, work.q4
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
def element_contact(now, then, R0, cyl, law, ft_old, fe, work, two_sided=False):
    """Contact force of one element on one cylinder ``cyl`` (:class:`Roller`), as a
    residual ``fe`` (12).

    Inputs are the current end points and nodal quaternions ``now`` and their committed
    values ``then`` (:class:`Ends`, for the frictional slip), the element's initial frame
    ``R0`` and its committed tangential force ``ft_old``.  The closest point is searched
    on this element (clamped to it).  Returns ``(active, p, f_t)``; ``work.V[12]`` holds
    the force vector ``-p n + f_t t`` (the negative of the force on the beam).
    ``two_sided`` keeps the contact active whatever the gap (the branch differentiated by
    the tangent).
    """
    x1, x2, qa, qb = now.x1, now.x2, now.qa, now.qb
    centre, axis, reach, bilateral = cyl.centre, cyl.axis, cyl.reach, cyl.bilateral
    k_n, mu, k_t = law.k_n, law.mu, law.k_t
    M, V, q4, T, dp = work.M, work.V, work.q4, work.T, work.dp
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
        _increment(x1, x2, then.x1, then.x2, qa, qb, then.qa, then.qb, dp, q4, wt)
        for i in range(3):
            dc[i] = centre[i] - cyl.centre_c[i]
        f_t = _friction(T, dp, dc, tvec, ft_old, p, mu, k_t)
    for i in range(3):
        fvec[i] = -p * nvec[i] + f_t * tvec[i]
    for j in range(12):
        fe[j] = T[0, j] * fvec[0] + T[1, j] * fvec[1] + T[2, j] * fvec[2]
    return True, p, f_t


@njit(cache=True)
def _element_tangent(now, then, R0, cyl, law, ft_old, fe, Ke, work):
    """Ke = d fe / d(nodal translations, spins) by forward differences (see module doc;
    arguments as :func:`element_contact`).

    The perturbed states keep the contact active (the active branch's derivative,
    also when the gap is about zero).
    """
    x1, x2, qa, qb = now.x1, now.x2, now.qa, now.qb
    xp, qp, fp, dp, q4, reach = work.xp, work.qp, work.fp, work.dp, work.q4, cyl.reach
    perturbed = Ends(xp[0], xp[1], qp[0], qp[1])
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
        element_contact(perturbed, then, R0, cyl, law, ft_old, fp, work, True)
        for i in range(12):
            Ke[i, j] = (fp[i] - fe[i]) / h


@njit(cache=True)
def assemble_contact(beam, rollers, law, state, want_tangent, f, band, bw):
    """Add the contact residual (and tangent) of the beam ``beam`` (:class:`BeamChain`) on
    all cylinders ``rollers`` (:class:`Rollers`) under ``law`` (:class:`ContactLaw`) to
    ``f`` (and ``band``).

    ``f`` is a resistance (internal minus external): contact forces enter with a minus
    sign.  ``state.reactions[c]`` receives the total force of the beam on cylinder c,
    ``state.ft_t[c, e]`` the trial tangential force; ``state.ft_c`` is only read
    (:class:`ContactState`).
    """
    X0, conn, R0, u, quat, u_c, quat_c = (beam.X0, beam.conn, beam.R0, beam.u, beam.quat,
                                          beam.u_c, beam.quat_c)
    reactions, pressures, status, ft_t = state.reactions, state.pressures, state.status, state.ft_t
    work = _contact_work()
    W = np.empty((4, 3))
    fe = np.empty(12)
    Ke = np.empty((12, 12))
    x1, x2, x1c, x2c = W[0], W[1], W[2], W[3]
    fvec = work.V[12]
    reactions[:, :] = 0.0
    pressures[:] = 0.0
    ft_t[:, :] = 0.0
    ne = conn.shape[0]
    for c in range(rollers.centres.shape[0]):
        axis = rollers.axes[c]
        reach = rollers.radii[c] + law.r_beam
        _closest_points(beam, rollers.centres[c], axis, reach, state, work)
        cyl = Roller(rollers.centres[c], rollers.centres_c[c], axis, reach, rollers.bilateral[c])
        for e in range(ne):
            if not _counted(status, e, ne):
                continue
            a, b = conn[e, 0], conn[e, 1]
            for i in range(3):
                x1[i] = X0[a, i] + u[a, i]
                x2[i] = X0[b, i] + u[b, i]
                x1c[i] = X0[a, i] + u_c[a, i]
                x2c[i] = X0[b, i] + u_c[b, i]
            now = Ends(x1, x2, quat[a], quat[b])
            then = Ends(x1c, x2c, quat_c[a], quat_c[b])
            active, p, f_t = element_contact(now, then, R0[e], cyl, law, state.ft_c[c, e], fe,
                                             work)
            if not active:
                continue
            ft_t[c, e] = f_t
            for i in range(3):
                reactions[c, i] += fvec[i]
            pressures[c] += p
            if want_tangent:
                _element_tangent(now, then, R0[e], cyl, law, state.ft_c[c, e], fe, Ke, work)
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
