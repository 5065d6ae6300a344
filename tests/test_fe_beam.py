"""Co-rotational fibre beam: consistent tangent, rigid-body invariance, mass."""
import numpy as np
import pytest

import harnesspipe  # noqa: F401
from harnesspipe.fe import rotation
from harnesspipe.fe.elements import beam
from harnesspipe.fe.materials.fiber import disc_fibres

E, SIGMA_Y, K, N = 100.0, 1.0, 10.0, 0.5
GJ = 50.0


class Element:
    """One element between (0,0,0) and (10,0,0) with its own history arrays."""

    def __init__(self):
        self.X = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
        self.conn = np.array([[0, 1]])
        self.R0 = beam.initial_frames(self.X, self.conn)
        self.y, self.z, self.A = disc_fibres(2.0, 3, 8)
        self.xi, self.w = beam.lobatto_points(3)
        shape = (1, self.xi.size, self.y.size)
        self.hist = [np.zeros((2,) + shape) for _ in range(2)]     # committed, trial
        self.bw = beam.band_width(self.conn)

    def force_tangent(self, u, quat, elastic):
        f = np.zeros(12)
        band = np.zeros((2 * self.bw + 1, 12))
        beam.assemble_beams(beam.BeamMesh(self.X, self.conn, self.R0, self.xi, self.w), u, quat,
                            beam.FibreSection(self.y, self.z, self.A, GJ),
                            beam.FibreMaterial(E, SIGMA_Y, K, N), elastic, *self.hist, True, f,
                            band, self.bw)
        Kd = np.zeros((12, 12))
        for j in range(12):
            for i in range(max(0, j - self.bw), min(12, j + self.bw + 1)):
                Kd[i, j] = band[self.bw + i - j, j]
        return f, Kd


def quats(*rotvecs):
    q = np.zeros((len(rotvecs), 4))
    for i, t in enumerate(rotvecs):
        rotation.quat_from_rotvec(np.asarray(t, float), q[i])
    return q


def perturbed(u, quat, j, h):
    u, quat = u.copy(), quat.copy()
    node, k = divmod(j, 6)
    if k < 3:
        u[node, k] += h
    else:
        dw = np.zeros(3)
        dw[k - 3] = h
        rotation.rotate_spatial(quat[node], dw, np.zeros(4))
    return u, quat


STATES = {
    # large rigid 3D rotation of the whole element plus a moderate deformation
    "large-3d": (np.array([[0.3, -0.5, 0.2], [-1.0, 2.0, 1.5]]), quats([0.4, -0.9, 1.2], [0.7, -0.5, 1.6])),
    "small": (np.array([[0.0, 0.0, 0.0], [0.01, 0.05, -0.02]]), quats([0.0, 0.01, 0.0], [0.002, -0.01, 0.02])),
}


@pytest.mark.parametrize("state", STATES)
@pytest.mark.parametrize("elastic", [True, False])
def test_tangent_matches_central_differences_of_internal_force(state, elastic):
    el = Element()
    u, quat = STATES[state]
    f, Kd = el.force_tangent(u, quat, elastic)
    h = 1e-6
    Kfd = np.column_stack([
        (el.force_tangent(*perturbed(u, quat, j, h), elastic)[0]
         - el.force_tangent(*perturbed(u, quat, j, -h), elastic)[0]) / (2 * h) for j in range(12)])
    assert np.abs(Kd - Kfd).max() <= 1e-6 * np.abs(Kfd).max()


def test_rigid_body_motion_gives_no_force():
    el = Element()
    Rq = quats([1.1, -0.7, 2.3])
    R = np.zeros((3, 3))
    rotation.quat_to_matrix(Rq[0], R)
    shift = np.array([3.0, -2.0, 5.0])
    u = (el.X @ R.T + shift) - el.X
    f, _ = el.force_tangent(u, np.vstack((Rq, Rq)), elastic=False)
    assert np.abs(f).max() < 1e-9


def test_small_displacement_stiffness_is_the_linear_beam_matrix():
    el = Element()
    _, Kd = el.force_tangent(np.zeros((2, 3)), quats([0, 0, 0], [0, 0, 0]), elastic=True)
    L, EA, EI = 10.0, E * np.pi * 4.0, E * np.pi * 2.0**4 / 4
    assert Kd[0, 0] == pytest.approx(EA / L, rel=1e-12)
    assert Kd[1, 1] == pytest.approx(12 * EI / L**3, rel=1e-12)
    assert Kd[5, 5] == pytest.approx(4 * EI / L, rel=1e-12)
    assert Kd[5, 11] == pytest.approx(2 * EI / L, rel=1e-12)
    assert Kd[3, 3] == pytest.approx(GJ / L, rel=1e-12)


def test_mass_matrices_carry_the_element_mass():
    l0, rho, A, Ip = 5.0, 1.3e-9, 156.0, 3900.0
    lumped = np.zeros(12)
    beam.element_mass_lumped(l0, rho, A, Ip, Ip / 2, Ip / 2, lumped)
    R = np.zeros((3, 3))
    rotation.quat_to_matrix(quats([0.3, 1.0, -0.4])[0], R)
    M = np.zeros((12, 12))
    beam.element_mass_consistent(l0, rho, A, Ip, R, M, np.zeros((12, 12)))
    m = rho * A * l0
    h = 0.5 * rho * l0                                    # each node holds half the slice
    np.testing.assert_allclose(lumped, h * np.tile([A, A, A, Ip, Ip / 2, Ip / 2], 2), rtol=1e-15)
    for direction in np.eye(3):  # a rigid translation carries the whole mass
        v = np.concatenate((direction, np.zeros(3), direction, np.zeros(3)))
        assert v @ M @ v == pytest.approx(m, rel=1e-12)
    assert np.allclose(M, M.T) and np.linalg.eigvalsh(M).min() > -1e-20
