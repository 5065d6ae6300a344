"""Wires on rigid cylinders (the test's rollers and loading pin, Sec. 4.1): one contact per
(wire, cylinder) at the wire's closest point to the cylinder's axis, penalty normal force
and constant-mu Coulomb friction, the reaction added to each cylinder.  Conventions:
:mod:`harnesspipe.fe.contact.common`.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from harnesspipe.fe.contact.common import to_tangent_plane
from harnesspipe.fe.loops import loop_kernel
from harnesspipe.fe.materials.friction import coulomb_return_map
from harnesspipe.fe.vec3 import dot


class WireChains(NamedTuple):
    """Wires as chains of segments on the cylinders (:func:`chain_cylinder_contact`)."""
    seg: np.ndarray         # (n_seg, 2) node ids, consecutive along each wire
    seg_r: np.ndarray       # (n_seg,) radii
    start: np.ndarray       # (n_chains + 1,) first segment of each chain
    mu: float               # Coulomb friction (the pins' mu_rtb)
    k_n: float              # normal penalty
    k_t: float              # stick penalty
    hist_ft: np.ndarray     # (n_chains, n_cyl, 3) friction history, in place


@loop_kernel
def _chain_closest(x, seg, seg_r, e0, e1, c0, ax, R):
    """Closest point of the segments e0..e1-1 of a chain to the axis line (point ``c0``,
    unit ``ax``): ``(gap, e, s)`` with gap = distance - R - r_e (smallest over the chain)."""
    best = np.inf
    e_best = -1
    s_best = 0.0
    for e in range(e0, e1):
        a = seg[e, 0]
        b = seg[e, 1]
        ta = (x[a, 0] - c0[0]) * ax[0] + (x[a, 1] - c0[1]) * ax[1] + (x[a, 2] - c0[2]) * ax[2]
        tb = (x[b, 0] - c0[0]) * ax[0] + (x[b, 1] - c0[1]) * ax[1] + (x[b, 2] - c0[2]) * ax[2]
        qa0 = x[a, 0] - c0[0] - ta * ax[0]          # radial offsets of the ends from the axis
        qa1 = x[a, 1] - c0[1] - ta * ax[1]
        qa2 = x[a, 2] - c0[2] - ta * ax[2]
        dq0 = x[b, 0] - c0[0] - tb * ax[0] - qa0
        dq1 = x[b, 1] - c0[1] - tb * ax[1] - qa1
        dq2 = x[b, 2] - c0[2] - tb * ax[2] - qa2
        dd = dq0 * dq0 + dq1 * dq1 + dq2 * dq2
        s = min(1.0, max(0.0, -(qa0 * dq0 + qa1 * dq1 + qa2 * dq2) / dd)) if dd > 0.0 else 0.0
        d2 = (qa0 + s * dq0) ** 2 + (qa1 + s * dq1) ** 2 + (qa2 + s * dq2) ** 2
        gap = math.sqrt(d2) - R - seg_r[e]
        if gap < best:
            best = gap
            e_best = e
            s_best = s
    return best, e_best, s_best


@loop_kernel
def _chain_pins(x, v, chains, w, cyl, dt, f_n, f_t, part, act, scr):
    """Chain ``w`` against every cylinder (:func:`chain_cylinder_contact`): forces on its
    nodes into ``f_n``, ``f_t``, on the cylinders into ``part[w]``, contacts into act[w];
    ``scr`` (5, 3) scratch."""
    seg, seg_r, chain_start, mu = chains.seg, chains.seg_r, chains.start, chains.mu
    k_n, k_t, hist_ft = chains.k_n, chains.k_t, chains.hist_ft
    cyl_c, cyl_axis, cyl_R, cyl_v = cyl.centres, cyl.axes, cyl.radii, cyl.velocity
    nv, dg, fold, fnew, ds = scr[0], scr[1], scr[2], scr[3], scr[4]
    n_cyl = cyl_c.shape[0]
    for c in range(n_cyl):
        ax = cyl_axis[c]
        gap, e, s = _chain_closest(x, seg, seg_r, chain_start[w], chain_start[w + 1],
                                   cyl_c[c], ax, cyl_R[c])
        if not gap < 0.0:
            for k in range(3):
                hist_ft[w, c, k] = 0.0
            continue
        act[w] += 1
        a = seg[e, 0]
        b = seg[e, 1]
        for k in range(3):
            nv[k] = (1.0 - s) * x[a, k] + s * x[b, k] - cyl_c[c, k]
        al = dot(nv, ax)
        for k in range(3):
            nv[k] -= al * ax[k]
        dist = math.sqrt(dot(nv, nv))
        for k in range(3):
            nv[k] /= dist
        pn = -k_n * gap
        for k in range(3):
            fnk = pn * nv[k]
            f_n[a, k] += (1.0 - s) * fnk
            f_n[b, k] += s * fnk
            part[w, c, k] -= fnk
        if k_t <= 0.0 or mu <= 0.0:
            continue
        for k in range(3):
            fold[k] = hist_ft[w, c, k]
            dg[k] = dt * ((1.0 - s) * v[a, k] + s * v[b, k] - cyl_v[c, k])
        to_tangent_plane(fold, dg, nv)
        coulomb_return_map(fold, dg, k_t, mu, pn, fnew, ds)
        for k in range(3):
            hist_ft[w, c, k] = fnew[k]
            f_t[a, k] -= (1.0 - s) * fnew[k]
            f_t[b, k] -= s * fnew[k]
            part[w, c, k] += fnew[k]


@njit(cache=True, parallel=True)
def chain_cylinder_contact(x, v, chains, cyl, dt, f_n, f_t, f_cyl):
    """Penalty contact of beam chains (wires) with rigid unbounded cylinders, Coulomb friction.

    A wire meets a 5 mm pin over a few millimetres, less than its element length: nodes
    alone (spheres at the nodes) let a wire whose nodes straddle a roller fall through it.
    Here each chain of ``chains`` (:class:`WireChains`: the segments ``start[w] ..
    start[w + 1] - 1`` of ``seg``, consecutive along the wire) touches each cylinder of
    ``cyl`` (:class:`~harnesspipe.fe.contact.common.Cylinders`) at most once, at the point
    of the chain closest to the cylinder's axis: gap ``g = min over the chain of (distance
    to the axis - R - r)``, normal force ``k_n max(-g, 0)`` along the radial direction,
    shared by the segment's end nodes with the weights ``(1 - s, s)``.  The minimum distance
    of a polyline to a line is continuous and its gradient is the unit radial vector at the
    closest point, so the penalty energy ``1/2 k_n g^2`` is a potential (no energy made as a
    bent wire slides over a roller).  Friction: Coulomb with ``mu`` (constant, the pins'
    mu_rtb), stick penalty ``k_t``, history ``hist_ft`` (n_chains, n_cyl, 3) in place (reset
    when the contact opens).  ``f_cyl`` (n_cyl, 3): force ON each cylinder, ADDED.
    Returns the number of active (chain, cylinder) contacts.  Parallel over the chains
    (each moves only its own nodes and history; the cylinders' forces are summed per
    chain, then in chain order).
    """
    n_cyl = cyl.centres.shape[0]
    n_ch = chains.start.shape[0] - 1
    part = np.empty((n_ch, n_cyl, 3))        # force on each cylinder from each chain
    act = np.empty(n_ch, dtype=np.int64)     # (filled by hand: np.zeros would be a parallel loop)
    for w in range(n_ch):
        act[w] = 0
        for c in range(n_cyl):
            for k in range(3):
                part[w, c, k] = 0.0
    size = (n_ch + 1) // 2                   # two tasks (scratch allocated per task)
    for task in prange(2):
        scr = np.empty((5, 3))
        for w in range(task * size, min(n_ch, (task + 1) * size)):
            _chain_pins(x, v, chains, w, cyl, dt, f_n, f_t, part, act, scr)
    return _chain_sum(act, part, f_cyl)


@njit(cache=True)
def chain_cylinder_contact_serial(x, v, chains, cyl, dt, f_n, f_t, f_cyl):
    """Serial twin of :func:`chain_cylinder_contact` (for a caller that runs it beside
    other work); the same arithmetic, the same results."""
    n_ch = chains.start.shape[0] - 1
    part = np.zeros((n_ch, cyl.centres.shape[0], 3))
    act = np.zeros(n_ch, dtype=np.int64)
    scr = np.empty((5, 3))
    for w in range(n_ch):
        _chain_pins(x, v, chains, w, cyl, dt, f_n, f_t, part, act, scr)
    return _chain_sum(act, part, f_cyl)


@njit(cache=True)
def _chain_sum(act, part, f_cyl):
    """The cylinders' forces summed over the chains, in chain order; returns the number
    of active (chain, cylinder) contacts."""
    n_active = 0
    for w in range(act.shape[0]):
        n_active += act[w]
        for c in range(part.shape[1]):
            for k in range(3):
                f_cyl[c, k] += part[w, c, k]
    return n_active
