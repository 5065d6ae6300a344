"""Nelder-Mead driver: paper's initial simplex, recovery, logging and resume."""
import numpy as np
import pytest

from harnesspipe.calibrate.objective import l2_error
from harnesspipe.calibrate.simplex import initial_simplex, nelder_mead


def test_initial_simplex_adds_five_percent_per_component():
    s = initial_simplex(np.array([1559.0, 8.6, 25.6, 0.12]))
    assert s.shape == (5, 4)
    np.testing.assert_allclose(s[0], [1559.0, 8.6, 25.6, 0.12])
    for i in range(4):
        expected = s[0].copy()
        expected[i] *= 1.05
        np.testing.assert_allclose(s[i + 1], expected)


def power_law_curve(p, eps):
    sigma_y, K, n = p
    return sigma_y + K * eps**n


def test_recovers_known_power_law_parameters():
    """Eq. 2 curve from known (sigma_Y, K, n); l2 force error (eq. 4) driven to zero."""
    eps = np.linspace(0.0, 0.2, 50)
    truth = np.array([8.6, 25.6, 0.12])
    target = power_law_curve(truth, eps)
    res = nelder_mead(lambda p: l2_error(target, power_law_curve(p, eps)), [10.0, 20.0, 0.2],
                      ["sigma_y", "K", "n"], xatol=1e-8, fatol=1e-10, maxfev=3000)
    np.testing.assert_allclose(res.x, truth, rtol=1e-3)
    assert res.converged and res.nfev == len(res.trace)
    assert list(res.trace.columns) == ["sigma_y", "K", "n", "error", "wall_s"]


def test_non_finite_error_is_a_rejected_point():
    res = nelder_mead(lambda p: np.nan if p[0] > 1.02 else (p[0] - 0.5) ** 2, [1.0], ["a"],
                      xatol=1e-6, fatol=1e-12, maxfev=500)
    assert res.x[0] == pytest.approx(0.5, abs=1e-3)
    assert np.isnan(res.trace["error"]).any()


def test_interrupted_run_resumes_from_its_log(tmp_path):
    log = tmp_path / "trace.h5"
    calls = []

    def objective(p):
        calls.append(p.copy())
        if len(calls) == 15 and not resumed:
            raise KeyboardInterrupt
        return float((p[0] - 2.0) ** 2 + 3.0 * (p[1] + 1.0) ** 2)

    resumed = False
    with pytest.raises(KeyboardInterrupt):
        nelder_mead(objective, [1.0, 1.0], ["a", "b"], log_path=log)
    assert len(calls) == 15
    resumed, calls[:] = True, []
    res = nelder_mead(objective, [1.0, 1.0], ["a", "b"], log_path=log, xatol=1e-6, fatol=1e-10)
    fresh = nelder_mead(lambda p: float((p[0] - 2.0) ** 2 + 3.0 * (p[1] + 1.0) ** 2), [1.0, 1.0],
                        ["a", "b"], xatol=1e-6, fatol=1e-10)
    assert res.nfev == fresh.nfev and len(calls) == res.nfev - 14  # 14 logged evaluations replayed
    np.testing.assert_allclose(res.x, fresh.x)


def test_log_for_other_parameters_is_refused(tmp_path):
    log = tmp_path / "trace.h5"
    nelder_mead(lambda p: float(p[0] ** 2), [1.0], ["a"], log_path=log, maxfev=12)
    with pytest.raises(ValueError, match="evaluation log is for parameters"):
        nelder_mead(lambda p: float(p[0] ** 2), [1.0], ["b"], log_path=log)


def test_log_of_another_objective_is_not_replayed(tmp_path):
    log = tmp_path / "trace.h5"
    nelder_mead(lambda p: float((p[0] - 1.0) ** 2), [2.0], ["a"], log_path=log, key="data-v1")
    res = nelder_mead(lambda p: float((p[0] - 3.0) ** 2), [2.0], ["a"], log_path=log, key="data-v2",
                      xatol=1e-8, fatol=1e-12)
    assert res.x[0] == pytest.approx(3.0, abs=1e-4)
