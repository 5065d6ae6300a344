"""Compile (or load from the cache) the Numba kernels of every model once."""
from __future__ import annotations

import time


def warm_up() -> dict[str, float]:
    """Run each model once on a tiny problem; return the wall time of each."""
    from harnesspipe import rom
    timings = {}
    t0 = time.perf_counter()
    rom.three_point(E=20.0, sigma_y=0.5, K=2.0, n=0.3, radius=7.0, supports="rollers",
                    deflection=2.0)
    rom.three_point(E=20.0, sigma_y=0.5, K=2.0, n=0.3, radius=7.0, supports="pinned",
                    deflection=2.0)
    timings["rom three-point"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    rom.cantilever(E=20.0, radius=7.0, length=100.0, tip_load=0.1, elastic=True)
    timings["rom cantilever"] = time.perf_counter() - t0
    return timings
