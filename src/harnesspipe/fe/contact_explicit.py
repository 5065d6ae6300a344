"""Contact, friction and cohesive kernels of the explicit high-fidelity bundle model (Sec. 4.1).

Interactions of the 3-point bending model of a wire bundle (eqs. 6-10):

(a) ``beam_beam_contact``     wire-wire, penalty normal + eq. 6 friction;
(b) ``chain_cylinder_contact`` beam chains (wires) against rigid cylinders (rollers,
                              loading pin): one contact per (wire, cylinder) at the wire's
                              closest point, constant-mu Coulomb, reaction on each cylinder;
    ``facets_cylinder_contact`` a set of shell quads (tube, tape) against the same
                              cylinders: one contact per (connected patch, cylinder) at the
                              facets' closest point;
(c) ``node_facet_contact``    nodes (wires) against shell quads (tube, tape), one-sided,
                              eq. 6 friction;
(d) ``cohesive_ties_quad`` / ``cohesive_ties_beam``  tape bonded to the tube / the wires by
                              the damaged cohesive law of eqs. 7-10 (fixed node-to-point ties)
                              with a dashpot beside each tie (:func:`_tie_dashpot`);
(e) ``make_ties``             Python helper building the ties from the initial geometry.

Conventions.  Units mm, N, s.  ``x`` (n_nodes, 3+) current positions, ``v``
(n_nodes, 3+) current half-step velocities (translations in [:, :3]), so that the
increment of the step that led to ``x`` is ``v dt``.  Force arrays are (n_nodes, 6+):
every kernel ADDS the forces acting ON the nodes into them, normal (penalty) forces in
``f_n``, tangential friction forces in ``f_t`` and cohesive forces in their own array
``f_c`` (so that the caller can account the work of each; frictional dissipation is the
work of ``f_t``).  Pair loops run in ``prange`` (serially when short: SERIAL_MAX_CHUNKS) into
per-pair arrays, then a serial scatter adds them to the nodes (no races).  Wire-wire first
flags the touching pairs (with an early bounding-box reject of far candidates), then
computes forces and friction for those only; node-facet rejects pairs whose node is far
from the quad's box before projecting (see :func:`_nf_project`) and updates its history
in place.  Each parallel kernel has a serial twin built from the same pieces
(``*_serial``): the hi-fi bundle runs those side by side in two lanes
(:mod:`harnesspipe.fe.bundle_lanes`), and the parallel kernels -- for a caller that runs
one kernel at a time -- are the lanes' reference in the tests.

History.  Each call is one committed explicit step: friction and cohesive history
arrays are updated IN PLACE.  Do not call a kernel twice for the same step.

* Slot arrays (wire-wire, node-facet): ``hist_partner`` (n_owner, MAXS) int64, -1 for a
  free slot, else the partner id (segment / quad); ``hist_ft`` (n_owner, MAXS, ..., 3)
  the committed elastic tangential (friction) force per unit weight of the contact point,
  a global vector.  Allocate with :func:`new_slot_history`.  After each call the slots
  hold exactly the contacts active in that call (an inactive pair forgets its friction).
  A contact whose partner changes to an ADJACENT element (shares a node: sliding onto the
  next element) inherits the old partner's force.  At most MAXS partners per owner are
  remembered (an overflowing contact still acts, but restarts from zero friction): size
  the history with :func:`fit_slot_history` after every search.
* Friction force at the current step: ``f_old`` is rotated onto the current tangent
  plane (projected and rescaled to keep its magnitude), then
  ``rate_dependent_friction`` / ``coulomb_return_map`` of :mod:`harnesspipe.fe.friction`.
* Eq. 6 rate in physical time: ``dt_phys = dt * time_scale`` with ``time_scale`` =
  physical duration / simulated duration; the slip rate is ``|dg_t| / dt_phys``.

Normal law everywhere: ``p = k_n max(-gap, 0)`` (linear penalty, no contact damping).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from harnesspipe.fe.cohesive import cohesive_dissipated_energy, cohesive_traction
from harnesspipe.fe.friction import coulomb_return_map, rate_dependent_friction
from harnesspipe.fe.rotation import quat_to_matrix
from harnesspipe.fe.spatial_hash import (box_pairs, node_aabbs, quad_aabbs, segment_aabbs,
                                         segment_closest_params)

PARALLEL_COS = (0.98, 0.995)   # |cos| of two segments: crossing rule below, parallel rule above,
                               # both blended in between (see _segment_points)
WW_POINTS = 3           # wire-wire contact points per pair: crossing point, two parallel ends
DEFAULT_MAXS = 8
CHUNK = 64              # items per parallel task (scratch arrays are allocated per task)
SERIAL_MAX_CHUNKS = 1   # up to this many tasks a loop runs serially (no parallel-region cost)
ENTRY_FRACTION = 0.05    # node-facet: a contact begins at most this far (x (r + t/2)) inside the surface
REJECT_TOL = 1e-9       # relative slack of the early distance rejects (round-off of the points)
LM_DAMP = 1e-9          # facet-to-axis projection: Levenberg term (x trace) for facets parallel to a pin
PATCH_REACH = 1.0       # facets within this x R of a pin's surface form its contact patches
SOFTMIN_TAU = 0.01      # mm: width of the soft minimum of a patch's facet gaps (pin contact)


def new_slot_history(n_owner, maxs=DEFAULT_MAXS, points=1):
    """Empty slot history: ``hist_partner`` (n_owner, maxs) = -1 and ``hist_ft``.

    ``points=WW_POINTS`` for wire-wire (``hist_ft`` (n_seg, maxs, WW_POINTS, 3));
    ``points=1`` for node-facet (``hist_ft`` (n_nodes_list, maxs, 3)).
    """
    hp = -np.ones((n_owner, maxs), dtype=np.int64)
    if points == 1:
        return hp, np.zeros((n_owner, maxs, 3))
    return hp, np.zeros((n_owner, maxs, points, 3))


def fit_slot_history(hist, owners):
    """The slot history ``(hist_partner, hist_ft)`` with room for every owner's candidate
    partners (``owners``: the owner of each candidate pair, e.g. ``min(a, b)`` of the
    wire-wire pairs); existing slots are kept.  A touching pair that finds no free slot
    loses its stick force at every step, and which pairs lose it depends on the pair order."""
    hp, hf = hist
    grow = int(np.bincount(owners, minlength=hp.shape[0]).max(initial=0)) - hp.shape[1]
    if grow <= 0:
        return hist
    pad = ((0, 0), (0, grow)) + ((0, 0),) * (hf.ndim - 2)
    return np.pad(hp, pad[:2], constant_values=-1), np.pad(hf, pad)


# ----------------------------------------------------------------------------- helpers
@njit(cache=True, inline="always")
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def _rotate_onto_plane(f, n):
    """Project ``f`` (3,) onto the plane normal to unit ``n`` keeping |f| (in place)."""
    m0 = math.sqrt(_dot(f, f))
    if m0 == 0.0:
        return
    fn = _dot(f, n)
    for k in range(3):
        f[k] -= fn * n[k]
    m1 = math.sqrt(_dot(f, f))
    if m1 < 1e-12 * m0:
        for k in range(3):
            f[k] = 0.0
        return
    for k in range(3):
        f[k] *= m0 / m1


@njit(cache=True)
def _to_tangent_plane(f_old, dg, n):
    """Friction inputs on the current tangent plane (unit normal ``n``), in place: the
    committed force ``f_old`` rotated onto it (:func:`_rotate_onto_plane`), the slip
    increment ``dg`` projected on it."""
    _rotate_onto_plane(f_old, n)
    dgn = _dot(dg, n)
    for k in range(3):
        dg[k] -= dgn * n[k]


@njit(cache=True)
def _any_perpendicular(d, out):
    """A unit vector normal to ``d``."""
    ax = 0
    if abs(d[1]) < abs(d[ax]):
        ax = 1
    if abs(d[2]) < abs(d[ax]):
        ax = 2
    e0 = 1.0 if ax == 0 else 0.0
    e1 = 1.0 if ax == 1 else 0.0
    e2 = 1.0 if ax == 2 else 0.0
    out[0] = d[1] * e2 - d[2] * e1
    out[1] = d[2] * e0 - d[0] * e2
    out[2] = d[0] * e1 - d[1] * e0
    m = math.sqrt(_dot(out, out))
    for k in range(3):
        out[k] /= m


@njit(cache=True)
def _share_node(conn, a, b):
    for i in range(conn.shape[1]):
        for j in range(conn.shape[1]):
            if conn[a, i] == conn[b, j]:
                return True
    return False


@njit(cache=True)
def _find_slot(hist_partner, conn, owner, partner):
    """Slot of ``partner`` in the owner's row, else of an element adjacent to it, else -1."""
    maxs = hist_partner.shape[1]
    for s in range(maxs):
        if hist_partner[owner, s] == partner:
            return s
    for s in range(maxs):
        q = hist_partner[owner, s]
        if q >= 0 and _share_node(conn, q, partner):
            return s
    return -1


@njit(cache=True)
def _free_slot(hist_partner, owner):
    for s in range(hist_partner.shape[1]):
        if hist_partner[owner, s] < 0:
            return s
    return -1


@njit(cache=True)
def _quad_tangents(x, quads, q, xi, eta, X, X_xi, X_eta):
    """Point X and tangents X_xi, X_eta of the bilinear quad q at (xi, eta) (written)."""
    for k in range(3):
        X[k] = 0.0
        X_xi[k] = 0.0
        X_eta[k] = 0.0
    for m in range(4):
        sx = -1.0 if (m == 0 or m == 3) else 1.0
        se = -1.0 if (m == 0 or m == 1) else 1.0
        Nm = 0.25 * (1 + sx * xi) * (1 + se * eta)
        dx = 0.25 * sx * (1 + se * eta)
        de = 0.25 * se * (1 + sx * xi)
        for k in range(3):
            c = x[quads[q, m], k]
            X[k] += Nm * c
            X_xi[k] += dx * c
            X_eta[k] += de * c


@njit(cache=True)
def _quad_eval(x, quads, q, xi, eta, X, n, e1):
    """Point X, unit normal n = unit(X_xi x X_eta), unit tangent e1 = unit(X_xi) (written)."""
    _quad_tangents(x, quads, q, xi, eta, X, e1, n)    # X_eta kept in n for now
    c0 = e1[1] * n[2] - e1[2] * n[1]
    c1 = e1[2] * n[0] - e1[0] * n[2]
    c2 = e1[0] * n[1] - e1[1] * n[0]
    nn = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    n[0] = c0 / nn
    n[1] = c1 / nn
    n[2] = c2 / nn
    le = math.sqrt(_dot(e1, e1))
    for k in range(3):
        e1[k] /= le


def quad_point(x, quads, q, xi, eta):
    """Point, unit normal (X_xi x X_eta) and unit tangent X_xi of quad q at (xi, eta)."""
    X = np.empty(3)
    n = np.empty(3)
    e1 = np.empty(3)
    _quad_eval(np.asarray(x, dtype=float), np.asarray(quads, dtype=np.int64), q, xi, eta, X, n, e1)
    return X, n, e1


@njit(cache=True)
def _project_quad(x, quads, q, p, clamp, out):
    """Closest point parameters of point p on quad q by Gauss-Newton (at most 7 iterations).

    ``clamp``: keep (xi, eta) in [-1, 1]^2 (projected iterations).  Writes
    out = (xi, eta, X(3), n(3)) as out[0:2], out[2:5], out[5:8]; unit normal X_xi x X_eta.
    """
    xi = 0.0
    eta = 0.0
    X0 = x[quads[q, 0]]
    X1 = x[quads[q, 1]]
    X2 = x[quads[q, 2]]
    X3 = x[quads[q, 3]]
    done = False
    for it in range(8):
        a0 = 0.25 * (1 - xi) * (1 - eta)
        a1 = 0.25 * (1 + xi) * (1 - eta)
        a2 = 0.25 * (1 + xi) * (1 + eta)
        a3 = 0.25 * (1 - xi) * (1 + eta)
        bx0 = -0.25 * (1 - eta)
        bx1 = 0.25 * (1 - eta)
        bx2 = 0.25 * (1 + eta)
        bx3 = -0.25 * (1 + eta)
        be0 = -0.25 * (1 - xi)
        be1 = -0.25 * (1 + xi)
        be2 = 0.25 * (1 + xi)
        be3 = 0.25 * (1 - xi)
        Xs0 = a0 * X0[0] + a1 * X1[0] + a2 * X2[0] + a3 * X3[0]
        Xs1 = a0 * X0[1] + a1 * X1[1] + a2 * X2[1] + a3 * X3[1]
        Xs2 = a0 * X0[2] + a1 * X1[2] + a2 * X2[2] + a3 * X3[2]
        tx0 = bx0 * X0[0] + bx1 * X1[0] + bx2 * X2[0] + bx3 * X3[0]
        tx1 = bx0 * X0[1] + bx1 * X1[1] + bx2 * X2[1] + bx3 * X3[1]
        tx2 = bx0 * X0[2] + bx1 * X1[2] + bx2 * X2[2] + bx3 * X3[2]
        te0 = be0 * X0[0] + be1 * X1[0] + be2 * X2[0] + be3 * X3[0]
        te1 = be0 * X0[1] + be1 * X1[1] + be2 * X2[1] + be3 * X3[1]
        te2 = be0 * X0[2] + be1 * X1[2] + be2 * X2[2] + be3 * X3[2]
        if done or it == 7:
            break
        r0 = p[0] - Xs0
        r1 = p[1] - Xs1
        r2 = p[2] - Xs2
        A = tx0 * tx0 + tx1 * tx1 + tx2 * tx2
        B = tx0 * te0 + tx1 * te1 + tx2 * te2
        C = te0 * te0 + te1 * te1 + te2 * te2
        g0 = tx0 * r0 + tx1 * r1 + tx2 * r2
        g1 = te0 * r0 + te1 * r1 + te2 * r2
        det = A * C - B * B
        if det <= 0.0:
            break
        dxi = (C * g0 - B * g1) / det
        deta = (A * g1 - B * g0) / det
        xi += dxi
        eta += deta
        if clamp:
            xi = min(1.0, max(-1.0, xi))
            eta = min(1.0, max(-1.0, eta))
        else:   # keep the iteration bounded for far-off points
            xi = min(3.0, max(-3.0, xi))
            eta = min(3.0, max(-3.0, eta))
        done = abs(dxi) + abs(deta) < 1e-10   # refresh the point once more, then stop
    out[0] = xi
    out[1] = eta
    out[2] = Xs0
    out[3] = Xs1
    out[4] = Xs2
    n0 = tx1 * te2 - tx2 * te1
    n1 = tx2 * te0 - tx0 * te2
    n2 = tx0 * te1 - tx1 * te0
    nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    out[5] = n0 / nn
    out[6] = n1 / nn
    out[7] = n2 / nn


# ---------------------------------------------------------------- (a) wire-wire contact
@njit(cache=True)
def _segment_points(x, seg, a, b, valence, s_out, u_out, w_out, blend):
    """Contact points of segments a, b (up to ``WW_POINTS``); returns the bit mask of the
    points present (0: none).  ``w_out`` are the weights of each rule alone; the blend
    factor beta and its derivative d beta / d|cos| go to ``blend``.

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
        blend[0] = 0.0
        blend[1] = 0.0
    elif cosab >= c1:
        blend[0] = 1.0
        blend[1] = 0.0
    else:
        t = (cosab - c0) / (c1 - c0)
        blend[0] = t * t * (3.0 - 2.0 * t)
        blend[1] = 6.0 * t * (1.0 - t) / (c1 - c0)
    mask = 0
    if blend[0] < 1.0:                    # not parallel: A E - B^2 > 0
        s, u = segment_closest_params(A, B, C, E, F)
        w = 1.0
        if (s == 0.0 and valence[a0] > 1) or (s == 1.0 and valence[a1] > 1):
            w *= 0.5
        if (u == 0.0 and valence[b0] > 1) or (u == 1.0 and valence[b1] > 1):
            w *= 0.5
        s_out[0] = s
        u_out[0] = u
        w_out[0] = w
        mask = 1
    if blend[0] > 0.0:
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
                s_out[k] = s
                u_out[k] = min(1.0, max(0.0, u))
                w_out[k] = w
            mask |= 6
    return mask


@njit(cache=True)
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


@njit(cache=True, parallel=True)
def beam_beam_contact(x, v, seg, seg_r, seg_body, pairs, k_n, k_t, mu_s, mu_k, d_c, dt,
                      time_scale, hist_partner, hist_ft, f_n, f_t):
    """Wire-wire penalty contact with eq. 6 friction between 2-node beam segments.

    Parameters
    ----------
    x, v : (n_nodes, 3+) positions, half-step velocities.
    seg : (n_seg, 2) node ids of the segments; seg_r : (n_seg,) radii (mm);
    seg_body : (n_seg,) wire id (segments of one wire never contact each other).
    pairs : (n_pairs, 2) candidate segment pairs (e.g. ``box_pairs(.., same_set=True)``
        on ``segment_aabbs``); the owner of a pair's history is ``min(a, b)``.
    k_n : normal penalty (N/mm per unit weight of a contact point);
    k_t : tangential (stick) penalty (N/mm), 0 disables friction.
    mu_s, mu_k, d_c : eq. 6 (d_c in s of PHYSICAL time).
    dt : solver step; time_scale : physical / simulated duration (dt_phys = dt time_scale).
    hist_partner : (n_seg, MAXS) int64; hist_ft : (n_seg, MAXS, WW_POINTS, 3) friction
        history per (owner, partner slot, contact point), in place (``new_slot_history(n_seg,
        maxs, points=WW_POINTS)``).
    f_n, f_t : (n_nodes, 3+) outputs, normal and friction forces ADDED.

    Geometry: gap ``|p_a - p_b| - r_a - r_b`` at the contact points of
    :func:`_segment_points` (closest points for crossing segments; for nearly parallel
    segments the two ends of their common part, node-to-segment like, which is well posed
    and continuous under tangential motion; blended in between, with the blend's own
    energy gradient).  Point forces go to the end nodes by the linear shape functions
    ``(1 - s, s)``.

    Returns the number of pairs with at least one active contact point.
    """
    n_pairs = pairs.shape[0]
    valence = _valence(seg, x.shape[0])
    # phase 1: which pairs touch, and at which of their points (kept for phase 2)
    flag = np.empty(n_pairs, dtype=np.int8)
    pts = np.empty((n_pairs, 4, WW_POINTS))   # s, u, weight per point; beta, beta' (row 3)
    n_chunks = (n_pairs + CHUNK - 1) // CHUNK
    if n_chunks <= SERIAL_MAX_CHUNKS:
        _ww_flags(x, seg, seg_r, seg_body, pairs, valence, 0, n_pairs, flag, pts)
    else:
        for ch in prange(n_chunks):
            _ww_flags(x, seg, seg_r, seg_body, pairs, valence, ch * CHUNK,
                      min(n_pairs, (ch + 1) * CHUNK), flag, pts)
    idx = _touching(flag)
    n_act = idx.size
    # phase 2: forces and friction of the touching pairs only
    pfn = np.empty((n_act, WW_POINTS, 3))     # weighted normal force on a's point
    pft = np.empty((n_act, WW_POINTS, 3))     # weighted friction force on a's point
    hnew = np.empty((n_act, WW_POINTS, 3))    # new friction history (per unit weight)
    pdu = np.empty(n_act)                     # (U_par - U_cross) beta' of the blend
    dt_phys = dt * time_scale
    n_chunks = (n_act + CHUNK - 1) // CHUNK
    if n_chunks <= SERIAL_MAX_CHUNKS:
        _ww_forces(x, v, seg, seg_r, pairs, idx, flag, pts, k_n, k_t, mu_s, mu_k, d_c, dt,
                   dt_phys, hist_partner, hist_ft, 0, n_act, pfn, pft, hnew, pdu)
    else:
        for ch in prange(n_chunks):
            _ww_forces(x, v, seg, seg_r, pairs, idx, flag, pts, k_n, k_t, mu_s, mu_k, d_c,
                       dt, dt_phys, hist_partner, hist_ft, ch * CHUNK,
                       min(n_act, (ch + 1) * CHUNK), pfn, pft, hnew, pdu)
    _ww_commit(x, seg, pairs, idx, flag, pts, pfn, pft, hnew, pdu, hist_partner, hist_ft,
               f_n, f_t)
    return n_act


@njit(cache=True)
def beam_beam_contact_serial(x, v, seg, seg_r, seg_body, pairs, k_n, k_t, mu_s, mu_k, d_c,
                             dt, time_scale, hist_partner, hist_ft, f_n, f_t):
    """Serial twin of :func:`beam_beam_contact` (for a caller that runs it beside other
    work); the same phases, the same arithmetic, the same results."""
    n_pairs = pairs.shape[0]
    valence = _valence(seg, x.shape[0])
    flag = np.empty(n_pairs, dtype=np.int8)
    pts = np.empty((n_pairs, 4, WW_POINTS))
    _ww_flags(x, seg, seg_r, seg_body, pairs, valence, 0, n_pairs, flag, pts)
    idx = _touching(flag)
    n_act = idx.size
    pfn = np.empty((n_act, WW_POINTS, 3))
    pft = np.empty((n_act, WW_POINTS, 3))
    hnew = np.empty((n_act, WW_POINTS, 3))
    pdu = np.empty(n_act)
    _ww_forces(x, v, seg, seg_r, pairs, idx, flag, pts, k_n, k_t, mu_s, mu_k, d_c, dt,
               dt * time_scale, hist_partner, hist_ft, 0, n_act, pfn, pft, hnew, pdu)
    _ww_commit(x, seg, pairs, idx, flag, pts, pfn, pft, hnew, pdu, hist_partner, hist_ft,
               f_n, f_t)
    return n_act


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


@njit(cache=True)
def _ww_commit(x, seg, pairs, idx, flag, pts, pfn, pft, hnew, pdu, hist_partner, hist_ft,
               f_n, f_t):
    """The serial end of the wire-wire contact: the new friction history of the touching
    pairs replaces the old one, and their point forces go to the segments' end nodes
    (in pair order)."""
    for i in range(hist_partner.shape[0]):
        for s in range(hist_partner.shape[1]):
            hist_partner[i, s] = -1
    for j in range(idx.size):
        p = idx[j]
        a = pairs[p, 0]
        b = pairs[p, 1]
        if a > b:
            a, b = b, a
        slot = _free_slot(hist_partner, a)
        if slot >= 0:
            hist_partner[a, slot] = b
            for k in range(WW_POINTS):
                for c in range(3):
                    hist_ft[a, slot, k, c] = hnew[j, k, c]
        a0 = seg[a, 0]
        a1 = seg[a, 1]
        b0 = seg[b, 0]
        b1 = seg[b, 1]
        if pdu[j] != 0.0:
            _blend_forces(x, a0, a1, b0, b1, pdu[j], f_n)
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


@njit(cache=True)
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


@njit(cache=True)
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


@njit(cache=True)
def _ww_flags(x, seg, seg_r, seg_body, pairs, valence, p0, p1, flag, pts):
    """flag[p] for pairs p0..p1-1: bit k set if contact point k of the pair penetrates;
    for a pair with a flag, its points (:func:`_segment_points`) into ``pts[p]``: rows s,
    u, weight, and (beta, beta', rule mask) in row 3."""
    for p in range(p0, p1):
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
        m = _segment_points(x, seg, a, b, valence, pts[p, 0], pts[p, 1], pts[p, 2], pts[p, 3])
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


@njit(cache=True)
def _ww_forces(x, v, seg, seg_r, pairs, idx, flag, pts, k_n, k_t, mu_s, mu_k, d_c, dt,
               dt_phys, hist_partner, hist_ft, j0, j1, pfn, pft, hnew, pdu):
    """Normal and friction forces of the touching pairs idx[j0:j1] (compact arrays by j) at
    their points ``pts`` (:func:`_ww_flags`); ``pdu[j]``: (U_par - U_cross) beta' for
    :func:`_blend_forces`."""
    scr = np.zeros((4, 3))
    for j in range(j0, j1):
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
        wv = pts[p, 2]
        bl = pts[p, 3]
        m = int(bl[2])
        beta = bl[0]
        u_cross = 0.0
        u_par = 0.0
        slot = -2                        # looked up at the first active point
        a0 = seg[a, 0]
        a1 = seg[a, 1]
        b0 = seg[b, 0]
        b1 = seg[b, 1]
        rr = seg_r[a] + seg_r[b]
        fold = scr[0]
        dg = scr[1]
        ds = scr[2]
        nv = scr[3]
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
                _any_perpendicular(dg, nv)
            pn = -k_n * gap
            if k == 0:
                u_cross += 0.5 * wv[k] * pn * (-gap)
                w = (1.0 - beta) * wv[k]
            else:
                u_par += 0.5 * wv[k] * pn * (-gap)
                w = beta * wv[k]
            for c in range(3):
                pfn[j, k, c] = w * pn * nv[c]
            if k_t <= 0.0:
                continue
            if slot == -2:
                slot = _find_slot(hist_partner, seg, a, b)
            for c in range(3):
                fold[c] = hist_ft[a, slot, k, c] if slot >= 0 else 0.0
                dg[c] = dt * ((1 - s) * v[a0, c] + s * v[a1, c]
                              - (1 - u) * v[b0, c] - u * v[b1, c])
            _to_tangent_plane(fold, dg, nv)
            rate_dependent_friction(fold, dg, dt_phys, k_t, mu_s, mu_k, d_c, pn, hnew[j, k], ds)
            for c in range(3):
                pft[j, k, c] = -w * hnew[j, k, c]
        pdu[j] = (u_par - u_cross) * bl[1]
        # a rule not in use hands its points the other's stick force (no loss at a switch)
        if m == 1:
            for c in range(3):
                hnew[j, 1, c] = hnew[j, 0, c]
                hnew[j, 2, c] = hnew[j, 0, c]
        elif m == 6:
            for c in range(3):
                hnew[j, 0, c] = 0.5 * (hnew[j, 1, c] + hnew[j, 2, c])


# ------------------------------------------- (b) wires and shell facets on rigid cylinders
@njit(cache=True)
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


@njit(cache=True)
def _chain_pins(x, v, seg, seg_r, chain_start, w, mu, cyl_c, cyl_axis, cyl_R, cyl_v, k_n, k_t,
                dt, hist_ft, f_n, f_t, part, act, nv, dg, fold, fnew, ds):
    """Chain ``w`` against every cylinder (:func:`chain_cylinder_contact`): forces on its
    nodes into ``f_n``, ``f_t``, on the cylinders into ``part[w]``, contacts into act[w]."""
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
        al = _dot(nv, ax)
        for k in range(3):
            nv[k] -= al * ax[k]
        dist = math.sqrt(_dot(nv, nv))
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
        _to_tangent_plane(fold, dg, nv)
        coulomb_return_map(fold, dg, k_t, mu, pn, fnew, ds)
        for k in range(3):
            hist_ft[w, c, k] = fnew[k]
            f_t[a, k] -= (1.0 - s) * fnew[k]
            f_t[b, k] -= s * fnew[k]
            part[w, c, k] += fnew[k]


@njit(cache=True, parallel=True)
def chain_cylinder_contact(x, v, seg, seg_r, chain_start, mu, cyl_c, cyl_axis, cyl_R, cyl_v,
                           k_n, k_t, dt, hist_ft, f_n, f_t, f_cyl):
    """Penalty contact of beam chains (wires) with rigid unbounded cylinders, Coulomb friction.

    A wire meets a 5 mm pin over a few millimetres, less than its element length: nodes
    alone (spheres at the nodes) let a wire whose nodes straddle a roller fall
    through it.  Here each chain (the segments ``chain_start[w] .. chain_start[w + 1] - 1``
    of ``seg``, consecutive along the wire) touches each cylinder at most once, at the point
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
    n_cyl = cyl_c.shape[0]
    n_ch = chain_start.shape[0] - 1
    part = np.empty((n_ch, n_cyl, 3))        # force on each cylinder from each chain
    act = np.empty(n_ch, dtype=np.int64)     # (filled by hand: np.zeros would be a parallel loop)
    for w in range(n_ch):
        act[w] = 0
        for c in range(n_cyl):
            for k in range(3):
                part[w, c, k] = 0.0
    size = (n_ch + 1) // 2                   # two tasks (scratch allocated per task)
    for task in prange(2):
        nv = np.empty(3)
        dg = np.empty(3)
        fold = np.empty(3)
        fnew = np.empty(3)
        ds = np.empty(3)
        for w in range(task * size, min(n_ch, (task + 1) * size)):
            _chain_pins(x, v, seg, seg_r, chain_start, w, mu, cyl_c, cyl_axis, cyl_R, cyl_v,
                        k_n, k_t, dt, hist_ft, f_n, f_t, part, act, nv, dg, fold, fnew, ds)
    return _chain_sum(act, part, f_cyl)


@njit(cache=True)
def chain_cylinder_contact_serial(x, v, seg, seg_r, chain_start, mu, cyl_c, cyl_axis, cyl_R,
                                  cyl_v, k_n, k_t, dt, hist_ft, f_n, f_t, f_cyl):
    """Serial twin of :func:`chain_cylinder_contact` (for a caller that runs it beside
    other work); the same arithmetic, the same results."""
    n_ch = chain_start.shape[0] - 1
    part = np.zeros((n_ch, cyl_c.shape[0], 3))
    act = np.zeros(n_ch, dtype=np.int64)
    nv = np.empty(3)
    dg = np.empty(3)
    fold = np.empty(3)
    fnew = np.empty(3)
    ds = np.empty(3)
    for w in range(n_ch):
        _chain_pins(x, v, seg, seg_r, chain_start, w, mu, cyl_c, cyl_axis, cyl_R, cyl_v, k_n,
                    k_t, dt, hist_ft, f_n, f_t, part, act, nv, dg, fold, fnew, ds)
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


@njit(cache=True)
def _quad_axis_closest(x, quads, q, c0, ax, out):
    """Point of the bilinear quad ``q`` closest to the axis line (point ``c0``, unit ``ax``).

    Minimises f = 1/2 |P (X(xi, eta) - c0)|^2, P = I - ax ax^T, over [-1, 1]^2 by projected
    Gauss-Newton: a coordinate on its bound whose gradient points outwards is held there
    and the other one solved alone (active set).  A quad with a direction along the axis
    (a facet parallel to the pin) has a line of minimisers; the Levenberg term
    ``LM_DAMP trace`` keeps the iterate at the point of that line nearest the previous
    iterate (the quad's centre line), with no effect on the distance.
    Writes out = (xi, eta, dist, n(3)), n the unit radial vector from the axis.
    """
    xi = 0.0
    eta = 0.0
    X = np.empty(3)
    tx = np.empty(3)
    te = np.empty(3)
    for it in range(12):
        _quad_tangents(x, quads, q, xi, eta, X, tx, te)
        rl = (X[0] - c0[0]) * ax[0] + (X[1] - c0[1]) * ax[1] + (X[2] - c0[2]) * ax[2]
        xl = _dot(tx, ax)
        el = _dot(te, ax)
        for k in range(3):
            X[k] -= c0[k] + rl * ax[k]          # radial offset P (X - c0)
            tx[k] -= xl * ax[k]                 # P X_xi
            te[k] -= el * ax[k]                 # P X_eta
        if it == 11:
            break
        g0 = _dot(tx, X)
        g1 = _dot(te, X)
        A = _dot(tx, tx)
        B = _dot(tx, te)
        C = _dot(te, te)
        lam = LM_DAMP * (A + C) + 1e-300
        A += lam
        C += lam
        hold_xi = (xi <= -1.0 and g0 > 0.0) or (xi >= 1.0 and g0 < 0.0)
        hold_eta = (eta <= -1.0 and g1 > 0.0) or (eta >= 1.0 and g1 < 0.0)
        dxi = 0.0
        deta = 0.0
        if not hold_xi and not hold_eta:
            det = A * C - B * B
            dxi = -(C * g0 - B * g1) / det
            deta = -(A * g1 - B * g0) / det
        elif not hold_xi:
            dxi = -g0 / A
        elif not hold_eta:
            deta = -g1 / C
        xi_new = min(1.0, max(-1.0, xi + dxi))
        eta_new = min(1.0, max(-1.0, eta + deta))
        step = abs(xi_new - xi) + abs(eta_new - eta)
        xi = xi_new
        eta = eta_new
        if step < 1e-12:
            break
    dist = math.sqrt(_dot(X, X))
    out[0] = xi
    out[1] = eta
    out[2] = dist
    for k in range(3):
        out[3 + k] = X[k] / dist if dist > 0.0 else 0.0


@njit(cache=True)
def _facets_near(x, quads, quad_t, c0, ax, R, cand, prj_all):
    """Quads of the set whose face comes within ``PATCH_REACH R`` of the cylinder
    (c0, ax, R) (gap = distance of the mid-surface to the axis - R - t/2 < PATCH_REACH R),
    the axis not on the mid-surface itself: their ids into
    ``cand``, their closest points (:func:`_quad_axis_closest`) into ``prj_all[:, :6]`` and
    gaps into ``prj_all[:, 6]``; returns their number.  A quad whose bounding sphere stays
    farther is not projected."""
    m = 0
    prj = np.empty(6)
    for q in range(quads.shape[0]):
        cx = 0.25 * (x[quads[q, 0], 0] + x[quads[q, 1], 0] + x[quads[q, 2], 0] + x[quads[q, 3], 0])
        cy = 0.25 * (x[quads[q, 0], 1] + x[quads[q, 1], 1] + x[quads[q, 2], 1] + x[quads[q, 3], 1])
        cz = 0.25 * (x[quads[q, 0], 2] + x[quads[q, 1], 2] + x[quads[q, 2], 2] + x[quads[q, 3], 2])
        rho2 = 0.0
        for k in range(4):
            d2 = ((x[quads[q, k], 0] - cx) ** 2 + (x[quads[q, k], 1] - cy) ** 2
                  + (x[quads[q, k], 2] - cz) ** 2)
            rho2 = max(rho2, d2)
        dl = (cx - c0[0]) * ax[0] + (cy - c0[1]) * ax[1] + (cz - c0[2]) * ax[2]
        r0 = cx - c0[0] - dl * ax[0]
        r1 = cy - c0[1] - dl * ax[1]
        r2 = cz - c0[2] - dl * ax[2]
        reach = (1.0 + PATCH_REACH) * R + 0.5 * quad_t[q]
        if math.sqrt(r0 * r0 + r1 * r1 + r2 * r2) - math.sqrt(rho2) >= reach:
            continue
        _quad_axis_closest(x, quads, q, c0, ax, prj)
        gap = prj[2] - R - 0.5 * quad_t[q]
        if gap < PATCH_REACH * R and prj[2] > 0.0:
            cand[m] = q
            for k in range(6):
                prj_all[m, k] = prj[k]
            prj_all[m, 6] = gap
            m += 1
    return m


@njit(cache=True)
def _patches(quads, cand, m, patch):
    """Connected patches of the quads cand[:m] near a pin (quads sharing a node): patch id
    per quad into ``patch``; returns the number of patches."""
    for i in range(m):
        patch[i] = -1
    n_p = 0
    stack = np.empty(m, dtype=np.int64)
    for i in range(m):
        if patch[i] >= 0:
            continue
        patch[i] = n_p
        stack[0] = i
        top = 1
        while top > 0:
            top -= 1
            j = stack[top]
            for l in range(m):
                if patch[l] < 0 and _share_node(quads, cand[j], cand[l]):
                    patch[l] = n_p
                    stack[top] = l
                    top += 1
        n_p += 1
    return n_p


@njit(cache=True, inline="always")
def _bilinear(xi, eta, a):
    """Shape function N_a(xi, eta) of a bilinear quad (nodes counter-clockwise from (-1, -1))."""
    sx = -1.0 if (a == 0 or a == 3) else 1.0
    se = -1.0 if (a == 0 or a == 1) else 1.0
    return 0.25 * (1.0 + sx * xi) * (1.0 + se * eta)


@njit(cache=True)
def _patch_contact(prj_all, patch, m, p, weight):
    """Soft minimum of the gaps of patch ``p``'s quads (LogSumExp, width SOFTMIN_TAU):
    ``G = g_min - tau ln sum_q exp(-(g_q - g_min) / tau)``, smooth in the nodes, below
    min g_q by at most tau ln(number of the patch's quads), in practice by tau ln(those
    within a few tau of the minimum).  Writes the weights
    dG/dg_q (softmax, summing to 1) into ``weight`` and returns ``(G, i_dom)``, i_dom the
    quad of largest weight."""
    g_min = np.inf
    i_dom = -1
    for l in range(m):
        if patch[l] == p and prj_all[l, 6] < g_min:
            g_min = prj_all[l, 6]
            i_dom = l
    total = 0.0
    for l in range(m):
        weight[l] = 0.0
        if patch[l] == p:
            weight[l] = math.exp(-(prj_all[l, 6] - g_min) / SOFTMIN_TAU)
            total += weight[l]
    for l in range(m):
        weight[l] /= total
    return g_min - SOFTMIN_TAU * math.log(total), i_dom


@njit(cache=True)
def _patch_scratch(n_q):
    """Work arrays of the pin-facet kernels for a set of ``n_q`` quads: candidate ids,
    their closest points and gaps (:func:`_facets_near`), patch ids and soft-minimum
    weights."""
    return (np.empty(n_q, dtype=np.int64), np.empty((n_q, 7)), np.empty(n_q, dtype=np.int64),
            np.empty(n_q))


@njit(cache=True)
def facets_cylinder_gaps(x, quads, quad_t, cyl_c, cyl_axis, cyl_R):
    """Smallest patch gap G (:func:`facets_cylinder_contact`) of the set at each cylinder
    (np.inf where no quad is near): negative where a pin starts inside the soft minimum."""
    cand, prj_all, patch, weight = _patch_scratch(quads.shape[0])
    gaps = np.full(cyl_c.shape[0], np.inf)
    for c in range(cyl_c.shape[0]):
        m = _facets_near(x, quads, quad_t, cyl_c[c], cyl_axis[c], cyl_R[c], cand, prj_all)
        for p in range(_patches(quads, cand, m, patch)):
            gaps[c] = min(gaps[c], _patch_contact(prj_all, patch, m, p, weight)[0])
    return gaps


@njit(cache=True)
def facets_cylinder_contact(x, v, quads, quad_t, mu, cyl_c, cyl_axis, cyl_R, cyl_slack, cyl_v,
                            k_n, k_t, dt, hist_q, hist_ft, f_n, f_t, f_cyl):
    """Penalty contact of a set of shell facets (a tube, a tape) with rigid unbounded
    cylinders (the pins), Coulomb friction.

    A pin crosses the tube at right angles: they touch at one point, which lies between
    the shell's nodes in general.  Nodes alone (spheres of radius t/2 at the nodes) let a
    5 mm pin sink between the tube's node lines -- by R - sqrt(R^2 - (h/2)^2), 0.6 mm
    for h = 3.2 mm -- and push on the nodes at up to 40 degrees from the vertical, so the
    force curve depended on where the node lines fell.  Here the facets meet the pin
    where they come closest to its axis.

    Each quad q near the cylinder (:func:`_facets_near`: within ``PATCH_REACH R`` of its
    surface) has its closest point to the axis and gap ``g_q = distance - R - t/2``.  The
    quads form connected patches (:func:`_patches`; the two lips of an open tube's cut
    are two).  A patch's gap is the soft minimum G of its quads' gaps
    (:func:`_patch_contact`), its penalty energy ``1/2 k_n min(G, 0)^2``; the force on
    the nodes is its exact gradient: ``k_n (-G) pi_q N_a(xi_q) n_q`` from each quad,
    pi_q = dG/dg_q, n_q the radial unit vector at the quad's closest point (envelope
    theorem).  A hard minimum is a potential too, but its gradient jumps wherever two
    local minima trade places (a dented tube under the feeder, touching the pin on both
    sides of a node ring): the central-difference step then made energy, ~10 % of the
    test's work; the soft one shares the force between them smoothly.  The patches are
    drawn with the margin PATCH_REACH R so that they do not split where they touch.
    ``cyl_slack`` (n_cyl,): gap allowance per cylinder, held for the run, for a
    strain-free start where the soft minimum of a pin resting on the set is below zero
    (``-`` :func:`facets_cylinder_gaps` at t = 0, a few SOFTMIN_TAU at most).  The soft
    minimum moves the contact by up to tau ln(quads near the minimum) (0.014 mm where four
    quads meet under the pin) -- geometry well below the facets' own chord sag.

    Friction: Coulomb with ``mu`` (the pins' mu_rtb or mu_rtp), stick penalty ``k_t``,
    at the patch's contact point (weights pi_q), normal the weighted radial direction;
    history per cylinder in MAXS slots, in place: ``hist_q`` (n_cyl, MAXS) int64 the
    patch's quad of largest weight (-1 free), ``hist_ft`` (n_cyl, MAXS, 3) its committed
    friction force; a patch continues the force of the first slot whose quad it contains
    (else starts from zero); the slots of patches that left are cleared.  The Coulomb
    limit is mu times the resultant normal force pn |sum pi_q n_q|.  Every patch carries
    its normal force; beyond MAXS patches at one cylinder the extra ones are frictionless.
    ``f_cyl`` (n_cyl, 3): force ON each cylinder, ADDED.  Returns the number of active
    (patch, cylinder) contacts.
    """
    n_cyl = cyl_c.shape[0]
    maxs = hist_q.shape[1]
    cand, prj_all, patch, weight = _patch_scratch(quads.shape[0])
    slot_q = np.empty(maxs, dtype=np.int64)
    slot_f = np.empty((maxs, 3))
    nv = np.empty(3)
    dg = np.empty(3)
    fold = np.empty(3)
    fnew = np.empty(3)
    ds = np.empty(3)
    n_active = 0
    for c in range(n_cyl):
        m = _facets_near(x, quads, quad_t, cyl_c[c], cyl_axis[c], cyl_R[c], cand, prj_all)
        n_p = _patches(quads, cand, m, patch)
        for s in range(maxs):
            slot_q[s] = hist_q[c, s]
            hist_q[c, s] = -1
            for k in range(3):
                slot_f[s, k] = hist_ft[c, s, k]
                hist_ft[c, s, k] = 0.0
        slot = 0
        for p in range(n_p):
            G, i_dom = _patch_contact(prj_all, patch, m, p, weight)
            G += cyl_slack[c]
            if not G < 0.0:
                continue
            n_active += 1
            pn = -k_n * G
            f_normal = pn * _patch_normal(v, quads, cand, prj_all, weight, m, pn, f_n, f_cyl[c],
                                          nv, dg)
            if k_t <= 0.0 or mu <= 0.0 or slot == maxs or f_normal <= 0.0:
                continue                   # frictionless (beyond MAXS patches: no history)
            hist_q[c, slot] = cand[i_dom]
            slot += 1
            for k in range(3):
                fold[k] = 0.0
                dg[k] = dt * (dg[k] - cyl_v[c, k])
            _patch_history(slot_q, slot_f, cand, weight, m, fold)
            _to_tangent_plane(fold, dg, nv)
            coulomb_return_map(fold, dg, k_t, mu, f_normal, fnew, ds)
            for k in range(3):
                hist_ft[c, slot - 1, k] = fnew[k]
                f_cyl[c, k] += fnew[k]
            for l in range(m):
                if weight[l] == 0.0:
                    continue
                for a in range(4):
                    w = weight[l] * _bilinear(prj_all[l, 0], prj_all[l, 1], a)
                    for k in range(3):
                        f_t[quads[cand[l], a], k] -= w * fnew[k]
    return n_active


@njit(cache=True)
def _patch_history(slot_q, slot_f, cand, weight, m, fold):
    """Committed friction force of a patch: that of the first previous slot whose quad is in
    the patch (weight > 0), else zero (``fold`` written)."""
    for s in range(slot_q.shape[0]):
        if slot_q[s] < 0:
            continue
        for l in range(m):
            if weight[l] > 0.0 and cand[l] == slot_q[s]:
                for k in range(3):
                    fold[k] = slot_f[s, k]
                return


@njit(cache=True)
def _patch_normal(v, quads, cand, prj_all, weight, m, pn, f_n, f_cyl, nv, vel):
    """Normal force of one patch contact (:func:`facets_cylinder_contact`): pn pi_q n_q
    N_a(xi_q) onto the nodes, minus its sum onto the cylinder ``f_cyl`` (3,); writes the
    unit mean normal ``nv`` and the contact point's velocity ``vel`` (weights pi_q N_a).
    Returns |sum_q pi_q n_q| (<= 1: the resultant is pn times it)."""
    for k in range(3):
        nv[k] = 0.0
        vel[k] = 0.0
    for l in range(m):
        if weight[l] == 0.0:
            continue
        for a in range(4):
            nd = quads[cand[l], a]
            w = weight[l] * _bilinear(prj_all[l, 0], prj_all[l, 1], a)
            for k in range(3):
                f_n[nd, k] += w * pn * prj_all[l, 3 + k]
                vel[k] += w * v[nd, k]
        for k in range(3):
            nv[k] += weight[l] * prj_all[l, 3 + k]
            f_cyl[k] -= weight[l] * pn * prj_all[l, 3 + k]
    nn = math.sqrt(_dot(nv, nv))
    if nn > 0.0:
        for k in range(3):
            nv[k] /= nn
    return nn


# ------------------------------------------------------ (c) nodes on shell facets (quads)
@njit(cache=True, parallel=True)
def node_facet_contact(x, v, nodes, node_r, quads, quad_t, quad_sign, pairs, k_n, k_t, mu_s,
                       mu_k, d_c, dt, time_scale, pen_max, hist_partner, hist_ft, f_n, f_t):
    """One-sided penalty contact of nodes (spheres) with bilinear shell quads, eq. 6 friction.

    Parameters
    ----------
    x, v : (n_nodes, 3+) positions, half-step velocities.
    nodes : (n_cn,) node ids (e.g. the wire nodes); node_r : (n_cn,) their radii.
    quads : (n_q, 4) node ids; quad_t : (n_q,) thicknesses; quad_sign : (n_q,) +1 / -1:
        the side where the nodes belong is ``quad_sign * (X_xi x X_eta)`` (e.g. -1 for
        wires inside a tube whose quad normals point outwards).
    pairs : (n_pairs, 2) candidate (index into ``nodes``, quad) pairs, e.g. ``box_pairs``
        of ``node_aabbs`` vs ``quad_aabbs`` with same_set False.
    k_n, k_t : penalties (N/mm); mu_s, mu_k, d_c : eq. 6 (mu_s = mu_k for constant mu);
    dt, time_scale : solver step, physical / simulated duration.
    pen_max : largest penetration accepted (mm); beyond it the node is taken to be on
        the other side (never grabbed from the wrong side), e.g. ``r + t/2``.
    hist_partner : (n_cn, MAXS) int64; hist_ft : (n_cn, MAXS, 3), in place
        (``new_slot_history(n_cn, maxs)``).
    f_n, f_t : outputs, ADDED.  The node receives F, the quad nodes -F N_i(xi, eta).

    Gap: distance of the node centre to the CLOSEST POINT of the facets' mid-surfaces
    (Gauss-Newton projection clamped to the quad, so that at edges and corners the closest
    point lies on the boundary), minus r + t/2.  Each node contacts at most its closest
    facet of the set: the distance to a polyhedral surface is continuous and its gradient is
    the unit vector to the closest point, so the penalty energy 1/2 k gap^2 is a potential
    -- the contact is conservative also where a node slides over a convex kink (under the
    loading pin the tube folds towards the wires), where a projection-along-normal rule
    has a dead zone of width ~ 2 (r + t/2) tan(kink/2) through which nodes sink and then
    get pushed out with energy that was never stored.  The force direction is the unit
    vector from the closest point to the node (the facet normal inside a facet); a node
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
    and was pushed out with energy never stored.  Limitation: one contact per node and
    set, so a node pinched between two opposite walls of the same set (a tube flattened
    below one wire diameter) only sees the nearer one.
    Returns the number of active contacts.
    """
    n_pairs = pairs.shape[0]
    dt_phys = dt * time_scale
    t_max = 0.0
    for q in range(quad_t.shape[0]):
        t_max = max(t_max, quad_t[q])
    pd = np.empty((n_pairs, 9))     # xi, eta, dist(signed), n(3) force direction, X(3)
    n_chunks = (n_pairs + CHUNK - 1) // CHUNK
    if n_chunks <= SERIAL_MAX_CHUNKS:
        _nf_project(x, nodes, node_r, quads, quad_sign, pairs, t_max, pen_max, 0, n_pairs, pd)
    else:
        for ch in prange(n_chunks):
            _nf_project(x, nodes, node_r, quads, quad_sign, pairs, t_max, pen_max, ch * CHUNK,
                        min(n_pairs, (ch + 1) * CHUNK), pd)
    return _nf_commit(x, v, nodes, node_r, quads, quad_t, pairs, pd, k_n, k_t, mu_s, mu_k, d_c,
                      dt, dt_phys, pen_max, hist_partner, hist_ft, f_n, f_t)


@njit(cache=True)
def node_facet_contact_serial(x, v, nodes, node_r, quads, quad_t, quad_sign, pairs, k_n, k_t,
                              mu_s, mu_k, d_c, dt, time_scale, pen_max, hist_partner, hist_ft,
                              f_n, f_t):
    """Serial twin of :func:`node_facet_contact` (for a caller that runs it beside other
    work); the same steps, the same arithmetic, the same results."""
    n_pairs = pairs.shape[0]
    t_max = 0.0
    for q in range(quad_t.shape[0]):
        t_max = max(t_max, quad_t[q])
    pd = np.empty((n_pairs, 9))
    _nf_project(x, nodes, node_r, quads, quad_sign, pairs, t_max, pen_max, 0, n_pairs, pd)
    return _nf_commit(x, v, nodes, node_r, quads, quad_t, pairs, pd, k_n, k_t, mu_s, mu_k, d_c,
                      dt, dt * time_scale, pen_max, hist_partner, hist_ft, f_n, f_t)


@njit(cache=True)
def _nf_commit(x, v, nodes, node_r, quads, quad_t, pairs, pd, k_n, k_t, mu_s, mu_k, d_c, dt,
               dt_phys, pen_max, hist_partner, hist_ft, f_n, f_t):
    """The serial end of the node-facet contact, from the projections ``pd`` of the pairs
    (:func:`_nf_project`): each node's closest facet, its force, friction and history."""
    n_pairs = pairs.shape[0]
    n_cn = nodes.shape[0]
    # closest facet per node (pairs are grouped by node); behind a facet only a node that was
    # in contact at the previous step (it went in from the front)
    best = np.full(n_cn, -1, dtype=np.int64)
    for p in range(n_pairs):
        i = pairs[p, 0]
        if not np.isfinite(pd[p, 2]) or (pd[p, 2] < 0.0 and hist_partner[i, 0] < 0):
            continue
        b = best[i]
        if b < 0 or abs(pd[p, 2]) < abs(pd[b, 2]):
            best[i] = p
    # node by node: each row of the history is read (old slot) before it is rewritten, so
    # the history is updated in place (no copies)
    maxs = hist_partner.shape[1]
    fold = np.empty(3)
    dg = np.empty(3)
    ds = np.empty(3)
    hnew = np.empty(3)
    nv = np.empty(3)
    N = np.empty(4)
    n_active = 0
    for i in range(n_cn):
        p = best[i]
        q = pairs[p, 1] if p >= 0 else -1
        gap = pd[p, 2] - node_r[i] - 0.5 * quad_t[q] if p >= 0 else 0.0
        entering = hist_partner[i, 0] < 0
        if (p < 0 or gap >= 0.0 or -gap > pen_max
                or (entering and -gap > ENTRY_FRACTION * (node_r[i] + 0.5 * quad_t[q]))):
            for s in range(maxs):
                hist_partner[i, s] = -1
            continue
        nd = nodes[i]
        n_active += 1
        xi = pd[p, 0]
        eta = pd[p, 1]
        N[0] = 0.25 * (1 - xi) * (1 - eta)
        N[1] = 0.25 * (1 + xi) * (1 - eta)
        N[2] = 0.25 * (1 + xi) * (1 + eta)
        N[3] = 0.25 * (1 - xi) * (1 + eta)
        pn = -k_n * gap
        for c in range(3):
            nv[c] = pd[p, 3 + c]
            hnew[c] = 0.0
        if k_t > 0.0:
            slot = _find_slot(hist_partner, quads, i, q)
            for c in range(3):
                fold[c] = hist_ft[i, slot, c] if slot >= 0 else 0.0
                vq = 0.0
                for m in range(4):
                    vq += N[m] * v[quads[q, m], c]
                dg[c] = dt * (v[nd, c] - vq)
            _to_tangent_plane(fold, dg, nv)
            rate_dependent_friction(fold, dg, dt_phys, k_t, mu_s, mu_k, d_c, pn, hnew, ds)
        for s in range(maxs):
            hist_partner[i, s] = -1
        hist_partner[i, 0] = q              # in contact (also read by the behind-facet rule)
        if k_t > 0.0:
            for c in range(3):
                hist_ft[i, 0, c] = hnew[c]
        for c in range(3):
            fnc = pn * nv[c]
            ftc = -hnew[c]
            f_n[nd, c] += fnc
            f_t[nd, c] += ftc
            for m in range(4):
                f_n[quads[q, m], c] -= N[m] * fnc
                f_t[quads[q, m], c] -= N[m] * ftc
    return n_active


@njit(cache=True, inline="always")
def _nf_reach(r, t_max, pen_max):
    """Largest |distance| of a node (radius r) from a facet it can be in contact with (see
    :func:`_nf_project`), with the slack of the early rejects."""
    return max(r + 0.5 * t_max, pen_max - r) * (1.0 + REJECT_TOL)


@njit(cache=True)
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


@njit(cache=True)
def _nf_project(x, nodes, node_r, quads, quad_sign, pairs, t_max, pen_max, p0, p1, pd):
    """Closest points of the (node, quad) pairs p0..p1-1 into pd (see node_facet_contact).

    Early reject: a pair whose node is farther from the bounding box of the quad's nodes
    (which holds the bilinear facet, so the box distance bounds |dist| from below) than
    ``T = max(r + t_max/2, pen_max - r)`` gets pd = inf.  Any contact has
    |dist| <= T (in front: |dist| < r + t/2; behind: |dist| + r + t/2 <= pen_max), so
    if a node's closest facet is in contact it is not rejected and every rejected pair is
    farther (the choice of the closest facet is unchanged), and if it is rejected no pair
    of the node can be in contact: the result is unchanged.
    """
    prj = np.zeros(8)
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
        _project_quad(x, quads, q, x[nd], True, prj)
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
        # else: behind the plane but beside the facet (closest point on its boundary, e.g.
        # a wire beyond the tube's end or an open cut's edge): not a penetration


# ------------------------------------------------------------------ (d) cohesive ties
@njit(cache=True)
def _tie_dashpot(c, v_node, v_target):
    """Force of a tie's dashpot on the tied node, one component: ``-c (v_node - v_target)``.

    The bond of a tape is a viscoelastic adhesive layer, not an ideal spring: without
    damping, the light tape nodes on their stiff ties ring at the highest frequencies of
    the mesh, where central differences misstate the energy by O((omega dt)^2) and where
    the ringing, fed by the pins' friction, grows (issue 25).  The dashpot (``c`` a
    fraction of the tie's critical damping, scaled by 1 - D so that it goes with the
    bond) damps that ringing within a few periods and is negligible at the test's rates;
    its power ``-c |v_node - v_target|^2`` is dissipation of the cohesive family."""
    return -c * (v_node - v_target)


@njit(cache=True)
def _cohesive_tie(delta, K, delta0, delta_mf, alpha, j, tie_kappa, tie_D, tie_energy,
                  tie_area, tloc):
    """Eqs. 7-10 at one tie; updates kappa, D (never decreasing) and the dissipated energy.

    A fully debonded tie (D = 1) carries nothing, not even the compressive penalty of
    eq. 7: its fixed target point is no longer where the surfaces touch once they have
    separated and slid, and a penalty acting there would push with no stored energy to
    draw on.  Contact after debonding is the contact algorithms' job."""
    D_old = tie_D[j]
    D, kappa = cohesive_traction(delta, K, delta0, delta_mf, alpha, tie_kappa[j], D_old, tloc)
    if D >= 1.0:
        tloc[0] = 0.0
        tloc[1] = 0.0
        tloc[2] = 0.0
    if D > D_old:
        dn = max(delta[0], 0.0)
        y = 0.5 * (K[0] * dn * dn + K[1] * delta[1] * delta[1] + K[2] * delta[2] * delta[2])
        tie_energy[j] += (D - D_old) * y * tie_area[j]
    tie_D[j] = D
    tie_kappa[j] = kappa


@njit(cache=True, parallel=True)
def cohesive_ties_quad(x, v, tie_node, tie_quad, tie_xi, tie_sign, tie_off, tie_area, tie_c,
                       quads, K, delta0, delta_mf, alpha, tie_kappa, tie_D, tie_energy, f_c):
    """Cohesive ties (eqs. 7-10) of nodes to fixed material points of shell quads.

    Parameters
    ----------
    x, v : (n_nodes, 3+) positions, half-step velocities.
    tie_node : (n_tie,) the bonded (tape) node; tie_quad : (n_tie,) target quad;
    tie_xi : (n_tie, 2) bilinear coordinates (xi, eta) in [-1, 1]^2 of the target point;
    tie_sign : (n_tie,) +1 / -1 orienting the normal X_xi x X_eta towards the tied node;
    tie_off : (n_tie, 3) initial separation x_node - x_target in the local frame
        (n, s, t) (so that delta = 0 at the start);
    tie_area : (n_tie,) tributary area (mm^2).  (All from :func:`make_ties`.)
    tie_c : (n_tie,) dashpot coefficient of the intact tie (N s/mm, :func:`_tie_dashpot`).
    quads : (n_q, 4) node ids; K (3,), delta0 (3,), delta_mf, alpha : eqs. 7-10.
    tie_kappa, tie_D : (n_tie,) history, in place (D never decreases);
    tie_energy : (n_tie,) dissipated energy (N mm) accumulated in place,
        sum of area * (D_new - D_old) * Y with Y = (K_n <dn>^2 + K_s ds^2 + K_t dt^2) / 2.
    f_c : (n_nodes, 3+) output, cohesive forces ADDED (own array, not f_n / f_t).

    Frame: n = sign * unit(X_xi x X_eta), s = unit(X_xi), t = n x s at the tie point (it
    rotates with the quad).  delta = frame^T (x_node - x_target) - tie_off.  The tied
    node receives -t(delta) A (opening pulls it back; compression pushes it out by the
    K_nn penalty whatever D), the quad nodes +t A N_i.
    Returns the number of fully debonded ties (D >= 1).
    """
    n = tie_node.shape[0]
    pf = np.empty((n, 3))
    pv = np.empty((n, 3))
    lever = np.empty((n, 3))
    n_chunks = (n + CHUNK - 1) // CHUNK
    for ch in prange(n_chunks):
        _quad_ties_range(ch * CHUNK, min(n, (ch + 1) * CHUNK), x, v, tie_node, tie_quad,
                         tie_xi, tie_sign, tie_off, tie_area, tie_c, quads, K, delta0,
                         delta_mf, alpha, tie_kappa, tie_D, tie_energy, pf, pv, lever)
    return _quad_ties_commit(x, tie_node, tie_quad, tie_xi, quads, tie_D, pf, pv, lever, f_c)


@njit(cache=True)
def cohesive_ties_quad_serial(x, v, tie_node, tie_quad, tie_xi, tie_sign, tie_off, tie_area,
                              tie_c, quads, K, delta0, delta_mf, alpha, tie_kappa, tie_D,
                              tie_energy, f_c):
    """Serial twin of :func:`cohesive_ties_quad` (for a caller that runs it beside other
    work); the same arithmetic, the same results."""
    n = tie_node.shape[0]
    pf = np.empty((n, 3))
    pv = np.empty((n, 3))
    lever = np.empty((n, 3))
    _quad_ties_range(0, n, x, v, tie_node, tie_quad, tie_xi, tie_sign, tie_off, tie_area, tie_c,
                     quads, K, delta0, delta_mf, alpha, tie_kappa, tie_D, tie_energy, pf, pv,
                     lever)
    return _quad_ties_commit(x, tie_node, tie_quad, tie_xi, quads, tie_D, pf, pv, lever, f_c)


@njit(cache=True)
def _quad_ties_range(lo, hi, x, v, tie_node, tie_quad, tie_xi, tie_sign, tie_off, tie_area,
                     tie_c, quads, K, delta0, delta_mf, alpha, tie_kappa, tie_D, tie_energy, pf,
                     pv, lever):
    """Ties ``lo..hi-1``: separation, eqs. 7-10 (damage in place) and the traction's force
    on the tied node into ``pf``, its lever about the target point into ``lever``, the
    dashpot's force on the tied node into ``pv``."""
    scr = np.empty((5, 3))
    for j in range(lo, hi):
        q = tie_quad[j]
        delta = scr[0]
        tloc = scr[1]
        X = scr[2]
        nq = scr[3]
        e1 = scr[4]
        _quad_eval(x, quads, q, tie_xi[j, 0], tie_xi[j, 1], X, nq, e1)
        sg = tie_sign[j]
        d0 = x[tie_node[j], 0] - X[0]
        d1 = x[tie_node[j], 1] - X[1]
        d2 = x[tie_node[j], 2] - X[2]
        lever[j, 0] = d0
        lever[j, 1] = d1
        lever[j, 2] = d2
        n0 = sg * nq[0]
        n1 = sg * nq[1]
        n2 = sg * nq[2]
        t0 = n1 * e1[2] - n2 * e1[1]
        t1 = n2 * e1[0] - n0 * e1[2]
        t2 = n0 * e1[1] - n1 * e1[0]
        delta[0] = d0 * n0 + d1 * n1 + d2 * n2 - tie_off[j, 0]
        delta[1] = d0 * e1[0] + d1 * e1[1] + d2 * e1[2] - tie_off[j, 1]
        delta[2] = d0 * t0 + d1 * t1 + d2 * t2 - tie_off[j, 2]
        _cohesive_tie(delta, K, delta0, delta_mf, alpha, j, tie_kappa, tie_D, tie_energy,
                      tie_area, tloc)
        A = tie_area[j]
        pf[j, 0] = -A * (tloc[0] * n0 + tloc[1] * e1[0] + tloc[2] * t0)
        pf[j, 1] = -A * (tloc[0] * n1 + tloc[1] * e1[1] + tloc[2] * t1)
        pf[j, 2] = -A * (tloc[0] * n2 + tloc[1] * e1[2] + tloc[2] * t2)
        c = (1.0 - tie_D[j]) * tie_c[j]
        xi = tie_xi[j, 0]
        eta = tie_xi[j, 1]
        for k in range(3):
            vt = (0.25 * (1 - xi) * (1 - eta) * v[quads[q, 0], k]
                  + 0.25 * (1 + xi) * (1 - eta) * v[quads[q, 1], k]
                  + 0.25 * (1 + xi) * (1 + eta) * v[quads[q, 2], k]
                  + 0.25 * (1 - xi) * (1 + eta) * v[quads[q, 3], k])
            pv[j, k] = _tie_dashpot(c, v[tie_node[j], k], vt)


@njit(cache=True)
def _quad_ties_commit(x, tie_node, tie_quad, tie_xi, quads, tie_D, pf, pv, lever, f_c):
    """The serial end of the quad ties: forces of the traction (``pf``, with the frame's)
    and of the dashpot (``pv``) to the tied nodes and the targets' nodes (in tie order);
    returns the number of failed ties."""
    n = tie_node.shape[0]
    n_failed = 0
    for j in range(n):
        if tie_D[j] >= 1.0:
            n_failed += 1
        q = tie_quad[j]
        xi = tie_xi[j, 0]
        eta = tie_xi[j, 1]
        N0 = 0.25 * (1 - xi) * (1 - eta)
        N1 = 0.25 * (1 + xi) * (1 - eta)
        N2 = 0.25 * (1 + xi) * (1 + eta)
        N3 = 0.25 * (1 - xi) * (1 + eta)
        for c in range(3):
            f = pf[j, c] + pv[j, c]
            f_c[tie_node[j], c] += f
            f_c[quads[q, 0], c] -= N0 * f
            f_c[quads[q, 1], c] -= N1 * f
            f_c[quads[q, 2], c] -= N2 * f
            f_c[quads[q, 3], c] -= N3 * f
        _frame_forces(x, quads, q, xi, eta, lever[j], pf[j], f_c)
    return n_failed


@njit(cache=True)
def _frame_forces(x, quads, q, xi, eta, L, p_node, f_c):
    """Forces on the quad nodes from the turning of the tie's frame (conservative ties).

    The tie's energy U(delta), delta = frame^T (x_node - X) - off, depends on the quad's
    frame (n, e1 = X_xi/|X_xi|, t = n x e1) through its rotation phi: dU/dphi = M = f x L
    with ``f = -p`` (``p`` the force on the tied node) and the lever ``L = x_node - X``
    (the tie's offset, tape mid-surface to covering mid-surface, plus the separation:
    the separation part matters once damage treats opening and closing apart).  With
    ``phi.e1 = -dn.t``, ``phi.t = dn.e1``, ``phi.n = de1.t`` the quad nodes receive,
    beyond ``-p N_i``, ``(dn/dx_i)^T (M_e1 t - M_t e1) - (de1/dx_i)^T t M_n``, where
    ``dn/dx_i = P (N_i,xi [X_eta]x^T - N_i,eta [X_xi]x^T)/|c|``, c = X_xi x X_eta,
    P = I - n n^T, and ``de1/dx_i = (I - e1 e1^T) N_i,xi / |X_xi|``.  Without them the
    tie is not conservative and creates energy as the covering turns.
    """
    Xx0 = Xx1 = Xx2 = 0.0
    Xe0 = Xe1 = Xe2 = 0.0
    for m in range(4):
        sx = -1.0 if (m == 0 or m == 3) else 1.0
        se = -1.0 if (m == 0 or m == 1) else 1.0
        dx = 0.25 * sx * (1 + se * eta)
        de = 0.25 * se * (1 + sx * xi)
        nd = quads[q, m]
        Xx0 += dx * x[nd, 0]
        Xx1 += dx * x[nd, 1]
        Xx2 += dx * x[nd, 2]
        Xe0 += de * x[nd, 0]
        Xe1 += de * x[nd, 1]
        Xe2 += de * x[nd, 2]
    c0 = Xx1 * Xe2 - Xx2 * Xe1
    c1 = Xx2 * Xe0 - Xx0 * Xe2
    c2 = Xx0 * Xe1 - Xx1 * Xe0
    cn = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    n0, n1, n2 = c0 / cn, c1 / cn, c2 / cn
    lx = math.sqrt(Xx0 * Xx0 + Xx1 * Xx1 + Xx2 * Xx2)
    e0, e1_, e2 = Xx0 / lx, Xx1 / lx, Xx2 / lx
    t0, t1, t2 = n1 * e2 - n2 * e1_, n2 * e0 - n0 * e2, n0 * e1_ - n1 * e0
    # M = f x L, f = -p_node the force the quad receives
    f0, f1, f2 = -p_node[0], -p_node[1], -p_node[2]
    M0 = f1 * L[2] - f2 * L[1]
    M1 = f2 * L[0] - f0 * L[2]
    M2 = f0 * L[1] - f1 * L[0]
    Me = M0 * e0 + M1 * e1_ + M2 * e2
    Mt = M0 * t0 + M1 * t1 + M2 * t2
    Mn = M0 * n0 + M1 * n1 + M2 * n2
    g0, g1, g2 = Me * t0 - Mt * e0, Me * t1 - Mt * e1_, Me * t2 - Mt * e2    # (dn)^T acts on g
    h0, h1, h2 = -Mn * t0, -Mn * t1, -Mn * t2                                # (de1)^T acts on h
    for m in range(4):
        sx = -1.0 if (m == 0 or m == 3) else 1.0
        se = -1.0 if (m == 0 or m == 1) else 1.0
        dx = 0.25 * sx * (1 + se * eta)
        de = 0.25 * se * (1 + sx * xi)
        # (dn/dx_m)^T g = (dx X_eta x g - de X_xi x g) / |c|
        r0 = (dx * (Xe1 * g2 - Xe2 * g1) - de * (Xx1 * g2 - Xx2 * g1)) / cn
        r1 = (dx * (Xe2 * g0 - Xe0 * g2) - de * (Xx2 * g0 - Xx0 * g2)) / cn
        r2 = (dx * (Xe0 * g1 - Xe1 * g0) - de * (Xx0 * g1 - Xx1 * g0)) / cn
        nd = quads[q, m]
        f_c[nd, 0] += r0 + dx * h0 / lx
        f_c[nd, 1] += r1 + dx * h1 / lx
        f_c[nd, 2] += r2 + dx * h2 / lx


@njit(cache=True)
def cohesive_ties_beam(x, v, quat, tie_node, tie_seg, tie_s, tie_anchor, tie_arm, tie_axis,
                       tie_area, tie_c, seg, K, delta0, delta_mf, alpha, tie_kappa, tie_D,
                       tie_energy, f_c):
    """Cohesive ties (eqs. 7-10) of nodes to material points of beams with rotational dofs.

    The target of tie j is ``P + R_a r0`` with ``P = (1 - s) x_0 + s x_1`` on segment
    ``tie_seg`` at ``tie_s``, ``r0 = tie_arm`` the initial lever arm (tied node minus P, in
    the reference configuration) and ``R_a`` the rotation of the anchor node ``tie_anchor``
    (the nearer end node; ``quat``).  The separation ``delta = x_node - P - R_a r0`` is
    split in the frame carried by the same rotation (normal ``R_a r0 / |r0|``, axis
    ``R_a tie_axis``, third ``n x axis``).  The node receives ``p = -A t``; the segment nodes
    ``-p (1 - s)``, ``-p s`` and the anchor the moment ``(x_node - P) x (-p)`` on its spins,
    the derivative of the tie's energy with respect to the anchor rotation, which turns
    both the arm and the frame: the tie is conservative with the beam's own rotations,
    also once damage treats opening and closing apart (a tie to the segment's translations
    alone is not, once the arm is finite and the wire turns).  The dashpot of
    :func:`_tie_dashpot` (``tie_c``, velocities ``v``) acts on the velocity of the node
    relative to ``P``'s (it only dissipates; it turns no frame).
    Returns the number of fully debonded ties.
    """
    n = tie_node.shape[0]
    R = np.empty((3, 3))
    arm = np.empty(3)
    nv = np.empty(3)
    ax = np.empty(3)
    tv = np.empty(3)
    delta = np.empty(3)
    tloc = np.empty(3)
    p = np.empty(3)
    failed = 0
    for j in range(n):
        e = tie_seg[j]
        s = tie_s[j]
        a0 = seg[e, 0]
        a1 = seg[e, 1]
        an = tie_anchor[j]
        quat_to_matrix(quat[an], R)
        for c in range(3):
            arm[c] = R[c, 0] * tie_arm[j, 0] + R[c, 1] * tie_arm[j, 1] + R[c, 2] * tie_arm[j, 2]
            ax[c] = R[c, 0] * tie_axis[j, 0] + R[c, 1] * tie_axis[j, 1] + R[c, 2] * tie_axis[j, 2]
        la = math.sqrt(_dot(arm, arm))
        for c in range(3):
            nv[c] = arm[c] / la
        tv[0] = nv[1] * ax[2] - nv[2] * ax[1]
        tv[1] = nv[2] * ax[0] - nv[0] * ax[2]
        tv[2] = nv[0] * ax[1] - nv[1] * ax[0]
        for c in range(3):
            p[c] = x[tie_node[j], c] - (1.0 - s) * x[a0, c] - s * x[a1, c] - arm[c]
        delta[0] = _dot(p, nv)
        delta[1] = _dot(p, ax)
        delta[2] = _dot(p, tv)
        _cohesive_tie(delta, K, delta0, delta_mf, alpha, j, tie_kappa, tie_D, tie_energy,
                      tie_area, tloc)
        if tie_D[j] >= 1.0:
            failed += 1
        A = tie_area[j]
        cd = (1.0 - tie_D[j]) * tie_c[j]
        for c in range(3):
            arm[c] += p[c]          # lever x_node - P: the arm and the separation
            p[c] = -A * (tloc[0] * nv[c] + tloc[1] * ax[c] + tloc[2] * tv[c])
            fv = _tie_dashpot(cd, v[tie_node[j], c], (1.0 - s) * v[a0, c] + s * v[a1, c])
            f_c[tie_node[j], c] += p[c] + fv
            f_c[a0, c] -= (1.0 - s) * (p[c] + fv)
            f_c[a1, c] -= s * (p[c] + fv)
        # moment of -p about the anchor's spins: (x_node - P) x (-p); the part arm x (-p)
        # from the turning target, the part delta x (-p) from the turning frame (zero when the
        # traction is parallel to delta, not once damage treats opening and closing apart)
        f_c[an, 3] -= arm[1] * p[2] - arm[2] * p[1]
        f_c[an, 4] -= arm[2] * p[0] - arm[0] * p[2]
        f_c[an, 5] -= arm[0] * p[1] - arm[1] * p[0]
    return failed


@njit(cache=True)
def cohesive_tie_dissipation(tie_kappa, tie_area, K, delta0, delta_mf, alpha):
    """Closed-form estimate of the energy dissipated per tie (N mm), eqs. 7-10.

    ``area * cohesive_dissipated_energy(K_nn, delta_n^0, delta_mf, alpha, kappa)``: exact
    for a proportional pure-opening path (or pure shear when K and delta^0 are equal in
    all directions, as in the paper); for mixed or non-proportional paths prefer the
    incremental ``tie_energy`` accumulated by the tie kernels.  The damage is ``tie_D``.
    """
    n = tie_kappa.shape[0]
    out = np.empty(n)
    for j in range(n):
        out[j] = tie_area[j] * cohesive_dissipated_energy(K[0], delta0[0], delta_mf, alpha,
                                                          tie_kappa[j])
    return out


# ----------------------------------------------------------------- (e) tie construction
@njit(cache=True, parallel=True)
def _candidates_quad(x, tape_nodes, quads, pairs, out_xi, out_gap, out_X, out_n):
    for p in prange(pairs.shape[0]):
        i = pairs[p, 0]
        q = pairs[p, 1]
        pr = np.empty(8)
        _project_quad(x, quads, q, x[tape_nodes[i]], True, pr)
        out_xi[p, 0] = pr[0]
        out_xi[p, 1] = pr[1]
        # re-evaluate exactly at the clamped parameters
        X = np.empty(3)
        nq = np.empty(3)
        e1 = np.empty(3)
        _quad_eval(x, quads, q, pr[0], pr[1], X, nq, e1)
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
    (ties_quad, ties_seg) : dicts of arrays, the arguments of
    :func:`cohesive_ties_quad` (``tie_node, tie_quad, tie_xi, tie_sign, tie_off,
    tie_area``) and the segment ties (``tie_node, tie_seg, tie_s, tie_n0, tie_t0,
    tie_off, tie_area``: :class:`harnesspipe.models.hifi.HifiSystem` turns them into the
    arguments of :func:`cohesive_ties_beam`), plus zeroed ``tie_kappa``, ``tie_D``,
    ``tie_energy``.
    """
    x = np.ascontiguousarray(np.asarray(x, dtype=float)[:, :3])
    tape_nodes = np.asarray(tape_nodes, dtype=np.int64)
    node_area = np.asarray(node_area, dtype=float)
    n = tape_nodes.size
    big = np.inf
    best_q_gap = np.full(n, big)
    best_s_gap = np.full(n, big)
    q_sel = None
    s_sel = None
    if quads is not None and len(quads):
        quads = np.asarray(quads, dtype=np.int64)
        quad_t = np.asarray(quad_t, dtype=float)
        lo_q, hi_q = quad_aabbs(x, quads, 0.5 * quad_t, tol + tape_half_t)
        lo_n, hi_n = node_aabbs(x, tape_nodes, np.zeros(n), 0.0)
        cell = float(np.median(np.max(hi_q - lo_q, axis=1)))
        pairs = box_pairs(lo_n, hi_n, lo_q, hi_q, cell, False)
        xi = np.zeros((len(pairs), 2))
        dist = np.zeros(len(pairs))
        X = np.zeros((len(pairs), 3))
        nq = np.zeros((len(pairs), 3))
        _candidates_quad(x, tape_nodes, quads, pairs, xi, dist, X, nq)
        gap = np.abs(dist - 0.5 * quad_t[pairs[:, 1]] - tape_half_t)
        ok = gap <= tol
        best = _best_per_node(n, pairs[ok, 0], gap[ok])
        idx = np.append(np.flatnonzero(ok), -1)      # sentinel: no candidate at all
        q_sel = np.where(best >= 0, idx[np.maximum(best, 0)], -1)
        best_q_gap = (np.where(best >= 0, gap[np.maximum(q_sel, 0)], big) if gap.size
                      else np.full(n, big))
        q_data = (pairs, xi, X, nq)
    if seg is not None and len(seg):
        seg = np.asarray(seg, dtype=np.int64)
        seg_r = np.asarray(seg_r, dtype=float)
        lo_e, hi_e = segment_aabbs(x, seg, seg_r, tol + tape_half_t)
        lo_n, hi_n = node_aabbs(x, tape_nodes, np.zeros(n), 0.0)
        cell = float(np.median(np.max(hi_e - lo_e, axis=1)))
        pairs_s = box_pairs(lo_n, hi_n, lo_e, hi_e, cell, False)
        s_par = np.zeros(len(pairs_s))
        dist_s = np.zeros(len(pairs_s))
        _candidates_seg(x, tape_nodes, seg, pairs_s, s_par, dist_s)
        gap_s = np.abs(dist_s - seg_r[pairs_s[:, 1]] - tape_half_t)
        ok = gap_s <= tol
        best = _best_per_node(n, pairs_s[ok, 0], gap_s[ok])
        idx = np.append(np.flatnonzero(ok), -1)      # sentinel: no candidate at all
        s_sel = np.where(best >= 0, idx[np.maximum(best, 0)], -1)
        best_s_gap = (np.where(best >= 0, gap_s[np.maximum(s_sel, 0)], big) if gap_s.size
                      else np.full(n, big))
    use_q = np.isfinite(best_q_gap) & (best_q_gap <= best_s_gap)
    use_s = np.isfinite(best_s_gap) & ~use_q

    ties_quad = {}
    iq = np.flatnonzero(use_q)
    if q_sel is not None:
        pairs, xi, X, nq = q_data
        sel = q_sel[iq]
        tq = pairs[sel, 1]
        nodes = tape_nodes[iq]
        d = x[nodes] - X[sel]
        nrm = nq[sel]
        e1 = np.zeros_like(nrm)
        for k, (q, (a, b)) in enumerate(zip(tq, xi[sel])):
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
        ties_quad = dict(tie_node=nodes, tie_quad=tq, tie_xi=np.ascontiguousarray(xi[sel]),
                         tie_sign=sign, tie_off=off, tie_area=node_area[iq].copy())
    else:
        ties_quad = dict(tie_node=np.zeros(0, np.int64), tie_quad=np.zeros(0, np.int64),
                         tie_xi=np.zeros((0, 2)), tie_sign=np.zeros(0), tie_off=np.zeros((0, 3)),
                         tie_area=np.zeros(0))
    m = len(ties_quad["tie_node"])
    ties_quad.update(tie_kappa=np.zeros(m), tie_D=np.zeros(m), tie_energy=np.zeros(m))

    is_ = np.flatnonzero(use_s)
    if s_sel is not None and is_.size:
        sel = s_sel[is_]
        te = pairs_s[sel, 1]
        sp = s_par[sel]
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
                _any_perpendicular(t0[k].copy(), n0[k])
        tt = np.cross(n0, t0)
        off = np.stack([np.einsum("ij,ij->i", d, n0), np.einsum("ij,ij->i", d, t0),
                        np.einsum("ij,ij->i", d, tt)], axis=1)
        ties_seg = dict(tie_node=nodes, tie_seg=te, tie_s=sp, tie_n0=n0, tie_t0=t0, tie_off=off,
                        tie_area=node_area[is_].copy())
    else:
        ties_seg = dict(tie_node=np.zeros(0, np.int64), tie_seg=np.zeros(0, np.int64),
                        tie_s=np.zeros(0), tie_n0=np.zeros((0, 3)), tie_t0=np.zeros((0, 3)),
                        tie_off=np.zeros((0, 3)), tie_area=np.zeros(0))
    m = len(ties_seg["tie_node"])
    ties_seg.update(tie_kappa=np.zeros(m), tie_D=np.zeros(m), tie_energy=np.zeros(m))
    return ties_quad, ties_seg
