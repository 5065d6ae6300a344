"""Isotropic power-law hardening of eq. 2 and its scalar return mapping.

Eq. 2:  sigma_bar = sigma_Y + K * (eps_bar_p)**n   once sigma_bar >= sigma_Y.

For n < 1 the slope  K n eps_p**(n-1)  is infinite at eps_p = 0.  The slope is
therefore evaluated at ``max(eps_p, EPS_P_FLOOR)``; the flow stress itself is
always exact.  The plastic increment is found by a bracketed Newton iteration
(bisection fallback), which never evaluates the slope at zero.
"""
from __future__ import annotations

from numba import njit

EPS_P_FLOOR = 1.0e-12  # smallest plastic strain at which the hardening slope is taken
RETURN_TOL = 1.0e-12   # relative tolerance on the yield function in the return mapping
RETURN_MAXIT = 60


@njit(cache=True)
def flow_stress(eps_p, sigma_y, K, n):
    """Flow stress sigma_Y + K eps_p**n (eq. 2)."""
    if eps_p <= 0.0:
        return sigma_y
    return sigma_y + K * eps_p**n


@njit(cache=True)
def hardening_slope(eps_p, K, n):
    """d(flow stress)/d(eps_p) = K n eps_p**(n-1), with eps_p floored at EPS_P_FLOOR."""
    if K == 0.0:
        return 0.0
    e = eps_p if eps_p > EPS_P_FLOOR else EPS_P_FLOOR
    return K * n * e ** (n - 1.0)


@njit(cache=True)
def plastic_increment(q_trial, c, eps_p_old, sigma_y, K, n):
    """Solve  q_trial - c*dg = flow_stress(eps_p_old + dg)  for dg >= 0.

    ``q_trial`` is the trial equivalent stress and ``c`` the elastic stiffness
    conjugate to it: ``E`` for a uniaxial fibre, ``3G`` for the 3D radial return.
    Returns 0 if the trial state is elastic.  The root is bracketed in
    [0, (q_trial - sigma_Y)/c], so the iteration cannot leave the admissible range.
    """
    f0 = q_trial - flow_stress(eps_p_old, sigma_y, K, n)
    if f0 <= 0.0:
        return 0.0
    lo = 0.0
    hi = (q_trial - sigma_y) / c
    dg = hi if K == 0.0 else 0.5 * hi
    scale = q_trial if q_trial > 1.0 else 1.0
    for _ in range(RETURN_MAXIT):
        ep = eps_p_old + dg
        f = q_trial - c * dg - flow_stress(ep, sigma_y, K, n)
        if abs(f) <= RETURN_TOL * scale:
            return dg
        if f > 0.0:
            lo = dg
        else:
            hi = dg
        df = -c - hardening_slope(ep, K, n)
        step = dg - f / df
        dg = step if lo < step < hi else 0.5 * (lo + hi)
    return dg
