"""Sensitivity screen of the hi-fi calibration cases (issue 27 item 3): how much each input
the chain could fit moves the curve in the window it would be fitted on.

Run with the project's venv: ``.venv/bin/python bench/bench_sensitivity.py [--profile quick]``.
Replaces the section "## Hi-fi sensitivity screen" of bench/RESULTS.md and writes the record
bench/sensitivity.json, which the pipeline's report shows (report/screen.py).

For each calibration case of the chain (Sec. 4.2: the closed and the half-lap CWB for the
friction and cohesive steps, the t2 fabric CWB for E2/E1) and each input, one virtual test
with the input moved by STEP (relative; the build state's ``wire_fill`` and ``tape_tension``
by an absolute step, their defaults being 0, ``end_tape_binds`` from 0 to 1, the closures down by one, their defaults being the
upper bound 1, ``pack_angle`` by 2 deg; a tube's corrugation pitch ``<tube>.pitch``, an
assumption of the paper's Table 2 geometry, by STEP like an interface input) against the base run at the config's start values (a build input at the chain's
start: :func:`harnesspipe.stages.chain_settings.build_start`) and the paper's Table 2.  The normalised sensitivity of a window is

    S = (||F' - F|| / ||F||) / (dp / p)     (l2 over the measured grid inside the window)

so S = 1 means a 1 % change of the input moves the window's curve by 1 %; for ``wire_fill``
and ``tape_tension`` the denominator is the absolute step (per unit fill, per N), for the
closures its size (per unit closure).  Inputs
that cannot act on a case (E2/E1 on a tube) are not run.  Each run is one Numba thread; two run side by side.
"""
from __future__ import annotations

import argparse
import datetime
import json
import subprocess
from multiprocessing import Pool
from pathlib import Path

import numpy as np

from benchlib import hifi_run, section_tail, write_section

HEADING = "## Hi-fi sensitivity screen"
STEP = 0.25                    # relative step of an interface input
ABSOLUTE = {"wire_fill": 0.5, "tape_tension": 2.0,      # defaults 0: absolute steps (fill, N)
            "end_tape_binds": 1.0, "fabric_end_tape_binds": 1.0,   # 0 -> 1: every wire bound, not only those touched
            "tube_closure": -0.5, "sleeve_closure": -0.5,  # defaults 1, the upper bound: down
            "pack_angle": 2.0}                             # deg, from the 1 deg seed turn
RECORD = Path(__file__).resolve().parent / "sensitivity.json"
COMMON = ("pack_angle", "wire_fill", "tape_tension", "mu_rtb", "mu_rtp", "delta0", "delta_f", "alpha_d")
CASES = {                      # calibration case -> (its windows, the inputs that can act on it)
    "cwb19_t2_closed": (("friction_window", "cohesive_window"),
                        ("end_tape_binds", "end_tape_layers", "closed_tube.pitch") + COMMON),
    "cwb19_t2_open_halflap": (("friction_window", "cohesive_window"),
                              ("end_tape_binds", "end_tape_layers", "tube_closure", "open_tube.pitch")
                              + COMMON),
    "cwb19_t2_fabric": (("fabric_window",),
                        ("fabric_end_tape_binds", "fabric_end_tape_layers", "sleeve_closure") + COMMON
                        + ("E2_over_E1",)),
}


def _run(job):
    """(case, input or None, profile) -> (case, input, deflection, force, summary)."""
    from harnesspipe.config import load
    case, name, profile = job
    sets = {} if name is None else {name: str(moved(load(overrides={"profile": profile}), name))}
    run = hifi_run(case, profile, sets)
    c = run.curve
    return case, name, c["deflection_mm"].to_numpy(), c["force_N"].to_numpy(), run.summary


def moved(cfg: dict, name: str) -> float:
    """The input's screened value: its start value moved by STEP (or its ABSOLUTE step)."""
    from harnesspipe.stages.chain_settings import build_start
    from harnesspipe.stages.hifi import parameters
    if name in cfg["hifi"]["build"]:
        value = build_start(cfg, name)
    elif name.endswith(".pitch"):                  # <tube>.pitch: the covering's geometry
        value = cfg["coverings"][name.split(".")[0]]["pitch"]
    else:
        value = parameters(cfg, {})["interface"][name]
    return value + ABSOLUTE[name] if name in ABSOLUTE else value * (1.0 + STEP)


def window_sensitivity(u, F0, F1, window, denominator) -> float:
    """S of the module docstring over the grid points ``u`` inside ``window``."""
    sel = (u >= max(window[0], 0.5)) & (u <= window[1])
    return float(np.linalg.norm(F1[sel] - F0[sel]) / np.linalg.norm(F0[sel]) / denominator)


PAIRS = [(c, n) for c, (_, names) in CASES.items() for n in names]   # the screen's rows, in order


def _selected(only: list[str] | None) -> list[tuple[str, str]]:
    """(case, input) pairs to run: every pair of CASES, or those ``only`` names as
    ``case/input`` (SystemExit naming a pair CASES does not have)."""
    if only is None:
        return PAIRS
    wanted = [tuple(o.split("/", 1)) for o in only]
    unknown = [o for o, w in zip(only, wanted) if w not in PAIRS]
    if unknown:
        raise SystemExit(f"--only {unknown}: expected case/input pairs of CASES, e.g. {'/'.join(PAIRS[0])}")
    return wanted


def _merged(rows: list[dict], old: dict | None) -> list[dict]:
    """The record's rows: the new ones, and the rows of the ``old`` record (``--only``) they
    do not replace, in CASES order."""
    by_pair = {(r["case"], r["input"]): r for r in (old["rows"] if old else []) + rows}
    return [by_pair[p] for p in PAIRS if p in by_pair]


def main() -> None:
    from harnesspipe.config import load
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profile", default="quick")
    ap.add_argument("--only", nargs="+", metavar="CASE/INPUT",
                    help="run these pairs (and their cases' base runs) alone and merge them into "
                         "the recorded screen; its other rows stay as recorded")
    args = ap.parse_args()
    cfg = load(overrides={"profile": args.profile})
    pipe = cfg["hifi"]["pipeline"]
    pairs = _selected(args.only)
    old = json.loads(RECORD.read_text()) if args.only and RECORD.exists() else None
    if args.only and (old is None or old["profile"] != args.profile):
        raise SystemExit(f"--only at {args.profile}: needs {RECORD.name} recorded at that profile "
                         "(run the whole screen first)")
    jobs = [(c, None, args.profile) for c in dict.fromkeys(c for c, _ in pairs)]
    jobs += [(c, name, args.profile) for c, name in pairs]
    with Pool(2) as pool:
        results = pool.map(_run, jobs, chunksize=1)
    curves = {(c, n): (u, F, s) for c, n, u, F, s in results}
    u = np.linspace(0.0, cfg["three_point"]["deflection"], 301)
    table, new_rows = {}, []
    for case, name in pairs:
        windows = CASES[case][0]
        u0, F0, _ = curves[(case, None)]
        u1, F1, _ = curves[(case, name)]
        den = abs(ABSOLUTE.get(name, STEP))
        S = {w: window_sensitivity(u, np.interp(u, u0, F0), np.interp(u, u1, F1), pipe[w], den)
             for w in windows}
        table[f"{case}/{name}"] = S
        new_rows.append({"case": case, "input": name,
                         "S": {w.replace("_window", ""): round(v, 4) for w, v in S.items()}})
    record = _merged(new_rows, old)
    rows = [f"| {r['case']} | {r['input']} | " + " | ".join(f"{w} {v:.3f}" for w, v in r["S"].items())
            + " |" for r in record]
    step = ", ".join(f"{k} {v:+}" for k, v in ABSOLUTE.items())
    text = f"""{HEADING}

`bench/bench_sensitivity.py --profile {args.profile}`: each input the chain could fit moved by
+{100 * STEP:.0f} % ({step}) from the config's start values, the paper's Table 2 coverings; S
= relative l2 change of the curve in the window / relative change of the input (absolute for
wire_fill, per unit fill, tape_tension, per N, end_tape_binds, from 0 to 1, the closures, per unit
closure, and pack_angle,
per deg).  S below ~0.05
means the window's curve barely sees the input.

| case | input | S per window |
|---|---|---|
""" + "\n".join(rows) + "\n"
    tail = section_tail(HEADING)          # the notes by hand stay
    write_section(HEADING, text + ("\n" + tail + "\n" if tail else ""))
    write_record(args.profile, step, record, old, added=new_rows)
    print(json.dumps(table, indent=1))


def write_record(profile: str, step: str, rows: list[dict], old: dict | None, added: list[dict]) -> None:
    """bench/sensitivity.json: the screen's S per case, input and window (``rows``), with what
    it was run on, for the pipeline's report.  With the ``old`` record (an ``--only`` run) the
    record keeps its commit and date, and the rows run now (``added``) name their own."""
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=RECORD.parent).stdout.strip()
    today = datetime.date.today().isoformat()
    head = {"profile": profile, "commit": commit, "date": today}
    extra = []
    if old is not None:
        head = {k: old[k] for k in head}
        replaced = {(r["case"], r["input"]) for r in added}
        extra = [a for a in old.get("added", []) if (a["case"], a["input"]) not in replaced]
        extra += [{"case": r["case"], "input": r["input"], "commit": commit, "date": today} for r in added]
    RECORD.write_text(json.dumps({**head, "step": f"+{100 * STEP:.0f} % ({step})", "rows": rows,
                                  **({"added": extra} if extra else {})}, indent=1) + "\n")


if __name__ == "__main__":
    main()
