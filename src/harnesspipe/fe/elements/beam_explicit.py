"""Co-rotational fibre beams for explicit dynamics: parallel internal force, lumped
mass with rotary-inertia scaling and the element stable step.

The element is the one of :mod:`harnesspipe.fe.elements.beam` (Battini & Pacoste 2002;
:func:`harnesspipe.fe.elements.beam.element_response` without its tangent).  Here it is
evaluated for many bodies at once -- the wires of a bundle -- each element with its
own section (``sec_id``: fibre coordinates and areas of the wire type) and its own
eq. 2 material (``mat_id``: rows ``(E, sigma_y, K, n)`` of ``mats``).  The element
loop is split into as many chunks as Numba threads, each chunk with its own work
arrays (allocated once per chunk, never per element), writing element forces into
``f_el``; a serial scatter adds them into the nodal force.

Lumped mass (row-sum, per node): ``rho' A l/2`` on translations and a scalar rotary
inertia ``J = rho' (l/2) max(I_p, 3 I l)`` on rotations, ``rho' = f_m rho``.  The
physical rotary inertia ``rho I_p l/2`` of a thin wire is so small that the rotational
dofs would limit the explicit step far below the axial bar limit; the lower bound
``6 rho I l^2 / 2`` makes the rotational row of the element's Gershgorin bound
(``6 E I / l / J``) at most half the axial one (``4 E / (rho l^2)``).  This is the
usual rotary-inertia scaling of explicit beam elements (Hughes & Liu 1981;
Belytschko, Liu & Moran 2014, sec. 6.3): it changes only the rotational dynamics,
which carry no energy in a quasi-static bending run.  The scalar inertia keeps the
spatial Euler equations free of gyroscopic terms (see :mod:`harnesspipe.fe.solvers.central_difference`).

Stable step per element: ``dt_e = 2 / omega_e``, ``omega_e^2`` the Gershgorin bound of
``M_e^-1/2 K_e M_e^-1/2`` for the elastic local Bernoulli stiffness (EA/l, 12EI/l^3,
6EI/l^2, 4EI/l, 2EI/l, GJ/l) and the element's own lumped mass.  By the element
eigenvalue bound (Irons 1970; Hughes 1987, sec. 9.3) ``min dt_e`` bounds the global
critical step from below; the elastic stiffness bounds the elastoplastic one.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from harnesspipe.fe.elements.beam import (BeamElement, FibreHistory, FibreMaterial, FibreSection,
                                          NodePair, beam_work, element_response)
from harnesspipe.fe.loops import loop_kernel
from harnesspipe.fe.materials.hardening import positive_pow, return_map_from
from harnesspipe.fe.rotation import log_matrix, ts_inverse_coeff

PARALLEL_MIN_EL = 64   # fewer elements per thread than this: one chunk (thread overhead)


class Beams(NamedTuple):
    """Co-rotational fibre beams, the one argument group of the kernels of this module.

    Numba passes it as one typed tuple: a kernel reads ``beams.conn``, not its second
    positional argument.  The arrays are the owner's own; the history and ``f_el`` are
    updated in place."""
    X0: np.ndarray          # (n_nodes, 3) initial positions
    conn: np.ndarray        # (n_el, 2) node ids
    R0: np.ndarray          # (n_el, 3, 3) initial element frames
    xi_g: np.ndarray        # (ng,) Gauss-Lobatto points along the element
    w_g: np.ndarray         # (ng,) their weights
    sec_y: np.ndarray       # (n_sec, nf) fibre coordinates in the section
    sec_z: np.ndarray       # (n_sec, nf)
    sec_area: np.ndarray    # (n_sec, nf) fibre areas
    sec_GJ: np.ndarray      # (n_sec,) torsional stiffness
    sec_id: np.ndarray      # (n_el,) section of each element
    mats: np.ndarray        # (n_mat, 4) eq. 2 material rows (E, sigma_y, K, n)
    mat_id: np.ndarray      # (n_el,) material row of each element
    eps_p: np.ndarray       # (n_el, ng, nf) fibre plastic strain, in place
    alpha: np.ndarray       # (n_el, ng, nf) equivalent plastic strain, in place
    sa_h: np.ndarray        # (n_el, ng, nf) alpha**n, in place
    f_el: np.ndarray        # (n_el, 12) element forces (scratch)


class BeamScratch(NamedTuple):
    """Work arrays of :func:`element_force`, allocated once per element range."""
    Rg: np.ndarray          # (2, 3, 3) the nodal rotation matrices
    W: np.ndarray           # (4, 3, 3) Rg1 R0, Rg2 R0, Rr, qv
    Rbar: np.ndarray        # (3, 3)
    th1: np.ndarray         # (3,) local rotation of node 1
    th2: np.ndarray         # (3,) of node 2
    v4: np.ndarray          # (4,) log_matrix work


@njit(cache=True)
def beam_scratch():
    """A fresh :class:`BeamScratch`."""
    return BeamScratch(np.empty((2, 3, 3)), np.empty((4, 3, 3)), np.empty((3, 3)),
                       np.empty(3), np.empty(3), np.empty(4))


@njit(cache=True, inline="always")
def _section_force(e0, kappa_y, kappa_z, sec, mat, beams, e, g):
    """Stress resultants ``(N, M_y, M_z)`` of the fibre section ``sec``
    (:class:`~harnesspipe.fe.materials.fiber.FibreSection`) of eq. 2 material ``mat``
    (:class:`~harnesspipe.fe.materials.fiber.FibreMaterial`), no tangent.

    The fibre strain, eq. 2 return and summation order of
    :func:`harnesspipe.fe.materials.fiber.section_response`; the section tangent ``D`` is not formed,
    and each fibre keeps ``sa = alpha**n`` in its history, so its flow stress
    ``sigma_Y + K sa`` (the elastic check) and the return map's start need no power
    (:func:`harnesspipe.fe.materials.hardening.return_map_from`): the same results up to round-off.
    History of element ``e``, Gauss point ``g``: ``beams.eps_p, alpha, sa_h`` read and, for
    a fibre that yields, updated in place (an explicit step is never rejected, so there is
    no trial state; an elastic fibre's history is only read).
    """
    y, z, area = sec.y, sec.z, sec.area
    E, sigma_y, K, n = mat.E, mat.sigma_y, mat.K, mat.n
    eps_p, alpha, sa_h = beams.eps_p, beams.alpha, beams.sa_h
    s0 = s1 = s2 = 0.0
    for f in range(y.shape[0]):
        yf = y[f]
        zf = z[f]
        ep = eps_p[e, g, f]
        sa = sa_h[e, g, f]
        sig = E * (e0 + zf * kappa_y - yf * kappa_z - ep)
        if abs(sig) > sigma_y + K * sa:         # beyond the flow stress: eq. 2 return
            al = alpha[e, g, f]
            dg, _, sa_new = return_map_from(abs(sig), E, al, sa, sigma_y, K, n)
            if dg > 0.0:
                dgs = dg if sig >= 0.0 else -dg
                sig -= E * dgs
                eps_p[e, g, f] = ep + dgs
                alpha[e, g, f] = al + dg
                sa_h[e, g, f] = sa_new
        fa = sig * area[f]                      # the fibre's axial force
        s0 += fa
        s1 += fa * zf
        s2 -= fa * yf
    return s0, s1, s2


@njit(cache=True, inline="always")
def _ts_inv_t_apply(th, m0, m1, m2):
    """Ts^-T(theta) m = m + (theta x m)/2 + c(a) (theta (theta.m) - a^2 m) (a tuple)."""
    a2 = th[0] * th[0] + th[1] * th[1] + th[2] * th[2]
    c = ts_inverse_coeff(np.sqrt(a2))
    tm = th[0] * m0 + th[1] * m1 + th[2] * m2
    r0 = m0 + 0.5 * (th[1] * m2 - th[2] * m1) + c * (th[0] * tm - a2 * m0)
    r1 = m1 + 0.5 * (th[2] * m0 - th[0] * m2) + c * (th[1] * tm - a2 * m1)
    r2 = m2 + 0.5 * (th[0] * m1 - th[1] * m0) + c * (th[2] * tm - a2 * m2)
    return r0, r1, r2


@njit(cache=True, inline="always")
def _nodal_triads(e, R0, Rg, ia, ib, W):
    """``P_i = Rg_i R0`` of element ``e`` into ``W[0]``, ``W[1]`` (the order of
    :func:`harnesspipe.fe.elements.beam.local_rotation`): the nodal triads carried by the
    nodal rotations ``Rg[ia]``, ``Rg[ib]`` (3, 3) from the initial frame ``R0[e]``."""
    for k in range(3):
        for j in range(3):
            t1 = 0.0
            t2 = 0.0
            for m in range(3):
                t1 += Rg[ia, k, m] * R0[e, m, j]
                t2 += Rg[ib, k, m] * R0[e, m, j]
            W[0, k, j] = t1
            W[1, k, j] = t2


@njit(cache=True, inline="always")
def _corotated_frame(x, a, b, W):
    """Co-rotated frame ``Rr = [r1 r2 r3]`` into ``W[2]`` (Battini & Pacoste 2002; the
    arithmetic of :func:`harnesspipe.fe.elements.beam.corotated_frame`): ``r1`` along the
    current chord ``x[b] - x[a]``, ``r3`` normal to ``r1`` and the mean ``q`` of the
    nodal ``y`` axes ``q1, q2`` (2nd columns of ``W[0]``, ``W[1]``), ``r2 = r3 x r1``;
    ``W[3]`` receives the columns ``q1, q2, q``.  Returns the current length ``l_n``."""
    ln = 0.0
    for i in range(3):
        W[2, i, 0] = x[b, i] - x[a, i]
        ln += W[2, i, 0] ** 2
    ln = np.sqrt(ln)
    for i in range(3):
        W[2, i, 0] /= ln
        W[3, i, 0] = W[0, i, 1]
        W[3, i, 1] = W[1, i, 1]
        W[3, i, 2] = 0.5 * (W[0, i, 1] + W[1, i, 1])
    r10 = W[2, 0, 0]
    r11 = W[2, 1, 0]
    r12 = W[2, 2, 0]
    q0 = W[3, 0, 2]
    q1 = W[3, 1, 2]
    q2 = W[3, 2, 2]
    c0 = r11 * q2 - r12 * q1
    c1 = r12 * q0 - r10 * q2
    c2 = r10 * q1 - r11 * q0
    s = np.sqrt(c0 ** 2 + c1 ** 2 + c2 ** 2)
    c0 /= s
    c1 /= s
    c2 /= s
    W[2, 0, 2] = c0
    W[2, 1, 2] = c1
    W[2, 2, 2] = c2
    W[2, 0, 1] = c1 * r12 - c2 * r11
    W[2, 1, 1] = c2 * r10 - c0 * r12
    W[2, 2, 1] = c0 * r11 - c1 * r10
    return ln


@njit(cache=True, inline="always")
def _local_rotation(W, node, Rbar, theta, v4):
    """Local rotation vector ``theta = log(Rr^T P)`` (3,) of node ``node`` (the arithmetic of
    :func:`harnesspipe.fe.elements.beam.local_rotation`), ``Rr = W[2]``, ``P = W[node]``.
    Work: Rbar (3, 3), v4 (4,)."""
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += W[2, k, i] * W[node, k, j]
            Rbar[i, j] = acc
    log_matrix(Rbar, theta, v4)


@njit(cache=True, inline="always")
def _local_force(e, ln, l0, th1, th2, sec, mat, beams):
    """Local force of the small-strain Bernoulli element (the arithmetic and summation
    order of :func:`harnesspipe.fe.elements.beam.local_bernoulli`): the axial force N and
    the bending moments at the nodes ``(f2, f3)``, ``(f5, f6)`` from the fibre resultants
    (:func:`_section_force`) integrated over the Gauss-Lobatto points ``beams.xi_g,
    w_g`` (ng,) with the strains ``e0 = (l_n - l_0)/l_0``, ``kappa = ((6 xi - 4) theta_1 +
    (6 xi - 2) theta_2)/l_0``, and the elastic torque ``GJ (theta_2x - theta_1x)/l_0``.
    Section ``sec``, material ``mat``, history of element ``e`` in ``beams``.
    Returns (N, f2, f3, f5, f6, torque)."""
    xi_g, w_g = beams.xi_g, beams.w_g
    f0 = f2 = f3 = f5 = f6 = 0.0
    e0 = (ln - l0) / l0
    inv_l0 = 1.0 / l0
    for g in range(xi_g.shape[0]):
        xi = xi_g[g]
        b1 = (6.0 * xi - 4.0) / l0
        b2 = (6.0 * xi - 2.0) / l0
        ky = b1 * th1[1] + b2 * th2[1]
        kz = b1 * th1[2] + b2 * th2[2]
        s0, s1, s2 = _section_force(e0, ky, kz, sec, mat, beams, e, g)
        wl = w_g[g] * l0
        f0 += (wl * inv_l0) * s0
        f2 += (wl * b1) * s1
        f5 += (wl * b2) * s1
        f3 += (wl * b1) * s2
        f6 += (wl * b2) * s2
    return f0, f2, f3, f5, f6, sec.GJ / l0 * (th2[0] - th1[0])


@njit(cache=True, inline="always")
def _global_force(e, f_el, W, ln, th1, th2, N, f2, f3, f5, f6, torque):
    """Global nodal forces ``f_el[e]`` (12) from the local force: ``f_a = B_a^T f_l``
    (Ts^-T applied as a vector, :func:`_ts_inv_t_apply`), then ``f_g = B^T f_a`` with the
    nonzeros of ``G^T`` (:func:`harnesspipe.fe.elements.beam._g_matrix`) in closed form:
    with ``m = m1 + m2`` and ``g = G^T m`` the local blocks ``-g_u1, m1 - g_w1, -g_u2,
    m2 - g_w2`` rotated by ``Rr = W[2]`` (``qv = W[3]``), the axial force ``N r1`` added
    to the translations."""
    m10, m11, m12 = _ts_inv_t_apply(th1, -torque, f2, f3)
    m20, m21, m22 = _ts_inv_t_apply(th2, torque, f5, f6)
    M1 = m10 + m20
    M2 = m11 + m21
    M3 = m12 + m22
    ql1 = ql2 = a11 = a12 = a21 = a22 = 0.0
    for k in range(3):
        ql1 += W[2, k, 0] * W[3, k, 2]
        ql2 += W[2, k, 1] * W[3, k, 2]
        a11 += W[2, k, 0] * W[3, k, 0]
        a12 += W[2, k, 1] * W[3, k, 0]
        a21 += W[2, k, 0] * W[3, k, 1]
        a22 += W[2, k, 1] * W[3, k, 1]
    eta = ql1 / ql2
    gu1 = -M3 / ln                      # g[1] = -g[7]
    gu2 = (eta * M1 + M2) / ln          # g[2] = -g[8]
    h = 0.5 * M1 / ql2                  # g[3:5] = h (a12, -a11), g[9:11] = h (a22, -a21)
    w10 = m10 - h * a12
    w11 = m11 + h * a11
    w20 = m20 - h * a22
    w21 = m21 + h * a21
    for i in range(3):
        r0 = W[2, i, 0]
        r1 = W[2, i, 1]
        r2 = W[2, i, 2]
        tu = r1 * gu1 + r2 * gu2
        f_el[e, i] = -r0 * N - tu
        f_el[e, 6 + i] = r0 * N + tu
        f_el[e, 3 + i] = r0 * w10 + r1 * w11 + r2 * m12
        f_el[e, 9 + i] = r0 * w20 + r1 * w21 + r2 * m22


@njit(cache=True, inline="always")
def element_force(e, beams, x, ia, ib, work):
    """Global internal force ``beams.f_el[e]`` (12) of element ``e``, lean path.

    Equals ``element_response(..., want_tangent=False)`` of :mod:`harnesspipe.fe.elements.beam`;
    ``work.Rg[ia]``, ``work.Rg[ib]`` hold the rotation matrices of the element's nodes
    (quat_to_matrix of their quaternions).  The co-rotated frame, the local rotations,
    the fibre resultants and the new history use the arithmetic of element_response
    (bit-identical); only the final mapping differs in round-off, because only what the
    force needs is formed:

    * ``Rg R0`` once per node (element_response forms it once per entry of Rr^T Rg R0);
    * ``f_a = B_a^T f_l`` with ``Ts^-T m = m + (theta x m)/2 + c (theta (theta.m) - a^2 m)``
      as a vector (no Ts^-1 matrix);
    * ``f_g = B^T f_a`` from the ten nonzeros of ``G^T`` in closed form (no 7x12 B matrix);
    * no section tangent D, no K_l, K_a, K_h, K_m.

    ``x`` (n_nodes, 3) current positions; the element's section, material and history
    are those of ``beams`` (history updated in place where a fibre yields); arrays are
    indexed in place (section rows are views).  ``work``: :class:`BeamScratch`.
    """
    a = beams.conn[e, 0]
    b = beams.conn[e, 1]
    k = beams.sec_id[e]
    m = beams.mat_id[e]
    X0, W = beams.X0, work.W
    sec = FibreSection(beams.sec_y[k], beams.sec_z[k], beams.sec_area[k], beams.sec_GJ[k])
    mat = FibreMaterial(beams.mats[m, 0], beams.mats[m, 1], beams.mats[m, 2], beams.mats[m, 3])
    _nodal_triads(e, beams.R0, work.Rg, ia, ib, W)
    ln = _corotated_frame(x, a, b, W)
    l0 = np.sqrt((X0[b, 0] - X0[a, 0]) ** 2 + (X0[b, 1] - X0[a, 1]) ** 2
                 + (X0[b, 2] - X0[a, 2]) ** 2)
    _local_rotation(W, 0, work.Rbar, work.th1, work.v4)
    _local_rotation(W, 1, work.Rbar, work.th2, work.v4)
    N, f2, f3, f5, f6, torque = _local_force(e, ln, l0, work.th1, work.th2, sec, mat, beams)
    _global_force(e, beams.f_el, W, ln, work.th1, work.th2, N, f2, f3, f5, f6, torque)


@njit(cache=True, inline="always")
def _quat_to_matrix_at(quat, a, Rg, i):
    """Rg[i] = rotation matrix of quat[a] (the arithmetic of rotation.quat_to_matrix)."""
    q0 = quat[a, 0]
    q1 = quat[a, 1]
    q2 = quat[a, 2]
    q3 = quat[a, 3]
    Rg[i, 0, 0] = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
    Rg[i, 0, 1] = 2.0 * (q1 * q2 - q0 * q3)
    Rg[i, 0, 2] = 2.0 * (q1 * q3 + q0 * q2)
    Rg[i, 1, 0] = 2.0 * (q1 * q2 + q0 * q3)
    Rg[i, 1, 1] = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3
    Rg[i, 1, 2] = 2.0 * (q2 * q3 - q0 * q1)
    Rg[i, 2, 0] = 2.0 * (q1 * q3 - q0 * q2)
    Rg[i, 2, 1] = 2.0 * (q2 * q3 + q0 * q1)
    Rg[i, 2, 2] = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3


@njit(cache=True, parallel=True)
def beam_forces(beams, x, quat, f_int, n_chunks, sign=1.0):
    """Add ``sign`` x the internal (resisting) forces of all elements of ``beams``
    (:class:`Beams`) into ``f_int`` (n_nodes, 6) (``sign = -1``: the forces ON the nodes).

    ``x`` (n_nodes, 3) current positions, ``quat`` (n_nodes, 4) nodal rotations; the
    history ``beams.eps_p, alpha, sa_h`` (``sa_h = alpha**n``) advances in place where a
    fibre yields (explicit steps are never rejected: every call advances the history);
    ``beams.f_el`` is scratch; ``n_chunks`` the number of parallel chunks
    (``numba.get_num_threads()``).

    Lean force-only path (:func:`element_force`) over contiguous chunks of elements
    (:func:`beam_range_forces`).  With fewer than ``PARALLEL_MIN_EL`` elements per chunk
    the chunks are merged.
    """
    n_el = beams.conn.shape[0]
    n_chunks = max(1, min(n_chunks, n_el // PARALLEL_MIN_EL))
    size = (n_el + n_chunks - 1) // n_chunks
    for c in prange(n_chunks):
        beam_range_forces(c * size, min(n_el, (c + 1) * size), beams, x, quat)
    beam_scatter(beams.conn, beams.f_el, f_int, sign)


@njit(cache=True)
def beam_range_forces(lo, hi, beams, x, quat):
    """Element forces of elements ``lo..hi-1`` into ``beams.f_el`` (arguments as
    :func:`beam_forces`).  The rotation matrix of a node shared with the previous
    element of a chain (``conn[e, 0] == conn[e - 1, 1]``) is reused, not rebuilt from
    its quaternion; scratch is allocated once per call."""
    _beam_loop(lo, hi, beams, x, quat, beam_scratch())


@loop_kernel
def _beam_loop(lo, hi, beams, x, quat, work):
    """:func:`beam_range_forces` with its scratch ``work`` (:class:`BeamScratch`)."""
    conn = beams.conn
    last = -1                       # node whose matrix is in Rg[1 - ia]
    ia = 0                          # Rg[ia] holds node a, Rg[1 - ia] node b
    for e in range(lo, hi):
        a = conn[e, 0]
        b = conn[e, 1]
        if a == last:               # node a was node b of the previous element
            ia = 1 - ia
        else:
            _quat_to_matrix_at(quat, a, work.Rg, ia)
        _quat_to_matrix_at(quat, b, work.Rg, 1 - ia)
        last = b
        element_force(e, beams, x, ia, 1 - ia, work)


@njit(cache=True)
def beam_scatter(conn, f_el, f_int, sign):
    """``f_int[node] += sign f_el`` over the elements' two nodes, in element order."""
    for e in range(conn.shape[0]):
        a = conn[e, 0]
        b = conn[e, 1]
        for i in range(6):
            f_int[a, i] += sign * f_el[e, i]
            f_int[b, i] += sign * f_el[e, 6 + i]


@njit(cache=True, parallel=True)
def beam_forces_reference(beams, trial, x, quat, f_int, n_chunks):
    """Reference for :func:`beam_forces` through ``element_response(want_tangent=False)`` of
    :mod:`harnesspipe.fe.elements.beam` (kept for tests and benchmarks).

    ``beams`` (:class:`Beams`) with the committed history ``eps_p, alpha`` (read; its
    ``sa_h`` is not needed); ``trial``: the same beams with the trial history arrays, into
    which ``eps_p, alpha`` are written and ``sa_h = alpha**n`` formed from them;
    ``beams.f_el`` scratch; forces added into ``f_int`` (n_nodes, 6); ``n_chunks`` the
    number of parallel chunks (``numba.get_num_threads()``).
    """
    conn, mats = beams.conn, beams.mats
    # locals: a store through a tuple's field inside a prange is lost (Numba issue 7135)
    eps_p_t, alpha_t, sa_t = trial.eps_p, trial.alpha, trial.sa_h
    n_el = conn.shape[0]
    n_chunks = max(1, min(n_chunks, n_el))
    for c in prange(n_chunks):
        work = beam_work()
        Ke = np.empty((12, 12))
        for e in range(c, n_el, n_chunks):
            a = conn[e, 0]
            b = conn[e, 1]
            k = beams.sec_id[e]
            m = beams.mat_id[e]
            element_response(BeamElement(beams.X0[a], beams.X0[b], beams.R0[e], beams.xi_g,
                                         beams.w_g),
                             NodePair(x[a], x[b], quat[a], quat[b]),
                             FibreSection(beams.sec_y[k], beams.sec_z[k], beams.sec_area[k],
                                          beams.sec_GJ[k]),
                             FibreMaterial(mats[m, 0], mats[m, 1], mats[m, 2], mats[m, 3]), False,
                             FibreHistory(beams.eps_p[e], beams.alpha[e], eps_p_t[e], alpha_t[e]),
                             False,
                             beams.f_el[e], Ke, work)
            for g in range(alpha_t.shape[1]):
                for f in range(alpha_t.shape[2]):
                    al = alpha_t[e, g, f]
                    sa_t[e, g, f] = positive_pow(al, mats[m, 3]) if al > 0.0 else 0.0
    beam_scatter(conn, beams.f_el, f_int, 1.0)


@njit(cache=True)
def beam_plastic_work(beams):
    """Plastic dissipation of all fibres of ``beams`` (:class:`Beams`),
    ``sum V_f (sigma_y a + K a^(n+1) / (n+1))``.

    For J2 with isotropic hardening the plastic work is the integral of the flow
    stress (eq. 2) over the accumulated plastic strain ``a`` -- exact, path-free.
    """
    conn, X0, w_g, sec_area = beams.conn, beams.X0, beams.w_g, beams.sec_area
    mats, mat_id, alpha = beams.mats, beams.mat_id, beams.alpha
    total = 0.0
    for e in range(conn.shape[0]):
        a0, b0 = conn[e, 0], conn[e, 1]
        l0 = np.sqrt((X0[b0, 0] - X0[a0, 0]) ** 2 + (X0[b0, 1] - X0[a0, 1]) ** 2
                     + (X0[b0, 2] - X0[a0, 2]) ** 2)
        k = beams.sec_id[e]
        sy = mats[mat_id[e], 1]
        K = mats[mat_id[e], 2]
        n = mats[mat_id[e], 3]
        for g in range(w_g.shape[0]):
            for f in range(sec_area.shape[1]):
                a = alpha[e, g, f]
                if a > 0.0:
                    total += w_g[g] * l0 * sec_area[k, f] * (sy * a + K * a ** (n + 1.0) / (n + 1.0))
    return total


def beam_lumped_mass(X0, conn, A, I, rho, out):
    """Add the lumped mass of beam elements into ``out`` (n_nodes, 6); ``A, I, rho``
    per element (I the bending moment of inertia; I_p = 2 I for a disc)."""
    l0 = np.linalg.norm(X0[conn[:, 1]] - X0[conn[:, 0]], axis=1)
    m_t = 0.5 * rho * A * l0
    J = 0.5 * rho * l0 * np.maximum(2.0 * I, 3.0 * I * l0)
    for k in range(2):
        np.add.at(out[:, 0], conn[:, k], m_t)
        np.add.at(out[:, 1], conn[:, k], m_t)
        np.add.at(out[:, 2], conn[:, k], m_t)
        for j in range(3, 6):
            np.add.at(out[:, j], conn[:, k], J)
    return m_t, J


def beam_stable_step(l, A, I, E, G, rho):
    """Per-element critical step 2 / omega_e (Gershgorin bound, elastic stiffness)."""
    m_t = 0.5 * rho * A * l
    J = 0.5 * rho * l * np.maximum(2.0 * I, 3.0 * I * l)
    EI = E * I
    axial = 2.0 * E * A / l / m_t
    torsion = 2.0 * G * 2.0 * I / l / J
    transverse = 24.0 * EI / l**3 / m_t + 12.0 * EI / l**2 / np.sqrt(m_t * J)
    rotation = 12.0 * EI / l**2 / np.sqrt(m_t * J) + 6.0 * EI / l / J
    omega2 = np.maximum.reduce([axial, torsion, transverse, rotation])
    return 2.0 / np.sqrt(omega2)
