"""Profile-likelihood intervals (calibrate/profile.py) against the exact interval of a linear
model and a parameter the data cannot bound."""
import numpy as np
import pytest

from harnesspipe.calibrate import profile

U = np.linspace(0.0, 30.0, 201)
X = np.column_stack([U, U**2])


def line_and_square(p):
    """F = a u + b u^2: linear in (a, b) (not in ln a, ln b)."""
    return p["a"] * U + p["b"] * U**2


def noisy_fit(sigma: float, seed: int):
    """Least-squares (a, b) of line_and_square to a noisy curve, the curve and Cov(a, b)."""
    y = line_and_square({"a": 0.7, "b": 0.002}) + sigma * np.random.default_rng(seed).standard_normal(U.size)
    beta = np.linalg.lstsq(X, y, rcond=None)[0]
    return {"a": beta[0], "b": beta[1]}, y, sigma**2 * np.linalg.inv(X.T @ X)


def test_profile_interval_of_a_linear_model_is_the_exact_one():
    """For a model linear in p with known noise the likelihood-ratio interval is exactly
    p^ +- 1.96 sd(p^); the profile must find it (to its tolerance, XTOL sd) for a well and a
    poorly determined parameter (b: sd 25 % of b^), where the Fisher interval in ln p,
    b^ exp(+-1.96 SE), is visibly off (asymmetric)."""
    p, y, cov = noisy_fit(sigma=1.0, seed=3)
    sd = np.sqrt(np.diag(cov))
    assert 0.15 < sd[1] / p["b"] < 0.4
    prof = profile.Profile(line_and_square, p, ["a", "b"], y, 1.0)
    for name, s in zip(("a", "b"), sd):
        lower, upper = prof.interval(name, s / p[name])
        assert lower == pytest.approx(p[name] - 1.96 * s, abs=profile.XTOL * s)
        assert upper == pytest.approx(p[name] + 1.96 * s, abs=profile.XTOL * s)
    lower, upper = prof.interval("b", sd[1] / p["b"])
    ln_wald = p["b"] * np.exp(-1.96 * sd[1] / p["b"])
    assert abs(lower - ln_wald) > 0.2 * sd[1]
    # with only a fixed (closed-form) a, b's profile is the conditional interval +- 1.96 / sqrt(X_b'X_b)
    only_b = profile.Profile(line_and_square, p, ["b"], y, 1.0)
    s_cond = 1.0 / np.sqrt(X[:, 1] @ X[:, 1])
    assert only_b.interval("b", None)[1] == pytest.approx(p["b"] + 1.96 * s_cond, abs=profile.XTOL * s_cond)


def saturating(p):
    """F = A (1 - exp(-u / tau)): for tau far beyond the 30 mm of the rows, a straight line."""
    return p["A"] * (1.0 - np.exp(-U / p["tau"]))


def test_a_side_the_data_do_not_bound_is_unbounded():
    """A curve that is a straight line within the noise: tau -> infinity fits as well as the
    estimate, so the upper side is None (unbounded out to SPAN in ln p) and the lower one a
    finite value below the estimate, where the curve visibly bends."""
    truth = {"A": 5e4, "tau": 1e4}              # slope 5 N/mm, bending 0.15 % over the rows
    y = saturating(truth) + 0.3 * np.random.default_rng(5).standard_normal(U.size)
    prof = profile.Profile(saturating, truth, ["A", "tau"], y, 0.3**2)
    lower, upper = prof.interval("tau", None)
    assert upper is None
    assert lower is not None and 2e3 < lower < truth["tau"]
    # the estimate's A moves with tau (A / tau is the slope): A's upper side is unbounded too
    assert prof.interval("A", None)[1] is None


def test_fit_intervals_take_the_profile_where_the_fisher_error_is_large():
    """fit.json's interval95: estimate * exp(+-1.96 SE) for an SE up to PROFILE_SE (a), the
    profile above it (b), nothing for a closed-form parameter without an SE (c); the profile
    uses the noise of the replicates' mean read off their rows (three replicates of noise 0.5:
    the mean's sd 0.5 / sqrt(3)).  With a closed-form parameter in the fit the profile holds
    it and is widened by the Fisher SE over the conditional one: an SE twice that doubles
    each side in ln p."""
    rng = np.random.default_rng(11)
    R = line_and_square({"a": 0.7, "b": 0.002}) + 0.5 * rng.standard_normal((3, U.size))
    beta = np.linalg.lstsq(X, R.mean(axis=0), rcond=None)[0]
    p = {"a": beta[0], "b": beta[1], "c": 1.0}
    sd_b = np.sqrt(np.linalg.inv(X.T @ X)[1, 1]) * 0.5 / np.sqrt(3)
    se = {"a": 0.02, "b": sd_b / p["b"], "c": None}
    assert se["b"] > profile.PROFILE_SE
    out = profile.fit_intervals(line_and_square, p, ["a", "b"], U, R, {"standard_error": se})
    assert out["a"] == {"lower": pytest.approx(p["a"] * np.exp(-1.96 * 0.02)),
                        "upper": pytest.approx(p["a"] * np.exp(1.96 * 0.02)), "method": "fisher"}
    assert out["c"] is None
    assert out["b"]["method"] == "profile"
    half = 1.96 * sd_b                          # the noise read off the rows: ~5 % in s
    assert out["b"]["upper"] - p["b"] == pytest.approx(half, rel=0.15)
    assert p["b"] - out["b"]["lower"] == pytest.approx(half, rel=0.15)
    wide = profile.fit_intervals(line_and_square, p, ["a", "b"], U, R,
                                 {"standard_error": {**se, "b": 2.0 * se["b"]}})["b"]
    for side in ("lower", "upper"):
        assert np.log(wide[side] / p["b"]) == pytest.approx(2.0 * np.log(out["b"][side] / p["b"]), rel=0.1)
