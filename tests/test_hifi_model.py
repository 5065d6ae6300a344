"""Hi-fi virtual three-point test (Sec. 4.1): explicit core on a pinned wire, a full CWB
run (energy balance, no energy created by any interaction, quasi-static end state,
artefacts) and the CLI's error handling."""
import json
import subprocess
import sys

import numpy as np
import pytest

from harnesspipe.config import load
from harnesspipe.fe.rotation import rotate_nodes
from harnesspipe.fe.solvers.central_difference import DynamicsSettings, ExplicitError, integrate
from harnesspipe.models.hifi_parts import Wires


class PinnedWire:
    """One elastic wire, pinned at both ends, mid-span load P with a smooth step, mass damping:
    the dynamics protocol in its smallest form."""

    families = ("internal", "load", "damping")

    def __init__(self, L=100.0, n_el=20, r=0.7, E=4528.0, P=0.05, T=0.2, c=150.0):
        x = np.linspace(0.0, L, n_el + 1)
        self.X = np.c_[x, np.zeros_like(x), np.zeros_like(x)]
        conn = np.c_[np.arange(n_el), np.arange(1, n_el + 1)]
        wire = dict(d_outer=2 * r, E=E, nu=0.39, sigma_y=1e9, K=0.0, n=1.0, rho=4.34e-9)
        self.w = Wires(self.X, conn, np.zeros(n_el, dtype=int), [wire], 2, 8, 3, 25.0)
        n = self.X.shape[0]
        self.x = self.X.copy()
        self.quat = np.zeros((n, 4))
        self.quat[:, 0] = 1.0
        self.mass = np.zeros((n, 6))
        self.w.add_mass(self.mass)
        self.free = np.ones((n, 6), dtype=bool)
        self.free[0, :3] = False
        self.free[-1, 1:3] = False
        self.free[:, 3:5] = False               # planar bending about z
        self.mid, self.P, self.T, self.c = n_el // 2, P, T, c
        self.F = np.zeros((3, n, 6))
        self.EI = E * np.pi * r**4 / 4.0
        self.L = L

    def stable_step(self):
        return self.w.stable_step(self.x)

    def forces(self, t, v, dt):
        from harnesspipe.fe.solvers.central_difference import smooth_step
        self.F[...] = 0.0
        self.w.add_forces(self.x, self.quat, self.F[0])
        self.F[1, self.mid, 1] = -self.P * smooth_step(min(t / (0.5 * self.T), 1.0))[0]
        self.F[2] = -self.c * self.mass * v
        return self.F

    def advance(self, du, t):
        self.x += du[:, :3]
        rotate_nodes(self.quat, np.ascontiguousarray(du[:, 3:]))

    def external_work(self, t0, t1):
        return 0.0                              # the load is a family: its work is W[load]

    def displacement_max(self):
        return float(np.abs(self.x - self.X).max())

    def observe(self, t):
        return {"deflection": -(self.x[self.mid, 1] - self.X[self.mid, 1])}


def test_explicit_pinned_wire_matches_static_beam_theory_and_balances_energy():
    s = PinnedWire()
    res = integrate(s, s.T, DynamicsSettings(safety=0.8, n_output=50))
    h = res.history
    u = h["deflection"].iloc[-1]
    assert u == pytest.approx(s.P * s.L**3 / (48.0 * s.EI), rel=0.02)
    # the load's work goes into strain energy and damping; the balance is closed
    W_load = -h["load"].iloc[-1]
    assert h["internal"].iloc[-1] + h["damping"].iloc[-1] + h["KE"].iloc[-1] == pytest.approx(W_load, rel=1e-3)
    assert h["internal"].iloc[-1] == pytest.approx(0.5 * s.P * u, rel=0.02)   # Clapeyron
    assert res.energy_error < 1e-3


class SpringMass:
    """Masses on a chain of linear springs, pulled at one end by a force applied at once
    (they vibrate): no dissipation, so the scheme's own energy error is all that is left."""

    families = ("spring", "load")

    def __init__(self, n=4, k=1e4, m=1e-3, P=2.0, T=1e-6):
        self.k, self.P, self.T = k, P, T
        self.mass = np.full((n, 6), m)
        self.free = np.zeros((n, 6), dtype=bool)
        self.free[:, 0] = True
        self.u = np.zeros(n)
        self.F = np.zeros((2, n, 6))

    def stable_step(self):
        return 2.0 / np.sqrt(4.0 * self.k / self.mass[0, 0])

    def forces(self, t, v, dt):
        e = np.diff(np.r_[0.0, self.u])          # first spring anchored at the origin
        f = self.k * e
        self.F[0, :, 0] = -f + np.r_[f[1:], 0.0]
        self.F[1, -1, 0] = self.P * min(t / self.T, 1.0)
        return self.F

    def advance(self, du, t):
        self.u += du[:, 0]

    def external_work(self, t0, t1):
        return 0.0

    def displacement_max(self):
        return float(np.abs(self.u).max())

    def observe(self, t):
        return {}


def test_balance_error_is_the_bounded_verlet_term_and_does_not_drift():
    """Undamped springs hit by a sudden load vibrate for ~7000 steps: the balance error is
    ``h^2/8 (|F_n|^2 - |F_0|^2)_M^-1`` (``integrate``'s docstring), bounded by the largest
    nodal force, and no larger at the end than after the first periods."""
    s = SpringMass()
    settings = DynamicsSettings(safety=0.9, n_output=400, energy_stop=10.0)
    res = integrate(s, 2.0, settings, internal="spring")
    assert res.n_steps > 7000
    b = np.abs(res.history["balance_error"].to_numpy()[1:])
    f_max = 4.0 * s.P           # a net nodal force bound: springs at twice the static load
    bound = 0.125 * res.dt**2 * s.mass.shape[0] * f_max**2 / s.mass[0, 0]
    assert 0.0 < b.max() <= bound
    assert b[-40:].max() <= 1.5 * b[:40].max()    # no drift



class UnstableSpringMass(SpringMass):
    """The springs above integrated at ``factor`` x their critical step."""

    def __init__(self, factor, **kw):
        super().__init__(**kw)
        self.factor = factor

    def stable_step(self):
        return self.factor * super().stable_step()


@pytest.mark.parametrize("factor, safety", [(50.0, 0.9), (1.0, 1.2)])
def test_a_step_beyond_the_stable_one_stops_the_run_and_says_why(factor, safety):
    """integrate at 45 x and at 1.2 x the critical step (eq. 11): the run blows up and
    stops with ExplicitError within its first periods, naming the check it failed (energy
    balance or non-finite state), the step, the time and the energies; at 0.9 x it runs."""
    s = UnstableSpringMass(factor)
    with pytest.raises(ExplicitError) as exc:
        integrate(s, 2.0, DynamicsSettings(safety=safety), internal="spring")
    e = exc.value
    assert 0 < e.step < 2000 and e.time == pytest.approx(e.step * e.dt, rel=1e-9)
    assert e.dt == pytest.approx(safety * s.stable_step())
    msg = str(e)
    assert msg.startswith("explicit run stopped: ") and f"at step {e.step}," in msg
    assert ("energy balance error" in msg) or ("non-finite state" in msg)
    assert "KE = " in msg and "IE = " in msg and "W_ext = " in msg
    res = integrate(SpringMass(), 2.0, DynamicsSettings(safety=0.9), internal="spring")
    assert res.n_steps > 7000 and res.energy_error < 1.0


def test_a_displacement_beyond_the_bound_stops_the_run():
    """A stable run whose pulled end travels further than ``max_displacement``: stopped at
    the first history row past it, the message giving the displacement and the bound."""
    s = SpringMass()
    with pytest.raises(ExplicitError) as exc:
        integrate(s, 2.0, DynamicsSettings(safety=0.9, max_displacement=1e-4), internal="spring")
    assert "displacement" in str(exc.value) and "> 0.0001 mm" in str(exc.value)
    assert s.displacement_max() > 1e-4

def test_close_and_kick_is_the_closing_half_step_then_the_next_opening():
    """close_and_kick (one step's closing half kick and the next's opening, fused) against
    the velocity-Verlet formulas; the closed step's work and KE do not depend on the next
    step, and h_next = 0 opens nothing (the last step; from rest, hdt = 0 closes nothing)."""
    from harnesspipe.fe.solvers.central_difference import close_and_kick
    rng = np.random.default_rng(5)
    n, P, hdt, h1 = 7, 3, 2e-4, 3e-4
    F = rng.standard_normal((P, n, 6))
    m = rng.random((n, 6)) + 0.5
    free = rng.random((n, 6)) > 0.2
    v0, du = rng.standard_normal((n, 6)), rng.standard_normal((n, 6))
    W0 = rng.standard_normal(P)
    out = {}
    for h in (h1, 0.0):
        v, W, W_end = v0.copy(), W0.copy(), np.zeros(P)
        f, du_next = np.zeros((n, 6)), np.zeros((n, 6))
        ke, w_total = close_and_kick(F, du, du_next, W, W_end, v, 1.0 / m, free, hdt, m, f, h)
        out[h] = (v, W, W_end, du_next, ke, w_total, f)
    f = F.sum(axis=0)
    v_end = np.where(free, v0 + hdt * f / m, 0.0)
    W_end = W0 + 0.5 * np.einsum("pij,ij->p", F, du)
    v1 = np.where(free, v_end + 0.5 * h1 * f / m, 0.0)
    for h, v_ref in ((h1, v1), (0.0, v_end)):
        v, W, W_got, du_next, ke, w_total, f_got = out[h]
        assert np.allclose(f_got, f, rtol=1e-15, atol=0.0)
        assert np.allclose(W_got, W_end, rtol=1e-14, atol=0.0)
        assert ke == pytest.approx(0.5 * np.sum(m * v_end**2), rel=1e-14)
        assert w_total == pytest.approx(W_end.sum(), rel=1e-14)
        assert np.allclose(v, v_ref, rtol=1e-14, atol=0.0)
        assert np.allclose(du_next, h * v_ref, rtol=1e-14, atol=0.0)
        assert np.allclose(W, W_end + 0.5 * np.einsum("pij,ij->p", F, du_next), rtol=1e-14)
    assert np.array_equal(out[0.0][1], out[0.0][2]) and not out[0.0][3].any()

SUMMARY_KEYS = {"wall_s", "steps", "dt", "f_m", "ke_ie_max", "energy_error", "n_beam_elements",
                "n_shell_elements", "contact_pairs_max", "force_drop"}


@pytest.fixture(scope="module")
def cwb_run(tmp_path_factory):
    """One full coarse-taped open-tube CWB (wires, tube with cut, helix and end tapes, ties,
    pins), quick mesh, shortened to 0.3 s: an energy test, not a quasi-static one."""
    from harnesspipe.stages.hifi import run_case
    cfg = load()
    cfg["profile"] = "quick"
    cfg["explicit"]["ke_ie_fail"] = 100.0
    out = tmp_path_factory.mktemp("hifi")
    summary = run_case(cfg, "cwb19_t2_open_coarse", {"t_total": "0.3"}, coverings=None,
                       out_csv=out / "curve.csv", summary_json=out / "summary.json",
                       outdir=out / "files")
    return out, summary


def test_full_cwb_run_closes_the_energy_balance_and_creates_no_energy(cwb_run):
    import pandas as pd
    out, summary = cwb_run
    h = pd.read_csv(out / "files" / "energies.csv")
    W = h["W_ext"].to_numpy()
    assert W[-1] > 10.0                                   # N mm: the feeder did real work
    # largest balance error of the run within 1 % of the test's work (dynamics.integrate)
    assert np.max(np.abs(h["balance_error"])) < 0.01 * W[-1]
    # the summary's error is the largest over every step, the history samples 200 of them
    row_max = np.max(np.abs(h["balance_error"])) / W[-1]
    assert row_max * (1.0 - 1e-9) <= summary["energy_error"] < 0.01
    for family in ("internal", "contact", "friction", "pin_contact", "pin_friction", "cohesive"):
        assert h[family].min() > -0.01 * W[-1], family     # no interaction is an energy source
    assert 0.0 < h["plastic"].iloc[-1] < h["internal"].iloc[-1]   # the wires yield (Table 1)
    curve = pd.read_csv(out / "curve.csv")
    assert list(curve.columns) == ["deflection_mm", "force_N"]
    assert h["deflection_mm_end"].iloc[-1] == pytest.approx(30.0, abs=1e-9)   # the feeder went the stroke
    # each row is a mean over its interval; the feeder ends at the test's rate, so the last
    # row's mean lies half a row's travel short of 30 mm (200 rows: 0.09 mm)
    assert 0.0 < 30.0 - curve["deflection_mm"].iloc[-1] < 0.1
    assert SUMMARY_KEYS <= set(json.loads((out / "summary.json").read_text()))
    assert summary["n_shell_elements"] > 0 and summary["contact_pairs_max"] > 0
    # the tape ties' opening: a running maximum that ends at the summary's largest separation
    opening = h["tie_opening_mm"].to_numpy()
    assert np.all(np.diff(opening) >= 0.0) and opening[0] < opening[-1]
    assert opening[-1] == pytest.approx(summary["tie_separation_max_mm"], rel=1e-8)   # csv digits


def test_full_cwb_run_writes_shapes_and_slip_out(cwb_run):
    import meshio
    import pandas as pd
    out, _ = cwb_run
    files = out / "files"
    vtus = sorted((files / "shapes").glob("*.vtu"))
    assert len(vtus) >= 3 and (files / "shapes" / "shapes.pvd").exists()
    assert (files / "shapes.png").stat().st_size > 1000
    m = meshio.read(vtus[-1])
    assert m.points[:, 1].min() < -25.0                    # bent: the mid-span went down ~30 mm
    slip = pd.read_csv(files / "slip_out.csv")
    assert len(slip) == 19 and np.all(np.isfinite(slip[["left_mm", "right_mm"]]))


def test_force_drop_finds_the_fall_below_the_running_peak_and_tells_a_snap_from_softening():
    from harnesspipe.models.hifi import force_drop, is_fall, is_snap
    u = np.linspace(0.0, 30.0, 301)
    rising = 10.0 * np.sqrt(u)
    assert force_drop(u, rising) == {"drop_N": 0.0, "fraction": 0.0, "from_mm": 0.0, "to_mm": 0.0}
    assert not is_fall(force_drop(u, rising)) and not is_snap(force_drop(u, rising))
    # a snap: 11.6 N at 24 mm falls to 6.4 N at 26 mm and recovers to 8.8 N at 30 mm
    snap = np.interp(u, [0.0, 24.0, 26.0, 30.0], [0.0, 11.6, 6.4, 8.8])
    d = force_drop(u, snap)
    assert d["drop_N"] == pytest.approx(5.2) and d["fraction"] == pytest.approx(5.2 / 11.6)
    assert (d["from_mm"], d["to_mm"]) == pytest.approx((24.0, 26.0))
    assert is_fall(d) and is_snap(d)
    # softening: the same fraction lost over 25 mm is a fall, not a snap
    soft = np.interp(u, [0.0, 5.0, 30.0], [0.0, 10.0, 10.0 * (1 - 5.2 / 11.6)])
    d = force_drop(u, soft)
    assert d["fraction"] == pytest.approx(5.2 / 11.6) and (d["from_mm"], d["to_mm"]) == pytest.approx((5.0, 30.0))
    assert is_fall(d) and not is_snap(d)
    # a ripple of 5 % is neither
    ripple = np.interp(u, [0.0, 10.0, 10.5, 30.0], [0.0, 10.0, 9.5, 15.0])
    assert not is_fall(force_drop(u, ripple)) and not is_snap(force_drop(u, ripple))


def _cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "harnesspipe", "hifi", "three-point", *args],
                          capture_output=True, text=True, cwd=cwd)


def test_cli_rejects_unknown_case_and_parameter(tmp_path):
    r = _cli("--case", "cwb99", "--out", str(tmp_path / "a.csv"), "--summary", str(tmp_path / "a.json"))
    assert r.returncode == 2 and "cwb99" in r.stderr and "cwb19_t2_closed" in r.stderr
    r = _cli("--case", "cwb19_t2_closed", "--set", "mu_rbt=0.3", "--out", str(tmp_path / "a.csv"),
             "--summary", str(tmp_path / "a.json"))
    assert r.returncode == 2 and "mu_rbt" in r.stderr and "mu_rtb" in r.stderr
    assert not (tmp_path / "a.csv").exists()


def test_case_loading_time_scale_and_explicit_override():
    """A soft bundle's case may lengthen the loading time (t_total_scale); --set t_total wins."""
    from harnesspipe.stages.hifi import inputs
    cfg = load(overrides={"profile": "quick"})
    base = cfg["profiles"]["quick"]["hifi"]["t_total"]
    scale = cfg["hifi"]["extra_cases"]["twb19_t2"]["t_total_scale"]
    assert scale > 1.0
    assert inputs(cfg, "twb19_t2", {}).explicit["t_total"] == pytest.approx(scale * base)
    assert inputs(cfg, "cwb19_t2_closed", {}).explicit["t_total"] == pytest.approx(base)
    assert inputs(cfg, "twb19_t2", {"t_total": "0.5"}).explicit["t_total"] == 0.5


@pytest.mark.parametrize("case", ["cwb19_t2_closed", "twb19_t2"])
def test_the_feeder_runs_at_the_tests_rate_in_physical_time(case):
    """Past its ramp the feeder moves at the test's 0.5 mm/s (Sec. 2.2: 30 mm in 60 s) in
    the physical time eq. 6 sees (model speed / time_scale), whatever the case's loading
    time, and ends the run at the full stroke."""
    from harnesspipe.models import hifi_mesh as hm
    from harnesspipe.models.hifi import HifiSystem
    from harnesspipe.stages.hifi import inputs
    cfg = load(overrides={"profile": "quick"})
    inp = inputs(cfg, case, {})
    s = HifiSystem(hm.build_mesh(inp.case, inp.config, inp.resolution), inp)
    rate = cfg["three_point"]["deflection"] / cfg["hifi"]["explicit"]["t_phys"]
    assert rate == pytest.approx(0.5)
    ramp = cfg["hifi"]["explicit"]["rate_ramp"]
    for x in (ramp, 0.5, 0.9, 1.0):
        s.pins.move_to(x * s.T)
        assert -s.pins.velocity[s.pins.feeder, 1] / s.time_scale == pytest.approx(rate, rel=1e-12)
    assert s.pins.feeder_displacement() == pytest.approx(cfg["three_point"]["deflection"], rel=1e-12)
    s.pins.move_to(0.0)
    assert s.pins.feeder_displacement() == 0.0 and s.pins.velocity[s.pins.feeder, 1] == 0.0


def test_wires_sharing_a_node_are_rejected():
    """The pins meet the wires chain by chain in parallel: a mesh whose wires share a node
    (two chains would move it at once) is refused with a clear error."""
    from harnesspipe.models import hifi_mesh as hm
    from harnesspipe.models.hifi import HifiSystem
    from harnesspipe.stages.hifi import inputs
    inp = inputs(load(overrides={"profile": "quick"}), "twb19_t2", {})
    mesh = hm.build_mesh(inp.case, inp.config, inp.resolution)
    HifiSystem(mesh, inp)                                    # as meshed: accepted
    first = np.flatnonzero(mesh.beam_wire == 1)[0]
    mesh.beam_conn[first, 0] = mesh.beam_conn[0, 0]          # wire 1 starts on wire 0's node
    with pytest.raises(ValueError, match="must not share nodes"):
        HifiSystem(mesh, inp)


def test_rejected_run_fails_with_diagnostics_and_writes_nothing(tmp_path):
    """A run the explicit checks reject (here: limits no run meets, in a config file; the
    stable-step safety factor above 1 that once forced a blow-up is now refused as input)
    exits 3 naming the step and the energies, and writes no file."""
    import yaml

    from harnesspipe.config import DEFAULT_CONFIG
    cfg = yaml.safe_load(DEFAULT_CONFIG.read_text())
    cfg["explicit"].update(ke_ie_fail=1e-9, energy_fail=1e-9)
    config = tmp_path / "config.yaml"
    config.write_text(yaml.safe_dump(cfg))
    out = tmp_path / "out"
    out.mkdir()
    r = _cli("--config", str(config), "--case", "cwb19_t2_closed", "--profile", "quick",
             "--set", "t_total=0.05", "--out", str(out / "a.csv"), "--summary", str(out / "a.json"))
    assert r.returncode == 3, r.stderr
    assert "step" in r.stderr and "W_ext" in r.stderr and "KE/IE" in r.stderr
    assert not any(out.iterdir())


def test_beam_tie_carries_no_force_under_rigid_motion_and_its_moment_balances():
    """A tape node tied to a wire point with a lever arm: a rigid rotation of wire and node
    leaves the tie unloaded; a pulled tie exerts no net force or moment on the system."""
    from harnesspipe.fe.contact.cohesive_ties import BeamTieSet, TieLaw, cohesive_ties_beam
    from harnesspipe.fe.rotation import quat_from_rotvec
    X = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [4.0, 0.75, 0.0]])
    seg = np.array([[0, 1]])
    args = dict(tie_node=np.array([2]), tie_seg=np.array([0]), tie_s=np.array([0.4]),
                tie_anchor=np.array([0]), tie_arm=np.array([[0.0, 0.75, 0.0]]),
                tie_axis=np.array([[1.0, 0.0, 0.0]]), tie_area=np.array([2.0]))
    K, d0 = np.full(3, 30.0), np.full(3, 0.03)

    def call(x, quat):
        f = np.zeros((3, 6))
        hist = [np.zeros(1), np.zeros(1), np.zeros(1)]
        ties = BeamTieSet(**args, tie_c=np.zeros(1), seg=seg, tie_kappa=hist[0], tie_D=hist[1],
                          tie_energy=hist[2])
        cohesive_ties_beam(x, np.zeros_like(x), quat, ties, TieLaw(K, d0, 0.08, 2.0), f)
        return f

    theta = np.array([0.3, -0.5, 0.9])
    q = np.zeros(4)
    quat_from_rotvec(theta, q)
    c, s = np.cos(np.linalg.norm(theta)), np.sin(np.linalg.norm(theta))
    k = theta / np.linalg.norm(theta)
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    R = np.eye(3) + s * Kx + (1 - c) * Kx @ Kx
    x = X @ R.T + np.array([1.0, 2.0, 3.0])
    quat = np.tile(q, (3, 1))
    assert np.abs(call(x, quat)).max() < 1e-10
    x2 = X.copy()
    x2[2] += [0.01, 0.02, 0.005]                     # open the tie (below delta0: elastic)
    f = call(x2, np.tile([1.0, 0.0, 0.0, 0.0], (3, 1)))
    assert np.abs(f[:, :3].sum(axis=0)).max() < 1e-12
    moment = np.cross(x2, f[:, :3]).sum(axis=0) + f[:, 3:].sum(axis=0)
    assert np.abs(moment).max() < 1e-12
    assert np.linalg.norm(f[2, :3]) == pytest.approx(30.0 * 2.0 * np.linalg.norm([0.01, 0.02, 0.005]))


def _default_halflap_one_wrap():
    from harnesspipe.models import hifi, hifi_mesh as hm
    from harnesspipe.stages.hifi import inputs
    cfg = load()
    cfg["profile"] = "default"
    inp = inputs(cfg, "cwb19_t2_open_halflap", {"end_tape_layers": "1", "tape_tension": "0"})
    return inp, hifi.HifiSystem(hm.build_mesh(inp.case, inp.config, inp.resolution), inp)


def test_tube_nodes_under_offset_ties_are_within_the_stable_step():
    """A quad tie's separation is read in the facet's turning frame, so the tape's offset
    (the half thicknesses, ~0.9 mm on the tube) couples the tie to every node of its facet,
    the nodes its shape functions weigh 0 included.  Left out of the Gershgorin bound, the
    default-profile half-lap at one wrap blew up at the tube's end edge within 140 steps
    (energy balance error 1.1e-3 N mm at step 138, the cohesive ties giving 0.9 N mm).
    With the lever in the bound it stays at rest's scale over its first ~380 steps."""
    inp, system = _default_halflap_one_wrap()
    res = integrate(system, 0.006, DynamicsSettings(safety=inp.explicit["safety"], n_output=6))
    h = res.history.iloc[-1]
    assert res.n_steps > 300
    assert h["KE"] < 1e-8 and abs(h["cohesive"]) < 1e-8 and h["debonded_ties"] == 0


def test_tie_rows_bound_the_quad_ties_stiffness():
    """The Gershgorin weights of the quad ties (``_tie_rows``: k B_a S at node a) against
    the tie's stiffness by central differences of the tie kernel, block row by block row
    (sum over b of the 3x3 blocks' spectral norms): within 10 % on the ties of the default
    half-lap (onto the tube and onto the tape underneath), interior and clamped to a
    facet's corner alike (the bound takes the facet's mean sides; on the tube's curved
    trapezoids it is exact to a few %, well inside the step's safety factor 0.8, i.e.
    1.56 on omega^2).  Without the lever (B = N) the
    facet nodes weighed 0 carry a stiffness the bound did not see."""
    inp, s = _default_halflap_one_wrap()
    itf = inp.interface
    ratio, unseen = [], 0.0
    for ties in (t for t in s.ties if t["kind"] == "quad"):     # onto the tube, onto the tape
        ratio_g, unseen_g = _tie_rows_against_stiffness(s, itf, ties)
        ratio += ratio_g
        unseen = max(unseen, unseen_g)
    assert len(ratio) > 100 and max(ratio) < 1.1 and np.median(ratio) > 0.3
    assert unseen > 0.3      # stiffness at nodes of weight N = 0: what the old bound missed


def _tie_rows_against_stiffness(s, itf, ties):
    """Per node of a sample of the group's ties: (block row sum of the tie's stiffness) / (its
    bound k B_a S), and the largest row sum / k at a facet node of weight N = 0."""
    from harnesspipe.fe.contact.cohesive_ties import (QuadTieSet, TieLaw, cohesive_ties_quad_serial,
                                                       tie_set)
    targets, B, S = s._tie_rows(ties)
    N_all = s._tie_targets(ties)[1]
    k = np.max(s.K_coh) * ties["tie_area"]
    n = ties["tie_node"].size
    clamped = np.flatnonzero(np.abs(ties["tie_xi"]).max(axis=1) >= 1.0)
    ratio, unseen = [], 0.0
    for i in np.unique(np.r_[np.arange(0, n, max(1, n // 12)), clamped[:8]]):
        nodes = np.r_[ties["tie_node"][i], targets[i]]
        one = slice(i, i + 1)

        def force(x):
            f = np.zeros_like(x)
            one_tie = {name: ties[name][one] for name in ("tie_node", "tie_quad", "tie_xi",
                                                          "tie_sign", "tie_off", "tie_area")}
            cohesive_ties_quad_serial(
                x, np.zeros_like(x),
                tie_set(QuadTieSet, one_tie, tie_c=np.zeros(1), quads=ties["quads"],
                        tie_kappa=np.zeros(1), tie_D=np.zeros(1), tie_energy=np.zeros(1)),
                TieLaw(s.K_coh, s.delta0, itf["delta_f"], itf["alpha_d"]), f)
            return f[nodes, :3].ravel()

        K, h = np.zeros((15, 15)), 1e-7
        for c in range(15):
            xp, xm = s.x.copy(), s.x.copy()
            xp[nodes[c // 3], c % 3] += h
            xm[nodes[c // 3], c % 3] -= h
            K[:, c] = -(force(xp) - force(xm)) / (2.0 * h)
        weight, N = np.r_[1.0, B[i]], np.r_[1.0, N_all[i]]
        for a in range(5):
            row = sum(np.linalg.norm(K[3 * a:3 * a + 3, 3 * b:3 * b + 3], 2) for b in range(5))
            if weight[a] == 0.0:          # a corner opposite the tie point: no coupling
                assert row < 1e-6 * k[i]
                continue
            ratio.append(row / (k[i] * weight[a] * S[i]))
            if N[a] == 0.0:
                unseen = max(unseen, row / k[i])
    return ratio, unseen


def _closed_quick(binds: str):
    from harnesspipe.models import hifi, hifi_mesh as hm
    from harnesspipe.stages.hifi import inputs
    inp = inputs(load(overrides={"profile": "quick"}), "cwb19_t2_closed", {"end_tape_binds": binds})
    return hifi.HifiSystem(hm.build_mesh(inp.case, inp.config, inp.resolution), inp)


def _tied_wires(s, side: float) -> set:
    """Wires holding a beam tie at the ``side`` (-1, +1) end of the sample."""
    out = set()
    for t in (t for t in s.ties if t["kind"] == "beam"):
        on_side = np.sign(s.x[t["tie_node"], 0] - s.x[:, 0].mean()) == side
        out |= set(s.mesh.beam_wire[t["tie_seg"][on_side]].tolist())
    return out


def test_end_tape_binds_every_wire_with_the_bands_bond_area_shared():
    """``end_tape_binds`` 0 (default): the end bands tie only wires of the 1-6-12 bundle's
    outer ring, the ones their nodes touch (8 of 12 with the quick and the default mesh), the
    inner 7 none.  1: every wire at both ends; the extra ties of each band node share its
    bond area (their areas sum to its own), and at rest every tie is unstretched whatever
    its lever arm (the ties exert no force in the undeformed state)."""
    from hifi_reference import separate_forces
    touching, every = _closed_quick("0"), _closed_quick("1")
    r = np.linalg.norm(touching.mesh.wire_yz - touching.mesh.wire_yz.mean(axis=0), axis=1)
    outer = set(np.argsort(r)[7:].tolist())
    held = _tied_wires(touching, -1.0) | _tied_wires(touching, 1.0)
    assert 8 <= len(held) and held <= outer
    for side in (-1.0, 1.0):
        assert _tied_wires(every, side) == set(range(19))
    base = {id(t) for t in every.ties[:len(touching.ties)]}
    extra = [t for t in every.ties if id(t) not in base]
    assert len(extra) == 2 * (19 - len(held))        # one group per loose wire and end
    own = dict(zip(*[np.concatenate(a) for a in zip(*[(t["tie_node"], t["tie_area"]) for t in touching.ties
                                                     if t["kind"] == "beam"])]))
    shared = {}
    for t in extra:
        for node, a in zip(t["tie_node"], t["tie_area"]):
            shared[node] = shared.get(node, 0.0) + a
    assert set(shared) <= set(own)
    assert np.allclose([shared[n] for n in shared], [own[n] for n in shared], rtol=1e-12)
    assert max(np.linalg.norm(t["tie_arm"], axis=1).max() for t in extra) > 2.0   # across the bundle
    F, _ = separate_forces(every, np.zeros_like(every.mass), 1e-6)
    assert np.abs(F[5]).max() < 1e-9


def test_a_fabric_cwbs_end_bands_bind_by_their_own_key():
    """``fabric_end_tape_binds`` (0 by default) decides a fabric-sleeved CWB's end bands, not
    the tube CWBs' ``end_tape_binds``; null takes ``end_tape_binds``."""
    from harnesspipe.models import hifi, hifi_mesh as hm
    from harnesspipe.stages.hifi import inputs

    def tied(sets):
        inp = inputs(load(overrides={"profile": "quick"}), "cwb19_t2_fabric", sets)
        return len(_tied_wires(hifi.HifiSystem(hm.build_mesh(inp.case, inp.config, inp.resolution), inp), 1.0))

    assert tied({"end_tape_binds": "1"}) < 19
    assert tied({"end_tape_binds": "0", "fabric_end_tape_binds": "1"}) == 19
    cfg = load(overrides={"profile": "quick", "hifi": {"build": {"fabric_end_tape_binds": None}}})
    inp = inputs(cfg, "cwb19_t2_fabric", {"end_tape_binds": "1"})
    assert len(_tied_wires(hifi.HifiSystem(hm.build_mesh(inp.case, inp.config, inp.resolution), inp), 1.0)) == 19
