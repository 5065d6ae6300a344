"""Branch-joint FE core: eq. 14 stiffnesses, eq. 15 damping, Newmark integration."""
import math

import numpy as np
import pytest

from harnesspipe.fe.connector import bushing_stiffness, connector_force
from harnesspipe.fe.newmark import DynamicConvergenceError, newmark


def test_bushing_stiffness_by_hand():
    # E = 20 MPa, G = 8 MPa, r = 5 mm, l = 30 mm: lambda = 6, lambda l = 180 mm
    # A = 78.5398, I = 490.874, J = 981.748
    k = bushing_stiffness(E=20.0, G=8.0, r=5.0, l=30.0)
    np.testing.assert_allclose(k, [20 * 78.5398 / 180, 8 * 78.5398 / 180, 8 * 78.5398 / 180,
                                   8 * 981.748 / 180, 20 * 490.874 / 180, 20 * 490.874 / 180], rtol=1e-5)
    with pytest.raises(ValueError, match="must be > 0"):
        bushing_stiffness(E=20.0, G=8.0, r=0.0, l=30.0)


def test_connector_force_is_kelvin_voigt():
    k = np.arange(1.0, 7.0)
    d, d_dot, f = np.full(6, 0.1), np.full(6, 2.0), np.zeros(6)
    connector_force(d, d_dot, k, 0.2, f)
    np.testing.assert_allclose(f, k * (0.1 + 0.2 * 2.0))


def oscillator(k, alpha=0.0):
    K = np.array([[k]])
    return lambda u, v: (K @ (u + alpha * v), K, alpha * K)


def test_newmark_conserves_energy_of_undamped_oscillator():
    k, m = (2 * math.pi) ** 2, 1.0   # period 1 s
    t, U, V, _ = newmark(np.array([[m]]), oscillator(k), lambda t: np.zeros(1),
                         np.array([1.0]), np.array([0.0]), dt=0.02, n_steps=2000)
    energy = 0.5 * m * V[:, 0] ** 2 + 0.5 * k * U[:, 0] ** 2
    assert np.max(np.abs(energy / energy[0] - 1.0)) < 1e-10
    # period error of the trapezoidal rule: (omega dt)^2 / 12 = 1.3e-3
    crossings = t[1:][np.diff(np.sign(U[:, 0])) > 0]
    assert np.mean(np.diff(crossings)) == pytest.approx(1.0, rel=3e-3)


def test_damped_connector_under_force_ramp_matches_kelvin_voigt():
    """k u + alpha k u' = r t (negligible mass): u = (r/k) [t - alpha (1 - exp(-t/alpha))]."""
    k, alpha, r = 50.0, 0.2, 3.0
    m = 1e-8 * k * alpha**2
    t, U, _, _ = newmark(np.array([[m]]), oscillator(k, alpha), lambda t: np.array([r * t]),
                         np.zeros(1), np.zeros(1), dt=1e-3, n_steps=2000)
    exact = (r / k) * (t - alpha * (1.0 - np.exp(-t / alpha)))
    assert np.max(np.abs(U[:, 0] - exact)) < 1e-3 * exact[-1]


def test_non_convergence_reports_step_and_residuals():
    def bad(u, v):  # an oscillating force with a wrong tangent: Newton cannot converge
        return np.array([1e3 * np.sin(50.0 * u[0]) + 10.0 * u[0]]), np.array([[-1.0]]), np.zeros((1, 1))
    with pytest.raises(DynamicConvergenceError,
                       match=r"Newmark step 1 \(t = 0.1 s\).*relative residuals.*last converged time 0 s"):
        newmark(1e-6 * np.eye(1), bad, lambda t: np.array([5.0 * t]), np.zeros(1), np.zeros(1), 0.1, 3)
