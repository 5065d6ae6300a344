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
    with open(path) as f:
        return json.load(f)
