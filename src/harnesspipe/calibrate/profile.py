"""Profile-likelihood intervals of poorly determined parameters (issue 29).

The Fisher interval ln p_j +- 1.96 SE_j (:mod:`harnesspipe.calibrate.uncertainty`)
treats the model as linear in ln p over the whole interval.  For a parameter the curve
barely determines (SE of ln p above some 5 %) that is rough: the least-squares estimate
moves along a curved valley of the sum of squares, and its error is neither symmetric nor
Gaussian in ln p (bench/RESULTS.md, "Interval coverage").  The profile likelihood does
not linearise.  With independent Gaussian row noise of variance s^2 on the fitted curve
(the mean of the specimens, its noise read off the rows) the log-likelihood is
-S(p) / (2 s^2), S(p) = ||F_ref - F(p)||^2, and the profile of p_j

    S_j(x) = min { S(p) : ln p_j = x, the other fitted parameters free } ,

gives the 95 % interval {x : S_j(x) - S(p^) <= s^2 chi^2_1(0.95)} (Wilks' theorem; for a
model linear in ln p it is exactly the Fisher interval).  Parameters the calibration
takes from a closed form (eq. 13's E) are held at their estimate.

Each endpoint is the root of the signed root deviance
h(t) = sqrt((S_j(x^ +- t) - S^) / s^2) - sqrt(chi^2_1(0.95)), which is linear in t for
a linear model (h = t / SE - 1.96): the profile is walked out from the estimate, the
first step the Fisher SE (within MIN_WALK..MAX_WALK), each next one GROWTH times longer
(short steps keep each inner minimisation in the same curved valley; longer ones reach
a flat side's end in a few), until h > 0; the root between the last two points by
Brent's method, to XTOL of the first step.  A side that stays below the threshold out to
SPAN in ln p (a factor e^3 = 20), or where the model fails on the way, is reported
unbounded (None).
The inner minimisation is Gauss-Newton in ln p (central differences: the valleys are
narrow, a forward-difference direction stalls in them; steps of at most
MAX_STEP, halved until S decreases; parameters the model refuses count as S = infinity),
each point started from the others' ln p interpolated (or extrapolated) from the two
nearest points of the profile already found.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import optimize, stats

from harnesspipe.calibrate import least_squares
from harnesspipe.calibrate.uncertainty import log_sensitivities

CHI2_95 = float(stats.chi2.ppf(0.95, 1))   # 3.84: the 95 % threshold of the deviance
SPAN = 3.0              # a profile is searched out to this distance in ln p
WALK = 0.1              # first profile step in ln p without a Fisher SE (else the SE) ...
MIN_WALK, MAX_WALK = 0.005, 0.25   # ... within these
GROWTH = 1.5            # each further step this much longer
WALK_POINTS = 30        # a side not closed within this many points is reported unbounded
XTOL = 0.1              # an endpoint to this fraction of the first step (0.1 SE)
ROOT_STEPS = 8          # Brent steps per endpoint at most
FAILED = 1e3            # h of a point inside the bracket where the model fails: beyond the end
GN_STEPS = least_squares.STEPS   # Gauss-Newton steps per profile point at most
CONVERGED = 1e-3        # ... ending when a step lowers S by less than this times s^2
MAX_STEP = least_squares.MAX_STEP   # a Gauss-Newton step moves no ln p by more than this


class Profile:
    """The profile of S(p) over the ``fitted`` parameters of a fit ``params`` to ``target``
    (``curve(p)``: the model on the target's rows; ``variance``: the noise variance s^2 of
    the target's rows)."""

    def __init__(self, curve: Callable[[dict], np.ndarray], params: dict, fitted: list[str],
                 target, variance: float):
        self.curve, self.fitted, self.variance = curve, list(fitted), float(variance)
        self.target = np.asarray(target, dtype=float)
        self.params = dict(params)
        self.S_hat = self.sum_of_squares(self.params)
        if not np.isfinite(self.S_hat) or not self.variance > 0.0:
            raise ValueError(f"no profile at a fit with S = {self.S_hat}, noise variance {variance}")

    def residual(self, p: dict) -> np.ndarray | None:
        """F_ref - F(p); None where the model fails or refuses the parameters."""
        try:
            r = self.target - np.asarray(self.curve(p), dtype=float)
        except (RuntimeError, ArithmeticError, ValueError):
            return None
        return r if np.all(np.isfinite(r)) else None

    def sum_of_squares(self, p: dict) -> float:
        """S(p), infinite where the model fails or refuses the parameters."""
        r = self.residual(p)
        return np.inf if r is None else float(r @ r)

    def minimise(self, name: str, x: float, start: dict) -> tuple[float, dict]:
        """(S_j(x), the parameters there): ln p_name held at x, the other fitted parameters
        by Gauss-Newton in ln p from ``start`` (:func:`least_squares.descend`), until a step
        lowers S by less than CONVERGED s^2."""
        others = [k for k in self.fitted if k != name]
        return least_squares.descend(self.residual, {**start, name: float(np.exp(x))}, others,
                                     tol=CONVERGED * self.variance, steps=GN_STEPS)

    def signed_root(self, S: float) -> float:
        """h = sqrt((S - S^) / s^2) - sqrt(chi^2_1(0.95)) (infinite where the model failed)."""
        return float(np.sqrt(max(S - self.S_hat, 0.0) / self.variance) - np.sqrt(CHI2_95))

    def endpoint(self, name: str, side: int, step: float) -> float | None:
        """The value of ``name`` at the interval's end on ``side`` (+1 up, -1 down), or None
        where the profile stays below the threshold out to SPAN in ln p or the model fails
        on the way or within WALK_POINTS points.  The profile is walked out in steps of
        ``step`` in ln p, each GROWTH times longer than the last but moving no other parameter
        by more than MAX_STEP along the valley (and at least MIN_WALK), until h > 0; the root
        of h between the last two points by Brent's method.  Each point starts from the others' ln p interpolated (or extrapolated)
        from the two nearest points walked (at first: along the fit's valley direction)."""
        x_hat = np.log(self.params[name])
        others = [k for k in self.fitted if k != name]
        at_fit = np.log([self.params[k] for k in others])
        walked = {0.0: at_fit}                              # t -> ln p of the others there
        fit_slope = side * np.array([self._conditional_slope(name).get(k, 0.0) for k in others])

        def valley(t: float) -> tuple[np.ndarray, np.ndarray]:
            """(the others' ln p predicted at t, their slope d ln p / dt there)."""
            near = sorted(walked, key=lambda v: abs(v - t))[:2]
            if len(near) < 2:
                return at_fit + fit_slope * t, fit_slope
            (t1, t2), (y1, y2) = near, (walked[near[0]], walked[near[1]])
            slope = (y2 - y1) / (t2 - t1)
            return y1 + slope * (t - t1), slope

        known = {0.0: -np.sqrt(CHI2_95)}                   # t -> h(t)

        def h(t: float) -> float:
            if t not in known:
                start = {**self.params, **dict(zip(others, np.exp(valley(t)[0])))}
                S, p = self.minimise(name, x_hat + side * t, start)
                if np.isfinite(S):
                    walked[t] = np.log([p[k] for k in others])
                known[t] = self.signed_root(S)
            return known[t]

        xtol = XTOL * step
        lo, t, h_t = 0.0, 0.0, known[0.0]
        while h_t < 0.0:
            if t >= SPAN or len(known) > WALK_POINTS:
                return None
            steepest = np.abs(valley(t)[1]).max(initial=0.0)
            move = max(MIN_WALK, min(step, MAX_STEP / max(steepest, 1e-12)))
            lo, t = t, min(t + move, SPAN)
            step *= GROWTH
            h_t = h(t)
        if not np.isfinite(h_t):
            return None
        t = optimize.brentq(lambda v: min(h(v), FAILED), lo, t, xtol=xtol, maxiter=ROOT_STEPS,
                            disp=False)
        return float(np.exp(x_hat + side * t))

    def _conditional_slope(self, name: str) -> dict:
        """d ln p_k / d ln p_name along the valley of the linearised S (the others' least-
        squares response to a unit change of ln p_name), {} if it cannot be computed."""
        others = [k for k in self.fitted if k != name]
        if not others:
            return {}
        try:
            J = log_sensitivities(self.curve, self.params, [name] + others)
        except (RuntimeError, ArithmeticError, ValueError):
            return {}
        b = -np.linalg.lstsq(J[:, 1:], J[:, 0], rcond=None)[0]
        return dict(zip(others, b)) if np.all(np.isfinite(b)) else {}

    def conditional_se(self, name: str) -> float:
        """Fisher SE of ln p_name with the other fitted parameters free and every other
        parameter of the fit known: s sqrt([(J_f^T J_f)^-1]_jj), J_f over ``fitted``."""
        J = log_sensitivities(self.curve, self.params, self.fitted)
        cov = self.variance * np.linalg.pinv(J.T @ J)
        return float(np.sqrt(cov[self.fitted.index(name), self.fitted.index(name)]))

    def interval(self, name: str, se: float | None) -> tuple[float | None, float | None]:
        """(lower, upper) 95 % profile interval of ``name`` (None: that side unbounded),
        walked in steps of its Fisher SE of ln p ``se`` (WALK without one)."""
        step = se if se is not None and np.isfinite(se) and se > 0.0 else WALK
        step = float(np.clip(step, MIN_WALK, MAX_WALK))
        return self.endpoint(name, -1, step), self.endpoint(name, +1, step)


PROFILE_SE = 0.05       # a Fisher SE of ln p above this: the interval from the profile
Z95 = float(stats.norm.ppf(0.975))


def fit_intervals(curve: Callable[[dict], np.ndarray], params: dict, fitted: list[str], u,
                  replicates, fisher: dict | None) -> dict:
    """fit.json's ``interval95``: the 95 % interval of each parameter of the tested specimens
    (load-cell noise alone, as the Fisher standard errors) of a fit ``params`` to the mean of
    ``replicates`` (n x N forces on the rows ``u``; ``curve(p)``: the model on u).

    {name: {"lower", "upper", "method"}}: ``fisher`` -- estimate * exp(+-1.96 SE) -- where
    the Fisher SE of ln p is at most PROFILE_SE; ``profile`` (:class:`Profile`, over the
    least-squares parameters ``fitted``, the noise variance of the mean s^2 = sum_k s_k^2 / n^2
    read off each specimen's rows) for a fitted parameter above that or without an SE (a fit
    on a boundary); a side None is unbounded.  The profile holds the closed-form parameters
    (those of ``params`` not in ``fitted``) at their estimate; their own noise, which the
    Fisher SE includes (:func:`harnesspipe.calibrate.uncertainty.estimator_map`), widens it:
    each side's distance in ln p times SE / SE_conditional, the ratio of the Fisher SE to the
    one with the closed-form parameters known (exact for a model linear in ln p).  A
    closed-form parameter without an SE has no interval (None)."""
    from harnesspipe.calibrate.uncertainty import row_noise_variance
    R = np.atleast_2d(np.asarray(replicates, dtype=float))
    se = (fisher or {}).get("standard_error") or {}
    out, profile = {}, None
    for name in params:
        s = se.get(name)
        if s is not None and (s <= PROFILE_SE or name not in fitted):
            out[name] = {"lower": float(params[name] * np.exp(-Z95 * s)),
                         "upper": float(params[name] * np.exp(Z95 * s)), "method": "fisher"}
        elif name in fitted:
            if profile is None:
                variance = sum(row_noise_variance(u, Fk) for Fk in R) / len(R) ** 2
                profile = Profile(curve, params, fitted, R.mean(axis=0), variance)
            widen = 1.0
            if s is not None and set(params) - set(fitted):
                widen = max(1.0, s / profile.conditional_se(name))
            out[name] = {**dict(zip(("lower", "upper"), (
                None if end is None else float(params[name] * (end / params[name]) ** widen)
                for end in profile.interval(name, s)))), "method": "profile"}
        else:
            out[name] = None
    return out
