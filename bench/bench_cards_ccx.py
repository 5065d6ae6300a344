"""CalculiX runs of the exported three-point decks of every Table 3 row (stand-alone:
``.venv/bin/python bench/bench_cards_ccx.py``).

For each case of the config's ``paper.table3`` (r_o from ``cases``): ``harnesspipe cards
--format calculix``, ``ccx -i three_point`` on one thread, and the pinned ROM curve
(default mesh, 30 increments); the mid-span force of both at 5, 10, 20 and 30 mm, their
deviation, ccx's wall time and its number of increments.  Also the closed-tube deck with
B32R (C3D20R) instead of B32.  Writes the section "## Solver cards in CalculiX" of
bench/RESULTS.md (the test tests/test_cards_ccx.py checks the closed tube within 5 %).
"""
from __future__ import annotations

import os
import platform
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from benchlib import section_tail, write_section
from harnesspipe import rom
from harnesspipe.cards import write_cards
from harnesspipe.cards.ccx_dat import node_print

HEADING = "## Solver cards in CalculiX"
CONFIG = Path(__file__).resolve().parents[1] / "config" / "config.yaml"
CHECK_MM = (5.0, 10.0, 20.0, 30.0)


def run_ccx(folder: Path) -> tuple[np.ndarray, np.ndarray, float]:
    """(deflection, force) of the LOAD node and ccx's wall time."""
    t0 = time.perf_counter()
    subprocess.run(["ccx", "-i", "three_point"], cwd=folder, check=True, capture_output=True,
                   env={**os.environ, "OMP_NUM_THREADS": "1"})
    wall = time.perf_counter() - t0
    out = node_print(folder / "three_point.dat")
    return np.r_[0.0, -out["uy"]], np.r_[0.0, -out["fy"]], wall


def compare(case: str, law: dict, r_o: float, u, F) -> str:
    curve = rom.three_point(**law, radius=r_o, supports="pinned", n_increments=30)
    F_rom = np.interp(CHECK_MM, curve["deflection_mm"], curve["force_N"])
    F_ccx = np.interp(CHECK_MM, u, F) if u[-1] >= CHECK_MM[-1] else np.full(4, np.nan)
    cells = [f"{a:.3f} / {b:.3f} ({100 * (a / b - 1):+.1f} %)" for a, b in zip(F_ccx, F_rom)]
    return " | ".join(cells)


def ccx_version() -> str:
    out = subprocess.run(["ccx", "-v"], capture_output=True, text=True).stdout
    return " ".join(out.split()[-2:]) if "Version" in out else "unknown version"


def main() -> None:
    config = yaml.safe_load(CONFIG.read_text())
    lines = [HEADING, "",
             f"`bench/bench_cards_ccx.py`, {time.strftime('%Y-%m-%d')}, {platform.machine()}, "
             f"ccx {ccx_version()}, one thread.  Mid-span force ccx / pinned ROM [N] "
             "(deviation) of the exported `three_point.inp` (20 B32 elements) at the paper's "
             "Table 3 values (config `paper.table3`, r_o from `cases`).", "",
             "| case | 5 mm | 10 mm | 20 mm | 30 mm | ccx wall [s] | increments |",
             "|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        table = tmp / "table3.csv"
        rows = config["paper"]["table3"]
        table.write_text("case,E,sigma_y,K,n\n" + "".join(
            f"{c},{r['E']},{r['sigma_y']},{r['K']},{r['n']}\n" for c, r in rows.items()))
        folders = write_cards(table, "calculix", tmp / "cards")
        for folder in folders:
            case = folder.name
            law = {k: rows[case][k] for k in ("E", "sigma_y", "K", "n")}
            u, F, wall = run_ccx(folder)
            row = compare(case, law, config["cases"][case]["r_o"], u, F)
            lines.append(f"| {case} | {row} | {wall:.1f} | {u.size - 1} |")
            print(lines[-1], flush=True)
        closed = tmp / "cards" / "cwb19_t2_closed"
        deck = closed / "three_point.inp"
        deck.write_text(deck.read_text().replace("TYPE=B32,", "TYPE=B32R,"))
        u, F, wall = run_ccx(closed)
        law = {k: rows["cwb19_t2_closed"][k] for k in ("E", "sigma_y", "K", "n")}
        lines.append(f"| cwb19_t2_closed, B32R | {compare('closed', law, 7.05, u, F)} | "
                     f"{wall:.1f} | {u.size - 1} |")
        print(lines[-1])
    tail = section_tail(HEADING)
    write_section(HEADING, "\n".join(lines) + ("\n\n" + tail if tail else ""))


if __name__ == "__main__":
    main()
