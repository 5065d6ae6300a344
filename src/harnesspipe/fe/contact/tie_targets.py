"""The cohesive ties built from the initial geometry: each tape node tied to the closest
point of the target quads (tube, underlying tape) or beam segments (wires) within a
tolerance (:func:`make_ties`; plain Python around two parallel candidate kernels).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from harnesspipe.fe.contact.search import box_pairs, node_aabbs, quad_aabbs, segment_aabbs
from harnesspipe.fe.contact.surface import project_quad, quad_eval, quad_point
from harnesspipe.fe.vec3 import any_perpendicular


@njit(cache=True, parallel=True)
def _candidates_quad(x, tape_nodes, quads, pairs, out_xi, out_gap, out_X, out_n):
    """Each candidate (tape node, quad) pair's closest point on the quad: its parameters,
    gap, point and normal."""
    for p in prange(pairs.shape[0]):
        i = pairs[p, 0]
        q = pairs[p, 1]
        pr = np.empty(8)
        project_quad(x, quads, q, x[tape_nodes[i]], True, pr)
        out_xi[p, 0] = pr[0]
        out_xi[p, 1] = pr[1]
        # re-evaluate exactly at the clamped parameters
        X = np.empty(3)
        nq = np.empty(3)
        e1 = np.empty(3)
        quad_eval(x, quads, q, pr[0], pr[1], X, nq, e1)
        d2 = 0.0
        for c in range(3):
            out_X[p, c] = X[c]
            out_n[p, c] = nq[c]
            d2 += (x[tape_nodes[i], c] - X[c]) ** 2
        out_gap[p] = math.sqrt(d2)
        nd = tape_nodes[i]
        if quads[q, 0] == nd or quads[q, 1] == nd or quads[q, 2] == nd or quads[q, 3] == nd:
            out_gap[p] = np.inf        # never tie a node to a quad of its own


@njit(cache=True, parallel=True)
def _candidates_seg(x, tape_nodes, seg, pairs, out_s, out_dist):
    """Each candidate (tape node, wire segment) pair's closest point on the segment (its
    parameter s in [0, 1]) and distance."""
    for p in prange(pairs.shape[0]):
        i = pairs[p, 0]
        e = pairs[p, 1]
        nd = tape_nodes[i]
        a0 = seg[e, 0]
        a1 = seg[e, 1]
        L2 = 0.0
        dd = 0.0
        for c in range(3):
            L2 += (x[a1, c] - x[a0, c]) ** 2
            dd += (x[nd, c] - x[a0, c]) * (x[a1, c] - x[a0, c])
        s = min(1.0, max(0.0, dd / L2))
        d2 = 0.0
        for c in range(3):
            d2 += (x[nd, c] - (1 - s) * x[a0, c] - s * x[a1, c]) ** 2
        out_s[p] = s
        out_dist[p] = math.sqrt(d2)


def _best_per_node(n_nodes, owner, score):
    """Index of the lowest score per owner (-1 where none)."""
    best = -np.ones(n_nodes, dtype=np.int64)
    if owner.size == 0:
        return best
    order = np.lexsort((score, owner))
    first = np.ones(order.size, dtype=bool)
    first[1:] = owner[order][1:] != owner[order][:-1]
    best[owner[order][first]] = order[first]
    return best


class QuadTargets(NamedTuple):
    """The quad candidates of the tape nodes and the closest one per node."""
    pairs: np.ndarray   # (n_pairs, 2) tape node index, quad
    xi: np.ndarray      # (n_pairs, 2) clamped parameters of the closest point
    X: np.ndarray       # (n_pairs, 3) the closest point
    nq: np.ndarray      # (n_pairs, 3) the quad's unit normal there
    sel: np.ndarray     # (n,) the pair chosen per tape node (-1: none within tol)
    gap: np.ndarray     # (n,) its surface gap (inf: none)


class SegmentTargets(NamedTuple):
    """The segment candidates of the tape nodes and the closest one per node."""
    pairs: np.ndarray   # (n_pairs, 2) tape node index, segment
    s: np.ndarray       # (n_pairs,) clamped parameter of the closest point
    sel: np.ndarray     # (n,) the pair chosen per tape node (-1: none within tol)
    gap: np.ndarray     # (n,) its surface gap (inf: none)


def _box_candidates(x, tape_nodes, lo_t, hi_t):
    """(n_pairs, 2) pairs (tape node index, target) whose node point lies in the target's
    inflated box, by grid search with cells of the median target box size."""
    n = tape_nodes.size
    lo_n, hi_n = node_aabbs(x, tape_nodes, np.zeros(n), 0.0)
    cell = float(np.median(np.max(hi_t - lo_t, axis=1)))
    return box_pairs(lo_n, hi_n, lo_t, hi_t, cell, False)


def _closest_within(n, pairs, gap, tol):
    """Per tape node the pair of smallest ``gap <= tol`` (-1: none) and that gap (inf: none)."""
    ok = gap <= tol
    best = _best_per_node(n, pairs[ok, 0], gap[ok])
    idx = np.append(np.flatnonzero(ok), -1)      # sentinel: no candidate at all
    sel = np.where(best >= 0, idx[np.maximum(best, 0)], -1)
    best_gap = (np.where(best >= 0, gap[np.maximum(sel, 0)], np.inf) if gap.size
                else np.full(n, np.inf))
    return sel, best_gap


def _quad_targets(x, tape_nodes, quads, quad_t, tape_half_t, tol) -> QuadTargets:
    """The closest quad point per tape node: gap ``|d| - t_q/2 - tape_half_t``."""
    lo_q, hi_q = quad_aabbs(x, quads, 0.5 * quad_t, tol + tape_half_t)
    pairs = _box_candidates(x, tape_nodes, lo_q, hi_q)
    xi = np.zeros((len(pairs), 2))
    dist = np.zeros(len(pairs))
    X = np.zeros((len(pairs), 3))
    nq = np.zeros((len(pairs), 3))
    _candidates_quad(x, tape_nodes, quads, pairs, xi, dist, X, nq)
    gap = np.abs(dist - 0.5 * quad_t[pairs[:, 1]] - tape_half_t)
    sel, best_gap = _closest_within(tape_nodes.size, pairs, gap, tol)
    return QuadTargets(pairs, xi, X, nq, sel, best_gap)


def _segment_targets(x, tape_nodes, seg, seg_r, tape_half_t, tol) -> SegmentTargets:
    """The closest segment point per tape node: gap ``|d| - r - tape_half_t``."""
    lo_e, hi_e = segment_aabbs(x, seg, seg_r, tol + tape_half_t)
    pairs = _box_candidates(x, tape_nodes, lo_e, hi_e)
    s_par = np.zeros(len(pairs))
    dist = np.zeros(len(pairs))
    _candidates_seg(x, tape_nodes, seg, pairs, s_par, dist)
    gap = np.abs(dist - seg_r[pairs[:, 1]] - tape_half_t)
    sel, best_gap = _closest_within(tape_nodes.size, pairs, gap, tol)
    return SegmentTargets(pairs, s_par, sel, best_gap)


def _with_state(ties: dict) -> dict:
    """Add the zeroed damage state ``tie_kappa``, ``tie_D``, ``tie_energy``."""
    m = len(ties["tie_node"])
    ties.update(tie_kappa=np.zeros(m), tie_D=np.zeros(m), tie_energy=np.zeros(m))
    return ties


def _no_quad_ties() -> dict:
    return dict(tie_node=np.zeros(0, np.int64), tie_quad=np.zeros(0, np.int64),
                tie_xi=np.zeros((0, 2)), tie_sign=np.zeros(0), tie_off=np.zeros((0, 3)),
                tie_area=np.zeros(0))


def _no_segment_ties() -> dict:
    return dict(tie_node=np.zeros(0, np.int64), tie_seg=np.zeros(0, np.int64),
                tie_s=np.zeros(0), tie_n0=np.zeros((0, 3)), tie_t0=np.zeros((0, 3)),
                tie_off=np.zeros((0, 3)), tie_area=np.zeros(0))


def _quad_ties(x, tape_nodes, node_area, quads, quad_sign, cand: QuadTargets, iq) -> dict:
    """The quad ties of the tape nodes ``iq``: target, parameters, side and the offset
    in the frame (n, e1, n x e1) of the closest point."""
    sel = cand.sel[iq]
    tq = cand.pairs[sel, 1]
    nodes = tape_nodes[iq]
    d = x[nodes] - cand.X[sel]
    nrm = cand.nq[sel]
    e1 = np.zeros_like(nrm)
    for k, (q, (a, b)) in enumerate(zip(tq, cand.xi[sel])):
        _, _, e1[k] = quad_point(x, quads, q, a, b)
    dn = np.einsum("ij,ij->i", d, nrm)
    if quad_sign is not None:
        sign = np.asarray(quad_sign, dtype=float)[tq]
    else:
        sign = np.where(dn < 0.0, -1.0, 1.0)
    nrm = nrm * sign[:, None]
    t = np.cross(nrm, e1)
    off = np.stack([np.einsum("ij,ij->i", d, nrm), np.einsum("ij,ij->i", d, e1),
                    np.einsum("ij,ij->i", d, t)], axis=1)
    return dict(tie_node=nodes, tie_quad=tq, tie_xi=np.ascontiguousarray(cand.xi[sel]),
                tie_sign=sign, tie_off=off, tie_area=node_area[iq].copy())


def _segment_ties(x, tape_nodes, node_area, seg, cand: SegmentTargets, is_) -> dict:
    """The segment ties of the tape nodes ``is_``: target, parameter, the initial frame
    (radial n0, axial t0) and the offset in the frame (n0, t0, n0 x t0)."""
    sel = cand.sel[is_]
    te = cand.pairs[sel, 1]
    sp = cand.s[sel]
    nodes = tape_nodes[is_]
    t0 = x[seg[te, 1]] - x[seg[te, 0]]
    t0 /= np.linalg.norm(t0, axis=1)[:, None]
    P = (1 - sp)[:, None] * x[seg[te, 0]] + sp[:, None] * x[seg[te, 1]]
    d = x[nodes] - P
    radial = d - np.einsum("ij,ij->i", d, t0)[:, None] * t0
    rn = np.linalg.norm(radial, axis=1)
    n0 = np.zeros_like(radial)
    for k in range(len(nodes)):
        if rn[k] > 1e-12:
            n0[k] = radial[k] / rn[k]
        else:
            any_perpendicular(t0[k].copy(), n0[k])
    tt = np.cross(n0, t0)
    off = np.stack([np.einsum("ij,ij->i", d, n0), np.einsum("ij,ij->i", d, t0),
                    np.einsum("ij,ij->i", d, tt)], axis=1)
    return dict(tie_node=nodes, tie_seg=te, tie_s=sp, tie_n0=n0, tie_t0=t0, tie_off=off,
                tie_area=node_area[is_].copy())


def make_ties(x, tape_nodes, node_area, quads=None, quad_t=None, quad_sign=None, seg=None,
              seg_r=None, tape_half_t=0.0, tol=0.05):
    """Tie each tape node to the closest point of the target quads / segments.

    Parameters
    ----------
    x : (n_nodes, 3+) INITIAL positions.
    tape_nodes : (n,) candidate bonded nodes; node_area : (n,) their tributary areas
        (mm^2, from the caller).
    quads, quad_t : (n_q, 4) target quads and thicknesses (optional);
    quad_sign : (n_q,) optional +1/-1 orienting X_xi x X_eta towards the tape; if None
        the side of each tape node is taken from its initial offset.
    seg, seg_r : (n_seg, 2) target beam segments and radii (optional).
    tape_half_t : half thickness of the tape (mm).
    tol : accepted |surface gap| (mm): the node is tied if the distance between the
        tape mid-surface and the target surface, |d| - t_q/2 - tape_half_t (quads) or
        |d| - r - tape_half_t (segments), is below tol; the closest target wins.

    Returns
    -------
    (ties_quad, ties_seg) : dicts of arrays, fields of
    :class:`~harnesspipe.fe.contact.cohesive_ties.QuadTieSet` (``tie_node, tie_quad,
    tie_xi, tie_sign, tie_off, tie_area``) and the segment ties (``tie_node, tie_seg,
    tie_s, tie_n0, tie_t0, tie_off, tie_area``: :class:`harnesspipe.models.hifi.HifiSystem`
    turns them into the fields of :class:`~harnesspipe.fe.contact.cohesive_ties.BeamTieSet`),
    plus zeroed ``tie_kappa``, ``tie_D``, ``tie_energy``
    (:func:`~harnesspipe.fe.contact.cohesive_ties.tie_set` makes the group of a dict).
    """
    x = np.ascontiguousarray(np.asarray(x, dtype=float)[:, :3])
    tape_nodes = np.asarray(tape_nodes, dtype=np.int64)
    node_area = np.asarray(node_area, dtype=float)
    n = tape_nodes.size
    qc = sc = None
    if quads is not None and len(quads):
        quads = np.asarray(quads, dtype=np.int64)
        qc = _quad_targets(x, tape_nodes, quads, np.asarray(quad_t, dtype=float),
                           tape_half_t, tol)
    if seg is not None and len(seg):
        seg = np.asarray(seg, dtype=np.int64)
        sc = _segment_targets(x, tape_nodes, seg, np.asarray(seg_r, dtype=float),
                              tape_half_t, tol)
    best_q_gap = qc.gap if qc is not None else np.full(n, np.inf)
    best_s_gap = sc.gap if sc is not None else np.full(n, np.inf)
    use_q = np.isfinite(best_q_gap) & (best_q_gap <= best_s_gap)
    use_s = np.isfinite(best_s_gap) & ~use_q
    iq, is_ = np.flatnonzero(use_q), np.flatnonzero(use_s)
    ties_quad = (_quad_ties(x, tape_nodes, node_area, quads, quad_sign, qc, iq)
                 if qc is not None else _no_quad_ties())
    ties_seg = (_segment_ties(x, tape_nodes, node_area, seg, sc, is_)
                if sc is not None and is_.size else _no_segment_ties())
    return _with_state(ties_quad), _with_state(ties_seg)
