"""Benchmark of the ROM three-point model (stand-alone: ``.venv/bin/python bench/bench_rom.py``).

Measures, on one core:
* the median wall time of a full 30 mm three-point curve with roller supports on the
  default mesh, after JIT (``--repeat`` runs), and the median CPU time of the process
  (``time.process_time``: less sensitive to other jobs on a shared machine);
* the JIT time with an empty Numba cache and when loading from the cache (fresh
  subprocesses with HARNESSPIPE_NUMBA_CACHE pointing at a temporary folder);
* optionally OpenSeesPy on the pinned model (co-rotational displacement-based fibre
  beams, same mesh, Lobatto points and increments, elastic-perfectly plastic fibres), as
  OpenSees' 3D model of it (the same 6 dofs per node) and as its 2D reduction: force
  agreement and speed ratio of each.
Appends the figures under "## ROM three-point" in bench/RESULTS.md (replacing that
section only).
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np

CLOSED = dict(E=15.7, sigma_y=0.6, K=1.59, n=0.3, radius=7.05)  # Table 3, closed tube
from benchlib import jit_seconds, write_section

HEADING = "## ROM three-point"
FIRST_CALL = ("import time; t = time.perf_counter(); from harnesspipe import rom; "
              "rom.three_point(E=15.7, sigma_y=0.6, K=1.59, n=0.3, radius=7.05); "
              "print(time.perf_counter() - t)")


COARSE = dict(n_elements=30, n_increments=15, n_rings=3, n_sectors=10)
FINE = dict(n_elements=80, n_increments=20, n_rings=8, n_sectors=24)


def timed(fn):
    """(result, wall seconds, CPU seconds of this process) of ``fn()``."""
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def warm_median(repeat: int, **mesh):
    """Median wall and CPU time of a full curve (after one untimed call), and the curve."""
    from harnesspipe import rom
    curve = rom.three_point(**CLOSED, **mesh)  # compile or load
    runs = [timed(lambda: rom.three_point(**CLOSED, **mesh)) for _ in range(repeat)]
    return (statistics.median(r[1] for r in runs), statistics.median(r[2] for r in runs),
            curve)


def deviation(curve, reference) -> float:
    """Largest force difference from the reference curve, relative to its peak."""
    F = np.interp(reference["deflection_mm"], curve["deflection_mm"], curve["force_N"])
    return float(np.max(np.abs(F - reference["force_N"])) / reference["force_N"].max())


def opensees_pinned(E, sigma_y, radius, span, deflection, n_el, n_inc, n_rings, n_sectors,
                    ndm=2, nu=0.39):
    """Pinned three-point curve with OpenSeesPy; returns (deflections, forces).

    ``ndm=3``: the model harnesspipe solves -- 6 dofs per node, 3D co-rotational
    elements with an elastic torsion stiffness GJ, and the out-of-plane translation
    and rotations fixed at every node (planar bending in x-y).  ``ndm=2``: OpenSees'
    planar reduction of it (3 dofs per node, the 2D co-rotational element).
    """
    import openseespy.opensees as ops
    ops.wipe()
    ops.model("basic", "-ndm", ndm, "-ndf", 3 if ndm == 2 else 6)
    for k in range(n_el + 1):
        ops.node(k + 1, span * k / n_el, *([0.0] * (ndm - 1)))
        planar = (0,) if ndm == 2 else (1, 1, 1, 0)   # free rz; 3D: uz, rx, ry fixed
        ops.fix(k + 1, int(k == 0), int(k in (0, n_el)), *planar)
    ops.uniaxialMaterial("ElasticPP", 1, E, sigma_y / E)
    if ndm == 2:
        ops.section("Fiber", 1)
        ops.geomTransf("Corotational", 1)
    else:
        GJ = E / (2.0 * (1.0 + nu)) * np.pi * radius**4 / 2.0
        ops.section("Fiber", 1, "-GJ", GJ)
        ops.geomTransf("Corotational", 1, 0.0, 0.0, 1.0)
    ops.patch("circ", 1, n_sectors, n_rings, 0.0, 0.0, 0.0, radius, 0.0, 360.0)
    ops.beamIntegration("Lobatto", 1, 1, 3)
    for k in range(n_el):
        ops.element("dispBeamColumn", k + 1, k + 1, k + 2, 1, 1)
    mid = n_el // 2 + 1
    ops.timeSeries("Linear", 1)
    ops.pattern("Plain", 1, 1)
    ops.load(mid, 0.0, -1.0, *([0.0] * (1 if ndm == 2 else 4)))
    ops.system("BandGeneral")
    ops.numberer("RCM")
    ops.constraints("Plain")
    ops.test("NormDispIncr", 1e-10, 50)
    ops.algorithm("Newton")
    ops.integrator("DisplacementControl", mid, 2, -deflection / n_inc)
    ops.analysis("Static")
    u, F = [0.0], [0.0]
    for _ in range(n_inc):
        if ops.analyze(1) != 0:
            raise RuntimeError("OpenSees did not converge")
        u.append(-ops.nodeDisp(mid, 2))
        F.append(ops.getLoadFactor(1))
    return np.array(u), np.array(F)


def compare_opensees(repeat: int) -> str:
    try:
        import openseespy.opensees  # noqa: F401
    except (ImportError, RuntimeError) as exc:  # the wheel needs the system libblas.so.3
        return (f"OpenSeesPy comparison: not run. `pip install openseespy` succeeded "
                f"({_version('openseespy')}) but the import fails here: {exc!r} (its shared "
                f"library needs the system `libblas.so.3`, absent on this machine).")
    from harnesspipe import rom
    case = dict(E=15.7, sigma_y=0.6, radius=7.05, span=127.0, deflection=30.0)
    mesh = dict(n_el=40, n_inc=20, n_rings=8, n_sectors=24)
    ours = dict(n_elements=40, n_increments=20, n_rings=8, n_sectors=24)
    rom.three_point(**case, K=0.0, n=1.0, supports="pinned", **ours)
    runs = {"ours": [], 2: [], 3: []}
    for _ in range(repeat):  # alternating, so all three see the same machine load
        runs["ours"].append(timed(lambda: rom.three_point(**case, K=0.0, n=1.0,
                                                          supports="pinned", **ours)))
        for ndm in (2, 3):
            runs[ndm].append(timed(lambda: opensees_pinned(**case, **mesh, ndm=ndm)))
    curve = runs["ours"][-1][0]
    wall = {k: statistics.median(r[1] for r in v) for k, v in runs.items()}
    cpu = {k: statistics.median(r[2] for r in v) for k, v in runs.items()}
    lines = []
    for ndm, name in ((3, "3D model (the same model: 6 dofs per node, out-of-plane dofs fixed)"),
                      (2, "2D model (OpenSees' planar reduction: 3 dofs per node)")):
        u, F = runs[ndm][-1][0]
        F_h = np.interp(u, curve["deflection_mm"], curve["force_N"])
        dev = np.max(np.abs(F_h[1:] - F[1:]) / np.abs(F[1:]))
        lines.append(f"- OpenSees {name}: median wall {1e3 * wall[ndm]:.1f} ms, CPU "
                     f"{1e3 * cpu[ndm]:.1f} ms; ratio OpenSees/harnesspipe {wall[ndm] / wall['ours']:.2f} "
                     f"(CPU {cpu[ndm] / cpu['ours']:.2f}); largest force deviation {100 * dev:.2f} %")
    return (f"OpenSeesPy {_version('openseespy')} comparison, pinned supports, elastic-perfectly "
            f"plastic fibres (E 15.7, sigma_Y 0.6, K 0), 40 co-rotational dispBeamColumn elements, "
            f"3 Lobatto points, 8 x 24 fibres (OpenSees `patch circ`, harnesspipe polar Gauss), "
            f"20 displacement-controlled increments to 30 mm, {repeat} alternating runs:\n"
            f"- harnesspipe: median wall {1e3 * wall['ours']:.1f} ms, CPU {1e3 * cpu['ours']:.1f} ms\n"
            + "\n".join(lines))


def _version(dist: str) -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version(dist)
    except PackageNotFoundError:
        return "?"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    import numba
    numba.set_num_threads(1)
    cold, cached = jit_seconds(FIRST_CALL)
    cold, cached = cold[0], cached[0]
    warm, warm_cpu, curve = warm_median(args.repeat)
    coarse, coarse_cpu, coarse_curve = warm_median(args.repeat, **COARSE)
    from harnesspipe import rom
    reference = rom.three_point(**CLOSED, **FINE)
    ops = compare_opensees(max(5, args.repeat // 2))
    text = (f"{HEADING}\n\n"
            f"`bench/bench_rom.py`, {time.strftime('%Y-%m-%d')}, {platform.processor() or platform.machine()}, "
            f"Python {platform.python_version()}, numba {numba.__version__}, one thread.\n"
            f"Case: Table 3 closed tube (E 15.7, sigma_Y 0.6, K 1.59, n 0.3), r_o 7.05, rollers, "
            f"30 mm, default mesh (40 elements, 20 output increments, 4 x 12 fibres, 3 Lobatto "
            f"points), {len(curve)} curve rows.\n\n"
            f"- full curve, warm (median of {args.repeat}): wall {1e3 * warm:.1f} ms (goal 50 ms), "
            f"CPU {1e3 * warm_cpu:.1f} ms; force deviation from an 80-element, 8 x 24-fibre "
            f"reference: {100 * deviation(curve, reference):.2f} %\n"
            f"- coarser mesh (30 elements, 15 increments, 3 x 10 fibres): wall "
            f"{1e3 * coarse:.1f} ms, CPU {1e3 * coarse_cpu:.1f} ms, deviation "
            f"{100 * deviation(coarse_curve, reference):.2f} %\n"
            f"- first call in a fresh process, empty Numba cache (JIT): {cold:.1f} s\n"
            f"- first call in a fresh process, from the cache: {cached:.2f} s\n"
            f"- machine load (1-min average, {os.cpu_count()} cores) at the end: "
            f"{os.getloadavg()[0]:.2f}\n\n{ops}\n")
    print(text)
    if not args.no_write:
        write_section(HEADING, text)


if __name__ == "__main__":
    main()
