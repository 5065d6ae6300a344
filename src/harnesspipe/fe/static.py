"""Implicit static path following: Newton-Raphson with line search and adaptive steps.

The solver knows nothing of beams or contact.  It drives a *problem* object that
owns the state and the physics and provides:

``bandwidth``                half bandwidth of the tangent (LAPACK band storage)
``set_load(lam)``            impose the loading (prescribed motions, loads) at factor lam;
                             prescribed displacements are best applied through the first
                             correction (``r += K du_p``, then ``update`` adds ``du_p``),
                             the linear predictor that avoids a kinked first iterate
``evaluate(want_tangent)``   ``(r, ref, band)``: residual (internal minus external force)
                             with constrained rows zeroed, a force scale ``ref`` for the
                             convergence test and the tangent in band storage
                             (``band[bw + i - j, j] = K[i, j]``, identity on constrained dofs)
``update(du)``               add a correction to the free unknowns
``commit()`` / ``revert()``  accept the current state / return to the last accepted one
``describe(lam)``            the loading at lam in words, for error messages
``accept()`` (optional)      after convergence: False if the problem changed an active
                             set (e.g. released a contact), so the increment is repeated

Convergence needs both the force norm ``|r| <= tol_force * ref`` and the energy norm
``|du . r| <= tol_energy * (du_1 . r_0)`` (Bathe 2014, sec. 8.4).  The line search
is the secant search on ``s(eta) = du . r(u + eta du)`` of Crisfield (1991, sec. 9.3).
Between the requested output points (``stops``) the step is halved on failure and
doubled again after quick convergence.

Predictor (``extrapolate``): each increment starts from the converged state plus the
previous increment's correction scaled to the new step (linear extrapolation of the
path, Crisfield 1991, sec. 9.4.2); a failed extrapolated attempt is retried from the
converged state before the step is cut.  The energy reference of an extrapolated
increment is the larger of its first correction's and the previous increment's
(scaled by the step ratio squared), so a good predictor does not tighten the test.
The banded tangent is factorised by LAPACK ``dgbsv`` (partial pivoting) directly.
A correction whose energy already passes the test is expected to be the last one:
its residual is evaluated without the tangent (which would go unused), and the
tangent is evaluated after all only if the force test then fails.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.linalg import lapack


class ConvergenceError(RuntimeError):
    """Raised when an increment cannot be completed even with the smallest step."""

    def __init__(self, increment: int, target: str, residuals, last_converged: str):
        self.increment = increment
        self.residuals = list(residuals)
        self.last_converged = last_converged
        hist = ", ".join(f"{x:.3e}" for x in self.residuals) or "none"
        super().__init__(
            f"Newton-Raphson did not converge at increment {increment} (towards {target}); "
            f"relative residual history of the last attempt: [{hist}]; "
            f"last converged state: {last_converged}")


class _NotConverged(Exception):
    def __init__(self, residuals):
        super().__init__()
        self.residuals = residuals


@dataclass(frozen=True)
class NewtonSettings:
    tol_force: float = 1.0e-6      # |r| / ref
    tol_energy: float = 1.0e-12    # |du . r| / (first iteration's)
    max_iter: int = 25
    line_search: bool = True
    ls_ratio: float = 0.8          # search when |s(1)| > ls_ratio |s(0)|
    ls_max: int = 4
    quick: int = 4                 # iterations counted as quick convergence (step grows)
    min_fraction: float = 1.0 / 256  # smallest step, as a fraction of the stop spacing
    max_set_changes: int = 3       # repeats of an increment after active-set changes
    extrapolate: bool = True       # predictor from the previous increment


@njit(cache=True)
def constrain_band(band, r, fixed, bw):
    """Zero the rows and columns of the ``fixed`` dofs (unit diagonal) and their residuals."""
    n = r.shape[0]
    for i in fixed:
        for j in range(max(0, i - bw), min(n, i + bw + 1)):
            band[bw + i - j, j] = 0.0
            band[bw + j - i, i] = 0.0
        band[bw, i] = 1.0
        r[i] = 0.0


@njit(cache=True)
def band_matvec(band, x, bw, out):
    """out += K x for K in band storage."""
    n = x.shape[0]
    for j in range(n):
        if x[j] != 0.0:
            for i in range(max(0, j - bw), min(n, j + bw + 1)):
                out[i] += band[bw + i - j, j] * x[j]


class _BandSolver:
    """Solve K du = -r with K in LAPACK band storage, through ``dgbsv`` (work kept)."""

    def __init__(self, bw: int, n: int):
        self.bw = bw
        self.ab = np.zeros((3 * bw + 1, n), order="F")  # bw extra rows for the LU fill-in

    def __call__(self, band, r):
        if self.ab.shape[1] != r.shape[0]:
            self.ab = np.zeros((3 * self.bw + 1, r.shape[0]), order="F")
        self.ab[self.bw:] = band
        _, _, du, info = lapack.dgbsv(self.bw, self.bw, self.ab, -r,
                                      overwrite_ab=True, overwrite_b=True)
        if info != 0 or not np.all(np.isfinite(du)):
            raise np.linalg.LinAlgError("singular tangent")
        return du


def newton(problem, lam: float, s: NewtonSettings) -> int:
    """Equilibrium at load factor ``lam`` from the last committed state; returns iterations."""
    return _increment(problem, lam, s, None, 0.0, {})[0]


def _increment(problem, lam, s, predictor, energy_ref, work):
    """Newton iterations at ``lam`` from the committed state (+ ``predictor``).

    ``work`` keeps the band solver and ``work["applied"]``, the total change of the
    unknowns.  ``energy_ref`` is a lower bound of the energy reference.  Returns
    (iterations, energy reference).
    """
    problem.revert()
    problem.set_load(lam)
    if predictor is not None:
        problem.update(predictor)
    r, ref, band = problem.evaluate(True)
    if "solver" not in work:
        work["solver"] = _BandSolver(problem.bandwidth, r.shape[0])
        work["applied"] = np.zeros(r.shape[0])
    solver, applied = work["solver"], work["applied"]
    applied[:] = 0.0 if predictor is None else predictor
    history = [np.sqrt(r @ r) / ref]
    if history[0] <= s.tol_force:
        return 0, energy_ref
    e0 = None
    for it in range(1, s.max_iter + 1):
        try:
            du = solver(band, r)
        except np.linalg.LinAlgError:  # singular tangent: lost support or collapse
            raise _NotConverged(history) from None
        s0 = du @ r
        # the energy test of this correction is known before the residual: when it
        # passes, the increment is expected to converge here and the tangent is skipped
        likely_last = e0 is not None and abs(s0) <= s.tol_energy * e0
        problem.update(du)
        r_new, ref, band = problem.evaluate(not likely_last)
        eta = 1.0
        if s.line_search and abs(du @ r_new) > s.ls_ratio * abs(s0):
            eta = _line_search(problem, du, s0, du @ r_new, s)
            r_new, ref, band = problem.evaluate(True)
            likely_last = False
        applied += eta * du
        energy = abs(eta * s0)
        e0 = max(energy, energy_ref) if e0 is None else e0
        r = r_new
        rel = np.sqrt(r @ r) / ref
        history.append(rel)
        if not np.isfinite(rel) or rel > 1.0e8:
            raise _NotConverged(history)
        if rel <= s.tol_force and energy <= s.tol_energy * max(e0, 1e-300):
            return it, e0
        if likely_last:  # not converged after all: the tangent is needed
            r, ref, band = problem.evaluate(True)
    raise _NotConverged(history)


def _line_search(problem, du, s0, s1, s: NewtonSettings) -> float:
    """Secant search for a root of s(eta) = du . r(u + eta du) in [0.1, 1]; state ends at eta."""
    eta_prev, s_prev = 0.0, s0
    eta, s_eta = 1.0, s1
    for _ in range(s.ls_max):
        if abs(s_eta) <= s.ls_ratio * abs(s0) or s_eta == s_prev:
            break
        eta_new = eta - s_eta * (eta - eta_prev) / (s_eta - s_prev)
        eta_new = min(max(eta_new, 0.1), 1.0)
        if abs(eta_new - eta) < 1e-3:
            break
        problem.update((eta_new - eta) * du)
        eta_prev, s_prev = eta, s_eta
        eta = eta_new
        r, _, _ = problem.evaluate(False)
        s_eta = du @ r
    return eta


def follow_path(problem, stops, settings: NewtonSettings = NewtonSettings(), on_stop=None) -> int:
    """Go from load factor 0 through every value of ``stops`` (increasing, in (0, 1]).

    ``on_stop(lam)`` is called after each stop is reached and committed.  Returns the
    number of increments used; raises :class:`ConvergenceError` when the step would
    fall below ``min_fraction`` of the stop spacing.
    """
    stops = np.asarray(stops, dtype=float)
    spacing = float(np.min(np.diff(np.concatenate(([0.0], stops)))))
    step = spacing
    lam = 0.0
    increment = 0
    work = {}
    last = None              # (previous increment's change of the unknowns, its step, energy)
    for target in stops:
        while lam < target - 1e-12 * spacing:
            trial = min(lam + step, target)
            increment += 1
            predictor, e_ref = None, 0.0
            if settings.extrapolate and last is not None:
                ratio = (trial - lam) / last[1]
                predictor, e_ref = ratio * last[0], ratio * ratio * last[2]
            try:
                try:
                    iterations, e0 = _increment(problem, trial, settings, predictor, e_ref, work)
                except _NotConverged:
                    if predictor is None:
                        raise
                    predictor, e_ref = None, 0.0      # retry from the converged state
                    iterations, e0 = _increment(problem, trial, settings, None, 0.0, work)
                for _ in range(settings.max_set_changes):
                    if getattr(problem, "accept", lambda: True)():
                        break
                    iterations, e0 = _increment(problem, trial, settings, predictor, e_ref, work)
            except _NotConverged as exc:
                problem.revert()
                step = 0.5 * (trial - lam)
                if step < settings.min_fraction * spacing:
                    raise ConvergenceError(increment, problem.describe(trial), exc.residuals,
                                           problem.describe(lam)) from None
                continue
            problem.commit()
            last = (work["applied"].copy(), trial - lam, e0)
            if iterations <= settings.quick:
                step = min(2.0 * step, spacing)
            lam = trial
        if on_stop is not None:
            on_stop(lam)
    return increment
