"""The hi-fi Y harness (models/hifi_branch.py, stages/branch_hifi.py): where Fig. 16 puts its
parts, how the wires run through the break-out joint, the strand and the zip ties, and the
energy balance of a short pull."""
from __future__ import annotations

import math

import numpy as np
import pytest

from harnesspipe.config import load
from harnesspipe.fe.solvers.central_difference import DynamicsSettings, integrate
from harnesspipe.models import hifi_branch as hb
from harnesspipe.models import hifi_mesh as hm
from harnesspipe.models.branch import Geometry
from harnesspipe.stages import branch_hifi
from harnesspipe.stages.hifi import inputs

G = Geometry()
D3 = np.array([math.cos(math.radians(30.0)), -math.sin(math.radians(30.0)), 0.0])


@pytest.fixture(scope="module")
def cfg():
    c = load()
    c["profile"] = "quick"
    return c


@pytest.fixture(scope="module")
def inp(cfg):
    i = inputs(cfg, "cwb38_t2_open_coarse", {"wire_elements": "10"})
    i.explicit.update(t_total=1.0, t_phys=50.0)
    return i


@pytest.fixture(scope="module")
def mesh(cfg, inp):
    return hb.build_mesh(cfg, inp.resolution, G)


def _chains(mesh):
    """Node sequence of every wire from its beams (consecutive segments)."""
    out = []
    for w in range(mesh.n_wires):
        seg = mesh.beam_conn[mesh.beam_wire == w]
        assert np.array_equal(seg[1:, 0], seg[:-1, 1]), f"wire {w} is not one chain"
        out.append(np.r_[seg[:, 0], seg[-1, 1]])
    return out


def test_every_wire_runs_from_the_s1_tie_through_the_joint_into_one_branch(mesh):
    """38 wires start at S1's far end (l1 + L1 + e1 from the branch point, e1 = l1), pass the
    branch point and end 19 at S2's taped tip (l2 + L2 + Le, where the strand pulls) and 19 at
    S3's far end (l3 + L3 + l3)."""
    chains = _chains(mesh)
    assert len(chains) == 38
    X = mesh.X
    starts = X[[c[0] for c in chains]]
    ends = X[[c[-1] for c in chains]]
    np.testing.assert_allclose(starts[:, 0], -(G.l1 + G.L1 + G.l1), atol=1e-9)
    to_s2 = np.isclose(ends[:, 0], G.l2 + G.L2 + G.Le)
    to_s3 = np.isclose(ends @ D3, G.l3 + G.L3 + G.l3)
    assert to_s2.sum() == 19 and to_s3.sum() == 19 and not np.any(to_s2 & to_s3)
    assert set(mesh.tip) == {c[-1] for c, s2 in zip(chains, to_s2) if s2}
    for c in chains:                       # each wire reaches the branch point exactly once
        assert np.sum(np.isclose(X[c, 0], 0.0) & (np.abs(X[c, 1]) < 10.0)) == 1
    # the bridges are the only beams kept out of wire-wire contact, two per wire
    assert mesh.bridge_beams.sum() == 2 * 38


def test_tubes_sit_where_fig16_puts_them(mesh):
    """S1: the 15 mm tube (mid radius (d_i + d_o)/4 = 8.35) from l1 to l1 + L1 along -x; S2 and
    S3: the 10 mm tube (6.2) from 30 mm to l + L along their axes; every tube open."""
    tube = mesh.shell_part == hm.PART_TUBE
    for k, (d, s0, s1, R) in enumerate([(np.array([-1.0, 0, 0]), G.l1, G.l1 + G.L1, 8.35),
                                        (np.array([1.0, 0, 0]), G.l2, G.l2 + G.L2, 6.2),
                                        (D3, G.l3, G.l3 + G.L3, 6.2)]):
        nodes = np.unique(mesh.shell_conn[tube & (mesh.shell_segment == k)])
        s = mesh.X[nodes] @ d
        radial = np.linalg.norm(mesh.X[nodes] - s[:, None] * d, axis=1)
        np.testing.assert_allclose([s.min(), s.max()], [s0, s1], atol=1e-9)
        np.testing.assert_allclose(radial, R, rtol=1e-9)
    assert mesh.cut_pairs.shape[0] == mesh.cut_next.size > 0


def test_zip_ties_hold_s1_and_s3_only(mesh):
    X = mesh.X
    c = mesh.clamped
    on_s1 = -X[c, 0] >= G.l1 + G.L1 - 5.0 - 1e-9
    on_s3 = X[c] @ D3 >= G.l3 + G.L3 - 5.0 - 1e-9
    assert np.all(on_s1 | on_s3) and on_s1.any() and on_s3.any()
    assert not np.any(np.isin(mesh.tip, c))


def test_short_pull_balances_energy_holds_the_ties_and_pulls_by_the_strand_law(cfg, inp, mesh):
    """20 ms of the pull: the zip-tied nodes do not move, the energy balance closes and the
    strand tension is EA/H (l - H) on the tip centroid."""
    system = hb.YSystem(mesh, inp, G, "inplane", 50.0)
    res = integrate(system, 0.02, DynamicsSettings(safety=inp.explicit["safety"], n_output=4))
    assert np.array_equal(system.x[mesh.clamped], mesh.X[mesh.clamped])
    assert res.energy_error < 1e-3
    r = system.head - system.x[mesh.tip].mean(axis=0)
    expected = G.strand_EA / G.H * (np.linalg.norm(r) - G.H)
    assert system.displacement() > 0.0 and expected > 0.0
    assert system.tension() == pytest.approx(expected, rel=1e-9)
    assert res.history["W_ext"].iloc[-1] > 0.0


def test_a_pull_that_is_not_quasi_static_fails_with_exit_3_and_writes_nothing(tmp_path, capsys):
    """50 mm in 50 ms of simulated time: KE/IE far above explicit.ke_ie_fail."""
    from harnesspipe.cli import main
    out, summary = tmp_path / "curve.csv", tmp_path / "summary.json"
    rc = main(["hifi", "branch", "--profile", "quick", "--t-total", "0.05", "--out", str(out),
               "--summary", str(summary), "--outdir", str(tmp_path / "files")])
    assert rc == 3 and "KE/IE" in capsys.readouterr().err
    assert not out.exists() and not summary.exists()


def test_incomplete_settings_are_named(cfg, tmp_path):
    settings = branch_hifi.settings_from_config(cfg)
    del settings["t_total"]
    with pytest.raises(Exception, match=r"missing \['t_total'\]"):
        branch_hifi.run(settings, tmp_path / "out")


def test_report_leaves_out_a_y_harness_run_of_another_profile(tmp_path):
    """A summary left in results/branch/hifi by a default run is not shown in a quick run's report
    (branch.hifi.in_all: [default]); the section names the target instead."""
    from harnesspipe import config as cfgmod
    from harnesspipe.report.html import branch_hifi_section
    folder = tmp_path / "branch" / "hifi"
    folder.mkdir(parents=True)
    (folder / "summary.json").write_text("{}")
    cfg = cfgmod.load(overrides={"profile": "quick"})
    text = branch_hifi_section(tmp_path, cfg)
    assert "Not part of the quick profile's run" in text and "branch_hifi_all" in text


def test_report_says_when_the_y_harness_has_not_run_yet(tmp_path):
    """Profile in branch.hifi.in_all but no summary (the report built before the run): the
    section says so instead of claiming the run is not part of the profile."""
    from harnesspipe import config as cfgmod
    from harnesspipe.report.html import branch_hifi_section
    cfg = cfgmod.load(overrides={"profile": "default"})
    text = branch_hifi_section(tmp_path, cfg)
    assert "Not run yet" in text and "Not part of" not in text and "branch_hifi_all" in text


def test_the_crosshead_pulls_at_the_tests_rate_in_physical_time(inp, mesh):
    """Past its ramp the crosshead moves at the test's 1 mm/s (Sec. 2.3: 50 mm at 1 mm/s) in
    the physical time eq. 6 sees, and ends the run at the full stroke, at rest from there."""
    system = hb.YSystem(mesh, inp, G, "inplane", 50.0)
    rate = 50.0 / inp.explicit["t_phys"]
    ramp = system.ramp
    assert ramp == inp.config["hifi"]["explicit"]["rate_ramp"] and rate == pytest.approx(1.0)
    for x in (ramp, 0.5, 0.99):
        dt = 1e-6 * system.T
        system._move_loading(x * system.T)
        d0 = system.displacement()
        system._move_loading(x * system.T + dt)
        v_model = (system.displacement() - d0) / dt
        assert v_model / system.time_scale == pytest.approx(rate, rel=1e-6)
    system._move_loading(system.T)
    assert system.displacement() == pytest.approx(50.0, rel=1e-12)
    system._move_loading(1.5 * system.T)
    assert system.displacement() == pytest.approx(50.0, rel=1e-12)
