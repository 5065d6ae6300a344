"""Calibration of the hi-fi interface parameters (Sec. 4.2): objectives and searches.

Each fit compares the hi-fi force-deflection curve with the measured mean on a
deflection window (Sec. 4.2.1: friction on u < 20 mm, cohesive on u > 20 mm) by the
l2 norm of eq. 4 on the measurement grid.  One parameter is found by a bounded 1-D
search (Brent's bounded method, ``scipy.optimize.minimize_scalar``), several by the
paper's Nelder-Mead (:func:`harnesspipe.calibrate.simplex.nelder_mead`); a build input
that takes one of a few values by a pick (:func:`choice_fit`).

Robustness.  A hi-fi run that fails -- unstable, energy balance lost, KE/IE above
its limit -- is a *rejected point*: its parameters and reason go to the log and the
objective returns the penalty ``REJECT_FACTOR x ||F_exp||`` (finite, so that Brent's
parabolic steps stay defined; a zero force scores ``||F_exp||``, so the penalty is worse
than any run within a factor of about ten of the measurement -- a run further off is
no basis for a calibration anyway).  Every
evaluation is appended to an HDF5 log as it happens; a rerun after an interruption
replays the logged evaluations instead of recomputing them.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

from harnesspipe.calibrate.objective import l2_error, on_grid
from harnesspipe.calibrate.simplex import (EvaluationLog, FitResult, StopSearch, admitted,
                                           best_logged, check_stop, logged_call, nelder_mead,
                                           rest_at_pick, stopped_at)

REJECT_FACTOR = 10.0
#: a simulated curve may end this fraction of the window's end short of it (the feeder stops
#: at the stroke; the output sampling can leave the last point a hair below the measured end)
END_TOLERANCE = 0.01


class RejectedRun(RuntimeError):
    """A hi-fi evaluation that did not produce a valid curve."""


def window_mask(u_grid, window) -> np.ndarray:
    lo, hi = window
    return (u_grid >= lo) & (u_grid <= hi)


def covered(u_grid, u_sim) -> np.ndarray:
    """The measured grid points a simulated curve covers: from its first deflection to its
    last, and up to ``END_TOLERANCE`` of the grid's end beyond it (they take its end value)."""
    u_grid, u_sim = np.asarray(u_grid, dtype=float), np.asarray(u_sim, dtype=float)
    return (u_grid >= u_sim.min()) & (u_grid <= u_sim.max() + END_TOLERANCE * max(u_grid.max(), 1e-12))


def curve_error(u_sim, f_sim, u_grid, f_exp, window) -> float:
    """eq. 4 on the grid points of the deflection window.

    Grid points beyond the simulated range by more than ``END_TOLERANCE`` of the
    window's end make the run a rejected point; closer ones take the end value.
    """
    u_sim, f_sim = np.asarray(u_sim, dtype=float), np.asarray(f_sim, dtype=float)
    if u_sim.size < 2 or not np.all(np.isfinite(f_sim)):
        raise RejectedRun("simulated curve is empty or not finite")
    order = np.argsort(u_sim, kind="stable")
    u_sim, f_sim = u_sim[order], f_sim[order]
    mask = window_mask(u_grid, window)
    u = u_grid[mask]
    tol = END_TOLERANCE * max(abs(float(window[1])), 1e-12)
    if u.size == 0:
        raise RejectedRun(f"no measured point in the window {tuple(window)}")
    if u.min() < u_sim[0] - tol or u.max() > u_sim[-1] + tol:
        raise RejectedRun(f"simulated curve ({u_sim[0]:.4g}..{u_sim[-1]:.4g} mm) does not cover "
                          f"the window {tuple(window)}")
    f = on_grid(u_sim, f_sim, np.clip(u, u_sim[0], u_sim[-1]))
    return l2_error(f_exp[mask], f)


def admissible(params: dict) -> str | None:
    """Why a parameter set cannot be simulated (None if it can): negative friction or
    cohesive values, or a damage onset not below the failure separation (eqs. 8-10)."""
    for k in ("mu_rtb", "mu_rtp", "alpha_d", "E2_over_E1"):
        if k in params and not params[k] >= 0.0:
            return f"{k} = {params[k]:.6g} < 0"
    for k in ("delta0", "delta_f"):
        if k in params and not params[k] > 0.0:
            return f"{k} = {params[k]:.6g} <= 0"
    if "delta0" in params and "delta_f" in params and not params["delta_f"] > params["delta0"]:
        return f"delta_f = {params['delta_f']:.6g} <= delta0 = {params['delta0']:.6g}"
    return None


def attempt(simulate, case: str, params: dict):
    """``simulate(case, params)``, or the reason it failed (``"Type: message"``) when it
    raises ``RuntimeError`` (which includes the explicit solver's ``ExplicitError``) or
    ``ArithmeticError``.  Module level, so that a process pool can run it."""
    try:
        return simulate(case, params)
    except (RuntimeError, ArithmeticError) as exc:
        return f"{type(exc).__name__}: {exc}"


class HifiObjective:
    """``error(params)`` of one or more hi-fi runs against measured means.

    ``simulate(case, params) -> (u, F)`` or ``(u, F, run)``; with ``on_run`` given,
    ``on_run(case, params, run)`` receives the third item.  ``targets``: list of
    (case, u_grid, F_mean, window); the error is the sum over targets.  With ``pool`` (an
    executor; ``simulate`` must then be picklable) the cases of one evaluation run side
    by side.  A failed run (see :func:`attempt`) or an inadmissible parameter set
    (:func:`admissible`) is a rejected point: it scores ``penalty`` and is appended to
    ``rejected_log`` (JSON lines: case, parameters, reason, ``key``).  ``n_runs`` counts
    the simulate calls of this process, ``n_rejected`` the rejections.
    """

    def __init__(self, simulate, targets, fixed: dict, names: list[str],
                 rejected_log: Path | None = None, key: str = "", pool=None, on_run=None):
        self.simulate, self.targets, self.fixed, self.names = simulate, targets, dict(fixed), list(names)
        self.rejected_log = Path(rejected_log) if rejected_log else None
        self.key = key
        self.pool, self.on_run = pool, on_run
        self.penalty = REJECT_FACTOR * sum(
            float(np.linalg.norm(F[window_mask(u, w)])) for _, u, F, w in targets)
        self.n_runs = 0
        self.n_rejected = 0

    def params(self, x) -> dict:
        return {**self.fixed, **{k: float(v) for k, v in zip(self.names, np.atleast_1d(x))}}

    def __call__(self, x) -> float:
        p = self.params(x)
        why = admissible(p)
        if why is not None:
            self._reject(None, p, f"RejectedRun: inadmissible: {why}")
            return self.penalty
        total = 0.0
        for (case, u_grid, f_exp, window), out in zip(self.targets, self._outcomes(p)):
            if isinstance(out, str):
                self._reject(case, p, out)
                return self.penalty
            if self.on_run is not None and len(out) > 2:
                self.on_run(case, p, out[2])
            try:
                total += curve_error(out[0], out[1], u_grid, f_exp, window)
            except RejectedRun as exc:
                self._reject(case, p, f"RejectedRun: {exc}")
                return self.penalty
        return total

    def _outcomes(self, p):
        """One outcome per target: side by side in the pool, else one by one (lazily, so
        that a rejected case stops the evaluation before the next one runs)."""
        cases = [t[0] for t in self.targets]
        if self.pool is None or len(cases) < 2:
            for c in cases:
                self.n_runs += 1
                yield attempt(self.simulate, c, p)
            return
        self.n_runs += len(cases)
        yield from self.pool.map(attempt, [self.simulate] * len(cases), cases, [p] * len(cases))

    def _reject(self, case, p, reason: str) -> None:
        self.n_rejected += 1
        if self.rejected_log is None:
            return
        self.rejected_log.parent.mkdir(parents=True, exist_ok=True)
        with open(self.rejected_log, "a") as f:
            f.write(json.dumps({"case": case, "parameters": p, "key": self.key,
                                "reason": reason}) + "\n")


def read_rejected(path: Path, key: str | None = None) -> list[dict]:
    """Rejected points of a log (only those written under ``key`` when given)."""
    path = Path(path)
    if not path.exists():
        return []
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return [r for r in rows if key is None or r.get("key", "") == key]


def bounded_fit(objective, name: str, bounds, *, xatol: float, log_path=None, key="",
                maxfev: int = 30, stop=None, keep: float | None = None, tie: float = 0.0,
                penalty: float = np.inf) -> FitResult:
    """Brent's bounded search for one parameter, every evaluation logged (and replayed).
    ``stop``, ``keep``, ``tie``, ``penalty``: as in
    :func:`harnesspipe.calibrate.simplex.nelder_mead`.  The start value ``keep``, when given,
    is evaluated first: the stop rule compares it with Brent's first points (a start the
    data tell apart from them is no near tie).  With ``tie`` > 0 a search that runs its
    course rests at the weighted pick of its evaluations
    (:func:`harnesspipe.calibrate.simplex.rest_at_pick`, resolution ``xatol``)."""
    log = EvaluationLog(log_path, [name], key)

    def wrapped(c):
        err = logged_call(log, objective, np.array([c], dtype=float))
        check_stop(stop, log)
        return err

    try:
        if keep is not None:
            wrapped(keep)
        res = minimize_scalar(wrapped, bounds=tuple(bounds), method="bounded",
                              options={"xatol": xatol, "maxiter": maxfev})
        x, fun, converged, message = [res.x], float(res.fun), bool(res.success), str(res.message)
        if tie > 0.0 and admitted([r[1] for r in log.rows], penalty).any():
            x, fun, how = rest_at_pick(log, objective, tie, xatol, penalty=penalty)
            message = f"{message}; {how}"
        elif keep is not None:     # the start, evaluated before Brent, may be the best point
            x, fun = best_logged(log)
    except StopSearch as reason:
        x, fun, kept = stopped_at(log, objective, None if keep is None else [keep])
        converged, message = False, f"{reason}; {kept}"
    return FitResult(names=[name], x=np.array(x, dtype=float), fun=fun, nfev=len(log.rows),
                     converged=converged, message=message, trace=log.frame())


def choice_fit(objective, name: str, choices, *, keep: float, tie: float, log_path=None,
               key="", penalty: float = np.inf) -> FitResult:
    """The best of a few discrete values of one parameter (a build option, e.g. which wires
    the end bands bind), every evaluation logged (and replayed): the start ``keep`` first,
    then the other ``choices`` in order.  The lowest error replaces the start only when it
    beats the start's by at least ``tie`` (the l2 standard error of the measured mean over the
    window, :func:`flat_screen`'s floor): a difference within the uncertainty of the data
    keeps the start, so the pick never hinges on a run's last bits.  A rejected run (error
    >= ``penalty``) is never picked."""
    log = EvaluationLog(log_path, [name], key)
    values = [float(keep)] + [float(c) for c in choices if float(c) != float(keep)]
    errors = [logged_call(log, objective, np.array([c], dtype=float)) for c in values]
    best = int(np.argmin(errors))
    told = errors[best] < penalty and (errors[0] >= penalty or errors[best] <= errors[0] - tie)
    pick = best if told else 0
    listed = ", ".join(f"{v:g}: {e:.4g} N" for v, e in zip(values, errors))
    how = (f"{name} {values[pick]:g} beats the start by at least the standard error of the "
           f"measured mean ({tie:.3g} N)" if pick != 0 else
           f"the start {values[0]:g} kept: no other value beats it by the standard error of the "
           f"measured mean ({tie:.3g} N)")
    return FitResult(names=[name], x=np.array([values[pick]]), fun=float(errors[pick]),
                     nfev=len(log.rows), converged=True, message=f"errors {listed}; {how}",
                     trace=log.frame())


def simplex_fit(objective, x0: dict, *, xatol: float, fatol: float, maxfev: int, log_path=None,
                key="", stop=None, keep_start: bool = False, tie: float = 0.0,
                penalty: float = np.inf) -> FitResult:
    """The paper's Nelder-Mead (+5 % simplex) on several parameters; ``keep_start``: a
    search its ``stop`` rule ends rests at ``x0``; ``tie`` > 0: one that runs its course
    rests at the weighted pick of its evaluations
    (:func:`harnesspipe.calibrate.simplex.rest_at_pick`)."""
    names = list(x0)
    start = np.array([x0[k] for k in names])
    return nelder_mead(objective, start, names, xatol=xatol, fatol=fatol, maxfev=maxfev,
                       log_path=log_path, key=key, stop=stop, keep=start if keep_start else None,
                       tie=tie, penalty=penalty)


def flat_screen(n_first: int, floor: float, penalty: float = np.inf):
    """Identifiability screen, a ``stop`` rule for the searches above.

    Once the search has made its first ``n_first`` evaluations -- the start and Brent's
    two golden-section points (3), or the +5 % simplex (number of parameters + 1) -- it
    ends the search if their errors (eq. 4) differ by less than ``floor``: the l2 norm,
    over the fit's window, of the standard error of the measured mean (summed over the
    cases like the error).  Parameters whose effect on the error stays within the
    uncertainty of the measured mean are not identified by the data; the search would
    only chase that uncertainty.  A rejected point among them -- an error not finite or
    at least ``penalty`` (:attr:`HifiObjective.penalty`, the score of a failed run) --
    never stops it.  ``floor`` <= 0 disables the screen.
    """
    def stop(rows) -> str | None:
        if floor <= 0.0 or len(rows) != n_first:
            return None
        errors = np.array([r[1] for r in rows])
        if not np.all(errors < penalty):       # also False for nan and inf
            return None
        spread = float(errors.max() - errors.min())
        if spread >= floor:
            return None
        return (f"not identifiable from this data: the errors of the first {n_first} evaluations "
                f"differ by {spread:.3g} N, less than the standard error of the measured mean "
                f"({floor:.3g} N, l2 over the window)")
    return stop


def screen_size(method: str, n_names: int) -> int:
    """How many first evaluations :func:`flat_screen` looks at in a search of ``n_names``
    parameters: the start and Brent's two golden-section points (``bounded``, 3), or the
    +5 % simplex (``simplex``, ``n_names`` + 1)."""
    if method == "bounded":
        return 3
    if method == "simplex":
        return n_names + 1
    raise ValueError(f"screen_size: method {method!r} is not bounded|simplex")


def decision_margin(method: str, errors, n_names: int, tie: float,
                    penalty: float = np.inf) -> float | None:
    """Signed distance [N] of a fit step's threshold decision from its threshold ``tie`` (the
    standard error of the measured mean, :func:`flat_screen`'s floor), from the step's
    evaluation errors in logged order.  A pick (``choice``, :func:`choice_fit`): the start's
    error minus the best other's minus ``tie`` (>= 0: the other value is picked).  A search
    (``bounded``, ``simplex``): the spread of its first evaluations (the start and Brent's two
    golden-section points, or the +5 % simplex) minus ``tie`` (< 0: the screen ends it and the
    start is kept).  Every other outcome of a search moves continuously with the errors
    (:func:`harnesspipe.calibrate.simplex.rest_at_pick`); these two jump, so a margin within
    the runs' last-bits spread means another machine may decide the other way.  None: no such
    decision (no screen, too few or rejected evaluations)."""
    errors = np.asarray(errors, dtype=float)
    if tie <= 0.0:
        return None
    if method == "choice":
        if len(errors) < 2 or not np.all(errors < penalty):
            return None
        return float(errors[0] - errors[1:].min() - tie)
    n_first = screen_size(method, n_names)
    first = errors[:n_first]
    if len(first) < n_first or not np.all(first < penalty):
        return None
    return float(first.max() - first.min() - tie)
