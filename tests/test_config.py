"""Config validation: schema (draft 2020-12) and semantic checks name the key."""
import subprocess
import sys

import pytest
import yaml

from harnesspipe import config as cfgmod
from conftest import REPO


def test_default_config_is_valid_and_has_both_profiles():
    cfg = cfgmod.load()
    assert set(cfg["profiles"]) >= {"quick", "default"}
    assert cfgmod.resolution(cfg) == cfg["profiles"]["default"]
    assert cfgmod.resolution(cfgmod.merge(cfg, {"profile": "quick"})) == cfg["profiles"]["quick"]


def test_schema_declares_draft_2020_12():
    assert cfgmod.load_schema()["$schema"].endswith("draft/2020-12/schema")


@pytest.mark.parametrize("override, expected", [
    ({"materials": {"wire_type1": {"E": -5.0}}}, "materials.wire_type1.E: -5.0 must be > 0"),
    ({"coverings": {"closed_tube": {"t": 0}}}, "coverings.closed_tube.t: 0 must be > 0"),
    ({"three_point": {"span": "127 mm"}}, "three_point.span: '127 mm' is not of type number"),
    ({"rom": {"simplex": {"xatol": 1e-4, "fatol": 1e-6, "maxiter": 5}}}, "unknown key rom.simplex.maxiter"),
    ({"tensil": {}}, "unknown key tensil"),
    ({"rom": {"reference": "test"}}, "rom.reference"),
    ({"profile": "fast"}, "profile: 'fast' is not one of"),
    ({"interfaces": {"mu_k": 0.5}}, "interfaces.mu_k: 0.5 must be <= mu_s"),
    ({"materials": {"wire_type2": {"d_core": 2.0}}}, "materials.wire_type2.d_core"),
    ({"branch": {"hifi": {"in_all": ["default", "fine"]}}}, "branch.hifi.in_all: ['fine'] not among"),
    ({"branch": {"hifi": {"in_all": True}}}, "branch.hifi.in_all"),
])
def test_bad_values_name_the_key(override, expected):
    with pytest.raises(cfgmod.ConfigError) as err:
        cfgmod.load(overrides=override)
    assert expected in str(err.value)
    assert "config.yaml" in str(err.value)


def test_missing_file_is_named(tmp_path):
    with pytest.raises(cfgmod.ConfigError, match="nope.yaml: config file not found"):
        cfgmod.load(tmp_path / "nope.yaml")


def test_snakemake_validates_config_at_start(tmp_path):
    """A bad config stops the workflow before any job, naming the key."""
    cfg = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    cfg["materials"]["wire_type2"]["E"] = -1.0
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(cfg))
    run = subprocess.run([sys.executable, "-m", "snakemake", "--dry-run", "--configfile", str(bad)],
                         cwd=REPO, capture_output=True, text=True)
    assert run.returncode != 0
    assert "materials.wire_type2.E: -1.0 must be > 0" in run.stdout + run.stderr
