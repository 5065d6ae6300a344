"""Benchmark of the tensile stage: one simulation and one calibration per component.

Run with the project's venv: ``.venv/bin/python bench/bench_tensile.py [--repeat N]``.
Appends the figures under "## Tensile" in bench/RESULTS.md (replacing that
section only).  Measures, on one thread:

* JIT: the first simulation of each kind in a fresh process, with an empty Numba
  cache and from the cache;
* one warm simulation per component and preset (median of ``--repeat``);
* one full calibration per component (default preset) from a noise-free
  synthetic curve made at Table 2, with the number of simulations and the
  recovered parameters;
* the 3D shell cells (closed and open tube) against the axisymmetric cell over
  the whole curve, showing what the cut does.
"""
from __future__ import annotations

import argparse
import platform
import statistics
import time

import numpy as np

from benchlib import jit_seconds, write_section

HEADING = "## Tensile"
TABLE2 = {"closed_tube": (1559.0, 8.6, 25.6, 0.12), "open_tube": (698.0, 8.8, 23.1, 0.83),
          "fabric_tube": (93.5, 10.0, 30.8, 0.60)}
FIRST_CALL = """
import time
t0 = time.perf_counter()
from harnesspipe.models.tensile import simulate
simulate("closed_tube", 1559.0, 8.6, 25.6, 0.12, preset="quick")
t1 = time.perf_counter()
simulate("fabric_tube", 93.5, 10.0, 30.8, 0.6, preset="quick")
print(t1 - t0, time.perf_counter() - t1)
"""


def warm_median(component: str, preset: str, repeat: int) -> float:
    from harnesspipe.models.tensile import simulate
    simulate(component, *TABLE2[component], preset=preset)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        simulate(component, *TABLE2[component], preset=preset)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def calibration(component: str) -> str:
    from harnesspipe.calibrate.tensile import calibrate_fabric, calibrate_tube
    from harnesspipe.models.tensile import simulate
    truth = TABLE2[component]
    measured = simulate(component, *truth)
    t0 = time.perf_counter()
    if component == "fabric_tube":
        params, fit = calibrate_fabric(measured)
    else:
        params, fit = calibrate_tube(component, measured, maxfev=600, xatol=1e-6, fatol=1e-8)
    wall = time.perf_counter() - t0
    target = dict(zip(("E", "sigma_y", "K", "n"), truth))
    worst = max(abs(params[k] / v - 1.0) for k, v in target.items())
    found = ", ".join(f"{k} {params[k]:.4g}" for k in target)
    return (f"- {component}: {wall:.1f} s, {fit.nfev} simulations "
            f"({wall / fit.nfev * 1e3:.0f} ms each), converged {fit.converged}; {found}; "
            f"largest deviation from Table 2 {100 * worst:.3f} %")


def shell_cells() -> str:
    """The 3D half-pitch cell with and without the cut on two meshes (the coarser one
    shows how far it is from converged), beside the axisymmetric cell the fit uses."""
    from harnesspipe.models.tensile import resolution, simulate, simulate_shell_tube
    truth = TABLE2["open_tube"]
    axi = simulate("open_tube", *truth)
    picks = [5, 10, 15, 17.5, 19.75, 22.5, 25]

    def at(df):
        return np.array([np.interp(u, df.displacement_mm, df.force_N) for u in picks])

    def fmt(F):
        return " / ".join(f"{f:.1f}" for f in F)

    lines = [f"F at u = {picks} mm; axisymmetric cell (default, 32 elements): {fmt(at(axi))} N"]
    for meridian, circumference in ((8, 12), (12, 24)):
        res = resolution("default", meridian=meridian, circumference=circumference, n_steps=100)
        F = {}
        for cut in (False, True):
            t0 = time.perf_counter()
            F[cut] = at(simulate_shell_tube(*truth, cut=cut, res=res))
            lines.append(f"- 3D shell cell, {meridian} x {circumference} elements, 100 steps, "
                         f"{'open (cut + contact)' if cut else 'closed'}: {fmt(F[cut])} N "
                         f"({time.perf_counter() - t0:.0f} s)")
        ratio = " / ".join(f"{r:.2f}" for r in F[True] / F[False])
        lines.append(f"  open / closed: {ratio}")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=10)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    import numba
    numba.set_num_threads(1)
    cold, cached = jit_seconds(FIRST_CALL)
    sims = [f"- {c}, {p}: {1e3 * warm_median(c, p, args.repeat):.1f} ms"
            for c in TABLE2 for p in ("quick", "default")]
    cals = [calibration(c) for c in TABLE2]
    text = (f"{HEADING}\n\n"
            f"`bench/bench_tensile.py`, {time.strftime('%Y-%m-%d')}, "
            f"{platform.processor() or platform.machine()}, Python {platform.python_version()}, "
            f"numba {numba.__version__}, one thread.  Tubes: axisymmetric half-pitch cell "
            f"(quick 12, default 32 elements, 16/25 steps); fabric: one 3D shell element "
            f"(homogeneous uniaxial stress), 16/25 steps.\n\n"
            f"JIT (first simulation in a fresh process; tube then fabric):\n"
            f"- empty Numba cache: {cold[0]:.1f} s (axisymmetric tube), {cold[1]:.1f} s (3D shell)\n"
            f"- from the cache: {cached[0]:.2f} s, {cached[1]:.2f} s\n\n"
            f"One simulation, warm (median of {args.repeat}):\n" + "\n".join(sims) + "\n\n"
            "Full calibration, default preset, from the literature initial guess, "
            "noise-free synthetic curve at Table 2:\n" + "\n".join(cals) + "\n\n"
            f"Cut or no cut (open-tube material of Table 2):\n{shell_cells()}\n")
    print(text)
    if not args.no_write:
        write_section(HEADING, text)


if __name__ == "__main__":
    main()
