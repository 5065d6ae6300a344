"""Compile (or load from the cache) the Numba kernels of every model once."""
from __future__ import annotations

import time


def warm_up_hifi() -> dict[str, float]:
    """Build the quick hi-fi model of an open, coarse-taped CWB (every contact, tie and
    element kind but fabric) and of a fabric CWB, and integrate their first 2 ms."""
    from harnesspipe.config import load
    from harnesspipe.fe.solvers.central_difference import integrate
    from harnesspipe.models import hifi, hifi_mesh
    from harnesspipe.stages.hifi import inputs
    cfg = load()
    cfg["profile"] = "quick"
    timings = {}
    for case in ("cwb19_t2_open_coarse", "cwb19_t2_fabric"):
        t0 = time.perf_counter()
        inp = inputs(cfg, case, {})
        integrate(hifi.HifiSystem(hifi_mesh.build_mesh(inp.case, cfg, inp.resolution), inp), 0.002)
        timings[f"hifi {case}"] = time.perf_counter() - t0
    return timings


def warm_up() -> dict[str, float]:
    """Run each model once on a tiny problem; return the wall time of each."""
    from harnesspipe import rom
    from harnesspipe.models import branch, tensile
    runs = {
        "rom three-point": lambda: (
            rom.three_point(E=20.0, sigma_y=0.5, K=2.0, n=0.3, radius=7.0, deflection=2.0),
            rom.three_point(E=20.0, radius=7.0, supports="pinned", deflection=2.0, elastic=True)),
        "rom cantilever": lambda: rom.cantilever(E=20.0, radius=7.0, length=100.0, tip_load=0.1,
                                                 elastic=True),
        "tensile tube": lambda: tensile.simulate("closed_tube", 1500.0, 8.0, 25.0, 0.2, preset="quick"),
        "tensile fabric": lambda: tensile.simulate("fabric_tube", 90.0, 10.0, 30.0, 0.6, preset="quick"),
        "branch": lambda: branch.simulate("inplane", 0.2, n_steps=10, stroke=1.0),
    }
    timings = {}
    for name, run in runs.items():
        t0 = time.perf_counter()
        run()
        timings[name] = time.perf_counter() - t0
    return timings
