"""Benchmark of the hi-fi virtual three-point test (``.venv/bin/python bench/bench_hifi.py``).

Measures, for the 19-wire closed-tube CWB (``cwb19_t2_closed``): the median wall time of
repeated runs per profile (after one untimed warm-up run in the same process, so JIT
compilation is excluded), the explicit step count and step, KE/IE and energy error, and
the per-phase cost breakdown of the run from its own timers (the elements, the bundle's
contacts and the cohesive ties are one phase: they run in concurrent lanes,
fe/assembly/lanes.py; the contact search; the loading's contacts and damping; the
integrator and bookkeeping); the first run in
fresh processes with an empty and with a filled Numba cache (JIT cost, reported apart).
``--convergence`` adds the mesh study (the default profile against a finer mesh) and the
mass-scaling study (f_m = 25 against f_m = 10 at the same simulated time): the largest
force difference over the curve and its RMS, relative to the peak force.  Writes the section
"## Hi-fi three-point" of bench/RESULTS.md (replacing that section only, but for its notes
by hand, "### By hand").
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from benchlib import BY_HAND, RESULTS, jit_seconds, section_tail, write_section

HEADING = "## Hi-fi three-point"
CASE = "cwb19_t2_closed"
FINER = {"wire_elements": "60", "tube_circ": "20", "tube_axial": "48"}
FIRST_RUN = (f"import sys, time; sys.path.insert(0, {str(Path(__file__).resolve().parent)!r}); "
             "t = time.perf_counter(); import bench_hifi; bench_hifi.warm_up(); "
             "print(time.perf_counter() - t)")


def quick_system():
    """The case's quick model, ready to integrate, and its inputs."""
    from harnesspipe.config import load
    from harnesspipe.models import hifi, hifi_mesh
    from harnesspipe.stages.hifi import inputs
    cfg = load()
    cfg["profile"] = "quick"
    inp = inputs(cfg, CASE, {})
    return hifi.HifiSystem(hifi_mesh.build_mesh(inp.case, cfg, inp.resolution), inp), inp


def warm_up() -> None:
    """Build the quick model and integrate its first 2 ms: every kernel compiled or loaded."""
    from harnesspipe.fe.solvers.central_difference import integrate
    integrate(quick_system()[0], 0.002)


def run(profile: str, overrides: dict | None = None):
    from harnesspipe.config import load
    from harnesspipe.models.hifi import three_point
    from harnesspipe.stages.hifi import inputs
    cfg = load()
    cfg["profile"] = profile
    cfg["explicit"]["ke_ie_fail"] = 100.0     # measured and reported, not enforced here
    return three_point(inputs(cfg, CASE, overrides or {}))


def family_costs(at: float = 0.4, calls: int = 100, repeat: int = 5) -> list[str]:
    """Cost per call of each force family at the quick model's state ``at`` T into its test
    (wires touching, fibres yielding): each family's own kernel (the parallel one where a
    family has one), one after the other (tests/hifi_reference.py), against the concurrent
    lanes that run them in a run; with the contact search and the integrator's step.  Each figure is the
    median over ``repeat`` rounds of the mean of ``calls`` calls from the same saved state."""
    from harnesspipe.fe.solvers.central_difference import (DynamicsSettings, close_and_kick,
                                                           integrate)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from hifi_reference import FAMILY_KERNELS, restore_histories, save_histories, separate_forces
    s, inp = quick_system()
    res = integrate(s, at * s.T, DynamicsSettings(safety=inp.explicit["safety"], n_output=2))
    dt, steps_per_search = res.dt, res.n_steps / s.searches
    v = np.random.default_rng(0).normal(scale=1e-2, size=s.mass.shape)   # slip and strain rates
    saved = save_histories(s)
    du, du_next, v_step, f = (np.zeros_like(s.mass) for _ in range(4))
    W, W_end = np.zeros(len(s.families)), np.zeros(len(s.families))
    minv = np.where(s.mass > 0.0, 1.0 / np.maximum(s.mass, 1e-300), 0.0)

    def per_call(fn):
        means = []
        for _ in range(repeat):
            restore_histories(s, saved)
            t0 = time.perf_counter()
            for _ in range(calls):
                fn()
            means.append((time.perf_counter() - t0) / calls)
        return statistics.median(means)

    rounds = [{} for _ in range(repeat)]
    for r in rounds:
        restore_histories(s, saved)
        for _ in range(calls):
            separate_forces(s, v, dt, r)
    family = {k: statistics.median(r[k] for r in rounds) / calls for k in FAMILY_KERNELS}
    lanes = per_call(lambda: s.forces(at * s.T, v, dt))      # the split keeps climbing
    search = per_call(s._search)
    row_cost = per_call(lambda: s.observe(at * s.T))
    step = per_call(lambda: close_and_kick(s.F, du, du_next, W, W_end, v_step, minv, s.free,
                                           0.5 * dt, s.mass, f, dt))
    restore_histories(s, saved)
    us = {k: f"{1e6 * t:.0f}" for k, t in family.items()}
    return ["", f"Cost per call at {at:g} T of the quick run ({s.active} active contacts, "
            f"{s.ww_pairs.shape[0]} wire-wire candidates; median of {repeat} rounds of "
            f"{calls} calls from the same state, us): each family's own kernel (the parallel "
            "one where a family has one), one after the other -- "
            + ", ".join(f"{k} {t}" for k, t in us.items())
            + f"; sum {1e6 * sum(family.values()):.0f}.  The system's forces() as a run "
            f"calls it (the same families in two concurrent lanes): {1e6 * lanes:.0f}.  A "
            f"contact search {1e6 * search:.0f} (one every {steps_per_search:.0f} steps so far).  The "
            f"integrator's step (close_and_kick) {1e6 * step:.0f}.  A history row's "
            f"observations {1e6 * row_cost:.0f} (200 rows a run)."]


def timed(profile: str, repeat: int):
    runs = [run(profile) for _ in range(repeat)]
    walls = [r.summary["wall_s"] for r in runs]
    return runs[len(runs) // 2], statistics.median(walls), walls


WINDOW_MM = 1.0   # deflection window of the windowed comparison (single-row stick-slip events)


def curve_difference(a, b, upto: float = 30.0, window: float = 0.0) -> tuple[float, float]:
    """(max, root mean square) of |F_a - F_b| over the deflection grid 0..upto, each
    relative to max F_b there; with ``window`` > 0 both curves are first averaged over that
    deflection window (a moving mean), which removes the single-row excursions of a
    stick-slip release (a wire slipping over its neighbour), whose timing no explicit run
    reproduces from one run to the next.  The max is set by the steepest part of the curve
    (a small shift of a stiffening onset, or such an event), the RMS by the whole curve."""
    u = np.linspace(0.0, upto, 61)
    fa, fb = (_window_mean(r.curve, u, window) for r in (a, b))
    peak = np.max(np.abs(fb))
    return float(np.max(np.abs(fa - fb)) / peak), float(np.sqrt(np.mean((fa - fb) ** 2)) / peak)


def _window_mean(curve, u, window: float):
    """The force curve at the deflections ``u``, as a moving mean over ``window`` mm (the
    curve itself for 0), from a 0.01 mm resampling."""
    d, f = curve["deflection_mm"].to_numpy(), curve["force_N"].to_numpy()
    if window <= 0.0:
        return np.interp(u, d, f)
    fine = np.arange(0.0, d.max() + 1e-9, 0.01)
    c = np.concatenate([[0.0], np.cumsum(np.interp(fine, d, f))])
    lo = np.clip(np.searchsorted(fine, u - 0.5 * window), 0, fine.size - 1)
    hi = np.clip(np.searchsorted(fine, u + 0.5 * window, side="right"), lo + 1, fine.size)
    return (c[hi] - c[lo]) / (hi - lo)


def convergence_line(label: str, base, other) -> str:
    (m20, r20), (m30, r30) = curve_difference(base, other, 20.0), curve_difference(base, other)
    w20, w30 = (curve_difference(base, other, upto, WINDOW_MM)[0] for upto in (20.0, 30.0))
    return (f"- {label} ({other.summary['wall_s']:.0f} s): max {m20:.1%} / {m30:.1%}, "
            f"RMS {r20:.1%} / {r30:.1%}; {WINDOW_MM:g} mm moving mean: max {w20:.1%} / {w30:.1%}")


def save_curves(runs: dict, folder: Path) -> None:
    """The study's force curves, for a look at where they differ (results/ is not in git)."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, r in runs.items():
        r.curve.to_csv(folder / f"{name}.csv", index=False)


def row(profile: str, r, median: float, walls) -> str:
    s = r.summary
    phases = ", ".join(f"{k} {v:.1f} s" for k, v in s["phase_s"].items())
    return (f"| {profile} | {s['n_beam_elements']} / {s['n_shell_elements']} | {s['steps']} | "
            f"{s['dt']:.3g} | {median:.1f} ({', '.join(f'{w:.1f}' for w in walls)}) | "
            f"{s['ke_ie_max']:.3g} | {s['energy_error']:.2g} | {phases} |")


CROSS_HEADING = "## Hi-fi cross-check against Table 3"


def crosscheck_section(results: Path) -> str:
    """Table 3 from the hi-fi runs at the paper's parameters (``snakemake hifi_crosscheck_all``)
    beside the paper's, with the runs' cost and quasi-static figures."""
    import json

    import pandas as pd
    import yaml
    cfg = yaml.safe_load((Path(__file__).resolve().parents[1] / "config" / "config.yaml").read_text())
    table = pd.read_csv(results / "table3.csv").set_index("case")
    beams = json.loads((results / CASE / "summary.json").read_text())["n_beam_elements"]
    profile = next((name for name, p in cfg["profiles"].items()
                    if 19 * p["hifi"]["wire_elements"] == beams), "?")   # 19 wires of the case
    lines = [CROSS_HEADING, "",
             "Hi-fi runs with the paper's Table 2 coverings and Sec. 4.2 interface values "
             "(mu_rtb 0.3, mu_rtp 0.1, delta0 0.03, delta_f 0.08, alpha 2, E2/E1 0.6), passed "
             "through eq. 13 + simplex exactly as the measured curves are "
             f"(`snakemake hifi_crosscheck_all`, profile {profile}; one Numba thread per run, two "
             "runs side by side, so the walls are those of a loaded machine).", "",
             "| case | beams / shells | E (paper) | sigma_y (paper) | K (paper) | n (paper) | run wall [s] | "
             "steps | KE/IE (past 1/3 stroke) | energy error |", "|---|---|---|---|---|---|---|---|---|---|"]
    for case, paper in cfg["paper"]["table3"].items():
        if case not in table.index:
            continue
        r = table.loc[case]
        s = json.loads((results / case / "summary.json").read_text())
        lines.append(f"| {case} | {s['n_beam_elements']} / {s['n_shell_elements']} | {r.E:.3g} ({paper['E']}) | {r.sigma_y:.3g} "
                     f"({paper['sigma_y']}) | {r.K:.3g} ({paper['K']}) | {r.n:.3g} ({paper['n']}) | "
                     f"{s['wall_s']:.0f} | {s['steps']} | {s['ke_ie_max']:.3f} | {s['energy_error']:.1e} |")
    ratios = {k: [table.loc[c][k] / cfg["paper"]["table3"][c][k] for c in cfg["paper"]["table3"]
                  if c in table.index] for k in ("E", "sigma_y", "K", "n")}
    lines += ["", "Ours over the paper's, over the cases: " + ", ".join(
        f"{k} {min(v):.2g}-{max(v):.2g}" for k, v in ratios.items()) + ".  n = 1 is the bound of "
        "the admissible hardening (N_MAX).  Runs above KE/IE 0.02 are not quasi-static by the "
        "paper's criterion (t_total 1 s, f_m 25)."]
    tail = section_tail(CROSS_HEADING)
    if tail:
        lines[-1] += "  Why they differ: the notes below."
        lines += ["", tail]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per profile")
    parser.add_argument("--profiles", nargs="+", default=["quick", "default"])
    parser.add_argument("--convergence", action="store_true")
    parser.add_argument("--threads", type=int, default=os.cpu_count(),
                        help="Numba threads (default: all cores, as one CLI run uses them)")
    parser.add_argument("--crosscheck", type=Path, default=None, metavar="DIR",
                        help="only write the cross-check section from DIR (results/hifi/crosscheck)")
    args = parser.parse_args()
    if args.crosscheck is not None:
        text = crosscheck_section(args.crosscheck)
        write_section(CROSS_HEADING, text)
        print(text)
        return
    import numba
    numba.set_num_threads(args.threads)                # see "Threads" in RESULTS.md
    warm_up()                                          # JIT, not timed
    lines = [HEADING, "",
             f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
             f"Numba threads {numba.get_num_threads()}; case `{CASE}`; wall = median of "
             f"{args.repeat} runs after a warm-up run (JIT excluded); phases from the run's timers.",
             "", "| profile | beams / shells | steps | dt [s] | wall [s] (runs) | KE/IE max | "
             "energy error | phases |", "|---|---|---|---|---|---|---|---|"]
    results = {}
    for profile in args.profiles:
        r, med, walls = timed(profile, args.repeat if profile == "quick" else 1)
        results[profile] = r
        lines.append(row(profile, r, med, walls))
    lines += family_costs()
    cold, cached = jit_seconds(FIRST_RUN)
    lines += ["", f"First run in a fresh process (one thread; quick model built and its first 2 ms integrated): "
                  f"{cold[0]:.1f} s with an empty Numba cache, {cached[0]:.1f} s from the cache."]
    if args.convergence:
        base = results.get("default") or run("default")
        fine = run("default", FINER)
        light = run("default", {"f_m": "10"})
        save_curves({"default": base, "finer": fine, "f_m10": light},
                    Path(__file__).resolve().parents[1] / "results" / "bench" / "hifi_convergence")
        lines += ["", "Convergence of the force curve (|dF| / peak force, its max and its RMS, over "
                  "0-20 mm -- the friction window -- and over the whole 0-30 mm, and the max once "
                  f"both curves are averaged over a {WINDOW_MM:g} mm deflection window; curves in "
                  "results/bench/hifi_convergence/):",
                  convergence_line(f"mesh: default vs finer ({', '.join(f'{k} {v}' for k, v in FINER.items())})",
                                   base, fine),
                  convergence_line("mass scaling: f_m 25 vs 10 at the same t_total", base, light)]
    else:
        lines += previous_convergence()
    tail = section_tail(HEADING)            # the notes by hand, kept
    if tail:
        lines += ["", tail]
    write_section(HEADING, "\n".join(lines))
    print("\n".join(lines))


def previous_convergence() -> list[str]:
    """The convergence paragraph of the section now in RESULTS.md (kept when a run without
    ``--convergence`` rewrites the section), marked as an earlier measurement."""
    text = RESULTS.read_text() if RESULTS.exists() else ""
    start = text.find(HEADING + "\n")
    if start < 0:
        return []
    end = text.find("\n## ", start + len(HEADING))
    section = text[start:end if end >= 0 else len(text)]
    if BY_HAND in section:
        section = section[:section.find(BY_HAND)]
    at = section.find("Convergence of the force curve")
    if at < 0:
        return []
    old = section[at:].rstrip().splitlines()
    if "(earlier run" not in old[0]:
        old[0] = old[0].replace("Convergence of the force curve",
                                "Convergence of the force curve (earlier run; `--convergence` "
                                "measures it anew)", 1)
    return [""] + old


if __name__ == "__main__":
    main()
