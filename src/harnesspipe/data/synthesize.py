"""The synthetic twin of the paper's tests (DESIGN sec. 4).

No raw measurements are published with the paper, so the shipped data set is
generated here, reproducibly: each physics stage registers a *generator* that
turns truth parameters into a force-displacement curve (and optionally marker
positions of the bent shape).  This module adds what a lab adds -- specimen-to-
specimen variability of the parameters and load-cell noise, both from a fixed
seed -- and writes CSVs in the lab's export shape, the manifest entries with
provenance, and the truth parameters in a separate ``truth.yaml`` that no
calibration reads.

Regenerating with the same config and generator version is byte-identical:
every test draws from its own ``numpy`` generator seeded by (seed, test id),
numbers are written with fixed formats and YAML keys in fixed order.
"""
from __future__ import annotations

import shutil
import tempfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import yaml

from harnesspipe import __version__
from harnesspipe.data.experimental import CURVE_COLUMNS, MANIFEST, MARKER_COLUMNS, DataError

TRUTH_FILE = "truth.yaml"


@dataclass
class Curve:
    """A simulated test: crosshead displacement, force, optional marker rows."""

    displacement: np.ndarray
    force: np.ndarray
    markers: np.ndarray | None = None  # rows: displacement, marker index, x, y


@dataclass
class TestSpec:
    """What a generator declares about one test it can synthesise."""

    test_id: str
    kind: str
    item: str
    protocol: dict            # stroke_mm, rate_mm_s, load_cell_N
    truth: dict               # parameter name -> value
    simulate: Callable[[dict], Curve]  # perturbed parameters -> curve
    folder: str
    load_case: str | None = None
    extra_truth: dict = field(default_factory=dict)  # fixed inputs recorded with the truth


GENERATORS: dict[str, Callable[[dict], list[TestSpec]]] = {}


def register(name: str):
    """Decorator: add a generator ``fn(cfg) -> list[TestSpec]`` under ``name``."""
    def deco(fn):
        GENERATORS[name] = fn
        return fn
    return deco


def test_seed(seed: int, test_id: str) -> int:
    """Stable per-test seed (independent of dict order and of the other tests)."""
    return (int(seed) * 1_000_003 + zlib.crc32(test_id.encode())) % 2**32


def perturb(truth: dict, rng: np.random.Generator, variability: float) -> dict:
    """Each parameter times (1 + variability * N(0,1)), clipped to +-3 sigma."""
    z = np.clip(rng.standard_normal(len(truth)), -3.0, 3.0)
    return {k: float(v) * (1.0 + variability * zi) for (k, v), zi in zip(truth.items(), z)}


def _decimate(curve: Curve, rows: int) -> tuple[np.ndarray, np.ndarray]:
    u = np.linspace(0.0, float(curve.displacement[-1]), rows)
    return u, np.interp(u, curve.displacement, curve.force)


def _write_csv(path: Path, header: tuple[str, ...], columns: list[np.ndarray], fmts: list[str]):
    """Write the columns with their formats; a value that prints as zero is written
    without a sign, so round-off below the printed digits never shows in the file."""
    lines = [",".join(header)]
    for row in zip(*columns):
        lines.append(",".join(_unsigned_zero(f % v) for f, v in zip(fmts, row)))
    path.write_text("\n".join(lines) + "\n")


def _unsigned_zero(text: str) -> str:
    return text[1:] if text.startswith("-") and not text.strip("-0.") else text


def write_sample(folder: Path, stem: str, curve: Curve, spec: TestSpec,
                 rng: np.random.Generator, syn: dict) -> dict:
    """One replicate: decimated, noisy CSV (+ markers); returns its manifest row."""
    u, F = _decimate(curve, syn["rows"])
    F = F + syn["noise_fraction"] * np.max(np.abs(F)) * rng.standard_normal(F.size)
    t = u / spec.protocol["rate_mm_s"]
    _write_csv(folder / f"{stem}.csv", CURVE_COLUMNS, [t, u, F], ["%.4f", "%.5f", "%.6g"])
    entry = {"name": stem.rsplit("_", 1)[-1], "file": f"{spec.folder}/{stem}.csv"}
    if curve.markers is not None:
        m = curve.markers
        _write_csv(folder / f"{stem}_markers.csv", MARKER_COLUMNS,
                   [m[:, 0] / spec.protocol["rate_mm_s"], m[:, 0], m[:, 1], m[:, 2], m[:, 3]],
                   ["%.4f", "%.5f", "%d", "%.4f", "%.4f"])
        entry["markers"] = f"{spec.folder}/{stem}_markers.csv"
    return entry


def synthesize_spec(spec: TestSpec, out: Path, syn: dict) -> tuple[dict, dict]:
    """All replicates of one test; returns (manifest entry, truth record)."""
    rng = np.random.default_rng(test_seed(syn["seed"], spec.test_id))
    folder = out / spec.folder
    folder.mkdir(parents=True, exist_ok=True)
    samples, per_sample = [], {}
    for k in range(1, syn["samples"] + 1):
        params = perturb(spec.truth, rng, syn["variability"])
        stem = f"{spec.test_id}_s{k}"
        samples.append(write_sample(folder, stem, spec.simulate(params), spec, rng, syn))
        per_sample[f"s{k}"] = {p: round(float(v), 6) for p, v in params.items()}
    entry = {"kind": spec.kind, "item": spec.item}
    if spec.load_case:
        entry["load_case"] = spec.load_case
    entry.update({
        "monotonic": True,
        "protocol": spec.protocol,
        "provenance": {"kind": "synthetic", "generator": f"harnesspipe synthesize ({spec.kind})",
                       "generator_version": __version__, "seed": int(syn["seed"]),
                       "truth": f"{TRUTH_FILE}#{spec.test_id}"},
        "samples": samples,
    })
    truth = {"parameters": spec.truth, "samples": per_sample, **spec.extra_truth}
    return entry, truth


def synthesize(cfg: dict, out: Path, generators: list[str] | None = None) -> Path:
    """Write the data set of the chosen generators (default: all) into ``out``.

    Written into a temporary folder first and moved into place only when every
    generator succeeded, so a failure never leaves a half-written data set.
    """
    names = generators or sorted(GENERATORS)
    unknown = [n for n in names if n not in GENERATORS]
    if unknown:
        raise DataError([f"synthesize --only: unknown generator(s) {unknown}; "
                         f"available: {sorted(GENERATORS)}"])
    syn = cfg["synthesize"]
    out = Path(out)
    specs = [spec for name in names for spec in GENERATORS[name](cfg)]
    dropped = sorted(set(_listed_tests(out)) - {spec.test_id for spec in specs})
    if dropped:
        raise DataError([f"{out}: its {MANIFEST} lists {len(dropped)} test(s) these generators "
                         f"do not make ({', '.join(dropped[:3])}{', ...' if len(dropped) > 3 else ''}), "
                         "which the new manifest would drop: write into a new folder, or run "
                         "every generator"])
    tests, truths = {}, {}
    with tempfile.TemporaryDirectory(dir=out.parent if out.parent.exists() else None) as tmp:
        tmp = Path(tmp)
        for spec in specs:
            tests[spec.test_id], truths[spec.test_id] = synthesize_spec(spec, tmp, syn)
        manifest = {
            "schema_version": 1,
            "description": "Synthetic twin of the paper's tests (no raw data is published); "
                           "see README.md. Replace entries and CSVs with measured data.",
            "provenance": {"kind": "synthetic", "generator": "harnesspipe synthesize",
                           "generator_version": __version__, "seed": int(syn["seed"]),
                           "truth": TRUTH_FILE},
            "tests": tests,
        }
        (tmp / MANIFEST).write_text(yaml.safe_dump(manifest, sort_keys=False, width=100))
        (tmp / TRUTH_FILE).write_text(
            "# Truth parameters of the synthetic twin. Calibrations never read this file;\n"
            "# only the report compares against it.\n"
            + yaml.safe_dump(truths, sort_keys=False, width=100))
        out.mkdir(parents=True, exist_ok=True)
        for child in list(tmp.iterdir()):
            target = out / child.name
            if target.is_dir():
                shutil.rmtree(target)
            elif target.exists():
                target.unlink()
            shutil.move(str(child), str(target))
    return out


def _listed_tests(folder: Path) -> list[str]:
    """The test ids of the manifest in ``folder`` (none: no manifest or an unreadable one,
    which the new one replaces)."""
    try:
        listed = yaml.safe_load((folder / MANIFEST).read_text())
    except (OSError, yaml.YAMLError):
        return []
    tests = listed.get("tests") if isinstance(listed, dict) else None
    return list(tests) if isinstance(tests, dict) else []


def read_truth(data_dir: Path) -> dict:
    """The truth file of a synthetic data set ({} for measured data). Report use only."""
    path = Path(data_dir) / TRUTH_FILE
    if not path.exists():
        return {}
    with open(path) as f:
        return yaml.safe_load(f) or {}
