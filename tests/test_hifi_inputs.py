"""Issue 25: a hi-fi run depends on the inputs that apply to its case and on nothing else.

A TWB (wires and half-lap tape, no tube, no fabric) has no use for the roller-tube
friction ``mu_rtb`` or the fabric's ``E2/E1``; a tube CWB none for ``E2/E1``.  Changing
them must leave the run bit for bit the same (trajectory, stable step, step count)."""
import numpy as np
import pandas as pd
import pytest

from harnesspipe.config import ConfigError, load
from harnesspipe.models.hifi import three_point
from harnesspipe.stages.hifi import inputs

STOP_MM = 10.0     # a third of the stroke, where the KE/IE check starts: the check reads the row
                   # that ends there (before, it read the rows' mean travel and found none: KE/IE inf)


def _run(case: str, **overrides):
    cfg = load()
    cfg["profile"] = "quick"
    sets = {"stop_deflection": str(STOP_MM), **{k: str(v) for k, v in overrides.items()}}
    return three_point(inputs(cfg, case, sets), n_shapes=2)


def _same_run(a, b):
    pd.testing.assert_frame_equal(a.history, b.history, check_exact=True)
    assert a.summary["steps"] == b.summary["steps"] and a.summary["dt"] == b.summary["dt"]
    for (ua, xa), (ub, xb) in zip(sorted(a.shapes.items()), sorted(b.shapes.items())):
        assert ua == ub and np.array_equal(xa, xb)


@pytest.mark.slow
@pytest.mark.parametrize("case, unused", [
    ("twb19_t2", {"mu_rtb": 0.55, "E2_over_E1": 0.25}),
    ("cwb19_t2_closed", {"E2_over_E1": 0.25}),
])
def test_inputs_that_do_not_apply_do_not_change_the_run(case, unused):
    base = _run(case)
    assert base.summary["contact_pairs_max"] > 0 and base.history["W_ext"].iloc[-1] > 1.0
    for key, value in unused.items():
        _same_run(base, _run(case, **{key: value}))


@pytest.mark.slow
def test_an_input_that_applies_does_change_the_run():
    """The comparison above can fail: the roller-tape friction moves a TWB's curve."""
    a, b = _run("twb19_t2"), _run("twb19_t2", mu_rtp=0.55)
    assert not a.history["force_N"].equals(b.history["force_N"])


@pytest.mark.slow
def test_a_tightly_wrapped_end_band_runs_through_its_prestress_ramp():
    """At 6 wraps and 4 N the prestress moves about 1 N mm between the tape's strain energy
    and its contacts before the feeder has done any work: the blow-up check scales with that
    energy too (``max(|W_ext|, |IE|)``), so the run goes on, and its energy balance closes."""
    cfg = load()
    run = _run("cwb19_t2_closed", end_tape_layers=6, tape_tension=4)   # stopped at 4 % of the time before
    h = run.history
    ramp = h[h["W_ext"].abs() < 1e-3]
    assert len(ramp) >= 3 and ramp["internal"].min() < -0.5          # N mm held by the prestress
    assert run.summary["energy_error"] < cfg["explicit"]["energy_fail"]
    assert run.curve["deflection_mm"].iloc[-1] == pytest.approx(STOP_MM, abs=0.5)


def test_build_state_keys_reach_the_run():
    """--set wire_fill / end_tape_layers (config hifi.build) go into the run's config (so into
    the mesh and the shells); an unknown key or a value the schema refuses is refused."""
    cfg = load()
    inp = inputs(cfg, "cwb19_t2_closed", {"wire_fill": "0.25"})
    assert inp.config["hifi"]["build"]["wire_fill"] == 0.25
    assert cfg["hifi"]["build"]["wire_fill"] == 0.0            # the config is not changed
    with pytest.raises(ConfigError, match="wire_fill"):
        inputs(cfg, "cwb19_t2_closed", {"wire_filling": "0.25"})
    with pytest.raises(ConfigError, match="wire_fill=1.5: expected a fraction"):
        inputs(cfg, "cwb19_t2_closed", {"wire_fill": "1.5"})
    with pytest.raises(ConfigError, match="end_tape_layers=0.5: expected a number of wraps"):
        inputs(cfg, "cwb19_t2_closed", {"end_tape_layers": "0.5"})
    assert inputs(cfg, "cwb19_t2_closed", {"end_tape_layers": "2.5"}).config["hifi"]["build"] == {
        "pack_angle": 1.0, "wire_fill": 0.0, "tube_closure": 1.0, "sleeve_closure": 1.0, "end_tape_layers": 2.5, "end_tape_binds": 0, "fabric_end_tape_binds": 0, "fabric_end_tape_layers": None, "tape_tension": 0.0}
    assert inputs(cfg, "cwb19_t2_closed", {"pack_angle": "7.5"}).config["hifi"]["build"]["pack_angle"] == 7.5
    with pytest.raises(ConfigError, match="pack_angle=45: expected a turn of the wire pack"):
        inputs(cfg, "cwb19_t2_closed", {"pack_angle": "45"})


def test_end_tape_layers_thicken_the_end_bands_only():
    """end_tape_layers scales the stiffness (and mass) thickness of the end bands' tape and of
    nothing else: not the helix, not the tube."""
    from harnesspipe.models import hifi_mesh as hm
    from harnesspipe.models.hifi_bundle import shell_materials
    cfg = load()
    one = inputs(cfg, "cwb19_t2_open_halflap", {})
    three = inputs(cfg, "cwb19_t2_open_halflap", {"end_tape_layers": "3"})
    mesh = hm.build_mesh(one.case, one.config, "quick")
    _, t1, rho1 = shell_materials(mesh, one)
    _, t3, rho3 = shell_materials(mesh, three)
    ends = np.isin(mesh.shell_group, (hm.GROUP_END_LEFT, hm.GROUP_END_RIGHT))
    assert ends.any() and (~ends & (mesh.shell_part == hm.PART_TAPE)).any()
    np.testing.assert_allclose(t3[ends], 3.0 * t1[ends])
    np.testing.assert_array_equal(t3[~ends], t1[~ends])
    np.testing.assert_array_equal(rho3, rho1)


def test_fabric_end_tape_layers_act_on_fabric_cwbs_only():
    """fabric_end_tape_layers sets the end bands of a fabric-sleeved CWB (null: end_tape_layers)
    and leaves a tube CWB's at end_tape_layers."""
    from harnesspipe.models import hifi_mesh as hm
    from harnesspipe.models.hifi_bundle import shell_materials
    cfg = load()

    def end_thickness(case, sets):
        inp = inputs(cfg, case, sets)
        mesh = hm.build_mesh(inp.case, inp.config, "quick")
        ends = np.isin(mesh.shell_group, (hm.GROUP_END_LEFT, hm.GROUP_END_RIGHT))
        return shell_materials(mesh, inp)[1][ends][0]

    one = end_thickness("cwb19_t2_fabric", {"end_tape_layers": "1"})
    assert end_thickness("cwb19_t2_fabric", {"end_tape_layers": "3"}) == pytest.approx(3.0 * one)
    assert end_thickness("cwb19_t2_fabric", {"end_tape_layers": "3", "fabric_end_tape_layers": "2"}) == \
        pytest.approx(2.0 * one)
    tube = end_thickness("cwb19_t2_closed", {"end_tape_layers": "3"})
    assert end_thickness("cwb19_t2_closed", {"end_tape_layers": "3", "fabric_end_tape_layers": "2"}) == tube
    with pytest.raises(ConfigError, match="fabric_end_tape_layers=0.5: expected a number of wraps"):
        inputs(cfg, "cwb19_t2_fabric", {"fabric_end_tape_layers": "0.5"})


def test_closed_slit_tube_is_its_layers_of_wall():
    """``--set tube_closure``: the slit tube rolled onto the bundle is m = R / R' stacked
    equivalent walls: E, sigma_y, K and rho x m at the same t_eq (n, nu kept); the tape is
    untouched; a closure outside [0, 1] is refused naming the key."""
    from harnesspipe.models import hifi_mesh as hm
    from harnesspipe.models.hifi_bundle import shell_materials
    cfg = load()
    moulded = inputs(cfg, "cwb19_t2_open_coarse", {"tube_closure": "0"})
    rolled = inputs(cfg, "cwb19_t2_open_coarse", {"tube_closure": "1"})
    m0 = hm.build_mesh(moulded.case, moulded.config, "quick")
    m1 = hm.build_mesh(rolled.case, rolled.config, "quick")
    mat0, t0, rho0 = shell_materials(m0, moulded)
    mat1, t1, rho1 = shell_materials(m1, rolled)
    m = m1.info["tube_layers"]
    assert m == pytest.approx(6.2 / m1.info["tube_mid_radius"]) and m > 1.3
    tube0, tube1 = m0.shell_part == hm.PART_TUBE, m1.shell_part == hm.PART_TUBE
    np.testing.assert_allclose(mat1[tube1][0, [0, 2, 3]], m * mat0[tube0][0, [0, 2, 3]])
    assert mat1[tube1][0, 4] == mat0[tube0][0, 4] and t1[tube1][0] == t0[tube0][0]
    assert rho1[tube1][0] == pytest.approx(m * rho0[tube0][0])
    tape0, tape1 = m0.shell_part == hm.PART_TAPE, m1.shell_part == hm.PART_TAPE
    np.testing.assert_array_equal(mat1[tape1][0], mat0[tape0][0])
    with pytest.raises(ConfigError, match="tube_closure=1.2: expected a fraction"):
        inputs(cfg, "cwb19_t2_open_coarse", {"tube_closure": "1.2"})
    resultant = load()
    resultant["coverings"]["open_tube"]["wall_law"] = "resultant"
    walls = inputs(resultant, "cwb19_t2_open_coarse", {"tube_closure": "1"})
    with pytest.raises(ValueError, match="wall_law resultant with hifi.build.tube_closure > 0"):
        shell_materials(hm.build_mesh(walls.case, walls.config, "quick"), walls)


def test_sleeve_closure_is_a_set_key_of_the_fabric():
    """``--set sleeve_closure``: the fabric sleeve curled onto the bundle wraps more of the
    same sheet (its mesh has more hoop elements, its material is unchanged); a value
    outside [0, 1] is refused naming the key."""
    from harnesspipe.models import hifi_mesh as hm
    from harnesspipe.models.hifi_bundle import shell_materials
    cfg = load()
    free = inputs(cfg, "cwb19_t2_fabric", {"sleeve_closure": "0"})
    curled = inputs(cfg, "cwb19_t2_fabric", {"sleeve_closure": "1"})
    assert curled.config["hifi"]["build"]["sleeve_closure"] == 1.0
    m0 = hm.build_mesh(free.case, free.config, "quick")
    m1 = hm.build_mesh(curled.case, curled.config, "quick")
    fab0, fab1 = m0.shell_part == hm.PART_FABRIC, m1.shell_part == hm.PART_FABRIC
    assert fab1.sum() > fab0.sum()
    mat0, _, rho0 = shell_materials(m0, free)
    mat1, _, rho1 = shell_materials(m1, curled)
    np.testing.assert_array_equal(mat1[fab1][0], mat0[fab0][0])
    assert rho1[fab1][0] == rho0[fab0][0]
    with pytest.raises(ConfigError, match="sleeve_closure=1.2: expected a fraction"):
        inputs(cfg, "cwb19_t2_fabric", {"sleeve_closure": "1.2"})


def test_end_tape_binds_is_a_set_key_of_zero_or_one():
    """``--set end_tape_binds=1`` reaches the build state; anything but 0 or 1 is refused
    naming the key and its two meanings."""
    cfg = load()
    assert cfg["hifi"]["build"]["end_tape_binds"] == 0
    assert inputs(cfg, "cwb19_t2_closed", {"end_tape_binds": "1"}).config["hifi"]["build"]["end_tape_binds"] == 1.0
    with pytest.raises(ConfigError, match=r"end_tape_binds=0.5: expected 0 \(the wires the end band "
                                          r"touches\) or 1 \(every wire under it\), a whole number"):
        inputs(cfg, "cwb19_t2_closed", {"end_tape_binds": "0.5"})


def test_corrugation_pitch_is_a_set_key_of_the_tubes():
    """``--set open_tube.pitch=4`` reaches the tube's homogenisation (its hoop bending
    stiffness grows with the ridge's spacing, issue 27 item 4); a pitch <= 0 and a pitch on
    the fabric sleeve are refused, naming the key."""
    from harnesspipe.models import hifi_mesh as hm
    from harnesspipe.models.hifi_bundle import shell_materials
    cfg = load()
    base = inputs(cfg, "cwb19_t2_open_halflap", {})
    wide = inputs(cfg, "cwb19_t2_open_halflap", {"open_tube.pitch": "4"})
    assert base.config["coverings"]["open_tube"]["pitch"] == cfg["coverings"]["open_tube"]["pitch"]
    assert wide.config["coverings"]["open_tube"]["pitch"] == 4.0
    assert wide.config["coverings"]["closed_tube"]["pitch"] == cfg["coverings"]["closed_tube"]["pitch"]
    mesh = hm.build_mesh(base.case, base.config, "quick")
    tube = mesh.shell_part == hm.PART_TUBE
    _, t_base, _ = shell_materials(mesh, base)
    _, t_wide, _ = shell_materials(mesh, wide)
    assert t_wide[tube][0] != pytest.approx(t_base[tube][0], rel=1e-3)   # t_eq = sqrt(12 D_h / k_ax)
    with pytest.raises(ConfigError, match="open_tube.pitch=0: expected a corrugation pitch"):
        inputs(cfg, "cwb19_t2_open_halflap", {"open_tube.pitch": "0"})
    with pytest.raises(ConfigError, match="fabric_tube.pitch: unknown parameter"):
        inputs(cfg, "cwb19_t2_fabric", {"fabric_tube.pitch": "3"})


def test_a_run_stopped_before_its_quasi_static_check_is_refused_up_front():
    """``--set stop_deflection`` below a third of the stroke would end the run before its
    KE/IE check starts: refused with the smallest valid stop named, before anything runs;
    0 (the whole stroke) and a stop at the check's start are accepted."""
    cfg = load()
    stroke = cfg["three_point"]["deflection"]
    with pytest.raises(ConfigError, match=rf"stop_deflection=8: expected 0 \(the whole stroke\) "
                                          rf"or a deflection of at least {stroke / 3:g} mm"):
        inputs(cfg, "cwb19_t2_closed", {"stop_deflection": "8"})
    for ok in ("0", f"{stroke / 3:g}", str(STOP_MM)):
        assert inputs(cfg, "cwb19_t2_closed", {"stop_deflection": ok}).explicit["stop_deflection"] == float(ok)


def test_tape_tension_prestresses_every_tape_element_along_the_tape():
    """``--set tape_tension=T`` (N) wraps the tape at T: every tape element (end bands and
    the half-lap helix) reaches the stress T / (w t) along its material axis, none across
    it, raised by the smooth step over the run's first WRAP_FRACTION (half of it at half
    that time); the other shells stay unstressed.  At or above the tape's yield force
    sigma_y w t the run is refused."""
    from harnesspipe.fe.elements import shell_bt as bt
    from harnesspipe.models import hifi, hifi_mesh as hm
    from harnesspipe.models.hifi_bundle import WRAP_FRACTION
    cfg = load()
    cfg["profile"] = "quick"
    inp = inputs(cfg, "cwb19_t2_open_halflap", {"tape_tension": "2"})
    system = hifi.HifiSystem(hm.build_mesh(inp.case, inp.config, inp.resolution), inp)
    tape_props = cfg["materials"]["pvc_tape"]
    sigma_1 = 2.0 / (tape_props["width"] * tape_props["thickness"])
    st, tape = system.sstate, system.mesh.shell_part == hm.PART_TAPE
    assert tape.sum() > 100 and (~tape).sum() > 100
    at_rest = np.zeros_like(system.mass)
    for level, t in ((0.5, 0.5), (1.0, 1.0), (1.0, 2.0)):      # t in units of the ramp
        system.forces(t * WRAP_FRACTION * system.T, at_rest, 1e-9)
        c, s = st[:, bt.S_MCOS], st[:, bt.S_MSIN]
        sx, sy, sxy = (st[:, bt.PT_SIG + i] for i in range(3))
        along = sx * c * c + sy * s * s + 2.0 * sxy * c * s
        across = sx * s * s + sy * c * c - 2.0 * sxy * c * s
        np.testing.assert_allclose(along[tape], level * sigma_1, rtol=1e-9)
        assert np.abs(across[tape]).max() < 1e-9 * sigma_1
        assert not st[~tape, :bt.S_GXZ].any()
    limit = tape_props["sigma_y"] * tape_props["width"] * tape_props["thickness"]
    with pytest.raises(ConfigError, match=rf"tape_tension=5: expected a wrapping tension below "
                                          rf"the tape's yield force sigma_y w t = {limit:.3g} N"):
        inputs(cfg, "cwb19_t2_open_halflap", {"tape_tension": "5"})
    with pytest.raises(ConfigError, match="tape_tension=-1: expected a wrapping tension"):
        inputs(cfg, "cwb19_t2_open_halflap", {"tape_tension": "-1"})
