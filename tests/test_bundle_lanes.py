"""The bundle's concurrent force lanes (fe/bundle_lanes.py): the same forces and
histories as the separate kernels, bit for bit, whatever the beam split; the split
that balances the lanes is found from the calls' times; meshes whose beams and shells share nodes are refused."""
import numpy as np
import pytest

from harnesspipe.config import load
from harnesspipe.fe import contact_explicit as ce
from harnesspipe.fe.dynamics import DynamicsSettings, integrate
from harnesspipe.fe.shell_bt import HOURGLASS_COEF, shell_forces
from harnesspipe.models import hifi_mesh as hm
from harnesspipe.fe.bundle_lanes import BeamSplit, check_disjoint, element_and_wire_contact
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
    return [a.copy() for a in (*s.wires.hist, s.sstate, *s.ww_hist)]


def _restore(s, saved):
    for a, b in zip((*s.wires.hist, s.sstate, *s.ww_hist), saved):
        a[...] = b


def _separate(s, v, dt):
    """The parallel kernels one after the other, as before the lanes."""
    F = np.zeros((3,) + s.mass.shape)
    s.wires.add_forces(s.x, s.quat, F[0])
    shell_forces(s.x, v, s.sconn, s.sthick, s.smat, s.sstate, dt, s.s_el, F[0], HOURGLASS_COEF, -1.0)
    itf = s.inp.interface
    n = ce.beam_beam_contact(s.x, v, s.seg, s.seg_r, s.seg_body, s.ww_pairs, s.k_ww, s.k_ww,
                             itf["mu_s"], itf["mu_k"], itf["d_c"], dt, s.time_scale,
                             s.ww_hist[0], s.ww_hist[1], F[1], F[2])
    return F, n


def _lanes(s, v, dt, split):
    F = np.zeros((3,) + s.mass.shape)
    w, itf = s.wires, s.inp.interface
    n = element_and_wire_contact(
        w.X0, w.conn, w.R0, s.x, s.quat, w.xi_g, w.w_g, w.sec_y, w.sec_z, w.sec_area, w.sec_GJ,
        w.sec_id, w.mats, *w.hist, w.f_el, split, v, s.sconn, s.sthick, s.smat, s.sstate, dt,
        s.s_el, HOURGLASS_COEF, s.seg, s.seg_r, s.seg_body, s.ww_pairs, s.k_ww, s.k_ww,
        itf["mu_s"], itf["mu_k"], itf["d_c"], s.time_scale, s.ww_hist[0], s.ww_hist[1],
        F[0], F[1], F[2])
    return F, n


def test_lanes_equal_the_separate_kernels_bit_for_bit_at_any_split(pressed_bundle):
    s, v, dt = pressed_bundle
    start = _state(s)
    F_ref, n_ref = _separate(s, v, dt)
    ref = _state(s)
    assert n_ref > 50                                 # the wires touch: the contact is exercised
    assert np.abs(F_ref[2]).max() > 0.0               # with friction
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
