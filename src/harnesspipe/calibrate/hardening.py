"""Flow-stress coordinates of the eq. 2 hardening law for simplex searches.

sigma_Y, K and n of eq. 2 are strongly correlated in a force-displacement curve
(a lower sigma_Y is nearly undone by a smaller n), and Nelder-Mead stalls in the
narrow valley they form.  The flow stresses s_i = sigma_Y + K eps_i^n at three
plastic strains eps_0 < eps_1 < eps_2 in geometric progression (ratio q)
describe the same family of curves, one to one, in nearly uncorrelated
coordinates:

    n = ln((s_2 - s_1) / (s_1 - s_0)) / ln q,   K = (s_1 - s_0) / (eps_0^n (q^n - 1)),
    sigma_Y = s_0 - K eps_0^n,

admissible for s_0 < s_1 < s_2 with 0 < n <= N_MAX and sigma_Y > 0.  With
sigma_Y known, two flow stresses fix (K, n).  N_MAX = 1 keeps the hardening
concave, as in every set of Tables 1-3; without it, noisy curves of weakly
hardening bundles are fitted by degenerate laws (n ~ 7, K ~ 1e7).
"""
from __future__ import annotations

import math

N_MAX = 1.0  # largest admissible hardening exponent (concave hardening)


def flow_stresses(sigma_y, K, n, eps_ref):
    """Eq. 2 flow stresses sigma_Y + K eps^n at each reference plastic strain."""
    return tuple(sigma_y + K * e**n for e in eps_ref)


def hardening_from_three(s, eps_ref):
    """(sigma_Y, K, n) through three flow stresses at geometric strains, or None."""
    (s0, s1, s2), eps0, q = s, eps_ref[0], eps_ref[1] / eps_ref[0]
    if not 0.0 < s0 < s1 < s2:
        return None
    n = math.log((s2 - s1) / (s1 - s0)) / math.log(q)
    if not 0.0 < n <= N_MAX:
        return None
    K = (s1 - s0) / (eps0**n * (q**n - 1.0))
    sigma_y = s0 - K * eps0**n
    return (sigma_y, K, n) if sigma_y > 0.0 else None


def hardening_from_two(sigma_y, s, eps_ref):
    """(sigma_Y, K, n) through two flow stresses with sigma_Y given, or None."""
    (s1, s2), (e1, e2) = s, eps_ref
    if not 0.0 < sigma_y < s1 < s2:
        return None
    n = math.log((s2 - sigma_y) / (s1 - sigma_y)) / math.log(e2 / e1)
    if not 0.0 < n <= N_MAX:
        return None
    return sigma_y, (s1 - sigma_y) / e1**n, n
