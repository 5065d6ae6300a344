"""Isotropic power-law hardening of eq. 2 and its scalar return mapping.

Eq. 2:  sigma_bar = sigma_Y + K * (eps_bar_p)**n   once sigma_bar >= sigma_Y.

For n < 1 the slope  K n eps_p**(n-1)  is infinite at eps_p = 0.  The slope is
therefore evaluated at ``max(eps_p, EPS_P_FLOOR)``; the flow stress itself is
always exact.

Return mapping.  With ``A = q_trial - sigma_Y + c eps_p_old`` the consistency
condition ``q_trial - c dg = sigma_bar(eps_p_old + dg)`` reads, for the total
plastic strain ``e = eps_p_old + dg``,

    h = A - c e - K e**n = 0.

For n < 1 it is solved for ``s = e**n`` instead (``e = s**m``, ``m = 1/n``): then
``h(s) = A - K s - c s**m`` is smooth at the virgin state (slope -K, not
infinite) and, like ``h(e)`` for n > 1, concave and decreasing.  Its curvature
``h'' = -c m (m - 1) e / s**2`` comes with its slope ``h' = -(K + c m e / s)``, no
power needed, so every step left of the root (h > 0, where the iteration starts)
is Halley's, ``ds = (h / -h') / (1 + h h'' / (2 h'^2))``: cubic, and shorter than
Newton's, which would overshoot the concave root.  A step right of the root
(h < 0) is Newton's, which from there converges monotonically; a clamp to the
admissible interval guards round-off, so no bracketing or bisection is needed.
For the small increments of an explicit step one Halley step mostly meets the
tolerance: 1.0-1.9 powers per return against 2.0-3.4 for Newton from the same
start (wires, tape and tube at strain increments 1e-8 to 1e-6).  The start
``e = eps_p_old`` itself needs no power.  Each power is taken as ``exp(p log x)``.
For n > 1 (no material of the paper) the unknown is ``e``, solved by Newton.
"""
from __future__ import annotations

import numpy as np
from numba import njit

EPS_P_FLOOR = 1.0e-12  # smallest plastic strain at which the hardening slope is taken
RETURN_TOL = 1.0e-12   # relative tolerance on the yield function in the return mapping
RETURN_MAXIT = 60


@njit(cache=True)
def positive_pow(x, p):
    """x**p for x > 0 (exp/log form: one transcendental pair, no special cases)."""
    return np.exp(p * np.log(x))


@njit(cache=True)
def flow_stress(eps_p, sigma_y, K, n):
    """Flow stress sigma_Y + K eps_p**n (eq. 2)."""
    if eps_p <= 0.0:
        return sigma_y
    return sigma_y + K * positive_pow(eps_p, n)


@njit(cache=True)
def hardening_slope(eps_p, K, n):
    """d(flow stress)/d(eps_p) = K n eps_p**(n-1), with eps_p floored at EPS_P_FLOOR."""
    if K == 0.0:
        return 0.0
    e = eps_p if eps_p > EPS_P_FLOOR else EPS_P_FLOOR
    return K * n * positive_pow(e, n - 1.0)


@njit(cache=True)
def return_map(q_trial, c, eps_p_old, sigma_y, K, n):
    """Plastic increment and hardening slope: ``(dg, H(eps_p_old + dg))``.

    Solves ``q_trial - c*dg = flow_stress(eps_p_old + dg)`` for ``dg >= 0`` (see the
    module docstring); ``dg = 0`` (and ``H = 0``) when the trial state is elastic.
    ``c`` is the elastic stiffness conjugate to ``q_trial``: ``E`` for a uniaxial
    fibre, ``3G`` for the 3D radial return.  ``H`` is :func:`hardening_slope` at the
    returned state, obtained without another power.
    """
    a = eps_p_old
    sa = positive_pow(a, n) if (a > 0.0 and K != 0.0) else 0.0   # a**n
    dg, H, _ = return_map_from(q_trial, c, a, sa, sigma_y, K, n)
    return dg, H


@njit(cache=True, inline="always")
def _halley_step(h, K, c, m, s, e):
    """The step in ``s`` of the return map for n < 1 at ``h = h(s)``, ``e = s**m`` (module
    docstring): Halley's left of the root (h > 0), Newton's right of it; Newton's with
    slope -K at the virgin state s = 0."""
    if s <= 0.0:
        return h / K
    g = c * m * e / s                   # c m s**(m-1)
    dh = K + g                          # -h'(s)
    ds = h / dh                         # Newton's step
    if h > 0.0:
        ds /= 1.0 + 0.5 * ds * g * (m - 1.0) / (s * dh)    # -h''(s) = g (m - 1) / s
    return ds


@njit(cache=True)
def return_map_from(q_trial, c, eps_p_old, sa, sigma_y, K, n):
    """:func:`return_map` from a stored ``sa = eps_p_old**n`` (a history variable: the
    flow stress ``sigma_Y + K sa`` then needs no power); returns ``(dg, H, sa_new)``,
    ``sa_new = (eps_p_old + dg)**n`` (``sa`` itself when elastic)."""
    a = eps_p_old
    f0 = q_trial - sigma_y - K * sa
    if f0 <= 0.0:
        return 0.0, 0.0, sa
    if K == 0.0:
        return f0 / c, 0.0, 0.0
    if n == 1.0:
        dg = f0 / (c + K)
        return dg, K, a + dg
    A = f0 + K * sa + c * a
    tol = RETURN_TOL * (q_trial if q_trial > 1.0 else 1.0)
    if n < 1.0:
        m = 1.0 / n
        s = sa                          # unknown s = e**n, h(s) = A - K s - c s**m
        hi = A / K                      # h(hi) < 0
        e = a                           # = sa**m, the committed pair
        for _ in range(RETURN_MAXIT):
            h = A - K * s - c * e
            if abs(h) <= tol:
                break
            s = min(max(s + _halley_step(h, K, c, m, s, e), sa), hi)
            e = positive_pow(s, m) if s > 0.0 else 0.0     # (e, s) stay a pair, converged or not
        dg = e - a if e > a else 0.0
        if e <= EPS_P_FLOOR:
            return dg, hardening_slope(e, K, n), s
        return dg, K * n * s / e, s     # K n e**(n-1) with s = e**n
    e = a                               # n > 1: unknown e, h(e) = A - c e - K e**n
    hi = a + f0 / c                     # h(hi) <= 0
    se = sa
    for _ in range(RETURN_MAXIT):
        h = A - c * e - K * se
        if abs(h) <= tol:
            break
        dh = c + (K * n * se / e if e > 0.0 else 0.0)
        e = min(max(e + h / dh, a), hi)
        se = positive_pow(e, n)
    return e - a, hardening_slope(e, K, n), se
