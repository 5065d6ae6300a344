"""Finite-rotation kernels against Rodrigues' formula and finite differences."""
import numpy as np
import pytest

import harnesspipe  # noqa: F401  (sets the Numba cache first)
from harnesspipe.fe import rotation as rot


def rodrigues(theta):
    a = np.linalg.norm(theta)
    S = np.array([[0, -theta[2], theta[1]], [theta[2], 0, -theta[0]], [-theta[1], theta[0], 0]])
    if a == 0:
        return np.eye(3)
    return np.eye(3) + np.sin(a) / a * S + (1 - np.cos(a)) / a**2 * S @ S


def matrix(theta):
    q = np.zeros(4)
    rot.quat_from_rotvec(np.asarray(theta, float), q)
    R = np.zeros((3, 3))
    rot.quat_to_matrix(q, R)
    return R


VECTORS = [np.array([0.3, -1.2, 0.8]), np.array([1e-7, 2e-7, -1e-7]), np.array([0.0, 0.0, 3.0]),
           np.array([0.02, -0.01, 0.03])]


@pytest.mark.parametrize("theta", VECTORS)
def test_exp_map_is_rodrigues_and_log_inverts_it(theta):
    R = matrix(theta)
    assert np.allclose(R, rodrigues(theta), atol=1e-14)
    back = np.zeros(3)
    rot.log_matrix(R, back, np.zeros(4))
    assert np.allclose(back, theta, atol=1e-12)


def test_quaternion_product_composes_rotations():
    a, b = VECTORS[0], np.array([-0.5, 0.4, 2.0])
    qa, qb, qab = np.zeros(4), np.zeros(4), np.zeros(4)
    rot.quat_from_rotvec(a, qa)
    rot.quat_from_rotvec(b, qb)
    rot.quat_mul(qa, qb, qab)
    R = np.zeros((3, 3))
    rot.quat_to_matrix(qab, R)
    assert np.allclose(R, rodrigues(a) @ rodrigues(b), atol=1e-14)


def test_spatial_update_left_multiplies():
    q = np.zeros(4)
    rot.quat_from_rotvec(VECTORS[0], q)
    dw = np.array([0.1, 0.2, -0.3])
    rot.rotate_spatial(q, dw, np.zeros(4))
    R = np.zeros((3, 3))
    rot.quat_to_matrix(q, R)
    assert np.allclose(R, rodrigues(dw) @ rodrigues(VECTORS[0]), atol=1e-14)



def test_drift_of_the_nodes_is_the_spatial_update_bit_for_bit():
    """move_nodes (the hi-fi drift, scalar arithmetic) = x += du and rotate_nodes, exactly,
    for spins on both sides of the series threshold; nodes past n_rot keep their rotation."""
    rng = np.random.default_rng(3)
    n, n_rot = 9, 6
    x = rng.standard_normal((n, 3))
    quat = rng.standard_normal((n, 4))
    quat /= np.linalg.norm(quat, axis=1)[:, None]
    du = rng.standard_normal((n, 6))
    du[:3, 3:] *= 1e-6              # below SMALL_ANGLE: the series branch
    x1, q1 = x.copy(), quat.copy()
    rot.move_nodes(x1, q1, du, n_rot)
    q2 = quat.copy()
    rot.rotate_nodes(q2[:n_rot], np.ascontiguousarray(du[:n_rot, 3:]))
    assert np.array_equal(x1, x + du[:, :3])
    assert np.array_equal(q1, q2)
    assert np.allclose(np.linalg.norm(q1, axis=1), 1.0, atol=1e-15)

@pytest.mark.parametrize("theta", VECTORS)
def test_tangent_operator_maps_dtheta_to_spatial_spin(theta):
    Ts, Ti = np.zeros((3, 3)), np.zeros((3, 3))
    rot.ts(theta, Ts)
    rot.ts_inv(theta, Ti)
    assert np.allclose(Ts @ Ti, np.eye(3), atol=1e-13)
    h = 1e-6
    R = rodrigues(theta)
    for j in range(3):
        d = np.zeros(3)
        d[j] = h
        W = (rodrigues(theta + d) - rodrigues(theta - d)) / (2 * h) @ R.T  # = S(Ts e_j)
        assert np.allclose([W[2, 1], W[0, 2], W[1, 0]], Ts[:, j], atol=1e-8)


@pytest.mark.parametrize("theta", [np.array([0.3, -0.5, 0.4]), np.array([0.01, 0.02, -0.015]),
                                   np.array([1.5, 0.5, -1.0])])
def test_kh_is_derivative_of_ts_inv_transpose(theta):
    v = np.array([1.0, 2.0, -0.5])
    Ti, H = np.zeros((3, 3)), np.zeros((3, 3))
    rot.ts_inv(theta, Ti)
    rot.kh_matrix(theta, v, Ti, np.zeros((3, 3)), H)

    def g(t):
        T = np.zeros((3, 3))
        rot.ts_inv(t, T)
        return T.T @ v

    h = 1e-6
    J = np.column_stack([(g(theta + h * e) - g(theta - h * e)) / (2 * h) for e in np.eye(3)])
    assert np.allclose(J @ Ti, H, atol=1e-8)


def test_series_branch_is_continuous():
    # across the small-angle switch the operators must not jump
    e = np.array([0.6, -0.48, 0.64])
    v = np.array([0.3, 1.0, -2.0])
    out = []
    for a in (rot.SERIES_ANGLE * (1 - 1e-9), rot.SERIES_ANGLE * (1 + 1e-9)):
        Ti, H = np.zeros((3, 3)), np.zeros((3, 3))
        rot.ts_inv(a * e, Ti)
        rot.kh_matrix(a * e, v, Ti, np.zeros((3, 3)), H)
        out.append(np.concatenate((Ti.ravel(), H.ravel())))
    assert np.allclose(out[0], out[1], atol=1e-10)
