"""Does a virtual test's outcome hinge on the last bits of its inputs?

Run with the project's venv: ``.venv/bin/python bench/bench_last_bits.py [--profile quick]``.
Replaces the section "## Hi-fi outcome against the last bits" of bench/RESULTS.md.

Explicit runs differ in their last bits between machines (another CPU, another libm), and a
chain's pick must not hinge on them.  This bench stands in for another machine by moving one
input by a relative ``--eps`` (1e-12, a few hundred ulps: no physical change) and reruns the
virtual test, ``--copies`` times (input x (1 + k eps), k = 0 .. copies - 1), once per wire-pack
turn of ``--angles`` (config ``hifi.build.pack_angle``; 0 is the pack as drawn, mirror-symmetric
about the loading plane).  Reported per turn: each run's l2 error (eq. 4, 0-30 mm) against the
measured mean and its largest force drop, and the spread of the errors, to compare with the
chain's tie (the standard error of the measured mean, a few N): a spread far below it cannot
move a pick.

The state is the one the chain met when its tension pick moved between two runs (bench/RESULTS.md
'Hi-fi outcome against the last bits', by hand): 5.33 wraps, tape tension 1.5279 N, the start interface;
``--table2`` gives the tensile stage's coverings (default: bench/last_bits_table2.csv, the
Table 2 of the quick pipeline's tensile fits in which the pick moved, session 30).  Each run is one
Numba thread; two run side by side.
"""
from __future__ import annotations

import argparse
import tempfile
from multiprocessing import Pool
from pathlib import Path

import numpy as np

from benchlib import hifi_run, section_tail, write_section

HEADING = "## Hi-fi outcome against the last bits"
ROOT = Path(__file__).resolve().parent.parent
TABLE2 = Path(__file__).resolve().parent / "last_bits_table2.csv"
STATE = {"end_tape_layers": 5.326237921249263, "tape_tension": 1.5278640450004204}


def _run(job):
    """(case, profile, table2, overrides) -> (overrides, deflection, force, summary)."""
    case, profile, table2, sets = job
    run = hifi_run(case, profile, {k: repr(v) for k, v in sets.items()}, table2)
    c = run.curve
    return sets, c["deflection_mm"].to_numpy(), c["force_N"].to_numpy(), run.summary


def measured(case: str):
    """The measured mean of ``case``'s bending test, prepared as the pipeline prepares it."""
    from harnesspipe.stages.data import prepare_test, read_prepared
    with tempfile.TemporaryDirectory() as tmp:
        h5 = prepare_test(ROOT / "data" / "experimental", f"bend_{case}", Path(tmp) / "m.h5")
        return read_prepared(h5)


def main() -> None:
    import pandas as pd
    from harnesspipe.stages.hifi_chain import curve_vs_measured
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profile", default="quick")
    ap.add_argument("--case", default="cwb19_t2_closed")
    ap.add_argument("--table2", type=Path, default=TABLE2, help="table2.csv of a tensile stage")
    ap.add_argument("--perturb", default="tape_tension", help="the input moved by eps")
    ap.add_argument("--eps", type=float, default=1e-12)
    ap.add_argument("--copies", type=int, default=3)
    ap.add_argument("--angles", default="0,1", help="pack_angle values, deg")
    args = ap.parse_args()
    angles = [float(a) for a in args.angles.split(",")]
    jobs = []
    for angle in angles:
        for k in range(args.copies):
            sets = {**STATE, "pack_angle": angle}
            sets[args.perturb] = sets[args.perturb] * (1.0 + k * args.eps)
            jobs.append((args.case, args.profile, str(args.table2), sets))
    with Pool(2) as pool:
        results = pool.map(_run, jobs, chunksize=1)
    prepared = measured(args.case)
    rows, spread = [], {}
    for sets, u, F, summary in results:
        err = curve_vs_measured(pd.DataFrame({"deflection_mm": u, "force_N": F}), prepared)
        drop = summary.get("force_drop") or {}
        spread.setdefault(sets["pack_angle"], []).append(err["error_l2"])
        rows.append(f"| {sets['pack_angle']:g} | {sets[args.perturb]!r} | {err['error_l2']:.2f} | "
                    f"{100 * err['error_rel']:.1f} | {drop.get('drop_N', 0.0):.2f} N at "
                    f"{drop.get('from_mm', 0.0):.1f}-{drop.get('to_mm', 0.0):.1f} mm |")
        print(rows[-1], flush=True)
    summary_rows = [f"| {a:g} | {np.ptp(e):.2f} |" for a, e in spread.items()]
    state = ", ".join(f"{k} {v!r}" for k, v in STATE.items())
    text = f"""{HEADING}

`bench/bench_last_bits.py --profile {args.profile} --case {args.case}`, Table 2:
`{args.table2.name}`; state {state}, the start interface; `{args.perturb}` moved
by a relative {args.eps:g} per copy (a stand-in for another machine's last bits).

| pack_angle [deg] | {args.perturb} | l2 error [N] | rel. [%] | largest force drop |
|---|---|---|---|---|
""" + "\n".join(rows) + """

Spread of the l2 error over the copies (max - min), per turn of the pack:

| pack_angle [deg] | spread [N] |
|---|---|
""" + "\n".join(summary_rows) + "\n"
    tail = section_tail(HEADING)          # the notes by hand stay
    write_section(HEADING, text + ("\n" + tail + "\n" if tail else ""))


if __name__ == "__main__":
    main()
