"""Assembly of two-node element vectors and matrices into LAPACK band storage."""
from __future__ import annotations

from numba import njit

NDOF_NODE = 6


@njit(cache=True)
def scatter_pair(a, b, fe, Ke, f, band, bw):
    """Add a two-node vector and matrix to ``f`` and ``band`` (LAPACK band storage)."""
    for i in range(12):
        gi = NDOF_NODE * (a if i < 6 else b) + i % 6
        f[gi] += fe[i]
        for j in range(12):
            if Ke[i, j] != 0.0:
                gj = NDOF_NODE * (a if j < 6 else b) + j % 6
                band[bw + gi - gj, gj] += Ke[i, j]
