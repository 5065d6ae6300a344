"""Belytschko-Lin-Tsay (BLT) shell for explicit dynamics: 4 nodes, 6 DOFs per node,
one-point in-plane quadrature, co-rotational rate formulation.

References
----------
* T. Belytschko, J.I. Lin, C.S. Tsay, "Explicit algorithms for the nonlinear
  dynamics of shells", Comput. Methods Appl. Mech. Engrg. 42 (1984) 225-251.
* T. Belytschko, W.K. Liu, B. Moran, *Nonlinear Finite Elements for Continua and
  Structures*, Wiley 2000, ch. 9 (9.6: one-point quadrature shells and hourglass
  control).
* J.O. Hallquist, *LS-DYNA Theory Manual*, LSTC, "Belytschko-Lin-Tsay shell" and
  "hourglass control" sections (element type 2; shell time step; rotary inertia).

Kinematics (all quantities at the current configuration, node order 1-2-3-4)
---------------------------------------------------------------------------
* Co-rotational frame from the current nodes: ``e3 = (x31 x x42)/|x31 x x42|``,
  ``e1`` = the mid-side vector ``x2 + x3 - x1 - x4`` projected on the plane normal to
  ``e3`` and normalised, ``e2 = e3 x e1``.  The frame is a function of the nodal
  positions only, so any rigid motion leaves all local quantities unchanged.
* Local nodal coordinates ``(x^_a, y^_a)`` (projection on e1, e2 about the centroid),
  local translational velocities ``v^ = E^T v`` and angular velocities
  ``theta^ = E^T omega`` (``E = [e1 e2 e3]``; ``v`` is the velocity at the half step
  ``n+1/2``, positions at ``n+1`` as usual in the central-difference method).
* One-point (centroid) gradient ``B1 = dN/dx^``, ``B2 = dN/dy^``::

      A  = 1/2 [(x^3 - x^1)(y^4 - y^2) + (x^2 - x^4)(y^3 - y^1)]
      B1 = [y^2 - y^4, y^3 - y^1, y^4 - y^2, y^1 - y^3] / (2A)
      B2 = [x^4 - x^2, x^1 - x^3, x^2 - x^4, x^3 - x^1] / (2A)

* Mindlin velocity field ``v(z) = v_mid + omega x (z e3)``, i.e. ``u^ = z theta^_y``,
  ``v^ = -z theta^_x``.  Velocity strains (engineering shear) at fibre ``z``::

      d_x  = B1.v^x + z B1.theta^y
      d_y  = B2.v^y - z B2.theta^x
      2d_xy = B1.v^y + B2.v^x + z (B2.theta^y - B1.theta^x)
      2d_xz = B1.v^z + mean(theta^y),   2d_yz = B2.v^z - mean(theta^x)

* Nodal forces from the virtual power (A = current area, resultants N, M, Q)::

      f^x_a = A (B1_a N_xx + B2_a N_xy)      f^y_a = A (B2_a N_yy + B1_a N_xy)
      f^z_a = A (B1_a Q_x + B2_a Q_y)
      m^x_a = -A (B2_a M_yy + B1_a M_xy) - A Q_y / 4
      m^y_a =  A (B1_a M_xx + B2_a M_xy) + A Q_x / 4,   m^z_a = 0 (no drilling stiffness)

  with ``N = h/2 sum_k w_k sigma_k``, ``M = (h/2)^2 sum_k w_k zeta_k sigma_k`` over
  ``N_THICKNESS = 5`` **Gauss-Legendre** points through the thickness (as
  :mod:`harnesspipe.fe.shell`), ``z_k = zeta_k h / 2``.  Local forces are rotated back
  with ``E`` and written per element to ``f_el``; a serial scatter ADDS them to the
  global ``f_int`` (shared with beams).

Constitutive update (rate form, stresses in the co-rotational frame)
-------------------------------------------------------------------
Every thickness point keeps a *total* co-rotational in-plane strain
``eps <- eps + dt d`` (components in the current element frame, which is the
BLT way of obtaining objectivity: no Jaumann term, the frame rotates with the
element) and the committed material history.  The existing strain-driven kernels
of :mod:`harnesspipe.fe.plane_stress` are then called with that total strain:

* J2 (``mat`` = (E, nu, sigma_y, K, n, 0)): :func:`j2_plane_stress` with eq. 2
  power-law hardening; the accumulated rate strain is a logarithmic strain
  (additive plastic split, as in ``fe/shell.py``).  It returns the total
  through-thickness strain ``eps_33`` (elastic Poisson + plastic incompressibility);
  the element thickness is ``h = h0 exp(mean_k eps_33)``.
  Elastic trial states are evaluated in closed form (plane-stress Hooke on
  ``eps - eps_p``, the exact result of the kernel when it stays elastic) against the
  flow stress ``sigma_y + K sa`` with ``sa = eps_bar_p**n`` kept in the state
  (``PT_SA``: no power per point and step); the kernel (Newton on sigma_33 = 0 with
  the radial return, :func:`j2_plane_stress_from` without the tangent) only runs when
  the trial state violates the yield condition.
* Orthotropic elastic eq. 12 (``mat`` = (E1, E2, nu12, G12, 0, 1)): material
  direction 1 is ``axes_ref`` projected on the initial element plane; its angle from
  the initial ``e1`` is stored in the state and convected with the co-rotational
  frame.  Thickness stays ``h0`` (eq. 12 gives no out-of-plane Poisson ratios), the
  transverse shear modulus is G12 -- both as in ``fe/shell.py``.

Transverse shear is elastic: ``Q = kappa G h gamma``, kappa = 5/6, with the total
shear strains ``gamma_xz, gamma_yz`` integrated from the rates.

Hourglass control (Belytschko-Tsay, stiffness form, elastic)
------------------------------------------------------------
``gamma_a = 1/4 [h_a - (h.x^) B1_a - (h.y^) B2_a]``, ``h = (1, -1, 1, -1)``, is
orthogonal to every linear field on a flat element.  Five hourglass rates
``q'_i = gamma.(v^x, v^y, theta^x, theta^y, v^z)`` drive incremental hourglass
forces ``Q_i <- Q_i + dt r_i q'_i`` (stored in the co-rotational frame), with
(``BB = sum_a B1_a^2 + B2_a^2``, ``r_hg`` = ``hg`` argument, default 0.1)::

    membrane  r_m = r_hg E h A BB / 8
    bending   r_b = r_hg E h^3 A BB / 192
    w-mode    r_w = r_hg kappa G h^3 BB / 12

and nodal forces/moments ``Q_i gamma_a``.  They are part of ``f_el``/``f_int``, so the
external work they absorb is part of the internal energy; their work is tracked
separately (``S_W_HG``).  E is max(E1, E2) and G = G12 for the orthotropic law.

Energies (per element, trapezoidal in the stresses, current volume ``A h``)
--------------------------------------------------------------------------
``S_W_INT`` total internal work (membrane + bending + transverse shear +
hourglass); ``S_W_PLASTIC`` plastic dissipation ``sum A h/2 w_k q_k d(eps_bar_p)``
(radial return: ``sigma : d eps_p = q d eps_bar_p`` exactly);  ``S_W_HG`` hourglass
work.  Elastic (recoverable) energy = W_INT - W_PLASTIC - W_HG, see
:func:`shell_energies`.

Mass and time step
------------------
Lumped: translational ``rho h A / 4`` per node, rotary (scalar, isotropic)
``max(rho h^3/12, rho h A/12) A/4`` per node (LS-DYNA / Hughes-Liu scaling; with
it the highest rotational/transverse-shear frequency of an element,
``omega^2 <= kappa G/rho (4/a^2 + 12/max(h^2, A))``, stays below the membrane one).
Stable step ``dt = L / c`` with ``L = A / max diagonal`` and the plate wave speed
``c = sqrt(max(D11, D22) / rho)`` (= sqrt(E / (rho (1 - nu^2))) for isotropic).  For a
square of side a this is ``a / (sqrt 2 c)``, below the one-element bound of the
free dilatational mode ``a / (c sqrt(1 + nu))`` and of the shear/rotation modes,
so the usual safety factor 0.9 is safe (``L = A / max side``, the LS-DYNA default,
gives a / c, above the free-element dilatational bound).  tests/test_shell_bt.py checks
the estimate against the eigenvalues of the linearised free mesh: dt_crit / dt_est =
sqrt(2 / (1 + nu)) = 1.24 for one free element (the tight case; a free-vibration run
blows up at 1.5 x) and 1.4-1.6 for a free 4 x 4 mesh (blows up at 2 x), stable at 0.9 x.
Cost: O(n_el), about 20-35 ns per element, cheap enough to recheck often.

Not modelled / limitations
--------------------------
* No warping correction (Belytschko-Wong-Chiang): warped elements are treated by
  their projection on the mean plane (fine for planar quads, e.g. tube meshes with
  nodes on rings; the twisted-beam benchmark would be too flexible).
* No drilling stiffness (m^z = 0); on flat, unsupported regions the drill rotation
  is a zero-frequency DOF (mass only), as in LS-DYNA type 2.
* One-point quadrature leaves a twist mechanism (antisymmetric w/theta_y hourglass
  patterns) that only the hourglass forces resist: a strip ONE element wide is far too
  soft in torsion (>100x for a 1 x 10 strip with r_hg = 0.1).  Use >= 2 elements
  across any twisted strip and monitor ``S_W_HG`` (the tests keep it < 5 % of W_INT).
* Transverse shear and hourglass forces are elastic (no plastic coupling); no
  thickness-stretch inertia; thickness change only through eps_33 of the J2 law.
* The frame's e1 follows the element edges, not the polar rotation: for large
  in-plane shear the stored stresses are "rotated" with the edges (standard BLT).
* Velocities must be those at the half step; the kernel is not meant for implicit
  use (see ``fe/shell.py`` for that).
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from harnesspipe.fe.plane_stress import (EPS33, P11, P12, P22, P33, STATE_SIZE,
                                         j2_plane_stress_from, orthotropic_plane_stress,
                                         orthotropic_plane_stress_stiffness)

N_THICKNESS = 5
_ZETA, _ZETA_W = np.polynomial.legendre.leggauss(N_THICKNESS)
ZETA = tuple(float(z) for z in _ZETA)      # tuples: compile-time constants (cacheable)
ZETA_W = tuple(float(w) for w in _ZETA_W)
SHEAR_CORRECTION = 5.0 / 6.0
HOURGLASS_COEF = 0.1
MAT_KIND = 5
MAT_J2, MAT_ORTHOTROPIC = 0, 1

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
CHUNK = 32   # elements per parallel task (scratch is allocated once per task)
PARALLEL_MIN = 128   # below this many elements shell_forces runs the serial kernel


@njit(cache=True)
def _frame(x, i0, i1, i2, i3, ef):
    """Co-rotational frame rows ef[0] = e1, ef[1] = e2, ef[2] = e3, a pure function of
    the four current nodal positions."""
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


@njit(cache=True)
def _element(e, x, v, conn, thick, mat, state, dt, hg, f_el, ef, loc, Dm, eps, sig, st_new,
             w4, w44, Dj):
    """Stress update and nodal forces of element ``e`` (writes f_el[e], updates state[e]).

    Scratch: ef (3, 3) frame, loc (14, 4) local nodal data, Dm/Dj (3, 3), eps/sig (3,),
    st_new (STATE_SIZE,), w4 (4,), w44 (4, 4).
    """
    nd0, nd1, nd2, nd3 = conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3]
    _frame(x, nd0, nd1, nd2, nd3, ef)
    xc0 = 0.25 * (x[nd0, 0] + x[nd1, 0] + x[nd2, 0] + x[nd3, 0])
    xc1 = 0.25 * (x[nd0, 1] + x[nd1, 1] + x[nd2, 1] + x[nd3, 1])
    xc2 = 0.25 * (x[nd0, 2] + x[nd1, 2] + x[nd2, 2] + x[nd3, 2])
    # loc rows: 0 x^, 1 y^, 2 v^x, 3 v^y, 4 v^z, 5 theta^x, 6 theta^y, 7 B1, 8 B2, 9 gamma,
    #           10..13 spare
    for a in range(4):
        nd = conn[e, a]
        d0, d1, d2 = x[nd, 0] - xc0, x[nd, 1] - xc1, x[nd, 2] - xc2
        loc[0, a] = d0 * ef[0, 0] + d1 * ef[0, 1] + d2 * ef[0, 2]
        loc[1, a] = d0 * ef[1, 0] + d1 * ef[1, 1] + d2 * ef[1, 2]
        for r in range(3):
            loc[2 + r, a] = v[nd, 0] * ef[r, 0] + v[nd, 1] * ef[r, 1] + v[nd, 2] * ef[r, 2]
        for r in range(2):
            loc[5 + r, a] = v[nd, 3] * ef[r, 0] + v[nd, 4] * ef[r, 1] + v[nd, 5] * ef[r, 2]
    X = loc[0]
    Y = loc[1]
    area = 0.5 * ((X[2] - X[0]) * (Y[3] - Y[1]) + (X[1] - X[3]) * (Y[2] - Y[0]))
    f2a = 1.0 / (2.0 * area)
    B1 = loc[7]
    B2 = loc[8]
    for a in range(4):
        B1[a] = (Y[(a + 1) % 4] - Y[(a + 3) % 4]) * f2a
        B2[a] = (X[(a + 3) % 4] - X[(a + 1) % 4]) * f2a
    hx = X[0] - X[1] + X[2] - X[3]
    hy = Y[0] - Y[1] + Y[2] - Y[3]
    gam = loc[9]
    hsign = (1.0, -1.0, 1.0, -1.0)
    bb = 0.0
    for a in range(4):
        gam[a] = 0.25 * (hsign[a] - hx * B1[a] - hy * B2[a])
        bb += B1[a] * B1[a] + B2[a] * B2[a]
    vx, vy, vz, tx, ty = loc[2], loc[3], loc[4], loc[5], loc[6]
    dmx = dmy = dmxy = kx = ky = kxy = 0.0
    gxz = gyz = 0.0
    q0 = q1 = q2 = q3 = q4 = 0.0
    for a in range(4):
        dmx += B1[a] * vx[a]
        dmy += B2[a] * vy[a]
        dmxy += B1[a] * vy[a] + B2[a] * vx[a]
        kx += B1[a] * ty[a]
        ky -= B2[a] * tx[a]
        kxy += B2[a] * ty[a] - B1[a] * tx[a]
        gxz += B1[a] * vz[a] + 0.25 * ty[a]
        gyz += B2[a] * vz[a] - 0.25 * tx[a]
        q0 += gam[a] * vx[a]
        q1 += gam[a] * vy[a]
        q2 += gam[a] * tx[a]
        q3 += gam[a] * ty[a]
        q4 += gam[a] * vz[a]

    st = state[e]
    h_old = st[S_THICK]
    h0 = thick[e]
    me = mat[e]
    ortho = me.shape[0] > MAT_KIND and me[MAT_KIND] == MAT_ORTHOTROPIC
    if ortho:
        E_hg = max(me[0], me[1])
        G = me[3]
        orthotropic_plane_stress_stiffness(me[0], me[1], me[2], me[3], Dm)
        mc, ms = st[S_MCOS], st[S_MSIN]
    else:
        E_hg = me[0]
        G = me[0] / (2.0 * (1.0 + me[1]))
        mc = ms = 0.0
        c_ps = me[0] / (1.0 - me[1] * me[1])
        nu_r = me[1] / (1.0 - me[1])
    # --- through-thickness integration (stress update with the fibre positions of h_old)
    hh = 0.5 * h_old
    nxx = nyy = nxy = mxx = myy = mxy = 0.0
    pw = 0.0    # sum_k w_k sigma_mid : d   (per unit area / (h/2))
    wp = 0.0    # plastic work density sum_k w_k q dg
    e33 = 0.0
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
            orthotropic_plane_stress(eps, mc, ms, Dm, sig)
        else:
            sold = st[o + PT_MAT:o + PT_MAT + STATE_SIZE]
            # elastic predictor in closed form (identical to what j2_plane_stress returns
            # when elastic: its sigma_33 = 0 guess is exact then); the kernel only runs
            # for plastic trial states
            a11 = eps[0] - sold[P11]
            a22 = eps[1] - sold[P22]
            sig[0] = c_ps * (a11 + me[1] * a22)
            sig[1] = c_ps * (a22 + me[1] * a11)
            sig[2] = 0.5 * (1.0 - me[1]) * c_ps * (eps[2] - 2.0 * sold[P12])
            qq = sig[0] * sig[0] + sig[1] * sig[1] - sig[0] * sig[1] + 3.0 * sig[2] * sig[2]
            fy = me[2] + me[3] * st[o + PT_SA]          # eq. 2 flow stress
            dg = 0.0
            if qq <= fy * fy:
                sold[EPS33] = sold[P33] - nu_r * (a11 + a22)
            else:
                dg, st[o + PT_SA] = j2_plane_stress_from(eps, sold, st[o + PT_SA], me[0], me[1],
                                                         me[2], me[3], me[4], sig, Dj, st_new,
                                                         w4, w44, False)
                for i in range(STATE_SIZE):
                    sold[i] = st_new[i]
            e33 += sold[EPS33]
            if dg > 0.0:
                qe = np.sqrt(sig[0] * sig[0] + sig[1] * sig[1] - sig[0] * sig[1]
                             + 3.0 * sig[2] * sig[2])
                wp += ZETA_W[k] * qe * dg
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
    if ortho:
        h = h0
    else:
        h = h0 * np.exp(e33 / N_THICKNESS)
    st[S_THICK] = h
    # resultants with the updated thickness
    c_n = 0.5 * h
    c_m = 0.25 * h * h
    nxx *= c_n
    nyy *= c_n
    nxy *= c_n
    mxx *= c_m
    myy *= c_m
    mxy *= c_m
    # --- transverse shear (elastic)
    ks = SHEAR_CORRECTION * G
    qx_old = ks * h_old * st[S_GXZ]
    qy_old = ks * h_old * st[S_GYZ]
    st[S_GXZ] += dt * gxz
    st[S_GYZ] += dt * gyz
    qx = ks * h * st[S_GXZ]
    qy = ks * h * st[S_GYZ]
    # --- hourglass (stiffness form)
    r_m = hg * E_hg * h * area * bb / 8.0
    r_b = hg * E_hg * h * h * h * area * bb / 192.0
    r_w = hg * ks * h * h * h * bb / 12.0
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
    # --- energies
    vol_half = area * c_n
    st[S_W_PLASTIC] += vol_half * wp
    st[S_W_HG] += w_hg
    st[S_W_INT] += (dt * vol_half * pw + 0.5 * dt * area * ((qx_old + qx) * gxz + (qy_old + qy) * gyz)
                    + w_hg)
    # --- nodal forces, local then global
    for a in range(4):
        b1, b2, ga = B1[a], B2[a], gam[a]
        fx = area * (b1 * nxx + b2 * nxy) + Hm0 * ga
        fy = area * (b2 * nyy + b1 * nxy) + Hm1 * ga
        fz = area * (b1 * qx + b2 * qy) + Hw * ga
        mx = -area * (b2 * myy + b1 * mxy) - 0.25 * area * qy + Hb0 * ga
        my = area * (b1 * mxx + b2 * mxy) + 0.25 * area * qx + Hb1 * ga
        for i in range(3):
            f_el[e, a, i] = fx * ef[0, i] + fy * ef[1, i] + fz * ef[2, i]
            f_el[e, a, 3 + i] = mx * ef[0, i] + my * ef[1, i]


@njit(cache=True, parallel=True)
def shell_element_forces(x, v, conn, thick, mat, state, dt, f_el, hg=HOURGLASS_COEF):
    """Element forces (global components) of all shells into ``f_el`` (n_el, 4, 6);
    updates ``state`` in place.  Parallel over chunks of elements; scratch is
    allocated once per chunk, never per element."""
    n_el = conn.shape[0]
    n_chunks = (n_el + CHUNK - 1) // CHUNK
    for c in prange(n_chunks):
        lo = c * CHUNK
        hi = min(n_el, lo + CHUNK)
        ef = np.empty((3, 3))
        loc = np.empty((14, 4))
        Dm = np.empty((3, 3))
        Dj = np.empty((3, 3))
        eps = np.empty(3)
        sig = np.empty(3)
        st_new = np.empty(STATE_SIZE)
        w4 = np.empty(4)
        w44 = np.empty((4, 4))
        for e in range(lo, hi):
            _element(e, x, v, conn, thick, mat, state, dt, hg, f_el, ef, loc, Dm, eps, sig,
                     st_new, w4, w44, Dj)


@njit(cache=True)
def shell_element_forces_serial(x, v, conn, thick, mat, state, dt, f_el, hg=HOURGLASS_COEF):
    """Serial twin of :func:`shell_element_forces` (small meshes: no thread launch)."""
    ef = np.empty((3, 3))
    loc = np.empty((14, 4))
    Dm = np.empty((3, 3))
    Dj = np.empty((3, 3))
    eps = np.empty(3)
    sig = np.empty(3)
    st_new = np.empty(STATE_SIZE)
    w4 = np.empty(4)
    w44 = np.empty((4, 4))
    for e in range(conn.shape[0]):
        _element(e, x, v, conn, thick, mat, state, dt, hg, f_el, ef, loc, Dm, eps, sig, st_new,
                 w4, w44, Dj)


@njit(cache=True)
def scatter_add(conn, f_el, f_int, sign=1.0):
    """f_int[conn[e, a]] += sign f_el[e, a] (serial, ADDS)."""
    for e in range(conn.shape[0]):
        for a in range(4):
            nd = conn[e, a]
            for i in range(6):
                f_int[nd, i] += sign * f_el[e, a, i]


@njit(cache=True)
def shell_forces(x, v, conn, thick, mat, state, dt, f_el, f_int, hg=HOURGLASS_COEF, sign=1.0):
    """One BLT internal-force evaluation: stress update over ``dt`` with the half-step
    velocities ``v`` (n_nodes, 6) at positions ``x`` (n_nodes, 3), element forces into
    ``f_el`` (n_el, 4, 6) and ``sign`` x them ADDED to ``f_int`` (n_nodes, 6) (1: the
    resisting force, -1: the force ON the nodes).  Nodes not in ``conn`` are not touched.
    Meshes with fewer than ``PARALLEL_MIN`` elements run serially (a thread launch costs
    more than they do)."""
    if conn.shape[0] < PARALLEL_MIN:
        shell_element_forces_serial(x, v, conn, thick, mat, state, dt, f_el, hg)
    else:
        shell_element_forces(x, v, conn, thick, mat, state, dt, f_el, hg)
    scatter_add(conn, f_el, f_int, sign)


@njit(cache=True)
def _area_diag(x, i0, i1, i2, i3):
    a0 = x[i2, 0] - x[i0, 0]
    a1 = x[i2, 1] - x[i0, 1]
    a2 = x[i2, 2] - x[i0, 2]
    b0 = x[i3, 0] - x[i1, 0]
    b1 = x[i3, 1] - x[i1, 1]
    b2 = x[i3, 2] - x[i1, 2]
    n0 = a1 * b2 - a2 * b1
    n1 = a2 * b0 - a0 * b2
    n2 = a0 * b1 - a1 * b0
    area = 0.5 * np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    d2 = max(a0 * a0 + a1 * a1 + a2 * a2, b0 * b0 + b1 * b1 + b2 * b2)
    return area, np.sqrt(d2)


@njit(cache=True)
def shell_lumped_mass(X, conn, thick, rho, out):
    """ADD the lumped mass to ``out`` (n_nodes, 6): rho h A / 4 on the translations,
    max(rho h^3/12, rho h A/12) A/4 on each rotation.  ``rho`` (n_el,)."""
    for e in range(conn.shape[0]):
        i0, i1, i2, i3 = conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3]
        area, _ = _area_diag(X, i0, i1, i2, i3)
        h = thick[e]
        m = 0.25 * rho[e] * h * area
        j = 0.25 * area * max(rho[e] * h ** 3 / 12.0, rho[e] * h * area / 12.0)
        for a in range(4):
            nd = conn[e, a]
            for i in range(3):
                out[nd, i] += m
                out[nd, 3 + i] += j


@njit(cache=True)
def wave_speed2(me, rho):
    """c^2 = max(D11, D22) / rho (plane-stress plate wave speed)."""
    if me.shape[0] > MAT_KIND and me[MAT_KIND] == MAT_ORTHOTROPIC:
        nu21 = me[2] * me[1] / me[0]
        return max(me[0], me[1]) / (1.0 - me[2] * nu21) / rho
    return me[0] / (1.0 - me[1] * me[1]) / rho


@njit(cache=True)
def shell_stable_step(x, conn, thick, mat, rho):
    """min_e L_e / c_e with L = A / max diagonal, c = sqrt(max(D11, D22) / rho).
    No safety factor applied.  ``rho`` (n_el,)."""
    dt = np.inf
    for e in range(conn.shape[0]):
        area, dmax = _area_diag(x, conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3])
        d = (area / dmax) / np.sqrt(wave_speed2(mat[e], rho[e]))
        if d < dt:
            dt = d
    return dt


@njit(cache=True)
def _init_state(X, conn, thick, axes_ref, state):
    ef = np.empty((3, 3))
    for e in range(conn.shape[0]):
        state[e, :] = 0.0
        state[e, S_THICK] = thick[e]
        _frame(X, conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3], ef)
        a1 = axes_ref[e, 0] * ef[0, 0] + axes_ref[e, 1] * ef[0, 1] + axes_ref[e, 2] * ef[0, 2]
        a2 = axes_ref[e, 0] * ef[1, 0] + axes_ref[e, 1] * ef[1, 1] + axes_ref[e, 2] * ef[1, 2]
        nrm = np.sqrt(a1 * a1 + a2 * a2)
        if nrm < 1e-12:
            a1, a2, nrm = 1.0, 0.0, 1.0
        state[e, S_MCOS] = a1 / nrm
        state[e, S_MSIN] = a2 / nrm


def init_shell_state(X, conn, thick, axes_ref=None):
    """Zero state (n_el, N_STATE) for the reference configuration ``X``.

    Thickness ``S_THICK`` = h0; material axis 1 = ``axes_ref`` (n_el, 3) projected on the
    initial element plane (default, or a vector normal to the plane: the element e1).
    Layout: thickness point k at ``k*PT_SIZE`` with ``PT_EPS`` (3 total strains),
    ``PT_SIG`` (3 stresses), ``PT_MAT`` (6, plane_stress history), ``PT_SA`` (eps_bar_p**n);
    then ``S_GXZ``, ``S_GYZ``, ``S_HG`` (5), ``S_THICK``, ``S_MCOS``, ``S_MSIN``,
    ``S_W_INT``, ``S_W_PLASTIC``, ``S_W_HG``; ``N_STATE`` = 78.
    """
    X = np.ascontiguousarray(X, dtype=float)
    conn = np.ascontiguousarray(conn, dtype=np.int64)
    thick = np.ascontiguousarray(thick, dtype=float)
    if axes_ref is None:
        axes_ref = np.zeros((conn.shape[0], 3))
    axes_ref = np.ascontiguousarray(axes_ref, dtype=float)
    state = np.zeros((conn.shape[0], N_STATE))
    _init_state(X, conn, thick, axes_ref, state)
    return state


@njit(cache=True)
def shell_plastic_work(state):
    """Plastic dissipation per element (n_el,)."""
    return state[:, S_W_PLASTIC].copy()


@njit(cache=True)
def shell_energies(state):
    """Totals (internal work, elastic, plastic, hourglass) over all elements;
    elastic = internal - plastic - hourglass."""
    wi = wp = wh = 0.0
    for e in range(state.shape[0]):
        wi += state[e, S_W_INT]
        wp += state[e, S_W_PLASTIC]
        wh += state[e, S_W_HG]
    return wi, wi - wp - wh, wp, wh


def element_frames(x, conn):
    """Current co-rotational frames (n_el, 3, 3), rows e1, e2, e3 (for post-processing)."""
    out = np.empty((conn.shape[0], 3, 3))
    _frames(np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(conn, dtype=np.int64), out)
    return out


@njit(cache=True)
def _frames(x, conn, out):
    for e in range(conn.shape[0]):
        _frame(x, conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3], out[e])
