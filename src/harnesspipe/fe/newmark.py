"""Implicit Newmark integration in physical time (for the branch ROM, Sec. 5).

Solves  M a + f_int(u, v) = f_ext(t)  with the Newmark relations

    u_{n+1} = u_n + dt v_n + dt^2 [(1/2 - beta) a_n + beta a_{n+1}]
    v_{n+1} = v_n + dt [(1 - gamma) a_n + gamma a_{n+1}]

and Newton iterations on a_{n+1}.  The default beta = 1/4, gamma = 1/2 (average
acceleration, trapezoidal rule) is unconditionally stable for linear systems,
second-order accurate and adds no numerical damping: an undamped linear
oscillator keeps its energy exactly (up to round-off), so all dissipation in a
run comes from the physical damping C = alpha K (eq. 15).  gamma > 1/2 with
beta = (gamma + 1/2)^2 / 4 adds algorithmic high-frequency damping.

The residual is supplied by the model as ``residual(u, v) -> (f_int, K_t, C_t)``
(internal force, tangent stiffness and tangent damping); the model's kernels do
the element work, this module only the time stepping.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


class DynamicConvergenceError(RuntimeError):
    """Newton iterations of a time step did not converge."""


@dataclass
class NewmarkParameters:
    beta: float = 0.25
    gamma: float = 0.5
    tol: float = 1e-9      # relative residual tolerance
    max_iter: int = 25


def newmark(M, residual, f_ext, u0, v0, dt, n_steps, params=None,
            fixed=None, prescribed=None):
    """Integrate ``n_steps`` steps; returns (t, U, V, A) histories.

    ``fixed``: indices of DOFs with prescribed motion; ``prescribed(t) -> (u, v, a)``
    of those DOFs.  ``f_ext(t)`` returns the external load vector.
    """
    params = params or NewmarkParameters()
    beta, gamma = params.beta, params.gamma
    n = u0.size
    free = np.setdiff1d(np.arange(n), fixed if fixed is not None else [])
    u, v = u0.astype(float).copy(), v0.astype(float).copy()
    fi, K, C = residual(u, v)
    a = np.zeros(n)
    a[free] = np.linalg.solve(M[np.ix_(free, free)], (f_ext(0.0) - fi)[free])
    t_hist, U, V, A = [0.0], [u.copy()], [v.copy()], [a.copy()]
    for step in range(1, n_steps + 1):
        t = step * dt
        u_pred = u + dt * v + dt**2 * (0.5 - beta) * a
        v_pred = v + dt * (1.0 - gamma) * a
        a_new = a.copy()
        if fixed is not None:
            up, vp, ap = prescribed(t)
            a_new[fixed] = ap
        history = []
        for it in range(params.max_iter):
            u_new = u_pred + beta * dt**2 * a_new
            v_new = v_pred + gamma * dt * a_new
            if fixed is not None:
                u_new[fixed], v_new[fixed] = up, vp
            fi, K, C = residual(u_new, v_new)
            r = (f_ext(t) - fi - M @ a_new)[free]
            scale = max(np.linalg.norm(f_ext(t)[free]), np.linalg.norm(fi[free]), 1e-12)
            history.append(np.linalg.norm(r) / scale)
            if history[-1] < params.tol:
                break
            S = M + gamma * dt * C + beta * dt**2 * K
            a_new[free] += np.linalg.solve(S[np.ix_(free, free)], r)
        else:
            raise DynamicConvergenceError(
                f"Newmark step {step} (t = {t:.6g} s) did not converge in {params.max_iter} "
                f"iterations; relative residuals {['%.2e' % h for h in history]}; "
                f"last converged time {t - dt:.6g} s")
        u, v, a = u_new, v_new, a_new
        t_hist.append(t)
        U.append(u.copy())
        V.append(v.copy())
        A.append(a.copy())
    return np.array(t_hist), np.array(U), np.array(V), np.array(A)
