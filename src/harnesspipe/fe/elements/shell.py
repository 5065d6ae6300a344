"""A mesh of four-node finite-strain shells (6 DOFs per node: ux, uy, uz and spins about
x, y, z): internal force and element tangents assembled over the mesh, nodal rotation
update, thickness update, lumped mass and nodal directors, and :class:`Shell`, the mesh
with its configuration and history as a :class:`harnesspipe.fe.solvers.static_dense.System`.

The element (total Lagrangian degenerated shell, Hencky strain with J2 or eq. 12
orthotropic plane stress, MITC4 transverse shear, drilling penalty, central-difference
tangent) is :mod:`harnesspipe.fe.elements.shell_element`.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from harnesspipe.fe.elements.shell_element import (DRILL_FACTOR, MAT_J2, MAT_ORTHOTROPIC,
                                                   N_THICKNESS, drilling, element_force,
                                                   element_tangent, material_axes,
                                                   reference_element, rotation_matrix,
                                                   shear_modulus, work_arrays)
from harnesspipe.fe.materials.plane_stress import EPS33, STATE_SIZE, fabric_shear_modulus

DOF_PER_NODE = 6


@njit(cache=True)
def _buffers():
    """Scratch of :func:`_element_contributions`, allocated once per assembly."""
    return (np.empty((4, 3)), np.empty((4, 3)), np.empty((4, 3)), np.empty((4, 6)),
            np.empty((24, 24)), np.empty((4, 6)), np.empty((4, 6)), np.empty((4, 3)),
            np.empty((4, 3)),
            np.empty((4, 3)), np.empty(3), np.empty(24, dtype=np.bool_), np.empty((4, 24)),
            np.empty(4), np.empty(4), np.empty(4), np.empty(3), np.empty(3), np.empty(3),
            np.empty((4, 3)), np.empty((4 * N_THICKNESS, STATE_SIZE)), work_arrays())


@njit(cache=True)
def _gather(e, conn, x, Q, D, T0, xe, de, se):
    """Element nodes, directors Q_a D_a and drilling vectors Q_a T0_a."""
    for a in range(4):
        node = conn[e, a]
        for i in range(3):
            xe[a, i] = x[node, i]
            de[a, i] = Q[node, i, 0] * D[node, 0] + Q[node, i, 1] * D[node, 1] + Q[node, i, 2] * D[node, 2]
            se[a, i] = (Q[node, i, 0] * T0[e, a, 0] + Q[node, i, 1] * T0[e, a, 1]
                        + Q[node, i, 2] * T0[e, a, 2])


@njit(cache=True)
def _element_contributions(e, conn, x, Q, D, T0, Jinv, dV, shear_ref, Jc, area, h0, h, mat,
                           axes, state_old, state_new, active, buf):
    """Force (buf[3]) and tangent (buf[4]) of element ``e`` incl. the drilling penalty."""
    (xe, de, se, fe, ke, fp, fm, xp, dp, sp_, axis, act, grad, omega, om_p, om_m,
     w3a, w3b, w3c, w43, scratch, work) = buf
    _gather(e, conn, x, Q, D, T0, xe, de, se)
    for a in range(4):
        for i in range(6):
            act[6 * a + i] = active[6 * conn[e, a] + i]
    element_force(xe, de, Jinv[e], dV[e], shear_ref[e], h0, h[e], mat, axes[e], state_old[e],
                  state_new[e], fe, work)
    element_tangent(xe, de, Jinv[e], dV[e], shear_ref[e], h0, h[e], mat, axes[e], state_old[e],
                    scratch, act, ke, fp, fm, xp, dp, axis, work)
    k_d = DRILL_FACTOR * shear_modulus(mat) * h0 * area[e]
    drilling(xe, de, se, Jc[e], k_d, fe, ke, grad, omega, om_p, om_m, xp, dp, sp_, axis,
             w3a, w3b, w3c, w43)


@njit(cache=True)
def assemble(conn, x, Q, D, T0, Jinv, dV, shear_ref, Jc, area, h0, h, mat, axes, state_old,
             state_new, active, f, kdata):
    """Internal force ``f`` and element tangents ``kdata`` (n_el, 576) in the order of
    :func:`tangent_pattern`.  ``x`` (n_nodes, 3) current nodes, ``Q`` (n_nodes, 3, 3)
    nodal rotations, ``D`` (n_nodes, 3) reference directors, ``T0`` (n_el, 4, 3),
    reference data per element, ``axes`` (n_el, 4, 5, 2) material axes,
    ``active`` (6 n_nodes,) DOFs that may move."""
    buf = _buffers()
    fe, ke = buf[3], buf[4]
    f[:] = 0.0
    for e in range(conn.shape[0]):
        _element_contributions(e, conn, x, Q, D, T0, Jinv, dV, shear_ref, Jc, area, h0, h,
                               mat, axes, state_old, state_new, active, buf)
        for a in range(4):
            for i in range(6):
                f[6 * conn[e, a] + i] += fe[a, i]
        for i in range(24):
            for j in range(24):
                kdata[e, 24 * i + j] = ke[i, j]


@njit(cache=True)
def internal_force(conn, x, Q, D, T0, Jinv, dV, shear_ref, Jc, area, h0, h, mat, axes, state_old,
                   state_new, f):
    """Internal force only (explicit dynamics): as :func:`assemble` without tangents.
    The drilling penalty force is included through its difference gradient."""
    buf = _buffers()
    (xe, de, se, fe, ke, fp, fm, xp, dp, sp_, axis, act, grad, omega, om_p, om_m,
     w3a, w3b, w3c, w43, scratch, work) = buf
    f[:] = 0.0
    for e in range(conn.shape[0]):
        _gather(e, conn, x, Q, D, T0, xe, de, se)
        element_force(xe, de, Jinv[e], dV[e], shear_ref[e], h0, h[e], mat, axes[e], state_old[e],
                      state_new[e], fe, work)
        k_d = DRILL_FACTOR * shear_modulus(mat) * h0 * area[e]
        drilling(xe, de, se, Jc[e], k_d, fe, ke, grad, omega, om_p, om_m, xp, dp, sp_, axis,
                 w3a, w3b, w3c, w43)
        for a in range(4):
            for i in range(6):
                f[6 * conn[e, a] + i] += fe[a, i]


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
        assemble(self.conn, self.x, self.Q, self.D, self.T0, self.Jinv, self.dV, self.shear_ref,
                 self.Jc, self.area, self.h0, self.h, self.mat, self.axes, self.state, self._trial,
                 self.active, self._f, self._kdata)
        K = self._sp.coo_matrix((self._kdata.ravel(), (self._rows, self._cols)),
                                shape=(self.n_dof, self.n_dof)).tocsr()
        if self.contact is not None:
            K = K + self._contact(self._f)
        return K, self._f

    def internal_force(self):
        """Internal force at the trial configuration, without tangent (explicit use)."""
        internal_force(self.conn, self.x, self.Q, self.D, self.T0, self.Jinv, self.dV,
                       self.shear_ref, self.Jc, self.area, self.h0, self.h, self.mat, self.axes,
                       self.state, self._trial, self._f)
        return self._f

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
