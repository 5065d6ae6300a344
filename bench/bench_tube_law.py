"""The ridged tube's wall law in the hi-fi virtual tests (issue 27 item 1): each plastic-tube
CWB run with the isotropic J2 equivalent shell and with the resultant law
(fe/materials/tube_wall.py), against the shipped measured means.

Run with the project's venv after a pipeline run (it reads the pipeline's Table 2, interface
and prepared test data; without them, the paper's Table 2 and interface):
``.venv/bin/python bench/bench_tube_law.py [--profile quick] [--results results]``.
Replaces the section "## Hi-fi tube wall law" of bench/RESULTS.md (keeping its notes by hand).

Per run: relative l2 force error over 0.5-30 mm against the measured mean (the pipeline's
fidelity measure, stages/hifi_chain.curve_vs_measured), the force at 5 / 10 / 20 / 30 mm,
eq. 13 E_eff, wall time, KE/IE past a third of the stroke and the energy balance error.
One Numba thread per run, two runs side by side.
"""
from __future__ import annotations

import argparse
import json
import time
from multiprocessing import Pool
from pathlib import Path

from benchlib import section_tail, write_section

HEADING = "## Hi-fi tube wall law"
CASES = ("cwb19_t2_closed", "cwb19_t2_open_halflap", "cwb19_t2_open_coarse",
         "cwb19_t1_open_coarse")
LAWS = ("isotropic", "resultant")
AT = (5.0, 10.0, 20.0, 30.0)


def _run(job):
    """(case, law, profile, results) -> row dict."""
    import os
    os.environ["NUMBA_NUM_THREADS"] = "1"
    import numpy as np
    from harnesspipe.calibrate.eq13 import effective_modulus
    from harnesspipe.config import load
    from harnesspipe.fe.solvers.central_difference import ExplicitError
    from harnesspipe.models.hifi import three_point
    from harnesspipe.stages.data import read_prepared
    from harnesspipe.stages.hifi import inputs, interface_choice
    from harnesspipe.stages.hifi_chain import curve_vs_measured
    case, law, profile, results = job
    cfg = load(overrides={"profile": profile})
    for cov in ("closed_tube", "open_tube"):
        cfg["coverings"][cov]["wall_law"] = law
    res = Path(results)
    interface = res / "hifi" / "interface.csv"
    _, itf = interface_choice(cfg, interface if interface.exists() else "paper")
    table2 = res / "tensile" / "table2.csv"
    sets = {}
    if not table2.exists():
        table2 = None
        for covering, props in cfg["paper"]["table2"].items():
            sets.update({f"{covering}.{k}": str(v) for k, v in props.items()})
    t0 = time.perf_counter()
    try:
        run = three_point(inputs(cfg, case, sets, table2, itf), n_shapes=1)
    except (ExplicitError, ValueError) as err:     # ValueError: a build the law does not model
        return {"case": case, "law": law, "failed": str(err).splitlines()[0]}
    wall = time.perf_counter() - t0
    c = run.curve
    u, F = c["deflection_mm"].to_numpy(), c["force_N"].to_numpy()
    row = {"case": case, "law": law, "wall_s": wall, "F": [float(np.interp(a, u, F)) for a in AT],
           "E_eff": float(effective_modulus(u, F, cfg["three_point"]["span"],
                                            cfg["cases"][case]["r_o"])),
           "ke_ie": run.summary.get("ke_ie_max"), "energy_error": run.summary.get("energy_error"),
           "interface": "pipeline" if interface.exists() else "paper",
           "table2": "pipeline" if table2 else "paper"}
    measured = res / "data" / f"bend_{case}.h5"
    if measured.exists():
        prep = read_prepared(measured)
        row["error_rel"] = curve_vs_measured(c, prep)["error_rel"]
        row["F_measured"] = [float(np.interp(a, prep.grid, prep.mean)) for a in AT]
    return row


def _cells(r) -> str:
    if "failed" in r:
        return f"failed: {r['failed']} | | | | |"
    err = f"{100 * r['error_rel']:.1f} %" if "error_rel" in r else "n/a"
    F = " / ".join(f"{f:.2f}" for f in r["F"])
    return (f"{err} | {F} | {r['E_eff']:.1f} | {r['ke_ie']:.3f} | {r['energy_error']:.1e} | "
            f"{r['wall_s']:.0f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profile", default="quick")
    ap.add_argument("--results", default="results")
    args = ap.parse_args()
    jobs = [(case, law, args.profile, args.results) for case in CASES for law in LAWS]
    with Pool(2) as pool:
        rows = pool.map(_run, jobs, chunksize=1)
    lines = []
    for r in rows:
        meas = " / ".join(f"{f:.2f}" for f in r.get("F_measured", []))
        lines.append(f"| {r['case']} | {r['law']} | {_cells(r)} | {meas} |")
        print(lines[-1], flush=True)
    first = next((r for r in rows if "failed" not in r), {})
    text = f"""{HEADING}

`bench/bench_tube_law.py --profile {args.profile}`: the plastic-tube CWBs with the ridged wall
as the isotropic J2 equivalent shell and as the resultant law (docs/theory/tube_equivalent.md),
at the {first.get('table2', '?')} Table 2 and the {first.get('interface', '?')} interface;
relative l2 error over 0.5-30 mm against the measured mean, force at {' / '.join(f'{a:g}' for a in AT)} mm,
eq. 13 E_eff [MPa] (Table 3: closed 15.7, half-lap 20.6, coarse 18.7), KE/IE past a third of
the stroke, energy balance error, wall time of one run [s] (one thread, two runs side by side).

| case | wall law | rel. l2 error | F [N] | E_eff | KE/IE | energy error | wall [s] | measured F [N] |
|---|---|---|---|---|---|---|---|---|
""" + "\n".join(lines) + "\n\n" + section_tail(HEADING)
    write_section(HEADING, text)
    print(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
