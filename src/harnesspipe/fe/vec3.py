"""Arithmetic on 3-vectors stored in the first three entries of an array row, for the
Numba kernels (no allocation; results written into ``out`` arguments).
"""
from __future__ import annotations

import math

from numba import njit

from harnesspipe.fe.loops import loop_kernel


@njit(cache=True, inline="always")
def dot(a, b):
    """a . b of two 3-vectors."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@loop_kernel
def any_perpendicular(d, out):
    """A unit vector normal to ``d``."""
    ax = 0
    if abs(d[1]) < abs(d[ax]):
        ax = 1
    if abs(d[2]) < abs(d[ax]):
        ax = 2
    e0 = 1.0 if ax == 0 else 0.0
    e1 = 1.0 if ax == 1 else 0.0
    e2 = 1.0 if ax == 2 else 0.0
    out[0] = d[1] * e2 - d[2] * e1
    out[1] = d[2] * e0 - d[0] * e2
    out[2] = d[0] * e1 - d[1] * e0
    m = math.sqrt(dot(out, out))
    for k in range(3):
        out[k] /= m
