"""Stress resultants of the corrugated (ridged) tube wall homogenised as a smooth shell.

The ridged polypropylene tube (Sec. 2.1, Table 2) cannot be meshed ridge by ridge in the
explicit three-point model, and no single plane-stress material through one thickness
gives it the properties that matter (docs/theory/tube_equivalent.md): its axial membrane
law is soft, nearly linear to a few per cent and stiffer in tension (the ridges
straighten) than in compression (they fold); its hoop bending stiffness and yield moment
are those of the ridged wall section, ~50 x the flat wall's; its wall hardly bends along
the axis.  The law here works on the shell's resultants directly, per unit length of the
mid-surface, in the material frame (axis 1 along the tube, 2 around it):

    N11 = k_e (eps11 - eps11_p),  N11 <= H_t(alpha_ax) in tension, -N11 <= H_c(alpha_ax)
    N22 = k_h eps22,  N12 = k_s gamma12
    M11 = D_x kappa11,  M12 = D_x kappa12 / 2
    M22 = D_h (kappa22 - kappa22_p),  |M22| <= H_h(alpha_h)
    Q   = kGt gamma_z

The flow curves ``H`` are piecewise-linear tables of (accumulated plastic strain, flow
resultant), derived from the ridged cell of the tensile stage and from the ridged wall
section (:mod:`harnesspipe.models.tube_equivalent`), so that monotonic loading follows
them exactly (to their linear interpolation); beyond the last point the last slope
continues.  ``alpha_ax`` accumulates the axial plastic strain of either sign (one
isotropic history for both curves), ``alpha_h`` the hoop plastic curvature.  The axial
and the hoop laws are uncoupled (no N11-M22 interaction in the yield condition).

Material row (``MAT_TUBE`` rows of the shell material table, width ``ROW_WIDTH``): the
scalars ``W_*``, index 5 the shell's material kind
(:data:`harnesspipe.fe.elements.shell_bt_element.MAT_KIND`), then the three tables
(``TAB_TENSION``, ``TAB_COMPRESSION``, ``TAB_HOOP``), each ``N_TAB`` abscissae alpha
followed by ``N_TAB`` flow values.
"""
from __future__ import annotations

from numba import njit

# row layout: scalars
W_KE, W_DH, W_DX, W_KH, W_KS = 0, 1, 2, 3, 4   # axial unloading stiffness k_e, D_h, D_x, k_h, k_s
W_KGT = 6                                       # kappa G t (index 5 is the shell's material kind)
N_TAB = 25                                      # points per flow table
TAB_TENSION, TAB_COMPRESSION, TAB_HOOP = 8, 8 + 2 * N_TAB, 8 + 4 * N_TAB
ROW_WIDTH = 8 + 6 * N_TAB

# state layout (per element, inside the shell's thickness-point block)
T_EPS = 0       # total membrane strain, element frame (3)
T_KAP = 3       # total curvature, element frame (3)
T_N = 6         # membrane resultants, element frame (3)
T_M = 9         # moment resultants, element frame (3)
T_EP = 12       # axial plastic strain eps11_p
T_AX = 13       # accumulated axial plastic strain alpha_ax
T_KP = 14       # hoop plastic curvature kappa22_p
T_AH = 15       # accumulated hoop plastic curvature alpha_h
T_SIZE = 16


@njit(cache=True, inline="always")
def to_material(a, b, g, c, s):
    """Strain-like triple (a11, a22, engineering a12) from the element frame to the
    material frame whose axis 1 is at (cos, sin) = (c, s) in the element frame."""
    return (c * c * a + s * s * b + c * s * g,
            s * s * a + c * c * b - c * s * g,
            2.0 * c * s * (b - a) + (c * c - s * s) * g)


@njit(cache=True, inline="always")
def to_element(n11, n22, n12, c, s):
    """Resultant (tensor) triple from the material frame back to the element frame."""
    return (c * c * n11 + s * s * n22 - 2.0 * c * s * n12,
            s * s * n11 + c * c * n22 + 2.0 * c * s * n12,
            c * s * (n11 - n22) + (c * c - s * s) * n12)


@njit(cache=True, inline="always")
def table_return(q, k, alpha, row, o):
    """Plastic increment d >= 0 of a 1D return onto the piecewise-linear flow table at
    ``row[o:o + 2 N_TAB]`` (abscissae alpha_j, then flow values H_j): solves
    ``q - k d = H(alpha + d)`` for the trial magnitude ``q`` and the unloading stiffness
    ``k``, segment by segment from the one holding ``alpha`` (exact on each; the last
    segment extends beyond the table).  ``d = 0`` when ``q <= H(alpha)``."""
    j = 0
    while j < N_TAB - 2 and row[o + j + 1] <= alpha:
        j += 1
    while True:
        a0, a1 = row[o + j], row[o + j + 1]
        h0, h1 = row[o + N_TAB + j], row[o + N_TAB + j + 1]
        slope = (h1 - h0) / (a1 - a0)
        f = q - h0 - slope * (alpha - a0)
        if f <= 0.0:
            return 0.0
        d = f / (k + slope)
        if j == N_TAB - 2 or alpha + d <= a1:
            return d
        j += 1


@njit(cache=True, inline="always")
def table_update(x, x_p, alpha, k, row, o_pos, o_neg):
    """1D elastoplastic resultant ``k (x - x_p)`` with the flow table at ``o_pos`` for
    positive and at ``o_neg`` for negative values (magnitudes) and one accumulated plastic
    history ``alpha``; returns ``(value, x_p_new, alpha_new, d_alpha)``."""
    trial = k * (x - x_p)
    if trial >= 0.0:
        d = table_return(trial, k, alpha, row, o_pos)
        x_p += d
    else:
        d = table_return(-trial, k, alpha, row, o_neg)
        x_p -= d
    return k * (x - x_p), x_p, alpha + d, d


@njit(cache=True, inline="always")
def tube_wall_resultants(st, me, c, s, dt, d_m, kappa):
    """Advance the resultants of one element over ``dt`` with the membrane strain rates
    ``d_m`` and curvature rates ``kappa`` (element frame, engineering shears) in the state
    block ``st`` (T_SIZE,); material axis 1 at ``(c, s)``.  Returns the new ``N``, ``M``
    (element frame), the stress power per unit area (mid-step resultants, times dt: the
    work of the step) and the plastic work per unit area of the step."""
    w = 0.0
    for i in range(3):
        w += 0.5 * dt * (st[T_N + i] * d_m[i] + st[T_M + i] * kappa[i])
        st[T_EPS + i] += dt * d_m[i]
        st[T_KAP + i] += dt * kappa[i]
    e11, e22, g12 = to_material(st[T_EPS], st[T_EPS + 1], st[T_EPS + 2], c, s)
    k11, k22, k12 = to_material(st[T_KAP], st[T_KAP + 1], st[T_KAP + 2], c, s)
    n11, st[T_EP], st[T_AX], da = table_update(e11, st[T_EP], st[T_AX], me[W_KE], me,
                                               TAB_TENSION, TAB_COMPRESSION)
    m22, st[T_KP], st[T_AH], dh = table_update(k22, st[T_KP], st[T_AH], me[W_DH], me,
                                               TAB_HOOP, TAB_HOOP)
    wp = abs(n11) * da + abs(m22) * dh
    N = to_element(n11, me[W_KH] * e22, me[W_KS] * g12, c, s)
    M = to_element(me[W_DX] * k11, m22, 0.5 * me[W_DX] * k12, c, s)
    for i in range(3):
        st[T_N + i] = N[i]
        st[T_M + i] = M[i]
        w += 0.5 * dt * (N[i] * d_m[i] + M[i] * kappa[i])
    return N, M, w, wp
