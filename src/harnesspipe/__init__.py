"""harnesspipe: calibration pipeline for FE models of automotive wire harnesses.

Follows "Finite element analysis of mechanical behavior of electrical wire
harnesses: High fidelity and reduced-order models" (the paper).  Equation and
section numbers in docstrings are the paper's.
"""
import os

from harnesspipe import _numba_cache

NUMBA_CACHE_DIR = _numba_cache.configure()  # before any numba import

# OpenMP threads that sleep when idle instead of spinning: a hi-fi run meets its threads at a
# barrier several times per explicit step, and beside another busy process spinning threads
# slowed a two-thread run 3.4x (passive: none); on an idle machine passive costs ~20 %
# (bench/RESULTS.md, "Hi-fi threads on a busy machine").  A user's own setting wins.
if "OMP_WAIT_POLICY" not in os.environ and "GOMP_SPINCOUNT" not in os.environ:
    os.environ["OMP_WAIT_POLICY"] = "passive"

__version__ = "0.1.0"
