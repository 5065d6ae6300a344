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
The banded tangent is factorised by :func:`band_lu_solve`, Gaussian elimination with
partial pivoting in band storage (the algorithm of LAPACK ``dgbtf2``/``dgbtrs``), in
one Numba call per correction.
A correction whose energy already passes the test is expected to be the last one:
its residual is evaluated without the tangent (which would go unused), and the
tangent is evaluated after all only if the force test then fails.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit


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


PIVOT_TOL = 1.0e-12  # smallest pivot of the equilibrated tangent (its diagonal is +-1)


@njit(cache=True)
def band_lu_solve(band, r, bw, lu, ipiv, scale, du):
    """Solve ``K du = -r`` for K in band storage (half bandwidth ``bw``); True on success.

    The system is first equilibrated symmetrically, ``(D K D) y = -D r`` with ``du = D y``
    and ``D = diag(|K_jj|^-1/2)`` in ``scale`` (n): beam rows mix forces and moments of
    very different size, and without it partial pivoting swaps rows in about half the
    columns (fill-in doubles the work).  Then Gaussian elimination with partial
    pivoting in band storage (Golub & Van Loan 2013, sec. 3.5.2 and 4.3; the algorithm
    of LAPACK ``dgbtf2`` + ``dgbtrs``).
    ``lu`` (n x (3 bw + 1)) holds column j of the band contiguously in ``lu[j]``:
    ``A(i, j) = lu[j, 2 bw + i - j]``, K in the last 2 bw + 1 entries and bw more for
    the fill-in of the interchanges; ``ipiv`` (n) receives the pivot rows.  ``band``
    and ``r`` are not changed.  False for a singular tangent: a pivot of the
    equilibrated matrix (unit diagonal) below ``PIVOT_TOL`` -- twelve digits lost, as
    past a plastic collapse -- or a solution that is not finite.
    """
    n = r.shape[0]
    kv = 2 * bw
    for j in range(n):                       # equilibration: d_j = |K_jj|^-1/2
        d = abs(band[bw, j])
        scale[j] = 1.0 / np.sqrt(d) if d > 0.0 else 1.0
    for j in range(n):                       # lu <- D K D
        for k in range(bw):
            lu[j, k] = 0.0
        for k in range(2 * bw + 1):
            i = j + k - bw
            lu[j, bw + k] = band[k, j] * scale[j] * scale[i] if 0 <= i < n else 0.0
    ju = 0
    for j in range(n):
        km = min(bw, n - 1 - j)
        col = lu[j]
        jp = j
        big = abs(col[kv])
        for i in range(j + 1, j + km + 1):
            if abs(col[kv + i - j]) > big:
                big = abs(col[kv + i - j])
                jp = i
        ipiv[j] = jp
        if big <= PIVOT_TOL:                 # singular to working precision
            return False
        ju = max(ju, min(jp + bw, n - 1))
        if jp != j:
            for c in range(j, ju + 1):
                t = lu[c, kv + j - c]
                lu[c, kv + j - c] = lu[c, kv + jp - c]
                lu[c, kv + jp - c] = t
        piv = col[kv]
        coupled = False
        for k in range(kv + 1, kv + km + 1):
            col[k] /= piv
            coupled |= col[k] != 0.0
        if not coupled:                       # e.g. a constrained dof: nothing to eliminate
            continue
        for c in range(j + 1, ju + 1):
            o = kv + j - c                    # A(j, c) = lu[c, o]; A(i, c) = lu[c, o + i - j]
            a_jc = lu[c, o]
            if a_jc != 0.0:
                for k in range(1, km + 1):
                    lu[c, o + k] -= col[kv + k] * a_jc
    for i in range(n):
        du[i] = -r[i] * scale[i]
    for j in range(n):                       # L: interchanges and multipliers
        jp = ipiv[j]
        if jp != j:
            t = du[j]
            du[j] = du[jp]
            du[jp] = t
        for k in range(1, min(bw, n - 1 - j) + 1):
            du[j + k] -= lu[j, kv + k] * du[j]
    for j in range(n - 1, -1, -1):           # U: upper bandwidth 2 bw after the fill-in
        du[j] /= lu[j, kv]
        if not np.isfinite(du[j]):
            return False
        for i in range(max(0, j - kv), j):
            du[i] -= lu[j, kv + i - j] * du[j]
    for i in range(n):
        du[i] *= scale[i]
    return True


class _BandSolver:
    """Solve K du = -r with K in band storage through :func:`band_lu_solve` (work kept)."""

    def __init__(self, bw: int, n: int):
        self.bw = bw
        self.lu = np.empty((n, 3 * bw + 1))
        self.ipiv = np.empty(n, dtype=np.int64)
        self.scale = np.empty(n)

    def __call__(self, band, r):
        n = r.shape[0]
        if self.lu.shape[0] != n:
            self.lu = np.empty((n, 3 * self.bw + 1))
            self.ipiv = np.empty(n, dtype=np.int64)
            self.scale = np.empty(n)
        du = np.empty(n)
        if not band_lu_solve(band, r, self.bw, self.lu, self.ipiv, self.scale, du):
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
