"""How many times its wires' own force a bundle carries: tests and virtual tests.

Run with the project's venv: ``.venv/bin/python bench/bench_coupling.py [--results DIR]``.
Replaces the section "## Coupling of the bundles over their wires alone" of bench/RESULTS.md.

For each CWB case with a shipped three-point test: the measured mean's force at a few
deflections over F_free, the force of the same wires bending each on its own
(:mod:`harnesspipe.models.free_wires`, Table 1, default ROM mesh).  What the covering, the
tape and the wires' friction add is the coupling F / F_free.  With ``--results`` (a project's
``results`` folder after the pipeline) the virtual tests' coupling stands beside it.  Two
cases whose inputs differ only in their wires should have a like coupling in a model driven by
the paper's inputs; the bench shows whether the tests do.
"""
from __future__ import annotations

import argparse
import datetime
from pathlib import Path

import numpy as np
import pandas as pd

from benchlib import section_tail, write_section

HEADING = "## Coupling of the bundles over their wires alone"
ROOT = Path(__file__).resolve().parent.parent
AT_MM = (5.0, 10.0, 20.0, 30.0)


def measured_mean(case: str, u: np.ndarray) -> np.ndarray | None:
    """The shipped test's mean force at ``u`` (None when the case has no test)."""
    from harnesspipe.data.experimental import load_test, read_manifest
    data = ROOT / "data" / "experimental"
    entry = read_manifest(data)["tests"].get(f"bend_{case}")
    if entry is None:
        return None
    problems: list[str] = []
    ts = load_test(data, f"bend_{case}", entry, problems)
    if ts is None:
        raise SystemExit(f"bench_coupling: bend_{case}: " + "; ".join(problems))
    return np.interp(u, ts.grid, ts.mean)


def virtual(results: Path | None, case: str, u: np.ndarray) -> np.ndarray | None:
    """The virtual test's force at ``u`` from ``results/hifi/virtual/<case>/curve.csv``."""
    path = None if results is None else results / "hifi" / "virtual" / case / "curve.csv"
    if path is None or not path.exists():
        return None
    c = pd.read_csv(path)
    return np.interp(u, c["deflection_mm"].to_numpy(), c["force_N"].to_numpy())


def _cells(F, F_free) -> str:
    from harnesspipe.models.free_wires import coupling
    if F is None:
        return " | ".join(["-"] * len(AT_MM))
    return " | ".join(f"{f:.2f} ({c:.2f}x)" for f, c in zip(F, coupling(F, F_free)))


def table(cfg: dict, results: Path | None) -> list[str]:
    from harnesspipe.models.free_wires import free_wire_force
    u = np.array(AT_MM)
    head = " | ".join(f"{x:g} mm" for x in AT_MM)
    rows = [f"| case | curve | {head} |", "|---|---|" + "---|" * len(AT_MM)]
    for case, c in cfg["cases"].items():
        F_test = measured_mean(case, u)
        if F_test is None or c["covering"] == "none":
            continue
        F_free = free_wire_force(cfg, c["wires"], u, cfg["profiles"]["default"]["rom"])
        wires = ", ".join(f"{n} {t.replace('wire_', '')}" for t, n in c["wires"].items())
        rows.append(f"| {case} | wires alone ({wires}) | " + " | ".join(f"{f:.2f}" for f in F_free) + " |")
        rows.append(f"| | test (mean) | {_cells(F_test, F_free)} |")
        if results is not None:
            rows.append(f"| | virtual test | {_cells(virtual(results, case, u), F_free)} |")
    return rows


def main() -> None:
    from harnesspipe.config import load
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", type=Path, default=None,
                    help="a project's results folder with the virtual tests (hifi/virtual)")
    args = ap.parse_args()
    cfg = load()
    source = f" virtual tests from `{args.results.name}/hifi/virtual`" if args.results else ""
    text = "\n".join([
        HEADING, "",
        f"`bench/bench_coupling.py`, {datetime.date.today()}.  Force [N] at the crosshead "
        f"deflection, and in brackets its coupling F / F_free over the wires alone (each wire "
        f"bending on its own: Table 1, default ROM mesh);{source or ' no virtual tests given'}.",
        "", *table(cfg, args.results), "", section_tail(HEADING)])
    write_section(HEADING, text)
    print(text)


if __name__ == "__main__":
    main()
