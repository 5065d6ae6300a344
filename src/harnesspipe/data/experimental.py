"""Test data: manifest, CSV validation, replicate resampling (DESIGN sec. 4).

Layout (documented for users in data/experimental/README.md)::

    manifest.yaml            one entry per test, each with its replicate samples
    <file>.csv               time_s, displacement_mm, force_N -- one row per DAQ sample
    <markers>.csv (optional) time_s, displacement_mm, marker, x_mm, y_mm

Every problem becomes one line naming the file and the row (file line number,
header = line 1), collected into a :class:`DataError`.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml
from jsonschema import Draft202012Validator

from harnesspipe.config import REPO_ROOT, yaml_problem
from harnesspipe.validate import force_sign_problem

MANIFEST = "manifest.yaml"
MANIFEST_SCHEMA = REPO_ROOT / "workflow" / "schemas" / "manifest.schema.yaml"
CURVE_COLUMNS = ("time_s", "displacement_mm", "force_N")
MARKER_COLUMNS = ("time_s", "displacement_mm", "marker", "x_mm", "y_mm")
MIN_ROWS = 10
METRES_RATIO = 1e-2   # max |u| below stroke * this: values look like metres
OVERRUN_RATIO = 1.5   # max |u| above stroke * this: the stated stroke (or the unit) is wrong
KILONEWTON_RATIO = 1e-3  # max |F| below load cell * this: values look like kN


class DataError(ValueError):
    """Bad test data: ``problems`` holds one line per problem (file, row, what)."""

    def __init__(self, problems: list[str]):
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


@dataclass
class Sample:
    name: str
    path: Path
    time: np.ndarray
    displacement: np.ndarray
    force: np.ndarray
    markers: np.ndarray | None = None  # rows: time, displacement, marker, x, y


@dataclass
class TestSet:
    """Replicates of one test and their resampled statistics."""

    test_id: str
    entry: dict
    samples: list[Sample]
    grid: np.ndarray = field(default=None)
    mean: np.ndarray = field(default=None)
    lo: np.ndarray = field(default=None)
    hi: np.ndarray = field(default=None)


def read_manifest(data_dir: Path) -> dict:
    data_dir = Path(data_dir)
    path = data_dir / MANIFEST
    if not path.exists():
        raise DataError([f"{path}: manifest not found"])
    try:
        with open(path) as f:
            manifest = yaml.safe_load(f)
    except yaml.YAMLError as exc:
        raise DataError([yaml_problem(path, exc)]) from None
    with open(MANIFEST_SCHEMA) as f:
        validator = Draft202012Validator(yaml.safe_load(f))
    problems = [f"{path}: {'.'.join(map(str, e.absolute_path)) or '(top level)'}: {e.message}"
                for e in validator.iter_errors(manifest or {})]
    if problems:
        raise DataError(problems)
    return manifest


def _read_table(path: Path, columns: tuple[str, ...], numeric: tuple[str, ...], problems):
    """Rows of a CSV as float arrays per column, or None after recording problems."""
    if not path.exists():
        problems.append(f"{path}: file not found")
        return None
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        problems.append(f"{path}: line 1: empty file (expected header {','.join(columns)})")
        return None
    header = [h.strip() for h in rows[0]]
    missing = [c for c in columns if c not in header]
    if missing:
        problems.append(f"{path}: line 1: missing column(s) {', '.join(missing)}; "
                        f"expected {','.join(columns)}, found {','.join(header)}")
        return None
    index = {c: header.index(c) for c in columns}
    values = {c: [] for c in numeric}
    for line_no, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        for c in numeric:
            cell = row[index[c]].strip() if index[c] < len(row) else ""
            try:
                v = float(cell)
            except ValueError:
                problems.append(f"{path}: line {line_no}: {c}: {cell!r} is not a number"
                                if cell else f"{path}: line {line_no}: {c}: empty cell")
                return None
            if math.isnan(v) or math.isinf(v):
                problems.append(f"{path}: line {line_no}: {c}: {cell} is not a finite number")
                return None
            values[c].append(v)
    n = len(values[numeric[0]])
    if n < MIN_ROWS:
        problems.append(f"{path}: {n} data rows, at least {MIN_ROWS} needed")
        return None
    return {c: np.asarray(v) for c, v in values.items()}


def _check_curve(path: Path, t: dict, entry: dict, problems) -> bool:
    ok = True
    u, F = t["displacement_mm"], t["force_N"]
    if entry.get("monotonic", True):
        bad = np.nonzero(np.diff(u) <= 0.0)[0]
        if bad.size:
            i = int(bad[0])
            kind = "repeats" if u[i + 1] == u[i] else "decreases from"
            problems.append(f"{path}: line {i + 3}: displacement_mm {u[i + 1]:g} {kind} "
                            f"{u[i]:g} (loading is monotonic)")
            ok = False
    proto = entry["protocol"]
    if np.max(np.abs(u)) < METRES_RATIO * proto["stroke_mm"]:
        problems.append(f"{path}: displacement_mm peaks at {np.max(np.abs(u)):g} for a "
                        f"{proto['stroke_mm']:g} mm stroke: values look like metres, expected mm")
        ok = False
    if np.max(np.abs(u)) > OVERRUN_RATIO * proto["stroke_mm"]:
        problems.append(f"{path}: displacement_mm reaches {np.max(np.abs(u)):g}, beyond the "
                        f"{proto['stroke_mm']:g} mm stroke of protocol.stroke_mm: the stroke or "
                        "the unit (expected mm) is wrong")
        ok = False
    if np.max(np.abs(F)) < KILONEWTON_RATIO * proto["load_cell_N"]:
        problems.append(f"{path}: force_N peaks at {np.max(np.abs(F)):g} with a "
                        f"{proto['load_cell_N']:g} N load cell: values look like kN, expected N")
        ok = False
    sign = force_sign_problem(F)
    if sign:
        problems.append(f"{path}: {sign}")
        ok = False
    if np.max(np.abs(F)) > proto["load_cell_N"]:
        problems.append(f"{path}: force_N reaches {np.max(np.abs(F)):g}, beyond the "
                        f"{proto['load_cell_N']:g} N load cell: check the unit (expected N)")
        ok = False
    return ok


def load_test(data_dir: Path, test_id: str, entry: dict, problems: list[str],
              n_grid: int = 101) -> TestSet | None:
    """Read and check every sample of one test; resample when all are good."""
    data_dir = Path(data_dir)
    samples = []
    for s in entry["samples"]:
        path = data_dir / s["file"]
        t = _read_table(path, CURVE_COLUMNS, CURVE_COLUMNS, problems)
        if t is None or not _check_curve(path, t, entry, problems):
            continue
        markers = None
        if "markers" in s:
            m = _read_table(data_dir / s["markers"], MARKER_COLUMNS, MARKER_COLUMNS, problems)
            if m is None:
                continue
            markers = np.column_stack([m[c] for c in MARKER_COLUMNS])
        samples.append(Sample(s["name"], path, t["time_s"], t["displacement_mm"], t["force_N"], markers))
    if len(samples) != len(entry["samples"]):
        return None
    return resample(TestSet(test_id, entry, samples), n_grid)


def resample(ts: TestSet, n_grid: int = 101) -> TestSet:
    """Common grid 0..(smallest max displacement); mean and min/max band of the replicates."""
    u_end = min(float(s.displacement[-1]) for s in ts.samples)
    ts.grid = np.linspace(0.0, u_end, n_grid)
    F = np.array([np.interp(ts.grid, s.displacement, s.force) for s in ts.samples])
    ts.mean, ts.lo, ts.hi = F.mean(axis=0), F.min(axis=0), F.max(axis=0)
    return ts


def load_all(data_dir: Path, n_grid: int = 101) -> dict[str, TestSet]:
    """Every test of a data folder; raises DataError listing all problems."""
    manifest = read_manifest(data_dir)
    problems: list[str] = []
    tests = {}
    for test_id, entry in manifest["tests"].items():
        ts = load_test(data_dir, test_id, entry, problems, n_grid)
        if ts is not None:
            tests[test_id] = ts
    if problems:
        raise DataError(problems)
    return tests
