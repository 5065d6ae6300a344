"""Nelder-Mead driver: paper's initial simplex, recovery, logging and resume."""
import numpy as np
import pytest

from harnesspipe.calibrate.objective import l2_error
from harnesspipe.calibrate.simplex import (EvaluationLog, initial_simplex, nelder_mead, pick_weights,
                                           rest_at_pick, weighted_pick)


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


# --------------------------------------------------------------------------- the weighted pick

def _log(xs, errors):
    log = EvaluationLog(None, ["T"])
    for x, e in zip(xs, errors):
        log.append(np.array([x]), e, 0.0)
    return log


def test_weighted_pick_is_the_gaussian_weighted_mean():
    """w = exp(-((e - e_min)/tie)^2/2): a point one tie above the best weighs exp(-1/2)."""
    log = _log([0.0, 1.0, 2.0, 3.0], [10.0, 11.0, 12.0, 10.0 + 1e3])
    w = np.exp(-0.5 * np.array([0.0, 1.0, 4.0, 1e6]))
    assert weighted_pick(log, 1.0)[0] == pytest.approx((w @ [0.0, 1.0, 2.0, 3.0]) / w.sum(), rel=1e-14)
    np.testing.assert_array_equal(pick_weights([5.0, 5.0 + 1e9], 1.0), [1.0, 0.0])


def test_rejected_points_weigh_nothing():
    """A penalty score (failed run) or a non-finite error does not pull the pick, however
    close it is to the best; with nothing admitted there is no pick."""
    xs, errors = [0.0, 1.0, 2.0, 3.0], [10.0, 10.5, np.nan, 100.0]
    assert weighted_pick(_log(xs, errors), 1.0, penalty=100.0)[0] == pytest.approx(
        np.exp(-0.125) / (1.0 + np.exp(-0.125)))
    with pytest.raises(ValueError, match="no admitted"):
        weighted_pick(_log([0.0], [np.inf]), 1.0)


def test_weighted_pick_moves_little_where_a_threshold_pick_jumps():
    """Errors as a tension search gives them (N, summed over two cases; tie 4.38 N, the
    uncertainty of the measured mean): the threshold rule 'nearest the start 0 within the
    tie of the best' jumps between 0 and 2.47 N when the error at 0 moves by 0.1 N across
    the tie; the weighted pick moves by less than 0.05 N when any one error moves by 0.1 N."""
    xs = np.array([0.0, 2.47, 1.53, 3.82, 3.1])
    errors = np.array([41.45, 37.10, 43.3, 45.0, 38.2])
    tie = 4.38
    base = weighted_pick(_log(xs, errors), tie)[0]
    for j in range(len(xs)):
        for de in (-0.1, 0.1):
            e = errors.copy()
            e[j] += de
            assert abs(weighted_pick(_log(xs, e), tie)[0] - base) < 0.05
    threshold = [min((abs(x), x) for x, e in zip(xs, err) if e <= err.min() + tie)[1]
                 for err in (errors, errors + np.array([0.1, 0, 0, 0, 0]))]
    assert threshold == [0.0, 2.47]


def test_rest_at_pick_evaluates_the_pick_or_takes_the_point_within_resolution():
    """The pick is evaluated and logged as the last row; within the resolution of an
    evaluated point it is that point (no new run); a rejected run there keeps the best."""
    calls = []

    def objective(x):
        calls.append(float(x[0]))
        return 10.0 + (x[0] - 0.4) ** 2

    log = _log([0.0, 1.0], [10.16, 10.36])
    x, err, how = rest_at_pick(log, objective, 0.2, 0.02)
    assert calls == [pytest.approx(x[0])] and err == log.rows[-1][1] == objective(x)
    assert 0.0 < x[0] < 0.5 and "evaluated there" in how
    near = _log([0.0, 0.01], [10.0, 10.0])           # pick 0.005: within 0.02 of both
    x, err, how = rest_at_pick(near, objective, 1.0, 0.02)
    assert x[0] == 0.0 and len(near.rows) == 2 and "evaluated point nearest" in how
    x, err, how = rest_at_pick(_log([0.0, 1.0], [10.0, 10.0]), lambda x: 1e9, 1.0, 0.02, penalty=100.0)
    assert (x[0], err) == (0.0, 10.0) and "rejected" in how
