"""Plane-stress kernels against closed forms: uniaxial J2 response, yield
consistency, sigma_33 = 0, consistent tangent vs finite differences, eq. 12."""
import numpy as np
import pytest
from scipy.optimize import brentq

import harnesspipe  # noqa: F401  (sets the Numba cache)
from harnesspipe.fe.materials.hardening import flow_stress
from harnesspipe.fe.materials.plane_stress import (EPS33, EPS_BAR_P, STATE_SIZE, J2Material,
                                                   fabric_shear_modulus, j2_plane_stress,
                                                   orthotropic_plane_stress_stiffness)

# closed plastic tube, Table 2 (n < 1), and a hardening exponent above 1
MATERIALS = [(1559.0, 0.42, 8.6, 25.6, 0.12), (93.5, 0.4, 10.0, 30.8, 0.60),
             (698.0, 0.42, 8.8, 23.1, 1.3)]


def update(eps, state, mat):
    sig, D = np.zeros(3), np.zeros((3, 3))
    new = np.zeros(STATE_SIZE)
    j2_plane_stress(np.asarray(eps, float), state, J2Material(*mat), sig, D, new, np.zeros(4),
                    np.zeros((4, 4)))
    return sig, D, new


def uniaxial_closed_form(eps11, E, nu, sigma_y, K, n):
    """1D J2: stress, and lateral strain -nu*sigma/E - eps_p/2 (plastic incompressibility)."""
    if E * eps11 <= sigma_y:
        sigma, eps_p = E * eps11, 0.0
    else:
        eps_p = brentq(lambda ep: E * (eps11 - ep) - flow_stress(ep, sigma_y, K, n), 0.0, eps11)
        sigma = E * (eps11 - eps_p)
    return sigma, -nu * sigma / E - 0.5 * eps_p


@pytest.mark.parametrize("mat", MATERIALS)
def test_uniaxial_stress_path_matches_1d_j2(mat):
    E, nu = mat[0], mat[1]
    state = np.zeros(STATE_SIZE)
    eps22 = 0.0
    for eps11 in np.linspace(0.0, 0.3, 61)[1:]:
        for _ in range(30):  # sigma_22 = 0 by Newton on eps_22
            sig, D, new = update([eps11, eps22, 0.0], state, mat)
            if abs(sig[1]) < 1e-10 * E:
                break
            eps22 -= sig[1] / D[1, 1]
        state = new
        sigma, lateral = uniaxial_closed_form(eps11, *mat)
        assert sig[0] == pytest.approx(sigma, rel=1e-8)
        assert eps22 == pytest.approx(lateral, rel=1e-7, abs=1e-12)
        assert state[EPS33] == pytest.approx(lateral, rel=1e-7, abs=1e-12)


@pytest.mark.parametrize("mat", MATERIALS)
def test_return_is_on_yield_surface_with_zero_sigma33(mat):
    rng = np.random.default_rng(1)
    state = np.zeros(STATE_SIZE)
    state[:4] = [0.01, -0.004, -0.006, 0.002]
    state[EPS_BAR_P] = 0.015
    for _ in range(20):
        eps = state[[0, 1, 3]] * [1, 1, 2] + rng.normal(scale=0.05, size=3)
        sig, D, new = update(eps, state, mat)
        if new[EPS_BAR_P] == state[EPS_BAR_P]:
            continue
        s11, s22, s12 = sig
        q = np.sqrt(s11**2 + s22**2 - s11 * s22 + 3 * s12**2)  # von Mises with sigma_33 = 0
        assert q == pytest.approx(flow_stress(new[EPS_BAR_P], *mat[2:]), rel=1e-9)
        # eps_33 closes the elastic law with sigma_33 = 0: eps33_e = -nu/E (s11 + s22)
        eps33_e = new[EPS33] - new[2]
        assert eps33_e == pytest.approx(-mat[1] / mat[0] * (s11 + s22), rel=1e-7, abs=1e-13)
        # plastic incompressibility
        assert new[0] + new[1] + new[2] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("mat", MATERIALS)
def test_consistent_tangent_matches_finite_differences(mat):
    rng = np.random.default_rng(2)
    state = np.zeros(STATE_SIZE)
    state[:4] = [0.004, -0.003, -0.001, 0.001]
    state[EPS_BAR_P] = 0.006
    h = 1e-7
    for _ in range(10):
        eps = rng.normal(scale=0.03, size=3)
        sig, D, _ = update(eps, state, mat)
        D_fd = np.zeros((3, 3))
        for j in range(3):
            e = np.zeros(3)
            e[j] = h
            D_fd[:, j] = (update(eps + e, state, mat)[0] - update(eps - e, state, mat)[0]) / (2 * h)
        assert np.allclose(D, D_fd, rtol=1e-5, atol=1e-6 * mat[0])


def test_orthotropic_stiffness_inverts_eq12_compliance():
    E1, nu12 = 93.5, 0.4
    E2 = 0.6 * E1
    G12 = fabric_shear_modulus(E1, E2, nu12)
    assert G12 == pytest.approx(0.5 * (E1 + E2) / (2 * (1 + nu12)))
    S = np.array([[1 / E1, -nu12 / E1, 0], [-nu12 / E1, 1 / E2, 0], [0, 0, 1 / G12]])
    D = np.zeros((3, 3))
    orthotropic_plane_stress_stiffness(E1, E2, nu12, G12, D)
    assert np.allclose(D @ S, np.eye(3), atol=1e-12)
    assert np.allclose(D, D.T)


def test_fabric_law_with_yarn_buckling_stores_and_returns_energy():
    """With the yarns' compression factor r_c the eq. 12 stress is the gradient of a strain
    energy: the work around a closed strain loop through tension and compression of both
    yarn directions vanishes (a stress cut at zero with the full Poisson coupling does not:
    its tangent is not symmetric, and explicit runs gained energy from it)."""
    from harnesspipe.fe.materials.plane_stress import orthotropic_plane_stress
    E1, E2, nu12, G12, r_c = 93.5, 40.0, 0.4, 25.0, 0.05
    D = np.zeros((3, 3))
    orthotropic_plane_stress_stiffness(E1, E2, nu12 * r_c, G12, D)
    c, s = np.cos(0.4), np.sin(0.4)
    theta = np.linspace(0.0, 2.0 * np.pi, 20001)
    path = np.column_stack([0.02 * np.cos(theta), 0.015 * np.sin(theta + 0.7),
                            0.01 * np.sin(2 * theta)])
    sig = np.zeros((theta.size, 3))
    for i, e in enumerate(path):
        orthotropic_plane_stress(e, c, s, D, r_c, sig[i])
    work = np.sum(0.5 * (sig[1:] + sig[:-1]) * np.diff(path, axis=0))
    scale = np.sum(np.abs(0.5 * (sig[1:] + sig[:-1]) * np.diff(path, axis=0)))
    assert abs(work) < 1e-6 * scale
    one = np.zeros(3)
    orthotropic_plane_stress(np.array([-0.01, 0.0, 0.0]), 1.0, 0.0, D, r_c, one)
    assert one[0] == pytest.approx(r_c * D[0, 0] * -0.01)       # a buckling warp yarn
    orthotropic_plane_stress(np.array([0.01, 0.0, 0.0]), 1.0, 0.0, D, r_c, one)
    assert one[0] == pytest.approx(D[0, 0] * 0.01)               # a stretched one: eq. 12
