"""Cross-check at the paper's inputs over the build state (issue 27 item 5): the eq. 13
E_eff of each Table 3 case's virtual test at the two bounds of the end bands' wraps, beside
Table 3's E.

Run with the project's venv: ``.venv/bin/python bench/bench_build_band.py [--profile quick]``.
Replaces the section "## Hi-fi E_eff band over the build state" of bench/RESULTS.md.

Each virtual test runs at the paper's Table 2 coverings and interface (config
``paper.table2``, ``paper.interface``: the inputs of the paper's own Table 3) with
``end_tape_layers`` at either bound of ``hifi.pipeline.layers_bounds``; the rest of the build
state at its default.  E_eff is eq. 13 on the run's curve (calibrate/eq13.effective_modulus,
the ROM stage's linear window).  Table 3's E falls inside the band when the build state the
paper does not give could explain it.  Each run is one Numba thread; two run side by side.
"""
from __future__ import annotations

import argparse
import json
from multiprocessing import Pool

from benchlib import write_section

HEADING = "## Hi-fi E_eff band over the build state"


def _run(job):
    """(case, end_tape_layers, profile) -> (case, layers, E_eff, summary)."""
    import os
    os.environ["NUMBA_NUM_THREADS"] = "1"
    from harnesspipe.calibrate.eq13 import effective_modulus
    from harnesspipe.config import load
    from harnesspipe.fe.solvers.central_difference import ExplicitError
    from harnesspipe.models.hifi import three_point
    from harnesspipe.stages.hifi import inputs
    case, layers, profile = job
    cfg = load(overrides={"profile": profile})
    sets = {k: str(v) for k, v in cfg["paper"]["interface"].items()}
    sets["end_tape_layers"] = str(layers)
    for covering, props in cfg["paper"]["table2"].items():
        sets.update({f"{covering}.{k}": str(v) for k, v in props.items()})
    try:
        run = three_point(inputs(cfg, case, sets), n_shapes=1)
    except ExplicitError as err:          # a rejected run is a row of the table, not a crash
        return case, layers, None, {"failed": str(err)}
    c = run.curve
    E = effective_modulus(c["deflection_mm"].to_numpy(), c["force_N"].to_numpy(),
                          cfg["three_point"]["span"], cfg["cases"][case]["r_o"])
    return case, layers, float(E), run.summary


def main() -> None:
    from harnesspipe.config import load
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profile", default="quick")
    args = ap.parse_args()
    cfg = load(overrides={"profile": args.profile})
    bounds = cfg["hifi"]["pipeline"]["layers_bounds"]
    table3 = cfg["paper"]["table3"]
    jobs = [(case, layers, args.profile) for case in table3 for layers in bounds]
    with Pool(2) as pool:
        results = pool.map(_run, jobs, chunksize=1)
    E = {(case, layers): e for case, layers, e, _ in results}
    failed = {(case, layers): s["failed"] for case, layers, _, s in results if "failed" in s}
    rows, out = [], {}
    for case, paper in table3.items():
        pair = [E[(case, b)] for b in bounds]
        out[case] = {"E_eff": pair, "table3_E": paper["E"]}
        cells = " | ".join("failed" if e is None else f"{e:.1f}" for e in pair)
        if None in pair:
            inside = "n/a (a run failed, below)"
        else:
            lo, hi = sorted(pair)
            inside = "yes" if lo <= paper["E"] <= hi else ("below" if paper["E"] < lo else "above")
        rows.append(f"| {case} | {cells} | {paper['E']:.1f} | {inside} |")
        print(rows[-1], flush=True)
    notes = "".join(f"\n* {c}, {b:g} wraps: {why}" for (c, b), why in failed.items())
    text = f"""{HEADING}

`bench/bench_build_band.py --profile {args.profile}`: eq. 13 E_eff [MPa] of each Table 3 case's
virtual test at the paper's Table 2 and interface, with the end bands' wraps at the bounds
of `hifi.pipeline.layers_bounds` ({bounds[0]:g} and {bounds[1]:g}); Table 3's E beside it.
"Table 3 in band": whether the build state the paper does not give could explain its E.

| case | E_eff, {bounds[0]:g} wrap(s) | E_eff, {bounds[1]:g} wraps | Table 3 E | Table 3 in band |
|---|---|---|---|---|
""" + "\n".join(rows) + "\n" + notes + "\n"
    write_section(HEADING, text)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
