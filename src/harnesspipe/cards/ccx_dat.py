"""Reading the *NODE PRINT blocks of a CalculiX ``.dat`` file.

CalculiX prints, per increment and request, a header such as

    displacements (vx,vy,vz) for set LOAD and time  0.1000000E-01

then one line per node: its number and three components (with TOTALS=YES also a
``total force`` line).  :func:`node_print` collects every block of a node set into one
table, one row per (time, node), and pairs the displacement and force of each.
"""
from __future__ import annotations

import re
from pathlib import Path

import pandas as pd

HEADER = re.compile(r"^\s*(displacements|forces)\s*\([^)]*\)\s*for set\s+(\S+)\s+and time\s+(\S+)",
                    re.IGNORECASE)
ROW = re.compile(r"^\s*(\d+)\s+(\S+)\s+(\S+)\s+(\S+)\s*$")
COLUMNS = {"displacements": ("ux", "uy", "uz"), "forces": ("fx", "fy", "fz")}


def node_print(path, nset: str = "LOAD") -> pd.DataFrame:
    """Columns time, node, ux, uy, uz, fx, fy, fz of every increment printed for ``nset``
    (ValueError when the file holds none)."""
    path = Path(path)
    records: dict[tuple[float, int], dict] = {}
    block = None
    for line in path.read_text(errors="replace").splitlines():
        head = HEADER.match(line)
        if head:
            kind, name, time = head.groups()
            block = (kind.lower(), float(time)) if name.upper() == nset.upper() else None
            continue
        row = ROW.match(line) if block else None
        if row:
            kind, time = block
            values = dict(zip(COLUMNS[kind], map(float, row.groups()[1:])))
            records.setdefault((time, int(row.group(1))), {}).update(values)
        elif line.strip() and block:
            block = None                      # e.g. a "total force" line ends the block
    if not records:
        raise ValueError(f"{path}: no *NODE PRINT output for set {nset}")
    frame = pd.DataFrame([{"time": t, "node": n, **v} for (t, n), v in sorted(records.items())])
    return frame.dropna().reset_index(drop=True)
