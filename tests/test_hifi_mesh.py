"""Hi-fi three-point bending meshes (models/hifi_mesh.py)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from conftest import with_closure

from harnesspipe.models.hifi_mesh import (GROUP_COVERING, GROUP_END_LEFT, GROUP_HELIX, PART_FABRIC,
                                          PART_TAPE, PART_TUBE, PRESETS, TIE_COVERING, TIE_TAPE,
                                          TIE_WIRES, build_mesh, coverage, element_sizes,
                                          shell_normals, to_meshio, write_vtu)

RES = PRESETS["quick"]


@pytest.fixture(scope="module")
def meshes(config):
    """The slit tubes as moulded (tube_closure 0) and the fabric sleeve as the paper models it
    (sleeve_closure 0): the geometry of eq. 5 and Fig. 6b checked here; the default closures,
    which roll the tube and curl the sleeve onto the bundle, in test_hifi_mesh_parts."""
    moulded = with_closure(config, 0.0)
    moulded["hifi"]["build"] = {**moulded["hifi"]["build"], "sleeve_closure": 0.0}
    return {name: build_mesh(case, moulded, RES) for name, case in config["cases"].items()}


def _radius(X):
    return np.hypot(X[..., 1], X[..., 2])


def _phi(X):
    return np.arctan2(-X[..., 2], X[..., 1])


def test_every_case_builds_with_consistent_counts(config, meshes):
    assert set(meshes) == set(config["cases"])
    for name, m in meshes.items():
        n_w, n_el = m.wire_nodes.shape
        assert n_w == 19 and n_el == RES["wire_elements"] + 1
        assert m.beam_conn.shape == (19 * RES["wire_elements"], 2)
        assert np.array_equal(np.unique(m.wire_nodes), np.arange(19 * n_el))   # wires first
        assert m.shell_conn.min() >= m.wire_nodes.size and m.shell_conn.max() < m.n_nodes
        assert np.unique(m.shell_conn).size == m.n_nodes - m.wire_nodes.size   # no orphan nodes
        n_cov = RES["tube_circ"] * RES["tube_axial"] if "fabric" not in name else \
            5 * (RES["tube_circ"] // 4) * RES["tube_axial"]
        assert np.sum(m.shell_group == GROUP_COVERING) == n_cov
        assert np.sum(m.shell_group == GROUP_END_LEFT) == RES["end_axial"] * RES["end_circ"]
        ns = m.shell_conn.shape[0]
        for arr, shape in ((m.shell_part, (ns,)), (m.shell_thickness, (ns,)), (m.shell_axis, (ns, 3))):
            assert arr.shape == shape
        assert m.beam_conn.shape[0] <= 700 and ns <= 512          # quick budget (half-lap 288 + 4 x 56)
        assert np.all(element_sizes(m)["shell_area"] > 0.0)


def test_wire_packing(config, meshes):
    m = meshes["cwb19_t2_closed"]
    d = 1.40 * 1.001
    yz = m.wire_yz
    r = np.sort(np.hypot(yz[:, 0], yz[:, 1]))
    np.testing.assert_allclose(r, np.r_[0.0, [d] * 6, [np.sqrt(3) * d] * 6, [2 * d] * 6], atol=1e-12)
    gaps = [np.hypot(*(yz[i] - yz[j])) - m.wire_radius[i] - m.wire_radius[j]
            for i, j in itertools.combinations(range(19), 2)]
    assert min(gaps) == pytest.approx(1e-3 * 1.40, rel=1e-6)      # packed, no initial overlap
    # beams along x from -100 to 100, at their cross-section position
    X = m.X[m.wire_nodes]
    np.testing.assert_allclose(X[:, 0, 0], -100.0)
    np.testing.assert_allclose(X[:, -1, 0], 100.0)
    np.testing.assert_allclose(X[:, :, 1:], np.repeat(yz[:, None, :], X.shape[1], axis=1))
    assert np.all(m.wire_type == 2) and np.allclose(m.wire_radius, 0.7)


def test_mixed_types_are_spread(meshes):
    m = meshes["cwb10t1_9t2_fabric"]
    assert np.sum(m.wire_type == 1) == 10 and np.sum(m.wire_type == 2) == 9
    r = np.round(np.hypot(m.wire_yz[:, 0], m.wire_yz[:, 1]), 6)
    ring1 = m.wire_type[(r > 0) & (r < 1.5)]
    ring2 = m.wire_type[r > 1.5]
    assert sorted(np.bincount(ring1)[1:]) == [3, 3] and sorted(np.bincount(ring2)[1:]) == [6, 6]
    np.testing.assert_allclose(m.wire_radius, np.where(m.wire_type == 1, 0.625, 0.7))
    gaps = [np.hypot(*(m.wire_yz[i] - m.wire_yz[j])) - m.wire_radius[i] - m.wire_radius[j]
            for i, j in itertools.combinations(range(19), 2)]
    assert min(gaps) > 0.0


def test_38_wires_need_the_larger_tube(config):
    case = {"wires": {"wire_type2": 38}, "covering": "open_tube", "taping": "coarse"}
    with pytest.raises(ValueError, match="do not fit"):
        build_mesh(case, config, RES)
    m = build_mesh({**case, "d_i": 15.0, "d_o": 18.4}, config, RES)
    assert m.n_wires == 38
    extra = m.wire_yz[-1]
    phi = np.degrees(np.arctan2(-extra[1], extra[0]))           # the lowest site, turned with the pack
    assert phi == pytest.approx(150.0 + config["hifi"]["build"]["pack_angle"])
    assert np.hypot(*extra) == pytest.approx(2 * np.sqrt(3) * 1.4014)
    assert m.info["clearance"] > 0


def test_wires_inside_covering_with_clearance(meshes):
    for name, m in meshes.items():
        cov = m.shell_group == GROUP_COVERING
        P = m.X[m.shell_conn[cov]]
        inner_face = _radius(P) - 0.5 * m.shell_thickness[cov][:, None]
        r_wire = np.hypot(m.wire_yz[:, 0], m.wire_yz[:, 1]) + m.wire_radius
        assert r_wire.max() == pytest.approx(m.info["bundle_radius"])
        assert inner_face.min() - r_wire.max() > 0.8, name          # 1.85 tubes, 0.9 fabric
    m = meshes["cwb19_t2_closed"]
    tube = m.X[np.unique(m.shell_conn[m.shell_part == PART_TUBE])]
    np.testing.assert_allclose(_radius(tube), 6.2)
    assert tube[:, 0].min() == pytest.approx(-76.2) and tube[:, 0].max() == pytest.approx(76.2)
    np.testing.assert_allclose(m.shell_thickness[m.shell_part == PART_TUBE], 1.7)   # faces d_i/2, d_o/2


def test_tape_radii_and_ties(meshes):
    m = meshes["cwb19_t2_open_coarse"]
    assert m.info["tape_radius"] == pytest.approx(7.1)                 # eq. 5
    r_tie = _radius(m.X[m.tie_nodes])
    np.testing.assert_allclose(r_tie[m.tie_target == TIE_COVERING], 7.1)
    np.testing.assert_allclose(r_tie[m.tie_target == TIE_WIRES], m.info["bundle_radius"] + 0.05)
    x_wires = m.X[m.tie_nodes[m.tie_target == TIE_WIRES], 0]
    assert np.all(np.abs(x_wires) > 76.2)                              # bare wires beyond the tube
    tape_el = m.shell_part == PART_TAPE
    assert np.unique(m.shell_conn[tape_el]).size == m.tie_nodes.size
    assert m.tie_area.sum() == pytest.approx(element_sizes(m)["shell_area"][tape_el].sum())
    # end bands span a = 38.1 from each sample end
    ends = np.unique(m.shell_conn[(m.shell_group >= GROUP_END_LEFT)])
    xs = m.X[ends, 0]
    assert np.sort(np.unique(np.round(np.abs(xs), 9)))[[0, -1]] == pytest.approx([61.9, 100.0])


def test_coarse_helix_pitch_and_coverage(meshes):
    m = meshes["cwb19_t2_open_coarse"]
    helix = np.flatnonzero(m.shell_group == GROUP_HELIX)
    assert m.info["helix"]["pitch"] == pytest.approx(2 * 18.8)         # eq. 5: p = 2 w
    # two whole pitches in the middle of the tube: 50 % covered, by one layer
    cov = coverage(m, helix, (-37.6, 37.6), n_x=160, n_phi=72)
    assert cov.max() == 1
    assert cov.mean() == pytest.approx(0.5, abs=0.01)
    # the strip stays between the end bands
    x = m.X[np.unique(m.shell_conn[helix]), 0]
    assert x.min() == pytest.approx(-61.9) and x.max() == pytest.approx(61.9)


def test_helix_geometry_from_nodes(meshes):
    for name, p in (("cwb19_t2_open_coarse", 37.6), ("cwb19_t2_open_halflap", 9.4)):
        m = meshes[name]
        conn = m.shell_conn[m.shell_group == GROUP_HELIX]
        # nodes 0 -> 3 run along the strip (u) at fixed eta: dx/dphi = p / (2 pi)
        a, b = m.X[conn[:, 0]], m.X[conn[:, 3]]
        dphi = np.angle(np.exp(1j * (_phi(b) - _phi(a))))
        np.testing.assert_allclose((b[:, 0] - a[:, 0]) / dphi, p / (2 * np.pi), rtol=1e-9)
        # across the strip (0 -> 1) the axial width sums to w
        w = (m.X[conn[:, 1], 0] - m.X[conn[:, 0], 0]).reshape(RES["tape_width"], -1).sum(axis=0)
        np.testing.assert_allclose(w, 18.8)
        # material axis along the helix tangent
        t = (b - a) / np.linalg.norm(b - a, axis=1)[:, None]
        ax = m.shell_axis[m.shell_group == GROUP_HELIX]
        assert np.min(np.abs(np.sum(t * ax, axis=1))) > 0.99


def test_halflap_covers_the_tube_twice(meshes):
    m = meshes["cwb19_t2_open_halflap"]
    helix = np.flatnonzero(m.shell_group == GROUP_HELIX)
    assert m.info["helix"]["pitch"] == pytest.approx(9.4)
    cov = coverage(m, helix, (-61.9 + 9.4, 61.9 - 9.4), n_x=200, n_phi=48)
    assert cov.min() >= 1                                  # 100 % of the taped length
    inner = coverage(m, helix, (-61.9 + 18.8, 61.9 - 18.8), n_x=160, n_phi=48)
    assert np.all(inner == 2)                              # two layers: never builds up
    # front half on the tube (r), back half on the previous wrap (r + t)
    r = _radius(m.X[m.tie_nodes])
    assert np.any(m.tie_target == TIE_TAPE)
    np.testing.assert_allclose(r[m.tie_target == TIE_TAPE].max(), 7.2)
    assert r[m.tie_target == TIE_TAPE].min() >= 7.125 - 1e-12       # first-turn ramp >= half way
    helix_nodes = np.unique(m.shell_conn[helix])
    assert _radius(m.X[helix_nodes]).max() == pytest.approx(7.2)


@pytest.mark.parametrize("name", ["cwb19_t2_open_halflap", "cwb19_t2_open_coarse"])
def test_every_tie_candidate_finds_its_target(meshes, name):
    """make_ties finds a target for every tie node: the wrap underneath (tape on tape), the
    covering, the wires."""
    from harnesspipe.fe.contact.tie_targets import make_ties
    m = meshes[name]
    tape_el = m.shell_part == PART_TAPE
    tape, cov = m.shell_conn[tape_el], m.shell_conn[~tape_el]
    targets = {TIE_TAPE: dict(quads=tape, quad_t=np.full(len(tape), 0.1), tol=0.15),
               TIE_COVERING: dict(quads=cov, quad_t=m.shell_thickness[~tape_el], tol=0.3),
               TIE_WIRES: dict(seg=m.beam_conn, seg_r=m.wire_radius[m.beam_wire], tol=0.5)}
    assert np.any(m.tie_target == TIE_TAPE) == name.endswith("halflap")
    for code, kw in targets.items():
        sel = m.tie_target == code
        if not sel.any():
            continue
        nodes = m.tie_nodes[sel]
        ties_q, ties_s = make_ties(m.X, nodes, m.tie_area[sel], tape_half_t=0.05, **kw)
        ties = ties_q if "quads" in kw else ties_s
        assert np.array_equal(np.sort(ties["tie_node"]), np.sort(nodes)), (name, code)
        if code == TIE_TAPE:     # another wrap's quad, t (t/2 at the step) below the node
            assert not np.any(tape[ties["tie_quad"]] == ties["tie_node"][:, None])
            d = np.linalg.norm(ties["tie_off"], axis=1)
            assert d.max() <= 0.1 + 1e-9 and d.min() >= 0.03, name


def test_halflap_back_half_over_previous_wrap(config):
    """Every TIE_TAPE node has a node of another wrap at the same (x, phi), t_tape (0.1)
    radially below it (t/2 at the stepped centre line and back edge), at both resolutions."""
    for res in (RES, "default"):
        m = build_mesh(config["cases"]["cwb19_t2_open_halflap"], with_closure(config, 0.0), res)
        top = m.X[m.tie_nodes[m.tie_target == TIE_TAPE]]
        below = m.X[np.unique(m.shell_conn[m.shell_group == GROUP_HELIX])]
        same = (np.abs(top[:, None, 0] - below[None, :, 0]) < 1e-9) & \
            (np.abs(np.angle(np.exp(1j * (_phi(top)[:, None] - _phi(below)[None, :])))) < 1e-9)
        dr = np.where(same, _radius(top)[:, None] - _radius(below)[None, :], np.inf)
        dr = np.where(dr > 1e-9, dr, np.inf).min(axis=1)      # the node itself excluded
        # (between t/2 and t over the first turn's centre line, still ramping up)
        assert np.all((dr >= 0.05 - 1e-9) & (dr <= 0.1 + 1e-9)), res
        assert np.sum(np.isclose(dr, 0.1)) >= 0.3 * dr.size
        assert m.info["helix"]["elements_per_turn"] >= 5
        assert np.all(element_sizes(m)["shell_char_length"] > 0.5)


def test_fabric_spiral(meshes):
    m = meshes["cwb19_t2_fabric"]
    fab = m.shell_part == PART_FABRIC
    assert not np.any(m.shell_part == PART_TUBE)
    nodes = np.unique(m.shell_conn[fab])
    X = m.X[nodes]
    ring = X[np.isclose(X[:, 0], -76.2)]
    order = np.argsort(_radius(ring))
    ph = np.unwrap(_phi(ring[order]))
    assert ph[-1] - ph[0] == pytest.approx(1.25 * 2 * np.pi)            # 1.25 wraps
    assert _radius(ring).min() == pytest.approx(4.7) and _radius(ring).max() == pytest.approx(5.3)
    # r linear in the wound angle
    np.testing.assert_allclose(_radius(ring[order]), 4.7 + 0.6 * (ph - ph[0]) / (2.5 * np.pi), atol=1e-12)
    np.testing.assert_allclose(m.shell_thickness[fab], 0.6)
    np.testing.assert_allclose(m.shell_axis[fab], np.tile([1.0, 0.0, 0.0], (fab.sum(), 1)))
    # overlap: the outer layer lies over the inner one, same angles, 0.48 mm further out
    inner, outer = m.X[m.fabric_overlap_inner], m.X[m.fabric_overlap_outer]
    assert inner.shape == outer.shape
    k_in = np.lexsort((np.round(_phi(inner), 9), np.round(inner[:, 0], 9)))
    k_out = np.lexsort((np.round(_phi(outer), 9), np.round(outer[:, 0], 9)))
    np.testing.assert_allclose(_radius(outer[k_out]) - _radius(inner[k_in]), 0.48, atol=1e-12)
    np.testing.assert_allclose(_phi(outer[k_out]), _phi(inner[k_in]), atol=1e-12)
    assert np.abs(_phi(inner)).max() <= 0.25 * np.pi + 1e-12                 # centred on the top


def test_outward_normals_and_tangent_axes(meshes):
    for name, m in meshes.items():
        n = shell_normals(m)
        c = m.X[m.shell_conn].mean(axis=1)
        radial = np.column_stack([np.zeros(len(c)), c[:, 1], c[:, 2]])
        radial /= np.linalg.norm(radial, axis=1)[:, None]
        assert np.all(np.sum(n * radial, axis=1) > 0.3), name
        np.testing.assert_allclose(np.linalg.norm(m.shell_axis, axis=1), 1.0)
        assert np.abs(np.sum(n * m.shell_axis, axis=1)).max() < 1e-12, name   # in the tangent plane
        tube = m.shell_part == PART_TUBE
        assert np.all(m.shell_axis[tube] == [1.0, 0.0, 0.0])


def test_open_tube_cut(meshes):
    closed, opened = meshes["cwb19_t2_closed"], meshes["cwb19_t2_open_coarse"]
    assert closed.cut_pairs.shape == (0, 2)
    pairs = opened.cut_pairs
    assert pairs.shape == (RES["tube_axial"] + 1, 2)
    np.testing.assert_allclose(opened.X[pairs[:, 0]], opened.X[pairs[:, 1]])   # duplicated
    assert np.all(pairs[:, 0] != pairs[:, 1])
    np.testing.assert_allclose(opened.X[pairs[:, 0], 1:], [[0.0, -6.2]] * len(pairs),   # at the side
                               atol=1e-12)
    tube = opened.shell_conn[opened.shell_part == PART_TUBE]
    for a, b in pairs:                                                          # no element bridges it
        assert not np.any(np.isin(a, tube) & np.any(tube == b, axis=1) & np.any(tube == a, axis=1))
    n_closed = np.unique(closed.shell_conn[closed.shell_part == PART_TUBE]).size
    n_open = np.unique(tube).size
    assert n_open - n_closed == RES["tube_axial"] + 1


def test_rollers_tangent_to_outer_surface(meshes):
    for name, m in meshes.items():
        c = m.rollers["centres"]
        assert m.rollers["radius"] == 2.5 and np.allclose(m.rollers["axis"], [0, 0, 1])
        np.testing.assert_allclose(c[:, 0], [-63.5, 63.5, 0.0])
        assert c[0, 1] < 0 < c[2, 1] and np.allclose(c[:, 2], 0.0)
        # no initial penetration: outer faces of all shell nodes and all wire surfaces
        n = shell_normals(m)
        for k, pin in enumerate(c):
            el = np.abs(m.X[m.shell_conn][:, :, 0].mean(axis=1) - pin[0]) < 15.0
            face = m.X[m.shell_conn[el]] + 0.5 * m.shell_thickness[el][:, None, None] * n[el][:, None, :]
            d = np.hypot(face[..., 0] - pin[0], face[..., 1] - pin[1])
            assert d.min() >= 2.5 - 1e-6, (name, k)
    # touching: values of the outermost surface
    closed = meshes["cwb19_t2_closed"]
    np.testing.assert_allclose(closed.rollers["centres"][:, 1], [-(7.15 + 2.5), -(7.15 + 2.5), 7.05 + 2.5])
    fab = meshes["cwb19_t2_fabric"]
    top = 4.7 + 0.6 * 2.25 / 2.5 + 0.3                                           # outer layer at the top
    np.testing.assert_allclose(fab.rollers["centres"][:, 1], [-(5.3 + 0.1 + 2.5)] * 2 + [top + 2.5])


def test_deterministic_and_vtu(config, meshes, tmp_path):
    case = config["cases"]["cwb19_t2_open_halflap"]
    a, b = build_mesh(case, config, RES), build_mesh(case, config, RES)
    for f in ("X", "beam_conn", "shell_conn", "shell_axis", "tie_nodes", "tie_area", "cut_pairs"):
        assert np.array_equal(getattr(a, f), getattr(b, f)), f
    mesh = to_meshio(a)
    assert mesh.cells[0].type == "line" and mesh.cells[1].type == "quad"
    path = tmp_path / "m.vtu"
    write_vtu(path, a, a.X + 1.0)
    import meshio
    back = meshio.read(path)
    assert back.points.shape == a.X.shape
    np.testing.assert_allclose(back.points, a.X + 1.0)
    sizes = element_sizes(a)
    np.testing.assert_allclose(sizes["beam_length"], 200.0 / RES["wire_elements"])
    assert np.all(sizes["shell_char_length"] > 0.5)


def test_default_resolution_and_options(config):
    case = config["cases"]["cwb19_t2_open_coarse"]
    m = build_mesh(case, config, "default")
    assert 900 <= m.beam_conn.shape[0] <= 1100 and m.shell_conn.shape[0] <= 900
    top = build_mesh(case, config, {**RES, "cut_at": "top"})
    np.testing.assert_allclose(top.X[top.cut_pairs[:, 0], 1], 6.2)
    bottom = build_mesh(case, config, {**RES, "cut_at": "bottom"})
    np.testing.assert_allclose(bottom.X[bottom.cut_pairs[:, 0], 1], -6.2)
    wires = build_mesh(case, config, {**RES, "end_tape": "wires"})
    assert np.all(wires.tie_target[np.isin(wires.tie_nodes, np.unique(
        wires.shell_conn[wires.shell_group >= GROUP_END_LEFT]))] == TIE_WIRES)
    with pytest.raises(ValueError):
        build_mesh({**case, "taping": "spiral"}, config, RES)


def test_taped_wire_bundle_without_covering(config):
    case = {"wires": {"wire_type2": 19}, "covering": "none", "taping": "halflap"}
    m = build_mesh(case, config, RES)
    assert not np.any(m.shell_group == GROUP_COVERING) and not np.any(m.shell_group == GROUP_END_LEFT)
    x = m.X[np.unique(m.shell_conn), 0]
    assert x.min() == pytest.approx(-100.0) and x.max() == pytest.approx(100.0)
    r = _radius(m.X[m.tie_nodes])
    np.testing.assert_allclose(r[m.tie_target == TIE_WIRES].min(), m.info["bundle_radius"] + 0.05)
    assert set(np.unique(m.tie_target)) == {TIE_WIRES, TIE_TAPE}
    assert np.all(m.rollers["centres"][:2, 1] < -(m.info["bundle_radius"] + 2.5))
