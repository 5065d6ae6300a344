"""The cross-check at the paper's inputs as a band over the build state (issue 27, item 5).

The paper never gives the specimens' build state, so its Table 3 E can only be checked
against the range the virtual test spans over it: bench/bench_build_band.py runs each Table 3
case at the paper's Table 2 and interface, at the corners of the build inputs the chain fits
(the end bands' wraps ``end_tape_layers`` and the tape's wrapping tension ``tape_tension``),
and takes eq. 13's E_eff of each curve.  Twenty hi-fi runs: the pipeline does not rerun them;
the bench writes its record, bench/build_band.json, and the report shows it beside Table 3
with the commit and profile it was measured at.
"""
from __future__ import annotations

import html
from pathlib import Path

from harnesspipe.report.names import labelled
from harnesspipe.report.screen import read_json_record

FIELDS = ("commit", "profile", "date", "corners", "rows")


def placement(E: float, band: list) -> str:
    """Where Table 3's ``E`` lies against the E_eff of the runs that ran (None: failed)."""
    ran = [e for e in band if e is not None]
    if not ran:
        return "no run"
    if min(ran) <= E <= max(ran):
        return "inside"
    return "below the band" if E < min(ran) else "above the band"


def read_record(path: Path | None) -> dict | None:
    """The band's record, or None when there is none (ValueError when it is broken)."""
    record = read_json_record(
        path, f"bench/bench_build_band.py's record, a JSON object with {', '.join(FIELDS)} "
              "(rows: case, E_eff per corner, table3_E)", FIELDS,
        lambda row: {"case", "E_eff", "table3_E"} <= row.keys() and isinstance(row["E_eff"], list))
    if record is not None:
        n = len(record["corners"])
        if any(len(row["E_eff"]) != n for row in record["rows"]):
            raise ValueError(f"{path}: every row's E_eff needs one value per corner ({n})")
    return record


def _corner(c: dict) -> str:
    w, T = c["end_tape_layers"], c["tape_tension"]
    return f"{w:g} wrap{'s' if w != 1 else ''}, {T:g} N"


def section(record: dict | None, cfg: dict) -> str:
    """An <h3> block: E_eff per corner beside Table 3's E, or nothing without a record."""
    if record is None:
        return ""
    rows = []
    for row in record["rows"]:
        cells = "".join(f"<td>{'failed' if e is None else f'{e:.1f}'}</td>" for e in row["E_eff"])
        where = placement(row["table3_E"], row["E_eff"])
        css = "" if where == "inside" else " class='bad'"
        rows.append(f"<tr><td>{html.escape(labelled(row['case'], cfg))}</td>{cells}"
                    f"<td>{row['table3_E']:.1f}</td><td{css}>{where}</td></tr>")
    inside = sum(placement(r["table3_E"], r["E_eff"]) == "inside" for r in record["rows"])
    head = "".join(f"<th>{html.escape(_corner(c))}</th>" for c in record["corners"])
    return ("<h3>Table 3's E against the band over the build state</h3><p class='note'>"
            "eq. 13 E_eff [MPa] of each case's virtual test at the paper's Table 2 and interface, "
            "at the corners of the bounds the chain fits two build inputs within (end_tape_layers: "
            "wraps of the end bands; tape_tension: the tape's wrapping tension), which the paper "
            "does not give; the other build inputs at their defaults (end_tape_binds 0). "
            f"Table 3's E lies inside the band for {inside} of {len(record['rows'])} cases: where it "
            "lies outside, no build state between these bounds explains it. Recorded by "
            f"bench/bench_build_band.py at commit {html.escape(record['commit'])} on "
            f"{html.escape(record['date'])}, {html.escape(record['profile'])} profile; not rerun by "
            "this pipeline (twenty hi-fi runs), so a model changed since needs the bench rerun.</p>"
            f"<div class='wide'><table><tr><th>case</th>{head}<th>Table 3 E</th>"
            "<th>where Table 3's E lies</th></tr>" + "".join(rows) + "</table></div>")
