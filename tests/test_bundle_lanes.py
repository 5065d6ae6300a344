"""The bundle's concurrent force lanes (fe/assembly/lanes.py): the same forces and
histories (elements, wire-wire and node-facet contact, cohesive ties, pins) as the separate
kernels, bit for bit, whatever the beam split; the split that balances the lanes is found
from the calls' times; meshes whose beams and shells share nodes are refused."""
import numpy as np
import pytest

from harnesspipe.config import load
from harnesspipe.fe.assembly.lanes import BeamSplit, check_disjoint, stack_groups
from harnesspipe.fe.solvers.central_difference import DynamicsSettings, integrate
from harnesspipe.models import hifi_mesh as hm
from harnesspipe.models.hifi import HifiSystem
from hifi_reference import history_arrays, restore_histories, save_histories, separate_forces
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
    start = save_histories(s)
    F_ref, n_ref = separate_forces(s, v, dt)
    ref = save_histories(s)
    assert n_ref > 50                                 # the wires touch: the contact is exercised
    assert np.abs(F_ref[2]).max() > 0.0               # with friction
    assert np.abs(F_ref[5]).max() > 0.0               # and loaded ties
    assert np.abs(F_ref[3]).max() > 0.0               # and the pins pressing
    assert any(not np.array_equal(a, b) for a, b in zip(start, ref))   # histories advanced
    n_el = s.wires.conn.shape[0]
    for split in (0, 1, n_el // 3, n_el - 1, n_el):
        restore_histories(s, start)
        F, n = _lanes(s, v, dt, split)
        assert n == n_ref
        assert np.array_equal(F, F_ref), split
        assert all(np.array_equal(a, b) for a, b in zip(history_arrays(s), ref)), split
    restore_histories(s, start)


class _FreshArguments(HifiSystem):
    """A system that builds bundle_forces' argument list anew at every call."""

    def _bundle_forces(self, v, dt, F):
        self._lane_groups = None
        return super()._bundle_forces(v, dt, F)


def test_argument_list_kept_between_searches_gives_the_same_run():
    """The lanes' argument list is made once per contact search: a run through several
    searches is bit-identical to one that rebuilds the list every step.  A stale list
    (the previous search's pairs and history) gives the same forces until a pair outside
    it comes into contact; 30 % of the stroke is past that (checked by not renewing it)."""
    inp = inputs(load(overrides={"profile": "quick"}), "cwb19_t2_open_coarse", {})
    mesh = hm.build_mesh(inp.case, inp.config, inp.resolution)
    runs = []
    for cls in (HifiSystem, _FreshArguments):
        s = cls(mesh, inp)
        res = integrate(s, 0.3 * s.T, DynamicsSettings(safety=inp.explicit["safety"], n_output=4))
        runs.append((s, res))
    (a, ra), (b, rb) = runs
    assert a.searches >= 3
    assert np.array_equal(a.x, b.x) and np.array_equal(a.quat, b.quat)
    assert ra.history.equals(rb.history)


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
    arrays, offsets = stack_groups(groups, spec, shared=("D",))
    (ids, xi, D), off = arrays.values(), offsets["ids"]
    assert ids.tolist() == [3, 4, 7] and off.tolist() == [0, 2, 3]
    assert xi[2].tolist() == [2.0, 2.0]
    D[2] = 0.5                                       # the kernel damages tie 0 of group 1
    assert groups[1]["D"][0] == 0.5 and groups[0]["D"].tolist() == [0.0, 0.0]
    arrays, offsets = stack_groups([], spec)
    (ids, xi, D), off = arrays.values(), offsets["ids"]
    assert ids.shape == (0,) and xi.shape == (0, 2) and off.tolist() == [0]


def test_tie_groups_keep_their_order_across_kinds():
    """Covering (quad), wire (beam) and tape (quad) ties act in that order, as the groups
    were made: tie_order names each group's kind and its place among its kind."""
    from types import SimpleNamespace

    def quad(n):
        return dict(kind="quad", tie_node=np.arange(n), tie_quad=np.zeros(n, int),
                    tie_xi=np.zeros((n, 2)), tie_sign=np.ones(n), tie_off=np.zeros((n, 3)),
                    tie_area=np.ones(n), tie_c=np.zeros(n), quads=np.zeros((2, 4), int),
                    tie_kappa=np.zeros(n),
                    tie_D=np.zeros(n), tie_energy=np.zeros(n))

    beam = dict(kind="beam", tie_node=np.arange(2), tie_seg=np.zeros(2, int), tie_s=np.zeros(2),
                tie_anchor=np.zeros(2, int), tie_arm=np.zeros((2, 3)), tie_axis=np.zeros((2, 3)),
                tie_area=np.ones(2), tie_c=np.zeros(2), tie_kappa=np.zeros(2), tie_D=np.zeros(2),
                tie_energy=np.zeros(2))
    s = SimpleNamespace(ties=[quad(3), beam, quad(5)])
    HifiSystem._stack_ties(s)
    assert s.tie_order.tolist() == [[0, 0], [1, 0], [0, 1]]
    assert s.quad_ties.off.tolist() == [[0, 0], [3, 2], [8, 4]]     # offsets: ties, quads
    assert s.beam_ties.off.tolist() == [0, 2]
    s.quad_ties.tie_D[4] = 1.0                                      # the tape's tie 1
    assert s.ties[2]["tie_D"][1] == 1.0
