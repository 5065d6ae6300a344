"""One Belytschko-Lin-Tsay (BLT) shell element: the stress update and nodal forces of
:mod:`harnesspipe.fe.elements.shell_bt`.  Co-rotational frame from the current nodes,
one-point (centroid) velocity strains of a Mindlin field, a total co-rotational strain per
thickness point (5 Gauss points) driving the J2 (eqs. 1-2) or the orthotropic (eq. 12)
plane-stress kernels -- or, for the ridged tube's wall, resultants straight from the
membrane strains and curvatures (:mod:`harnesspipe.fe.materials.tube_wall`) --, elastic
transverse shear (kappa = 5/6), Belytschko-Tsay stiffness hourglass control, nodal forces
from the virtual power; internal, plastic and hourglass work per element.

Theory (the kinematics, the constitutive update, the hourglass rates and stiffnesses, the
energies, with their equations): docs/theory/shell_blt.md.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from harnesspipe.fe.materials.plane_stress import (EPS33, P11, P12, P22, P33, STATE_SIZE,
                                                   J2Material, j2_plane_stress_from,
                                                   orthotropic_plane_stress,
                                                   orthotropic_plane_stress_stiffness)
from harnesspipe.fe.materials.tube_wall import (T_SIZE, W_DH, W_DX, W_KE, W_KGT, W_KH,
                                                tube_wall_resultants)

N_THICKNESS = 5
_ZETA, _ZETA_W = np.polynomial.legendre.leggauss(N_THICKNESS)
ZETA = tuple(float(z) for z in _ZETA)      # tuples: compile-time constants (cacheable)
ZETA_W = tuple(float(w) for w in _ZETA_W)
SHEAR_CORRECTION = 5.0 / 6.0
MAT_KIND = 5
MAT_J2, MAT_ORTHOTROPIC, MAT_TUBE = 0, 1, 2
MAT_COMPRESSION = 4   # eq. 12 rows (E1, E2, nu12, G12, r_c, MAT_ORTHOTROPIC): the yarns' compression factor

# --- state layout (per element, N_STATE floats) ------------------------------------
# thickness point k occupies [k*PT_SIZE, (k+1)*PT_SIZE):
PT_EPS = 0            # total co-rotational strain eps_xx, eps_yy, gamma_xy (3)
PT_SIG = 3            # stress sigma_xx, sigma_yy, sigma_xy (3), co-rotational frame
PT_MAT = 6            # plane_stress history (STATE_SIZE = 6): p11 p22 p33 p12 eps_bar_p eps33
PT_SA = PT_MAT + STATE_SIZE     # eps_bar_p**n (J2: the flow stress without a power)
PT_SIZE = PT_SA + 1             # 13
_E = N_THICKNESS * PT_SIZE      # 65
S_GXZ, S_GYZ = _E, _E + 1                     # total transverse shear strains
S_HG = _E + 2                                 # 5 hourglass forces: m_x, m_y, b_x, b_y, w
S_THICK = _E + 7                              # current thickness h
S_MCOS, S_MSIN = _E + 8, _E + 9               # material axis 1 in the element frame
S_W_INT, S_W_PLASTIC, S_W_HG = _E + 10, _E + 11, _E + 12
N_STATE = _E + 13                             # 78

# rows of the local nodal data ``loc`` (10, 4), one column per node
L_X, L_Y = 0, 1                 # local coordinates x^, y^ about the centroid
L_VX, L_VY, L_VZ = 2, 3, 4      # local translational velocities v^
L_TX, L_TY = 5, 6               # local angular velocities theta^x, theta^y
L_B1, L_B2 = 7, 8               # centroid gradient dN/dx^, dN/dy^
L_GAMMA = 9                     # Belytschko-Tsay hourglass vector


class Work(NamedTuple):
    """Scratch of :func:`element_forces`, made once per element loop (or parallel chunk)."""
    ef: np.ndarray          # (3, 3) co-rotational frame, rows e1, e2, e3
    loc: np.ndarray         # (10, 4) local nodal data, rows L_*
    Dm: np.ndarray          # (3, 3) orthotropic plane-stress stiffness
    Dj: np.ndarray          # (3, 3) J2 tangent (not formed)
    eps: np.ndarray         # (3,) total strain at a thickness point
    sig: np.ndarray         # (3,) its stress
    st_new: np.ndarray      # (STATE_SIZE,) J2 history after a return
    w4: np.ndarray          # (4,) J2 Newton work
    w44: np.ndarray         # (4, 4)


class PlaneLaw(NamedTuple):
    """The law of a shell element's thickness points: eq. 12 (``ortho``, material axis 1
    at ``(mc, ms)`` = (cos, sin) of its angle from e1) or eq. 2 J2 with the plane-stress
    ``c_ps = E / (1 - nu^2)`` and ``nu_r = nu / (1 - nu)`` of its elastic predictor."""
    ortho: bool
    mc: float
    ms: float
    c_ps: float
    nu_r: float


@njit(cache=True, inline="always")
def work_arrays():
    """A fresh :class:`Work` (inlined: the caller sees the allocations)."""
    return Work(np.empty((3, 3)), np.empty((10, 4)), np.empty((3, 3)), np.empty((3, 3)),
                np.empty(3), np.empty(3), np.empty(STATE_SIZE), np.empty(4), np.empty((4, 4)))


@njit(cache=True, inline="always")
def frame(x, i0, i1, i2, i3, ef):
    """Co-rotational frame (BLT; BLM 9.6) of the quad ``i0..i3`` of ``x``
    (n_nodes, 3): rows ef[0] = e1, ef[1] = e2, ef[2] = e3 of ``ef`` (3, 3), a pure
    function of the four current nodal positions."""
    a0 = x[i2, 0] - x[i0, 0]
    a1 = x[i2, 1] - x[i0, 1]
    a2 = x[i2, 2] - x[i0, 2]
    b0 = x[i3, 0] - x[i1, 0]
    b1 = x[i3, 1] - x[i1, 1]
    b2 = x[i3, 2] - x[i1, 2]
    n0 = a1 * b2 - a2 * b1
    n1 = a2 * b0 - a0 * b2
    n2 = a0 * b1 - a1 * b0
    nn = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    n0 /= nn
    n1 /= nn
    n2 /= nn
    s0 = x[i1, 0] + x[i2, 0] - x[i0, 0] - x[i3, 0]
    s1 = x[i1, 1] + x[i2, 1] - x[i0, 1] - x[i3, 1]
    s2 = x[i1, 2] + x[i2, 2] - x[i0, 2] - x[i3, 2]
    sn = s0 * n0 + s1 * n1 + s2 * n2
    s0 -= sn * n0
    s1 -= sn * n1
    s2 -= sn * n2
    ss = np.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    s0 /= ss
    s1 /= ss
    s2 /= ss
    ef[0, 0], ef[0, 1], ef[0, 2] = s0, s1, s2
    ef[1, 0] = n1 * s2 - n2 * s1
    ef[1, 1] = n2 * s0 - n0 * s2
    ef[1, 2] = n0 * s1 - n1 * s0
    ef[2, 0], ef[2, 1], ef[2, 2] = n0, n1, n2


@njit(cache=True, inline="always")
def _local_nodes(e, x, v, conn, ef, loc):
    """Co-rotational frame ``ef`` of element ``e`` and, in ``loc``, its nodes' local
    coordinates ``x^, y^`` about the centroid, velocities ``v^ = E^T v`` and angular
    velocities ``theta^ = E^T omega`` (BLT; BLM 9.6).  ``x`` (n_nodes, 3), ``v``
    (n_nodes, 6) half-step velocities, ``conn`` (n_el, 4)."""
    nd0, nd1, nd2, nd3 = conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3]
    frame(x, nd0, nd1, nd2, nd3, ef)
    xc0 = 0.25 * (x[nd0, 0] + x[nd1, 0] + x[nd2, 0] + x[nd3, 0])
    xc1 = 0.25 * (x[nd0, 1] + x[nd1, 1] + x[nd2, 1] + x[nd3, 1])
    xc2 = 0.25 * (x[nd0, 2] + x[nd1, 2] + x[nd2, 2] + x[nd3, 2])
    for a in range(4):
        nd = conn[e, a]
        d0, d1, d2 = x[nd, 0] - xc0, x[nd, 1] - xc1, x[nd, 2] - xc2
        loc[L_X, a] = d0 * ef[0, 0] + d1 * ef[0, 1] + d2 * ef[0, 2]
        loc[L_Y, a] = d0 * ef[1, 0] + d1 * ef[1, 1] + d2 * ef[1, 2]
        for r in range(3):
            loc[L_VX + r, a] = v[nd, 0] * ef[r, 0] + v[nd, 1] * ef[r, 1] + v[nd, 2] * ef[r, 2]
        for r in range(2):
            loc[L_TX + r, a] = v[nd, 3] * ef[r, 0] + v[nd, 4] * ef[r, 1] + v[nd, 5] * ef[r, 2]


@njit(cache=True, inline="always")
def _centroid_gradient(loc):
    """One-point gradient ``B1, B2`` (BLT; BLM 9.6) and the Belytschko-Tsay
    hourglass vector ``gamma_a = 1/4 [h_a - (h.x^) B1_a - (h.y^) B2_a]`` (BLM 9.6) into
    ``loc`` (10, 4) from its local coordinates; returns the area A and
    ``BB = sum_a B1_a^2 + B2_a^2``."""
    area = 0.5 * ((loc[L_X, 2] - loc[L_X, 0]) * (loc[L_Y, 3] - loc[L_Y, 1])
                  + (loc[L_X, 1] - loc[L_X, 3]) * (loc[L_Y, 2] - loc[L_Y, 0]))
    f2a = 1.0 / (2.0 * area)
    for a in range(4):
        loc[L_B1, a] = (loc[L_Y, (a + 1) % 4] - loc[L_Y, (a + 3) % 4]) * f2a
        loc[L_B2, a] = (loc[L_X, (a + 3) % 4] - loc[L_X, (a + 1) % 4]) * f2a
    hx = loc[L_X, 0] - loc[L_X, 1] + loc[L_X, 2] - loc[L_X, 3]
    hy = loc[L_Y, 0] - loc[L_Y, 1] + loc[L_Y, 2] - loc[L_Y, 3]
    hsign = (1.0, -1.0, 1.0, -1.0)
    bb = 0.0
    for a in range(4):
        b1, b2 = loc[L_B1, a], loc[L_B2, a]
        loc[L_GAMMA, a] = 0.25 * (hsign[a] - hx * b1 - hy * b2)
        bb += b1 * b1 + b2 * b2
    return area, bb


@njit(cache=True, inline="always")
def _velocity_strains(loc):
    """Mindlin velocity strains at the centroid (BLT; BLM 9.6): membrane rates
    ``(d_x, d_y, 2 d_xy)``, curvature rates ``(k_x, k_y, 2 k_xy)`` (the fibre at ``z``
    has ``d_m + z k``) and transverse shear rates ``(2 d_xz, 2 d_yz)``, from ``loc``
    (10, 4)."""
    dmx = dmy = dmxy = kx = ky = kxy = 0.0
    gxz = gyz = 0.0
    for a in range(4):
        b1, b2 = loc[L_B1, a], loc[L_B2, a]
        vx, vy, vz, tx, ty = loc[L_VX, a], loc[L_VY, a], loc[L_VZ, a], loc[L_TX, a], loc[L_TY, a]
        dmx += b1 * vx
        dmy += b2 * vy
        dmxy += b1 * vy + b2 * vx
        kx += b1 * ty
        ky -= b2 * tx
        kxy += b2 * ty - b1 * tx
        gxz += b1 * vz + 0.25 * ty
        gyz += b2 * vz - 0.25 * tx
    return (dmx, dmy, dmxy), (kx, ky, kxy), (gxz, gyz)


@njit(cache=True, inline="always")
def _hourglass_rates(loc):
    """The five hourglass rates ``q' = gamma.(v^x, v^y, theta^x, theta^y, v^z)``
    (BLM 9.6) from ``loc`` (10, 4)."""
    q0 = q1 = q2 = q3 = q4 = 0.0
    for a in range(4):
        ga = loc[L_GAMMA, a]
        q0 += ga * loc[L_VX, a]
        q1 += ga * loc[L_VY, a]
        q2 += ga * loc[L_TX, a]
        q3 += ga * loc[L_TY, a]
        q4 += ga * loc[L_VZ, a]
    return q0, q1, q2, q3, q4


@njit(cache=True, inline="always")
def _moduli(ortho, m0, m1, m3):
    """Hourglass modulus E, shear modulus G and the plane-stress ``E/(1 - nu^2)``,
    ``nu/(1 - nu)`` (J2) of a material row starting ``(m0, m1, _, m3)`` (J2: E, nu;
    eq. 12: E1, E2, _, G12)."""
    if ortho:
        return max(m0, m1), m3, 0.0, 0.0
    return m0, m0 / (2.0 * (1.0 + m1)), m0 / (1.0 - m1 * m1), m1 / (1.0 - m1)


@njit(cache=True, inline="always")
def _elastic_trial(a11, a22, g12, nu, c_ps):
    """Plane-stress Hooke stresses (s_xx, s_yy, s_xy) of the elastic strains
    ``(a11, a22, g12)`` (engineering shear); ``c_ps = E / (1 - nu^2)``."""
    return c_ps * (a11 + nu * a22), c_ps * (a22 + nu * a11), 0.5 * (1.0 - nu) * c_ps * g12


@njit(cache=True, inline="always")
def _von_mises(sig):
    """Plane-stress von Mises stress of ``sig`` (3,) = (s_xx, s_yy, s_xy)."""
    return np.sqrt(sig[0] * sig[0] + sig[1] * sig[1] - sig[0] * sig[1] + 3.0 * sig[2] * sig[2])


@njit(cache=True, inline="always")
def _through_thickness(st, me, law, dt, d_m, kappa, work):
    """Stress update at the ``N_THICKNESS`` Gauss-Legendre points (fibre positions of the
    thickness ``st[S_THICK]`` at the start of the step; BLT): the total strains
    ``eps <- eps + dt (d_m + z kappa)`` and the stresses of the element state ``st``
    (N_STATE,) are advanced in place, with the :class:`PlaneLaw` ``law``: eq. 12 (stiffness
    ``work.Dm`` (3, 3)) or eq. 2 J2 (``me`` the material row; closed-form elastic
    predictor, the return of :func:`j2_plane_stress_from` only for a trial state beyond
    the flow stress ``sigma_y + K sa``).  Returns the sums ``sum_k w_k sigma_k`` and
    ``sum_k w_k zeta_k sigma_k`` (the resultants N, M without their factors h/2,
    (h/2)^2), the stress power ``sum_k w_k sigma_mid : d`` and the plastic work
    ``sum_k w_k q dg`` (both per unit area and h/2), and ``sum_k eps_33``.
    Scratch from ``work`` (:class:`Work`): eps, sig, Dj, st_new, w4, w44."""
    ortho, mc, ms, c_ps, nu_r = law
    eps, sig, Dm, Dj, st_new, w4, w44 = (work.eps, work.sig, work.Dm, work.Dj, work.st_new,
                                         work.w4, work.w44)
    j2 = J2Material(me[0], me[1], me[2], me[3], me[4])
    dmx, dmy, dmxy = d_m
    kx, ky, kxy = kappa
    hh = 0.5 * st[S_THICK]
    nxx = nyy = nxy = mxx = myy = mxy = 0.0
    pw = wp = e33 = 0.0
    for k in range(N_THICKNESS):
        o = k * PT_SIZE
        z = ZETA[k] * hh
        dx = dmx + z * kx
        dy = dmy + z * ky
        dxy = dmxy + z * kxy
        eps[0] = st[o + PT_EPS] + dt * dx
        eps[1] = st[o + PT_EPS + 1] + dt * dy
        eps[2] = st[o + PT_EPS + 2] + dt * dxy
        if ortho:
            orthotropic_plane_stress(eps, mc, ms, Dm, me[MAT_COMPRESSION], sig)
        else:
            sold = st[o + PT_MAT:o + PT_MAT + STATE_SIZE]
            a11 = eps[0] - sold[P11]
            a22 = eps[1] - sold[P22]
            sig[0], sig[1], sig[2] = _elastic_trial(a11, a22, eps[2] - 2.0 * sold[P12], me[1], c_ps)
            qq = sig[0] * sig[0] + sig[1] * sig[1] - sig[0] * sig[1] + 3.0 * sig[2] * sig[2]
            fy = me[2] + me[3] * st[o + PT_SA]          # eq. 2 flow stress
            dg = 0.0
            if qq <= fy * fy:
                sold[EPS33] = sold[P33] - nu_r * (a11 + a22)
            else:
                dg, st[o + PT_SA] = j2_plane_stress_from(eps, sold, st[o + PT_SA], j2, sig, Dj,
                                                         st_new, w4, w44, False)
                for i in range(STATE_SIZE):
                    sold[i] = st_new[i]
            e33 += st[o + PT_MAT + EPS33]
            if dg > 0.0:
                wp += ZETA_W[k] * _von_mises(sig) * dg
        pw += ZETA_W[k] * 0.5 * ((st[o + PT_SIG] + sig[0]) * dx + (st[o + PT_SIG + 1] + sig[1]) * dy
                                 + (st[o + PT_SIG + 2] + sig[2]) * dxy)
        for i in range(3):
            st[o + PT_EPS + i] = eps[i]
            st[o + PT_SIG + i] = sig[i]
        w = ZETA_W[k]
        nxx += w * sig[0]
        nyy += w * sig[1]
        nxy += w * sig[2]
        wz = w * ZETA[k]
        mxx += wz * sig[0]
        myy += wz * sig[1]
        mxy += wz * sig[2]
    return (nxx, nyy, nxy), (mxx, myy, mxy), pw, wp, e33


@njit(cache=True, inline="always")
def _transverse_shear(st, dt, ks, h_old, h, g_rate):
    """Elastic transverse shear ``Q = kappa G h gamma`` (BLT): advances the total
    shear strains of the state ``st`` by ``dt g_rate``; returns (Q_x, Q_y) before and
    after the step (``ks`` = kappa G; thicknesses ``h_old``, ``h``)."""
    gxz, gyz = g_rate
    qx_old = ks * h_old * st[S_GXZ]
    qy_old = ks * h_old * st[S_GYZ]
    st[S_GXZ] += dt * gxz
    st[S_GYZ] += dt * gyz
    qx = ks * h * st[S_GXZ]
    qy = ks * h * st[S_GYZ]
    return (qx_old, qy_old), (qx, qy)


@njit(cache=True, inline="always")
def _hourglass_stiffness(hg, E_hg, ks, h, area, bb):
    """Belytschko-Tsay hourglass stiffnesses (BLM 9.6) of a plane-stress section:
    membrane r_m = r_hg E h A BB / 8, bending r_b = r_hg E h^3 A BB / 192, w-mode
    r_w = r_hg kappa G h^3 BB / 12."""
    return (hg * E_hg * h * area * bb / 8.0, hg * E_hg * h * h * h * area * bb / 192.0,
            hg * ks * h * h * h * bb / 12.0)


@njit(cache=True, inline="always")
def _hourglass_stiffness_resultant(hg, me, area, bb):
    """The same stiffnesses for a section given by its resultant stiffnesses (the tube
    wall's row): membrane ``Eh`` the largest of k_e, k_h, bending ``D = E h^3/12`` the
    largest of D_h, D_x, and ``h^2 = 12 D / Eh`` in the w-mode."""
    Eh = max(me[W_KE], me[W_KH])
    D = max(me[W_DH], me[W_DX])
    return hg * Eh * area * bb / 8.0, hg * D * area * bb / 16.0, hg * me[W_KGT] * D * bb / Eh


@njit(cache=True, inline="always")
def _hourglass_forces(st, dt, r, q):
    """Belytschko-Tsay stiffness hourglass control (BLM 9.6): the five hourglass forces
    ``Q_i <- Q_i + dt r_i q'_i`` in the state ``st`` for the stiffnesses ``r`` = (r_m,
    r_b, r_w) and the rates ``q`` (5,); returns the new forces and their work over the
    step."""
    q0, q1, q2, q3, q4 = q
    r_m, r_b, r_w = r
    o = S_HG
    hg_old0, hg_old1, hg_old2, hg_old3, hg_old4 = st[o], st[o + 1], st[o + 2], st[o + 3], st[o + 4]
    st[o] += dt * r_m * q0
    st[o + 1] += dt * r_m * q1
    st[o + 2] += dt * r_b * q2
    st[o + 3] += dt * r_b * q3
    st[o + 4] += dt * r_w * q4
    Hm0, Hm1, Hb0, Hb1, Hw = st[o], st[o + 1], st[o + 2], st[o + 3], st[o + 4]
    w_hg = 0.5 * dt * ((hg_old0 + Hm0) * q0 + (hg_old1 + Hm1) * q1 + (hg_old2 + Hb0) * q2
                       + (hg_old3 + Hb1) * q3 + (hg_old4 + Hw) * q4)
    return (Hm0, Hm1, Hb0, Hb1, Hw), w_hg


@njit(cache=True, inline="always")
def _add_work(st, dt, area, h, pw, wp, w_hg, Q_old, Q, g_rate):
    """Trapezoidal works of the step into the state ``st``: plastic dissipation, hourglass
    and total internal work (membrane + bending + transverse shear + hourglass)."""
    vol_half = area * (0.5 * h)
    st[S_W_PLASTIC] += vol_half * wp
    st[S_W_HG] += w_hg
    st[S_W_INT] += (dt * vol_half * pw + 0.5 * dt * area * ((Q_old[0] + Q[0]) * g_rate[0]
                                                            + (Q_old[1] + Q[1]) * g_rate[1])
                    + w_hg)


@njit(cache=True, inline="always")
def _nodal_forces(e, f_el, ef, loc, area, N, M, Q, H):
    """Nodal forces and moments from the virtual power (BLT; BLM 9.6) of the resultants
    ``N``, ``M`` (3,), ``Q`` (2,) and the hourglass forces ``H`` (5,), rotated from the
    co-rotational frame ``ef`` into ``f_el[e]`` (4, 6)."""
    nxx, nyy, nxy = N
    mxx, myy, mxy = M
    qx, qy = Q
    Hm0, Hm1, Hb0, Hb1, Hw = H
    for a in range(4):
        b1, b2, ga = loc[L_B1, a], loc[L_B2, a], loc[L_GAMMA, a]
        fx = area * (b1 * nxx + b2 * nxy) + Hm0 * ga
        fy = area * (b2 * nyy + b1 * nxy) + Hm1 * ga
        fz = area * (b1 * qx + b2 * qy) + Hw * ga
        mx = -area * (b2 * myy + b1 * mxy) - 0.25 * area * qy + Hb0 * ga
        my = area * (b1 * mxx + b2 * mxy) + 0.25 * area * qx + Hb1 * ga
        for i in range(3):
            f_el[e, a, i] = fx * ef[0, i] + fy * ef[1, i] + fz * ef[2, i]
            f_el[e, a, 3 + i] = mx * ef[0, i] + my * ef[1, i]


@njit(cache=True, inline="always")
def element_forces(e, x, v, conn, thick, mat, state, dt, hg, f_el, work):
    """Stress update over ``dt`` and nodal forces of element ``e``: writes ``f_el[e]``
    (4, 6), updates ``state[e]`` (N_STATE,).  ``x`` (n_nodes, 3) positions, ``v``
    (n_nodes, 6) half-step velocities, ``conn`` (n_el, 4), ``thick`` (n_el,) initial
    thicknesses, ``mat`` (n_el, 5 or more) material rows, ``hg`` the hourglass coefficient;
    ``work`` the scratch (:class:`Work`).  Inlined into a loop kernel
    (:mod:`harnesspipe.fe.loops`): its arrays and views are not reference-counted."""
    ef, loc, Dm = work.ef, work.loc, work.Dm
    _local_nodes(e, x, v, conn, ef, loc)
    area, bb = _centroid_gradient(loc)
    rates = _velocity_strains(loc)
    d_m, kappa, g_rate = rates
    q = _hourglass_rates(loc)
    st = state[e]
    me = mat[e]
    if me.shape[0] > MAT_KIND and me[MAT_KIND] == MAT_TUBE:
        _tube_element(e, st, me, dt, hg, area, bb, rates, q, f_el, work)
        return
    h_old = st[S_THICK]
    ortho = me.shape[0] > MAT_KIND and me[MAT_KIND] == MAT_ORTHOTROPIC
    E_hg, G, c_ps, nu_r = _moduli(ortho, me[0], me[1], me[3])
    mc = ms = 0.0
    if ortho:
        orthotropic_plane_stress_stiffness(me[0], me[1], me[2] * me[MAT_COMPRESSION], me[3], Dm)
        mc, ms = st[S_MCOS], st[S_MSIN]
    law = PlaneLaw(ortho, mc, ms, c_ps, nu_r)
    n_sum, m_sum, pw, wp, e33 = _through_thickness(st, me, law, dt, d_m, kappa, work)
    h = thick[e] if ortho else thick[e] * np.exp(e33 / N_THICKNESS)
    st[S_THICK] = h
    c_n = 0.5 * h                   # resultants with the updated thickness
    c_m = 0.25 * h * h
    N = (n_sum[0] * c_n, n_sum[1] * c_n, n_sum[2] * c_n)
    M = (m_sum[0] * c_m, m_sum[1] * c_m, m_sum[2] * c_m)
    ks = SHEAR_CORRECTION * G
    Q_old, Q = _transverse_shear(st, dt, ks, h_old, h, g_rate)
    H, w_hg = _hourglass_forces(st, dt, _hourglass_stiffness(hg, E_hg, ks, h, area, bb), q)
    _add_work(st, dt, area, h, pw, wp, w_hg, Q_old, Q, g_rate)
    _nodal_forces(e, f_el, ef, loc, area, N, M, Q, H)


@njit(cache=True, inline="always")
def _tube_element(e, st, me, dt, hg, area, bb, rates, q, f_el, work):
    """:func:`element_forces` of a ridged-tube wall element (``MAT_TUBE``): resultants from
    :func:`harnesspipe.fe.materials.tube_wall.tube_wall_resultants` in the state's first
    ``T_SIZE`` slots, transverse shear ``kGt gamma``, no thickness change (the element's
    thickness is its mass thickness only).  ``rates`` the velocity strains
    (:func:`_velocity_strains`)."""
    d_m, kappa, g_rate = rates
    h = st[S_THICK]
    N, M, w, wp = tube_wall_resultants(st[:T_SIZE], me, st[S_MCOS], st[S_MSIN], dt, d_m, kappa)
    Q_old, Q = _transverse_shear(st, dt, me[W_KGT] / h, h, h, g_rate)
    H, w_hg = _hourglass_forces(st, dt, _hourglass_stiffness_resultant(hg, me, area, bb), q)
    st[S_W_PLASTIC] += area * wp
    st[S_W_HG] += w_hg
    st[S_W_INT] += area * (w + 0.5 * dt * ((Q_old[0] + Q[0]) * g_rate[0]
                                           + (Q_old[1] + Q[1]) * g_rate[1])) + w_hg
    _nodal_forces(e, f_el, work.ef, work.loc, area, N, M, Q, H)
