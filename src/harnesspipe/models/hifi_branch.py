"""High-fidelity (mesoscale) model of the Y-shaped branching harness (Sec. 5, Figs. 16-18a).

The hi-fi counterpart of :mod:`harnesspipe.models.branch`, on the same Fig. 16 geometry
(:class:`harnesspipe.models.branch.Geometry`: branch point at the origin, harness plane
x-y, S1 along -x, S2 along +x, S3 at -30 deg) and built from the parts of the hi-fi
three-point model (:mod:`harnesspipe.models.hifi`): every wire a fibre beam with the
Table 1 properties, the open tubes as equivalent shells with their cut, the coarse tape
helix on the tubes, wire-wire contact with the friction of eq. 6, wire-covering contact,
cohesive tape (eqs. 7-10) and explicit dynamics with mass scaling.

Construction (choices where Fig. 16/17 are not explicit, each an assumption):

* Each CWB with its TWB portions is one straight segment meshed by
  :func:`harnesspipe.models.hifi_mesh.build_mesh` (S1: ``cwb38_t2_open_coarse``, the
  15 mm tube; S2, S3: ``cwb19_t2_open_coarse``), with the tube of length L_k and the wires
  extending e_k beyond both tube ends: e_1 = l1, e_2 = Le (the strand pulls at the end of
  S2's taped tail, l2 + L2 + Le from the branch point, as in the ROM), e_3 = l3.  The
  segment's end bands (tape bonding the tube ends to the wires, Sec. 2.2) reach
  ``over_tube`` onto the tube, as in the three-point model; on the joint side they are the
  TWB tape of the break-out joint.
* Break-out: S1's 38 wires end at the branch point.  The 19 on S3's side (lowest y) run
  on into S3, the others into S2, each matched to a position of the branch's bundle by
  least total distance; S2 and S3 start ``bridge`` mm from the branch point (where their
  bundles have separated: 2 s sin 15 deg > 2 bundle radii needs s > 14 mm), their wires
  and joint-side tape closer in are cut away, and each wire is continued by
  ``bridge_elements`` straight beams across the gap.  These bridges are bare wires: the
  multiple half-lap layers on the joint itself are not meshed, and the bridges take no
  part in wire-wire contact (they cross one another in the break-out).
* Zip ties: every node of S1 and S3 from ``clamp_width`` inside the far tube end
  outwards is fixed.
* Aramid strand: a straight spring of stiffness EA/H (the ROM's strand) from the
  crosshead, H = 625 above the S2 tip (+y in plane, +z out of plane), to the centroid of
  the tip nodes of S2's wires, its tension shared equally among them.  The crosshead
  travels 50 mm at the test's constant rate (1 mm/s, Sec. 2.3), reached from rest over
  the first ``explicit.rate_ramp`` of the run, as the three-point feeder
  (:func:`harnesspipe.fe.solvers.central_difference.rate_ramp`); the contacts' eq. 6
  friction sees the physical slip rates (``time_scale``).
* Interface values: the config's ``branch.hifi.interface`` (default: the paper's
  calibrated values, so that the comparison does not wait for our calibration chain).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from harnesspipe.fe.solvers.central_difference import DynamicsSettings, integrate, ramp_share, rate_ramp
from harnesspipe.models import hifi_mesh as hm
from harnesspipe.models.branch import LOAD_CASES, Geometry
from harnesspipe.models.hifi_bundle import (BundleSystem, HifiInputs, quasi_static_ratio,
                                            shell_materials)

Z = np.array([0.0, 0.0, 1.0])


@dataclass
class YMesh:
    """The merged mesh (the attributes :class:`harnesspipe.models.hifi_bundle.BundleSystem` reads)."""

    X: np.ndarray
    beam_conn: np.ndarray
    beam_wire: np.ndarray
    wire_type: np.ndarray
    wire_radius: np.ndarray
    n_wire_nodes: int
    shell_conn: np.ndarray
    shell_part: np.ndarray
    shell_group: np.ndarray
    shell_thickness: np.ndarray
    shell_axis: np.ndarray
    shell_segment: np.ndarray     # (n_shell,) 0, 1, 2 = S1, S2, S3
    cut_pairs: np.ndarray
    cut_next: np.ndarray
    tie_nodes: np.ndarray
    tie_target: np.ndarray
    tie_area: np.ndarray
    clamped: np.ndarray           # node ids fixed by the zip ties
    tip: np.ndarray               # S2's wire end nodes (the strand's attachment)
    s2_wire: np.ndarray           # nodes along S2's centre-most wire (bent shape)
    bridge_beams: np.ndarray      # (n_beam,) bool
    segments: list = field(default_factory=list)   # per segment: case, direction, distance range
    fabric_overlap_inner: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    fabric_overlap_outer: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    @property
    def n_nodes(self) -> int:
        return self.X.shape[0]

    @property
    def n_wires(self) -> int:
        return self.wire_radius.size


def _segment_config(config: dict, L: float, e: float) -> dict:
    """The config with the three-point sample replaced by one segment: tube L, wires e beyond.
    The slit tubes stay as moulded (build ``tube_closure`` 0): the joint's wires leave them
    through the slit, which a tube rolled shut onto its bundle would not have."""
    tp = config["three_point"]
    over_tube = tp["taped_end"] - 0.5 * (tp["sample_length"] - tp["tube_length"])
    seg = {**tp, "tube_length": L, "sample_length": L + 2.0 * e, "taped_end": e + over_tube}
    hifi = {**config["hifi"], "build": {**config["hifi"]["build"], "tube_closure": 0.0}}
    return {**config, "three_point": seg, "hifi": hifi}


def _segment_resolution(res: dict, config: dict, length: float, tube: float) -> dict:
    """The profile's resolution scaled from the three-point sample to the segment's lengths;
    the tubes' cut on the segment's local top, i.e. out of the harness plane (:func:`_frame`)."""
    tp = config["three_point"]
    out = {"cut_at": "top", **res}
    out["wire_elements"] = max(2, round(res["wire_elements"] * length / tp["sample_length"]))
    out["tube_axial"] = max(2, round(res["tube_axial"] * tube / tp["tube_length"]))
    return out


def _frame(d):
    """Local (axial, up, side) of a segment: x -> d, y -> z (the cut on top, out of the
    harness plane), z -> d x z."""
    return np.stack([d, Z, np.cross(d, Z)])


class _Piece:
    """One segment's mesh placed in the harness, with what was cut away removed."""

    def __init__(self, mesh, d, s_centre, s_min):
        self.mesh, self.d = mesh, d
        s = mesh.X[:, 0] + s_centre                         # distance from the branch point
        self.X = s_centre * d + mesh.X @ _frame(d)
        keep = s >= s_min - 1e-9
        nw = mesh.n_wire_nodes
        self.wire_keep = keep[:nw]
        shell_ok = np.all(keep[mesh.shell_conn], axis=1)
        used = np.zeros(mesh.n_nodes, bool)
        used[np.unique(mesh.shell_conn[shell_ok])] = True
        self.shell_ok = shell_ok
        self.shell_nodes = np.flatnonzero(used)


def build_mesh(config: dict, resolution: dict, geometry: Geometry, bridge: float = 15.0,
               bridge_elements: int = 2, clamp_width: float = 5.0) -> YMesh:
    """The Y harness (module docstring); ``resolution``: the hi-fi profile's resolution."""
    g = geometry
    cases = {**config["cases"], **config["hifi"].get("extra_cases", {})}
    a = math.radians(g.angle_deg)
    dirs = [np.array([-1.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]),
            np.array([math.cos(a), -math.sin(a), 0.0])]
    spec = [("cwb38_t2_open_coarse", g.L1, g.l1, g.l1, 0.0),
            ("cwb19_t2_open_coarse", g.L2, g.l2, g.Le, bridge),
            ("cwb19_t2_open_coarse", g.L3, g.l3, g.l3, bridge)]
    pieces = []
    for (case, L, l_joint, e, s_min), d in zip(spec, dirs):
        if l_joint - e > 1e-9 and s_min == 0.0:
            raise ValueError(f"branch segment {case}: wires must reach the branch point")
        cfg = _segment_config(config, L, e)
        res = _segment_resolution(resolution, config, L + 2 * e, L)
        mesh = hm.build_mesh(cases[case], cfg, res)
        s_centre = l_joint + 0.5 * L
        pieces.append(_Piece(mesh, d, s_centre, s_min))
    return _merge(pieces, spec, bridge_elements, clamp_width)


def _routes(p1, p2, p3) -> dict:
    """S1 wire -> (branch 1 = S2 or 2 = S3, wire of that branch): the 19 wires on S3's side
    (lowest y at the branch point) go to S3; within a branch, by least total distance between
    the two bundles' positions relative to their centroids."""
    ends1 = p1.X[p1.mesh.wire_nodes[:, 0]]                  # at the branch point (s = 0)
    to3 = np.argsort(ends1[:, 1])[:p3.mesh.n_wires]
    to2 = np.setdiff1d(np.arange(p1.mesh.n_wires), to3)
    route = {}
    for branch, piece, idx in ((1, p2, to2), (2, p3, to3)):
        first = np.array([row[piece.wire_keep[row]][0] for row in piece.mesh.wire_nodes])
        rel_a = ends1[idx] - ends1[idx].mean(axis=0)
        rel_b = piece.X[first] - piece.X[first].mean(axis=0)
        ia, ib = linear_sum_assignment(np.linalg.norm(rel_a[:, None, :] - rel_b[None, :, :], axis=2))
        route.update({int(idx[i]): (branch, int(j)) for i, j in zip(ia, ib)})
    return route


def _join_wires(pieces, n_bridge) -> dict:
    """Every wire as one chain: S1 from its zip tie to the branch point, ``n_bridge`` straight
    beams across the gap, then its branch to the end.  Node ids from 0 (wires first)."""
    p1 = pieces[0]
    m1 = p1.mesh
    n_s1 = m1.wire_nodes.shape[1]
    X, conn, body, bridge, seg = [], [], [], [], []
    maps = [{}, {}, {}]                                      # per piece: local node -> global id
    tip, s2_line = [], None

    def add(x, piece, node=None):
        if node is not None:
            maps[piece][node] = len(X)
        X.append(x)
        seg.append(piece)
        return len(X) - 1

    for w, (branch, j) in sorted(_routes(*pieces).items()):
        piece = pieces[branch]
        row = piece.mesh.wire_nodes[j]
        row = row[piece.wire_keep[row]]
        ids = [add(p1.X[node], 0, node) for node in m1.wire_nodes[w][::-1]]
        A, B = p1.X[m1.wire_nodes[w, 0]], piece.X[row[0]]
        ids += [add(A + (B - A) * k / n_bridge, -1) for k in range(1, n_bridge)]
        ids += [add(piece.X[node], branch, node) for node in row]
        ids = np.array(ids)
        conn.append(np.column_stack([ids[:-1], ids[1:]]))
        body.append(np.full(ids.size - 1, w))
        flag = np.zeros(ids.size - 1, bool)
        flag[n_s1 - 1:n_s1 - 1 + n_bridge] = True
        bridge.append(flag)
        if branch == 1:
            tip.append(ids[-1])
            r = float(np.hypot(*piece.mesh.wire_yz[j]))
            if s2_line is None or r < s2_line[0]:
                s2_line = (r, ids[n_s1 - 1 + n_bridge:])
    return {"X": X, "conn": np.concatenate(conn), "body": np.concatenate(body),
            "bridge": np.concatenate(bridge), "seg": seg, "maps": maps,
            "tip": np.array(tip, dtype=np.int64), "s2_line": np.asarray(s2_line[1], dtype=np.int64)}


def _place_shells(pieces, wires) -> dict:
    """The shells of the three segments, numbered after the wires (appends to
    ``wires["X"]`` / ``["seg"]``), with their cut pairs and tie candidates."""
    out = {k: [] for k in ("conn", "part", "group", "thick", "axis", "segment", "cut_pairs",
                           "cut_next", "tie_nodes", "tie_target", "tie_area")}
    X, seg = wires["X"], wires["seg"]
    for k, piece in enumerate(pieces):
        m = piece.mesh
        gid = np.full(m.n_nodes, -1)
        for node in piece.shell_nodes:
            gid[node] = len(X)
            X.append(piece.X[node])
            seg.append(k)
        ok = piece.shell_ok
        out["conn"].append(gid[m.shell_conn[ok]])
        out["part"].append(m.shell_part[ok])
        out["group"].append(m.shell_group[ok])
        out["thick"].append(m.shell_thickness[ok])
        out["axis"].append(m.shell_axis[ok] @ _frame(piece.d))
        out["segment"].append(np.full(int(ok.sum()), k))
        if m.cut_pairs.size:
            out["cut_pairs"].append(gid[m.cut_pairs])
            out["cut_next"].append(gid[m.cut_next])
        keep = np.isin(m.tie_nodes, piece.shell_nodes)
        out["tie_nodes"].append(gid[m.tie_nodes[keep]])
        out["tie_target"].append(m.tie_target[keep])
        out["tie_area"].append(m.tie_area[keep])
    return {k: np.concatenate(v) for k, v in out.items()}


def _merge(pieces, spec, n_bridge, clamp_width) -> YMesh:
    wires = _join_wires(pieces, n_bridge)
    nw = len(wires["X"])
    sh = _place_shells(pieces, wires)
    X = np.array(wires["X"])
    node_seg = np.array(wires["seg"])
    clamped = []                       # zip ties: S1 and S3 from clamp_width inside the far tube end out
    for k in (0, 2):
        _, L, l_joint, _, _ = spec[k]
        clamped.append(np.flatnonzero((node_seg == k) & (X @ pieces[k].d >= l_joint + L - clamp_width)))
    m1 = pieces[0].mesh
    return YMesh(
        X=X, beam_conn=wires["conn"].astype(np.int64), beam_wire=wires["body"].astype(np.int64),
        wire_type=m1.wire_type.astype(int), wire_radius=m1.wire_radius.astype(float), n_wire_nodes=nw,
        shell_conn=sh["conn"].astype(np.int64), shell_part=sh["part"], shell_group=sh["group"],
        shell_thickness=sh["thick"], shell_axis=sh["axis"], shell_segment=sh["segment"],
        cut_pairs=sh["cut_pairs"], cut_next=sh["cut_next"], tie_nodes=sh["tie_nodes"],
        tie_target=sh["tie_target"], tie_area=sh["tie_area"], clamped=np.unique(np.concatenate(clamped)),
        tip=wires["tip"], s2_wire=wires["s2_line"], bridge_beams=wires["bridge"],
        segments=[{"case": s[0], "direction": p.d.tolist(), "tube": (s[2], s[2] + s[1])}
                  for s, p in zip(spec, pieces)])


class YSystem(BundleSystem):
    """The hi-fi Y harness under the strand pull; the system protocol of
    :mod:`harnesspipe.fe.solvers.central_difference`.  The strand's force on the tip nodes is the driven
    family ``pin_contact`` (its elastic energy is credited by the crosshead's work).

    The nodal mass factor may reach 64 (three-point model: 16): the corner nodes of the
    tubes' cut edges at the tube ends near the joint (a quarter of an element's mass)
    would otherwise set the step, 11 % below the wires' (added mass unchanged, 36 %).
    """

    node_scale_cap = 64.0

    def __init__(self, mesh: YMesh, inp: HifiInputs, geometry: Geometry, load_case: str,
                 stroke: float):
        self.cases = {**inp.config["cases"], **inp.config["hifi"].get("extra_cases", {})}
        super().__init__(mesh, inp)
        self.free[mesh.clamped] = False
        self.ww_skip = mesh.bridge_beams
        self.k_strand = geometry.strand_EA / geometry.H
        self.H, self.stroke = geometry.H, float(stroke)
        self.ramp = float(inp.explicit["rate_ramp"])      # the crosshead at the test's rate (Sec. 2.3)
        self.time_scale = float(inp.explicit["t_phys"]) / (self.T * ramp_share(self.ramp))
        self.e = LOAD_CASES[load_case].astype(float)
        self.head0 = self.x[mesh.tip].mean(axis=0) + self.H * self.e
        self.head = self.head0.copy()
        self.head_prev = self.head0.copy()
        self.f_head = np.zeros(3)          # force of the strand ON the crosshead
        self.f_head_prev = np.zeros(3)
        self.impulse = self.impulse_u = self.impulse_time = self.u_prev = 0.0

    def _shell_materials(self):
        """The tube of each segment with its own case (15 mm tube on S1, 10 mm on S2, S3)."""
        per_segment = [shell_materials(self.mesh, HifiInputs(
            self.cases[seg["case"]], self.inp.config, self.inp.interface, self.inp.explicit,
            self.inp.resolution, self.inp.coverings)) for seg in self.mesh.segments]
        n = self.mesh.shell_conn.shape[0]
        out = [np.zeros((n, max(m.shape[1] for m, _, _ in per_segment))), np.zeros(n), np.zeros(n)]
        for k, (mat, thick, rho) in enumerate(per_segment):
            sel = self.mesh.shell_segment == k
            out[0][sel, :mat.shape[1]] = mat[sel]
            out[1][sel] = thick[sel]
            out[2][sel] = rho[sel]
        return tuple(out)

    def displacement(self) -> float:
        return float((self.head - self.head0) @ self.e)

    def tension(self) -> float:
        return float(np.linalg.norm(self.f_head))

    def _move_loading(self, t):
        self.head_prev[...] = self.head
        S, _ = rate_ramp(t / self.T, self.ramp)
        self.head[...] = self.head0 + self.stroke * S * self.e

    def _loading_forces(self, v, dt, F) -> int:
        """The strand: tension k (l - H) >= 0 from the crosshead on the tip nodes' centroid,
        shared equally among them."""
        tip = self.mesh.tip
        r = self.head - self.x[tip].mean(axis=0)
        length = float(np.linalg.norm(r))
        T = max(0.0, self.k_strand * (length - self.H))
        f = T * r / length
        F[3, tip, :3] += f / tip.size
        self.f_head = -f
        return int(T > 0.0)

    def external_work(self, t0, t1) -> float:
        """Work of the crosshead on the system (trapezoidal); the step's impulse of the
        tension for :meth:`observe`."""
        w = -0.5 * float((self.f_head_prev + self.f_head) @ (self.head - self.head_prev))
        T, T_prev = self.tension(), float(np.linalg.norm(self.f_head_prev))
        u = self.displacement()
        self.impulse += 0.5 * (t1 - t0) * (T + T_prev)
        self.impulse_u += 0.5 * (t1 - t0) * (u + self.u_prev)
        self.impulse_time += t1 - t0
        self.u_prev = u
        self.f_head_prev = self.f_head.copy()
        return w

    def observe(self, t) -> dict:
        """History row: ``displacement_mm`` (crosshead) and ``force_N`` (strand tension) are
        means since the previous row, as a load cell averages; ``displacement_mm_end`` is the
        crosshead at the row's end, where the energies are taken."""
        span = self.impulse_time
        f = self.impulse / span if span > 0.0 else self.tension()
        u = self.impulse_u / span if span > 0.0 else self.displacement()
        self.impulse = self.impulse_u = self.impulse_time = 0.0
        return {"displacement_mm": u, "displacement_mm_end": self.displacement(),
                "force_N": f, "force_N_instant": self.tension(),
                "plastic": self.plastic_work(), "contacts": self.active,
                "debonded_ties": self.debonded()}


@dataclass
class YRun:
    curve: object                 # displacement_mm, force_N
    history: object
    shapes: dict                  # crosshead displacement -> S2 wire node positions (n, 3)
    summary: dict
    mesh: YMesh


def pull(inp: HifiInputs, geometry: Geometry, load_case: str, stroke: float = 50.0,
         n_shapes: int = 5, bridge: float = 15.0, reject: bool = True, progress=None) -> YRun:
    """Run the hi-fi pull test; raises ExplicitError when the run goes unstable or, with
    ``reject``, is not quasi-static (``config.explicit.ke_ie_fail``) or its energy balance
    fails.  ``progress``: as in :func:`harnesspipe.models.hifi.three_point` (the force is the
    strand's tension, the deflection the crosshead's travel)."""
    from harnesspipe.fe.solvers.central_difference import ExplicitError
    t0 = time.perf_counter()
    if load_case not in LOAD_CASES:
        raise ValueError(f"load case {load_case!r}: expected one of {sorted(LOAD_CASES)}")
    mesh = build_mesh(inp.config, inp.resolution, geometry, bridge=bridge)
    system = YSystem(mesh, inp, geometry, load_case, stroke)
    settings = DynamicsSettings(safety=inp.explicit["safety"], n_output=200)
    marks = np.linspace(0.0, 1.0, n_shapes + 1)
    shapes, state = {}, {"next": 0}

    def on_output(step, t):
        while state["next"] < marks.size and t >= marks[state["next"]] * system.T - 1e-12:
            shapes[round(system.displacement(), 6)] = system.x[mesh.s2_wire].copy()
            state["next"] += 1
        if progress is not None:
            progress(step=step, time_fraction=t / system.T, deflection_mm=system.displacement(),
                     force_N=system.tension(), stroke_mm=stroke)

    res = integrate(system, system.T, settings, on_output=on_output)
    hist = res.history
    ke_ie = quasi_static_ratio(hist, stroke, travel="displacement_mm_end")
    limits = inp.config["explicit"]
    h = hist.iloc[-1]
    state_ = (res.n_steps, system.T, h["KE"], h["internal"], h["W_ext"], res.dt)
    if reject and ke_ie > limits["ke_ie_fail"]:
        raise ExplicitError(f"hi-fi branch: max KE/IE {ke_ie:.3g} > {limits['ke_ie_fail']:g} "
                            "(not quasi-static: raise t_total)", *state_)
    if reject and res.energy_error > limits["energy_fail"]:
        raise ExplicitError(f"hi-fi branch: energy balance error {res.energy_error:.3g} > "
                            f"{limits['energy_fail']:g}", *state_)
    summary = {
        "load_case": load_case, "wall_s": time.perf_counter() - t0, "steps": res.n_steps,
        "dt": res.dt, "f_m": inp.explicit["f_m"], "t_total": system.T,
        "ke_ie_max": ke_ie, "quasi_static": bool(ke_ie <= limits["ke_ie_max"]),
        "energy_error": res.energy_error, "n_beam_elements": int(mesh.beam_conn.shape[0]),
        "n_shell_elements": int(mesh.shell_conn.shape[0]), "n_nodes": int(mesh.n_nodes),
        "n_ties": system.n_ties(), "contact_pairs_max": int(system.pairs_max),
        "added_mass_fraction": system.added_mass_fraction,
        "plastic_work": float(h["plastic"]), "debonded_ties": system.debonded(),
        "energies": {k: float(h[k]) for k in (*system.families, "KE", "W_ext")},
    }
    return YRun(hist[["displacement_mm", "force_N"]].copy(), hist, shapes, summary, mesh)
