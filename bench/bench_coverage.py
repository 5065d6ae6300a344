"""Coverage study of the tensile and ROM stages' 95 % intervals (issue 29, item 4).

Run with the project's venv: ``.venv/bin/python bench/bench_coverage.py [--stage
tensile|rom] [--seeds N]`` (default: tensile, 20 seeds, about 20 s each on one core;
rom: about 2 min per seed for the six three-point cases).  For each seed the synthetic
twin's tests of the stage are regenerated (specimen scatter and load-cell noise as the
config's ``synthesize`` section, curves on the quick mesh: the tensile quick preset, the
quick profile's ROM mesh) and fitted by the stage (same mesh, like for like; a simplex
budget of ``--maxfev`` so that every fit converges; the ROM stage on the measured mean).
Each reported interval is checked against the truth it is meant to contain
(:mod:`harnesspipe.calibrate.coverage`): Fisher against the tested specimens' own
parameters, the replicate sandwich against the population value.  Writes the section
"## Interval coverage (issue 29)" (tensile) or "## Interval coverage of the ROM stage
(issue 29)" of bench/RESULTS.md (notes below its "### By hand" sub-heading are kept).
``--save FILE`` writes the interval records to JSON (after every seed) instead of the
section (a run split over seeds, ``--seed0``), ``--load FILE ...`` writes the section from such files merged,
without fitting again.
"""
from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from benchlib import section_tail, write_section

HEADINGS = {"tensile": "## Interval coverage (issue 29)",
            "rom": "## Interval coverage of the ROM stage (issue 29)"}
ITEMS = {"tensile": ("closed_tube", "open_tube", "fabric_tube"),
         "rom": ("cwb19_t2_closed", "cwb19_t2_open_halflap", "cwb19_t2_open_coarse",
                 "cwb19_t2_fabric", "cwb10t1_9t2_fabric", "cwb19_t1_open_coarse")}
SEED0 = 1000   # seeds SEED0 .. SEED0 + N - 1 (the shipped twin's seed is not among them)


def run(stage: str, seeds: int, maxfev: int, seed0: int = SEED0, items=None) -> tuple[list[dict], float]:
    """Interval records of seeds ``seed0`` .. ``seed0 + seeds - 1`` for ``items`` (default:
    every item of ``stage``), and the mean wall time per seed."""
    from harnesspipe.calibrate.coverage import rom_seed, tensile_seed
    from harnesspipe.config import load
    cfg = load()
    one_seed = tensile_seed if stage == "tensile" else rom_seed
    rows, t0 = [], time.perf_counter()
    for k in range(seeds):
        with tempfile.TemporaryDirectory() as work:
            rows += one_seed(cfg, seed0 + k, items or ITEMS[stage], Path(work), maxfev=maxfev)
        print(f"seed {k + 1}/{seeds}: {time.perf_counter() - t0:.0f} s", flush=True)
    return rows, (time.perf_counter() - t0) / seeds


def _cell(entry: dict | None) -> str:
    if entry is None or entry["coverage"] is None:
        return "no SE | -"
    missing = entry["seeds"] - entry["intervals"]
    note = f" ({missing} without SE)" if missing else ""
    flag = "" if entry["coverage"] >= 0.88 else " **low**"
    return (f"{100 * entry['coverage']:.0f} % ({entry['covered']}/{entry['intervals']}){flag}"
            f"{note} | {entry['median_abs_z']:.2f}")


def table(rows: list[dict], item: str = "component") -> str:
    """Markdown: per item and quantity, Fisher and sandwich coverage and median |z|."""
    from harnesspipe.calibrate.coverage import coverage_table
    by = {(e["component"], e["kind"], e["quantity"]): e for e in coverage_table(rows)}
    lines = [f"| {item} | quantity | Fisher coverage | Fisher median abs(z) | sandwich coverage "
             "| sandwich median abs(z) |", "|---|---|---|---|---|---|"]
    quantities = dict.fromkeys((r["component"], r["quantity"]) for r in rows)
    for component, quantity in quantities:
        cells = [_cell(by.get((component, kind, quantity))) for kind in ("fisher", "sandwich")]
        lines.append(f"| {component} | {quantity} | {cells[0]} | {cells[1]} |")
    return "\n".join(lines)


def overall(rows: list[dict], kind: str) -> str:
    have = [r for r in rows if r["kind"] == kind and r["covered"] is not None]
    return f"{100 * sum(r['covered'] for r in have) / len(have):.1f} % of {len(have)}"


INTERVALS = """Nominal 95 % intervals, estimate * exp(+-q SE) with SE in ln p:

* **Fisher** (fit.json `fisher`, noise read off the rows; q = 1.96) describes the load-cell
  noise alone, so its truth is the *tested specimens'* parameters: what the stage's
  estimator finds on the specimens' mean curve without noise (Gauss-Newton from the
  specimens' mean parameters, which the twin records; the mean parameters themselves differ
  from it by the model's curvature over the 4 % scatter, several Fisher SEs for the
  fabric's K and n){rom_truth};
* **sandwich** (fit.json `standard_error`, 2 dof; q = t(2) = 4.30) describes the
  population the specimens are drawn from: its truth is the generating value ({table})."""

READING = """Nominal 95 % should come out between 88 and 99 %; at 20 seeds the
counts move in steps of 5 % and 20/20 is the likeliest count for a right 95 % interval
(P = 36 %; 17/20 or fewer: P = 7.5 %), so only coverage below 88 % is marked **low**.
median abs(z): the median of |ln(estimate / truth)| / SE, 0.67 for a right Fisher SE
(normal), 0.82 for a right sandwich on 2 dof (Student t); an SE too small by sqrt(3) gives
1.17 and 1.42."""


def section(stage: str, rows: list[dict], seeds: int, per_seed: float, maxfev: int) -> str:
    items = ITEMS[stage]
    unconverged = len({(r["seed"], r["component"]) for r in rows if not r["converged"]})
    run_line = (f"`bench/bench_coverage.py --stage {stage} --seeds {seeds} --maxfev {maxfev}` "
                f"({per_seed:.0f} s per seed on one core).")
    if stage == "tensile":
        what = f"""The synthetic twin's tensile tests regenerated at {seeds} seeds (3 specimens, 4 % specimen
scatter of each parameter, 0.5 % load-cell noise, 201 rows; curves on the quick mesh) and
fitted by the tensile stage on the quick mesh (like for like; simplex budget {maxfev},
{unconverged} of {seeds * len(items)} fits not converged)."""
        intervals = INTERVALS.format(rom_truth="", table="Table 2")
        flow = """Flow stress sigma_Y + K eps_p^n at the issue's strains (tubes 1e-2, 0.1; the fabric, whose
test reaches ~2.5 % plastic strain, 5e-3 and 2.5e-2), its SE by the delta method from the
reported correlations."""
    else:
        what = f"""The synthetic twin's three-point tests regenerated at {seeds} seeds (3 specimens, 4 %
specimen scatter of each parameter, 0.5 % load-cell noise, 201 rows; curves by the ROM on
the quick profile's mesh) and fitted by the ROM stage on the same mesh (the measured mean
as reference; E by eq. 13 with the model-consistent factor, then the flow-stress simplex on
(sigma_Y, K, n), then E matched to the data's eq. 13 slope with the model at the fitted
hardening, jointly with the hardening's least squares (``rom.consistent_E_model:
elastoplastic``); simplex budget {maxfev}, {unconverged} of {seeds * len(items)} fits not
converged)."""
        intervals = INTERVALS.format(
            rom_truth="; for the ROM stage the same estimating equations (E's over eq. 13's "
                      "window, the hardening's least squares) on that noise-free mean curve",
            table="Table 3; cwb19_t1_open_coarse: the twin's scaled coarse-taped set")
        flow = """Flow stress sigma_Y + K eps_p^n at the issue's strains (2e-3, 5e-3, 2e-2), its SE by the
delta method from the reported correlations."""
    return f"""{HEADINGS[stage]}

{run_line}
{what}
{intervals}

{flow}  {READING}

{table(rows, "component" if stage == "tensile" else "case")}

Overall: Fisher {overall(rows, "fisher")} intervals, sandwich {overall(rows, "sandwich")}.

{section_tail(HEADINGS[stage]) or ""}"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", choices=sorted(ITEMS), default="tensile")
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--maxfev", type=int, default=1000)
    parser.add_argument("--seed0", type=int, default=SEED0, help="first seed")
    parser.add_argument("--items", nargs="+", help="only these components / cases (with --save)")
    parser.add_argument("--save", type=Path, help="write the interval records to this JSON file "
                                                  "(and no section: for runs split over seeds)")
    parser.add_argument("--load", type=Path, nargs="+",
                        help="records of earlier runs, merged (no fitting)")
    args = parser.parse_args()
    if args.save:                                  # rewritten after every seed
        rows, wall = [], 0.0
        for k in range(args.seeds):
            seed_rows, seconds = run(args.stage, 1, args.maxfev, args.seed0 + k, args.items)
            rows, wall = rows + seed_rows, wall + seconds
            args.save.write_text(json.dumps({"stage": args.stage, "seeds": k + 1,
                                             "maxfev": args.maxfev, "per_seed_s": wall / (k + 1),
                                             "rows": rows}))
        print(table(rows))
        return
    if args.load:
        saved = [json.loads(path.read_text()) for path in args.load]
        rows = [r for run_ in saved for r in run_["rows"]]
        args.stage, args.maxfev = saved[0]["stage"], saved[0]["maxfev"]
        args.seeds = sum(run_["seeds"] for run_ in saved)
        per_seed = sum(run_["per_seed_s"] * run_["seeds"] for run_ in saved) / args.seeds
    else:
        rows, per_seed = run(args.stage, args.seeds, args.maxfev, args.seed0)
    write_section(HEADINGS[args.stage], section(args.stage, rows, args.seeds, per_seed, args.maxfev))
    print(table(rows))


if __name__ == "__main__":
    main()
