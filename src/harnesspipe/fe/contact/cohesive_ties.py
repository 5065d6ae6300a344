"""Cohesive ties (Sec. 4.1, eqs. 7-10): tape nodes bonded to fixed material points of the
tube's quads or of the wires' beams by the damaged traction-separation law of
:mod:`harnesspipe.fe.materials.cohesive`, with a dashpot beside each tie
(:func:`_tie_dashpot`).  Cohesive forces go to their own array ``f_c``; the damage
history (kappa, D, dissipated energy) advances in place.  Conventions:
:mod:`harnesspipe.fe.contact.common`.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from harnesspipe.fe.contact.common import CHUNK
from harnesspipe.fe.contact.surface import quad_eval
from harnesspipe.fe.loops import loop_kernel
from harnesspipe.fe.materials.cohesive import cohesive_dissipated_energy, cohesive_traction
from harnesspipe.fe.rotation import quat_to_matrix
from harnesspipe.fe.vec3 import dot


class TieLaw(NamedTuple):
    """The cohesive law of eqs. 7-10."""
    K: np.ndarray           # (3,) K_nn, K_ss, K_tt
    delta0: np.ndarray      # (3,) onset separations
    delta_f: float          # separation at failure
    alpha_d: float          # mixed-mode exponent


class QuadTieSet(NamedTuple):
    """Ties of nodes to material points of shell quads (:func:`cohesive_ties_quad`;
    :func:`harnesspipe.fe.contact.tie_targets.make_ties` gives the tie arrays)."""
    tie_node: np.ndarray    # (n,) the bonded (tape) node
    tie_quad: np.ndarray    # (n,) target quad
    tie_xi: np.ndarray      # (n, 2) bilinear coordinates (xi, eta) in [-1, 1]^2 of the target
    tie_sign: np.ndarray    # (n,) +1 / -1 orienting X_xi x X_eta towards the tied node
    tie_off: np.ndarray     # (n, 3) initial separation in the local frame (n, s, t)
    tie_area: np.ndarray    # (n,) tributary area (mm^2)
    tie_c: np.ndarray       # (n,) dashpot coefficient of the intact tie (N s/mm)
    quads: np.ndarray       # (n_q, 4) node ids
    tie_kappa: np.ndarray   # (n,) damage history, in place (D never decreases)
    tie_D: np.ndarray       # (n,)
    tie_energy: np.ndarray  # (n,) dissipated energy (N mm), accumulated in place


class BeamTieSet(NamedTuple):
    """Ties of nodes to material points of beams with rotational dofs
    (:func:`cohesive_ties_beam`)."""
    tie_node: np.ndarray    # (n,) the bonded node
    tie_seg: np.ndarray     # (n,) target segment
    tie_s: np.ndarray       # (n,) target point along it
    tie_anchor: np.ndarray  # (n,) node whose rotation carries the arm
    tie_arm: np.ndarray     # (n, 3) initial arm from the axis to the node
    tie_axis: np.ndarray    # (n, 3) initial segment direction
    tie_area: np.ndarray    # (n,)
    tie_c: np.ndarray       # (n,)
    seg: np.ndarray         # (n_seg, 2) node ids of the beams' segments
    tie_kappa: np.ndarray   # (n,) damage history, in place
    tie_D: np.ndarray       # (n,)
    tie_energy: np.ndarray  # (n,)


def tie_set(kind, arrays: dict, **given):
    """The :class:`QuadTieSet` or :class:`BeamTieSet` (``kind``) of the arrays in
    ``arrays`` (keyed by field), the fields in ``given`` taken from there instead."""
    return kind(**{name: given[name] if name in given else arrays[name] for name in kind._fields})


@njit(cache=True, inline="always")
def _tie_dashpot(c, v_node, v_target):
    """Force of a tie's dashpot on the tied node, one component: ``-c (v_node - v_target)``.

    The bond of a tape is a viscoelastic adhesive layer, not an ideal spring: without
    damping, the light tape nodes on their stiff ties ring at the highest frequencies of
    the mesh, where central differences misstate the energy by O((omega dt)^2) and where
    the ringing, fed by the pins' friction, grows (bench/RESULTS.md, "Hi-fi energy
    balance").  The dashpot (``c`` a
    fraction of the tie's critical damping, scaled by 1 - D so that it goes with the
    bond) damps that ringing within a few periods and is negligible at the test's rates;
    its power ``-c |v_node - v_target|^2`` is dissipation of the cohesive family."""
    return -c * (v_node - v_target)


@njit(cache=True, inline="always")
def _cohesive_tie(delta, law, ties, j, tloc):
    """Eqs. 7-10 at tie ``j`` of ``ties`` (either set); updates its kappa, D (never
    decreasing) and dissipated energy.

    A fully debonded tie (D = 1) carries nothing, not even the compressive penalty of
    eq. 7: its fixed target point is no longer where the surfaces touch once they have
    separated and slid, and a penalty acting there would push with no stored energy to
    draw on.  Contact after debonding is the contact algorithms' job."""
    K, tie_D = law.K, ties.tie_D
    D_old = tie_D[j]
    D, kappa = cohesive_traction(delta, K, law.delta0, law.delta_f, law.alpha_d,
                                 ties.tie_kappa[j], D_old, tloc)
    if D >= 1.0:
        tloc[0] = 0.0
        tloc[1] = 0.0
        tloc[2] = 0.0
    if D > D_old:
        dn = max(delta[0], 0.0)
        y = 0.5 * (K[0] * dn * dn + K[1] * delta[1] * delta[1] + K[2] * delta[2] * delta[2])
        ties.tie_energy[j] += (D - D_old) * y * ties.tie_area[j]
    tie_D[j] = D
    ties.tie_kappa[j] = kappa


@njit(cache=True, parallel=True)
def cohesive_ties_quad(x, v, ties, law, f_c):
    """Cohesive ties (eqs. 7-10) of nodes to fixed material points of shell quads.

    Parameters
    ----------
    x, v : (n_nodes, 3+) positions, half-step velocities.
    ties : :class:`QuadTieSet`; its ``tie_off`` the initial separation x_node - x_target
        in the local frame (n, s, t) (so that delta = 0 at the start), its ``tie_c`` the
        dashpot of the intact tie (:func:`_tie_dashpot`); its history in place, the
        dissipated energy the sum of area * (D_new - D_old) * Y with
        Y = (K_n <dn>^2 + K_s ds^2 + K_t dt^2) / 2.
    law : :class:`TieLaw`, eqs. 7-10.
    f_c : (n_nodes, 3+) output, cohesive forces ADDED (own array, not f_n / f_t).

    Frame: n = sign * unit(X_xi x X_eta), s = unit(X_xi), t = n x s at the tie point (it
    rotates with the quad).  delta = frame^T (x_node - x_target) - tie_off.  The tied
    node receives -t(delta) A (opening pulls it back; compression pushes it out by the
    K_nn penalty whatever D), the quad nodes +t A N_i.
    Returns the number of fully debonded ties (D >= 1).
    """
    n = ties.tie_node.shape[0]
    pf = np.empty((n, 3))
    pv = np.empty((n, 3))
    lever = np.empty((n, 3))
    n_chunks = (n + CHUNK - 1) // CHUNK
    for ch in prange(n_chunks):
        _quad_ties_range(ch * CHUNK, min(n, (ch + 1) * CHUNK), x, v, ties, law, pf, pv, lever,
                         np.empty((5, 3)))
    return _quad_ties_commit(x, ties, pf, pv, lever, f_c)


@njit(cache=True)
def cohesive_ties_quad_serial(x, v, ties, law, f_c):
    """Serial twin of :func:`cohesive_ties_quad` (for a caller that runs it beside other
    work); the same arithmetic, the same results."""
    n = ties.tie_node.shape[0]
    pf = np.empty((n, 3))
    pv = np.empty((n, 3))
    lever = np.empty((n, 3))
    _quad_ties_range(0, n, x, v, ties, law, pf, pv, lever, np.empty((5, 3)))
    return _quad_ties_commit(x, ties, pf, pv, lever, f_c)


@loop_kernel
def _quad_ties_range(lo, hi, x, v, ties, law, pf, pv, lever, scr):
    """Ties ``lo..hi-1`` of ``ties``: separation, eqs. 7-10 (damage in place) and the
    traction's force on the tied node into ``pf``, its lever about the target point into
    ``lever``, the dashpot's force on the tied node into ``pv``; ``scr`` (5, 3) scratch."""
    tie_node, tie_quad, tie_xi, tie_sign = ties.tie_node, ties.tie_quad, ties.tie_xi, ties.tie_sign
    tie_off, tie_area, tie_c, quads = ties.tie_off, ties.tie_area, ties.tie_c, ties.quads
    tie_D = ties.tie_D
    delta = scr[0]
    tloc = scr[1]
    X = scr[2]
    nq = scr[3]
    e1 = scr[4]
    for j in range(lo, hi):
        q = tie_quad[j]
        quad_eval(x, quads, q, tie_xi[j, 0], tie_xi[j, 1], X, nq, e1)
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
        _cohesive_tie(delta, law, ties, j, tloc)
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


@loop_kernel
def _quad_ties_commit(x, ties, pf, pv, lever, f_c):
    """The serial end of the quad ties: forces of the traction (``pf``, with the frame's)
    and of the dashpot (``pv``) to the tied nodes and the targets' nodes (in tie order);
    returns the number of failed ties."""
    tie_node, tie_quad, tie_xi, quads, tie_D = (ties.tie_node, ties.tie_quad, ties.tie_xi,
                                                ties.quads, ties.tie_D)
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
        _frame_forces(x, quads, q, xi, eta, lever, pf, j, f_c)
    return n_failed


@njit(cache=True, inline="always")
def _frame_forces(x, quads, q, xi, eta, lever, pf, j, f_c):
    """Forces on the quad nodes from the turning of the tie's frame (conservative ties).

    The tie's energy U(delta), delta = frame^T (x_node - X) - off, depends on the quad's
    frame (n, e1 = X_xi/|X_xi|, t = n x e1) through its rotation phi: dU/dphi = M = f x L
    with ``f = -p`` (``p = pf[j]`` the force on tie j's node) and the lever
    ``L = lever[j] = x_node - X``
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
    f0, f1, f2 = -pf[j, 0], -pf[j, 1], -pf[j, 2]
    M0 = f1 * lever[j, 2] - f2 * lever[j, 1]
    M1 = f2 * lever[j, 0] - f0 * lever[j, 2]
    M2 = f0 * lever[j, 1] - f1 * lever[j, 0]
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
def cohesive_ties_beam(x, v, quat, ties, law, f_c):
    """Cohesive ties (eqs. 7-10) of nodes to material points of beams with rotational dofs
    (``ties``: :class:`BeamTieSet`; ``law``: :class:`TieLaw`; forces ADDED into ``f_c``).

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
    return _beam_ties(x, v, quat, ties, law, f_c, np.empty((10, 3)))


@loop_kernel
def _beam_ties(x, v, quat, ties, law, f_c, scr):
    """:func:`cohesive_ties_beam` with its scratch ``scr`` (10, 3)."""
    tie_node, tie_seg, tie_s, tie_anchor = ties.tie_node, ties.tie_seg, ties.tie_s, ties.tie_anchor
    tie_arm, tie_axis, tie_area, tie_c = ties.tie_arm, ties.tie_axis, ties.tie_area, ties.tie_c
    seg, tie_D = ties.seg, ties.tie_D
    n = tie_node.shape[0]
    R, arm, nv, ax, tv = scr[0:3], scr[3], scr[4], scr[5], scr[6]
    delta, tloc, p = scr[7], scr[8], scr[9]
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
        la = math.sqrt(dot(arm, arm))
        for c in range(3):
            nv[c] = arm[c] / la
        tv[0] = nv[1] * ax[2] - nv[2] * ax[1]
        tv[1] = nv[2] * ax[0] - nv[0] * ax[2]
        tv[2] = nv[0] * ax[1] - nv[1] * ax[0]
        for c in range(3):
            p[c] = x[tie_node[j], c] - (1.0 - s) * x[a0, c] - s * x[a1, c] - arm[c]
        delta[0] = dot(p, nv)
        delta[1] = dot(p, ax)
        delta[2] = dot(p, tv)
        _cohesive_tie(delta, law, ties, j, tloc)
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
