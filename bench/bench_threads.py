"""Benchmark of the hi-fi run's thread count on a busy machine (``.venv/bin/python bench/bench_threads.py``).

A hi-fi virtual test synchronises its Numba threads several times per explicit step (tens of
thousands of steps per run).  When another process holds one of the cores, a thread that
loses its core stalls every such barrier, so a run can slow far more than the share of the
machine it lost.  This bench measures it: the closed-tube CWB (quick profile, the paper's
interface, stopped at ``--set stop_deflection``) run by ``harnesspipe hifi three-point`` with 1
and 2 threads, under each Numba threading layer this machine has (``workqueue``; ``omp``, GNU
OpenMP, with its default and with the passive wait policy), and beside

- nothing (an idle machine),
- a busy neighbour: one single-threaded process spinning on a core (any other job),
- a twin: the same run started at the same moment with the same thread count (two pipeline
  jobs).

Each figure is the median over ``--repeats`` of the run's own integration wall time
(``wall_s`` of its summary, the Numba cache warm: one untimed run first loads or compiles it,
and its time is reported apart).  Writes the section "## Hi-fi threads on a busy machine" of
bench/RESULTS.md (replacing that section only, but for its notes by hand).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchlib import BY_HAND, section_tail, write_section

HEADING = "## Hi-fi threads on a busy machine"
CASE = "cwb19_t2_closed"
LAYERS = {"workqueue": {"NUMBA_THREADING_LAYER": "workqueue"},
          "omp": {"NUMBA_THREADING_LAYER": "omp", "GOMP_SPINCOUNT": "300000"},   # libgomp's own default
          "omp, passive wait": {"NUMBA_THREADING_LAYER": "omp", "OMP_WAIT_POLICY": "passive"},
          "omp, spin 10k": {"NUMBA_THREADING_LAYER": "omp", "GOMP_SPINCOUNT": "10000"},
          "harnesspipe's default": {}}     # nothing set: the package's own choice
VARIANT_KEYS = ("NUMBA_THREADING_LAYER", "OMP_WAIT_POLICY", "GOMP_SPINCOUNT")
NEIGHBOURS = ("none", "busy", "twin")
SPIN = "while True: pass"


def harnesspipe() -> str:
    return str(Path(sys.executable).with_name("harnesspipe"))


def start_run(folder: Path, tag: str, threads: int, env: dict, stop: float) -> tuple:
    out = folder / f"{tag}.csv"
    summary = folder / f"{tag}.json"
    cmd = [harnesspipe(), "hifi", "three-point", "--case", CASE, "--profile", "quick",
           "--interface", "paper", "--set", f"stop_deflection={stop:g}",
           "--threads", str(threads), "--out", str(out), "--summary", str(summary)]
    own = {k: v for k, v in os.environ.items() if k not in VARIANT_KEYS}   # the variant's alone
    proc = subprocess.Popen(cmd, env={**own, **env}, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    return proc, summary


def finish(run: tuple) -> float:
    proc, summary = run
    _, err = proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"hi-fi run failed (exit {proc.returncode}):\n{err[-2000:]}")
    return float(json.loads(summary.read_text())["wall_s"])


def measure(layer_env: dict, threads: int, neighbour: str, stop: float) -> float:
    """Integration wall time of one run (the mean of the two runs for a twin)."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        spinner = subprocess.Popen([sys.executable, "-c", SPIN]) if neighbour == "busy" else None
        try:
            runs = [start_run(folder, "a", threads, layer_env, stop)]
            if neighbour == "twin":
                runs.append(start_run(folder, "b", threads, layer_env, stop))
            walls = [finish(r) for r in runs]
        finally:
            if spinner is not None:
                spinner.kill()
                spinner.wait()
    return statistics.fmean(walls)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--stop", type=float, default=12.0, help="stop_deflection of each run, mm")
    ap.add_argument("--no-write", action="store_true", help="print only")
    ap.add_argument("--layers", nargs="*", default=list(LAYERS), choices=list(LAYERS),
                    help="the layer variants to measure (default: all)")
    args = ap.parse_args()

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:      # loads or compiles the kernels
        finish(start_run(Path(tmp), "warm", 1, {}, args.stop))
    warm = time.perf_counter() - t0

    rows = []
    for layer in args.layers:
        for threads in (1, 2):
            for neighbour in NEIGHBOURS:
                walls = [measure(LAYERS[layer], threads, neighbour, args.stop)
                         for _ in range(args.repeats)]
                rows.append((layer, threads, neighbour, walls))
                print(f"{layer:18s} threads {threads} beside {neighbour:5s}: median "
                      f"{statistics.median(walls):7.2f} s  ({', '.join(f'{w:.2f}' for w in walls)})",
                      flush=True)
    if not args.no_write:
        write_section(HEADING, report(rows, warm, args))


def report(rows: list, warm: float, args) -> str:
    """The section: one row per (layer, threads, neighbour), median, range and ratios."""
    median = {(l, t, n): statistics.median(w) for l, t, n, w in rows}
    ref = min(m for (l, t, n), m in median.items() if n == "none")
    lines = [HEADING, "",
             f"`bench/bench_threads.py` on {platform.machine()}, {os.cpu_count()} cores, "
             f"{time.strftime('%Y-%m-%d')}: the {CASE} quick-profile run to "
             f"{args.stop:g} mm (the paper's interface), {args.repeats} runs each: their "
             f"integration wall time (median, and the range: a stalled run shows there), "
             f"Numba cache warm (the first run, cache load or compile included, whole "
             f"process: {warm:.1f} s).  'slowdown': the median against the same layer and "
             f"thread count alone; 'vs best idle': against the fastest idle median "
             f"({ref:.2f} s).  A twin is the same run started beside it (the figure is the "
             f"two runs' mean).", "",
             "| threading layer | threads | beside | wall s, median (range) | slowdown | vs best idle |",
             "|---|---|---|---|---|---|"]
    for layer, threads, neighbour, walls in rows:
        m = median[(layer, threads, neighbour)]
        lines.append(f"| {layer} | {threads} | {neighbour} | {m:.2f} ({min(walls):.2f}-"
                     f"{max(walls):.2f}) | {m / median[(layer, threads, 'none')]:.2f} | "
                     f"{m / ref:.2f} |")
    tail = section_tail(HEADING)
    return "\n".join(lines) + "\n\n" + (tail or BY_HAND + "\n\n(none yet)") + "\n"


if __name__ == "__main__":
    main()
