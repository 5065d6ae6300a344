"""harnesspipe: calibration pipeline for FE models of automotive wire harnesses.

Follows "Finite element analysis of mechanical behavior of electrical wire
harnesses: High fidelity and reduced-order models" (the paper).  Equation and
section numbers in docstrings are the paper's.
"""
from harnesspipe import _numba_cache

NUMBA_CACHE_DIR = _numba_cache.configure()  # before any numba import

__version__ = "0.1.0"
