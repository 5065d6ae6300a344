"""Newton-Raphson path following on small problems with known solutions."""
import numpy as np
import pytest

import harnesspipe  # noqa: F401
from harnesspipe.fe.solvers.static import (ConvergenceError, NewtonSettings, band_lu_solve,
                                           constrain_band, follow_path)


class Springs:
    """Two unknowns u, one equation each: r_i = c_i atan(u_i) + u_i^3 - lam F_i (band width 0).

    A second problem variant has no solution beyond lam * F > c * pi / 2 (atan only).
    """

    bandwidth = 0

    def __init__(self, F, c=(1.0, 2.0), cubic=True):
        self.F, self.c, self.cubic = np.asarray(F, float), np.asarray(c, float), cubic
        self.u = np.zeros(2)
        self.u_c = np.zeros(2)
        self.lam = 0.0
        self.evaluations = 0

    def set_load(self, lam):
        self.lam = lam

    def evaluate(self, want_tangent):
        self.evaluations += 1
        u = self.u
        r = self.c * np.arctan(u) + (u**3 if self.cubic else 0.0) - self.lam * self.F
        with np.errstate(over="ignore"):
            band = np.array([self.c / (1 + u**2) + (3 * u**2 if self.cubic else 0.0)])
        constrain_band(band, r, np.zeros(0, dtype=np.int64), 0)
        return r, max(np.linalg.norm(self.lam * self.F), 1e-12), band

    def update(self, du):
        self.u += du

    def commit(self):
        self.u_c[:] = self.u

    def revert(self):
        self.u[:] = self.u_c

    def describe(self, lam):
        return f"force factor {lam:.4g}"


def test_path_reaches_equilibrium_at_every_stop():
    p = Springs(F=[30.0, -50.0])
    seen = []
    follow_path(p, np.linspace(0, 1, 5)[1:], on_stop=lambda lam: seen.append((lam, p.u.copy())))
    for lam, u in seen:
        assert np.allclose(p.c * np.arctan(u) + u**3, lam * p.F, rtol=1e-9)
    assert [s[0] for s in seen] == pytest.approx([0.25, 0.5, 0.75, 1.0])


def _to_band(K, bw):
    n = K.shape[0]
    band = np.zeros((2 * bw + 1, n))
    for i in range(n):
        for j in range(max(0, i - bw), min(n, i + bw + 1)):
            band[bw + i - j, j] = K[i, j]
    return band


@pytest.mark.parametrize("n, bw", [(1, 0), (7, 1), (40, 3), (60, 11)])
def test_band_lu_solve_matches_dense_solve(n, bw):
    """Nonsymmetric band matrices whose diagonal is small or zero: the pivoting must
    interchange rows (and fill in above the band) to solve them."""
    rng = np.random.default_rng(n + bw)
    K = np.zeros((n, n))
    for i in range(n):
        for j in range(max(0, i - bw), min(n, i + bw + 1)):
            K[i, j] = rng.normal()
    K[np.arange(n), np.arange(n)] *= 1e-3
    if n > 1:
        K[0, 0] = 0.0
    r = rng.normal(size=n)
    band = _to_band(K, bw)
    du = np.empty(n)
    ok = band_lu_solve(band, r, bw, np.empty((n, 3 * bw + 1)), np.empty(n, dtype=np.int64),
                       np.empty(n), du)
    assert ok
    assert np.allclose(K @ du, -r, atol=1e-9 * np.abs(r).max() * np.linalg.cond(K))
    assert np.array_equal(band, _to_band(K, bw))          # the input is left alone


def test_band_lu_solve_reports_a_singular_matrix():
    K = np.diag([1.0, 2.0, 3.0])
    K[1, 1] = 0.0                                         # a zero column: no pivot
    du = np.empty(3)
    assert not band_lu_solve(_to_band(K, 1), np.ones(3), 1, np.empty((3, 4)),
                             np.empty(3, dtype=np.int64), np.empty(3), du)


def test_constrained_dofs_stay_put():
    band = np.array([[0.0, 5.0, 6.0], [2.0, 3.0, 4.0], [7.0, 8.0, 0.0]])
    r = np.array([1.0, 2.0, 3.0])
    constrain_band(band, r, np.array([1]), 1)
    assert r.tolist() == [1.0, 0.0, 3.0]
    assert band[1, 1] == 1.0 and band[0, 1] == 0.0 and band[2, 0] == 0.0 and band[0, 2] == 0.0


def test_unreachable_load_raises_convergence_error_with_diagnostics():
    p = Springs(F=[2.0, 0.0], c=(1.0, 1.0), cubic=False)  # atan(u) = 2 lam: none beyond lam = pi/4
    with pytest.raises(ConvergenceError) as info:
        follow_path(p, np.linspace(0, 1, 11)[1:], NewtonSettings(max_iter=12))
    err = info.value
    msg = str(err)
    assert isinstance(err, RuntimeError)
    assert f"increment {err.increment}" in msg and err.increment >= 8
    last = float(err.last_converged.split()[-1])
    assert f"last converged state: {err.last_converged}" in msg
    assert 0.7 <= last <= np.pi / 4  # substeps got as close to the limit as the step allows
    assert np.arctan(p.u_c[0]) == pytest.approx(2 * last, rel=1e-3)
    assert "towards force factor 0.7" in msg  # the failed target lies between 0.7 and 0.8
    assert len(err.residuals) >= 2 and f"{err.residuals[0]:.3e}" in msg
