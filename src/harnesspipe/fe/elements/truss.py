"""Co-rotational truss (axial force only): the aramid strand H of the branch test (Sec. 5)."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def truss_response(xa, xb, L0, EA, f, K):
    """Co-rotational truss: axial force N = EA (l - L0)/L0 along e = (x_b - x_a)/l.

    f = N (-e, e) on the translations of a and b; K = EA/L0 e e^T + N/l (I - e e^T)
    in the (a, b) translational blocks (12-dof layout, rotations untouched).
    Returns N.
    """
    e = xb - xa
    length = np.sqrt(e[0] ** 2 + e[1] ** 2 + e[2] ** 2)
    e /= length
    N = EA * (length - L0) / L0
    for i in range(12):
        f[i] = 0.0
        for j in range(12):
            K[i, j] = 0.0
    for i in range(3):
        f[i] = -N * e[i]
        f[6 + i] = N * e[i]
        for j in range(3):
            k = EA / L0 * e[i] * e[j] + N / length * ((1.0 if i == j else 0.0) - e[i] * e[j])
            K[i, j] = k
            K[6 + i, 6 + j] = k
            K[i, 6 + j] = -k
            K[6 + i, j] = -k
    return N
