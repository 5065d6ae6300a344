"""Fibre section quadrature and the eq. 2 J2 fibre law."""
import numpy as np
import pytest

import harnesspipe  # noqa: F401
from harnesspipe.fe.materials.fiber import (FibreHistory, FibreMaterial, FibreSection, disc_fibres,
                                            fibre_update, section_response)
from harnesspipe.fe.materials.hardening import flow_stress


@pytest.mark.parametrize("n_rings,n_sectors", [(2, 3), (4, 12), (7, 20)])
def test_disc_quadrature_is_exact_for_area_and_inertia(n_rings, n_sectors):
    r = 7.05
    y, z, A = disc_fibres(r, n_rings, n_sectors)
    assert A.sum() == pytest.approx(np.pi * r**2, rel=1e-13)
    assert (A * y**2).sum() == pytest.approx(np.pi * r**4 / 4, rel=1e-13)
    assert (A * z**2).sum() == pytest.approx(np.pi * r**4 / 4, rel=1e-13)
    assert abs((A * y).sum()) < 1e-10 and abs((A * y * z).sum()) < 1e-8


@pytest.mark.parametrize("n", [0.3, 1.0, 2.0])
def test_fibre_stress_lies_on_eq2_flow_curve(n):
    E, sigma_y, K = 1000.0, 5.0, 80.0
    for eps in (0.02, -0.05):
        sig, Et, eps_p, alpha = fibre_update(eps, 0.0, 0.0, E, sigma_y, K, n, False)
        assert abs(sig) == pytest.approx(flow_stress(alpha, sigma_y, K, n), rel=1e-10)
        assert sig == pytest.approx(E * (eps - eps_p), rel=1e-12)
        assert np.sign(sig) == np.sign(eps) and alpha == pytest.approx(abs(eps_p))


def test_fibre_unloads_elastically_and_reloads_on_the_hardened_curve():
    """Loaded to 3 %, unloaded to 2.9 % (elastic), reloaded from there: elastic up to the
    strain where the stress meets the flow stress reached before (no new yield at 2.99 %),
    then on the eq. 2 curve past it (3.5 %: more plastic strain, the stress the flow stress
    of the larger alpha)."""
    E, sigma_y, K, n = 1000.0, 5.0, 80.0, 0.5
    sig1, _, ep, al = fibre_update(0.03, 0.0, 0.0, E, sigma_y, K, n, False)
    sig, Et, ep2, al2 = fibre_update(0.029, ep, al, E, sigma_y, K, n, False)
    assert Et == E and ep2 == ep and al2 == al and sig == pytest.approx(E * (0.029 - ep))
    sig, Et, ep3, al3 = fibre_update(0.0299, ep2, al2, E, sigma_y, K, n, False)
    assert Et == E and ep3 == ep and al3 == al and sig < sig1
    sig, Et, ep4, al4 = fibre_update(0.035, ep3, al3, E, sigma_y, K, n, False)
    assert al4 > al and ep4 > ep and Et < E
    assert sig == pytest.approx(flow_stress(al4, sigma_y, K, n), rel=1e-10)
    assert sig == pytest.approx(E * (0.035 - ep4), rel=1e-12)


@pytest.mark.parametrize("n", [0.12, 0.83, 1.0, 1.5])
@pytest.mark.parametrize("eps_p_old", [0.0, 1e-3])
def test_fibre_tangent_matches_finite_difference(n, eps_p_old):
    E, sigma_y, K = 1559.0, 8.6, 25.6
    eps = eps_p_old + sigma_y / E * 3.0
    h = 1e-9
    _, Et, _, _ = fibre_update(eps, eps_p_old, eps_p_old, E, sigma_y, K, n, False)
    sp = fibre_update(eps + h, eps_p_old, eps_p_old, E, sigma_y, K, n, False)[0]
    sm = fibre_update(eps - h, eps_p_old, eps_p_old, E, sigma_y, K, n, False)[0]
    assert Et == pytest.approx((sp - sm) / (2 * h), rel=1e-4)


def test_section_reaches_the_plastic_moment_of_a_disc():
    # perfectly plastic fibres at a large curvature: M -> M_p = 4/3 sigma_Y r^3
    r, sigma_y, E = 7.05, 2.0, 1e4
    y, z, A = disc_fibres(r, 12, 48)
    s, D = np.zeros(3), np.zeros((3, 3))
    nf = y.size
    kappa = 2000 * sigma_y / (E * r)
    hist = FibreHistory(*(np.zeros((1, nf)) for _ in range(4)))
    section_response(0.0, 0.0, kappa, FibreSection(y, z, A, 0.0), FibreMaterial(E, sigma_y, 0.0, 1.0),
                     False, hist, 0, s, D)
    assert s[2] == pytest.approx(4.0 / 3.0 * sigma_y * r**3, rel=2e-3)
    assert abs(s[0]) < 1e-9 * sigma_y * r**2


def test_section_tangent_matches_finite_difference():
    r, E, sigma_y, K, n = 7.05, 15.7, 0.6, 1.59, 0.3
    y, z, A = disc_fibres(r, 4, 12)
    nf = y.size
    sec, mat = FibreSection(y, z, A, 0.0), FibreMaterial(E, sigma_y, K, n)
    hist = FibreHistory(*(np.zeros((1, nf)) for _ in range(4)))
    e = np.array([1e-3, 0.004, -0.006])
    s, D = np.zeros(3), np.zeros((3, 3))
    section_response(*e, sec, mat, False, hist, 0, s, D)
    h = 1e-8
    for j in range(3):
        sp, sm = np.zeros(3), np.zeros(3)
        section_response(*(e + h * np.eye(3)[j]), sec, mat, False, hist, 0, sp, np.zeros((3, 3)))
        section_response(*(e - h * np.eye(3)[j]), sec, mat, False, hist, 0, sm, np.zeros((3, 3)))
        assert np.allclose(D[:, j], (sp - sm) / (2 * h), rtol=1e-5, atol=1e-6 * np.abs(D).max())


@pytest.mark.parametrize("n", [0.12, 0.3, 0.9, 1.0, 1.5, 2.0])
@pytest.mark.parametrize("alpha_old", [0.0, 1e-9, 1e-3, 0.2])
def test_return_map_solves_eq2_and_gives_the_slope(n, alpha_old):
    from harnesspipe.fe.materials.hardening import hardening_slope, return_map
    c, sigma_y, K = 1559.0, 8.6, 25.6
    for over in (1e-9, 1e-4, 1e-2, 0.5, 10.0):
        q = flow_stress(alpha_old, sigma_y, K, n) * (1.0 + over)
        dg, H = return_map(q, c, alpha_old, sigma_y, K, n)
        assert dg > 0.0
        assert q - c * dg == pytest.approx(flow_stress(alpha_old + dg, sigma_y, K, n), rel=1e-11)
        assert H == pytest.approx(hardening_slope(alpha_old + dg, K, n), rel=1e-9)
    assert return_map(0.999 * flow_stress(alpha_old, sigma_y, K, n), c, alpha_old,
                      sigma_y, K, n)[0] == 0.0
