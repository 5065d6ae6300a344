"""Branch-joint FE core: eq. 14 stiffnesses and the implicit Newmark integrator of the branch ROM."""
import math

import numpy as np
import pytest

from harnesspipe.fe.elements.bushing import bushing_stiffness
from harnesspipe.fe.solvers.newmark import DynamicConvergenceError, integrate, time_grid


def test_bushing_stiffness_by_hand():
    # E = 20 MPa, G = 8 MPa, r = 5 mm, l = 30 mm: lambda = 6, lambda l = 180 mm
    # A = 78.5398, I = 490.874, J = 981.748
    k = bushing_stiffness(E=20.0, G=8.0, r=5.0, l=30.0)
    np.testing.assert_allclose(k, [20 * 78.5398 / 180, 8 * 78.5398 / 180, 8 * 78.5398 / 180,
                                   8 * 981.748 / 180, 20 * 490.874 / 180, 20 * 490.874 / 180], rtol=1e-5)
    with pytest.raises(ValueError, match="must be > 0"):
        bushing_stiffness(E=20.0, G=8.0, r=0.0, l=30.0)


class Oscillator:
    """One dof under ``m u'' + k (u + alpha u') = r t``, as an integrator problem: the load
    and the Kelvin-Voigt rate (from the integrator's Newmark relations) inside ``f_int``."""
    ndof, bandwidth, fixed = 1, 0, np.zeros(0, dtype=np.int64)

    def __init__(self, m, k, r, alpha=0.0, tangent=None):
        self.mass, self.k, self.r, self.alpha = np.array([m]), k, r, alpha
        self.tangent = tangent
        self.u = self.u_n = self.v_n = self.a_n = 0.0
        self.t, self.rates, self.reverted = 0.0, None, 0

    def begin_step(self, t, rates):
        self.t, self.rates = t, rates
        return np.zeros(1)

    def _rate(self):
        c = self.rates
        du = self.u - self.u_n
        return (c.c_d * du + c.c_v * self.v_n + c.c_a * self.a_n,
                c.a_d * du + c.a_v * self.v_n + c.a_a * self.a_n)

    def evaluate(self):
        v, _ = self._rate()
        f = self.k * (self.u + self.alpha * v) - self.r * self.t
        dfdu = self.k * (1.0 + self.alpha * self.rates.c_d)
        return np.array([f]), np.array([[dfdu if self.tangent is None else self.tangent]])

    def update(self, du):
        self.u += du[0]

    def commit(self):
        self.v_n, self.a_n = self._rate()
        self.u_n = self.u

    def revert(self):
        self.u, self.reverted = self.u_n, self.reverted + 1


def run(problem, times):
    u = [0.0]
    integrate(problem, times, on_step=lambda t: u.append(problem.u), force_floor=1e-6)
    return np.array(u)


def test_newmark_forced_undamped_oscillator_has_second_order_phase_error():
    """m u'' + k u = r t from rest: u = (r/k) (t - sin(w t) / w).  The average-acceleration
    rule adds no damping and errs in phase by (w dt)^2 / 12 per radian: the error
    after five periods is within that bound and falls by 4 when dt halves."""
    m, k, r = 1.0, (2 * math.pi) ** 2, 3.0
    w = math.sqrt(k / m)
    errors = []
    for n in (1000, 2000):
        t = np.linspace(0.0, 5.0, n + 1)
        u = run(Oscillator(m, k, r), t)
        exact = (r / k) * (t - np.sin(w * t) / w)
        errors.append(np.max(np.abs(u - exact)))
        phase_bound = w * t[-1] * (w * (t[1] - t[0])) ** 2 / 12.0
        assert errors[-1] <= 1.1 * (r / (k * w)) * phase_bound
    assert errors[0] / errors[1] == pytest.approx(4.0, rel=0.05)


def test_damped_connector_under_force_ramp_matches_kelvin_voigt():
    """k u + alpha k u' = r t (negligible mass): u = (r/k) [t - alpha (1 - exp(-t/alpha))]."""
    k, alpha, r = 50.0, 0.2, 3.0
    t = time_grid(2.0, 400, 1e-4)
    u = run(Oscillator(1e-8 * k * alpha**2, k, r, alpha), t)
    exact = (r / k) * (t - alpha * (1.0 - np.exp(-t / alpha)))
    assert np.max(np.abs(u - exact)) < 1e-3 * exact[-1]


def test_non_convergence_reports_step_and_residuals():
    """A wrong tangent: Newton cannot converge; the error names the step's time, the
    residual history and the last converged time, and the problem is reverted."""
    problem = Oscillator(1.0, 100.0, 5.0, tangent=-399.0)   # + m / (beta dt^2) = 400
    with pytest.raises(DynamicConvergenceError,
                       match=r"t = 0.1 s.*relative residuals.*last converged time 0 s"):
        integrate(problem, np.array([0.0, 0.1, 0.2]))
    assert problem.reverted == 1 and problem.u == 0.0
