"""The decorator of the FE core's hot loops: over elements, contact pairs and ties.

Numba counts references to every array a compiled function receives and to every view
it takes (``state[e]``), with an atomic operation on entry and again on exit; a helper
inlined into a loop gets its arrays as new variables and counts them per iteration.  In
the loops that run every explicit step these counts cost about as much as the
arithmetic (bench/RESULTS.md "Hi-fi three-point").  A loop kernel is compiled without
them.  It may take views of the arrays it is given (their owner outlives the call) but
may not allocate: Numba refuses to compile an allocation in it, so its scratch comes
from the caller, which keeps the counts.
"""
from __future__ import annotations

from numba import njit


def loop_kernel(fn):
    """``njit(cache=True)`` without reference counting (Numba's ``_nrt=False``; Numba is
    pinned in pyproject.toml).  Kernels that it calls without inlining and that are
    compiled first from it inherit the setting, so they must not allocate either."""
    return njit(cache=True, _nrt=False)(fn)
