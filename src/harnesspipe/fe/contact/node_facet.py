"""Nodes (the wires' nodes as spheres) on bilinear shell quads (tube, tape), Sec. 4.1:
one-sided penalty contact with the rate-dependent friction of eq. 6.

Each node's gap to a set is the soft minimum of its distances to the set's facets (width
SOFTMIN_TAU), its normal force the gradient of the penalty energy, its friction acts on
its closest facet; pairs whose node is far from the quad's box are rejected before the
projection (:func:`_nf_project`).  Conventions: :mod:`harnesspipe.fe.contact.common`.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from harnesspipe.fe.contact.common import (CHUNK, REJECT_TOL, SERIAL_MAX_CHUNKS, find_slot,
                                           to_tangent_plane)
from harnesspipe.fe.contact.surface import project_quad
from harnesspipe.fe.loops import loop_kernel
from harnesspipe.fe.materials.friction import rate_dependent_friction

ENTRY_FRACTION = 0.05   # a contact begins at most this far (x (r + t/2)) inside the surface
SOFTMIN_TAU = 0.002     # mm: width of the soft minimum of a node's facet distances
SOFTMIN_REACH = 40.0    # facets farther than this x SOFTMIN_TAU beyond the closest: weight < 5e-18


class FacetSet(NamedTuple):
    """One node-facet contact set, the argument group of :func:`node_facet_contact`."""
    nodes: np.ndarray       # (n_cn,) node ids (e.g. the wire nodes)
    node_r: np.ndarray      # (n_cn,) their radii
    quads: np.ndarray       # (n_q, 4) node ids
    quad_t: np.ndarray      # (n_q,) thicknesses
    quad_sign: np.ndarray   # (n_q,) +1 / -1: the nodes' side is quad_sign (X_xi x X_eta)
    pairs: np.ndarray       # (n_pairs, 2) candidate (index into nodes, quad) pairs
    k_n: float              # normal penalty (N/mm)
    k_t: float              # stick penalty (N/mm)
    mu_s: float             # eq. 6 (mu_s = mu_k for constant mu)
    mu_k: float
    d_c: float
    pen_max: float          # largest penetration accepted (mm)
    hist_partner: np.ndarray   # (n_cn, maxs) int64 slot history, in place
    hist_ft: np.ndarray        # (n_cn, maxs, 3) friction history, in place


@njit(cache=True, parallel=True)
def node_facet_contact(x, v, fset, dt, time_scale, f_n, f_t):
    """One-sided penalty contact of nodes (spheres) with bilinear shell quads, eq. 6 friction.

    Parameters
    ----------
    x, v : (n_nodes, 3+) positions, half-step velocities.
    fset : :class:`FacetSet`: the nodes (e.g. the wire nodes) and their radii; the quads,
        their thicknesses and signs (the side where the nodes belong is
        ``quad_sign * (X_xi x X_eta)``, e.g. -1 for wires inside a tube whose quad normals
        point outwards); the candidate (index into ``nodes``, quad) pairs, e.g.
        ``box_pairs`` of ``node_aabbs`` vs ``quad_aabbs`` with same_set False; penalties
        (N/mm) and eq. 6; ``pen_max``, the largest penetration accepted (mm), beyond which
        the node is taken to be on the other side (never grabbed from the wrong side), e.g.
        ``r + t/2``; the history (``new_slot_history(n_cn, maxs)``), in place.
    dt, time_scale : solver step, physical / simulated duration.
    f_n, f_t : outputs, ADDED.  The node receives F, the quad nodes -F N_i(xi, eta).

    Gap: the distance of the node centre to the CLOSEST POINT of each facet's mid-surface
    (Gauss-Newton projection clamped to the quad, so that at edges and corners the closest
    point lies on the boundary) less t/2, h_q, reduced over the node's facets to the soft
    minimum g = h_min - tau ln sum_q exp(-(h_q - h_min) / tau) (tau = SOFTMIN_TAU), minus r.
    The distance to a polyhedral surface is continuous and its gradient is the unit vector
    to the closest point, so the penalty energy 1/2 k gap^2 is a potential -- the contact is
    conservative also where a node slides over a convex kink (under the loading pin the tube
    folds towards the wires), where a projection-along-normal rule has a dead zone of width
    ~ 2 (r + t/2) tan(kink/2) through which nodes sink and then get pushed out with energy
    that was never stored.  The hard minimum (the closest facet alone) is kinked where two
    facets are equally close at a CONCAVE corner (a wire pressed into a node line of the
    faceted tube): its force flips there by 2 k pen sin(half the kink), nodes chattered
    across, and the explicit step made energy that the tie dashpots and friction then took
    up (a 10 mm run of the closed-on open tube: contact -10.3 N mm, i.e. made, and the
    ties' dashpots 9.4 N mm; with the soft minimum +1.7 and 0.6).  The soft minimum is
    smooth; it lowers the gap by tau ln m where m facets are equally close (a seam of a flat
    sheet: tau ln 2).  The normal force on the node is k pen sum_q w_q n_q / sum_q w_q
    (weights w_q = exp(-(h_q - h_min) / tau), n_q the unit vector from facet q's closest
    point to the node, the facet normal inside a facet), each facet taking its share at its
    closest point; friction acts against the slip on the closest facet, in the plane normal
    to the weighted normal, limited by that normal force.  A node
    already behind the mid-surface (side test ``quad_sign * n . d < 0``) over the facet's
    interior is pushed along the facet normal, up to the penetration ``pen_max``, provided it
    was in contact with the set at the previous step (``hist_partner[i, 0] >= 0``: it went in
    from the front); behind the plane but beside the facet (closest point on its boundary: a
    wire beyond the tube's end, an open cut's edge) is no contact.  More generally a node that
    was not in contact at the previous step begins a contact only at the surface: with a
    penetration up to ``ENTRY_FRACTION (r + t/2)`` (a step's approach is far less); deeper,
    it is on the other side.  Otherwise a node that passed behind the mid-surface beyond
    ``pen_max`` (or around a free edge) met its whole penetration at once on its way back --
    measured as 9 N mm made in one step by the fabric's overlap self-contact.  Without the history rule a
    node beside a FREE edge of the set and behind its plane (the next fabric layer of a spiral
    where the set's quads stop) met its whole penetration at once when it slid over the facet,
    and was pushed out with energy never stored.  Limitation: one gap per node and set, so a
    node pinched between two opposite walls of the same set (a tube flattened below one wire
    diameter) only sees the nearer one.
    Returns the number of active contacts.
    """
    n_pairs = fset.pairs.shape[0]
    t_max = _t_max(fset.quad_t)
    pd = np.empty((n_pairs, 9))     # xi, eta, dist(signed), n(3) force direction, X(3)
    n_chunks = (n_pairs + CHUNK - 1) // CHUNK
    if n_chunks <= SERIAL_MAX_CHUNKS:
        _nf_project(x, fset, t_max, 0, n_pairs, pd, np.zeros(8))
    else:
        for ch in prange(n_chunks):
            _nf_project(x, fset, t_max, ch * CHUNK, min(n_pairs, (ch + 1) * CHUNK), pd,
                        np.zeros(8))
    return _nf_commit(x, v, fset, pd, dt, dt * time_scale, f_n, f_t)


@njit(cache=True)
def node_facet_contact_serial(x, v, fset, dt, time_scale, f_n, f_t):
    """Serial twin of :func:`node_facet_contact` (for a caller that runs it beside other
    work); the same steps, the same arithmetic, the same results."""
    n_pairs = fset.pairs.shape[0]
    pd = np.empty((n_pairs, 9))
    _nf_project(x, fset, _t_max(fset.quad_t), 0, n_pairs, pd, np.zeros(8))
    return _nf_commit(x, v, fset, pd, dt, dt * time_scale, f_n, f_t)


@njit(cache=True)
def _t_max(quad_t):
    """The thickest quad's thickness (0 for none)."""
    t_max = 0.0
    for q in range(quad_t.shape[0]):
        t_max = max(t_max, quad_t[q])
    return t_max


class NodeGaps(NamedTuple):
    """Each contact node's soft-minimum gap of one call (:func:`_nf_softmin`) and its
    force, the work arrays of :func:`_nf_commit`."""
    was_in: np.ndarray      # (n_cn,) bool: in contact at the previous step
    h_min: np.ndarray       # (n_cn,) closest facet surface distance
    dom: np.ndarray         # (n_cn,) int64 dominant (closest) pair, -1 for none
    w_sum: np.ndarray       # (n_cn,) sum of the soft-minimum weights
    n_sum: np.ndarray       # (n_cn, 3) weighted sum of the pairs' force directions
    pn_w: np.ndarray        # (n_cn,) p_n / w_sum of each node in contact, else 0


@njit(cache=True)
def _nf_commit(x, v, fset, pd, dt, dt_phys, f_n, f_t):
    """The serial end of the node-facet contact, from the projections ``pd`` of the pairs
    of ``fset`` (:func:`_nf_project`): each node's soft-minimum gap, its forces (the
    gradient of the penalty energy), friction on its dominant facet and its history.
    Returns the number of active contacts."""
    n_cn = fset.nodes.shape[0]
    ng = NodeGaps(np.empty(n_cn, dtype=np.bool_), np.full(n_cn, np.inf),
                  np.full(n_cn, -1, dtype=np.int64), np.zeros(n_cn), np.zeros((n_cn, 3)),
                  np.zeros(n_cn))
    _nf_softmin(fset, pd, ng)
    return _nf_node_forces(x, v, fset, pd, dt, dt_phys, f_n, f_t, ng, np.empty((5, 3)),
                           np.empty(4))


@loop_kernel
def _nf_node_forces(x, v, fset, pd, dt, dt_phys, f_n, f_t, ng, scr, N):
    """:func:`_nf_commit`'s forces and history from the gaps ``ng`` (:class:`NodeGaps`);
    scratch ``scr`` (5, 3), ``N`` (4,)."""
    nodes, node_r, quads, quad_t = fset.nodes, fset.node_r, fset.quads, fset.quad_t
    pairs = fset.pairs
    k_n, k_t, mu_s, mu_k, d_c = fset.k_n, fset.k_t, fset.mu_s, fset.mu_k, fset.d_c
    pen_max, hist_partner, hist_ft = fset.pen_max, fset.hist_partner, fset.hist_ft
    was_in, h_min, dom, w_sum, n_sum, pn_w = ng
    n_cn = nodes.shape[0]
    # node by node: each row of the history is read (old slot) before it is rewritten, so
    # the history is updated in place (no copies)
    maxs = hist_partner.shape[1]
    fold, dg, ds, hnew, nv = scr[0], scr[1], scr[2], scr[3], scr[4]
    n_active = 0
    for i in range(n_cn):
        p = dom[i]
        q = pairs[p, 1] if p >= 0 else -1
        gap = h_min[i] - SOFTMIN_TAU * math.log(w_sum[i]) - node_r[i] if p >= 0 else 0.0
        if (p < 0 or gap >= 0.0 or -gap > pen_max
                or (not was_in[i] and -gap > ENTRY_FRACTION * (node_r[i] + 0.5 * quad_t[q]))):
            for s in range(maxs):
                hist_partner[i, s] = -1
            continue
        nd = nodes[i]
        n_active += 1
        pn = -k_n * gap
        pn_w[i] = pn / w_sum[i]
        n_len = math.sqrt(n_sum[i, 0] ** 2 + n_sum[i, 1] ** 2 + n_sum[i, 2] ** 2)
        for c in range(3):
            nv[c] = n_sum[i, c] / n_len if n_len > 0.0 else pd[p, 3 + c]
            hnew[c] = 0.0
            f_n[nd, c] += pn_w[i] * n_sum[i, c]
        _bilinear_weights(pd[p, 0], pd[p, 1], N)
        if k_t > 0.0:
            slot = find_slot(hist_partner, quads, i, q)
            for c in range(3):
                fold[c] = hist_ft[i, slot, c] if slot >= 0 else 0.0
                vq = 0.0
                for m in range(4):
                    vq += N[m] * v[quads[q, m], c]
                dg[c] = dt * (v[nd, c] - vq)
            to_tangent_plane(fold, dg, nv)
            rate_dependent_friction(fold, dg, dt_phys, k_t, mu_s, mu_k, d_c, pn_w[i] * n_len,
                                    hnew, ds)
        for s in range(maxs):
            hist_partner[i, s] = -1
        hist_partner[i, 0] = q              # in contact (also read by the behind-facet rule)
        if k_t > 0.0:
            for c in range(3):
                hist_ft[i, 0, c] = hnew[c]
        for c in range(3):
            f_t[nd, c] -= hnew[c]
            for m in range(4):
                f_t[quads[q, m], c] += N[m] * hnew[c]
    # the facets' reactions: each pair's share of the normal force at its closest point
    for p in range(pairs.shape[0]):
        i = pairs[p, 0]
        if pn_w[i] == 0.0:
            continue
        w = _nf_weight(pd, quad_t, was_in, pairs, p, h_min[i])
        if w == 0.0:
            continue
        _bilinear_weights(pd[p, 0], pd[p, 1], N)
        q = pairs[p, 1]
        for c in range(3):
            fc = pn_w[i] * w * pd[p, 3 + c]
            for m in range(4):
                f_n[quads[q, m], c] -= N[m] * fc
    return n_active


@loop_kernel
def _nf_softmin(fset, pd, ng):
    """Each node's distances to its facets' surfaces h_p = dist_p - t_q / 2 reduced to the
    soft minimum h_min - SOFTMIN_TAU ln(sum_p exp(-(h_p - h_min) / SOFTMIN_TAU)): into
    ``ng`` (:class:`NodeGaps`, as allocated by :func:`_nf_commit`) h_min, the dominant
    (closest) pair, the sum of the weights and the weighted sum of the pairs' force
    directions.  A pair behind its facet counts only for a node that was in contact at the
    previous step (``was_in``, set here from the history)."""
    pairs, quad_t, hist_partner = fset.pairs, fset.quad_t, fset.hist_partner
    was_in, h_min, dom, w_sum, n_sum = ng.was_in, ng.h_min, ng.dom, ng.w_sum, ng.n_sum
    for i in range(was_in.shape[0]):
        was_in[i] = hist_partner[i, 0] >= 0
    for p in range(pairs.shape[0]):
        i = pairs[p, 0]
        if _nf_counts(pd, was_in, i, p):
            h = pd[p, 2] - 0.5 * quad_t[pairs[p, 1]]
            if h < h_min[i]:
                h_min[i] = h
                dom[i] = p
    for p in range(pairs.shape[0]):
        i = pairs[p, 0]
        w = _nf_weight(pd, quad_t, was_in, pairs, p, h_min[i])
        if w == 0.0:
            continue            # pd's directions are not written for such a pair
        w_sum[i] += w
        for c in range(3):
            n_sum[i, c] += w * pd[p, 3 + c]


@njit(cache=True, inline="always")
def _nf_counts(pd, was_in, i, p):
    """Pair p (of node i) takes part: projected, and in front of its facet or the node was
    in contact at the previous step (it went in from the front)."""
    return np.isfinite(pd[p, 2]) and (pd[p, 2] >= 0.0 or was_in[i])


@njit(cache=True, inline="always")
def _nf_weight(pd, quad_t, was_in, pairs, p, h_min):
    """Soft-minimum weight exp(-(h_p - h_min) / SOFTMIN_TAU) of pair p, 0 for a pair that
    does not take part (:func:`_nf_counts`)."""
    if not _nf_counts(pd, was_in, pairs[p, 0], p):
        return 0.0
    return math.exp(-(pd[p, 2] - 0.5 * quad_t[pairs[p, 1]] - h_min) / SOFTMIN_TAU)


@njit(cache=True, inline="always")
def _bilinear_weights(xi, eta, N):
    """The bilinear shape functions of a quad at (xi, eta) into N (4,)."""
    N[0] = 0.25 * (1 - xi) * (1 - eta)
    N[1] = 0.25 * (1 + xi) * (1 - eta)
    N[2] = 0.25 * (1 + xi) * (1 + eta)
    N[3] = 0.25 * (1 - xi) * (1 + eta)


@njit(cache=True, inline="always")
def _nf_reach(r, t_max, pen_max):
    """Largest |distance| of a node (radius r) from a facet it can be in contact with (see
    :func:`_nf_project`), with the slack of the early rejects."""
    return max(r + 0.5 * t_max + SOFTMIN_REACH * SOFTMIN_TAU, pen_max - r) * (1.0 + REJECT_TOL)


@loop_kernel
def _node_quad_plane_gap(x, nd, quads, q):
    """A lower bound of the distance of node ``nd`` from the bilinear facet ``q``: with
    ``X(xi, eta) = c + a xi + b eta + d xi eta`` and ``N = a x b / |a x b|``, the facet
    lies within ``|N . d|`` of its mid-plane ``N . (X - c) = 0`` (``|xi eta| <= 1``), so
    ``|N . (x - c)| - |N . d|`` bounds the distance of ``x`` from it (0 for a degenerate
    facet).  On a tube's facets it rejects the pairs whose node lies across the tube from
    the facet but inside its box."""
    i0, i1, i2, i3 = quads[q, 0], quads[q, 1], quads[q, 2], quads[q, 3]
    a0 = 0.25 * (x[i1, 0] + x[i2, 0] - x[i0, 0] - x[i3, 0])
    a1 = 0.25 * (x[i1, 1] + x[i2, 1] - x[i0, 1] - x[i3, 1])
    a2 = 0.25 * (x[i1, 2] + x[i2, 2] - x[i0, 2] - x[i3, 2])
    b0 = 0.25 * (x[i2, 0] + x[i3, 0] - x[i0, 0] - x[i1, 0])
    b1 = 0.25 * (x[i2, 1] + x[i3, 1] - x[i0, 1] - x[i1, 1])
    b2 = 0.25 * (x[i2, 2] + x[i3, 2] - x[i0, 2] - x[i1, 2])
    n = (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0)     # a x b
    nn = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    if nn == 0.0:
        return 0.0
    side = 0.0                      # N . (x - c) |a x b|
    warp = 0.0                      # N . d |a x b|
    for k in range(3):
        c = 0.25 * (x[i0, k] + x[i1, k] + x[i2, k] + x[i3, k])
        side += n[k] * (x[nd, k] - c)
        warp += n[k] * 0.25 * (x[i0, k] - x[i1, k] + x[i2, k] - x[i3, k])
    return (abs(side) - abs(warp)) / nn


@loop_kernel
def _node_quad_box_d2(x, nd, quads, q):
    """Squared distance of node ``nd`` from the bounding box of quad ``q``'s nodes."""
    d2 = 0.0
    for c in range(3):
        lo = min(min(x[quads[q, 0], c], x[quads[q, 1], c]),
                 min(x[quads[q, 2], c], x[quads[q, 3], c]))
        hi = max(max(x[quads[q, 0], c], x[quads[q, 1], c]),
                 max(x[quads[q, 2], c], x[quads[q, 3], c]))
        d = max(lo - x[nd, c], x[nd, c] - hi)
        if d > 0.0:
            d2 += d * d
    return d2


@njit(cache=True)
def near_node_facet_pairs(x, nodes, node_r, quads, quad_t, pairs, pen_max, margin):
    """Mask of the candidate (node, quad) pairs of :func:`node_facet_contact` that can
    come into contact before the next search: node within ``_nf_reach + margin`` of the
    quad's node box.  Until the next search every node stays within ``margin / 2`` of
    where it is now (the search rule), so the box distance shrinks by less than
    ``margin``; a pair dropped here would be rejected early by :func:`_nf_project` at
    every step until then (same result).  The mask keeps the order of ``pairs``."""
    t_max = 0.0
    for q in range(quad_t.shape[0]):
        t_max = max(t_max, quad_t[q])
    keep = np.empty(pairs.shape[0], dtype=np.bool_)
    for p in range(pairs.shape[0]):
        i = pairs[p, 0]
        lim = _nf_reach(node_r[i], t_max, pen_max) + margin
        keep[p] = _node_quad_box_d2(x, nodes[i], quads, pairs[p, 1]) <= lim * lim
    return keep


@loop_kernel
def _nf_project(x, fset, t_max, p0, p1, pd, prj):
    """Closest points of the (node, quad) pairs p0..p1-1 of ``fset`` into pd (see
    node_facet_contact); ``prj`` (8,) scratch.

    Early reject: a pair whose node is farther from the bounding box of the quad's nodes
    (which holds the bilinear facet, so the box distance bounds |dist| from below), or
    from the slab about the facet's mid-plane that holds it
    (:func:`_node_quad_plane_gap`), than
    ``T = max(r + t_max/2 + SOFTMIN_REACH tau, pen_max - r)`` gets pd = inf.  Any contact
    has |dist| <= T (in front: |dist| < r + t/2; behind: |dist| + r + t/2 <= pen_max), and
    so has every facet of a node in contact whose soft-minimum weight exceeds
    exp(-SOFTMIN_REACH) (its h within SOFTMIN_REACH tau of h_min < r), so if a node is in
    contact its closest facet and every facet of non-negligible weight are kept, and if it
    is rejected no pair of the node can be in contact: the result is unchanged up to the
    round-off of the dropped pairs' weights (below exp(-SOFTMIN_REACH) of the closest's).
    """
    nodes, node_r, quads, quad_sign = fset.nodes, fset.node_r, fset.quads, fset.quad_sign
    pairs, pen_max = fset.pairs, fset.pen_max
    for p in range(p0, p1):
        i = pairs[p, 0]
        q = pairs[p, 1]
        nd = nodes[i]
        pd[p, 2] = np.inf
        if (quads[q, 0] == nd or quads[q, 1] == nd or quads[q, 2] == nd
                or quads[q, 3] == nd):
            continue
        lim = _nf_reach(node_r[i], t_max, pen_max)
        if _node_quad_box_d2(x, nd, quads, q) > lim * lim:
            continue
        if _node_quad_plane_gap(x, nd, quads, q) > lim:
            continue
        project_quad(x, quads, q, x[nd], True, prj)
        d0 = x[nd, 0] - prj[2]
        d1 = x[nd, 1] - prj[3]
        d2 = x[nd, 2] - prj[4]
        dist = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        sg = quad_sign[q]
        side = sg * (d0 * prj[5] + d1 * prj[6] + d2 * prj[7])
        pd[p, 0] = prj[0]
        pd[p, 1] = prj[1]
        pd[p, 6] = prj[2]
        pd[p, 7] = prj[3]
        pd[p, 8] = prj[4]
        if side >= 0.0 and dist > 1e-12:
            pd[p, 2] = dist
            pd[p, 3] = d0 / dist
            pd[p, 4] = d1 / dist
            pd[p, 5] = d2 / dist
        elif abs(prj[0]) < 1.0 - 1e-9 and abs(prj[1]) < 1.0 - 1e-9:
            # behind the mid-surface, over the facet's interior: push out along the normal
            pd[p, 2] = -dist
            pd[p, 3] = sg * prj[5]
            pd[p, 4] = sg * prj[6]
            pd[p, 5] = sg * prj[7]
