"""Artefacts every fitting stage writes, in one format the report reads.

``<outdir>/fit.json``   parameters, error norms, evaluations, wall time, test id
``<outdir>/curve.csv``  simulated curve at the fitted parameters (displacement_mm, force_N)
``<outdir>/trace.h5``   every optimiser evaluation (written by calibrate.simplex)
``<outdir>/fit.png``    measured band, mean and fitted curve
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from harnesspipe.input_files import read_json


def write_json(path: Path, payload: dict) -> None:
    """Atomic JSON write (a failed run never leaves a valid-looking file)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(payload, indent=2, sort_keys=False, default=_plain))
    tmp.replace(path)


def write_csv(path: Path, frame: pd.DataFrame) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    frame.to_csv(tmp, index=False, float_format="%.8g")
    tmp.replace(path)


def _plain(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def write_fit(outdir: Path, *, stage: str, item: str, test_id: str, parameters: dict,
              error_l2: float, error_rel: float, nfev: int, converged: bool, wall_s: float,
              curve: pd.DataFrame, extra: dict | None = None) -> Path:
    """Write fit.json and curve.csv of one fitted item; returns fit.json's path."""
    outdir = Path(outdir)
    write_csv(outdir / "curve.csv", curve)
    payload = {"stage": stage, "item": item, "test_id": test_id,
               "parameters": {k: float(v) for k, v in parameters.items()},
               "error_l2": float(error_l2), "error_rel": float(error_rel), "nfev": int(nfev),
               "converged": bool(converged), "wall_s": float(wall_s), **(extra or {})}
    write_json(outdir / "fit.json", payload)
    return outdir / "fit.json"


def read_fit(path: Path) -> dict:
    """A fit.json (or any JSON record of a stage); not JSON: InputFileError naming the file."""
    return read_json(path)


def write_shapes(outdir: Path, shapes: dict, stem: str = "shape") -> Path:
    """Deformed centre lines for ParaView: one VTU (polyline) per frame and a PVD index.

    ``shapes`` maps a crosshead displacement to an (n_nodes, 3) array.  Also writes
    ``shapes.csv`` (displacement_mm, node, x_mm, y_mm, z_mm) for plotting.
    """
    import meshio

    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    entries, rows = [], []
    for k, (d, xyz) in enumerate(sorted(shapes.items())):
        xyz = np.asarray(xyz, dtype=float)
        cells = [("line", np.column_stack([np.arange(len(xyz) - 1), np.arange(1, len(xyz))]))]
        name = f"{stem}_{k:03d}.vtu"
        meshio.write(outdir / name, meshio.Mesh(xyz, cells))
        entries.append(f'    <DataSet timestep="{float(d):g}" file="{name}"/>')
        rows += [(float(d), i, *p) for i, p in enumerate(xyz)]
    pvd = outdir / "shapes.pvd"
    pvd.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
                   + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")
    write_csv(outdir / "shapes.csv",
              pd.DataFrame(rows, columns=["displacement_mm", "node", "x_mm", "y_mm", "z_mm"]))
    return pvd
