"""Shell facets (tube, tape) on rigid cylinders (the test's rollers and loading pin,
Sec. 4.1): one contact per (connected patch of facets, cylinder) at a soft minimum of the
facets' gaps (width SOFTMIN_TAU), penalty normal force and constant-mu Coulomb friction,
the reaction added to each cylinder.  Conventions: :mod:`harnesspipe.fe.contact.common`.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from harnesspipe.fe.contact.common import share_node, to_tangent_plane
from harnesspipe.fe.contact.surface import quad_tangents
from harnesspipe.fe.loops import loop_kernel
from harnesspipe.fe.materials.friction import coulomb_return_map
from harnesspipe.fe.vec3 import dot

LM_DAMP = 1e-9          # facet-to-axis projection: Levenberg term (x trace) for facets parallel to a pin
PATCH_REACH = 1.0       # facets within this x R of a pin's surface form its contact patches
SOFTMIN_TAU = 0.01      # mm: width of the soft minimum of a patch's facet gaps (pin contact)


class PinFacetSet(NamedTuple):
    """A set of shell facets on the cylinders (:func:`facets_cylinder_contact`)."""
    quads: np.ndarray       # (n_q, 4) node ids
    quad_t: np.ndarray      # (n_q,) thicknesses
    mu: float               # Coulomb friction (the pins' mu_rtb or mu_rtp)
    slack: np.ndarray       # (n_cyl,) gap allowance per cylinder, held for the run
    k_n: float              # normal penalty
    k_t: float              # stick penalty
    hist_q: np.ndarray      # (n_cyl, maxs) int64 the patches' quads, in place
    hist_ft: np.ndarray     # (n_cyl, maxs, 3) their friction forces, in place


@loop_kernel
def _quad_axis_closest(x, quads, q, c0, ax, out, scr):
    """Point of the bilinear quad ``q`` closest to the axis line (point ``c0``, unit ``ax``).

    Minimises f = 1/2 |P (X(xi, eta) - c0)|^2, P = I - ax ax^T, over [-1, 1]^2 by projected
    Gauss-Newton: a coordinate on its bound whose gradient points outwards is held there
    and the other one solved alone (active set).  A quad with a direction along the axis
    (a facet parallel to the pin) has a line of minimisers; the Levenberg term
    ``LM_DAMP trace`` keeps the iterate at the point of that line nearest the previous
    iterate (the quad's centre line), with no effect on the distance.
    Writes out = (xi, eta, dist, n(3)), n the unit radial vector from the axis; ``scr``
    (3, 3) scratch.
    """
    xi = 0.0
    eta = 0.0
    X, tx, te = scr[0], scr[1], scr[2]
    for it in range(12):
        quad_tangents(x, quads, q, xi, eta, X, tx, te)
        rl = (X[0] - c0[0]) * ax[0] + (X[1] - c0[1]) * ax[1] + (X[2] - c0[2]) * ax[2]
        xl = dot(tx, ax)
        el = dot(te, ax)
        for k in range(3):
            X[k] -= c0[k] + rl * ax[k]          # radial offset P (X - c0)
            tx[k] -= xl * ax[k]                 # P X_xi
            te[k] -= el * ax[k]                 # P X_eta
        if it == 11:
            break
        g0 = dot(tx, X)
        g1 = dot(te, X)
        A = dot(tx, tx)
        B = dot(tx, te)
        C = dot(te, te)
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
    dist = math.sqrt(dot(X, X))
    out[0] = xi
    out[1] = eta
    out[2] = dist
    for k in range(3):
        out[3 + k] = X[k] / dist if dist > 0.0 else 0.0


@loop_kernel
def _facets_near(x, quads, quad_t, c0, ax, R, work):
    """Quads of the set whose face comes within ``PATCH_REACH R`` of the cylinder
    (c0, ax, R) (gap = distance of the mid-surface to the axis - R - t/2 < PATCH_REACH R),
    the axis not on the mid-surface itself: their ids into
    ``work.cand``, their closest points (:func:`_quad_axis_closest`) into
    ``work.prj_all[:, :6]`` and gaps into ``work.prj_all[:, 6]`` (``work``:
    :class:`PatchWork`); returns their number.  A quad whose bounding sphere stays farther
    is not projected."""
    cand, prj_all, prj, scr = work.cand, work.prj_all, work.prj, work.vec[:3]
    m = 0
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
        _quad_axis_closest(x, quads, q, c0, ax, prj, scr)
        gap = prj[2] - R - 0.5 * quad_t[q]
        if gap < PATCH_REACH * R and prj[2] > 0.0:
            cand[m] = q
            for k in range(6):
                prj_all[m, k] = prj[k]
            prj_all[m, 6] = gap
            m += 1
    return m


@loop_kernel
def _patches(quads, m, work):
    """Connected patches of the quads ``work.cand[:m]`` near a pin (quads sharing a node):
    patch id per quad into ``work.patch``; returns the number of patches."""
    cand, patch, stack = work.cand, work.patch, work.stack
    for i in range(m):
        patch[i] = -1
    n_p = 0
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
                if patch[l] < 0 and share_node(quads, cand[j], cand[l]):
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


@loop_kernel
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


class PatchWork(NamedTuple):
    """Work arrays of the pin-facet kernels for a set of ``n_q`` quads (:func:`patch_work`)."""
    cand: np.ndarray        # (n_q,) int64 ids of the quads near a pin (:func:`_facets_near`)
    prj_all: np.ndarray     # (n_q, 7) their closest points (xi, eta, dist, n) and gaps
    patch: np.ndarray       # (n_q,) int64 their patch ids (:func:`_patches`)
    weight: np.ndarray      # (n_q,) soft-minimum weights (:func:`_patch_contact`)
    stack: np.ndarray       # (n_q,) int64 (:func:`_patches`)
    prj: np.ndarray         # (6,) one quad's closest point
    vec: np.ndarray         # (8, 3) a projection's X, X_xi, X_eta; then nv, dg, fold, fnew, ds
    slot_q: np.ndarray      # (maxs,) int64 the previous step's history of one cylinder
    slot_f: np.ndarray      # (maxs, 3)


@njit(cache=True)
def patch_work(n_q, maxs):
    """A :class:`PatchWork` for ``n_q`` quads and ``maxs`` history slots."""
    i8 = np.int64
    return PatchWork(np.empty(n_q, dtype=i8), np.empty((n_q, 7)), np.empty(n_q, dtype=i8),
                     np.empty(n_q), np.empty(n_q, dtype=i8), np.empty(6), np.empty((8, 3)),
                     np.empty(maxs, dtype=i8), np.empty((maxs, 3)))


@njit(cache=True)
def facets_cylinder_gaps(x, quads, quad_t, cyl_c, cyl_axis, cyl_R):
    """Smallest patch gap G (:func:`facets_cylinder_contact`) of the set at each cylinder
    (np.inf where no quad is near): negative where a pin starts inside the soft minimum."""
    work = patch_work(quads.shape[0], 0)
    gaps = np.full(cyl_c.shape[0], np.inf)
    for c in range(cyl_c.shape[0]):
        m = _facets_near(x, quads, quad_t, cyl_c[c], cyl_axis[c], cyl_R[c], work)
        for p in range(_patches(quads, m, work)):
            gaps[c] = min(gaps[c], _patch_contact(work.prj_all, work.patch, m, p, work.weight)[0])
    return gaps


@njit(cache=True)
def facets_cylinder_contact(x, v, fset, cyl, dt, f_n, f_t, f_cyl):
    """Penalty contact of a set of shell facets (a tube, a tape; ``fset``:
    :class:`PinFacetSet`) with rigid unbounded cylinders (the pins; ``cyl``:
    :class:`~harnesspipe.fe.contact.common.Cylinders`), Coulomb friction.

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
    ``fset.slack`` (n_cyl,): gap allowance per cylinder, held for the run, for a
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
    work = patch_work(fset.quads.shape[0], fset.hist_q.shape[1])
    return _facet_pins(x, v, fset, cyl, dt, f_n, f_t, f_cyl, work)


@loop_kernel
def _facet_pins(x, v, fset, cyl, dt, f_n, f_t, f_cyl, work):
    """:func:`facets_cylinder_contact` with its work arrays (:class:`PatchWork`)."""
    quads, quad_t, mu, cyl_slack = fset.quads, fset.quad_t, fset.mu, fset.slack
    k_n, k_t, hist_q, hist_ft = fset.k_n, fset.k_t, fset.hist_q, fset.hist_ft
    cyl_c, cyl_axis, cyl_R, cyl_v = cyl.centres, cyl.axes, cyl.radii, cyl.velocity
    n_cyl = cyl_c.shape[0]
    maxs = hist_q.shape[1]
    cand, prj_all, weight = work.cand, work.prj_all, work.weight
    patch, slot_q, slot_f = work.patch, work.slot_q, work.slot_f
    nv, dg, fold, fnew, ds = work.vec[3], work.vec[4], work.vec[5], work.vec[6], work.vec[7]
    n_active = 0
    for c in range(n_cyl):
        m = _facets_near(x, quads, quad_t, cyl_c[c], cyl_axis[c], cyl_R[c], work)
        n_p = _patches(quads, m, work)
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
            to_tangent_plane(fold, dg, nv)
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


@loop_kernel
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


@loop_kernel
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
    nn = math.sqrt(dot(nv, nv))
    if nn > 0.0:
        for k in range(3):
            nv[k] /= nn
    return nn
