"""FE core: Numba kernels for materials, elements, contact and solvers.

Every ``@njit`` kernel of the package lives below this folder; the Numba cache is
keyed to a hash of these sources (see :mod:`harnesspipe._numba_cache`).
Imports go one way: ``fe`` <- ``models`` <- ``calibrate`` <- ``stages``/``cli``.
"""
