"""Stage 1, data check: validate the data folder and resample each test."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from harnesspipe.data.experimental import DataError, load_test, read_manifest
from harnesspipe.input_files import InputFileError, open_hdf5


def check_data(data_dir: Path, cfg: dict | None = None) -> str:
    """Validate every test; return a one-line summary or raise DataError (all problems).
    With the config ``cfg``, the summary also names the tests whose item the config does not
    know (a bending test of no case, a tensile test of no covering): the pipeline leaves them
    out."""
    manifest = read_manifest(data_dir)
    problems: list[str] = []
    n_samples = n_rows = 0
    kinds: dict[str, int] = {}
    for test_id, entry in manifest["tests"].items():
        ts = load_test(data_dir, test_id, entry, problems)
        if ts is None:
            continue
        kinds[entry["kind"]] = kinds.get(entry["kind"], 0) + 1
        n_samples += len(ts.samples)
        n_rows += sum(s.force.size for s in ts.samples)
    if problems:
        raise DataError(problems)
    by_kind = ", ".join(f"{v} {k}" for k, v in sorted(kinds.items()))
    unused = _unused_tests(manifest["tests"], cfg) if cfg is not None else []
    return (f"{data_dir}: OK: {len(manifest['tests'])} tests ({by_kind}), "
            f"{n_samples} samples, {n_rows} rows"
            + (f"; not used by the config: {'; '.join(unused)}" if unused else ""))


def _unused_tests(tests: dict, cfg: dict) -> list[str]:
    """'test_id (item ... is not a ...)' for each test whose item the config has no use for."""
    known = {"three_point": ({**cfg["cases"], **cfg["hifi"].get("extra_cases", {})}, "case"),
             "tensile": (cfg["coverings"], "covering")}
    return [f"{test_id} (item {entry['item']!r} is not a {known[entry['kind']][1]} of the config)"
            for test_id, entry in tests.items()
            if entry["kind"] in known and entry["item"] not in known[entry["kind"]][0]]


def prepare_test(data_dir: Path, test_id: str, out_h5: Path, n_grid: int = 101) -> Path:
    """Resample one test's replicates to a common grid; write raw samples, mean,
    min/max band and marker rows to one HDF5 file (written atomically)."""
    manifest = read_manifest(data_dir)
    if test_id not in manifest["tests"]:
        raise DataError([f"{Path(data_dir) / 'manifest.yaml'}: no test {test_id!r}"])
    problems: list[str] = []
    ts = load_test(data_dir, test_id, manifest["tests"][test_id], problems, n_grid)
    if ts is None:
        raise DataError(problems)
    out_h5 = Path(out_h5)
    out_h5.parent.mkdir(parents=True, exist_ok=True)
    tmp = out_h5.with_suffix(".tmp")
    with h5py.File(tmp, "w") as f:
        f.attrs["test_id"] = test_id
        f.attrs["entry"] = json.dumps(ts.entry)
        for name in ("grid", "mean", "lo", "hi"):
            f[name] = getattr(ts, name)
        for s in ts.samples:
            g = f.create_group(f"samples/{s.name}")
            g["time_s"], g["displacement_mm"], g["force_N"] = s.time, s.displacement, s.force
            if s.markers is not None:
                g["markers"] = s.markers
    tmp.replace(out_h5)
    return out_h5


@dataclass
class Prepared:
    """A prepared test as read back by later stages."""

    test_id: str
    entry: dict
    grid: np.ndarray
    mean: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    samples: dict[str, dict[str, np.ndarray]]

    def replicates(self) -> np.ndarray:
        """Force of every replicate on ``grid`` (n_samples x n_grid)."""
        return np.array([np.interp(self.grid, s["displacement_mm"], s["force_N"])
                         for s in self.samples.values()])

    def rows(self) -> tuple[np.ndarray, np.ndarray]:
        """``(u, F)``: the measured rows inside the common range 0..grid[-1] and every
        replicate's force at them (n_samples x n_rows).

        The rows are the first specimen's displacement samples; specimens exported at the
        same abscissa (one DAQ rate, one crosshead rate: the usual case) give their own
        forces, unchanged; a specimen sampled elsewhere is interpolated onto those rows.
        A fit to the mean of F over these rows is then least squares on every measured row
        of every specimen (the objectives of the tensile and ROM stages)."""
        first = next(iter(self.samples.values()))["displacement_mm"]
        u = first[(first >= 0.0) & (first <= self.grid[-1] * (1.0 + 1e-12))]
        if u.size < 2:
            raise ValueError(f"{self.test_id}: fewer than two measured rows in 0..{self.grid[-1]} mm")
        F = np.array([s["force_N"][(s["displacement_mm"] >= 0.0)
                                   & (s["displacement_mm"] <= u[-1])]
                      if _same_rows(s["displacement_mm"], u) else
                      np.interp(u, s["displacement_mm"], s["force_N"])
                      for s in self.samples.values()])
        return u, F

    def standard_error(self) -> np.ndarray:
        """Standard error of the mean curve on ``grid``: the replicates' sample standard
        deviation over sqrt(n) (zero for a single replicate)."""
        F = self.replicates()
        if F.shape[0] < 2:
            return np.zeros_like(self.grid)
        return F.std(axis=0, ddof=1) / np.sqrt(F.shape[0])


def _same_rows(displacement: np.ndarray, u: np.ndarray) -> bool:
    """Whether a specimen's displacement samples inside 0..u[-1] are exactly the rows ``u``."""
    inside = displacement[(displacement >= 0.0) & (displacement <= u[-1])]
    return inside.shape == u.shape and bool(np.array_equal(inside, u))


def read_prepared(path: Path) -> Prepared:
    """The prepared test in ``path`` (as :func:`prepare_test` writes it); a file that is not
    one: InputFileError naming it."""
    with open_hdf5(path, "a prepared test (HDF5)") as f:
        missing = ([k for k in ("grid", "mean", "lo", "hi", "samples") if k not in f]
                   + [k for k in ("test_id", "entry") if k not in f.attrs])
        if missing:
            raise InputFileError(f"{path}: not a prepared test: no {', '.join(missing)} "
                                 "(harnesspipe prepare writes one)")
        samples = {name: {k: g[k][...] for k in g} for name, g in f["samples"].items()}
        return Prepared(str(f.attrs["test_id"]), json.loads(f.attrs["entry"]),
                        f["grid"][...], f["mean"][...], f["lo"][...], f["hi"][...], samples)
