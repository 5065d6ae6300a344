"""Construction catalogues (harnesspipe.campaign): the schema and the checks naming the entry and
the key, the mapping of an entry onto the hi-fi model's case, the per-entry settings, the library
row.  The demo campaign end to end is in test_campaign_pipeline.py."""
from __future__ import annotations

import copy
import json
import math
import subprocess
import sys

import numpy as np
import pytest
import yaml

from conftest import REPO
from harnesspipe import config as hp_config
from harnesspipe.campaign import catalogue as K
from harnesspipe.campaign import settings as S
from harnesspipe.campaign.library import (COLUMNS, bending_stiffness, library, properties, quality_message,
                                         yield_curvature)
from harnesspipe.config import ConfigError
from harnesspipe.models.hifi_mesh import PART_TAPE, build_mesh

CAMPAIGNS = REPO / "config" / "campaigns"


@pytest.fixture(scope="module")
def cfg() -> dict:
    return hp_config.load(overrides={"profile": "quick"})


@pytest.fixture(scope="module")
def demo() -> dict:
    return yaml.safe_load((CAMPAIGNS / "demo.yaml").read_text())


def _check(data, cfg):
    return K.check(data, cfg, "cat.yaml")


def _with(demo: dict, name: str, **entry) -> dict:
    data = copy.deepcopy(demo)
    data["constructions"][name] = entry
    return data


def test_shipped_catalogues_are_valid(cfg):
    demo = K.load(CAMPAIGNS / "demo.yaml", cfg)
    paper = K.load(CAMPAIGNS / "paper.yaml", cfg)
    assert demo.name == "demo" and len(demo.constructions) == 3
    assert all(sum(e["wires"].values()) <= 7 for e in demo.constructions.values())   # small: quick campaign
    expected = {**cfg["cases"], **cfg["hifi"]["extra_cases"]}
    assert set(paper.constructions) == set(expected)     # the six CWBs and the branch's segments


GOOD = {"wires": {"wire_type2": 7}, "covering": {"type": "closed", "d_i": 6.0, "d_o": 9.4}}


@pytest.mark.parametrize("entry, names", [
    ({**GOOD, "wirez": 3}, ["construction bad: unknown key wirez"]),
    ({"wires": {"wire_type2": 7}}, ["construction bad: covering: missing"]),
    ({**GOOD, "covering": "mesh"}, ["construction bad: covering: 'mesh': expected one of"]),
    ({**GOOD, "covering": {"type": "fabric", "d_i": 6.0}}, ["construction bad: covering.d_i: not allowed here"]),
    ({**GOOD, "wires": {"wire_type2": 0}}, ["construction bad: wires.wire_type2: 0"]),
    ({**GOOD, "wires": {"copper": 7}}, ["construction bad: wires.copper: not allowed here"]),
    ({**GOOD, "wires": {"wire_type7": 7}}, ["construction bad: wires.wire_type7: not a wire type"]),
    ({**GOOD, "taping": "spiral"}, ["construction bad: taping: 'spiral': expected one of"]),
    ({**GOOD, "taping": {"type": "coarse", "tape": "duct_tape"}}, ["construction bad: taping.tape: 'duct_tape'"]),
    ({**GOOD, "covering": {"type": "open", "d_i": 9.0, "d_o": 8.0}}, ["construction bad: covering.d_i: 9 must be < d_o 8"]),
    ({**GOOD, "wires": {"wire_type2": 19}}, ["construction bad: covering.d_i: 6: 19 wires (bundle radius 3.50 mm) do not fit"]),
    ({**GOOD, "covering": "fabric", "wires": {"wire_type2": 37}}, ["construction bad: covering.r1: 4.7 (the config's): 37 wires"]),
    ({**GOOD, "test": {"span": 100.0, "deflection": 60.0}}, ["construction bad: test.deflection: 60: expected a deflection below half"]),
    ({**GOOD, "test": {"span": -1.0}}, ["construction bad: test.span: -1.0"]),
    ({**GOOD, "build": {"wire_fill": 1.5}}, ["construction bad: build.wire_fill: 1.5"]),
    ({**GOOD, "loading_time_scale": 0}, ["construction bad: loading_time_scale: 0"]),
])
def test_bad_entry_names_the_construction_and_the_key(cfg, demo, entry, names):
    with pytest.raises(ConfigError) as err:
        _check(_with(demo, "bad", **entry), cfg)
    text = str(err.value)
    for name in names:
        assert f"cat.yaml: {name}" in text, text
    assert "w7_t2_closed" not in text          # the good entries are not blamed


def test_bad_names_and_types_are_named(cfg, demo):
    with pytest.raises(ConfigError, match=r"cat.yaml: constructions: bad-name: not allowed here"):
        _check(_with(demo, "bad-name", **GOOD), cfg)
    own = {"d_core": 0.8, "d_outer": 0.6, "E": 5000.0, "sigma_y": 5.0, "K": 900.0, "n": 0.8,
           "nu": 0.39, "rho": 4.5e-9}
    with pytest.raises(ConfigError, match=r"wire_types: wire_type3.d_core: 0.8 must be < d_outer 0.6"):
        _check({**demo, "wire_types": {"wire_type3": own}}, cfg)
    with pytest.raises(ConfigError, match=r"wire_types: wire_type1: already a wire type of config materials"):
        _check({**demo, "wire_types": {"wire_type1": {**own, "d_outer": 1.0}}}, cfg)
    tape = {"E": 300.0, "sigma_y": 5.0, "K": 20.0, "n": 0.5, "nu": 0.3, "rho": 1.1e-9,
            "thickness": 0.3, "width": 19.0}
    with pytest.raises(ConfigError, match=r"tapes: polypropylene: already a material of config materials"):
        _check({**demo, "tapes": {"polypropylene": tape}}, cfg)
    with pytest.raises(ConfigError, match=r"wire_types: wire_type3.n: 1.5"):
        _check({**demo, "wire_types": {"wire_type3": {**own, "d_outer": 1.0, "n": 1.5}}}, cfg)


def test_cli_check_exits_2_naming_entry_and_key(tmp_path, demo):
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(_with(demo, "w7_big", **{**GOOD, "wires": {"wire_type2": 19}})))
    run = subprocess.run([sys.executable, "-m", "harnesspipe", "campaign", "check", str(bad)],
                         capture_output=True, text=True)
    assert run.returncode == 2
    assert "construction w7_big: covering.d_i" in run.stderr and "do not fit" in run.stderr
    good = subprocess.run([sys.executable, "-m", "harnesspipe", "campaign", "check",
                           str(CAMPAIGNS / "demo.yaml")], capture_output=True, text=True)
    assert good.returncode == 0 and "3 constructions" in good.stdout


def _arrays(mesh) -> dict:
    return {k: v for k, v in vars(mesh).items() if isinstance(v, np.ndarray)}


@pytest.mark.parametrize("name", ["cwb19_t2_closed", "cwb19_t2_open_halflap", "cwb10t1_9t2_fabric",
                                  "cwb38_t2_open_coarse", "twb19_t2"])
def test_paper_entry_maps_onto_the_pipelines_case(cfg, name):
    """The catalogue's entry of a paper case builds the very mesh and material state of the
    pipeline's case (config cases / hifi.extra_cases)."""
    cat = K.load(CAMPAIGNS / "paper.yaml", cfg)
    res = hp_config.resolution(cfg)["hifi"]
    model = K.model_config(name, cat, cfg, hp_config.resolution(cfg))
    case = model["cases"][name]
    ref_case = {**cfg["cases"], **cfg["hifi"]["extra_cases"]}[name]
    assert case["r_o"] == pytest.approx(ref_case["r_o"])
    assert case["t_total_scale"] == ref_case.get("t_total_scale", 1.0)
    assert model["three_point"] == pytest.approx(cfg["three_point"])
    mapped, ref = build_mesh(case, model, res), build_mesh(ref_case, cfg, res)
    for key, value in _arrays(ref).items():
        np.testing.assert_allclose(_arrays(mapped)[key], value, atol=1e-9, err_msg=key)
    assert mapped.info["covering"] == ref.info["covering"]
    assert mapped.info["taping"] == {"ends": "none"}.get(ref.info["taping"], ref.info["taping"])   # the same build


def test_new_wire_type_tape_and_test_geometry_reach_the_model(cfg):
    """A user's wire type and tape (Table-1-like) and a shorter span end up in the mesh and in
    the wires' and tape's material rows of the assembled hi-fi system."""
    from harnesspipe.models.hifi import HifiSystem
    from harnesspipe.stages.hifi import inputs
    data = {"wire_types": {"wire_type3": {"d_core": 0.5, "d_outer": 0.9, "E": 7000.0, "sigma_y": 6.0,
                                          "K": 700.0, "n": 0.7, "nu": 0.39, "rho": 5.0e-9}},
            "tapes": {"cloth_tape": {"E": 300.0, "sigma_y": 5.0, "K": 20.0, "n": 0.5, "nu": 0.3,
                                     "rho": 1.1e-9, "thickness": 0.3, "width": 19.0}},
            "constructions": {"mix": {"wires": {"wire_type3": 4, "wire_type2": 3},
                                      "covering": {"type": "open", "d_i": 6.0, "d_o": 9.4},
                                      "taping": {"type": "coarse", "tape": "cloth_tape"},
                                      "test": {"span": 100.0, "deflection": 20.0}}}}
    cat = _check(data, cfg)
    model = K.model_config("mix", cat, cfg, hp_config.resolution(cfg))
    assert model["three_point"]["span"] == 100.0 and model["three_point"]["sample_length"] == 173.0
    assert model["three_point"]["tube_length"] == pytest.approx(173.0 - (200.0 - 152.4))
    settings = json.loads(S.hifi(cat, "mix", cfg, hp_config.resolution(cfg), S.interface(cfg, "nowhere"),
                                 S.coverings(cfg, "nowhere")))
    inp = inputs(settings["model"], "mix", {}, covering_values=settings["coverings"])
    system = HifiSystem(build_mesh(inp.case, inp.config, inp.resolution), inp)
    mesh = system.mesh
    assert sorted(np.unique(mesh.wire_type)) == [2, 3] and np.sum(mesh.wire_type == 3) == 4
    np.testing.assert_allclose(mesh.wire_radius[mesh.wire_type == 3], 0.45)
    E_el = system.wires.mats[system.wires.sec_id, 0]
    np.testing.assert_allclose(E_el[mesh.wire_type[mesh.beam_wire] == 3], 7000.0)
    np.testing.assert_allclose(E_el[mesh.wire_type[mesh.beam_wire] == 2], 4528.0)
    tape = mesh.shell_part == PART_TAPE
    np.testing.assert_allclose(mesh.shell_thickness[tape], 0.3)
    np.testing.assert_allclose(system.smat[tape, 0], 300.0)
    np.testing.assert_allclose(np.abs(mesh.rollers["centres"][:2, 0]), 50.0)    # span 100
    assert K.hifi_case(cat.constructions["mix"], cfg)["r_o"] == 4.7             # d_o / 2


def test_default_outer_radius_of_a_taped_bundle(cfg, demo):
    cat = _check(demo, cfg)
    # 7 type-2 wires: packed radius 1.5 d (1.001 clearance), plus the 0.1 mm tape
    assert cat.constructions["w7_t2_halflap"]["covering"] == {"type": "none"}
    r = K.hifi_case(cat.constructions["w7_t2_halflap"], cfg)["r_o"]
    assert r == pytest.approx(1.4 * 1.001 + 0.7 + 0.1)


def test_settings_follow_their_own_entry_only(cfg, demo, tmp_path):
    """Adding or changing one entry changes no other entry's settings; the interface's fitted
    build state enters every run unless the entry sets its own."""
    res = hp_config.resolution(cfg)
    itf, covs = S.interface(cfg, tmp_path), S.coverings(cfg, tmp_path)
    assert itf[0].startswith("paper") and covs[0].startswith("paper")
    base = _check(demo, cfg)
    grown = _check(_with(demo, "w7_extra", **GOOD, build={"wire_fill": 0.5}), cfg)
    for name in base.constructions:
        for make in (lambda c, n: S.hifi(c, n, cfg, res, itf, covs), lambda c, n: S.rom(c, n, cfg, res)):
            assert make(base, name) == make(grown, name)
    (tmp_path / "hifi").mkdir()
    (tmp_path / "hifi" / "interface.csv").write_text(
        "parameter,value\nmu_rtb,0.25\nmu_rtp,0.15\ndelta0,0.03\ndelta_f,0.08\nalpha_d,2\n"
        "E2_over_E1,0.5\nend_tape_layers,3.5\nfabric_end_tape_layers,1.5\n")
    fitted = S.interface(cfg, tmp_path)
    assert fitted[0] == str(tmp_path / "hifi" / "interface.csv")
    own = json.loads(S.hifi(grown, "w7_extra", cfg, res, fitted, covs))["model"]["hifi"]
    other = json.loads(S.hifi(grown, "w7_t2_closed", cfg, res, fitted, covs))["model"]["hifi"]
    assert other["build"] == {"pack_angle": 1.0, "wire_fill": 0.0, "tube_closure": 1.0, "sleeve_closure": 1.0, "end_tape_layers": 3.5, "end_tape_binds": 0, "fabric_end_tape_binds": 0, "fabric_end_tape_layers": 1.5, "tape_tension": 0.0}
    assert own["build"] == {"pack_angle": 1.0, "wire_fill": 0.5, "tube_closure": 1.0, "sleeve_closure": 1.0, "end_tape_layers": 3.5, "end_tape_binds": 0, "fabric_end_tape_binds": 0, "fabric_end_tape_layers": 1.5, "tape_tension": 0.0}
    assert other["parameters"]["mu_rtb"] == 0.25 and other["parameters"]["E2_over_E1"] == 1.0   # no fabric
    sleeve = _check(_with(demo, "w7_fabric", wires={"wire_type2": 7}, covering="fabric"), cfg)
    assert json.loads(S.hifi(sleeve, "w7_fabric", cfg, res, fitted, covs))["model"]["hifi"][
        "parameters"]["E2_over_E1"] == 0.5
    with pytest.raises(ConfigError, match="campaign_interface"):
        S.interface({**cfg, "campaign_interface": str(tmp_path / "missing.csv")}, tmp_path)


def _row_settings(cat, name, cfg):
    return json.loads(S.rom(cat, name, cfg, hp_config.resolution(cfg)))


def test_failed_run_gives_a_failed_row_without_numbers(cfg, demo, tmp_path):
    cat = _check(demo, cfg)
    hifi = tmp_path / "w7_t2_closed" / "hifi"
    hifi.mkdir(parents=True)
    (hifi / "result.json").write_text(json.dumps({
        "case": "w7_t2_closed", "status": "failed", "stage": "hifi virtual test", "wall_s": 3.0,
        "diagnostics": {"error": "ExplicitError: explicit run stopped: max KE/IE 0.9 > 0.1"}}))
    (hifi / "curve.csv").write_text("deflection_mm,force_N\n")
    row = properties("w7_t2_closed", hifi, _row_settings(cat, "w7_t2_closed", cfg), tmp_path / "w7_t2_closed")
    assert row["status"] == "failed" and "KE/IE 0.9" in row["message"]
    assert all(row[k] is None for k in ("E", "sigma_y", "K", "n", "EI", "kappa_y"))
    frame = library([tmp_path / "w7_t2_closed" / "property.json"], tmp_path / "properties.csv")
    assert list(frame.columns) == COLUMNS
    back = (tmp_path / "properties.csv").read_text().splitlines()[1].split(",")
    assert back[:6] == ["w7_t2_closed", "", "", "", "", "7.05"]     # no plausible-looking numbers
    assert back[7:9] == ["", ""]                                    # EI, kappa_y
    # rho: the seven type-2 wires' mass over pi r_o^2
    assert float(back[6]) == pytest.approx(7 * 4.34e-9 * 0.7**2 / 7.05**2)


def test_a_run_that_falls_or_is_not_quasi_static_says_so_in_its_row():
    smooth = {"quasi_static": True, "ke_ie": 0.01, "force_drop": {"drop_N": 0.1, "fraction": 0.01,
                                                                "from_mm": 28.0, "to_mm": 29.0}}
    assert quality_message(smooth) == ""
    snap = {**smooth, "force_drop": {"drop_N": 3.8, "fraction": 0.37, "from_mm": 13.7, "to_mm": 15.7}}
    assert quality_message(snap) == ("the virtual test's force falls 37 % between 13.7 and 15.7 mm "
                                     "(a snap), and the beam is fitted through it")
    slow = {**smooth, "force_drop": {"drop_N": 4.8, "fraction": 0.78, "from_mm": 23.1, "to_mm": 30.0}}
    assert quality_message(slow) == ("the virtual test's force falls 78 % between 23.1 and 30.0 mm, "
                                     "and the beam is fitted through it")
    both = quality_message({**snap, "quasi_static": False, "ke_ie": 0.05})
    assert both.startswith("KE/IE 0.05 above the paper's 2 %") and "; the virtual test's force falls" in both
    assert quality_message({"quasi_static": True}) == ""          # a result.json from before force_drop


def test_section_properties():
    # EI of a solid disc, and kappa_Y of its outer fibre: sigma_Y = E kappa r_o
    assert bending_stiffness(15.7, 7.05) == pytest.approx(15.7 * math.pi * 7.05**4 / 4)
    kappa = yield_curvature(15.7, 0.6, 7.05)
    assert 15.7 * kappa * 7.05 == pytest.approx(0.6)
