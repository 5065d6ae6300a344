"""The hi-fi sensitivity screen in the report (issue 27, item 3).

The screen moves each input the chain could fit and measures how much the calibration
window's curve follows (bench/bench_sensitivity.py, normalised sensitivity
S = (||dF|| / ||F||) / (dp / p) over the window).  It costs some thirty hi-fi runs, so the
pipeline does not rerun it: the bench writes its record, bench/sensitivity.json, and the
report shows that record with the commit and profile it was measured at, beside the chain
step that fits each input (or "kept", an input the chain leaves at its documented value).
"""
from __future__ import annotations

import html
import json
from pathlib import Path

from harnesspipe.stages.chain_settings import STEPS

BARELY = 0.05      # S below this: the window's curve barely sees the input


FIELDS = ("commit", "profile", "date", "step", "rows")


def read_json_record(path: Path | None, expected: str, fields: tuple, row_ok) -> dict | None:
    """A bench's JSON record (an object with ``fields``, its ``rows`` a list of which each
    passes ``row_ok``), or None when there is none; a broken one raises ValueError naming the
    file, what was ``expected`` and what is wrong."""
    if path is None or not Path(path).exists():
        return None
    expected = f"{path}: expected {expected}"
    try:
        record = json.loads(Path(path).read_text())
    except ValueError as exc:
        raise ValueError(f"{expected}; it is not JSON ({exc})") from None
    if not isinstance(record, dict) or any(k not in record for k in fields):
        missing = [k for k in fields if not isinstance(record, dict) or k not in record]
        raise ValueError(f"{expected}; missing: {missing}")
    if not isinstance(record["rows"], list):
        raise ValueError(f"{expected}; rows is not a list")
    bad = [i for i, row in enumerate(record["rows"]) if not (isinstance(row, dict) and row_ok(row))]
    if bad:
        raise ValueError(f"{expected}; rows {bad} are not so")
    return record


def read_record(path: Path | None) -> dict | None:
    """The screen's record, or None when there is none (:func:`read_json_record`)."""
    return read_json_record(
        path, f"bench/bench_sensitivity.py's record, a JSON object with {', '.join(FIELDS)} "
              "(rows: case, input, S per window)", FIELDS,
        lambda row: {"case", "input", "S"} <= row.keys() and isinstance(row["S"], dict))


def fitted_by(name: str) -> str:
    """The chain step that fits ``name``, or 'kept' when no step does."""
    steps = [step for step, s in STEPS.items() if name in s["names"]]
    return ", ".join(steps) or "kept"


def _cell(S: float) -> str:
    text = f"{S:.3f}"
    return f"<span class='note'>{text}</span>" if S < BARELY else f"<b>{text}</b>"


def _added(record: dict) -> str:
    """Rows run later alone (``bench_sensitivity.py --only``), with their commit and date."""
    return "".join(f"; the row {html.escape(a['case'])} / {html.escape(a['input'])} added at "
                   f"commit {html.escape(a['commit'])} on {html.escape(a['date'])}"
                   for a in record.get("added", []))


def section(record: dict | None) -> str:
    """An <h3> block: the screen's table, or nothing when no record is given."""
    if record is None:
        return ""
    rows = []
    for row in record["rows"]:
        cells = ", ".join(f"{html.escape(w)} {_cell(S)}" for w, S in row["S"].items())
        rows.append(f"<tr><td>{html.escape(row['case'])}</td><td>{html.escape(row['input'])}</td>"
                    f"<td>{cells}</td><td>{html.escape(fitted_by(row['input']))}</td></tr>")
    return ("<h3>Sensitivity screen of the calibration windows</h3><p class='note'>"
            "Normalised sensitivity S = (relative l2 change of the window's curve) / (relative "
            f"change of the input), each input moved by {html.escape(record['step'])} from the "
            f"chain's start values; S below {BARELY} (grey) means the window's curve barely sees "
            "the input. Recorded by bench/bench_sensitivity.py at commit "
            f"{html.escape(record['commit'])} on {html.escape(record['date'])}, {html.escape(record['profile'])} "
            "profile" + _added(record) + "; not rerun by this pipeline (about thirty hi-fi runs), "
            "so a model changed since then needs the bench rerun.</p><div class='wide'><table><tr><th>case</th>"
            "<th>input</th><th>S per window</th><th>fitted by</th></tr>"
            + "".join(rows) + "</table></div>")
