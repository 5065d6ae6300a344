"""The settings rules pass to the stages (stages/stage_settings.py, stages/chain_settings.py):
what each run reads of the config, and the chain's roles and scheduling."""
from __future__ import annotations

import json

import pytest

from harnesspipe import config as hp_config
from harnesspipe.stages import chain_settings as chain
from harnesspipe.stages import stage_settings as settings


def test_rom_settings_carry_the_case_radius_and_follow_the_profile():
    cfg = hp_config.load(overrides={"profile": "quick"})
    profile = hp_config.resolution(cfg)
    s = json.loads(settings.rom(cfg, profile, "cwb38_t2_open_coarse"))
    assert s["r_o"] == cfg["hifi"]["extra_cases"]["cwb38_t2_open_coarse"]["r_o"]
    assert s["maxfev"] == profile["simplex_maxfev"] and s["mesh"] == profile["rom"]
    assert json.loads(settings.rom_on_hifi(cfg, profile, "cwb19_t2_closed"))["reference"] == "hifi"


def test_tensile_settings_take_the_covering_material():
    cfg = hp_config.load()
    profile = hp_config.resolution(cfg)
    s = json.loads(settings.tensile(cfg, profile, "open_tube"))
    material = cfg["coverings"]["open_tube"]["material"]
    assert s["nu"] == cfg["materials"][material]["nu"]
    assert s["initial"] == cfg["tensile"]["initial_guess"][material]


def test_branch_hifi_settings_hold_both_segments_and_the_paper_interface():
    cfg = hp_config.load()
    s = json.loads(settings.branch_hifi(cfg, hp_config.resolution(cfg)))
    assert {"cwb38_t2_open_coarse", "cwb19_t2_open_coarse"} <= set(s["model"]["cases"])
    assert "E2_over_E1" not in s["interface"]
    assert s["interface"]["mu_rtb"] == cfg["paper"]["interface"]["mu_rtb"]


def test_chain_roles_and_longest_virtual_test_first():
    cfg = hp_config.load()
    assert chain.role("cwb19_t2_closed") == "calibration"
    assert chain.role("cwb19_t1_open_coarse") == "validation"
    assert chain.role("twb19_t2") == "prediction"
    p38 = chain.virtual_priority(cfg, "cwb38_t2_open_coarse", reused=False)
    p19 = chain.virtual_priority(cfg, "cwb19_t2_open_coarse", reused=False)
    assert 1.0 < p19 < p38 < 10.0
    assert chain.virtual_priority(cfg, "cwb38_t2_open_coarse", reused=True) == 1.0


def test_chain_starts_with_the_build_state_and_carries_it():
    """The build steps fit the end bands' wraps, then the tape's wrapping tension, from the
    config's start values within layers_bounds and tension_bounds on the whole test of the
    tube CWBs; every later step takes both as priors."""
    cfg = hp_config.load()
    s = json.loads(chain.fit_settings(cfg, "build"))
    assert s["names"] == ["end_tape_layers"] and s["method"] == "bounded"
    assert s["start"]["end_tape_layers"] == cfg["hifi"]["build"]["end_tape_layers"]
    assert s["bounds"] == cfg["hifi"]["pipeline"]["layers_bounds"]
    assert s["window"] == cfg["hifi"]["pipeline"]["build_window"]
    t = json.loads(chain.fit_settings(cfg, "tension"))
    assert t["names"] == ["tape_tension"] and t["method"] == "bounded"
    assert t["start"]["tape_tension"] == cfg["hifi"]["build"]["tape_tension"]
    assert t["bounds"] == cfg["hifi"]["pipeline"]["tension_bounds"] and t["cases"] == s["cases"]
    assert t["window"] == s["window"]
    # the same inputs named in both (the tension step's start is the build step's pick: one run)
    assert set(t["start"]) == set(s["start"]) and s["start"]["tape_tension"] == t["start"]["tape_tension"]
    assert list(chain.STEPS)[:3] == ["binding", "build", "tension"]
    assert chain.STEPS["tension"]["prior"] == ["binding", "build"]
    assert all({"binding", "build", "tension"} <= set(step["prior"]) for name, step in chain.STEPS.items()
               if name not in ("binding", "build", "tension"))
    b = json.loads(chain.fit_settings(cfg, "binding"))
    assert b["names"] == ["end_tape_binds"] and b["method"] == "choice" and b["bounds"] is None
    assert b["choices"] == [0, 1] and b["start"]["end_tape_binds"] == 0.0
    assert b["cases"] == s["cases"] and b["window"] == s["window"] and set(b["start"]) == set(s["start"])


def test_slit_tube_closure_is_picked_on_the_half_lap_cwb_after_the_end_bands():
    """After the end bands (binding, build, tension), closure picks tube_closure from
    closure_choices on the half-lap CWB alone (the one calibration case with a slit tube),
    from its config start; every later step takes the pick, so the interface the virtual
    tests read carries it."""
    cfg = hp_config.load()
    pipe = cfg["hifi"]["pipeline"]
    c = json.loads(chain.fit_settings(cfg, "closure"))
    assert c["names"] == ["tube_closure"] and c["cases"] == ["cwb19_t2_open_halflap"]
    assert c["method"] == "choice" and c["choices"] == pipe["closure_choices"]
    assert c["start"]["tube_closure"] == cfg["hifi"]["build"]["tube_closure"] and c["window"] == pipe["build_window"]
    assert chain.STEPS["closure"]["prior"] == ["binding", "build", "tension"]
    assert all("closure" in step["prior"] for name, step in chain.STEPS.items()
               if name not in ("binding", "build", "tension", "closure"))
    # every step's start holds it, so a run's identity does not depend on the step that made it
    assert all("tube_closure" in json.loads(chain.fit_settings(cfg, s))["start"] for s in chain.STEPS)
    bad = hp_config.load(overrides={"hifi": {"pipeline": {"closure_choices": [1.0, 0.0]}}})
    with pytest.raises(ValueError, match="hifi.pipeline.closure_choices"):
        chain.check_windows(bad)


def test_chain_fits_at_the_chain_profile_and_virtual_tests_at_the_run_profile():
    """hifi.pipeline.chain_profile: the fits' models carry that profile's mesh, the virtual
    tests the run's own; a virtual test reuses a fit's run only when the two meshes agree; a
    name that is no profile is refused naming the key."""
    cfg = hp_config.load(overrides={"profile": "default", "hifi": {"pipeline": {"chain_profile": "quick"}}})
    fit = json.loads(chain.fit_settings(cfg, "build"))
    for m in fit["models"].values():
        assert m["profile"] == "quick"
        assert m["profiles"] == {"quick": {"hifi": cfg["profiles"]["quick"]["hifi"]}}
    assert fit["maxfev"] == cfg["hifi"]["pipeline"]["budgets"]["quick"]["bounded_maxfev"]
    run = json.loads(chain.run_settings(cfg, "cwb19_t2_closed", hp_config.resolution(cfg), crosscheck=False))
    assert run["model"]["profiles"] == {"default": {"hifi": cfg["profiles"]["default"]["hifi"]}}
    assert not chain.reuses_fit_runs(cfg)
    own = hp_config.load(overrides={"profile": "default", "hifi": {"pipeline": {"chain_profile": None}}})
    assert chain.reuses_fit_runs(own)
    own_fit = json.loads(chain.fit_settings(own, "build"))
    assert own_fit["models"]["cwb19_t2_closed"]["profile"] == "default"
    assert own_fit["maxfev"] == cfg["hifi"]["pipeline"]["budgets"]["default"]["bounded_maxfev"]
    bad = hp_config.load(overrides={"hifi": {"pipeline": {"chain_profile": "fine"}}})
    with pytest.raises(ValueError, match="hifi.pipeline.chain_profile: 'fine'"):
        chain.check_windows(bad)


def test_fabric_cwb_fits_its_own_end_bands_before_its_orthotropy():
    """fabric_build fits fabric_end_tape_layers on the t2 fabric CWB from end_tape_layers'
    config start (not the tube CWBs' fitted value: its priors do not set it), within
    layers_bounds; the fabric step takes it as its last prior, so its fit.json's interface
    (what the fabric virtual tests read) carries it."""
    cfg = hp_config.load()
    s = json.loads(chain.fit_settings(cfg, "fabric_build"))
    assert s["names"] == ["fabric_end_tape_layers"] and s["cases"] == ["cwb19_t2_fabric"]
    assert cfg["hifi"]["build"]["fabric_end_tape_layers"] is None
    assert s["start"]["fabric_end_tape_layers"] == cfg["hifi"]["build"]["end_tape_layers"]
    assert s["bounds"] == cfg["hifi"]["pipeline"]["layers_bounds"]
    assert not any("fabric_end_tape_layers" in chain.STEPS[p]["names"] for p in chain.STEPS["fabric_build"]["prior"])
    assert chain.STEPS["fabric"]["prior"][-1] == "fabric_build"
    own = hp_config.load(overrides={"hifi": {"build": {"fabric_end_tape_layers": 2.0}}})
    assert json.loads(chain.fit_settings(own, "fabric_build"))["start"]["fabric_end_tape_layers"] == 2.0


def test_fabric_cwb_picks_which_wires_its_end_bands_bind_on_its_own_case():
    """fabric_binding picks fabric_end_tape_binds from binds_choices on the t2 fabric CWB
    alone, from its config start 0 (not the tube CWBs' pick: no prior step fits it; null
    starts at end_tape_binds' config value); the fabric CWB's later steps take its pick."""
    cfg = hp_config.load()
    s = json.loads(chain.fit_settings(cfg, "fabric_binding"))
    assert s["names"] == ["fabric_end_tape_binds"] and s["cases"] == ["cwb19_t2_fabric"]
    assert s["method"] == "choice" and s["choices"] == cfg["hifi"]["pipeline"]["binds_choices"]
    assert s["start"]["fabric_end_tape_binds"] == 0.0 and s["window"] == cfg["hifi"]["pipeline"]["fabric_window"]
    assert s["start"]["end_tape_binds"] == 0.0          # the tube CWBs' pick comes as a prior, not a start
    assert not any("fabric_end_tape_binds" in chain.STEPS[p]["names"] for p in chain.STEPS["fabric_binding"]["prior"])
    assert "fabric_binding" in chain.STEPS["fabric_build"]["prior"]
    assert "fabric_binding" in chain.STEPS["fabric"]["prior"]
    tube = json.loads(chain.fit_settings(cfg, "binding"))
    assert "fabric_end_tape_binds" not in tube["start"]      # a tube CWB's run does not read it
    own = hp_config.load(overrides={"hifi": {"build": {"fabric_end_tape_binds": None, "end_tape_binds": 1}}})
    assert json.loads(chain.fit_settings(own, "fabric_binding"))["start"]["fabric_end_tape_binds"] == 1.0
