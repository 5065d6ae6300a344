"""The parts of the hi-fi three-point meshes, each on its own (models/hifi_mesh_parts.py), and
how build_mesh numbers and assembles them (models/hifi_mesh.py)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from conftest import with_closure

from harnesspipe.models import hifi_mesh_parts as mp
from harnesspipe.models.hifi_mesh import PRESETS, build_mesh

RES = PRESETS["quick"]


@pytest.fixture(scope="module")
def sample(config):
    return mp.Sample.from_config(config)


def _case(config, name):
    return {**config["cases"], **config["hifi"]["extra_cases"]}[name]


def _bundle_and_covering(config, sample, name, turned: bool = False):
    """The bundle as drawn (or, ``turned``, as the mesh builder turns it: the config's
    pack_angle) and its covering."""
    case = _case(config, name)
    bundle = mp.wire_bundle(case, config)
    if turned:
        bundle = mp.turn_bundle(bundle, config["hifi"]["build"]["pack_angle"])
    return bundle, mp.covering(case, config, bundle, sample.t_tape)


def _radius(X):
    return np.hypot(X[..., 1], X[..., 2])


def _normals_outward(part):
    """Whether each quad's normal (X2 - X1) x (X4 - X1) points away from the bundle axis."""
    P = part.X[part.conn]
    n = np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 1])
    return np.sum(n[:, 1:] * P.mean(axis=1)[:, 1:], axis=1) > 0.0


# ---------------------------------------------------------------------------- wires

@pytest.mark.parametrize("name, n, rings", [
    ("cwb19_t2_closed", 19, [0.0] + [1.0] * 6 + [np.sqrt(3)] * 6 + [2.0] * 6),
    ("cwb38_t2_open_coarse", 38, None)])
def test_wire_bundle_is_a_hexagonal_packing_inside_the_tube(config, sample, name, n, rings):
    bundle, cov = _bundle_and_covering(config, sample, name)
    d = 1.40 * 1.001                                   # pitch: d_outer + 0.1 % clearance
    assert bundle.yz.shape == (n, 2) and bundle.pitch == pytest.approx(d)
    r = np.hypot(bundle.yz[:, 0], bundle.yz[:, 1])
    if rings is not None:
        np.testing.assert_allclose(np.sort(r), d * np.array(rings), atol=1e-12)
    else:     # 37 = three full shells; the 38th the lowest site of the next (phi = 150 deg)
        assert np.all(r[:37] <= 3 * d + 1e-12) and r[37] == pytest.approx(2 * np.sqrt(3) * d)
        np.testing.assert_allclose(bundle.yz[-1], [-3.0 * d, -np.sqrt(3) * d], atol=1e-12)
    # lattice: every centre is an integer combination of the two lattice vectors
    ij = np.linalg.solve(np.array([[1.0, 0.5], [0.0, np.sqrt(3) / 2]]) * d, bundle.yz.T)
    np.testing.assert_allclose(ij, np.round(ij), atol=1e-9)
    gaps = [np.hypot(*(bundle.yz[i] - bundle.yz[j])) - bundle.radius[i] - bundle.radius[j]
            for i, j in itertools.combinations(range(n), 2)]
    assert min(gaps) == pytest.approx(1.4e-3, rel=1e-9)              # packed, not touching
    assert bundle.r_bundle == pytest.approx(r.max() + 0.7)
    assert bundle.r_bundle < cov.inner_min() == pytest.approx(0.5 * cov.d_i)


def test_mixed_wire_types_alternate_and_keep_their_radii(config):
    bundle = mp.wire_bundle({"wires": {"wire_type1": 10, "wire_type2": 9}}, config)
    assert np.bincount(bundle.wire_type)[1:].tolist() == [10, 9]
    assert bundle.wire_type[:7].tolist() == [1, 2, 1, 2, 1, 2, 1]        # centre, ring 1
    np.testing.assert_allclose(bundle.radius, np.where(bundle.wire_type == 1, 0.625, 0.7))


def test_round_band_gap_over_the_hexagonal_bundle(config, sample):
    """The support of the 19-wire hexagon is least between a corner wire (2 d) and an edge
    wire (sqrt 3 d): a round band of radius r_bundle is (2 - sqrt 3) d off the bundle there."""
    bundle, _ = _bundle_and_covering(config, sample, "cwb19_t2_closed")
    assert bundle.round_gap_max() == pytest.approx((2.0 - np.sqrt(3.0)) * bundle.pitch, rel=1e-9)


def test_wire_beams_number_the_wires_first(config, sample):
    bundle, _ = _bundle_and_covering(config, sample, "cwb19_t2_closed")
    beams = mp.wire_beams(bundle, *sample.x_sample, 8)
    assert beams.X.shape == (19 * 9, 3) and beams.beam_conn.shape == (19 * 8, 2)
    np.testing.assert_array_equal(beams.wire_nodes[3], 3 * 9 + np.arange(9))
    np.testing.assert_allclose(beams.X[beams.wire_nodes[:, :], 0], np.tile(np.linspace(-100, 100, 9), (19, 1)))
    np.testing.assert_allclose(beams.X[beams.wire_nodes[5], 1:], np.tile(bundle.yz[5], (9, 1)))
    assert np.all(beams.beam_conn[:, 1] - beams.beam_conn[:, 0] == 1)
    np.testing.assert_array_equal(np.bincount(beams.beam_wire), [8] * 19)


# ------------------------------------------------------------------------ coverings

@pytest.mark.parametrize("name", ["cwb19_t2_closed", "cwb10t1_9t2_fabric", "cwb38_t2_open_coarse"])
def test_spread_bundle_moves_the_wires_towards_the_wall(config, sample, name):
    """wire_fill 0 keeps the packed bundle; 1 brings the outer wires to the covering's inner
    face less the packing clearance, half-way lands half-way; the lattice only scales (no
    two wires closer than their diameters, same angular order)."""
    bundle, cov = _bundle_and_covering(config, sample, name)
    assert mp.spread_bundle(bundle, cov.inner_min(), 0.0) is bundle
    r_in = cov.inner_min()
    full = mp.spread_bundle(bundle, r_in, 1.0)
    assert full.r_bundle == pytest.approx(r_in - mp.WIRE_CLEARANCE * bundle.pitch, abs=1e-12)
    half = mp.spread_bundle(bundle, r_in, 0.5)
    assert half.r_bundle == pytest.approx(0.5 * (bundle.r_bundle + full.r_bundle), abs=1e-12)
    for spread in (half, full):
        gaps = [np.hypot(*(spread.yz[a] - spread.yz[b])) - spread.radius[a] - spread.radius[b]
                for a, b in itertools.combinations(range(spread.yz.shape[0]), 2)]
        assert min(gaps) > 0.0
        np.testing.assert_allclose(np.arctan2(spread.yz[1:, 1], spread.yz[1:, 0]),
                                   np.arctan2(bundle.yz[1:, 1], bundle.yz[1:, 0]), atol=1e-12)
    with pytest.raises(ValueError, match="wire_fill 1.5"):
        mp.spread_bundle(bundle, r_in, 1.5)


def _mirror_offset(yz) -> float:
    """How far the pack is from its mirror image about the loading plane (z -> -z): the
    largest distance from a wire's mirror image to the nearest wire."""
    mirrored = yz * np.array([1.0, -1.0])
    return float(np.max(np.min(np.linalg.norm(mirrored[:, None] - yz[None], axis=-1), axis=1)))


@pytest.mark.parametrize("name", ["cwb19_t2_closed", "cwb10t1_9t2_fabric"])
def test_turn_bundle_is_a_rigid_turn_that_breaks_the_mirror(config, sample, name):
    """turn_bundle moves every wire's phi by the angle and nothing else (pair distances,
    radii, types and bundle radius kept).  As drawn, the pack is its own mirror image about
    the loading plane; turned by 1 deg, its outer wires are 2 r sin(1 deg) off it."""
    bundle, _ = _bundle_and_covering(config, sample, name)
    assert mp.turn_bundle(bundle, 0.0) is bundle
    assert _mirror_offset(bundle.yz) < 1e-12
    turned = mp.turn_bundle(bundle, 1.0)
    pair = lambda yz: np.linalg.norm(yz[:, None] - yz[None], axis=-1)
    np.testing.assert_allclose(pair(turned.yz), pair(bundle.yz), atol=1e-12)
    np.testing.assert_array_equal(turned.wire_type, bundle.wire_type)
    assert turned.r_bundle == bundle.r_bundle and turned.pitch == bundle.pitch
    phi = lambda yz: np.arctan2(-yz[1:, 1], yz[1:, 0])
    np.testing.assert_allclose(np.angle(np.exp(1j * (phi(turned.yz) - phi(bundle.yz)))),
                               np.radians(1.0), atol=1e-12)
    r_out = np.max(np.hypot(*bundle.yz.T))
    assert _mirror_offset(turned.yz) == pytest.approx(2.0 * r_out * np.sin(np.radians(0.5)) * 2.0
                                                      * np.cos(np.radians(0.5)), rel=1e-9)


def test_the_configs_pack_is_no_mirror_image_of_itself(config):
    """The default build turns the pack (config hifi.build.pack_angle) so that the mesh's wires
    are no mirror image of themselves about the loading plane, by far more than round-off: a
    sideways shift of the top wires under the feeder is decided by the geometry (at 0 it was
    decided by the last bits of the inputs; bench/RESULTS.md 'Hi-fi outcome against the last bits')."""
    mesh = build_mesh(_case(config, "cwb19_t2_closed"), config, RES)
    assert config["hifi"]["build"]["pack_angle"] > 0.0
    assert _mirror_offset(mesh.wire_yz) > 0.05                       # mm, against ~1e-15 of round-off
    drawn = {**config, "hifi": {**config["hifi"], "build": {**config["hifi"]["build"], "pack_angle": 0.0}}}
    assert _mirror_offset(build_mesh(_case(config, "cwb19_t2_closed"), drawn, RES).wire_yz) < 1e-12


def test_build_mesh_spreads_the_wires_of_a_covered_bundle_only(config):
    """config hifi.build.wire_fill reaches the mesh of a CWB (its clearance shrinks to the
    packing clearance at 1) and leaves a TWB (no covering) as it is."""
    spread = {**config, "hifi": {**config["hifi"], "build": {**config["hifi"]["build"], "wire_fill": 1.0}}}
    closed = _case(config, "cwb19_t2_closed")
    m0, m1 = build_mesh(closed, config, RES), build_mesh(closed, spread, RES)
    assert m0.info["clearance"] > 1.8 and m1.info["clearance"] == pytest.approx(
        mp.WIRE_CLEARANCE * m0.info["wire_pitch"])
    twb = _case(config, "twb19_t2")
    np.testing.assert_array_equal(build_mesh(twb, config, RES).X, build_mesh(twb, spread, RES).X)


def test_bundle_that_does_not_fit_is_refused(config, sample):
    case = {"wires": {"wire_type2": 38}, "covering": "closed_tube"}
    bundle = mp.wire_bundle(case, config)
    with pytest.raises(ValueError, match="do not fit in closed_tube"):
        mp.covering(case, config, bundle, sample.t_tape)
    cov = mp.covering({**case, "d_i": 15.0, "d_o": 18.4}, config, bundle, sample.t_tape)
    assert cov.R == pytest.approx(8.35) and cov.t == pytest.approx(1.7)




@pytest.mark.parametrize("c", [0.5, 1.0])
def test_slit_tube_closes_onto_the_bundle_keeping_its_wall(config, sample, c):
    """tube_closure c rolls the slit tube c of the way to the bundle: at 1 its inner face
    lies on the packed bundle (plus the packing clearance); the ridge depth stays; the
    moulded circumference 2 pi R is kept as layers x 2 pi R'; the overlapped section is
    closed.  A closed tube and c = 0 leave the tube as moulded."""
    case = _case(config, "cwb19_t2_open_coarse")
    bundle = mp.wire_bundle(case, config)
    moulded = mp.covering(case, with_closure(config, 0.0), bundle, sample.t_tape)
    cov = mp.covering(case, with_closure(config, c), bundle, sample.t_tape)
    assert moulded.cut and moulded.layers == 1.0 and moulded.d_i == 10.7
    r_in = bundle.r_bundle + mp.WIRE_CLEARANCE * bundle.pitch
    assert 0.5 * cov.d_i == pytest.approx(0.5 * 10.7 - c * (0.5 * 10.7 - r_in))
    assert cov.d_o - cov.d_i == pytest.approx(14.1 - 10.7)
    assert cov.layers * cov.R == pytest.approx(moulded.R) and cov.layers > 1.0
    assert not cov.cut
    closed = mp.covering(_case(config, "cwb19_t2_closed"), with_closure(config, c), bundle, sample.t_tape)
    assert closed.d_i == 10.7 and closed.layers == 1.0
    with pytest.raises(ValueError, match="tube_closure 1.5"):
        mp.covering(case, with_closure(config, 1.5), bundle, sample.t_tape)


def _with_sleeve(config: dict, c: float) -> dict:
    return {**config, "hifi": {**config["hifi"], "build": {**config["hifi"]["build"], "sleeve_closure": c}}}


@pytest.mark.parametrize("c", [0.5, 1.0])
def test_fabric_sleeve_curls_onto_the_bundle_keeping_its_sheet(config, sample, c):
    """sleeve_closure c moves the sleeve's inner layer c of the way to the bundle (at 1 its
    inner face on the packed bundle plus the packing clearance); the woven sheet keeps its
    length and its growth per wrap, so it wraps more.  A tube and c = 0 are left alone."""
    case = _case(config, "cwb19_t2_fabric")
    bundle = mp.wire_bundle(case, config)
    free = mp.covering(case, _with_sleeve(config, 0.0), bundle, sample.t_tape)
    cov = mp.covering(case, _with_sleeve(config, c), bundle, sample.t_tape)
    assert (free.r1, free.r2, free.wraps) == (4.7, 5.3, 1.25)
    r_in = bundle.r_bundle + mp.WIRE_CLEARANCE * bundle.pitch
    assert cov.r1 - 0.5 * cov.t == pytest.approx(free.r1 - 0.5 * free.t - c * (free.r1 - 0.5 * free.t - r_in))
    length = lambda v: v.theta_end * 0.5 * (v.r1 + v.r2)
    assert length(cov) == pytest.approx(length(free), rel=1e-12)
    assert (cov.r2 - cov.r1) / cov.wraps == pytest.approx((free.r2 - free.r1) / free.wraps)
    assert cov.wraps > free.wraps and cov.theta_end == pytest.approx(2.0 * np.pi * cov.wraps)
    tube = mp.covering(_case(config, "cwb19_t2_closed"), _with_sleeve(config, c), bundle, sample.t_tape)
    assert tube.d_i == 10.7
    with pytest.raises(ValueError, match="sleeve_closure 1.5"):
        mp.covering(case, _with_sleeve(config, 1.5), bundle, sample.t_tape)


def test_sleeve_on_a_small_bundle_curls_to_two_wraps_at_most(config, sample):
    """7 wires would take the sheet round 2.1 times: the curl stops at two wraps (the
    self-contact pairs two layers), the sheet's length kept, still clear of the bundle."""
    case = {**_case(config, "cwb19_t2_fabric"), "wires": {"wire_type2": 7}}
    bundle = mp.wire_bundle(case, config)
    free = mp.covering(case, _with_sleeve(config, 0.0), bundle, sample.t_tape)
    cov = mp.covering(case, _with_sleeve(config, 1.0), bundle, sample.t_tape)
    assert cov.wraps == mp.MAX_SLEEVE_WRAPS
    assert cov.theta_end * 0.5 * (cov.r1 + cov.r2) == pytest.approx(free.theta_end * 0.5 * (free.r1 + free.r2))
    assert bundle.r_bundle < cov.r1 - 0.5 * cov.t < free.r1


def test_curled_sleeve_mesh_wraps_the_bundle_without_overlap(config):
    """build_mesh with the sleeve curled on: the fabric's innermost nodes lie at r1' and
    every wire's surface inside the sleeve's inner face (no initial penetration), closer to
    it than the free sleeve's 0.9 mm."""
    case = _case(config, "cwb19_t2_fabric")
    for c, gap_max in ((0.0, None), (1.0, 0.01)):
        m = build_mesh(case, _with_sleeve(config, c), RES)
        fab = m.X[np.unique(m.shell_conn[m.shell_part == mp.PART_FABRIC])]
        r_fab = np.hypot(fab[:, 1], fab[:, 2])
        wires = m.X[m.wire_nodes.ravel()]
        r_wire = np.hypot(wires[:, 1], wires[:, 2]).max() + m.info["wire_pitch"] / 2 / (1 + mp.WIRE_CLEARANCE)
        gap = r_fab.min() - 0.5 * 0.6 - r_wire
        assert gap >= 0.0
        if gap_max is None:
            assert gap > 0.85
        else:
            assert gap < gap_max


def test_closed_slit_tube_mesh_has_no_cut_and_sits_on_the_bundle(config):
    """build_mesh with the slit tube closed: no cut node pairs, the clearance is the packing
    clearance, the pins touch the smaller tube, info carries the layers."""
    case = _case(config, "cwb19_t2_open_coarse")
    m0, m1 = build_mesh(case, with_closure(config, 0.0), RES), build_mesh(case, with_closure(config, 1.0), RES)
    assert m0.cut_pairs.shape[0] > 0 and m1.cut_pairs.shape[0] == 0
    assert m0.info["tube_layers"] == 1.0 and m1.info["tube_layers"] == pytest.approx(6.2 / m1.info["tube_mid_radius"])
    assert m1.info["clearance"] == pytest.approx(mp.WIRE_CLEARANCE * m1.info["wire_pitch"])
    assert m1.rollers["centres"][2, 1] < m0.rollers["centres"][2, 1]        # the feeder lower


@pytest.mark.parametrize("name, cut", [("cwb19_t2_closed", False), ("cwb19_t2_open_coarse", True)])
def test_tube_nodes_lie_on_the_mid_surface(config, sample, name, cut):
    _, cov = _bundle_and_covering(with_closure(config, 0.0), sample, name)
    xc = np.linspace(*sample.x_tube, 5)
    part = mp.tube_shell(cov, xc, 12, 0.5 * np.pi)
    assert cov.cut == cut
    assert part.X.shape == (5 * (13 if cut else 12), 3) and part.conn.shape == (4 * 12, 4)
    np.testing.assert_allclose(_radius(part.X), 0.25 * (10.7 + 14.1))          # R = 6.2
    assert cov.R - 0.5 * part.thickness == pytest.approx(0.5 * cov.d_i)        # faces d_i/2,
    assert cov.R + 0.5 * part.thickness == pytest.approx(0.5 * cov.d_o)        # d_o/2
    assert np.all(_normals_outward(part))
    assert np.isin(part.X[:, 0], xc).all()
    if cut:
        pairs = part.node_sets["cut_pairs"]
        np.testing.assert_array_equal(part.X[pairs[:, 0]], part.X[pairs[:, 1]])
        np.testing.assert_allclose(part.X[pairs[:, 0], 1:], [[0.0, -6.2]] * 5, atol=1e-12)
        assert not np.any(np.isin(part.conn, pairs[:, 0]).any(axis=1)        # no quad bridges
                          & np.isin(part.conn, pairs[:, 1]).any(axis=1))        # the cut
        np.testing.assert_allclose(np.linalg.norm(part.X[part.node_sets["cut_next"]] - part.X[pairs[:, 0]], axis=1),
                                   2 * 6.2 * np.sin(np.pi / 12))              # one hoop chord away
    else:
        assert part.node_sets == {}


def test_fabric_nodes_lie_on_the_spiral(config, sample):
    """The free sleeve (sleeve_closure 0): Fig. 6b's spiral, its overlap's layers paired."""
    _, cov = _bundle_and_covering(_with_sleeve(config, 0.0), sample, "cwb19_t2_fabric")
    part = mp.fabric_shell(cov, np.linspace(*sample.x_tube, 3), 12)
    ring = part.X[:part.X.shape[0] // 3]                                     # first station
    theta = np.unwrap(np.arctan2(-ring[:, 2], ring[:, 1])) - cov.phi0
    assert theta[0] == pytest.approx(0.0) and theta[-1] == pytest.approx(2.5 * np.pi)
    np.testing.assert_allclose(_radius(ring), 4.7 + 0.6 * theta / (2.5 * np.pi), atol=1e-12)
    assert np.all(_normals_outward(part))
    inner, outer = (part.X[part.node_sets[k]] for k in ("fabric_overlap_inner", "fabric_overlap_outer"))
    np.testing.assert_allclose(outer[:, [0]], inner[:, [0]])
    np.testing.assert_allclose(np.arctan2(-outer[:, 2], outer[:, 1]), np.arctan2(-inner[:, 2], inner[:, 1]),
                               atol=1e-12)
    np.testing.assert_allclose(_radius(outer) - _radius(inner), (5.3 - 4.7) / 1.25)   # 0.48


# ---------------------------------------------------------------------------- tapes

def _wire_distance(bundle, X):
    """Distance of points X (n, 3) to the nearest wire surface (in the cross-section)."""
    d = np.linalg.norm(X[:, None, 1:] - bundle.yz[None], axis=2) - bundle.radius[None]
    return d.min(axis=1)


def _support_gap(bundle, X):
    """Radial gap of points X (n, 3) over the bundle in their own direction e:
    |yz| - max over the wires of (e . yz_w + r_w)."""
    r = _radius(X)
    e = X[:, 1:] / r[:, None]
    return r - np.max(e @ bundle.yz.T + bundle.radius[None, :], axis=1)


@pytest.mark.parametrize("end_tape", ["stepped", "wires"])
def test_end_band_lies_on_its_tie_targets(config, sample, end_tape):
    bundle, cov = _bundle_and_covering(config, sample, "cwb19_t2_open_coarse")
    res = {**RES, "end_tape": end_tape}
    part = mp.end_band(1.0, mp.GROUP_END_RIGHT, bundle, cov, sample, res)
    assert part.X.shape == (7 * 8, 3) and part.conn.shape == (6 * 8, 4)
    x = part.X[:, 0]
    assert x.min() == pytest.approx(100.0 - 38.1) and x.max() == pytest.approx(100.0)
    on_cov = part.tie_target == mp.TIE_COVERING
    on_wires = part.tie_target == mp.TIE_WIRES
    assert np.all(on_cov | on_wires)
    if end_tape == "stepped":      # over the tube up to its end l/2 = 76.2, then on the wires
        assert np.all(x[on_cov] <= 76.2 + 1e-9) and np.all(x[on_wires] >= 76.2 - 1e-9)
        assert 0 < on_cov.sum() < on_wires.sum()
    else:
        assert not on_cov.any()
    # covering ties: on the tube's outer face (t/2 off); wire ties: round over the hexagonal
    # bundle, no wire inside the tape, radially t/2 .. t/2 + round_gap_max over the bundle
    np.testing.assert_allclose(_radius(part.X[on_cov]) - (cov.R + 0.5 * cov.t), 0.5 * sample.t_tape)
    np.testing.assert_allclose(_radius(part.X[on_wires]), bundle.r_bundle + 0.5 * sample.t_tape)
    assert _wire_distance(bundle, part.X[on_wires]).min() == pytest.approx(0.5 * sample.t_tape)
    gap = _support_gap(bundle, part.X[on_wires]) - 0.5 * sample.t_tape
    assert gap.min() >= -1e-12 and gap.max() <= bundle.round_gap_max() + 1e-12
    hoop = part.axis
    c = part.X[part.conn].mean(axis=1)
    assert np.abs(hoop[:, 0]).max() == 0.0 and np.abs(np.sum(hoop[:, 1:] * c[:, 1:], axis=1)).max() < 1e-12
    assert np.all(_normals_outward(part))


def test_end_band_profile_steps_at_the_tube_end(sample):
    s, on_cov = mp.end_band_profile(sample, 6, stepped=True)
    np.testing.assert_allclose(s[[0, -1]], [100.0, 61.9])
    assert np.all(np.diff(s) < 0)
    assert on_cov.tolist() == [False] * 4 + [True] * 3          # 4 on the wires, 2 over the tube
    assert s[4] == pytest.approx(76.2)                           # the tube end, on the covering
    flat, on = mp.end_band_profile(sample, 6, stepped=False)
    np.testing.assert_allclose(flat, np.linspace(100.0, 61.9, 7))
    assert not on.any()


def _helix(config, sample, name, taping_ratio, res):
    """The helix on the moulded tube (tube_closure 0: eq. 5's r = 7.1)."""
    bundle, cov = _bundle_and_covering(with_closure(config, 0.0), sample, name)
    p = sample.w_tape * config["three_point"][taping_ratio]
    return (*mp.helix_strip(cov, sample, p, taping_ratio == "halflap_overlap", res), cov, bundle)


def _strip_grid(part, res):
    """Node coordinates as (n_eta + 1, n_u + 1, 3), eta-major."""
    return part.X.reshape(int(res["tape_width"]) + 1, -1, 3)


def test_coarse_helix_pitch_and_gaps(config, sample):
    """Eq. 5: pitch p = 2 w, the strip w wide along the axis, gaps of w between wraps."""
    part, info, cov, _ = _helix(config, sample, "cwb19_t2_open_coarse", "coarse_pitch_over_width", RES)
    G = _strip_grid(part, RES)
    w, p = sample.w_tape, info["pitch"]
    assert p == pytest.approx(2 * w)
    centre = G[2]                                              # eta = 0
    phi = np.unwrap(np.arctan2(-centre[:, 2], centre[:, 1]))
    np.testing.assert_allclose(np.diff(centre[:, 0]) / np.diff(phi), p / (2 * np.pi))
    np.testing.assert_allclose(G[-1, :, 0] - G[0, :, 0], w)                # axial width w
    np.testing.assert_allclose(_radius(part.X), cov.tape_radius(0.0))      # r = 7.1 on the tube
    assert _radius(part.X)[0] == pytest.approx(7.1)
    assert np.all(part.tie_target == mp.TIE_COVERING)
    assert (G[0, 0, 0], G[-1, -1, 0]) == pytest.approx((-61.9, 61.9))      # between the end bands
    assert info["turns"] == pytest.approx((123.8 - w) / p)
    assert np.all(_normals_outward(part))


@pytest.mark.parametrize("res", [RES, PRESETS["default"]])
def test_halflap_wraps_overlap_by_half_the_width(config, sample, res):
    """Half-lap: p = w/2, so each wrap lies half on the tube and half (w/2) on the previous
    wrap; the stations repeat every turn, so a back-half node lies over a node of the
    previous wrap, t (t/2 over the centre line's step) above it."""
    part, info, cov, _ = _helix(config, sample, "cwb19_t2_open_halflap", "halflap_overlap", res)
    G = _strip_grid(part, res)
    w, p, t, k = sample.w_tape, info["pitch"], sample.t_tape, info["elements_per_turn"]
    assert p == pytest.approx(0.5 * w) and k >= 5
    u = G[2, :, 0]
    np.testing.assert_allclose(np.diff(u)[1:], p / k)       # u[0]: the remainder's start
    j = np.arange(1, u.size - k)                            # station j + k: one turn later
    # front edge of wrap n vs back edge of wrap n + 1 at the same phi: overlap w - p = w/2
    np.testing.assert_allclose(G[-1, j, 0] - G[0, j + k, 0], 0.5 * w)
    ph = np.arctan2(-G[..., 2], G[..., 1])
    np.testing.assert_allclose(np.angle(np.exp(1j * (ph[0, j + k] - ph[-1, j]))), 0.0, atol=1e-9)
    # back half of wrap n + 1 over the front half of wrap n, once the ramp is done
    done = u[j + k] >= u[0] + p - 1e-9
    r = _radius(G)
    np.testing.assert_allclose((r[1, j + k] - r[3, j])[done], t)             # eta -w/4 over +w/4
    np.testing.assert_allclose((r[2, j + k] - r[4, j])[done], 0.5 * t)       # centre over edge
    assert r.max() == pytest.approx(cov.tape_radius(0.0) + t)                # two layers at most


def test_halflap_tie_targets_are_over_their_facets(config, sample):
    """TIE_TAPE nodes lie over the previous wrap's nodes (t/2 .. t); TIE_COVERING nodes on
    the tube's outer face + t/2, up to t higher on the first turn's ramp."""
    part, info, cov, _ = _helix(config, sample, "cwb19_t2_open_halflap", "halflap_overlap", RES)
    t = sample.t_tape
    on_tape = part.tie_target == mp.TIE_TAPE
    assert set(np.unique(part.tie_target)) == {mp.TIE_TAPE, mp.TIE_COVERING}
    gap = _radius(part.X) - (cov.R + 0.5 * cov.t) - 0.5 * t
    assert np.all((gap[~on_tape] >= -1e-12) & (gap[~on_tape] <= t + 1e-12))
    np.testing.assert_allclose(gap[~on_tape & (part.X[:, 0] > 0)], 0.0, atol=1e-12)   # ramp done
    top, below = part.X[on_tape], part.X
    ph = lambda X: np.arctan2(-X[:, 2], X[:, 1])                              # noqa: E731
    same = (np.abs(top[:, None, 0] - below[None, :, 0]) < 1e-9) & \
        (np.abs(np.angle(np.exp(1j * (ph(top)[:, None] - ph(below)[None, :])))) < 1e-9)
    dr = np.where(same, _radius(top)[:, None] - _radius(below)[None, :], np.inf)
    dr = np.where(dr > 1e-9, dr, np.inf).min(axis=1)
    assert np.all((dr >= 0.5 * t - 1e-9) & (dr <= t + 1e-9))


def test_twb_helix_runs_along_the_wires(config, sample):
    part, info, cov, bundle = _helix(config, sample, "twb19_t2", "halflap_overlap", RES)
    assert cov.kind == "none" and info["x_range"] == sample.x_sample
    assert part.X[:, 0].min() == pytest.approx(-100.0) and part.X[:, 0].max() == pytest.approx(100.0)
    on_wires = part.tie_target == mp.TIE_WIRES
    assert set(np.unique(part.tie_target)) == {mp.TIE_WIRES, mp.TIE_TAPE}
    assert _wire_distance(bundle, part.X[on_wires]).min() == pytest.approx(0.5 * sample.t_tape)
    gap = _support_gap(bundle, part.X[on_wires]) - 0.5 * sample.t_tape     # + t on the ramp
    assert gap.min() >= -1e-12 and gap.max() <= bundle.round_gap_max() + sample.t_tape + 1e-12


# ------------------------------------------------------------------------- assembly

@pytest.mark.parametrize("name", ["cwb19_t2_open_halflap", "cwb19_t2_fabric"])
def test_build_mesh_numbers_the_parts_in_order(config, sample, name):
    """build_mesh = the wires, the covering, the two end bands, the helix, each part's nodes
    in one block at its offset, its node sets and tie targets carried over."""
    case = config["cases"][name]
    m = build_mesh(case, config, RES)
    bundle, cov = _bundle_and_covering(config, sample, name, turned=True)
    xc = np.linspace(*sample.x_tube, RES["tube_axial"] + 1)
    parts = [mp.fabric_shell(cov, xc, RES["tube_circ"]) if cov.kind == "fabric"
             else mp.tube_shell(cov, xc, RES["tube_circ"], 0.5 * np.pi)]
    parts += [mp.end_band(s, g, bundle, cov, sample, RES)
              for s, g in ((-1.0, mp.GROUP_END_LEFT), (1.0, mp.GROUP_END_RIGHT))]
    if case["taping"] == "halflap":
        parts.append(mp.helix_strip(cov, sample, 0.5 * sample.w_tape, True, RES)[0])
    base, el = m.n_wire_nodes, 0
    np.testing.assert_array_equal(m.X[:base], mp.wire_beams(bundle, *sample.x_sample, RES["wire_elements"]).X)
    ties, tie_nodes = [], []
    for part in parts:
        n, ne = part.X.shape[0], part.conn.shape[0]
        np.testing.assert_array_equal(m.X[base:base + n], part.X)
        np.testing.assert_array_equal(m.shell_conn[el:el + ne], part.conn + base)
        assert np.all(m.shell_group[el:el + ne] == part.group)
        for key, ids in part.node_sets.items():
            np.testing.assert_array_equal(getattr(m, key), ids + base)
        if part.tie_target is not None:
            ties.append(part.tie_target)
            tie_nodes.append(base + np.arange(n))
        base, el = base + n, el + ne
    assert base == m.n_nodes and el == m.shell_conn.shape[0]
    np.testing.assert_array_equal(m.tie_target, np.concatenate(ties))
    np.testing.assert_array_equal(m.tie_nodes, np.concatenate(tie_nodes))
