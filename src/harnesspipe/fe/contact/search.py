"""Broad-phase contact search by uniform-grid spatial hashing (explicit bundle model).

Every primitive (beam segment, shell quad, node) is bounded by an axis-aligned box
(AABB) inflated by its radius / half thickness and a search ``margin``.  A pair
found with the margin covers every contact of the two primitives as long as their
relative motion stays below the margin: the caller re-runs the search as soon as any
node has moved more than half the margin since the last one (:func:`max_drift2`, the
Verlet-list "skin" rule), so no contact is ever missed.

Algorithm (no O(n^2) loop).  The space is cut into cubes of edge ``cell``.  Each
box of set B is registered in every cell it touches, as an entry ``(key, id)`` with
the exact integer key ``ix + nx (iy + ny iz)`` of the cell (cell indices relative
to the lowest corner of all boxes, so no hash collisions); the entries are sorted by
key with ``np.argsort``.  Each box of set A then looks up the cells it touches
(binary search on the sorted keys) and tests the AABB overlap of the entries found.
A pair sharing several cells is reported once: only from the cell that holds the
lower corner of the intersection of the two boxes.  Pass 1 counts the pairs of each
A box in ``prange``, a prefix sum gives the offsets, pass 2 writes them (no races).

Cost is O((n_a + n_b) c log n_b + pairs) with ``c`` the cells per box: choose
``cell`` about the typical box extent (e.g. the element length, or 2 (r + margin)
for wires); a cell much smaller than the boxes multiplies the entries.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange


class Grid(NamedTuple):
    """The grid of :func:`box_pairs` with the boxes of set B registered: lowest corner
    ``origin`` (3,), cell edge ``cell``, cells per axis ``dims`` (3,), and the sorted
    entries (cell key ``keys``, box id ``ids``) of :func:`_register`."""
    origin: np.ndarray
    cell: float
    dims: np.ndarray
    keys: np.ndarray
    ids: np.ndarray


@njit(cache=True)
def max_drift2(x, x_ref):
    """Largest squared distance ``|x_i - x_ref_i|^2`` over the nodes (n, 3+)."""
    d_max = 0.0
    for i in range(x_ref.shape[0]):
        d = 0.0
        for k in range(3):
            d += (x[i, k] - x_ref[i, k]) ** 2
        d_max = max(d_max, d)
    return d_max


@njit(cache=True)
def _cell_grid(lo_a, hi_a, lo_b, hi_b, cell):
    """Origin and number of cells per axis of a grid covering all boxes."""
    origin = np.empty(3)
    top = np.empty(3)
    for k in range(3):
        origin[k] = math.inf
        top[k] = -math.inf
    for i in range(lo_a.shape[0]):
        for k in range(3):
            origin[k] = min(origin[k], lo_a[i, k])
            top[k] = max(top[k], hi_a[i, k])
    for i in range(lo_b.shape[0]):
        for k in range(3):
            origin[k] = min(origin[k], lo_b[i, k])
            top[k] = max(top[k], hi_b[i, k])
    dims = np.empty(3, dtype=np.int64)
    for k in range(3):
        dims[k] = int(math.floor((top[k] - origin[k]) / cell)) + 1
    return origin, dims


@njit(cache=True)
def _cell_of(x, origin, cell, dims, k):
    """Index along axis ``k`` of the grid cell holding coordinate ``x``, clamped to the grid."""
    c = int(math.floor((x - origin[k]) / cell))
    if c < 0:
        return 0
    if c >= dims[k]:
        return dims[k] - 1
    return c


@njit(cache=True)
def _lower_bound(keys, key):
    """First index of the sorted ``keys`` whose key is not below ``key`` (binary search)."""
    lo = 0
    hi = keys.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if keys[mid] < key:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def _register(lo_b, hi_b, origin, cell, dims):
    """Sorted (key, box id) entries of the cells touched by the boxes of B."""
    n = lo_b.shape[0]
    counts = np.zeros(n + 1, dtype=np.int64)
    for j in range(n):
        c = 1
        for k in range(3):
            c *= (_cell_of(hi_b[j, k], origin, cell, dims, k)
                  - _cell_of(lo_b[j, k], origin, cell, dims, k) + 1)
        counts[j + 1] = counts[j] + c
    keys = np.empty(counts[n], dtype=np.int64)
    ids = np.empty(counts[n], dtype=np.int64)
    for j in prange(n):
        p = counts[j]
        x0, x1, y0, y1, z0, z1 = _cell_range(lo_b, hi_b, j, origin, cell, dims)
        for iz in range(z0, z1 + 1):
            for iy in range(y0, y1 + 1):
                for ix in range(x0, x1 + 1):
                    keys[p] = ix + dims[0] * (iy + dims[1] * iz)
                    ids[p] = j
                    p += 1
    order = np.argsort(keys, kind="mergesort")
    return keys[order], ids[order]


@njit(cache=True, inline="always")
def _cell_range(lo, hi, i, origin, cell, dims):
    """Lowest and highest grid cell of box ``i`` along x, y, z (integers)."""
    return (_cell_of(lo[i, 0], origin, cell, dims, 0), _cell_of(hi[i, 0], origin, cell, dims, 0),
            _cell_of(lo[i, 1], origin, cell, dims, 1), _cell_of(hi[i, 1], origin, cell, dims, 1),
            _cell_of(lo[i, 2], origin, cell, dims, 2), _cell_of(hi[i, 2], origin, cell, dims, 2))


@njit(cache=True)
def _query(i, lo_a, hi_a, lo_b, hi_b, grid, same_set, out, start):
    """Count (out is None-like: start < 0) or write the pairs of box i of A; ``grid`` the
    :class:`Grid` with B's boxes registered."""
    keys, ids, origin, cell, dims = grid.keys, grid.ids, grid.origin, grid.cell, grid.dims
    npair = 0
    x0, x1, y0, y1, z0, z1 = _cell_range(lo_a, hi_a, i, origin, cell, dims)
    nk = keys.shape[0]
    for iz in range(z0, z1 + 1):
        for iy in range(y0, y1 + 1):
            for ix in range(x0, x1 + 1):
                key = ix + dims[0] * (iy + dims[1] * iz)
                p = _lower_bound(keys, key)
                while p < nk and keys[p] == key:
                    j = ids[p]
                    p += 1
                    if same_set and j <= i:
                        continue
                    overlap = True
                    for k in range(3):
                        if lo_a[i, k] > hi_b[j, k] or lo_b[j, k] > hi_a[i, k]:
                            overlap = False
                            break
                    if not overlap:
                        continue
                    # report once: from the cell of the intersection's lower corner
                    if (_cell_of(max(lo_a[i, 0], lo_b[j, 0]), origin, cell, dims, 0) != ix
                            or _cell_of(max(lo_a[i, 1], lo_b[j, 1]), origin, cell, dims, 1) != iy
                            or _cell_of(max(lo_a[i, 2], lo_b[j, 2]), origin, cell, dims, 2) != iz):
                        continue
                    if start >= 0:
                        out[start + npair, 0] = i
                        out[start + npair, 1] = j
                    npair += 1
    return npair


@njit(cache=True, parallel=True)
def box_pairs(lo_a, hi_a, lo_b, hi_b, cell, same_set):
    """Candidate pairs of overlapping AABBs by uniform-grid spatial hashing.

    Parameters
    ----------
    lo_a, hi_a : (n_a, 3) lower / upper corners of the boxes of set A.
    lo_b, hi_b : (n_b, 3) the same for set B (pass the A arrays again when same_set).
    cell : grid cell edge (mm), about the typical box extent.
    same_set : True when A and B are the same list: each pair is returned once with
        i < j and no self pairs.

    Returns
    -------
    pairs : (n_pairs, 2) int64, ``pairs[p] = (i, j)`` with box i of A overlapping box j
        of B (closed boxes: touching counts), sorted by i; unique.
    """
    n_a = lo_a.shape[0]
    if n_a == 0 or lo_b.shape[0] == 0:
        return np.empty((0, 2), dtype=np.int64)
    origin, dims = _cell_grid(lo_a, hi_a, lo_b, hi_b, cell)
    if float(dims[0]) * float(dims[1]) * float(dims[2]) > 4.0e18:
        raise ValueError("box_pairs: cell too small for the domain (int64 key overflow)")
    keys, ids = _register(lo_b, hi_b, origin, cell, dims)
    grid = Grid(origin, cell, dims, keys, ids)
    dummy = np.empty((0, 2), dtype=np.int64)
    counts = np.empty(n_a, dtype=np.int64)
    for i in prange(n_a):
        counts[i] = _query(i, lo_a, hi_a, lo_b, hi_b, grid, same_set, dummy, -1)
    offsets = np.empty(n_a + 1, dtype=np.int64)
    offsets[0] = 0
    for i in range(n_a):
        offsets[i + 1] = offsets[i] + counts[i]
    out = np.empty((offsets[n_a], 2), dtype=np.int64)
    for i in prange(n_a):
        _query(i, lo_a, hi_a, lo_b, hi_b, grid, same_set, out, offsets[i])
    return out


@njit(cache=True)
def segment_aabbs(x, seg, radius, margin):
    """AABBs of 2-node segments inflated by their radius and a margin.

    x : (n_nodes, 3+) positions (only [:, :3] used); seg : (n_seg, 2) node ids;
    radius : (n_seg,) radii (mm); margin : search margin (mm).
    Returns lo, hi : (n_seg, 3).
    """
    n = seg.shape[0]
    lo = np.empty((n, 3))
    hi = np.empty((n, 3))
    for e in range(n):
        a = seg[e, 0]
        b = seg[e, 1]
        pad = radius[e] + margin
        for k in range(3):
            lo[e, k] = min(x[a, k], x[b, k]) - pad
            hi[e, k] = max(x[a, k], x[b, k]) + pad
    return lo, hi


@njit(cache=True)
def quad_aabbs(x, quads, half_thickness, margin):
    """AABBs of 4-node facets inflated by their half thickness and a margin.

    quads : (n_q, 4) node ids; half_thickness : (n_q,) (mm); margin (mm).
    Returns lo, hi : (n_q, 3).
    """
    n = quads.shape[0]
    lo = np.empty((n, 3))
    hi = np.empty((n, 3))
    for q in range(n):
        pad = half_thickness[q] + margin
        for k in range(3):
            a = x[quads[q, 0], k]
            b = a
            for m in range(1, 4):
                c = x[quads[q, m], k]
                a = min(a, c)
                b = max(b, c)
            lo[q, k] = a - pad
            hi[q, k] = b + pad
    return lo, hi


@njit(cache=True)
def node_aabbs(x, nodes, radius, margin):
    """AABBs (cubes) of nodes: ``x[nodes] -+ (radius + margin)``; radius (n,) per node."""
    n = nodes.shape[0]
    lo = np.empty((n, 3))
    hi = np.empty((n, 3))
    for i in range(n):
        pad = radius[i] + margin
        for k in range(3):
            lo[i, k] = x[nodes[i], k] - pad
            hi[i, k] = x[nodes[i], k] + pad
    return lo, hi


# --------------------------------------------------------------- narrow phase (skin)
@njit(cache=True, inline="always")
def segment_closest_params(A, B, C, E, F):
    """Parameters ``(s, u)`` in [0, 1]^2 of the closest points ``a0 + s da``, ``b0 + u db``
    of two segments of nonzero length, from ``A = da.da, B = da.db, C = da.r, E = db.db,
    F = db.r`` (``r = a0 - b0``): the unconstrained minimiser of the squared distance,
    clamped on s, u solved for it and clamped, s recomputed for a clamped u (Ericson 2005,
    Real-Time Collision Detection, sec. 5.1.9); parallel segments (``A E - B^2 <= 0``)
    start from s = 0."""
    denom = A * E - B * B
    s = min(1.0, max(0.0, (B * F - C * E) / denom)) if denom > 0.0 else 0.0
    u = (B * s + F) / E
    if u < 0.0:
        u = 0.0
        s = min(1.0, max(0.0, -C / A))
    elif u > 1.0:
        u = 1.0
        s = min(1.0, max(0.0, (B - C) / A))
    return s, u


@njit(cache=True)
def segment_distance(x, a0, a1, b0, b1):
    """Smallest distance between the segments ``x[a0] x[a1]`` and ``x[b0] x[b1]``.

    Closest points by :func:`segment_closest_params`; a point segment is handled as a
    point."""
    d1 = np.empty(3)
    d2 = np.empty(3)
    r = np.empty(3)
    for k in range(3):
        d1[k] = x[a1, k] - x[a0, k]
        d2[k] = x[b1, k] - x[b0, k]
        r[k] = x[a0, k] - x[b0, k]
    A = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]
    E = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]
    F = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2]
    if A <= 0.0 and E <= 0.0:
        s = u = 0.0
    elif A <= 0.0:
        s = 0.0
        u = min(1.0, max(0.0, F / E))
    else:
        C = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2]
        if E <= 0.0:
            u = 0.0
            s = min(1.0, max(0.0, -C / A))
        else:
            B = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]
            s, u = segment_closest_params(A, B, C, E, F)
    d = 0.0
    for k in range(3):
        c = r[k] + s * d1[k] - u * d2[k]
        d += c * c
    return math.sqrt(d)


@njit(cache=True)
def near_segment_pairs(x, seg, seg_r, pairs, margin):
    """Mask of the candidate pairs (e.g. of :func:`box_pairs` on :func:`segment_aabbs`)
    whose segments are closer than ``r_a + r_b + margin`` -- the Verlet skin on the true
    distance.  Until the next search every node stays within ``margin / 2`` of where it
    is now (the search rule), so two segments approach by less than ``margin``: a pair
    dropped here cannot touch before then.  The mask keeps the order of ``pairs``."""
    keep = np.empty(pairs.shape[0], dtype=np.bool_)
    for p in range(pairs.shape[0]):
        a = pairs[p, 0]
        b = pairs[p, 1]
        reach = (seg_r[a] + seg_r[b] + margin) * (1.0 + 1e-9)
        keep[p] = segment_distance(x, seg[a, 0], seg[a, 1], seg[b, 0], seg[b, 1]) < reach
    return keep
