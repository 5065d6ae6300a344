"""Shared fixtures: a small, valid data folder written from a closed-form curve."""
from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

REPO = Path(__file__).resolve().parents[1]
ARTIFACTS = REPO / "tests" / "artifacts"  # screenshots etc. (git-ignored)


def write_curve(path: Path, u: np.ndarray, F: np.ndarray, rate: float = 0.5) -> None:
    lines = ["time_s,displacement_mm,force_N"]
    lines += [f"{ui / rate:.4f},{ui:.5f},{fi:.6g}" for ui, fi in zip(u, F)]
    path.write_text("\n".join(lines) + "\n")


def bilinear(u, k=0.8, u_y=3.0, k2=0.1):
    """A simple elastic-then-hardening force curve (N) for data tests."""
    return np.where(u < u_y, k * u, k * u_y + k2 * (u - u_y))


def with_closure(config: dict, c: float) -> dict:
    """``config`` with ``hifi.build.tube_closure`` c (0: the slit tubes as moulded)."""
    return {**config, "hifi": {**config["hifi"], "build": {**config["hifi"]["build"], "tube_closure": c}}}


def pytest_collection_modifyitems(session, config, items):
    """The end-to-end pipeline files first (a stable sort): under ``make test``'s two
    workers (pytest-xdist, a file at a time) the longest file then runs beside the others
    instead of after them."""
    items.sort(key=lambda item: item.get_closest_marker("pipeline") is None)


@pytest.fixture
def good_data(tmp_path) -> Path:
    """A data folder with one three-point test of three valid samples (+ markers)."""
    root = tmp_path / "data"
    (root / "three_point").mkdir(parents=True)
    u = np.linspace(0.0, 30.0, 61)
    samples = []
    for k, scale in enumerate((0.97, 1.0, 1.04), start=1):
        write_curve(root / "three_point" / f"t_s{k}.csv", u, scale * bilinear(u))
        samples.append({"name": f"s{k}", "file": f"three_point/t_s{k}.csv"})
    (root / "three_point" / "t_s1_markers.csv").write_text(
        "time_s,displacement_mm,marker,x_mm,y_mm\n"
        + "".join(f"{d / 0.5:.3f},{d:.3f},{m},{-60 + 15 * m:.3f},{-d * (1 - abs(-60 + 15 * m) / 70):.3f}\n"
                  for d in (10.0, 20.0, 30.0) for m in range(9)))
    samples[0]["markers"] = "three_point/t_s1_markers.csv"
    manifest = {"schema_version": 1, "tests": {"tp_case": {
        "kind": "three_point", "item": "cwb19_t2_closed", "monotonic": True,
        "protocol": {"stroke_mm": 30.0, "rate_mm_s": 0.5, "load_cell_N": 222.4},
        "provenance": {"kind": "measured", "lab": "test fixture"},
        "samples": samples}}}
    (root / "manifest.yaml").write_text(yaml.safe_dump(manifest, sort_keys=False))
    return root


@pytest.fixture(scope="session")
def in_ci() -> bool:
    return os.environ.get("CI", "").lower() in ("1", "true", "yes")


def copy_project(dest: Path) -> Path:
    """Copy what a user's checkout holds (no results, venv or caches) to ``dest``."""
    ignore = shutil.ignore_patterns("results", ".snakemake", ".venv", ".cache", "__pycache__",
                                    "*.egg-info", "artifacts", ".git", ".pytest_cache")
    shutil.copytree(REPO, dest, ignore=ignore)
    return dest


def job_stats(run) -> dict[str, int]:
    """Rule -> job count of a finished ``snakemake --dry-run`` (subprocess result; {} when
    nothing is to be done)."""
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    text = run.stdout + run.stderr
    if "Nothing to be done" in text:
        return {}
    table = text.split("Job stats:")[1]
    return {m.group(1): int(m.group(2)) for m in re.finditer(r"^(\w+)\s+(\d+)\s*$", table, re.M)
            if m.group(1) != "total"}


@pytest.fixture(scope="module")
def config() -> dict:
    """The shipped config/config.yaml as plain YAML (no validation, no profile resolution)."""
    return yaml.safe_load((REPO / "config" / "config.yaml").read_text())
