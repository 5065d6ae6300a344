"""Contact, friction and cohesive kernels of the explicit bundle model (fe/contact/)."""
import math

import numpy as np
import pytest
from scipy.optimize import minimize

from harnesspipe.fe.contact.cohesive_ties import (QuadTieSet, TieLaw, cohesive_tie_dissipation,
                                                   cohesive_ties_quad, tie_set)
from harnesspipe.fe.contact.common import Cylinders, fit_slot_history, new_slot_history
from harnesspipe.fe.contact.facet_pins import (SOFTMIN_TAU, PinFacetSet, facets_cylinder_contact,
                                               facets_cylinder_gaps)
from harnesspipe.fe.contact.node_facet import SOFTMIN_TAU as NF_TAU
from harnesspipe.fe.contact.node_facet import FacetSet, near_node_facet_pairs, node_facet_contact
from harnesspipe.fe.contact.search import (box_pairs, max_drift2, near_segment_pairs, node_aabbs,
                                           quad_aabbs, segment_aabbs, segment_distance)
from harnesspipe.fe.contact.tie_targets import make_ties
from harnesspipe.fe.contact.wire_pins import WireChains, chain_cylinder_contact
from harnesspipe.fe.contact.wire_wire import WW_POINTS, WireContact, beam_beam_contact
from harnesspipe.fe.materials.cohesive import cohesive_dissipated_energy

R_W = 0.65


def _z(n):
    return np.zeros((n, 6))


# ------------------------------------------------------------------------ spatial hash
@pytest.mark.parametrize("same", [True, False])
def test_box_pairs_matches_brute_force(same):
    rng = np.random.default_rng(3)
    lo_a = rng.uniform(-10, 10, (250, 3))
    hi_a = lo_a + rng.uniform(0, 4, (250, 3))
    if same:
        lo_b, hi_b = lo_a, hi_a
    else:
        lo_b = rng.uniform(-10, 10, (180, 3))
        hi_b = lo_b + rng.uniform(0, 2, (180, 3))
    for cell in (0.7, 2.0, 9.0):
        got = box_pairs(lo_a, hi_a, lo_b, hi_b, cell, same)
        ov = np.all((lo_a[:, None] <= hi_b[None]) & (lo_b[None] <= hi_a[:, None]), axis=2)
        if same:
            ov = np.triu(ov, 1)
        ref = set(zip(*np.nonzero(ov)))
        pairs = [tuple(p) for p in got]
        assert len(pairs) == len(set(pairs))          # each pair once
        assert set(pairs) == ref
        if same:
            assert np.all(got[:, 0] < got[:, 1])


def _segment_distance(p0, p1, q0, q1):
    """Closest distance of two segments, by dense sampling of one and projection on the other."""
    s = np.linspace(0.0, 1.0, 401)[:, None]
    pts = p0 + s * (p1 - p0)
    d = q1 - q0
    u = np.clip((pts - q0) @ d / (d @ d), 0.0, 1.0)[:, None]
    return float(np.min(np.linalg.norm(pts - (q0 + u * d), axis=1)))


def test_skin_search_keeps_every_touching_pair():
    """Candidates found with margin m hold every pair that touches after each node moved up
    to m / 2 (the rule of HifiSystem: search anew once max_drift2 > (m / 2)^2)."""
    rng = np.random.default_rng(11)
    n, r, m = 120, 0.5, 0.2
    a = rng.uniform(0.0, 12.0, (n, 3))
    x = np.vstack([a, a + rng.normal(scale=2.0, size=(n, 3))])
    seg = np.c_[np.arange(n), np.arange(n, 2 * n)]
    radii = np.full(n, r)
    lo, hi = segment_aabbs(x, seg, radii, m)
    found = {tuple(p) for p in box_pairs(lo, hi, lo, hi, 2.0, True)}
    step = rng.normal(size=x.shape)
    x1 = x + 0.4999 * m * step / np.linalg.norm(step, axis=1)[:, None]
    assert max_drift2(x1, x) < (0.5 * m) ** 2
    touching = {(i, j) for i in range(n) for j in range(i + 1, n)
                if _segment_distance(x1[i], x1[n + i], x1[j], x1[n + j]) < 2 * r}
    assert len(touching) > 20 and touching <= found
    # narrowed on the true distance (r_a + r_b + m): still every touching pair, fewer pairs
    p = np.array(sorted(found), dtype=np.int64)
    near = {tuple(q) for q in p[near_segment_pairs(x, seg, radii, p, m)]}
    assert touching <= near and len(near) < 0.8 * len(found)


def test_segment_distance_matches_sampling():
    rng = np.random.default_rng(5)
    for case in range(300):
        x = rng.normal(size=(4, 3))
        if case % 3 == 1:                        # parallel, overlapping or not
            x[3] = x[2] + rng.uniform(-2, 2) * (x[1] - x[0])
        if case % 3 == 2:                        # a point segment
            x[1] = x[0]
        # the squared distance is a convex quadratic in (s, u) on the unit square
        fun = lambda su: float(np.sum((x[0] + su[0] * (x[1] - x[0]) - x[2] - su[1] * (x[3] - x[2])) ** 2))
        ref = minimize(fun, [0.5, 0.5], bounds=[(0, 1), (0, 1)], method="L-BFGS-B",
                       options={"ftol": 1e-15, "gtol": 1e-12})
        d = segment_distance(x, 0, 1, 2, 3)
        assert d**2 <= ref.fun + 1e-12 and d == pytest.approx(np.sqrt(ref.fun), abs=1e-6)
        assert d <= _segment_distance(x[0], x[1], x[2], x[3]) + 1e-12


def test_aabb_helpers():
    x = np.array([[0.0, 0, 0], [3, 1, 0], [3, 1, 2], [0, 0, 2]])
    lo, hi = segment_aabbs(x, np.array([[0, 1]]), np.array([0.5]), 0.1)
    assert np.allclose(lo[0], [-0.6, -0.6, -0.6]) and np.allclose(hi[0], [3.6, 1.6, 0.6])
    lo, hi = quad_aabbs(x, np.array([[0, 1, 2, 3]]), np.array([0.2]), 0.0)
    assert np.allclose(lo[0], [-0.2, -0.2, -0.2]) and np.allclose(hi[0], [3.2, 1.2, 2.2])
    lo, hi = node_aabbs(x, np.array([2]), np.array([1.0]), 0.5)
    assert np.allclose(hi[0] - lo[0], 3.0)


# ------------------------------------------------------------------------- wire-wire
def _bb(x, v, seg, pairs, body, hp, hf, k_n=100.0, k_t=0.0, dt=1e-5, ts=1.0, mu=(0.4, 0.1, 2.0)):
    fn = _z(len(x))
    ft = _z(len(x))
    wc = WireContact(seg, np.full(len(seg), R_W), body, pairs, k_n, k_t, *mu, hp, hf)
    n = beam_beam_contact(x, v, wc, dt, ts, fn, ft)
    return n, fn, ft


def test_crossed_wires_static_load_and_no_tunnelling():
    k_n, m, F = 100.0, 1e-6, 2.0
    seg = np.array([[0, 1], [2, 3]])
    body = np.array([0, 1])
    pairs = np.array([[0, 1]])
    omega = math.sqrt(2 * k_n / m)
    dt = 0.2 / omega
    # (1) B pressed on A with F (F/2 per node), damped explicit loop -> penetration F/k
    x = np.array([[-5.0, 0, 0], [5, 0, 0], [0, -5, 2 * R_W + 0.1], [0, 5, 2 * R_W + 0.1]])
    v = _z(4)
    hp, hf = new_slot_history(2, 8, WW_POINTS)
    c = 0.5 * 2 * math.sqrt(k_n * m)
    for _ in range(3000):
        x[2:] += dt * v[2:, :3]
        _, fn, ft = _bb(x, v, seg, pairs, body, hp, hf, k_n=k_n, dt=dt)
        a = (fn[2:, :3] - c * v[2:, :3]) / m
        a[:, 2] -= F / 2 / m
        v[2:, :3] += dt * a
    pen = 2 * R_W - (x[2, 2] - x[0, 2])
    assert pen == pytest.approx(F / k_n, rel=1e-3)
    assert fn[:2, 2].sum() == pytest.approx(-F, rel=1e-3)       # reaction on A = load
    assert fn[2:, 2].sum() == pytest.approx(F, rel=1e-3)
    assert np.allclose(fn[:, :3].sum(axis=0), 0.0, atol=1e-12)
    # (2) B thrown at A at 0.1 mm per step (< element size, < r_a + r_b): it bounces
    x = np.array([[-5.0, 0, 0], [5, 0, 0], [0.3, -5, 2 * R_W + 0.5], [0.3, 5, 2 * R_W + 0.5]])
    v = _z(4)
    v0 = 0.1 / dt
    v[2:, 2] = -v0
    hp, hf = new_slot_history(2, 8, WW_POINTS)
    zmin = np.inf
    for _ in range(400):
        x[2:] += dt * v[2:, :3]
        zmin = min(zmin, x[2, 2])
        _, fn, _ = _bb(x, v, seg, pairs, body, hp, hf, k_n=k_n, dt=dt)
        v[2:, :3] += dt * fn[2:, :3] / m
    pen_max = v0 * math.sqrt(2 * m / k_n)    # energy balance (mass 2m on k_n), < 2 r
    assert pen_max < 2 * R_W
    assert 2 * R_W - zmin <= 1.05 * pen_max
    assert v[2, 2] > 0.9 * v0 and x[2, 2] > 2 * R_W        # bounced back, never crossed


def test_parallel_wires_equal_split_no_jitter():
    pen = 0.05
    k_n = 100.0
    x = np.array([[0.0, 0, 0], [8, 0, 0], [0, 0, 2 * R_W - pen], [8, 0, 2 * R_W - pen]])
    seg = np.array([[0, 1], [2, 3]])
    body = np.array([0, 1])
    hp, hf = new_slot_history(2, 8, WW_POINTS)
    ref = None
    rng = np.random.default_rng(0)
    for trial in range(20):
        xp = x.copy()
        if trial:
            xp[2:, :2] += rng.uniform(-1e-6, 1e-6, (2, 2))
        n, fn, _ = _bb(xp, _z(4), seg, np.array([[0, 1]]), body, hp, hf, k_n=k_n)
        assert n == 1
        if ref is None:
            ref = fn.copy()
            assert fn[2, 2] == pytest.approx(fn[3, 2], rel=1e-12)        # equal split
            assert fn[2:, 2].sum() == pytest.approx(k_n * pen, rel=1e-12)
        # the overlap's force (_overlap_forces): at exact alignment the isolated pair's
        # weight has its kink (sliding either way shortens the overlap), so its sign follows
        # the jitter; it is bounded by U_par / w / (L_a + L_b) = k_n pen^2 / 16 (x the lever
        # of b's ends over L_a, 2 R / 8, when a turns) and balanced in the pair
        kink = k_n * pen**2 / 16.0 * (1.0 + 2 * R_W / 8.0)
        assert np.allclose(fn[:, :3], ref[:, :3], atol=2.0 * kink + 1e-6 * k_n * pen)   # no jitter beyond it
        assert np.allclose(fn[:, :3].sum(axis=0), ref[:, :3].sum(axis=0), atol=1e-9)
    # chains of 4 segments, aligned and staggered by half an element: every node-to-segment
    # line carries k_n pen, the total is k_n pen x (overlap length / element length)
    for shift in (0.0, 4.0):
        xa = np.stack([np.arange(5) * 8.0, np.zeros(5), np.zeros(5)], axis=1)
        xb = xa + [shift, 0, 2 * R_W - pen]
        xx = np.vstack([xa, xb])
        sg = np.array([[i, i + 1] for i in range(4)] + [[5 + i, 6 + i] for i in range(4)])
        bd = np.array([0] * 4 + [1] * 4)
        lo, hi = segment_aabbs(xx, sg, np.full(8, R_W), 0.1)
        pairs = box_pairs(lo, hi, lo, hi, 8.0, True)
        hp, hf = new_slot_history(8, 8, WW_POINTS)
        _, fn, _ = _bb(xx, _z(10), sg, pairs, bd, hp, hf, k_n=k_n)
        overlap = 32.0 - shift
        assert fn[5:, 2].sum() == pytest.approx(k_n * pen * overlap / 8.0, rel=1e-12)
        if shift == 0.0:
            assert np.allclose(fn[6:9, 2], k_n * pen) and np.allclose(fn[[5, 9], 2], k_n * pen / 2)


def _ww_loop_work(path, n=4000):
    """Work of the wire-wire contact forces (trapezoidal) on two segments whose four nodes
    follow ``path(theta)`` around theta in [0, 2 pi], and the sum of its steps' magnitudes."""
    W = scale = 0.0
    x0 = f0 = None
    for th in np.linspace(0.0, 2 * np.pi, n + 1):
        x = path(th)
        hp, hf = new_slot_history(2, 8, WW_POINTS)
        f = _bb(x, _z(4), np.array([[0, 1], [2, 3]]), np.array([[0, 1]]), np.array([0, 1]),
                hp, hf)[1][:, :3]
        if f0 is not None:
            dW = 0.5 * np.sum((f0 + f) * (x - x0))
            W += dW
            scale += abs(dW)
        x0, f0 = x, f
    return W, scale


def test_wire_wire_energy_continuous_between_crossing_and_parallel_rules():
    """A penetrating segment turning (in a plane parallel to its partner's) through the
    angles where the crossing rule hands over to the parallel rule, while its penetration
    varies: the work of the contact forces around the closed path is that of a potential.
    (A sharp switch at one angle returned 49 % of the path's work as created energy.)"""
    def path(th, phi_mid, dphi):
        phi = math.radians(phi_mid + dphi * math.cos(th))
        pen = 0.05 + 0.03 * math.sin(th)
        d = 4.0 * np.array([math.cos(phi), math.sin(phi), 0.0])
        cb = np.array([5.5, 0.3, 2 * R_W - pen])
        return np.array([[0, 0, 0], [8.0, 0, 0], cb - d, cb + d])

    for phi_mid, dphi, tol in ((8.5, 5.0, 5e-3),     # |cos| 0.973..0.9986: through the blend
                               (20.0, 5.0, 1e-12)):  # crossing rule only: exact potential
        W, scale = _ww_loop_work(lambda th: path(th, phi_mid, dphi))
        assert scale > 0.1
        assert abs(W) < tol * scale


def test_parallel_wires_sliding_past_each_other_make_no_energy():
    """Nearly parallel segments in partial overlap, the partner sliding along (the overlap
    growing and shrinking) while its ends' penetrations vary out of phase: the work of the
    contact forces around the closed path is that of a potential.  The parallel rule's
    weight is the overlap length; without the force of its gradient (the pair's energy
    changing with the overlap at a fixed penetration) a wire sliding in a squeezed pack
    took energy from nowhere (bench/RESULTS.md, "The slit tube closed onto the bundle")."""
    def path(th):
        xo = 4.0 + 3.0 * math.cos(th)                       # overlap 1 .. 7 of 8 mm
        pen0, pen1 = 0.05 + 0.02 * math.sin(th), 0.03       # |cos| > 0.9999: parallel rule
        return np.array([[0, 0, 0], [8.0, 0, 0], [xo, 0.2, 2 * R_W - pen0],
                         [xo + 8.0, 0.2, 2 * R_W - pen1]])

    W, scale = _ww_loop_work(path)
    assert scale > 0.01
    assert abs(W) < 1e-5 * scale


def test_wire_wire_friction_eq6_history_across_rehash():
    """Parallel wires sliding axially: friction = mu(rate) N, mu from eq. 6 in physical time."""
    pen, k_n, k_t = 0.05, 100.0, 200.0
    N = k_n * pen
    dt = 1e-4
    for ts, V in ((1.0, 0.5), (120.0, 0.5 * 120)):
        x = np.array([[0.0, 0, 0], [8, 0, 0], [0, 0, 2 * R_W - pen], [8, 0, 2 * R_W - pen]])
        v = _z(4)
        v[2:, 0] = V
        seg = np.array([[0, 1], [2, 3]])
        hp, hf = new_slot_history(2, 4, WW_POINTS)
        for step in range(300):
            # (positions frozen: the slip comes from the velocities, the overlap stays 8 mm)
            pairs = np.array([[0, 1]]) if step % 2 else np.array([[1, 0], [0, 0]])
            _, fn, ft = _bb(x, v, seg, pairs, np.array([0, 1]), hp, hf, k_n=k_n, k_t=k_t,
                            dt=dt, ts=ts)
        mu = 0.1 + 0.3 * math.exp(-2.0 * V / ts)   # physical slip rate V / ts
        assert ft[2:, 0].sum() == pytest.approx(-mu * N, rel=1e-9)    # opposes B's motion
        assert ft[:2, 0].sum() == pytest.approx(mu * N, rel=1e-9)
        assert np.allclose(ft[:, 1:3], 0.0)
    # (the two runs differ 120x in simulated speed but share the physical rate, hence mu)


def test_slot_history_grows_to_every_candidate_partner():
    """One wire crossed by ten others: with 8 slots two touching pairs keep no friction
    history; fit_slot_history makes room for all ten (and keeps what is stored)."""
    n = 10
    xs = np.linspace(-4.5, 4.5, n)
    x = [[-6.0, 0, 0], [6.0, 0, 0]]
    for xc in xs:
        x += [[xc, -3.0, 2 * R_W - 0.02], [xc, 3.0, 2 * R_W - 0.02]]
    x = np.array(x)
    seg = np.array([[2 * k, 2 * k + 1] for k in range(n + 1)], dtype=np.int64)
    pairs = np.array([[0, k] for k in range(1, n + 1)], dtype=np.int64)
    body = np.arange(n + 1)
    v = _z(len(x))
    v[2:, 0] = 1.0                                  # the crossing wires slide along the first
    kept = {}
    for fit in (False, True):
        hist = new_slot_history(n + 1, 8, WW_POINTS)
        hist[0][0, 0] = 3                           # something stored before the fit
        if fit:
            hist = fit_slot_history(hist, pairs.min(axis=1))
            assert hist[0][0, 0] == 3 and hist[0].shape[1] == n
        for _ in range(2):
            _, fn, ft = _bb(x, v, seg, pairs, body, *hist, k_t=50.0)
        kept[fit] = int(np.sum(hist[0][0] >= 0))
    assert kept == {False: 8, True: n}


# ---------------------------------------------------------------- node on rigid cylinder
def _tube(n_c, n_x, h, a, phase=0.0):
    """Cylindrical quad mesh of radius ``a`` along x: n_c x n_x quads of axial length h,
    node lines at x = -n_x h / 2 + i h, first node line at the angle ``phase`` from +y."""
    th = 2 * np.pi * np.arange(n_c) / n_c + phase
    xs = (np.arange(n_x + 1) - n_x / 2) * h
    x = np.array([[xi, a * np.cos(tt), a * np.sin(tt)] for xi in xs for tt in th])
    quads = np.array([[i * n_c + j, (i + 1) * n_c + j, (i + 1) * n_c + (j + 1) % n_c,
                       i * n_c + (j + 1) % n_c] for i in range(n_x) for j in range(n_c)])
    return x, quads


def _pin_hist(maxs=4):
    return np.full((1, maxs), -1, dtype=np.int64), np.zeros((1, maxs, 3))


def _pin_facets(x, v, quads, t, hist, c, k_n=100.0, k_t=0.0, mu=0.3, dt=1e-3, Rc=2.5,
                slack=0.0):
    fn, ft, fc = _z(len(x)), _z(len(x)), np.zeros((1, 3))
    fset = PinFacetSet(quads, np.full(len(quads), t), mu, np.array([slack]), k_n, k_t, *hist)
    cyl = Cylinders(np.array([c], float), np.array([[0.0, 0, 1]]), np.array([Rc]), np.zeros((1, 3)))
    n = facets_cylinder_contact(x, v, fset, cyl, dt, fn, ft, fc)
    return n, fn, ft, fc


def _quads_along_pin(n_q, y, half=1.0, pitch=3.0):
    """``n_q`` separate unit quads in the xz plane at height y, one behind the other along
    the pin's axis (z), with gaps between them: ``n_q`` patches on one pin."""
    x, quads = [], []
    for i in range(n_q):
        z = (i - (n_q - 1) / 2) * pitch
        quads.append(len(x) + np.arange(4))
        x += [[-half, y, z - half], [half, y, z - half], [half, y, z + half], [-half, y, z + half]]
    return np.array(x), np.array(quads)


def test_pin_slack_shifts_the_contact_by_its_allowance():
    """A pin slack s (the strain-free start of a pin resting in the soft minimum) moves the
    contact's onset by s: force k (pen - s) while pen > s, none once s > pen."""
    Rc, t, pen, k_n = 2.5, 0.27, 0.05, 400.0
    x, quads = _quads_along_pin(1, Rc + t / 2 - pen)
    for slack, force in ((0.0, k_n * pen), (0.02, k_n * (pen - 0.02)), (0.06, 0.0), (0.5, 0.0)):
        n, fn, _, fc = _pin_facets(x, _z(len(x)), quads, t, _pin_hist(), [0.0, 0.0, 0.0],
                                   k_n=k_n, Rc=Rc, slack=slack)
        assert n == (1 if force > 0.0 else 0)
        assert fn[:, 1].sum() == pytest.approx(force, abs=1e-12)
        assert np.allclose(fc[0], -fn[:, :3].sum(axis=0))


def test_patches_beyond_the_history_slots_keep_their_normal_force():
    """Five separate quads on one pin with four history slots: all five patches push
    (k pen each), the first four also carry friction (stick k_t dg against a slide along
    the pin), the fifth is frictionless -- it has no slot to remember its force."""
    Rc, t, pen, k_n, k_t, dt, V = 2.5, 0.27, 0.04, 400.0, 300.0, 1e-3, 1.0
    x, quads = _quads_along_pin(5, Rc + t / 2 - pen)
    v = _z(len(x))
    v[:, 2] = V
    hist = _pin_hist(maxs=4)
    n, fn, ft, fc = _pin_facets(x, v, quads, t, hist, [0.0, 0.0, 0.0], k_n=k_n, k_t=k_t,
                                mu=0.5, dt=dt, Rc=Rc)
    assert n == 5
    for q in quads:
        assert fn[q, 1].sum() == pytest.approx(k_n * pen, rel=1e-12)
    for q in quads[:4]:
        assert ft[q, 2].sum() == pytest.approx(-k_t * V * dt, rel=1e-12)
    assert not ft[quads[4]].any()
    assert sorted(hist[0][0]) == [0, 1, 2, 3]
    assert np.allclose(fc[0], -(fn + ft)[:, :3].sum(axis=0))


def _soft_gap(x, quads, t, c, Rc):
    """The patch gap by its definition: every quad's smallest distance to the pin's axis (z)
    on a fine (xi, eta) grid, less R + t/2, then their soft minimum (LogSumExp)."""
    u = np.linspace(-1.0, 1.0, 201)
    XI, ETA = np.meshgrid(u, u, indexing="ij")
    N = 0.25 * np.stack([(1 - XI) * (1 - ETA), (1 + XI) * (1 - ETA), (1 + XI) * (1 + ETA),
                         (1 - XI) * (1 + ETA)], axis=-1)
    g = np.array([np.min(np.hypot(*(N @ x[q][:, :2] - c[:2]).transpose(2, 0, 1))) for q in quads])
    g -= Rc + t / 2
    return g.min() - SOFTMIN_TAU * np.log(np.sum(np.exp(-(g - g.min()) / SOFTMIN_TAU)))


@pytest.mark.parametrize("phase", [0.0, np.pi / 16])
def test_tube_on_a_pin_is_held_wherever_its_node_lines_fall(phase):
    """A tube (radius 6.2, 16 x 3.2 mm quads, wall 1.7) across a 5 mm pin: the pin meets the
    faceted mid-surface where it comes closest, so the force does not depend on where the
    pin falls between the node lines (nodes alone: the pin would sink 0.6 mm between them),
    and the gap is that of the facets -- a node line at the bottom (phase 0) or the
    chord's middle 6.2 (1 - cos(pi / 16)) higher (phase pi / 16) -- softened by the soft
    minimum over the quads near the closest point (a few tau).  The force is k (-G) with G
    the soft minimum by its definition; reaction = -sum of nodal forces."""
    a, t, Rc, pen, k_n = 6.2, 1.7, 2.5, 0.01, 100.0
    x, quads = _tube(16, 8, 3.2, a, phase)
    bottom = a * math.cos(math.pi / 16) if phase else a
    for xc in (0.0, 0.4, 0.8, 1.6):
        c = np.array([xc, -bottom - t / 2 - Rc + pen, 0.0])
        n, fn, _, fc = _pin_facets(x, _z(len(x)), quads, t, _pin_hist(), c, k_n=k_n)
        assert n == 1
        G = _soft_gap(x, quads, t, c, Rc)
        assert fn[:, 1].sum() == pytest.approx(-k_n * G, rel=2e-3)  # grid
        assert facets_cylinder_gaps(x, quads, np.full(len(quads), t), c[None, :],
                                    np.array([[0.0, 0, 1]]), np.array([Rc]))[0] == pytest.approx(G, rel=2e-3)
        assert k_n * pen < fn[:, 1].sum() < k_n * (pen + 3.0 * SOFTMIN_TAU)
        # the soft minimum spreads the contact over ~sqrt(2 a tau) = 0.35 mm along the tube:
        # a small axial part where the pin is off a node ring, none across (z)
        assert abs(fn[:, 0].sum()) < 0.02 * fn[:, 1].sum() and abs(fn[:, 2].sum()) < 1e-9
        assert np.allclose(fc[0], -fn[:, :3].sum(axis=0))
    # midway between node lines no node reaches the pin: node contact would see nothing
    assert np.min(np.hypot(x[:, 0] - 1.6, x[:, 1] - c[1]) - Rc - t / 2) > 0.0


def test_each_lip_of_an_open_tube_meets_the_pin():
    """An open tube with its cut under the pin (seam nodes duplicated): the two lips are two
    patches, each held at its own free edge with k pen, split evenly -- not one lip alone.
    (A closed tube there: one patch, k (pen + tau ln 2); a slit under a pin is twice as stiff
    a contact, one reason the hi-fi mesh puts the slit on the side.)"""
    a, t, Rc, pen, k_n = 6.2, 1.7, 2.5, 0.01, 100.0
    n_c, j_b = 16, 4
    x, quads = _tube(n_c, 8, 3.2, a, np.pi / 2)        # node line j_b = 4 at the bottom
    seam = np.arange(j_b, len(x), n_c)
    twin = len(x) + np.arange(seam.size)
    x = np.vstack([x, x[seam]])                         # the cut: seam nodes duplicated
    far = np.any(quads % n_c == j_b + 1, axis=1)        # the quads on one side of the seam
    for old, new in zip(seam, twin):
        rows = far & (quads == old).any(axis=1)
        quads[rows] = np.where(quads[rows] == old, new, quads[rows])
    c = [1.0, -a - t / 2 - Rc + pen, 0.0]
    n, fn, _, fc = _pin_facets(x, _z(len(x)), quads, t, _pin_hist(), c, k_n=k_n)
    assert n == 2
    assert fn[:, 1].sum() == pytest.approx(2 * k_n * pen, rel=1e-6)   # one quad per lip at its edge
    assert fn[seam, 1].sum() == pytest.approx(fn[twin, 1].sum(), rel=1e-9)


def test_pin_facet_forces_are_the_gradient_of_the_penalty_energy():
    """A dented tube pressed onto a pin at several places along and across it: the nodal
    forces equal -d/dx of 1/2 k min(G, 0)^2 (G the soft-minimum gap, facets_cylinder_gaps)
    by central differences -- the contact is a potential, also where the closest point
    passes node lines and where two local minima (the dent's sides) share the force."""
    a, t, Rc, k_n, h = 6.2, 1.7, 2.5, 500.0, 1e-6
    x0, quads = _tube(12, 10, 3.0, a, 0.1)
    x0[:, 1] -= 0.15 * np.exp(-(x0[:, 0] / 2.0) ** 2) * (x0[:, 1] < 0)    # a dent at x = 0
    thick = np.full(len(quads), t)
    axis = np.array([[0.0, 0, 1]])

    def energy(x, c):
        G = facets_cylinder_gaps(x, quads, thick, c[None, :], axis, np.array([Rc]))[0]
        return 0.5 * k_n * min(G, 0.0) ** 2
    for cx, cz in ((0.0, 0.0), (0.9, 0.3), (1.5, -0.7), (2.2, 0.0)):
        c = np.array([cx, -a - t / 2 - Rc + 0.2, cz])
        _, fn, _, _ = _pin_facets(x0, _z(len(x0)), quads, t, _pin_hist(), c, k_n=k_n)
        loaded = np.flatnonzero(np.abs(fn[:, :3]).sum(axis=1) > 0.0)
        assert loaded.size >= 2
        for node in loaded:
            for k in range(3):
                xp, xm = x0.copy(), x0.copy()
                xp[node, k] += h
                xm[node, k] -= h
                dE = (energy(xp, c) - energy(xm, c)) / (2 * h)
                assert fn[node, k] == pytest.approx(-dE, abs=1e-5 * np.abs(fn).max())


def test_facets_on_a_pin_stick_slip_energy_and_reaction():
    """A flat plate (2 x 2 quads) pressed onto a pin and slid along the pin's axis (gap
    unchanged): elastic stick k_t dg, then slip at mu N against the motion; dissipation
    mu N (distance - mu N / k_t); history cleared when the plate leaves the pin.  The pin
    lies under the plate's middle node line, which all four quads reach: the soft minimum
    adds tau ln 4 to the penetration."""
    Rc, t, pen, k_n, k_t, mu, dt, V = 2.5, 0.27, 0.02, 500.0, 300.0, 0.3, 1e-3, 1.0
    N = k_n * (pen + SOFTMIN_TAU * math.log(4))
    xp, quads = _plate(2, 4.0)
    xp = xp[:, [0, 2, 1]]                              # plate in the xz plane
    xp[:, 1] = Rc + t / 2 - pen
    hist = _pin_hist()
    v = _z(len(xp))
    v[:, 2] = V
    W = 0.0
    dist = 0.0
    f_prev = 0.0
    x = xp.copy()
    for step in range(200):
        x[:, 2] += V * dt
        dist += V * dt
        n, fn, ft, fc = _pin_facets(x, v, quads, t, hist, [0.0, 0.0, 0.0], k_n=k_n, k_t=k_t,
                                    mu=mu, dt=dt)
        assert n == 1
        f_now = ft[:, 2].sum()
        W += 0.5 * (f_prev + f_now) * V * dt
        f_prev = f_now
        if step == 0:
            assert f_now == pytest.approx(-k_t * V * dt)
    assert f_now == pytest.approx(-mu * N)
    assert fn[:, 1].sum() == pytest.approx(N)
    assert np.allclose(fc[0], -(fn + ft)[:, :3].sum(axis=0))
    stored = (mu * N) ** 2 / (2 * k_t)
    assert -W - stored == pytest.approx(mu * N * (dist - mu * N / k_t), rel=2e-3)
    x[:, 1] += 1.0
    n, fn, ft, fc = _pin_facets(x, v, quads, t, hist, [0.0, 0.0, 0.0], k_n=k_n, k_t=k_t, mu=mu)
    assert n == 0 and np.all(hist[0] == -1) and not hist[1].any() and not fn.any() and not fc.any()


# -------------------------------------------------------------------- node on shell facet
def _plate(n_el=2, size=4.0, z=0.0):
    """Flat n_el x n_el quad mesh in the xy plane, normals +z."""
    g = np.linspace(-size / 2, size / 2, n_el + 1)
    X, Y = np.meshgrid(g, g, indexing="ij")
    x = np.stack([X.ravel(), Y.ravel(), np.full(X.size, z)], axis=1)
    idx = np.arange(X.size).reshape(n_el + 1, n_el + 1)
    quads = np.array([[idx[i, j], idx[i + 1, j], idx[i + 1, j + 1], idx[i, j + 1]]
                      for i in range(n_el) for j in range(n_el)])
    return x, quads


def _facet(x, v, nodes, quads, t, sign, pairs, hp, hf, k_n=100.0, k_t=0.0, dt=1e-3, ts=1.0,
           mu=(0.4, 0.1, 2.0), pen_max=1.0, r=R_W):
    fn, ft = _z(len(x)), _z(len(x))
    fset = FacetSet(nodes, np.full(len(nodes), r), quads, np.full(len(quads), t),
                    np.full(len(quads), sign), pairs, k_n, k_t, *mu, pen_max, hp, hf)
    n = node_facet_contact(x, v, fset, dt, ts, fn, ft)
    return n, fn, ft


def _chain(xs, y):
    """One wire along x through the points (xs, y), nodes 0..n-1, segments consecutive."""
    x = np.c_[xs, np.broadcast_to(y, xs.shape), np.zeros(len(xs))]
    seg = np.c_[np.arange(len(xs) - 1), np.arange(1, len(xs))].astype(np.int64)
    return x, seg


def _pin(x, v, seg, hist, k_n=500.0, k_t=0.0, mu=0.3, dt=1e-3, Rc=2.5):
    fn, ft, fc = _z(len(x)), _z(len(x)), np.zeros((1, 3))
    chains = WireChains(seg, np.full(len(seg), R_W), np.array([0, len(seg)]), mu, k_n, k_t, hist)
    cyl = Cylinders(np.zeros((1, 3)), np.array([[0.0, 0, 1]]), np.array([Rc]), np.zeros((1, 3)))
    n = chain_cylinder_contact(x, v, chains, cyl, dt, fn, ft, fc)
    return n, fn, ft, fc


def test_chains_on_a_pin_act_independently_and_the_pin_gets_their_sum():
    """Five wires (two tasks of chains: 3 + 2) pressed onto one roller by different amounts
    and sliding at different speeds: each wire's forces and friction history are those it
    gets alone, and the force on the roller is minus the sum over the wires."""
    Rc, k_n, k_t, mu, dt = 2.5, 500.0, 300.0, 0.3, 1e-3
    xs = np.array([-16.5, -6.5, 3.5, 13.5])
    pens = np.array([0.01, 0.02, -0.05, 0.03, 0.015])       # the third one is clear
    wires = [_chain(xs, Rc + R_W - pen) for pen in pens]
    for i, (x, _) in enumerate(wires):
        x[:, 2] = 3.0 * i                                    # along the roller's axis
    x = np.vstack([w[0] for w in wires])
    seg = np.vstack([w[1] + 4 * i for i, w in enumerate(wires)])
    v = _z(len(x))
    v[:, 0] = np.repeat(0.1 * np.arange(1, 6), 4)
    start = np.arange(0, len(seg) + 1, 3)
    cyl = Cylinders(np.zeros((1, 3)), np.array([[0.0, 0, 1]]), np.array([Rc]), np.zeros((1, 3)))
    hist, fn, ft, fc = np.zeros((5, 1, 3)), _z(len(x)), _z(len(x)), np.zeros((1, 3))
    for _ in range(3):                                       # history carried over steps
        fn[:], ft[:], fc[:] = 0.0, 0.0, 0.0
        n = chain_cylinder_contact(x, v, WireChains(seg, np.full(len(seg), R_W), start, mu, k_n,
                                                    k_t, hist), cyl, dt, fn, ft, fc)
    assert n == 4
    for i, (xi, si) in enumerate(wires):
        h1 = np.zeros((1, 1, 3))
        for _ in range(3):
            fni, fti = _z(4), _z(4)
            chain_cylinder_contact(xi, v[4 * i:4 * i + 4],
                                   WireChains(si, np.full(3, R_W), np.array([0, 3]), mu, k_n, k_t,
                                              h1), cyl, dt, fni, fti, np.zeros((1, 3)))
        np.testing.assert_array_equal(fn[4 * i:4 * i + 4], fni)
        np.testing.assert_array_equal(ft[4 * i:4 * i + 4], fti)
        np.testing.assert_array_equal(hist[i], h1[0])
        assert (fni[:, 1].sum() > 0.0) == (pens[i] > 0.0)
    np.testing.assert_allclose(fc[0], -(fn + ft)[:, :3].sum(axis=0), rtol=1e-12, atol=1e-12)


def test_wire_resting_on_a_roller_between_its_nodes_is_held():
    """A wire of 10 mm elements across a 5 mm roller, nodes 3.5 and 6.5 mm from its axis: the
    nodes alone never touch it (the wire would fall through); the chain contact carries the
    load at the closest point, shared by the segment's nodes by (1 - s, s)."""
    Rc, pen, k_n = 2.5, 0.02, 500.0
    x, seg = _chain(np.array([-16.5, -6.5, 3.5, 13.5]), Rc + R_W - pen)
    hist = np.zeros((1, 1, 3))
    n, fn, _, fc = _pin(x, _z(4), seg, hist, k_n=k_n)
    assert n == 1
    assert fn[:, 1].sum() == pytest.approx(k_n * pen, rel=1e-9)
    assert fn[1, 1] == pytest.approx(0.35 * k_n * pen) and fn[2, 1] == pytest.approx(0.65 * k_n * pen)
    assert np.allclose(fc[0], -fn[:, :3].sum(axis=0))
    assert np.all(np.hypot(x[:, 0], x[:, 1]) > Rc + R_W)      # no node reaches the roller


def test_bent_wire_sliding_over_a_roller_makes_no_energy():
    """A kinked wire pressed onto a roller and moved round a closed loop that encloses area
    (slid 6 mm across the roller and back while pressed down and let up by 0.3 mm, out of
    phase): the normal forces do no net work round it (the chain's distance to the axis is a
    potential), while their work on the way is of order one.  A force that depended on the
    path, not the position alone, would do net work round such a loop (an out-and-back path
    could not tell)."""
    Rc, k_n, n = 2.5, 500.0, 6000
    xs = np.array([-8.0, 0.0, 8.0, 16.0])
    y = Rc + R_W + np.array([0.6, -0.2, 0.1, 0.8])       # bent: the kink sags onto the roller
    hist = np.zeros((1, 1, 3))
    theta = np.linspace(0.0, 2.0 * np.pi, n + 1)
    ox, oy = -3.0 + 3.0 * np.cos(theta), -0.3 * np.sin(theta)
    W = scale = 0.0
    f_prev = None
    for i in range(n + 1):
        x, seg = _chain(xs + ox[i], y + oy[i])
        _, fn, _, _ = _pin(x, _z(4), seg, hist, k_n=k_n)
        f = fn[:, :2].sum(axis=0)                     # every node moves by the same (dx, dy)
        if f_prev is not None:
            dW = 0.5 * (f + f_prev) @ np.array([ox[i] - ox[i - 1], oy[i] - oy[i - 1]])
            W += dW
            scale += abs(dW)
        f_prev = f
    assert scale > 1.0                                 # N mm: the contact stores and returns energy
    assert abs(W) < 1e-4 * scale


def test_wire_dragged_over_a_roller_slips_at_mu_n():
    Rc, pen, k_n, k_t, mu, dt, V = 2.5, 0.02, 500.0, 300.0, 0.3, 1e-3, 1.0
    hist = np.zeros((1, 1, 3))
    v = _z(4)
    v[:, 0] = V
    for step in range(100):
        x, seg = _chain(np.array([-16.5, -6.5, 3.5, 13.5]) + V * dt * step, Rc + R_W - pen)
        _, fn, ft, fc = _pin(x, v, seg, hist, k_n=k_n, k_t=k_t, mu=mu, dt=dt)
        if step == 0:                                  # stick: k_t times the slip
            assert ft[:, 0].sum() == pytest.approx(-k_t * V * dt)
    assert ft[:, 0].sum() == pytest.approx(-mu * k_n * pen, rel=1e-9)
    assert np.allclose(fc[0], -(fn + ft)[:, :3].sum(axis=0))


def _soft_min(h):
    """The node-facet kernel's soft minimum of a node's facet distances."""
    h = np.asarray(h, dtype=float)
    return h.min() - NF_TAU * np.log(np.exp(-(h - h.min()) / NF_TAU).sum())


def test_node_on_facet_normal_edge_partition_and_one_sided():
    """Over a facet's interior the penalty acts once, along the normal; over a seam of the
    flat plate (2 facets) or its corner (4) the soft minimum deepens the gap by tau ln 2 or
    tau ln 4 (a node is never counted twice); the facets' reactions balance the node's force
    and act along the lines to their closest points (no moment about the node)."""
    xp, quads = _plate(2, 4.0)
    t, pen, k_n = 0.27, 0.03, 100.0
    all_pairs = np.array([[0, q] for q in range(4)])
    for pos, m in (([0.7, 0.6], 1), ([0.0, 0.6], 2), ([0.0, 0.0], 4)):   # interior, seam, corner
        x = np.vstack([xp, [pos + [R_W + t / 2 - pen]]])
        hp, hf = new_slot_history(1, 8)
        n, fn, _ = _facet(x, _z(len(x)), np.array([len(xp)]), quads, t, 1.0, all_pairs, hp, hf)
        assert n == 1
        assert fn[-1, :3] == pytest.approx([0, 0, k_n * (pen + NF_TAU * math.log(m))], rel=1e-9,
                                           abs=1e-12)
        assert fn[:-1, :3].sum(0) == pytest.approx(-fn[-1, :3], abs=1e-12)
        assert np.cross(x[:-1] - x[-1], fn[:-1, :3]).sum(0) == pytest.approx(np.zeros(3), abs=1e-12)
    # beside a seam: the gap is the soft minimum of the distances to the facets' closest points
    pos = np.array([0.004, -0.97])
    x = np.vstack([xp, [[*pos, R_W + t / 2 - pen]]])
    hp, hf = new_slot_history(1, 8)
    _, fn, _ = _facet(x, _z(len(x)), np.array([len(xp)]), quads, t, 1.0, all_pairs, hp, hf)
    lo, hi = np.array([[-2, -2], [-2, 0], [0, -2], [0, 0]]), np.array([[0, 0], [0, 2], [2, 0], [2, 2]])
    to_node = x[-1] - np.c_[np.clip(pos, lo, hi), np.zeros(4)]     # from each closest point
    d = np.linalg.norm(to_node, axis=1)
    w = np.exp(-(d - d.min()) / NF_TAU)
    grad_g = (w[:, None] * to_node / d[:, None]).sum(0) / w.sum()
    assert fn[-1, :3] == pytest.approx(k_n * (R_W - _soft_min(d - t / 2)) * grad_g, rel=1e-9)
    # wrong side (sign -1: nodes belong below) and beyond the cut-off: no force
    x = np.vstack([xp, [[0.5, 0.5, R_W + t / 2 - pen]]])
    hp, hf = new_slot_history(1, 8)
    assert _facet(x, _z(len(x)), np.array([len(xp)]), quads, t, -1.0, all_pairs, hp, hf)[0] == 0
    assert _facet(x, _z(len(x)), np.array([len(xp)]), quads, t, 1.0, all_pairs, hp, hf,
                  pen_max=0.01)[0] == 0


def _valley(theta):
    """Two facets meeting along the y axis at a concave corner (the inside of a faceted tube
    at a node line), normals up; node 6 is the contact node."""
    z = 2.0 * math.tan(theta)
    x = np.array([[-2, -1, z], [0, -1, 0], [0, 1, 0], [-2, 1, z], [2, -1, z], [2, 1, z], [0, 0, 0]],
                 dtype=float)
    return x, np.array([[0, 1, 2, 3], [1, 4, 5, 2]])


def test_node_in_a_concave_corner_feels_a_smooth_gradient_force():
    """A node pressed into a concave corner: its force is the gradient of the penalty energy
    1/2 k_n pen^2 of the soft-minimum gap and turns continuously across the corner's bisector.
    With the closest facet alone (the hard minimum) it flipped there by 2 k_n pen sin(theta),
    and nodes pressed into the node lines of the faceted tube chattered across it, making
    energy (bench/RESULTS.md, 'The node-facet contact made energy at concave corners')."""
    theta, t, k_n = math.radians(11.25), 0.27, 100.0
    x, quads = _valley(theta)
    pairs = np.array([[0, 0], [0, 1]])

    def force(p):
        x[6] = p
        hp, hf = new_slot_history(1, 8)
        hp[0, 0] = 0                          # in contact at the previous step
        _, fn, _ = _facet(x, _z(7), np.array([6]), quads, t, 1.0, pairs, hp, hf, pen_max=0.5)
        return fn[6, :3]

    def energy(p):
        n = np.array([[math.sin(theta), 0, math.cos(theta)], [-math.sin(theta), 0, math.cos(theta)]])
        g = _soft_min(n @ p - t / 2) - R_W       # interior feet on both facets near the bisector
        return 0.5 * k_n * max(-g, 0.0) ** 2

    z = (R_W + t / 2 - 0.02) / math.cos(theta)
    f = np.array([force(np.array([s, 0.0, z])) for s in np.linspace(-0.02, 0.02, 41)])
    flip = 2 * k_n * 0.02 * math.sin(theta)             # the hard minimum's jump
    assert np.abs(np.diff(f[:, 0])).max() < 0.1 * flip
    assert f[0, 0] > 0 > f[-1, 0]                      # both sides push it back to the bisector
    e = 1e-6
    for p in ([0.0, 0.0, z], [0.003, 0.0, z], [-0.01, 0.2, z - 0.01]):
        p = np.array(p)
        grad = [(energy(p + e * u) - energy(p - e * u)) / (2 * e) for u in np.eye(3)]
        assert force(p) == pytest.approx(-np.array(grad), rel=1e-6, abs=1e-9)


def test_node_behind_a_free_edge_is_not_grabbed():
    """A node behind the plate's plane beside its free edge (e.g. the next layer of a fabric
    spiral where the facet set stops) that slides over the plate is on the other side: no
    force.  A node that went in from the front stays pushed out."""
    xp, quads = _plate(1, 4.0)                      # one quad, x and y in [-2, 2]: free edges
    t, k_n = 0.27, 100.0
    pairs = np.array([[0, 0]])
    hp, hf = new_slot_history(1, 8)
    for xx in (2.3, 2.05, 1.9, 1.5):               # beside the edge x = 2, then over the plate
        x = np.vstack([xp, [[xx, 0.0, -0.1]]])      # 0.1 mm behind the mid-surface
        assert _facet(x, _z(len(x)), np.array([len(xp)]), quads, t, 1.0, pairs, hp, hf)[0] == 0
    hp, hf = new_slot_history(1, 8)
    for z in (R_W + t / 2 - 0.02, 0.2, -0.1):      # in from the front, through the mid-surface
        x = np.vstack([xp, [[1.5, 0.0, z]]])
        n, fn, _ = _facet(x, _z(len(x)), np.array([len(xp)]), quads, t, 1.0, pairs, hp, hf)
        assert n == 1 and fn[-1, 2] == pytest.approx(k_n * (R_W + t / 2 - z), rel=1e-9)


def test_node_facet_contact_begins_only_at_the_surface():
    """A node found deep inside the plate's contact zone without having touched it at the
    previous step is on the other side (a contact begins at the surface: no energy made
    at once); one that came in from the surface stays pushed out however deep it goes."""
    xp, quads = _plate(2, 4.0)
    t, k_n = 0.27, 100.0
    pairs = np.array([[0, q] for q in range(4)])
    top = R_W + t / 2
    x = np.vstack([xp, [[0.5, 0.5, top - 0.3]]])
    hp, hf = new_slot_history(1, 8)
    assert _facet(x, _z(len(x)), np.array([len(xp)]), quads, t, 1.0, pairs, hp, hf)[0] == 0
    hp, hf = new_slot_history(1, 8)
    for z in np.arange(top + 0.01, top - 0.31, -0.01):
        x = np.vstack([xp, [[0.5, 0.5, z]]])
        n, fn, _ = _facet(x, _z(len(x)), np.array([len(xp)]), quads, t, 1.0, pairs, hp, hf)
        assert n == (1 if z < top else 0)
        assert fn[-1, 2] == pytest.approx(k_n * max(top - z, 0.0), rel=1e-9, abs=1e-12)


def test_node_sliding_on_facet_eq6_rate_and_dissipation():
    xp, quads = _plate(4, 8.0)                   # 2 mm quads: the node crosses quad edges
    t, pen, k_n, k_t = 0.27, 0.02, 100.0, 10.0
    N = k_n * pen
    mu_s, mu_k, d_c = 0.4, 0.1, 2.0
    dt = 1e-3
    for ts, V in ((1.0, 0.4), (120.0, 30.0)):
        x = np.vstack([xp, [[-3.0, -0.3, R_W + t / 2 - pen]]])
        v = _z(len(x))
        v[-1, 0] = V
        nodes = np.array([len(xp)])
        hp, hf = new_slot_history(1, 4)
        W = 0.0
        W_n = 0.0                               # integral of the normal force along the path
        f_prev = 0.0
        n_prev = N
        dt_v = 4.5 / 400 / V                    # travel 4.5 mm in 400 steps of solver time dt_v
        for step in range(400):
            x[-1, 0] += V * dt_v
            lo_n, hi_n = node_aabbs(x, nodes, np.array([R_W]), 0.1)
            lo_q, hi_q = quad_aabbs(x, quads, np.full(len(quads), t / 2), 0.1)
            pairs = box_pairs(lo_n, hi_n, lo_q, hi_q, 2.0, False)
            n, fn, ft = _facet(x, v, nodes, quads, t, 1.0, pairs, hp, hf, k_t=k_t, dt=dt_v,
                               ts=ts, mu=(mu_s, mu_k, d_c))
            W += 0.5 * (f_prev + ft[-1, 0]) * V * dt_v       # work of f_t (trapezoid)
            f_prev = ft[-1, 0]
            W_n += 0.5 * (n_prev + fn[-1, 2]) * V * dt_v
            n_prev = fn[-1, 2]
            if step == 0:
                mu0 = mu_k + (mu_s - mu_k) * math.exp(-d_c * V / ts)
                assert ft[-1, 0] == pytest.approx(-k_t * V * dt_v)    # stick (k_t dg < mu N)
                assert k_t * V * dt_v < mu0 * N
            if min(abs(x[-1, 0] - e) for e in (-2.0, 0.0)) > 0.3:
                assert fn[-1, 2] == pytest.approx(N, rel=1e-9)
            else:                               # over a seam: the soft minimum's dip
                assert N - 1e-12 <= fn[-1, 2] <= N + k_n * NF_TAU * math.log(2) + 1e-12
            assert ft[:, :3].sum(0) == pytest.approx(np.zeros(3), abs=1e-12)
        mu = mu_k + (mu_s - mu_k) * math.exp(-d_c * V / ts)      # physical rate V / ts
        assert ft[-1, 0] == pytest.approx(-mu * N, rel=1e-9)      # kept across 2 quad edges
        assert -W - (mu * N) ** 2 / (2 * k_t) == pytest.approx(mu * (W_n - N * mu * N / k_t),
                                                                rel=2e-3)


# ------------------------------------------------------------------------- cohesive ties
K = np.array([30.0, 30.0, 30.0])
D0 = np.array([0.03, 0.03, 0.03])
DF, ALPHA = 0.08, 2.0


def _quad_tie(off=0.185, area=2.0):
    xp, quads = _plate(1, 4.0)
    x = np.vstack([xp, [[0.3, -0.2, off]]])
    tq, ts_ = make_ties(x, [4], [area], quads=quads, quad_t=[0.27], tape_half_t=0.05, tol=0.05)
    assert len(tq["tie_node"]) == 1 and len(ts_["tie_node"]) == 0
    return x, quads, tq


def _run_quad_tie(x, quads, tq):
    fc = _z(len(x))
    nf = cohesive_ties_quad(x, np.zeros_like(x), tie_set(QuadTieSet, tq, tie_c=np.zeros(1),
                                                         quads=quads),
                            TieLaw(K, D0, DF, ALPHA), fc)
    return nf, fc


@pytest.mark.parametrize("direction", [2, 0])          # normal opening, shear
def test_cohesive_tie_opening_and_shear(direction):
    x0, quads, tq = _quad_tie()
    A = tq["tie_area"][0]
    assert np.allclose(tq["tie_xi"][0], [0.15, -0.1])
    assert tq["tie_off"][0, 0] == pytest.approx(0.185)
    deltas = np.concatenate([np.linspace(0, 0.05, 251), np.linspace(0.05, 0.0, 51),
                             np.linspace(0.0, 0.1, 501)])
    F, Ds = [], []
    for d in deltas:
        x = x0.copy()
        x[4, direction] += d
        nf, fc = _run_quad_tie(x, quads, tq)
        F.append(-fc[4, direction])
        Ds.append(tq["tie_D"][0])
        assert np.allclose(fc[:, :3].sum(0), 0.0, atol=1e-12)
    F, Ds = np.array(F), np.array(Ds)
    assert np.all(np.diff(Ds) >= 0.0)                                  # D never decreases
    load = slice(0, 251)
    i_peak = np.argmax(F[load])
    assert deltas[i_peak] == pytest.approx(0.03, abs=2e-4)             # peak at delta0
    assert F[i_peak] == pytest.approx(K[0] * 0.03 * A, rel=1e-3)
    # unloading from 0.05 along the damaged secant, D frozen
    D05 = Ds[250]
    unl = slice(251, 302)
    assert np.allclose(Ds[unl], D05)
    assert np.allclose(F[unl], (1 - D05) * K[0] * deltas[unl] * A)
    # reloading past 0.05 then failure at delta_f: zero traction, D = 1
    assert F[-1] == 0.0 and Ds[-1] == 1.0 and nf == 1
    assert F[deltas.size - 501 + 401] == 0.0 < F[deltas.size - 501 + 399]   # fails at 0.08
    # dissipated energy: incremental and closed form agree with G_c A
    Gc = cohesive_dissipated_energy(K[0], 0.03, DF, ALPHA, 1.0)
    assert tq["tie_energy"][0] == pytest.approx(Gc * A, rel=2e-2)
    assert cohesive_tie_dissipation(tq["tie_kappa"], tq["tie_area"], K, D0, DF, ALPHA)[0] \
        == pytest.approx(Gc * A, rel=1e-12)


def test_cohesive_compression_no_damage_and_rigid_rotation_free():
    x0, quads, tq = _quad_tie()
    A = tq["tie_area"][0]
    x = x0.copy()
    x[4, 2] -= 0.2                                  # deep compression: penalty, no damage
    _, fc = _run_quad_tie(x, quads, tq)
    assert fc[4, 2] == pytest.approx(K[0] * 0.2 * A) and tq["tie_D"][0] == 0.0
    assert tq["tie_kappa"][0] == 0.0
    # rigid rotation of tube + tape by 40 deg: no separation, no force (local frame)
    c, s = math.cos(0.7), math.sin(0.7)
    Rm = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    _, fc = _run_quad_tie(x0 @ Rm.T + [1.0, 2.0, 3.0], quads, tq)
    assert np.abs(fc).max() < 1e-12
    # tape node over a wire segment: found by make_ties at its material point (the beam
    # ties of the model use it with the wire's rotations: test_hifi_model)
    xw = np.array([[0.0, 0, 0], [6, 0, 0], [2.0, 0.2, R_W + 0.05]])
    tq2, ts2 = make_ties(xw, [2], [1.5], seg=np.array([[0, 1]]), seg_r=[R_W], tape_half_t=0.05)
    assert len(tq2["tie_node"]) == 0 and len(ts2["tie_node"]) == 1
    assert ts2["tie_s"][0] == pytest.approx(1 / 3) and ts2["tie_area"][0] == 1.5
    assert np.allclose(ts2["tie_t0"][0], [1.0, 0.0, 0.0])


def _rotation(axis, angle):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * Kx + (1 - math.cos(angle)) * Kx @ Kx


def _loop_work(forces_at, n=4000):
    """Work of the tie forces around a closed path theta = 0..2 pi (trapezoid rule):
    ``forces_at(theta) -> (f (n, 6), x (n, 3), rotation angle about the fixed axis)``."""
    th = np.linspace(0.0, 2.0 * np.pi, n + 1)
    W = scale = 0.0
    f0, x0, a0, axis = forces_at(th[0])
    for t in th[1:]:
        f1, x1, a1, _ = forces_at(t)
        dW = 0.5 * np.sum((f0[:, :3] + f1[:, :3]) * (x1 - x0))
        dW += 0.5 * (f0[:, 3:] + f1[:, 3:]).sum(axis=0) @ (axis * (a1 - a0))
        W += dW
        scale += abs(dW)
        f0, x0, a0 = f1, x1, a1
    return W, scale


def test_damaged_ties_are_conservative_when_closing_differs_from_opening():
    """With damage frozen (0 < D < 1, kappa above the path), a tie in normal compression
    (undamaged penalty) and shear (damaged) has a traction not parallel to its separation.
    Its forces must still derive from its energy: zero work around a closed path on which
    the target turns (quad frame, or the wire anchor's rotation) and the tied node moves."""
    from harnesspipe.fe.contact.cohesive_ties import BeamTieSet, cohesive_ties_beam
    from harnesspipe.fe.rotation import quat_from_rotvec
    axis = np.array([1.0, 0.3, 0.2])
    x0, quads, tq = _quad_tie()
    centre = x0[:4].mean(axis=0)

    def quad_forces(th):
        a = 0.3 * math.sin(th + 0.5)
        R = _rotation(axis, a)
        x = (x0 - centre) @ R.T + centre
        x[4] += [0.02 * math.cos(th), 0.02 * math.sin(th), -0.03]     # shear + closing, fixed axes
        tq["tie_D"][:] = 0.5
        tq["tie_kappa"][:] = 0.07
        return _run_quad_tie(x, quads, tq)[1], x, a, axis / np.linalg.norm(axis)

    W, scale = _loop_work(quad_forces)
    assert tq["tie_D"][0] == 0.5 and scale > 1e-3
    assert abs(W) < 1e-6 * scale

    X = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [4.0, 0.75, 0.0]])
    hist = [np.full(1, 0.07), np.full(1, 0.5), np.zeros(1)]
    k = axis / np.linalg.norm(axis)

    def beam_forces(th):
        a = 0.3 * math.sin(th + 0.5)
        R = _rotation(axis, a)
        x = X @ R.T
        x[2] += [0.02 * math.cos(th), -0.03, 0.02 * math.sin(th)]     # closing: -y, fixed axes
        q = np.zeros(4)
        quat_from_rotvec(a * k, q)
        f = np.zeros((3, 6))
        hist[0][:] = 0.07
        hist[1][:] = 0.5
        ties = BeamTieSet(np.array([2]), np.array([0]), np.array([0.4]), np.array([0]),
                          np.array([[0.0, 0.75, 0.0]]), np.array([[1.0, 0.0, 0.0]]),
                          np.array([2.0]), np.zeros(1), np.array([[0, 1]]), *hist)
        cohesive_ties_beam(x, np.zeros_like(x), np.tile(q, (3, 1)), ties, TieLaw(K, D0, DF, ALPHA),
                           f)
        return f, x, a, k

    W, scale = _loop_work(beam_forces)
    assert hist[1][0] == 0.5 and scale > 1e-3
    assert abs(W) < 1e-6 * scale


# ------------------------------------------------------------- early rejects (candidates)
def test_plane_gap_bounds_the_distance_from_a_warped_facet():
    """_node_quad_plane_gap never exceeds a point's distance from the bilinear facet
    (sampled densely), for warped facets; on a flat facet it is the distance from its plane,
    so a point over the facet's interior gets its exact distance."""
    from harnesspipe.fe.contact.node_facet import _node_quad_plane_gap
    rng = np.random.default_rng(3)
    g = np.linspace(-1.0, 1.0, 161)
    xi, eta = [a.ravel() for a in np.meshgrid(g, g)]
    shape = 0.25 * np.c_[(1 - xi) * (1 - eta), (1 + xi) * (1 - eta), (1 + xi) * (1 + eta),
                         (1 - xi) * (1 + eta)]
    quads = np.array([[0, 1, 2, 3]])
    for warp in (0.0, 0.3, 1.0):
        for _ in range(20):
            corners = np.array([[0.0, 0, 0], [2, 0, 0], [2, 1.5, 0], [0, 1.5, 0]])
            corners += rng.normal(scale=0.2, size=(4, 3))
            corners[[0, 2], 2] += warp
            p = rng.normal(scale=2.0, size=3) + [1.0, 0.75, 0.0]
            x = np.vstack([corners, p])
            dist = np.linalg.norm(shape @ corners - p, axis=1).min()
            gap = _node_quad_plane_gap(x, 4, quads, 0)
            assert gap <= dist + 1e-12
    flat = np.array([[0.0, 0, 0], [2, 0, 0], [2, 1.5, 0], [0, 1.5, 0], [0.7, 0.4, -1.3]])
    assert _node_quad_plane_gap(flat, 4, quads, 0) == pytest.approx(1.3, rel=1e-14)


def test_far_candidates_change_nothing():
    """All-pairs candidate lists (mostly far apart: rejected early) and skin lists (searched
    with a margin m, narrowed by near_segment_pairs / near_node_facet_pairs and kept until a
    node has moved m / 2) give the same forces and history as the tight box_pairs lists of
    every step, step after step, for wire-wire and node-facet."""
    rng = np.random.default_rng(7)
    n_w, n_s = 6, 8
    xs = np.linspace(0.0, 8.0, n_s + 1)
    xw = np.vstack([np.c_[xs, np.full_like(xs, 1.25 * (w % 3)), np.full_like(xs, 1.25 * (w // 3))]
                    for w in range(n_w)])
    seg = np.vstack([np.c_[np.arange(n_s), np.arange(1, n_s + 1)] + w * (n_s + 1)
                     for w in range(n_w)]).astype(np.int64)
    body = np.repeat(np.arange(n_w), n_s)
    xp, quads = _plate(4, 10.0, z=-0.8)
    xp[:, 0] += 4.0
    xp[:, 1] += 1.25
    x0 = np.vstack([xw, xp])
    quads = quads + len(xw)
    nodes = np.arange(len(xw))
    r = np.full(len(nodes), R_W)
    t = np.full(len(quads), 0.3)
    sign = np.ones(len(quads))
    all_ww = np.array([[a, b] for a in range(len(seg)) for b in range(a + 1, len(seg))])
    all_nf = np.array([[i, q] for i in range(len(nodes)) for q in range(len(quads))])
    m_skin = 0.3
    runs, searches = [], 0
    for mode in ("tight", "all", "skin"):
        x = x0.copy()
        hw = new_slot_history(len(seg), 8, points=WW_POINTS)
        hf = new_slot_history(len(nodes), 8)
        rng = np.random.default_rng(1)
        out = []
        x_search = None
        for step in range(12):
            v = np.zeros((len(x), 6))
            v[:len(xw), :3] = rng.normal(scale=20.0, size=(len(xw), 3))
            v[:len(xw), 2] -= 30.0                 # press the wires onto each other and the plate
            x[:, :3] += 1e-3 * v[:, :3]
            if mode == "tight":
                lo, hi = segment_aabbs(x, seg, np.full(len(seg), R_W), 0.5)
                pw = box_pairs(lo, hi, lo, hi, 2.0, True)
                lo_n, hi_n = node_aabbs(x, nodes, r, 0.5)
                lo_q, hi_q = quad_aabbs(x, quads, 0.5 * t, 0.5)
                pf = box_pairs(lo_n, hi_n, lo_q, hi_q, 2.0, False)
            elif mode == "skin":
                if x_search is None or max_drift2(x, x_search) > (0.5 * m_skin) ** 2:
                    x_search, searches = x.copy(), searches + 1
                    rw = np.full(len(seg), R_W)
                    lo, hi = segment_aabbs(x, seg, rw, m_skin)
                    pw = box_pairs(lo, hi, lo, hi, 2.0, True)
                    pw = pw[near_segment_pairs(x, seg, rw, pw, m_skin)]
                    lo_n, hi_n = node_aabbs(x, nodes, r, m_skin)
                    lo_q, hi_q = quad_aabbs(x, quads, 0.5 * t, m_skin)
                    pf = box_pairs(lo_n, hi_n, lo_q, hi_q, 2.0, False)
                    pf = pf[near_node_facet_pairs(x, nodes, r, quads, t, pf, 1.0, m_skin)]
            else:
                pw, pf = all_ww, all_nf
            fn, ft = _z(len(x)), _z(len(x))
            n1 = beam_beam_contact(x, v, WireContact(seg, np.full(len(seg), R_W), body, pw, 100.0,
                                                     50.0, 0.4, 0.1, 2.0, hw[0], hw[1]),
                                   1e-3, 1.0, fn, ft)
            n2 = node_facet_contact(x, v, FacetSet(nodes, r, quads, t, sign, pf, 100.0, 50.0, 0.4,
                                                   0.1, 2.0, 1.0, hf[0], hf[1]), 1e-3, 1.0, fn, ft)
            out.append((n1, n2, fn.copy(), ft.copy()))
        runs.append((out, hw, hf))
    assert 2 < searches < 12                  # the skin lists are reused between searches
    (o1, hw1, hf1) = runs[0]
    for o2, hw2, hf2 in runs[1:]:
        assert sum(o[0] for o in o1) > 10 and sum(o[1] for o in o1) > 10    # contacts happen
        for a, b in zip(o1, o2):
            assert a[0] == b[0] and a[1] == b[1]
            np.testing.assert_allclose(a[2], b[2], rtol=0, atol=1e-12)
            np.testing.assert_allclose(a[3], b[3], rtol=0, atol=1e-12)
        np.testing.assert_allclose(hf1[1], hf2[1], rtol=0, atol=1e-12)
        np.testing.assert_array_equal(hf1[0], hf2[0])


@pytest.mark.parametrize("D", [0.0, 0.4, 1.0])
def test_tie_dashpot_resists_the_relative_velocity_with_the_bond(D):
    """At zero separation the tie carries only its dashpot: -(1 - D) c (v_node - v_target)
    on the tied node, the reaction spread over the quad's nodes by the shape functions (no
    net force), and negative power (it only dissipates); a debonded tie carries nothing."""
    x, quads, tq = _quad_tie()
    rng = np.random.default_rng(3)
    v = np.zeros((len(x), 6))
    v[:, :3] = rng.normal(size=(len(x), 3))
    c = 0.02
    tq["tie_D"][:] = D
    tq["tie_kappa"][:] = 0.0 if D == 0.0 else 0.2
    fc = _z(len(x))
    cohesive_ties_quad(x, v, tie_set(QuadTieSet, tq, tie_c=np.array([c]), quads=quads),
                       TieLaw(K, D0, DF, ALPHA), fc)
    xi, eta = tq["tie_xi"][0]
    N = 0.25 * np.array([(1 - xi) * (1 - eta), (1 + xi) * (1 - eta), (1 + xi) * (1 + eta),
                         (1 - xi) * (1 + eta)])
    v_rel = v[4, :3] - N @ v[quads[0], :3]
    expected = -(1.0 - D) * c * v_rel
    assert np.allclose(fc[4, :3], expected, rtol=1e-12, atol=1e-15)
    assert np.allclose(fc[:, :3].sum(axis=0), 0.0, atol=1e-15)
    power = float(np.sum(fc[:, :3] * v[:, :3]))
    assert power == pytest.approx(-(1.0 - D) * c * v_rel @ v_rel, rel=1e-9, abs=1e-15)
