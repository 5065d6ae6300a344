"""Cross-check at the paper's inputs over the build state (issue 27 item 5): the eq. 13
E_eff of each Table 3 case's virtual test at the corners of the build inputs the chain fits
(the end bands' wraps and the tape's wrapping tension), beside Table 3's E.

Run with the project's venv: ``.venv/bin/python bench/bench_build_band.py [--profile quick]``.
Replaces the section "## Hi-fi E_eff band over the build state" of bench/RESULTS.md and
writes the record bench/build_band.json, which the pipeline's report shows beside its
Table 3 cross-check (report/band.py).

Each virtual test runs at the paper's Table 2 coverings and interface (config
``paper.table2``, ``paper.interface``: the inputs of the paper's own Table 3) with
``end_tape_layers`` and ``tape_tension`` at the bounds of ``hifi.pipeline.layers_bounds``
and ``tension_bounds``; the rest of the build state at its default (``end_tape_binds`` 0,
which the chain's binding step may change).  E_eff is eq. 13 on the run's curve (calibrate/eq13.effective_modulus,
the ROM stage's linear window).  Table 3's E falls inside the band when the build state the
paper does not give could explain it.  Each run is one Numba thread; two run side by side.
"""
from __future__ import annotations

import argparse
import datetime
import json
import subprocess
from multiprocessing import Pool
from pathlib import Path

from benchlib import section_tail, write_section

HEADING = "## Hi-fi E_eff band over the build state"
RECORD = Path(__file__).resolve().parent / "build_band.json"


def _run(job):
    """(case, (end_tape_layers, tape_tension), profile) -> (case, corner, E_eff, summary)."""
    import os
    os.environ["NUMBA_NUM_THREADS"] = "1"
    from harnesspipe.calibrate.eq13 import effective_modulus
    from harnesspipe.config import load
    from harnesspipe.fe.solvers.central_difference import ExplicitError
    from harnesspipe.models.hifi import three_point
    from harnesspipe.stages.hifi import inputs
    case, corner, profile = job
    cfg = load(overrides={"profile": profile})
    sets = {k: str(v) for k, v in cfg["paper"]["interface"].items()}
    sets["end_tape_layers"], sets["tape_tension"] = (str(v) for v in corner)
    for covering, props in cfg["paper"]["table2"].items():
        sets.update({f"{covering}.{k}": str(v) for k, v in props.items()})
    try:
        run = three_point(inputs(cfg, case, sets), n_shapes=1)
    except ExplicitError as err:          # a rejected run is a row of the table, not a crash
        return case, corner, None, {"failed": str(err)}
    c = run.curve
    E = effective_modulus(c["deflection_mm"].to_numpy(), c["force_N"].to_numpy(),
                          cfg["three_point"]["span"], cfg["cases"][case]["r_o"])
    return case, corner, float(E), run.summary


def main() -> None:
    from harnesspipe.config import load
    from harnesspipe.report.band import placement
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profile", default="quick")
    args = ap.parse_args()
    cfg = load(overrides={"profile": args.profile})
    pipe = cfg["hifi"]["pipeline"]
    corners = [(w, T) for w in pipe["layers_bounds"] for T in pipe["tension_bounds"]]
    table3 = cfg["paper"]["table3"]
    jobs = [(case, c, args.profile) for case in table3 for c in corners]
    with Pool(2) as pool:
        results = pool.map(_run, jobs, chunksize=1)
    E = {(case, c): e for case, c, e, _ in results}
    failed = {(case, c): s["failed"] for case, c, _, s in results if "failed" in s}
    rows, out = [], []
    for case, paper in table3.items():
        band = [E[(case, c)] for c in corners]
        out.append({"case": case, "E_eff": band, "table3_E": paper["E"],
                    "failed": [failed.get((case, c)) for c in corners]})
        cells = " | ".join("failed" if e is None else f"{e:.1f}" for e in band)
        rows.append(f"| {case} | {cells} | {paper['E']:.1f} | {placement(paper['E'], band)} |")
        print(rows[-1], flush=True)
    notes = "".join(f"\n* {c}, {w:g} wraps, {T:g} N: {why}" for (c, (w, T)), why in failed.items())
    head = " | ".join(f"{w:g} wrap(s), {T:g} N" for w, T in corners)
    text = f"""{HEADING}

`bench/bench_build_band.py --profile {args.profile}`, {datetime.date.today()}: eq. 13 E_eff [MPa] of
each Table 3 case's virtual test at the paper's Table 2 and interface, at the corners of the
build inputs the chain fits (`end_tape_layers` over `hifi.pipeline.layers_bounds`,
`tape_tension` over `tension_bounds`, N); Table 3's E beside it, and where it lies against
the band: inside, the build state the paper does not give could explain it.

| case | {head} | Table 3 E | Table 3's E |
|---|{"---|" * len(corners)}---|---|
""" + "\n".join(rows) + "\n" + notes + "\n\n" + section_tail(HEADING)
    write_section(HEADING, text)
    write_record(args.profile, corners, out)
    print(json.dumps(out, indent=1))


def write_record(profile: str, corners: list, rows: list[dict]) -> None:
    """bench/build_band.json: each case's E_eff at the ``corners`` (end_tape_layers,
    tape_tension), None for a failed run, beside Table 3's E, with what it was run on."""
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=RECORD.parent).stdout.strip()
    RECORD.write_text(json.dumps({
        "profile": profile, "commit": commit, "date": datetime.date.today().isoformat(),
        "corners": [{"end_tape_layers": w, "tape_tension": T} for w, T in corners],
        "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
