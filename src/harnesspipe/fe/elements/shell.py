"""A mesh of four-node finite-strain shells (6 DOFs per node: ux, uy, uz and spins about
x, y, z): internal force and element tangents assembled over the mesh, nodal rotation
update, thickness update, lumped mass and nodal directors, and :class:`Shell`, the mesh
with its configuration and history as a :class:`harnesspipe.fe.solvers.static_dense.System`.

The element (total Lagrangian degenerated shell, Hencky strain with J2 or eq. 12
orthotropic plane stress, MITC4 transverse shear, drilling penalty, central-difference
tangent) is :mod:`harnesspipe.fe.elements.shell_element`.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from harnesspipe.fe.elements.shell_element import (DRILL_FACTOR, MAT_J2, MAT_ORTHOTROPIC,
                                                   N_THICKNESS, DrillWork, ElementRef,
                                                   Perturbed, drill_arrays,
                                                   drilling, element_force, element_tangent,
                                                   material_axes, perturbed_arrays,
                                                   reference_element, rotation_matrix,
                                                   shear_modulus, work_arrays)
from harnesspipe.fe.materials.plane_stress import EPS33, STATE_SIZE, fabric_shear_modulus

DOF_PER_NODE = 6


class ShellMesh(NamedTuple):
    """The mesh and its reference data: ``conn`` (n_el, 4), reference directors ``D``
    (n_nodes, 3), per element the drilling vectors ``T0`` (n_el, 4, 3), the data of
    :func:`reference_element` (``Jinv``, ``dV``, ``shear_ref``, centre Jacobian ``Jc``,
    ``area``) and :func:`material_axes`' ``axes`` (n_el, 4, 5, 2); the thickness ``h0``
    and the material row ``mat`` (see :func:`shell_element.element_force`)."""
    conn: np.ndarray
    D: np.ndarray
    T0: np.ndarray
    Jinv: np.ndarray
    dV: np.ndarray
    shear_ref: np.ndarray
    Jc: np.ndarray
    area: np.ndarray
    axes: np.ndarray
    h0: float
    mat: np.ndarray


class Configuration(NamedTuple):
    """The current configuration: nodes ``x`` (n_nodes, 3), nodal rotations ``Q``
    (n_nodes, 3, 3) and element thicknesses ``h`` (n_el,)."""
    x: np.ndarray
    Q: np.ndarray
    h: np.ndarray


class Scratch(NamedTuple):
    """Scratch of one element, allocated once per assembly: its nodes, directors and
    drilling vectors (4, 3), force (4, 6), tangent (24, 24), active DOFs (24,), and the
    groups of :mod:`harnesspipe.fe.elements.shell_element`."""
    xe: np.ndarray
    de: np.ndarray
    se: np.ndarray
    fe: np.ndarray
    ke: np.ndarray
    act: np.ndarray
    pert: Perturbed
    drill: DrillWork
    work: tuple


@njit(cache=True)
def _scratch():
    """A :class:`Scratch`."""
    return Scratch(np.empty((4, 3)), np.empty((4, 3)), np.empty((4, 3)), np.empty((4, 6)),
                   np.empty((24, 24)), np.empty(24, dtype=np.bool_), perturbed_arrays(),
                   drill_arrays(), work_arrays())


@njit(cache=True)
def _gather(e, mesh, cfg, xe, de, se):
    """Element nodes, directors Q_a D_a and drilling vectors Q_a T0_a."""
    conn, D, T0 = mesh.conn, mesh.D, mesh.T0
    x, Q = cfg.x, cfg.Q
    for a in range(4):
        node = conn[e, a]
        for i in range(3):
            xe[a, i] = x[node, i]
            de[a, i] = Q[node, i, 0] * D[node, 0] + Q[node, i, 1] * D[node, 1] + Q[node, i, 2] * D[node, 2]
            se[a, i] = (Q[node, i, 0] * T0[e, a, 0] + Q[node, i, 1] * T0[e, a, 1]
                        + Q[node, i, 2] * T0[e, a, 2])


@njit(cache=True)
def _element_ref(e, mesh):
    """The :class:`ElementRef` of element ``e`` (views into the mesh's arrays)."""
    return ElementRef(mesh.Jinv[e], mesh.dV[e], mesh.shear_ref[e], mesh.axes[e], mesh.h0,
                      mesh.mat)


@njit(cache=True)
def _drill_stiffness(e, mesh):
    """The drilling penalty k_d = DRILL_FACTOR G h0 A of element ``e``."""
    return DRILL_FACTOR * shear_modulus(mesh.mat) * mesh.h0 * mesh.area[e]


@njit(cache=True)
def _element_contributions(e, mesh, cfg, state_old, state_new, active, buf):
    """Force (``buf.fe``) and tangent (``buf.ke``) of element ``e`` incl. the drilling
    penalty."""
    _gather(e, mesh, cfg, buf.xe, buf.de, buf.se)
    for a in range(4):
        for i in range(6):
            buf.act[6 * a + i] = active[6 * mesh.conn[e, a] + i]
    ref = _element_ref(e, mesh)
    element_force(buf.xe, buf.de, ref, cfg.h[e], state_old[e], state_new[e], buf.fe, buf.work)
    element_tangent(buf.xe, buf.de, ref, cfg.h[e], state_old[e], buf.act, buf.ke, buf.pert,
                    buf.work)
    drilling(buf.xe, buf.de, buf.se, mesh.Jc[e], _drill_stiffness(e, mesh), buf.fe, buf.ke,
             buf.pert, buf.drill)


@njit(cache=True)
def assemble(mesh, cfg, state_old, state_new, active, f, kdata):
    """Internal force ``f`` and element tangents ``kdata`` (n_el, 576) in the order of
    :func:`tangent_pattern`, for the :class:`ShellMesh` in the :class:`Configuration`
    ``cfg``; ``state_old`` the committed and ``state_new`` the trial histories,
    ``active`` (6 n_nodes,) DOFs that may move."""
    buf = _scratch()
    f[:] = 0.0
    conn = mesh.conn
    for e in range(conn.shape[0]):
        _element_contributions(e, mesh, cfg, state_old, state_new, active, buf)
        for a in range(4):
            for i in range(6):
                f[6 * conn[e, a] + i] += buf.fe[a, i]
        for i in range(24):
            for j in range(24):
                kdata[e, 24 * i + j] = buf.ke[i, j]


@njit(cache=True)
def internal_force(mesh, cfg, state_old, state_new, f):
    """Internal force only (explicit dynamics): as :func:`assemble` without tangents.
    The drilling penalty force is included through its difference gradient."""
    buf = _scratch()
    f[:] = 0.0
    conn = mesh.conn
    for e in range(conn.shape[0]):
        _gather(e, mesh, cfg, buf.xe, buf.de, buf.se)
        element_force(buf.xe, buf.de, _element_ref(e, mesh), cfg.h[e], state_old[e],
                      state_new[e], buf.fe, buf.work)
        drilling(buf.xe, buf.de, buf.se, mesh.Jc[e], _drill_stiffness(e, mesh), buf.fe, buf.ke,
                 buf.pert, buf.drill)
        for a in range(4):
            for i in range(6):
                f[6 * conn[e, a] + i] += buf.fe[a, i]


def tangent_pattern(conn):
    """Global (row, col) of every entry of ``kdata`` from :func:`assemble`."""
    dofs = (DOF_PER_NODE * np.asarray(conn)[:, :, None] + np.arange(DOF_PER_NODE)).reshape(-1, 24)
    rows = np.repeat(dofs, 24, axis=1).ravel()
    cols = np.tile(dofs, (1, 24)).ravel()
    return rows, cols


@njit(cache=True)
def update_rotations(Q, dtheta):
    """Q_a <- exp(dtheta_a) Q_a for every node (``dtheta`` (n_nodes, 3) spins)."""
    R = np.empty((3, 3))
    for a in range(Q.shape[0]):
        rotation_matrix(dtheta[a], R)
        Q[a] = R @ Q[a]


@njit(cache=True)
def updated_thickness(h0, state):
    """Element thickness h0 exp(mean eps_33 of its Gauss points)."""
    h = np.empty(state.shape[0])
    for e in range(state.shape[0]):
        h[e] = h0 * np.exp(np.mean(state[e, :, EPS33]))
    return h


def lumped_mass(X, conn, h0, rho):
    """Row-sum lumped mass per DOF (6 per node): rho h0 A / 4 on translations and
    rho h0^3 / 12 A / 4 on rotations, A the element area (diagonal of quadrilaterals)."""
    X = np.asarray(X, float)
    m = np.zeros(DOF_PER_NODE * X.shape[0])
    for nodes in np.asarray(conn):
        p = X[nodes]
        A = 0.5 * np.linalg.norm(np.cross(p[2] - p[0], p[3] - p[1]))
        for node in nodes:
            m[6 * node:6 * node + 3] += rho * h0 * A / 4.0
            m[6 * node + 3:6 * node + 6] += rho * h0**3 / 12.0 * A / 4.0
    return m


def nodal_normals(X, conn):
    """Unit nodal directors: normalised sum of the normals of the adjacent elements."""
    X = np.asarray(X, float)
    D = np.zeros_like(X)
    for nodes in np.asarray(conn):
        p = X[nodes]
        normal = np.cross(p[2] - p[0], p[3] - p[1])
        D[nodes] += normal / np.linalg.norm(normal)
    return D / np.linalg.norm(D, axis=1)[:, None]


class Shell:
    """A mesh of 4-node shells with its configuration and history, as a
    :class:`harnesspipe.fe.solvers.static_dense.System` (DOFs ux, uy, uz, spin x, y, z).

    ``hold(dofs)`` marks DOFs that never move (their tangent columns are skipped);
    ``contact`` = (nodes, axis, stiffness): penalty keeping x[nodes, axis] >= 0
    (a rigid plane, used for a mirror-symmetric self-contact).

    Material: J2 with eq. 2 hardening from (E, nu, sigma_y, K, n), or, with
    ``orthotropic=(E1, E2, nu12[, G12])`` (and E ... n omitted), the eq. 12
    orthotropic elastic law; G12 defaults to the paper's
    ``fabric_shear_modulus(E1, E2, nu12)``.  ``axis``: material direction 1, a
    3-vector for all elements or an (n_el, 3) array, projected onto the shell's
    tangent plane; default (None) the local x axis of each element (direction of
    its first natural coordinate xi at the centre).  See also :meth:`orthotropic`.
    """

    def __init__(self, X, conn, h0, E=None, nu=None, sigma_y=None, K=None, n=None, directors=None,
                 contact=None, *, orthotropic=None, axis=None):
        import scipy.sparse as sp  # local: the kernels above do not need it

        self._sp = sp
        self.X = np.ascontiguousarray(X, dtype=float)
        self.conn = np.ascontiguousarray(conn, dtype=np.int64)
        self.h0 = float(h0)
        if orthotropic is None:
            if None in (E, nu, sigma_y, K, n):
                raise ValueError("J2 material needs E, nu, sigma_y, K, n")
            self.mat = np.array([E, nu, sigma_y, K, n, MAT_J2], dtype=float)
        else:
            if any(v is not None for v in (E, nu, sigma_y, K, n)):
                raise ValueError("give either the J2 constants or orthotropic=(E1, E2, nu12[, G12])")
            E1, E2, nu12 = (float(v) for v in orthotropic[:3])
            G12 = float(orthotropic[3]) if len(orthotropic) > 3 else fabric_shear_modulus(E1, E2, nu12)
            if min(E1, E2, G12) <= 0.0 or nu12 * nu12 * E2 / E1 >= 1.0:
                raise ValueError("eq. 12 compliance is not positive definite")
            self.mat = np.array([E1, E2, nu12, G12, 0.0, MAT_ORTHOTROPIC], dtype=float)
        n_nodes, n_el = self.X.shape[0], self.conn.shape[0]
        self.D = np.ascontiguousarray(nodal_normals(X, conn) if directors is None else directors,
                                      dtype=float)
        self.Jinv = np.empty((n_el, 4, N_THICKNESS, 3, 3))
        self.dV = np.empty((n_el, 4, N_THICKNESS))
        self.shear_ref = np.empty((n_el, 4))
        self.Jc = np.empty((n_el, 3, 3))
        self.T0 = np.empty((n_el, 4, 3))
        self.area = np.empty(n_el)
        for e, nodes in enumerate(self.conn):
            self.area[e] = reference_element(self.X[nodes], self.D[nodes], self.h0, self.Jinv[e],
                                             self.dV[e], self.shear_ref[e], self.Jc[e], self.T0[e])
        a1 = np.zeros((n_el, 3)) if axis is None else np.broadcast_to(
            np.asarray(axis, dtype=float), (n_el, 3))
        self.axes = np.empty((n_el, 4, N_THICKNESS, 2))
        for e, nodes in enumerate(self.conn):
            material_axes(self.X[nodes], self.D[nodes], self.h0, np.array(a1[e], dtype=float),
                          self.axes[e])
        self.mesh = ShellMesh(self.conn, self.D, self.T0, self.Jinv, self.dV, self.shear_ref,
                              self.Jc, self.area, self.axes, self.h0, self.mat)
        self.n_dof = DOF_PER_NODE * n_nodes
        self.active = np.ones(self.n_dof, dtype=np.bool_)
        self.contact = contact
        self.x = self.X.copy()
        self.Q = np.tile(np.eye(3), (n_nodes, 1, 1))
        self.h = np.full(n_el, self.h0)
        self.state = np.zeros((n_el, 4 * N_THICKNESS, STATE_SIZE))
        self._trial = self.state.copy()
        self._saved = (self.x.copy(), self.Q.copy())
        self._rows, self._cols = tangent_pattern(self.conn)
        self._f = np.zeros(self.n_dof)
        self._kdata = np.zeros((n_el, 576))

    @classmethod
    def orthotropic(cls, X, conn, h0, E1, E2, nu12, G12=None, axis=None, directors=None,
                    contact=None):
        """Shell of the eq. 12 orthotropic elastic material (G12 default: Sec. 4.2.2 rule)."""
        props = (E1, E2, nu12) if G12 is None else (E1, E2, nu12, G12)
        return cls(X, conn, h0, directors=directors, contact=contact, orthotropic=props, axis=axis)

    @property
    def u(self):
        """Nodal displacements (n_nodes, 3)."""
        return self.x - self.X

    def directors(self):
        """Current nodal directors Q_a D_a."""
        return np.einsum("aij,aj->ai", self.Q, self.D)

    def hold(self, dofs):
        self.active[np.asarray(dofs, dtype=np.int64)] = False

    def tangent_and_force(self):
        assemble(self.mesh, self._configuration(), self.state, self._trial, self.active, self._f,
                 self._kdata)
        K = self._sp.coo_matrix((self._kdata.ravel(), (self._rows, self._cols)),
                                shape=(self.n_dof, self.n_dof)).tocsr()
        if self.contact is not None:
            K = K + self._contact(self._f)
        return K, self._f

    def internal_force(self):
        """Internal force at the trial configuration, without tangent (explicit use)."""
        internal_force(self.mesh, self._configuration(), self.state, self._trial, self._f)
        return self._f

    def _configuration(self):
        return Configuration(self.x, self.Q, self.h)

    def _contact(self, f):
        nodes, axis, k = self.contact
        gap = self.x[nodes, axis]
        closed = gap < 0.0
        dofs = DOF_PER_NODE * np.asarray(nodes)[closed] + axis
        f[dofs] += k * gap[closed]
        diag = np.zeros(self.n_dof)
        diag[dofs] = k
        return self._sp.diags(diag)

    def advance(self, du):
        du = du.reshape(-1, DOF_PER_NODE)
        self.x += du[:, :3]
        update_rotations(self.Q, np.ascontiguousarray(du[:, 3:]))

    def accept(self):
        self.state[...] = self._trial
        self.h = updated_thickness(self.h0, self.state)
        self._saved = (self.x.copy(), self.Q.copy())

    def reject(self):
        self.x[...], self.Q[...] = self._saved
