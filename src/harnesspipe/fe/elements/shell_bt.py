"""Belytschko-Lin-Tsay (BLT) shell for explicit dynamics: 4 nodes, 6 DOFs per node,
one-point in-plane quadrature, co-rotational rate formulation (Belytschko, Lin & Tsay 1984;
Belytschko, Liu & Moran, ch. 9.6).

Here: the element loops (parallel over chunks of elements, serial for small meshes) writing
forces per element to ``f_el`` and a serial scatter that ADDS them to the global ``f_int``
(shared with beams); the lumped mass (translational ``rho h A / 4``, scaled rotary), the
stable step ``dt = L / c`` (``L = A / max diagonal``, plate wave speed), the initial state
and the energy totals.  The element itself, with the state layout, is
:mod:`harnesspipe.fe.elements.shell_bt_element`.

Theory, the step estimate's checks and the limitations (no warping correction, no drilling
stiffness, the one-point twist mechanism, elastic shear and hourglass): docs/theory/shell_blt.md.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from harnesspipe.fe.loops import loop_kernel
from harnesspipe.fe.materials.tube_wall import W_KE, W_KH, W_KS

from harnesspipe.fe.elements.shell_bt_element import (  # noqa: F401 -- layout re-exported
    MAT_J2, MAT_KIND, MAT_ORTHOTROPIC, MAT_TUBE, N_STATE, N_THICKNESS, PT_EPS, PT_MAT, PT_SA, PT_SIG,
    PT_SIZE, S_GXZ, S_GYZ, S_HG, S_MCOS, S_MSIN, S_THICK, S_W_HG, S_W_INT, S_W_PLASTIC,
    SHEAR_CORRECTION, ZETA, ZETA_W, element_forces, frame, work_arrays)

HOURGLASS_COEF = 0.1
CHUNK = 32   # elements per parallel task (scratch is allocated once per task)
PARALLEL_MIN = 128   # below this many elements shell_forces runs the serial kernel


@njit(cache=True)
def shell_range_forces(lo, hi, x, v, conn, thick, mat, state, dt, f_el, hg):
    """Element forces of elements ``lo..hi-1`` into ``f_el`` (arguments as
    :func:`shell_element_forces`); scratch is allocated once per call."""
    _element_loop(lo, hi, x, v, conn, thick, mat, state, dt, f_el, hg, work_arrays())


@loop_kernel
def _element_loop(lo, hi, x, v, conn, thick, mat, state, dt, f_el, hg, work):
    """:func:`shell_range_forces` with its scratch ``work`` (a :class:`Work`)."""
    for e in range(lo, hi):
        element_forces(e, x, v, conn, thick, mat, state, dt, hg, f_el, work)


@njit(cache=True, parallel=True)
def shell_element_forces(x, v, conn, thick, mat, state, dt, f_el, hg=HOURGLASS_COEF):
    """Element forces (global components) of all shells into ``f_el`` (n_el, 4, 6);
    updates ``state`` (n_el, N_STATE) in place.  Parallel over chunks of ``CHUNK``
    elements (:func:`shell_range_forces`)."""
    n_el = conn.shape[0]
    n_chunks = (n_el + CHUNK - 1) // CHUNK
    for c in prange(n_chunks):
        shell_range_forces(c * CHUNK, min(n_el, (c + 1) * CHUNK), x, v, conn, thick, mat, state,
                           dt, f_el, hg)


@njit(cache=True)
def shell_element_forces_serial(x, v, conn, thick, mat, state, dt, f_el, hg=HOURGLASS_COEF):
    """Serial twin of :func:`shell_element_forces` (small meshes: no thread launch)."""
    shell_range_forces(0, conn.shape[0], x, v, conn, thick, mat, state, dt, f_el, hg)


@njit(cache=True)
def scatter_add(conn, f_el, f_int, sign=1.0):
    """f_int[conn[e, a]] += sign f_el[e, a] (serial, ADDS)."""
    for e in range(conn.shape[0]):
        for a in range(4):
            nd = conn[e, a]
            for i in range(6):
                f_int[nd, i] += sign * f_el[e, a, i]


def shell_forces(x, v, conn, thick, mat, state, dt, f_el, f_int, hg=HOURGLASS_COEF, sign=1.0):
    """One BLT internal-force evaluation: stress update over ``dt`` with the half-step
    velocities ``v`` (n_nodes, 6) at positions ``x`` (n_nodes, 3), element forces into
    ``f_el`` (n_el, 4, 6) and ``sign`` x them ADDED to ``f_int`` (n_nodes, 6) (1: the
    resisting force, -1: the force ON the nodes).  Nodes not in ``conn`` are not touched.
    Meshes with fewer than ``PARALLEL_MIN`` elements run serially (a thread launch costs
    more than they do).

    A Python function on purpose: a cached ``njit`` function that calls a ``parallel=True``
    kernel which was itself loaded from Numba's cache when the caller compiled is cached
    broken, and the next process that loads it crashes (Numba 0.68; tests/test_numba_cache.py
    replays the sequence).  The dispatch costs a few microseconds a step."""
    if conn.shape[0] < PARALLEL_MIN:
        shell_element_forces_serial(x, v, conn, thick, mat, state, dt, f_el, hg)
    else:
        shell_element_forces(x, v, conn, thick, mat, state, dt, f_el, hg)
    scatter_add(conn, f_el, f_int, sign)


@njit(cache=True)
def _area_diag(x, i0, i1, i2, i3):
    """(area, longer diagonal) of the quad i0-i1-i2-i3: the area half the norm of the
    diagonals' cross product."""
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
def wave_speed2(me, rho, h):
    """c^2 = max(D11, D22) / rho (plane-stress plate wave speed); for a tube-wall row
    (resultants) the largest membrane stiffness over the mass per area, max(k_e, k_h,
    k_s) / (rho h)."""
    if me.shape[0] > MAT_KIND and me[MAT_KIND] == MAT_TUBE:
        return max(me[W_KE], me[W_KH], me[W_KS]) / (rho * h)
    if me.shape[0] > MAT_KIND and me[MAT_KIND] == MAT_ORTHOTROPIC:
        nu21 = me[2] * me[1] / me[0]
        return max(me[0], me[1]) / (1.0 - me[2] * nu21) / rho
    return me[0] / (1.0 - me[1] * me[1]) / rho


def wave_speeds2(mat, rho, thick) -> np.ndarray:
    """:func:`wave_speed2` of every row of ``mat`` (n_el, k) with ``rho``, ``thick`` (n_el,)."""
    mat = np.ascontiguousarray(mat, dtype=float)
    return np.array([wave_speed2(mat[e], float(rho[e]), float(thick[e]))
                     for e in range(mat.shape[0])])


@njit(cache=True)
def shell_stable_step(x, conn, thick, mat, rho):
    """min_e L_e / c_e with L = A / max diagonal, c = sqrt(max(D11, D22) / rho).
    No safety factor applied.  ``rho`` (n_el,)."""
    dt = np.inf
    for e in range(conn.shape[0]):
        area, dmax = _area_diag(x, conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3])
        d = (area / dmax) / np.sqrt(wave_speed2(mat[e], rho[e], thick[e]))
        if d < dt:
            dt = d
    return dt


@njit(cache=True)
def _init_state(X, conn, thick, axes_ref, state):
    """Each element's state row at rest: no stress or strain, its thickness, and the material
    axis ``axes_ref`` expressed in the element's corotational frame."""
    ef = np.empty((3, 3))
    for e in range(conn.shape[0]):
        state[e, :] = 0.0
        state[e, S_THICK] = thick[e]
        frame(X, conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3], ef)
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


def uniaxial_prestrain(mat, elements, sigma_1) -> tuple[np.ndarray, np.ndarray]:
    """The eigenstrain ``(e11, e22) = (sigma_1 / E, -nu sigma_1 / E)`` of material axes 1, 2
    that holds the J2 (isotropic, elastic) ``elements`` at the uniaxial stress ``sigma_1``
    along axis 1 (plane-stress Hooke of it is ``(sigma_1, 0, 0)``): a tape wrapped under
    tension, whose natural length is shorter than its mesh.  ``sigma_1`` must stay below
    the elements' yield stress (wrapped elastically)."""
    elements = np.asarray(elements, dtype=np.int64)
    if np.any(mat[elements, MAT_KIND] != MAT_J2) or np.any(sigma_1 >= mat[elements, 2]):
        raise ValueError(f"prestress {sigma_1:g} MPa: expected J2 elements below their yield stress")
    E, nu = mat[elements, 0], mat[elements, 1]
    return sigma_1 / E, -nu * sigma_1 / E


@njit(cache=True)
def add_prestrain(state, elements, e11, e22, fraction):
    """Add ``fraction`` of the material-axes strain ``(e11[i], e22[i], 0)`` to the total
    strain of element ``elements[i]`` at every thickness point, rotated into the element
    frame (axis 1 at ``(S_MCOS, S_MSIN)``: ``eps_xx = e11 c^2 + e22 s^2``, ``eps_yy = e11
    s^2 + e22 c^2``, ``gamma_xy = 2 (e11 - e22) c s``).  The next stress update turns it
    into stress (the total-strain state); raised by fractions over time it is a prestress
    applied smoothly, at once (``fraction`` 1 before the first step) a sudden one."""
    for i in range(elements.size):
        e = elements[i]
        c, s = state[e, S_MCOS], state[e, S_MSIN]
        a, b = fraction * e11[i], fraction * e22[i]
        exx = a * c * c + b * s * s
        eyy = a * s * s + b * c * c
        gxy = 2.0 * (a - b) * c * s
        for k in range(N_THICKNESS):
            o = k * PT_SIZE + PT_EPS
            state[e, o] += exx
            state[e, o + 1] += eyy
            state[e, o + 2] += gxy


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
    """The corotational frame of every element at ``x`` into ``out`` (n_elements, 3, 3)."""
    for e in range(conn.shape[0]):
        frame(x, conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3], out[e])
