"""Standard errors of fitted parameters (calibrate/uncertainty.py) against linear regression
theory and a Monte-Carlo experiment."""
import numpy as np
import pandas as pd
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
        sol = least_squares(lambda x, F=F: saturating({"A": np.exp(x[0]), "tau": np.exp(x[1])}) - F,
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


# --- Fisher standard errors with the noise read off the rows, chi-square, correlations -----

ROWS = np.linspace(0.0, 30.0, 201)


def line_and_square(p):
    """F = a u + b u^2 on the rows: linear in (a, b), analytic covariance known."""
    return p["a"] * ROWS + p["b"] * ROWS**2


def test_row_noise_is_read_off_the_rows_not_the_curve():
    """White noise of known sigma on a curved, kinked force curve with uneven rows: the
    estimate is within its sampling error (~2 % at 3000 rows) of sigma^2; without noise a
    piecewise-linear curve gives exactly zero (its kink is one row against thousands)."""
    rng = np.random.default_rng(17)
    u = np.sort(rng.uniform(0.0, 30.0, 3000))
    smooth = np.where(u < 8.0, 0.7 * u, 5.6 + 0.1 * (u - 8.0))
    assert unc.row_noise_variance(u, smooth) == 0.0
    noisy = smooth + 0.02 * u**2 / 30.0 + 0.05 * rng.standard_normal(u.size)
    assert unc.row_noise_variance(u, noisy) == pytest.approx(0.05**2, rel=0.1)


def test_row_noise_refuses_bad_rows():
    with pytest.raises(ValueError, match="increase strictly"):
        unc.row_noise_variance(np.array([0.0, 1.0, 1.0, 2.0, 3.0]), np.zeros(5))
    with pytest.raises(ValueError, match="at least 5 rows"):
        unc.row_noise_variance(np.arange(3.0), np.zeros(3))


def test_fisher_standard_errors_of_a_linear_model_are_the_analytic_ones():
    """Three replicates of F = X beta plus white noise sigma: the fit to their mean has
    Cov(beta) = sigma^2 / 3 (X^T X)^-1 exactly; fit_statistics must return that (in ln p),
    with sigma read off the rows (within its ~3 % sampling error) and the analytic
    correlation (which does not depend on sigma at all)."""
    p, sigma = {"a": 0.7, "b": -0.01}, 0.05
    rng = np.random.default_rng(23)
    replicates = line_and_square(p) + sigma * rng.standard_normal((3, ROWS.size))
    X = np.column_stack([ROWS, ROWS**2])
    beta, *_ = np.linalg.lstsq(X, replicates.mean(axis=0), rcond=None)
    fitted = {"a": beta[0], "b": beta[1]}
    cov = sigma**2 / 3 * np.linalg.inv(X.T @ X)
    analytic = np.sqrt(np.diag(cov)) / np.abs(beta)
    result = unc.fit_statistics(line_and_square, fitted, ["a", "b"], ROWS, replicates)
    assert result["noise_sigma_N"] == pytest.approx(sigma, rel=0.1)
    se = result["standard_error"]
    np.testing.assert_allclose([se["a"], se["b"]], analytic, rtol=0.1)
    # in ln p: d ln b = db / b, so a negative b flips the sign of the correlation
    rho = np.sign(beta[0] * beta[1]) * cov[0, 1] / np.sqrt(cov[0, 0] * cov[1, 1])
    assert result["correlation"][0][1] == pytest.approx(rho, rel=1e-6)
    assert result["correlation"][1][0] == result["correlation"][0][1]


def saturating_rows(p):
    return p["A"] * (1.0 - np.exp(-ROWS / p["tau"]))


def test_fisher_intervals_cover_the_truth_of_noisy_nonlinear_fits():
    """200 data sets of three specimens (noise only, same truth), each fitted by least
    squares through its mean: the spread of ln A, ln tau matches the Fisher standard errors,
    and the 95 % intervals (+-1.96 SE) hold the truth 95 % of the time (binomial 3-sigma
    range at 200 sets: 90-99.6 %).  Without the 1/n of the mean the errors would be sqrt(3)
    too large; with the fit residual of one specimen's scatter, too."""
    truth, sigma = {"A": 10.0, "tau": 4.0}, 0.3
    rng = np.random.default_rng(29)
    estimates, covered, ses = [], 0, []
    for _ in range(200):
        R = saturating_rows(truth) + sigma * rng.standard_normal((3, ROWS.size))
        sol = least_squares(lambda x, R=R: saturating_rows({"A": np.exp(x[0]), "tau": np.exp(x[1])})
                            - R.mean(axis=0), np.log([9.0, 5.0]), xtol=1e-12, ftol=1e-12)
        fitted = {"A": np.exp(sol.x[0]), "tau": np.exp(sol.x[1])}
        se = unc.fit_statistics(saturating_rows, fitted, ["A", "tau"], ROWS, R)["standard_error"]
        se = np.array([se["A"], se["tau"]])
        estimates.append(sol.x)
        ses.append(se)
        covered += np.all(np.abs(sol.x - np.log([10.0, 4.0])) < 1.96 * se)
    np.testing.assert_allclose(np.std(estimates, axis=0, ddof=1), np.mean(ses, axis=0), rtol=0.15)
    # both parameters in their intervals: 0.95^2 = 90 % if independent, more when correlated
    assert 0.85 <= covered / 200 <= 0.99


def test_chi_square_passes_noise_and_fails_a_misfit():
    """Residuals that are the noise alone pass at about 1 - alpha of realisations (200
    sets: 99 +- 0.7 %); a model that misses a smooth term of 3 noise units fails."""
    rng = np.random.default_rng(31)
    passed = [unc.chi_square(0.1 * rng.standard_normal(201), 0.01, 2)["pass"] for _ in range(200)]
    assert 0.96 <= np.mean(passed) < 1.0
    check = unc.chi_square(0.1 * rng.standard_normal(201) + 0.3 * np.sin(ROWS / 5.0), 0.01, 2)
    assert not check["pass"] and check["chi2_per_dof"] > 3.0 and check["dof"] == 199


def test_chi_square_refuses_what_it_cannot_judge():
    with pytest.raises(ValueError, match="no chi-square"):
        unc.chi_square(np.ones(2), 1.0, 2)
    with pytest.raises(ValueError, match="no chi-square"):
        unc.chi_square(np.ones(10), 0.0, 2)


def test_fit_summary_keeps_the_sandwich_and_adds_fisher_and_chi_square():
    """fit.json's entries: the sandwich (standard_error, dof n - 1, its correlation) beside
    the Fisher figures and the chi-square of the mean's residual; one replicate has no
    sandwich but its own residual's errors on N - m degrees of freedom."""
    p = {"a": 0.7, "b": 0.02}
    rng = np.random.default_rng(37)
    scatter = np.exp(0.04 * rng.standard_normal((4, 2)))
    R = np.array([line_and_square({"a": p["a"] * x, "b": p["b"] * y}) for x, y in scatter])
    R += 0.05 * rng.standard_normal(R.shape)
    out = unc.fit_summary(line_and_square, p, ["a", "b"], ROWS, R)
    assert out["standard_error_dof"] == 3
    assert out["replicate_correlation"]["names"] == ["a", "b"]
    assert out["fisher"]["noise_sigma_N"] == pytest.approx(0.05, rel=0.15)
    # the specimen scatter (4 %) is far above the noise: the sandwich sees it, Fisher does not
    assert out["standard_error"]["a"] > 5 * out["fisher"]["standard_error"]["a"]
    one = unc.fit_summary(line_and_square, p, ["a", "b"], ROWS, R[:1])
    assert one["standard_error_dof"] == ROWS.size - 2 and one["chi_square"]["dof"] == ROWS.size - 2


# --- prediction band of the fitted curve, flow-stress band (report, issue 29 item 6) -----

def test_prediction_band_of_a_linear_model_is_the_analytic_one():
    """F = X beta: Var F_i = X_i Cov(beta) X_i^T exactly.  In ln p, J_ij = X_ij beta_j and
    Cov(ln p) = Cov(beta) / (beta_j beta_k); prediction_band must give the same, and
    fit_statistics' band_N (its J by central differences, the noise off the rows) the
    analytic band at the noise it estimated."""
    beta = np.array([0.7, -0.01])
    X = np.column_stack([ROWS, ROWS**2])
    cov_beta = np.array([[4e-4, -1e-5], [-1e-5, 6e-7]])
    analytic = np.sqrt(np.einsum("ij,jk,ik->i", X, cov_beta, X))
    J = X * beta
    band = unc.prediction_band(J, cov_beta / np.outer(beta, beta))
    np.testing.assert_allclose(band, analytic, rtol=1e-12)
    rng = np.random.default_rng(41)
    p = {"a": beta[0], "b": beta[1]}
    R = line_and_square(p) + 0.05 * rng.standard_normal((3, ROWS.size))
    result = unc.fit_statistics(line_and_square, p, ["a", "b"], ROWS, R)
    s2_mean = result["noise_sigma_N"] ** 2 / 3            # rms over 3 specimens, of their mean
    expected = np.sqrt(s2_mean * np.einsum("ij,jk,ik->i", X, np.linalg.inv(X.T @ X), X))
    np.testing.assert_allclose(result["band_N"], expected, rtol=1e-6)
    # F(0) = 0 is certain; elsewhere the fit averages many rows: below one row's noise of the mean
    assert result["band_N"][0] == 0.0 and 0.0 < result["band_N"].max() < 0.05 / np.sqrt(3)


def test_prediction_band_is_finite_where_a_parameter_is_not_determined():
    """F = a c u fixes only the product a c: a and c separately have no standard error, but
    the band is that of the product, as fitted with the one parameter k = a c."""
    rng = np.random.default_rng(43)
    R = 0.7 * ROWS + 0.05 * rng.standard_normal((3, ROWS.size))
    both = unc.fit_statistics(lambda p: p["a"] * p["c"] * ROWS, {"a": 0.5, "c": 1.4}, ["a", "c"],
                              ROWS, R)
    assert both["standard_error"] == {"a": None, "c": None}
    one = unc.fit_statistics(lambda p: p["k"] * ROWS, {"k": 0.7}, ["k"], ROWS, R)
    np.testing.assert_allclose(both["band_N"], one["standard_error"]["k"] * 0.7 * ROWS, rtol=1e-4)
    np.testing.assert_allclose(one["band_N"], one["standard_error"]["k"] * 0.7 * ROWS, rtol=1e-4)


def test_replicate_band_of_a_linear_model_is_the_standard_error_of_the_mean_force():
    """F = a u + b u^2 with four replicates exactly in that family, fitted at their mean
    (a, b): each replicate's deviation is J d_k, so Var F_i = J_i C_sandwich J_i^T is the
    variance of the replicates' mean force at row i, s_i^2 / n (sample variance, n - 1).
    fit_summary returns it as band_replicate_N and curve_bands writes t(0.975, n - 1) times it
    on the curve's grid: the textbook t interval of the mean force at each row.  A closed-form
    parameter (a, taken from each replicate) gives the same to first order in its scatter."""
    a_k = 0.7 * np.array([1.00, 1.03, 0.98, 1.01])
    b_k = 0.02 * np.array([1.02, 0.97, 1.01, 1.00])
    R = np.array([line_and_square({"a": a, "b": b}) for a, b in zip(a_k, b_k)])
    p = {"a": a_k.mean(), "b": b_k.mean()}
    J = np.column_stack([p["a"] * ROWS, p["b"] * ROWS**2])
    sem = R.std(axis=0, ddof=1) / np.sqrt(len(R))
    np.testing.assert_allclose(unc.replicate_band(J, R), sem, rtol=1e-10, atol=1e-14)
    out = unc.fit_summary(line_and_square, p, ["a", "b"], ROWS, R)
    np.testing.assert_allclose(out["band_replicate_N"], sem, rtol=1e-6, atol=1e-12)
    t3 = 3.182446305284263                       # Student's t(0.975) on 3 dof
    curve = pd.DataFrame({"displacement_mm": ROWS, "force_N": line_and_square(p)})
    hardening = {"sigma_y": 1.0, "K": 2.0, "n": 0.5}      # curve_bands' flow stress needs them
    written, _ = unc.curve_bands(dict(out), {**p, **hardening}, ROWS, curve, (1e-3, 0.1))
    np.testing.assert_allclose(written["band_replicate_N"], t3 * sem, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(written["band_N"], unc.Z95 * out["band_N"])
    closed = unc.fit_summary(line_and_square, {"a": np.exp(np.log(a_k).mean()), "b": p["b"]},
                             ["b"], ROWS, R, closed_form={"a": list(a_k)})
    np.testing.assert_allclose(closed["band_replicate_N"][1:], sem[1:], rtol=0.03)
    # the band is the specimens' scatter, not the load-cell noise: without scatter it vanishes
    same = unc.fit_summary(line_and_square, p, ["a", "b"], ROWS, np.repeat(R[:1], 3, axis=0))
    np.testing.assert_allclose(same["band_replicate_N"], 0.0, atol=1e-12)
    assert unc.fit_summary(line_and_square, p, ["a", "b"], ROWS, R[:1])["band_replicate_N"] is None


def test_flow_stress_band_is_the_delta_method_and_matches_sampling():
    """sigma = sigma_Y + K eps^n: the delta-method sd against the spread of sigma over
    50 000 draws of ln p ~ N(ln p*, C) with a small (linear-regime) correlated C, at
    plastic strains 1e-3 .. 0.1; E in the covariance does not enter."""
    p = {"E": 900.0, "sigma_y": 8.0, "K": 30.0, "n": 0.45}
    names = ["E", "sigma_y", "K", "n"]
    se = np.array([0.01, 0.02, 0.03, 0.02])
    corr = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, -0.5, -0.3],
                     [0.0, -0.5, 1.0, 0.8], [0.0, -0.3, 0.8, 1.0]])
    C = corr * np.outer(se, se)
    eps = np.array([1e-3, 1e-2, 0.1])
    sigma, sd = unc.flow_stress_band(p, names, C, eps)
    np.testing.assert_allclose(sigma, 8.0 + 30.0 * eps**0.45)
    draws = np.exp(np.log([p[k] for k in names])
                   + np.random.default_rng(47).multivariate_normal(np.zeros(4), C, 50_000))
    sampled = draws[:, 1, None] + draws[:, 2, None] * eps ** draws[:, 3, None]
    np.testing.assert_allclose(sd, sampled.std(axis=0), rtol=0.03)
    only_E = np.diag([0.01, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(unc.flow_stress_band(p, names, only_E, eps)[1], 0.0)


def test_curve_bands_put_the_band_on_the_curve_grid_and_the_flow_stress_in_fit_json():
    """curve_bands: 1.96 sd interpolated from the rows onto the curve's grid (NaN beyond the
    rows), band_N popped from the summary; the flow stress at 25 strains over the span,
    with no band when a standard error is missing."""
    u = np.linspace(0.0, 10.0, 101)
    p = {"E": 900.0, "sigma_y": 8.0, "K": 30.0, "n": 0.45}
    fisher = {"names": ["E", "sigma_y", "K", "n"],
              "standard_error": {"E": 0.01, "sigma_y": 0.02, "K": 0.03, "n": 0.02},
              "correlation": np.eye(4).tolist()}
    curve = pd.DataFrame({"displacement_mm": [0.0, 5.0, 12.0], "force_N": [0.0, 1.0, 2.0]})
    summary = {"fisher": fisher, "band_N": 0.1 * u}
    out, flow = unc.curve_bands(summary, p, u, curve, (1e-3, 0.01, 0.1))
    assert "band_N" not in summary
    np.testing.assert_allclose(out["band_N"][:2], [0.0, unc.Z95 * 0.5])
    assert np.isnan(out["band_N"][2])
    assert len(flow["eps_p"]) == 25 and flow["eps_p"][0] == 1e-3 and flow["eps_p"][-1] == 0.1
    _, sd = unc.flow_stress_band(p, fisher["names"], np.diag([1e-4, 4e-4, 9e-4, 4e-4]), 0.1)
    assert flow["band"][-1] == pytest.approx(unc.Z95 * sd[0], rel=1e-3)
    fisher["standard_error"]["n"] = None
    assert unc.curve_bands({"fisher": fisher}, p, u, curve, (1e-3, 0.1))[1]["band"] is None


def test_fisher_covariance_of_a_closed_form_parameter_is_that_of_the_estimator():
    """a from a closed form -- the slope through the origin on the first 30 rows, whose
    gradient d ln a / dF is u_i / (a sum u^2) there -- and b by least squares on what a
    leaves: Cov = s^2 M M^T (estimator_map) against the spread of that estimator over 4000
    noise draws (linear in F: exact up to sampling, ~3 %); least squares on both would
    give a far smaller SE of a."""
    p = {"a": 0.7, "b": 0.002}
    J = np.column_stack([p["a"] * ROWS, p["b"] * ROWS**2])
    window = (ROWS > 0.0) & (ROWS <= ROWS[30])
    g = np.where(window, ROWS / (p["a"] * ROWS[window] @ ROWS[window]), 0.0)
    M, touched = unc.estimator_map(J, ["a", "b"], {"a": g})
    assert not touched.any()
    noise = 0.05 * np.random.default_rng(53).standard_normal((4000, ROWS.size))
    d_a = noise @ g
    d_b = (noise - np.outer(d_a, J[:, 0])) @ np.linalg.pinv(J[:, 1:]).T
    sampled = np.cov(np.column_stack([d_a, d_b[:, 0]]).T)
    np.testing.assert_allclose(0.05**2 * M @ M.T, sampled, rtol=0.06)
    least_squares = unc.estimator_map(J, ["a", "b"])[0]
    assert np.linalg.norm(least_squares[0]) < 0.5 * np.linalg.norm(M[0])


def test_eq13_gradients_are_the_derivatives_of_the_closed_forms():
    """d ln E / dF_i and d ln sigma_Y / dF_i of eq. 13 against central differences of the
    closed forms themselves, on an elastic-plastic curve (linear part held)."""
    from harnesspipe.calibrate import eq13
    u = np.linspace(0.0, 30.0, 201)
    F = np.where(u < 6.0, 0.5 * u, 3.0 + 0.1 * (u - 6.0))
    g_E = eq13.log_modulus_gradient(u, F, 127.0)
    g_Y = eq13.log_yield_stress_gradient(u, F, 127.0)
    for i in (3, 17, 21, 60):
        dF = np.zeros_like(F)
        dF[i] = 1e-6
        dE = (np.log(eq13.effective_modulus(u, F + dF, 127.0, 7.05))
              - np.log(eq13.effective_modulus(u, F - dF, 127.0, 7.05))) / 2e-6
        dY = (np.log(eq13.yield_stress(u, F + dF, 127.0, 7.05))
              - np.log(eq13.yield_stress(u, F - dF, 127.0, 7.05))) / 2e-6
        assert g_E[i] == pytest.approx(dE, rel=1e-5, abs=1e-9)
        assert g_Y[i] == pytest.approx(dY, rel=1e-5, abs=1e-9)
    assert g_E[60] == 0.0 and g_Y[3] == 0.0 and g_Y[17] > 0.0     # 0.02 L = 2.54 mm: rows 16, 17
