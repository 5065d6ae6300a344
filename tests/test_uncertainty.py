"""Standard errors of fitted parameters (calibrate/uncertainty.py) against linear regression
theory and a Monte-Carlo experiment."""
import numpy as np
import pytest
from scipy.optimize import least_squares

from harnesspipe.calibrate import uncertainty as unc

U = np.linspace(0.0, 30.0, 101)


def quadratic(p):
    """F = a u + b u^2: linear in (a, b)."""
    return p["a"] * U + p["b"] * U**2


def saturating(p):
    """F = A (1 - exp(-u / tau)): nonlinear in tau."""
    return p["A"] * (1.0 - np.exp(-U / p["tau"]))


def test_linear_model_gives_the_textbook_covariance():
    """For F = X beta, Cov(beta) = s^2 (X^T X)^-1; in ln p: Cov_ij / (beta_i beta_j)."""
    p = {"a": 0.7, "b": -0.01}
    J = unc.log_sensitivities(quadratic, p, ["a", "b"])
    X = np.column_stack([U, U**2])
    expected = 0.04 * np.linalg.inv(X.T @ X) / np.outer([0.7, -0.01], [0.7, -0.01])
    np.testing.assert_allclose(unc.log_covariance(J, 0.04), expected, rtol=1e-4)


def test_standard_errors_match_the_spread_of_monte_carlo_fits():
    """300 noisy realisations of a nonlinear curve, each fitted by least squares: the spread of
    ln A, ln tau agrees with the linearised standard errors (the Cramer-Rao bound here) within
    the Monte-Carlo uncertainty, and so does the mean of the residual-based estimates."""
    truth, sigma = {"A": 10.0, "tau": 4.0}, 0.3
    bound = np.sqrt(np.diag(unc.log_covariance(unc.log_sensitivities(saturating, truth, ["A", "tau"]),
                                               sigma**2)))
    rng = np.random.default_rng(3)
    estimates, reported = [], []
    for _ in range(300):
        F = saturating(truth) + sigma * rng.standard_normal(U.size)
        sol = least_squares(lambda x: saturating({"A": np.exp(x[0]), "tau": np.exp(x[1])}) - F,
                            np.log([9.0, 5.0]), xtol=1e-12, ftol=1e-12)
        fitted = {"A": np.exp(sol.x[0]), "tau": np.exp(sol.x[1])}
        estimates.append(sol.x)
        reported.append(list(unc.fit_standard_errors(saturating, fitted, ["A", "tau"], F).values()))
    spread = np.std(estimates, axis=0, ddof=1)
    np.testing.assert_allclose(spread, bound, rtol=0.12)      # ~4 % Monte-Carlo error at 300
    np.testing.assert_allclose(np.mean(reported, axis=0), bound, rtol=0.05)


def test_replicate_sandwich_is_the_covariance_of_the_mean_parameters():
    """Replicates made by scattering the parameters of a linear model: the sandwich returns the
    sample covariance of their ln p over n (what the mean curve's estimate scatters by)."""
    p = {"a": 0.7, "b": 0.02}
    rng = np.random.default_rng(5)
    d = 0.04 * rng.standard_normal((5, 2))
    replicates = np.array([quadratic({"a": p["a"] * np.exp(x), "b": p["b"] * np.exp(y)}) for x, y in d])
    J = unc.log_sensitivities(quadratic, p, ["a", "b"])
    # a linear model is linear in p, not ln p: the exact map has a second-order term
    np.testing.assert_allclose(unc.replicate_log_covariance(J, replicates), np.cov(d.T) / 5, rtol=0.1)
    se = unc.fit_standard_errors(quadratic, p, ["a", "b"], replicates.mean(axis=0), replicates)
    assert se["a"] == pytest.approx(np.std(d[:, 0], ddof=1) / np.sqrt(5), rel=0.1)


def test_a_parameter_the_curve_does_not_see_is_not_determined():
    """F = a b u + c u^2 fixes only the product a b: a and b get infinite standard errors,
    c a finite one."""
    model = lambda p: p["a"] * p["b"] * U + p["c"] * U**2
    p = {"a": 2.0, "b": 3.0, "c": 0.01}
    J = unc.log_sensitivities(model, p, ["a", "b"])
    assert np.all(np.isinf(np.diag(unc.log_covariance(J, 1.0))))
    se = unc.fit_standard_errors(model, p, ["a", "b", "c"], model(p) + 0.1 * np.sin(U))
    assert se["a"] is None and se["b"] is None and 0.0 < se["c"] < 0.1


def test_replicates_must_match_the_grid():
    J = np.ones((101, 2))
    with pytest.raises(ValueError, match=r"replicates must be \(n >= 2, 101\)"):
        unc.replicate_log_covariance(J, np.ones((1, 101)))


def test_a_fit_on_the_boundary_reports_no_standard_errors():
    """A parameter driven to ~0 leaves its ln p without effect on the curve; the linearised
    errors of the others would be conditional on it and are not reported either."""
    model = lambda p: p["a"] * U + p["b"] * U**2
    se = unc.fit_standard_errors(model, {"a": 0.7, "b": 1e-12}, ["a", "b"], model({"a": 0.7, "b": 0.0}) + 0.1 * np.sin(U))
    assert se == {"a": None, "b": None}


def test_a_failing_perturbed_simulation_gives_no_standard_errors():
    """The fit stands; its errors are simply not available (the stage writes null)."""
    def fragile(p):
        if p["a"] > 0.7:
            raise RuntimeError("no convergence")
        return p["a"] * U
    assert unc.fit_standard_errors(fragile, {"a": 0.7}, ["a"], 0.7 * U) is None


def test_non_finite_forces_give_no_standard_errors():
    nan_curve = lambda p: np.full(U.size, np.nan) if p["a"] > 0.7 else p["a"] * U
    assert unc.fit_standard_errors(nan_curve, {"a": 0.7}, ["a"], 0.7 * U) is None


def test_closed_form_parameter_is_taken_from_each_replicate():
    """F = E u + b u^2 with E from a closed form on each replicate and b fitted: E's error is
    the spread of its replicate values / sqrt(n); b's is that of what E leaves unexplained --
    here b alone scatters, so b recovers its own spread exactly (a linear model), and a joint
    fit of both would not separate them differently."""
    p = {"E": 0.7, "b": 0.02}
    rng = np.random.default_rng(11)
    dE, db = 0.03 * rng.standard_normal(4), 0.05 * rng.standard_normal(4)
    E_k, b_k = p["E"] * np.exp(dE), p["b"] * np.exp(db)
    replicates = np.array([e * U + b * U**2 for e, b in zip(E_k, b_k)])
    se = unc.fit_standard_errors(quadratic_E, p, ["b"], replicates.mean(axis=0), replicates,
                                 closed_form={"E": E_k})
    assert se["E"] == pytest.approx(np.std(dE, ddof=1) / 2.0, rel=1e-9)
    # b: ln-linearisation of b exp(db) ~ b (1 + db): second-order terms only
    assert se["b"] == pytest.approx(np.std(db, ddof=1) / 2.0, rel=0.05)


def quadratic_E(p):
    return p["E"] * U + p["b"] * U**2


def test_degrees_of_freedom_follow_the_estimator():
    """n - 1 for the mean of n >= 2 replicates, the curve's points less its fitted
    parameters for a single curve (one specimen: the fit residual, not a replicate spread)."""
    one = quadratic({"a": 0.7, "b": 0.01})[None, :]
    assert unc.error_dof(U.size, ["a", "b"], np.vstack([one, one, one])) == 2
    assert unc.error_dof(U.size, ["a", "b"], one) == U.size - 2
    assert unc.error_dof(U.size, ["a", "b"]) == U.size - 2


def test_a_curve_with_no_more_points_than_parameters_has_no_standard_errors():
    u2 = U[:2]
    line = lambda p: p["a"] * u2 + p["b"] * u2**2
    assert unc.fit_standard_errors(line, {"a": 0.7, "b": 0.01}, ["a", "b"], 0.7 * u2) is None
