"""Wire-wire contact of the explicit bundle model (Sec. 4.1): penalty normal force and the
rate-dependent friction of eq. 6 between the 2-node beam segments of different wires.

A pair first has its touching contact points flagged (an early bounding-box and distance
reject of far candidates, :func:`_ww_flags`), then forces and friction are computed for
those only (:func:`_ww_forces`) and committed serially (:func:`_ww_commit`).  Contact
points (:func:`_segment_points`): the crossing rule (closest points) for crossing
segments, the parallel rule (the two ends of the common part) for nearly parallel ones,
blended in between.  Conventions: :mod:`harnesspipe.fe.contact.common`.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from harnesspipe.fe.contact.common import REJECT_TOL, find_slot, free_slot, to_tangent_plane
from harnesspipe.fe.contact.search import segment_closest_params
from harnesspipe.fe.loops import loop_kernel
from harnesspipe.fe.materials.friction import rate_dependent_friction
from harnesspipe.fe.vec3 import any_perpendicular

PARALLEL_COS = (0.98, 0.995)   # |cos| of two segments: crossing rule below, parallel rule above,
                               # both blended in between (see _segment_points)
WW_POINTS = 3           # contact points per pair: crossing point, two parallel ends


class WireContact(NamedTuple):
    """Wire-wire contact, the argument group of :func:`beam_beam_contact`."""
    seg: np.ndarray         # (n_seg, 2) node ids of the wires' segments
    seg_r: np.ndarray       # (n_seg,) radii (mm)
    seg_body: np.ndarray    # (n_seg,) wire of each segment (one wire's never touch)
    pairs: np.ndarray       # (n_pairs, 2) candidate segment pairs
    k_n: float              # normal penalty (N/mm per unit weight of a contact point)
    k_t: float              # tangential (stick) penalty (N/mm), 0 disables friction
    mu_s: float             # eq. 6
    mu_k: float
    d_c: float              # (s of physical time)
    hist_partner: np.ndarray   # (n_seg, maxs) int64 slot history, in place
    hist_ft: np.ndarray        # (n_seg, maxs, WW_POINTS, 3) friction history, in place


class Touching(NamedTuple):
    """The touching pairs of one call: flags and points of every candidate (phase 1), the
    forces and new history of the touching ones, compact by ``j`` (phase 2)."""
    flag: np.ndarray        # (n_pairs,) int8, bit k: point k penetrates
    pts: np.ndarray         # (n_pairs, 4, WW_POINTS) s, u, weight; beta, beta', rule (row 3)
    idx: np.ndarray         # (n_act,) the touching pairs
    pfn: np.ndarray         # (n_act, WW_POINTS, 3) weighted normal force on a's point
    pft: np.ndarray         # (n_act, WW_POINTS, 3) weighted friction force on a's point
    hnew: np.ndarray        # (n_act, WW_POINTS, 3) new friction history (per unit weight)
    pdu: np.ndarray         # (n_act, 2) (U_par - U_cross) beta', beta U_par / w


@njit(cache=True)
def _touching_arrays(flag, pts):
    """The :class:`Touching` of the flagged pairs, phase-2 arrays allocated (unset)."""
    idx = _touching(flag)
    n_act = idx.size
    return Touching(flag, pts, idx, np.empty((n_act, WW_POINTS, 3)),
                    np.empty((n_act, WW_POINTS, 3)), np.empty((n_act, WW_POINTS, 3)),
                    np.empty((n_act, 2)))


@njit(cache=True, inline="always")
def _segment_points(x, seg, a, b, valence, pts, p):
    """Contact points of segments a, b (up to ``WW_POINTS``) into ``pts[p]`` (rows s, u,
    weight; :class:`Touching`); returns the bit mask of the points present (0: none).  The
    weights are those of each rule alone; the blend factor beta and its derivative
    d beta / d|cos| go to ``pts[p, 3, 0]``, ``pts[p, 3, 1]``.

    Point 0, crossing rule: the closest points of the two segments (clamped), weight 1,
    halved at an end node shared with another segment (that segment finds the same point).
    Points 1, 2, parallel rule: the two ends of the common part of the segments projected
    on a's axis, each paired with its closest point on b, weight  L_overlap / (L_a + L_b)
    each (the pair carries  k_n * mean penetration * L_overlap / L_mean; for equal aligned
    chains every node-to-node line carries k_n * penetration).
    The crossing rule holds for |cos| <= PARALLEL_COS[0], the parallel rule for |cos| >=
    PARALLEL_COS[1]; in between the pair's energy is ``(1 - beta) U_cross + beta U_par``
    with beta a smooth step in |cos|.  A sharp switch would make the energy jump whenever
    a penetrating pair turns through the threshold (the closest point of the crossing rule
    and the ends of the parallel rule see different penetrations): measured as wire-wire
    contact creating energy in kicks in bent twisted-wire bundles.
    """
    a0 = seg[a, 0]
    a1 = seg[a, 1]
    b0 = seg[b, 0]
    b1 = seg[b, 1]
    da0 = x[a1, 0] - x[a0, 0]
    da1 = x[a1, 1] - x[a0, 1]
    da2 = x[a1, 2] - x[a0, 2]
    db0 = x[b1, 0] - x[b0, 0]
    db1 = x[b1, 1] - x[b0, 1]
    db2 = x[b1, 2] - x[b0, 2]
    r0 = x[a0, 0] - x[b0, 0]
    r1 = x[a0, 1] - x[b0, 1]
    r2 = x[a0, 2] - x[b0, 2]
    A = da0 * da0 + da1 * da1 + da2 * da2
    E = db0 * db0 + db1 * db1 + db2 * db2
    B = da0 * db0 + da1 * db1 + da2 * db2
    C = da0 * r0 + da1 * r1 + da2 * r2
    F = db0 * r0 + db1 * r1 + db2 * r2
    La = math.sqrt(A)
    Lb = math.sqrt(E)
    cosab = abs(B) / (La * Lb)
    c0, c1 = PARALLEL_COS
    if cosab <= c0:
        pts[p, 3, 0] = 0.0
        pts[p, 3, 1] = 0.0
    elif cosab >= c1:
        pts[p, 3, 0] = 1.0
        pts[p, 3, 1] = 0.0
    else:
        t = (cosab - c0) / (c1 - c0)
        pts[p, 3, 0] = t * t * (3.0 - 2.0 * t)
        pts[p, 3, 1] = 6.0 * t * (1.0 - t) / (c1 - c0)
    mask = 0
    if pts[p, 3, 0] < 1.0:                    # not parallel: A E - B^2 > 0
        s, u = segment_closest_params(A, B, C, E, F)
        w = 1.0
        if (s == 0.0 and valence[a0] > 1) or (s == 1.0 and valence[a1] > 1):
            w *= 0.5
        if (u == 0.0 and valence[b0] > 1) or (u == 1.0 and valence[b1] > 1):
            w *= 0.5
        pts[p, 0, 0] = s
        pts[p, 1, 0] = u
        pts[p, 2, 0] = w
        mask = 1
    if pts[p, 3, 0] > 0.0:
        # parallel: common part on a's axis
        sb0 = -C / A                      # b0 on a: (b0 - a0).da / A
        sb1 = (B - C) / A                 # b1 on a
        lo = max(0.0, min(sb0, sb1))
        hi = min(1.0, max(sb0, sb1))
        w = (hi - lo) * La / (La + Lb) if hi >= lo else 0.0
        if w > 0.0:
            for k in range(1, 3):
                s = lo if k == 1 else hi
                u = (F + s * B) / E           # point of a at s, projected on b
                pts[p, 0, k] = s
                pts[p, 1, k] = min(1.0, max(0.0, u))
                pts[p, 2, k] = w
            mask |= 6
    return mask


@njit(cache=True, inline="always")
def _blend_forces(x, a0, a1, b0, b1, dUdcos, f_n):
    """Forces ``-dU/dcos * d|cos|/dx`` of the blend (``dUdcos = (U_par - U_cross) beta'``):
    the part of the pair's energy gradient that comes from beta turning with the segments."""
    A = E = B = 0.0
    for c in range(3):
        da = x[a1, c] - x[a0, c]
        db = x[b1, c] - x[b0, c]
        A += da * da
        E += db * db
        B += da * db
    LL = math.sqrt(A * E)
    cs = abs(B) / LL
    sg = 1.0 if B >= 0.0 else -1.0
    for c in range(3):
        da = x[a1, c] - x[a0, c]
        db = x[b1, c] - x[b0, c]
        ga = sg * db / LL - cs * da / A          # d|cos| / d(da)
        gb = sg * da / LL - cs * db / E          # d|cos| / d(db)
        f_n[a1, c] -= dUdcos * ga
        f_n[a0, c] += dUdcos * ga
        f_n[b1, c] -= dUdcos * gb
        f_n[b0, c] += dUdcos * gb


@njit(cache=True, inline="always")
def _end_projection_grad(x, a0, ea, La, bx, g):
    """Gradient of ``(x_bx - x_a0) . e_a`` (node bx projected on a's axis, in mm) with
    respect to a0, a1, bx: rows 0, 1, 2 of ``g``."""
    qe = 0.0
    for c in range(3):
        qe += (x[bx, c] - x[a0, c]) * ea[c]
    for c in range(3):
        q_perp = (x[bx, c] - x[a0, c]) - qe * ea[c]
        g[0, c] = -ea[c] - q_perp / La
        g[1, c] = q_perp / La
        g[2, c] = ea[c]


@njit(cache=True, inline="always")
def _overlap_forces(x, a0, a1, b0, b1, coef, f_n, ea, eb, g_ov, g):
    """Forces ``-coef grad w`` of the parallel rule's weight w = L_ov / (L_a + L_b)
    (:func:`_segment_points`; ``coef`` = beta U_par / w): the pair's parallel energy
    ``beta w sum 1/2 k_n g^2`` changes with the overlap L_ov as the segments slide along
    each other, and this is the force of that change.  L_ov = hi - lo on a's axis (mm), each
    end either a's own end (clamped: 0 or L_a) or one of b's nodes projected on a.
    Scratch: ``ea``, ``eb`` (3,) the unit axes, ``g_ov`` (4, 3) d L_ov / d (a0, a1, b_lo,
    b_hi), ``g`` (3, 3) a projection's gradient."""
    La = Lb = 0.0
    for c in range(3):
        ea[c] = x[a1, c] - x[a0, c]
        eb[c] = x[b1, c] - x[b0, c]
        La += ea[c] * ea[c]
        Lb += eb[c] * eb[c]
    La = math.sqrt(La)
    Lb = math.sqrt(Lb)
    p0 = p1 = 0.0
    for c in range(3):
        ea[c] /= La
        eb[c] /= Lb
        p0 += (x[b0, c] - x[a0, c]) * ea[c]
        p1 += (x[b1, c] - x[a0, c]) * ea[c]
    b_lo, b_hi = (b0, b1) if p0 <= p1 else (b1, b0)
    lo = max(0.0, min(p0, p1))
    hi = min(La, max(p0, p1))
    if hi <= lo:
        return
    L_sum = La + Lb
    g_ov[...] = 0.0
    if max(p0, p1) >= La:            # hi = L_a
        for c in range(3):
            g_ov[0, c] -= ea[c]
            g_ov[1, c] += ea[c]
    else:
        _end_projection_grad(x, a0, ea, La, b_hi, g)
        for c in range(3):
            g_ov[0, c] += g[0, c]
            g_ov[1, c] += g[1, c]
            g_ov[3, c] += g[2, c]
    if min(p0, p1) > 0.0:            # lo = b_lo's projection, else 0
        _end_projection_grad(x, a0, ea, La, b_lo, g)
        for c in range(3):
            g_ov[0, c] -= g[0, c]
            g_ov[1, c] -= g[1, c]
            g_ov[2, c] -= g[2, c]
    r = (hi - lo) / (L_sum * L_sum)  # d w = d L_ov / L_sum - L_ov (d L_a + d L_b) / L_sum^2
    for c in range(3):
        f_n[a0, c] -= coef * (g_ov[0, c] / L_sum + r * ea[c])
        f_n[a1, c] -= coef * (g_ov[1, c] / L_sum - r * ea[c])
        f_n[b_lo, c] -= coef * g_ov[2, c] / L_sum
        f_n[b_hi, c] -= coef * g_ov[3, c] / L_sum
        f_n[b0, c] -= coef * r * eb[c]
        f_n[b1, c] += coef * r * eb[c]


@njit(cache=True)
def beam_beam_contact(x, v, wc, dt, time_scale, f_n, f_t):
    """Wire-wire penalty contact with eq. 6 friction between 2-node beam segments.

    Parameters
    ----------
    x, v : (n_nodes, 3+) positions, half-step velocities.
    wc : :class:`WireContact`; its ``pairs`` the candidate segment pairs (e.g.
        ``box_pairs(.., same_set=True)`` on ``segment_aabbs``), the owner of a pair's
        history ``min(a, b)``; its history (``new_slot_history(n_seg, maxs,
        points=WW_POINTS)``) per (owner, partner slot, contact point), in place.
    dt : solver step; time_scale : physical / simulated duration (dt_phys = dt time_scale).
    f_n, f_t : (n_nodes, 3+) outputs, normal and friction forces ADDED.

    Geometry: gap ``|p_a - p_b| - r_a - r_b`` at the contact points of
    :func:`_segment_points` (closest points for crossing segments; for nearly parallel
    segments the two ends of their common part, node-to-segment like, which is well posed
    and continuous under tangential motion; blended in between, with the blend's own
    energy gradient).  Point forces go to the end nodes by the linear shape functions
    ``(1 - s, s)``.

    Serial: the bundle runs it beside the other force families
    (:mod:`harnesspipe.fe.assembly.lanes`).  Returns the number of pairs with at least one
    active contact point.
    """
    n_pairs = wc.pairs.shape[0]
    valence = _valence(wc.seg, x.shape[0])
    # phase 1: which pairs touch, and at which of their points (kept for phase 2)
    flag = np.empty(n_pairs, dtype=np.int8)
    pts = np.empty((n_pairs, 4, WW_POINTS))
    _ww_flags(x, wc, valence, flag, pts)
    # phase 2: forces and friction of the touching pairs only
    t = _touching_arrays(flag, pts)
    _ww_forces(x, v, wc, t, dt, dt * time_scale, np.zeros((5, 3)))
    _ww_commit(x, wc, t, f_n, f_t, np.empty((9, 3)))
    return t.idx.size


@njit(cache=True)
def _valence(seg, n_nodes):
    """Number of segments at each node."""
    valence = np.zeros(n_nodes, dtype=np.int64)
    for e in range(seg.shape[0]):
        valence[seg[e, 0]] += 1
        valence[seg[e, 1]] += 1
    return valence


@njit(cache=True)
def _touching(flag):
    """Indices of the nonzero flags, in order."""
    n_act = 0
    for p in range(flag.size):
        if flag[p] != 0:
            n_act += 1
    idx = np.empty(n_act, dtype=np.int64)
    j = 0
    for p in range(flag.size):
        if flag[p] != 0:
            idx[j] = p
            j += 1
    return idx


@loop_kernel
def _ww_commit(x, wc, t, f_n, f_t, scr):
    """The serial end of the wire-wire contact: the new friction history of the touching
    pairs ``t`` (:class:`Touching`) replaces the old one, and their point forces go to the
    segments' end nodes (in pair order).  ``scr`` (9, 3) scratch."""
    seg, pairs, hist_partner, hist_ft = wc.seg, wc.pairs, wc.hist_partner, wc.hist_ft
    idx, flag, pts, pfn, pft, hnew, pdu = t.idx, t.flag, t.pts, t.pfn, t.pft, t.hnew, t.pdu
    for i in range(hist_partner.shape[0]):
        for s in range(hist_partner.shape[1]):
            hist_partner[i, s] = -1
    ea, eb, g_ov, g = scr[0], scr[1], scr[2:6], scr[6:9]     # :func:`_overlap_forces`' scratch
    for j in range(idx.size):
        p = idx[j]
        a = pairs[p, 0]
        b = pairs[p, 1]
        if a > b:
            a, b = b, a
        slot = free_slot(hist_partner, a)
        if slot >= 0:
            hist_partner[a, slot] = b
            for k in range(WW_POINTS):
                for c in range(3):
                    hist_ft[a, slot, k, c] = hnew[j, k, c]
        a0 = seg[a, 0]
        a1 = seg[a, 1]
        b0 = seg[b, 0]
        b1 = seg[b, 1]
        if pdu[j, 0] != 0.0:
            _blend_forces(x, a0, a1, b0, b1, pdu[j, 0], f_n)
        if pdu[j, 1] != 0.0:
            _overlap_forces(x, a0, a1, b0, b1, pdu[j, 1], f_n, ea, eb, g_ov, g)
        for k in range(WW_POINTS):
            if not (flag[p] >> k) & 1:
                continue
            s = pts[p, 0, k]
            u = pts[p, 1, k]
            for c in range(3):
                fn = pfn[j, k, c]
                ft = pft[j, k, c]
                f_n[a0, c] += (1 - s) * fn
                f_n[a1, c] += s * fn
                f_n[b0, c] -= (1 - u) * fn
                f_n[b1, c] -= u * fn
                f_t[a0, c] += (1 - s) * ft
                f_t[a1, c] += s * ft
                f_t[b0, c] -= (1 - u) * ft
                f_t[b1, c] -= u * ft


@njit(cache=True, inline="always")
def _boxes_apart(x, a0, a1, b0, b1, r):
    """True if the bounding boxes of segments (a0, a1) and (b0, b1) are farther apart than
    ``r``: then every point pair of the segments is, and no contact point can touch."""
    d2 = 0.0
    for c in range(3):
        lo_a = min(x[a0, c], x[a1, c])
        hi_a = max(x[a0, c], x[a1, c])
        lo_b = min(x[b0, c], x[b1, c])
        hi_b = max(x[b0, c], x[b1, c])
        d = max(lo_b - hi_a, lo_a - hi_b)
        if d > 0.0:
            d2 += d * d
    return d2 > (r * (1.0 + REJECT_TOL)) ** 2


@njit(cache=True, inline="always")
def _segments_apart(x, a0, a1, b0, b1, r):
    """True if the segments (a0, a1) and (b0, b1) are farther apart than ``r`` (their
    closest points, :func:`segment_closest_params`): every contact point of
    :func:`_segment_points` lies on both segments, so none can touch."""
    A = B = C = E = F = 0.0
    for c in range(3):
        da = x[a1, c] - x[a0, c]
        db = x[b1, c] - x[b0, c]
        rc = x[a0, c] - x[b0, c]
        A += da * da
        B += da * db
        C += da * rc
        E += db * db
        F += db * rc
    s, u = segment_closest_params(A, B, C, E, F)
    d2 = 0.0
    for c in range(3):
        d = ((1 - s) * x[a0, c] + s * x[a1, c]) - ((1 - u) * x[b0, c] + u * x[b1, c])
        d2 += d * d
    return d2 > (r * (1.0 + REJECT_TOL)) ** 2


@loop_kernel
def _ww_flags(x, wc, valence, flag, pts):
    """flag[p] for every pair p of ``wc`` (:class:`WireContact`): bit k set if contact
    point k of the pair penetrates; for a pair with a flag, its points
    (:func:`_segment_points`) into ``pts[p]``: rows s, u, weight, and (beta, beta', rule
    mask) in row 3."""
    seg, seg_r, seg_body, pairs = wc.seg, wc.seg_r, wc.seg_body, wc.pairs
    for p in range(pairs.shape[0]):
        flag[p] = 0
        a = pairs[p, 0]
        b = pairs[p, 1]
        if a > b:
            a, b = b, a
        if a == b or seg_body[a] == seg_body[b]:
            continue
        a0 = seg[a, 0]
        a1 = seg[a, 1]
        b0 = seg[b, 0]
        b1 = seg[b, 1]
        rr = seg_r[a] + seg_r[b]
        if _boxes_apart(x, a0, a1, b0, b1, rr) or _segments_apart(x, a0, a1, b0, b1, rr):
            continue                                # early rejects (most candidates)
        m = _segment_points(x, seg, a, b, valence, pts, p)
        pts[p, 3, 2] = m
        f = 0
        for k in range(WW_POINTS):
            if not (m >> k) & 1:
                continue
            s = pts[p, 0, k]
            u = pts[p, 1, k]
            dist2 = 0.0
            for c in range(3):
                d = ((1 - s) * x[a0, c] + s * x[a1, c]) - ((1 - u) * x[b0, c] + u * x[b1, c])
                dist2 += d * d
            if not (math.sqrt(dist2) - rr >= 0.0):
                f |= 1 << k
        flag[p] = f


@loop_kernel
def _ww_forces(x, v, wc, t, dt, dt_phys, scr):
    """Normal and friction forces of the touching pairs ``t.idx`` (:class:`Touching`,
    compact arrays by j) at their points ``t.pts`` (:func:`_ww_flags`); ``pdu[j, 0]``:
    (U_par - U_cross) beta' for :func:`_blend_forces`, ``pdu[j, 1]``: beta U_par / w, the
    parallel energy per unit weight, for :func:`_overlap_forces`.  ``scr`` (5, 3) zeroed
    scratch."""
    seg, seg_r, pairs = wc.seg, wc.seg_r, wc.pairs
    hist_partner, hist_ft = wc.hist_partner, wc.hist_ft
    k_n, k_t, mu_s, mu_k, d_c = wc.k_n, wc.k_t, wc.mu_s, wc.mu_k, wc.d_c
    idx, flag, pts, pfn, pft, hnew, pdu = t.idx, t.flag, t.pts, t.pfn, t.pft, t.hnew, t.pdu
    fold, dg, ds, nv, fnew = scr[0], scr[1], scr[2], scr[3], scr[4]
    for j in range(idx.size):
        p = idx[j]
        for k in range(WW_POINTS):
            for c in range(3):
                pfn[j, k, c] = 0.0
                pft[j, k, c] = 0.0
                hnew[j, k, c] = 0.0
        a = pairs[p, 0]
        b = pairs[p, 1]
        if a > b:
            a, b = b, a
        m = int(pts[p, 3, 2])
        beta = pts[p, 3, 0]
        u_cross = 0.0
        u_par = 0.0
        slot = -2                        # looked up at the first active point
        a0 = seg[a, 0]
        a1 = seg[a, 1]
        b0 = seg[b, 0]
        b1 = seg[b, 1]
        rr = seg_r[a] + seg_r[b]
        for k in range(WW_POINTS):
            if not (flag[p] >> k) & 1:
                continue
            s = pts[p, 0, k]
            u = pts[p, 1, k]
            dist2 = 0.0
            for c in range(3):
                pa = (1 - s) * x[a0, c] + s * x[a1, c]
                pb = (1 - u) * x[b0, c] + u * x[b1, c]
                nv[c] = pa - pb
                dist2 += nv[c] * nv[c]
            dist = math.sqrt(dist2)
            gap = dist - rr
            if dist > 1e-12 * rr:
                for c in range(3):
                    nv[c] /= dist
            else:
                for c in range(3):
                    dg[c] = x[a1, c] - x[a0, c]
                any_perpendicular(dg, nv)
            pn = -k_n * gap
            wk = pts[p, 2, k]
            if k == 0:
                u_cross += 0.5 * wk * pn * (-gap)
                w = (1.0 - beta) * wk
            else:
                u_par += 0.5 * wk * pn * (-gap)
                w = beta * wk
            for c in range(3):
                pfn[j, k, c] = w * pn * nv[c]
            if k_t <= 0.0:
                continue
            if slot == -2:
                slot = find_slot(hist_partner, seg, a, b)
            for c in range(3):
                fold[c] = hist_ft[a, slot, k, c] if slot >= 0 else 0.0
                dg[c] = dt * ((1 - s) * v[a0, c] + s * v[a1, c]
                              - (1 - u) * v[b0, c] - u * v[b1, c])
            to_tangent_plane(fold, dg, nv)
            rate_dependent_friction(fold, dg, dt_phys, k_t, mu_s, mu_k, d_c, pn, fnew, ds)
            for c in range(3):
                hnew[j, k, c] = fnew[c]
                pft[j, k, c] = -w * fnew[c]
        w1 = pts[p, 2, 1]
        pdu[j, 0] = (u_par - u_cross) * pts[p, 3, 1]
        pdu[j, 1] = beta * u_par / w1 if (m & 6) and w1 > 0.0 else 0.0
        # a rule not in use hands its points the other's stick force (no loss at a switch)
        if m == 1:
            for c in range(3):
                hnew[j, 1, c] = hnew[j, 0, c]
                hnew[j, 2, c] = hnew[j, 0, c]
        elif m == 6:
            for c in range(3):
                hnew[j, 0, c] = 0.5 * (hnew[j, 1, c] + hnew[j, 2, c])
