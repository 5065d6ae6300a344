"""Implicit Newmark time stepping with a lumped mass and banded tangents (branch ROM, Sec. 5).

The integrator drives a *problem* that owns the state and the physics, like the
static solver of :mod:`harnesspipe.fe.solvers.static`:

``ndof``, ``bandwidth``, ``mass``  number of dofs, half bandwidth, lumped mass diagonal
``fixed``                          constrained dofs (sorted); their motion is the problem's
``begin_step(t, rates)``           impose the prescribed motion at t and hand the Newmark
                                   relations (:class:`Rates`) to rate-dependent elements;
                                   returns the prescribed increment over the step (ndof)
``evaluate()``                     ``(f_int, band)``: internal force (incl. damping) and its
                                   tangent w.r.t. the displacement in band storage
``update(du)``                     add a displacement (rotations: spatial spin) increment
``commit()`` / ``revert()``        accept the step / return to the last accepted state

Newmark relations on the step increment du = u_{n+1} - u_n (rotations as spins):

    a_{n+1} = (du - dt v_n - dt^2 (1/2 - beta) a_n) / (beta dt^2)
    v_{n+1} = v_n + dt ((1 - gamma) a_n + gamma a_{n+1})

and Newton on  M a_{n+1} + f_int = 0  with the iteration matrix
K_t + M / (beta dt^2).  gamma = 1/2, beta = 1/4 (average acceleration) adds no
numerical damping; gamma > 1/2 with beta = (gamma + 1/2)^2 / 4 damps the modes with
omega dt >> 1 (Hughes 2000, sec. 9.1).  Rate-dependent elements apply the same
relations to their own deformation measures (``rate_coefficients``).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.linalg import solve_banded

from harnesspipe.fe.solvers.static import constrain_band


class DynamicConvergenceError(RuntimeError):
    """Newton iterations of a time step did not converge."""


@dataclass(frozen=True)
class NewmarkSettings:
    gamma: float = 0.5
    beta: float = 0.25
    tol_force: float = 1.0e-6      # |r_free| / force scale
    tol_du: float = 1.0e-9         # |delta du| / (|du| + length scale)
    max_iter: int = 20


class Rates(NamedTuple):
    """Newmark relations of a step, for any quantity x (nodal dof or element measure):

    x_dot_{n+1}  = c_d (x_{n+1} - x_n) + c_v x_dot_n + c_a x_ddot_n
    x_ddot_{n+1} = a_d (x_{n+1} - x_n) + a_v x_dot_n + a_a x_ddot_n
    """
    c_d: float
    c_v: float
    c_a: float
    a_d: float
    a_v: float
    a_a: float


def rate_coefficients(dt: float, s: NewmarkSettings) -> Rates:
    g, b = s.gamma, s.beta
    return Rates(g / (b * dt), 1.0 - g / b, dt * (1.0 - g / (2.0 * b)),
                 1.0 / (b * dt**2), -1.0 / (b * dt), 1.0 - 1.0 / (2.0 * b))


def time_grid(duration: float, n_steps: int, dt_min: float) -> np.ndarray:
    """Times 0 = t_0 < ... < t_n = duration with steps growing geometrically from ``dt_min``.

    Fine steps where a Kelvin-Voigt transient starts, coarse ones later; the ratio
    q solves dt_min (q^n - 1) / (q - 1) = duration (uniform if dt_min = duration / n).
    """
    if not (duration > 0.0 and n_steps >= 1 and 0.0 < dt_min <= duration / n_steps):
        raise ValueError(f"need duration > 0, n_steps >= 1, 0 < dt_min <= duration/n_steps; "
                         f"got {duration}, {n_steps}, {dt_min}")
    lo, hi = 1.0, 2.0
    while dt_min * (hi**n_steps - 1.0) / (hi - 1.0) < duration:
        hi *= 2.0
    for _ in range(200):
        q = 0.5 * (lo + hi)
        if q == 1.0 or dt_min * (q**n_steps - 1.0) / (q - 1.0) < duration:
            lo = q
        else:
            hi = q
    steps = dt_min * hi ** np.arange(n_steps)
    return np.concatenate(([0.0], np.cumsum(steps * duration / steps.sum())))


def integrate(problem, times, settings: NewmarkSettings = NewmarkSettings(), on_step=None,
              length_scale: float = 1.0, force_floor: float = 1.0e-12) -> int:
    """Step the problem from rest through ``times``; ``on_step(t)`` after each committed step.

    Returns the total number of Newton iterations.  Raises
    :class:`DynamicConvergenceError` with the residual history.
    """
    n, bw, M = problem.ndof, problem.bandwidth, problem.mass
    free = np.setdiff1d(np.arange(n), problem.fixed)
    v, a = np.zeros(n), np.zeros(n)
    total = 0
    for t_old, t in zip(times[:-1], times[1:]):
        dt = t - t_old
        du_fixed = problem.begin_step(t, rate_coefficients(dt, settings))
        du = np.zeros(n)
        du[free] = dt * v[free] + 0.5 * dt**2 * a[free]   # predictor a_{n+1} = a_n
        du[problem.fixed] = du_fixed[problem.fixed]
        problem.update(du)
        a_new, history = _newton_step(problem, du, v, a, t, dt, M, free, bw, settings,
                                      length_scale, force_floor)
        total += len(history)
        v = v + dt * ((1.0 - settings.gamma) * a + settings.gamma * a_new)
        a = a_new
        problem.commit()
        if on_step is not None:
            on_step(t)
    return total


def _newton_step(problem, du, v, a, t, dt, M, free, bw, s, length_scale, force_floor):
    """Newton iterations on the step increment ``du`` (updated in place); returns a_{n+1}."""
    b = s.beta
    history = []
    for _ in range(s.max_iter):
        a_new = (du - dt * v - dt**2 * (0.5 - b) * a) / (b * dt**2)
        a_new[problem.fixed] = 0.0
        f_int, band = problem.evaluate()
        r = M * a_new + f_int
        scale = max(np.linalg.norm(f_int), force_floor)
        band[bw, free] += M[free] / (b * dt**2)
        constrain_band(band, r, problem.fixed, bw)
        ddu = -solve_banded((bw, bw), band, r, overwrite_ab=True, check_finite=False)
        history.append(np.linalg.norm(r) / scale)
        if history[-1] <= s.tol_force and \
                np.linalg.norm(ddu) <= s.tol_du * (np.linalg.norm(du) + length_scale):
            return a_new, history
        problem.update(ddu)
        du += ddu
    problem.revert()
    raise DynamicConvergenceError(
        f"Newmark step to t = {t:.6g} s did not converge in {s.max_iter} iterations; "
        f"relative residuals {['%.2e' % h for h in history]}; last converged time "
        f"{t - dt:.6g} s")
