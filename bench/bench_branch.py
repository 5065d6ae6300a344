"""Benchmark of the Y-harness ROM (stand-alone: ``.venv/bin/python bench/bench_branch.py``).

Measures, on one core: the median wall time of the 50 mm in-plane pull at 1 mm/s
(default model, after one untimed call), the first call in fresh processes with an
empty and with a filled Numba cache, and the size of the alpha effect (force of
alpha = 0.2 minus alpha = 0 at a few crosshead travels) at 1 mm/s and, for the
reading of the paper's Fig. 18a, with the 50 mm pulled in 1 s.  Writes the figures
under "## Branch Y-harness ROM" in bench/RESULTS.md (replacing that section only).
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np

from benchlib import jit_seconds, write_section

HEADING = "## Branch Y-harness ROM"
FIRST_CALL = ("import time; t = time.perf_counter(); from harnesspipe.models import branch; "
              "branch.simulate('inplane', 0.2); print(time.perf_counter() - t)")
TRAVELS = (1.0, 5.0, 10.0, 50.0)


def warm_median(repeat: int) -> float:
    from harnesspipe.models import branch
    branch.simulate("inplane", 0.2)
    walls = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        branch.simulate("inplane", 0.2)
        walls.append(time.perf_counter() - t0)
    return statistics.median(walls)


def alpha_effect(rate: float, dt_min: float) -> str:
    """'u: F_0.2 vs F_0 (+diff %)' at the TRAVELS for the in-plane pull at ``rate``."""
    from harnesspipe.models import branch
    F = {}
    for alpha in (0.2, 0.0):
        c = branch.simulate("inplane", alpha, rate=rate, dt_min=dt_min)
        F[alpha] = np.interp(TRAVELS, c["displacement_mm"], c["force_N"])
    return "; ".join(f"{u:g} mm: {a * 1e3:.3f} vs {b * 1e3:.3f} mN ({100 * (a - b) / b:+.1f} %)"
                     for u, a, b in zip(TRAVELS, F[0.2], F[0.0]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=10)
    args = parser.parse_args()
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    cold, cached = jit_seconds(FIRST_CALL)
    cold, cached = cold[0], cached[0]
    warm = warm_median(args.repeat)
    slow = alpha_effect(rate=1.0, dt_min=0.02)
    fast = alpha_effect(rate=50.0, dt_min=0.0004)
    import numba
    text = (f"{HEADING}\n\n"
            f"`bench/bench_branch.py`, {time.strftime('%Y-%m-%d')}, {platform.machine()}, "
            f"Python {platform.python_version()}, numba {numba.__version__}, one thread.\n"
            "Case: `harnesspipe.models.branch.simulate('inplane', alpha=0.2)`, default model "
            "(10 mm elements, 3 x 8 fibres, 3 Lobatto points, 60 Newmark steps from 0.02 s), "
            "50 mm at 1 mm/s.\n\n"
            f"- full curve, warm (median of {args.repeat}): {1e3 * warm:.1f} ms (goal 1 s)\n"
            f"- first call in a fresh process, empty Numba cache (JIT): {cold:.1f} s\n"
            f"- first call in a fresh process, from the cache: {cached:.2f} s\n\n"
            "Alpha effect, strand force at alpha 0.2 vs 0 (elastic joint):\n"
            f"- 1 mm/s (the test, 50 s): {slow}\n"
            f"- 50 mm in 1 s (the paper's Fig. 18a reading): {fast}\n")
    write_section(HEADING, text)
    print(text)


if __name__ == "__main__":
    main()
