"""The synthetic-twin framework: provenance, variability, noise, reproducibility."""
import filecmp

import numpy as np
import pytest
import yaml

from harnesspipe import config as cfgmod
from harnesspipe.data import synthesize as syn
from harnesspipe.stages.data import check_data
from conftest import bilinear


@pytest.fixture
def toy_generator():
    """A closed-form generator, registered for the duration of one test."""
    def simulate(p):
        u = np.linspace(0.0, 30.0, 301)
        return syn.Curve(u, bilinear(u, k=p["k"], u_y=p["u_y"], k2=p["k2"]))

    def gen(cfg):
        return [syn.TestSpec(test_id="toy_bend", kind="three_point", item="cwb19_t2_closed",
                             protocol={"stroke_mm": 30.0, "rate_mm_s": 0.5, "load_cell_N": 222.4},
                             truth={"k": 0.8, "u_y": 3.0, "k2": 0.1}, simulate=simulate,
                             folder="three_point")]
    syn.GENERATORS["toy"] = gen
    yield "toy"
    del syn.GENERATORS["toy"]


def test_writes_valid_data_with_provenance_and_separate_truth(tmp_path, toy_generator):
    cfg = cfgmod.load()
    out = syn.synthesize(cfg, tmp_path / "d", [toy_generator])
    assert "OK: 1 tests" in check_data(out)
    manifest = yaml.safe_load((out / "manifest.yaml").read_text())
    entry = manifest["tests"]["toy_bend"]
    assert entry["provenance"] == {"kind": "synthetic", "generator": "harnesspipe synthesize (three_point)",
                                   "generator_version": "0.1.0", "seed": cfg["synthesize"]["seed"],
                                   "truth": "truth.yaml#toy_bend"}
    assert len(entry["samples"]) == cfg["synthesize"]["samples"]
    truth = syn.read_truth(out)["toy_bend"]
    assert truth["parameters"] == {"k": 0.8, "u_y": 3.0, "k2": 0.1}
    assert "0.8" not in (out / "manifest.yaml").read_text()  # truth never in the manifest
    ks = [truth["samples"][s]["k"] for s in ("s1", "s2", "s3")]
    assert len(set(ks)) == 3 and all(abs(k / 0.8 - 1) < 3 * cfg["synthesize"]["variability"] + 1e-9 for k in ks)


def test_noise_level_matches_config(tmp_path, toy_generator):
    cfg = cfgmod.merge(cfgmod.load(), {"synthesize": {"variability": 0.0, "rows": 2001}})
    out = syn.synthesize(cfg, tmp_path / "d", [toy_generator])
    data = np.loadtxt(out / "three_point" / "toy_bend_s1.csv", delimiter=",", skiprows=1)
    resid = data[:, 2] - bilinear(data[:, 1])
    expected = cfg["synthesize"]["noise_fraction"] * bilinear(30.0)
    assert np.std(resid) == pytest.approx(expected, rel=0.1)


def test_regeneration_is_byte_identical(tmp_path, toy_generator):
    cfg = cfgmod.load()
    a = syn.synthesize(cfg, tmp_path / "a", [toy_generator])
    b = syn.synthesize(cfg, tmp_path / "b", [toy_generator])
    cmp = filecmp.dircmp(a, b)
    assert not cmp.diff_files and not cmp.left_only and not cmp.right_only
    files = sorted(p.relative_to(a) for p in a.rglob("*.csv"))
    assert files and all(filecmp.cmp(a / f, b / f, shallow=False) for f in files)


def test_failing_generator_leaves_nothing_behind(tmp_path, toy_generator):
    def broken(cfg):
        raise RuntimeError("solver diverged")
    syn.GENERATORS["broken"] = broken
    try:
        with pytest.raises(RuntimeError):
            syn.synthesize(cfgmod.load(), tmp_path / "d", [toy_generator, "broken"])
    finally:
        del syn.GENERATORS["broken"]
    assert not (tmp_path / "d").exists()


def test_shipped_data_regenerates_byte_identically(tmp_path):
    """`harnesspipe synthesize` with the shipped config rewrites data/experimental exactly."""
    from harnesspipe.data import generators, generators_branch  # noqa: F401  (register)
    from conftest import REPO
    out = syn.synthesize(cfgmod.load(), tmp_path / "d")
    shipped = REPO / "data" / "experimental"
    made = sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())
    assert made == sorted(p.relative_to(shipped) for p in shipped.rglob("*")
                          if p.is_file() and p.name != "README.md")
    different = [str(f) for f in made if not filecmp.cmp(out / f, shipped / f, shallow=False)]
    assert different == []
