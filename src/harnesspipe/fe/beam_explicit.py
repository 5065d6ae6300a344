"""Co-rotational fibre beams for explicit dynamics: parallel internal force, lumped
mass with rotary-inertia scaling and the element stable step.

The element is the one of :mod:`harnesspipe.fe.beam` (Battini & Pacoste 2002;
:func:`harnesspipe.fe.beam.element_response` without its tangent).  Here it is
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
spatial Euler equations free of gyroscopic terms (see :mod:`harnesspipe.fe.explicit`).

Stable step per element: ``dt_e = 2 / omega_e``, ``omega_e^2`` the Gershgorin bound of
``M_e^-1/2 K_e M_e^-1/2`` for the elastic local Bernoulli stiffness (EA/l, 12EI/l^3,
6EI/l^2, 4EI/l, 2EI/l, GJ/l) and the element's own lumped mass.  By the element
eigenvalue bound (Irons 1970; Hughes 1987, sec. 9.3) ``min dt_e`` bounds the global
critical step from below; the elastic stiffness bounds the elastoplastic one.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from harnesspipe.fe.beam import element_response


@njit(cache=True, parallel=True)
def beam_forces(X0, conn, R0, x, quat, xi_g, w_g, sec_y, sec_z, sec_area, sec_GJ, sec_id,
                mats, mat_id, eps_p_c, alpha_c, eps_p_t, alpha_t, f_el, f_int, n_chunks):
    """Add the internal (resisting) forces of all beam elements into ``f_int`` (n_nodes, 6).

    ``X0``/``x`` (n_nodes, 3) reference and current positions, ``quat`` (n_nodes, 4) nodal
    rotations, ``conn`` (n_el, 2) global node ids, ``R0`` (n_el, 3, 3) initial frames;
    ``sec_y, sec_z, sec_area`` (n_sec, n_fib) fibre data, ``sec_GJ`` (n_sec,);
    ``mats`` (n_mat, 4) rows (E, sigma_y, K, n); history (n_el, n_gauss, n_fib): committed
    ``eps_p_c, alpha_c`` are read, trial ``eps_p_t, alpha_t`` written; ``f_el`` (n_el, 12)
    scratch; ``n_chunks`` the number of parallel chunks (``numba.get_num_threads()``).
    """
    n_el = conn.shape[0]
    n_chunks = max(1, min(n_chunks, n_el))
    for c in prange(n_chunks):
        M33 = np.empty((10, 3, 3))
        V3 = np.empty((6, 3))
        v4 = np.empty(4)
        fl = np.empty(7)
        fa = np.empty(7)
        Kl = np.empty((7, 7))
        Ka = np.empty((7, 7))
        s = np.empty(3)
        D = np.empty((3, 3))
        B = np.empty((3, 7))
        Gt = np.empty((3, 12))
        Bg = np.empty((7, 12))
        t12 = np.empty((11, 12))
        W77 = np.empty((7, 7))
        Ke = np.empty((12, 12))
        for e in range(c, n_el, n_chunks):
            a = conn[e, 0]
            b = conn[e, 1]
            k = sec_id[e]
            m = mat_id[e]
            element_response(X0[a], X0[b], R0[e], x[a], x[b], quat[a], quat[b], xi_g, w_g,
                             sec_y[k], sec_z[k], sec_area[k], sec_GJ[k], mats[m, 0], mats[m, 1],
                             mats[m, 2], mats[m, 3], False, eps_p_c[e], alpha_c[e], eps_p_t[e],
                             alpha_t[e], False, f_el[e], Ke, M33, V3, v4, fl, Kl, fa, Ka, s, D,
                             B, Gt, Bg, t12, W77)
    for e in range(n_el):
        a = conn[e, 0]
        b = conn[e, 1]
        for i in range(6):
            f_int[a, i] += f_el[e, i]
            f_int[b, i] += f_el[e, 6 + i]


@njit(cache=True)
def beam_plastic_work(conn, X0, w_g, sec_area, sec_id, mats, mat_id, alpha):
    """Plastic dissipation of all fibres, ``sum V_f (sigma_y a + K a^(n+1) / (n+1))``.

    For J2 with isotropic hardening the plastic work is the integral of the flow
    stress (eq. 2) over the accumulated plastic strain ``a`` -- exact, path-free.
    """
    total = 0.0
    for e in range(conn.shape[0]):
        l0 = np.sqrt(np.sum((X0[conn[e, 1]] - X0[conn[e, 0]]) ** 2))
        k = sec_id[e]
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
