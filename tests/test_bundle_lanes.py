"""The bundle's concurrent force lanes (fe/bundle_lanes.py): the same forces and
histories (elements, wire-wire and node-facet contact, cohesive ties, pins) as the separate
kernels, bit for bit, whatever the beam split; the split that balances the lanes is found
from the calls' times; meshes whose beams and shells share nodes are refused."""
import numpy as np
import pytest

from harnesspipe.config import load
from harnesspipe.fe import contact_explicit as ce
from harnesspipe.fe.bundle_lanes import BeamSplit, check_disjoint, stack_groups
from harnesspipe.fe.dynamics import DynamicsSettings, integrate
from harnesspipe.fe.shell_bt import HOURGLASS_COEF, shell_forces
from harnesspipe.models import hifi_mesh as hm
from harnesspipe.models.hifi import HifiSystem
from harnesspipe.stages.hifi import inputs


@pytest.fixture(scope="module")
def pressed_bundle():
    """The quick closed CWB 30 % into its test (5 mm deflection): wires touching, shells
    and beams loaded."""
    inp = inputs(load(overrides={"profile": "quick"}), "cwb19_t2_closed", {})
    s = HifiSystem(hm.build_mesh(inp.case, inp.config, inp.resolution), inp)
    res = integrate(s, 0.3 * s.T, DynamicsSettings(safety=inp.explicit["safety"], n_output=2))
    v = np.random.default_rng(0).normal(scale=1e-2, size=s.mass.shape)   # slip and strain rates
    return s, v, res.dt


def _state(s):
    arrays = [*s.wires.hist, s.sstate, *s.ww_hist]
    arrays += [h for fs in s.facet_sets for h in fs["hist"]]
    arrays += [t[k] for t in s.ties for k in ("tie_kappa", "tie_D", "tie_energy")]
    arrays += [s.wire_pins["hist"], s.pins.force]
    arrays += [g[k] for g in s.pin_groups for k in ("hist_q", "hist")]
    return arrays


def _copy(s):
    return [a.copy() for a in _state(s)]


def _restore(s, saved):
    for a, b in zip(_state(s), saved):
        a[...] = b


def _separate(s, v, dt):
    """The parallel kernels one after the other, as before the lanes."""
    F = np.zeros((6,) + s.mass.shape)
    s.wires.add_forces(s.x, s.quat, F[0])
    shell_forces(s.x, v, s.sconn, s.sthick, s.smat, s.sstate, dt, s.s_el, F[0], HOURGLASS_COEF, -1.0)
    itf = s.inp.interface
    n = ce.beam_beam_contact(s.x, v, s.seg, s.seg_r, s.seg_body, s.ww_pairs, s.k_ww, s.k_ww,
                             itf["mu_s"], itf["mu_k"], itf["d_c"], dt, s.time_scale,
                             s.ww_hist[0], s.ww_hist[1], F[1], F[2])
    for fs in s.facet_sets:
        n += ce.node_facet_contact(s.x, v, fs["nodes"], fs["r"], fs["quads"], fs["t"], fs["sign"],
                                   fs["pairs"], fs["k"], fs["k"], *fs["mu"], dt, s.time_scale,
                                   fs["pen_max"], fs["hist"][0], fs["hist"][1], F[1], F[2])
    for t in s.ties:
        if t["kind"] == "quad":
            ce.cohesive_ties_quad(s.x, t["tie_node"], t["tie_quad"], t["tie_xi"], t["tie_sign"],
                                  t["tie_off"], t["tie_area"], t["quads"], s.K_coh, s.delta0,
                                  itf["delta_f"], itf["alpha_d"], t["tie_kappa"], t["tie_D"],
                                  t["tie_energy"], F[5])
        else:
            ce.cohesive_ties_beam(s.x, s.quat, t["tie_node"], t["tie_seg"], t["tie_s"],
                                  t["tie_anchor"], t["tie_arm"], t["tie_axis"], t["tie_area"],
                                  s.seg, s.K_coh, s.delta0, itf["delta_f"], itf["alpha_d"],
                                  t["tie_kappa"], t["tie_D"], t["tie_energy"], F[5])
    p, w = s.pins, s.wire_pins
    p.force[...] = 0.0
    n += ce.chain_cylinder_contact(s.x, v, s.seg, s.seg_r, w["start"], w["mu"], p.centres, p.axes,
                                   p.radii, p.velocity, w["k"], w["k"], dt, w["hist"], F[3], F[4],
                                   p.force)
    for g in s.pin_groups:
        n += ce.facets_cylinder_contact(s.x, v, g["quads"], g["t"], g["mu"], p.centres, p.axes,
                                        p.radii, g["slack"], p.velocity, g["k"], g["k"], dt,
                                        g["hist_q"], g["hist"], F[3], F[4], p.force)
    return F, n


def _lanes(s, v, dt, split):
    """The system's lanes call at a given beam split."""
    F = np.zeros((6,) + s.mass.shape)
    s.beam_split.current = lambda: split
    s.cyl_force[...] = 0.0
    try:
        n = s._bundle_forces(v, dt, F)
    finally:
        del s.beam_split.current
    return F, n


def test_lanes_equal_the_separate_kernels_bit_for_bit_at_any_split(pressed_bundle):
    s, v, dt = pressed_bundle
    assert len(s.facet_sets) >= 1 and {t["kind"] for t in s.ties} == {"quad", "beam"}
    start = _copy(s)
    F_ref, n_ref = _separate(s, v, dt)
    ref = _copy(s)
    assert n_ref > 50                                 # the wires touch: the contact is exercised
    assert np.abs(F_ref[2]).max() > 0.0               # with friction
    assert np.abs(F_ref[5]).max() > 0.0               # and loaded ties
    assert np.abs(F_ref[3]).max() > 0.0               # and the pins pressing
    assert any(not np.array_equal(a, b) for a, b in zip(start, ref))   # histories advanced
    n_el = s.wires.conn.shape[0]
    for split in (0, 1, n_el // 3, n_el - 1, n_el):
        _restore(s, start)
        F, n = _lanes(s, v, dt, split)
        assert n == n_ref
        assert np.array_equal(F, F_ref), split
        assert all(np.array_equal(a, b) for a, b in zip(_state(s), ref)), split
    _restore(s, start)


def test_split_climb_settles_at_the_balanced_split_despite_delays():
    """Lane 0 costs a + k, lane 1 costs b + (n - k): a call takes max(...), least at
    k* = (n + b - a) / 2, plus the machine's delays (random, some large).  From either
    side the climb reaches k* and stays within two steps of it."""
    rng = np.random.default_rng(1)
    n = 380
    for a, b in ((250.0, 100.0), (0.0, 300.0)):
        k_star = (n + b - a) / 2.0
        split = BeamSplit(n)
        centres = []
        for _ in range(8000):
            k = split.current()
            delay = rng.exponential(20.0) + (1000.0 if rng.random() < 0.02 else 0.0)
            split.record(max(a + k, b + n - k) + delay)
            centres.append(split.centre)
        assert np.all(np.abs(np.array(centres[4000:]) - k_star) <= 2 * split.delta)


def test_beams_and_shells_sharing_a_node_are_refused():
    beams = np.array([[0, 1], [1, 2]])
    check_disjoint(beams, np.array([[3, 4, 5, 6]]))
    with pytest.raises(ValueError, match="shared by beams and shells"):
        check_disjoint(beams, np.array([[2, 4, 5, 6]]))


def test_stacked_groups_share_their_histories_with_the_groups():
    """Stacking keeps each group's rows in order with its offsets; a shared (history)
    array is the same memory in the group and in the stack; no groups: empty arrays of
    the declared shape."""
    spec = {"ids": ((), np.int64), "xi": ((2,), float), "D": ((), float)}
    groups = [dict(ids=np.array([3, 4]), xi=np.ones((2, 2)), D=np.zeros(2)),
              dict(ids=np.array([7]), xi=2 * np.ones((1, 2)), D=np.zeros(1))]
    (ids, xi, D), (off, _, _) = stack_groups(groups, spec, shared=("D",))
    assert ids.tolist() == [3, 4, 7] and off.tolist() == [0, 2, 3]
    assert xi[2].tolist() == [2.0, 2.0]
    D[2] = 0.5                                       # the kernel damages tie 0 of group 1
    assert groups[1]["D"][0] == 0.5 and groups[0]["D"].tolist() == [0.0, 0.0]
    (ids, xi, D), (off, _, _) = stack_groups([], spec)
    assert ids.shape == (0,) and xi.shape == (0, 2) and off.tolist() == [0]


def test_tie_groups_keep_their_order_across_kinds():
    """Covering (quad), wire (beam) and tape (quad) ties act in that order, as the groups
    were made: tie_order names each group's kind and its place among its kind."""
    from types import SimpleNamespace

    def quad(n):
        return dict(kind="quad", tie_node=np.arange(n), tie_quad=np.zeros(n, int),
                    tie_xi=np.zeros((n, 2)), tie_sign=np.ones(n), tie_off=np.zeros((n, 3)),
                    tie_area=np.ones(n), quads=np.zeros((2, 4), int), tie_kappa=np.zeros(n),
                    tie_D=np.zeros(n), tie_energy=np.zeros(n))

    beam = dict(kind="beam", tie_node=np.arange(2), tie_seg=np.zeros(2, int), tie_s=np.zeros(2),
                tie_anchor=np.zeros(2, int), tie_arm=np.zeros((2, 3)), tie_axis=np.zeros((2, 3)),
                tie_area=np.ones(2), tie_kappa=np.zeros(2), tie_D=np.zeros(2),
                tie_energy=np.zeros(2))
    s = SimpleNamespace(ties=[quad(3), beam, quad(5)])
    HifiSystem._stack_ties(s)
    assert s.tie_order.tolist() == [[0, 0], [1, 0], [0, 1]]
    assert s.quad_ties[-1].tolist() == [[0, 0], [3, 2], [8, 4]]     # offsets: ties, quads
    assert s.beam_ties[-1].tolist() == [0, 2]
    s.quad_ties[8][4] = 1.0                                          # tie_D of the tape's tie 1
    assert s.ties[2]["tie_D"][1] == 1.0
