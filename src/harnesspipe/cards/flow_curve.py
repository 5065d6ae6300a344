"""Eq. 2, sigma = sigma_Y + K eps_p^n, as the piecewise-linear table a solver card holds.

Solvers take the hardening law as points (eps_p, sigma) joined by straight lines.  The
chord of the concave power law lies below it; on [a, q a] its largest relative
deviation from K eps^n depends on q and n only (the law is scale-free), and the
constant sigma_Y makes the deviation from sigma smaller still.  So a geometric
sequence eps_k = eps_lo q^k, with the largest q whose chord deviation stays under the
tolerance, keeps the whole table within it from eps_lo to eps_max:

    max over t in [1, q] of  1 - (1 + (q^n - 1)(t - 1)/(q - 1)) / t^n  <=  tol.

The table starts at (0, sigma_Y), the first yield, as every solver requires; below
eps_lo the first segment is the chord from sigma_Y to sigma(eps_lo).  The law's slope
is infinite at eps_p = 0 for n < 1, so no finite table follows it there: eps_lo is
the start of the range the guarantee covers.  STRAIN_RANGE says why its default is
harmless for the three-point test.
"""
from __future__ import annotations

import math

import numpy as np

from harnesspipe.calibrate.hardening import flow_stresses

TOLERANCE = 0.005           # largest relative deviation of the table from eq. 2 on STRAIN_RANGE
# Plastic strains the table covers within TOLERANCE.  The ROM's flow-stress coordinates
# span 5e-4..5e-2, the strains of the 30 mm test (config rom.reference_strains); the
# range reaches 50x below and 20x above.  Below 1e-5 the plastic strain is under 0.1 %
# of the elastic strain at yield (sigma_Y / E = 0.8-4 % for Table 3): measured on the
# closed-tube CWB, a table starting at 1e-8 instead moves the CalculiX three-point force
# by 0.03 % at 30 mm (tests/test_cards_ccx.py module docstring).
STRAIN_RANGE = (1.0e-5, 1.0)
Q_MAX = 10.0                # coarsest ratio of consecutive strains (n = 1 is exact at any q)
_SAMPLES = 401              # points per interval on which a chord's deviation is evaluated


def flow_stress(eps_p, sigma_y: float, K: float, n: float) -> np.ndarray:
    """sigma_Y + K eps_p^n (eq. 2) at plastic strains ``eps_p``."""
    return np.asarray(flow_stresses(sigma_y, K, n, np.asarray(eps_p, dtype=float)))


def chord_deviation(q: float, n: float) -> float:
    """Largest relative shortfall of the chord of t^n on [1, q] below t^n."""
    t = np.linspace(1.0, q, _SAMPLES)
    chord = 1.0 + (q**n - 1.0) * (t - 1.0) / (q - 1.0)
    return float(np.max(1.0 - chord / t**n))


def geometric_ratio(n: float, tol: float = TOLERANCE) -> float:
    """Largest ratio q <= Q_MAX with chord_deviation(q, n) <= tol (bisection on ln q)."""
    if chord_deviation(Q_MAX, n) <= tol:
        return Q_MAX
    lo, hi = 0.0, math.log(Q_MAX)          # chord_deviation grows with q
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if chord_deviation(math.exp(mid), n) <= tol else (lo, mid)
    return math.exp(lo)


def tabulate(sigma_y: float, K: float, n: float, tol: float = TOLERANCE,
             strain_range: tuple[float, float] = STRAIN_RANGE) -> tuple[np.ndarray, np.ndarray]:
    """(eps_p, sigma) of the table: (0, sigma_Y), then eps_lo q^k up to and including
    eps_max, q = :func:`geometric_ratio` (module docstring)."""
    eps_lo, eps_max = strain_range
    if not 0.0 < eps_lo < eps_max:
        raise ValueError(f"strain range {strain_range}: need 0 < eps_lo < eps_max")
    q = geometric_ratio(n, tol)
    steps = math.ceil(math.log(eps_max / eps_lo) / math.log(q) - 1e-9)
    eps = np.concatenate(([0.0], np.geomspace(eps_lo, eps_max, steps + 1)))
    return eps, flow_stress(eps, sigma_y, K, n)
