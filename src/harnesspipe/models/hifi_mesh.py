"""Geometry and meshes of the high-fidelity three-point bending models (Sec. 2.2, 4.1, Fig. 7).

Pure numpy.  :func:`build_mesh` turns a config ``cases`` entry into a :class:`HifiMesh`:
beam elements for the wires, 4-node shells for the covering (tube or fabric) and the PVC
tape, plus tie candidates, self-contact node sets and the three pins.

Coordinates (mm)
----------------
Bundle axis x, sample x in [-100, 100] (``three_point.sample_length``); loading in -y:
feeder on top at x = 0, rollers below at x = +-span/2 = +-63.5, pin axes along z, pins
5 mm diameter.  Cylindrical angle ``phi`` measured from +y towards -z:
``(y, z) = rho (cos phi, -sin phi)``, so phi = 0 is the top (under the feeder) and
phi = pi the bottom (on the rollers).  Every quad is ordered so that
``(X2 - X1) x (X4 - X1)`` points outward (away from the bundle axis).

Choices where the paper is silent (each documented where it is made)
-------------------------------------------------------------------
* Wires: hexagonal packing 1-6-12(-18) at pitch ``d = max d_outer x (1 + 1e-3)`` (clearance
  so no pair starts in contact), centred on the tube axis; the bundle is narrower than the
  tube (19 type-2: bundle radius 3.50, tube inner face 5.35) and the wires settle onto the
  tube wall under the load.  Order: by distance, then by angle phi from the top.  A partly
  filled last shell is filled from the bottom (smallest y, then smallest z): 38 wires =
  37 (full hexagonal shells up to the 3rd) + 1 at the lowest of the six next sites, at
  distance 2 sqrt(3) d (phi = 150 deg, y = -3 d).  Mixed types are interleaved over the
  ordered positions by largest remaining quota, e.g. 10 type 1 + 9 type 2 alternate
  1,2,1,2,... around every ring (centre type 1; ring 1: 3+3; ring 2: 6+6).
* Plastic tube: smooth equivalent shell (:mod:`harnesspipe.models.tube_equivalent`) on the
  mean mid radius of the ridged wall ``R = (d_i + d_o)/4`` (6.2 mm), x in [-l/2, l/2]
  (l = 152.4).  ``shell_thickness`` of the tube is the *geometric* (contact) thickness
  ``(d_o - d_i)/2`` = 1.7, whose faces are the ridged envelope (inner d_i/2, outer d_o/2);
  the stiffness section thickness is ``equivalent_shell(...)["t"]``, assigned by the model.
* Open tube: longitudinal cut at the side (phi = pi/2, on the neutral axis of the bend,
  where no pin meets it).  The paper does not say where the slit was (its Fig. 17 shows
  the branch harness's cut from the side).  On top (``resolution["cut_at"] = "top"``,
  phi = 0, under the feeder) the pin presses on the two free edges of the slit; it wedges
  them apart and the wires' penalty contact against the split lips then makes energy,
  4-7 % of the test's work in the quick model; ``"bottom"`` (phi = pi) puts the rollers
  there.  Nodes are duplicated along the seam; ``cut_pairs`` lists (node at phi = cut,
  node at phi = cut + 2 pi) per axial station.
* Fabric tube: 1.25 wraps of a sheet whose mid-surface spirals ``r(theta) = r1 + (r2 - r1)
  theta / (2 pi wraps)`` (4.7 -> 5.3), theta in [0, 2 pi wraps]; the overlap (theta in
  [0, pi/2] under theta in [2 pi, 5 pi/2]) is centred on the top.  The two layers' mid
  surfaces are 0.48 mm apart for t = 0.6: with shell-offset contact they start 0.12 mm
  interpenetrated (``info["fabric_layer_gap"]``); use a contact thickness <= 0.48 there.
* Taped ends (all cases, Sec. 2.2: "the straightened wires and the tube are taped together
  at the ends"; Figs. 9, 13): a band of length a = 38.1 from each sample end.  Default
  ``end_tape = "stepped"``: over the bare wires (23.8 mm beyond the tube) at radius
  bundle radius + t_tape/2, then one conical shoulder element, then over the covering (the
  last 14.3 mm) at covering outer radius + t_tape/2 -- the fabrication sequence of
  Sec. 2.2.  ``end_tape = "wires"``: the band wraps the wires only, over its whole length
  (inside the tube for the last 14.3 mm).  Bands are wound tape: material axis hoop.
* Coarse / half-lap helix (open tube): on the covering between the end bands,
  x in [-l/2 + a - (L_s - l)/2, ...] = [-61.9, 61.9] (123.8 mm; eq. 5 writes
  u in [0, L - w], i.e. a taped length L = 127, 3.2 mm more, which would double the tape on
  the end bands).  Eq. 5 reading: w is the strip's extent along the axis, p = 2w gives
  gaps of w (50 % coverage away from the strip ends).  Radius r = d_o/2 + t_tape/2 = 7.1
  (eq. 5).  Material axis along the helix.
* Half-lap: ONE helical strip of pitch p = w/2 (a real half-lap tape is one continuous
  strip, each wrap lying half on the tube and half on the previous wrap).  Mesh: across the
  width the front half (towards +x, the winding direction) is at r (on the tube), the back
  half at r + t_tape (on the previous wrap), the centre node at r + t/2; during the first
  turn the back half ramps from r to r + t (nothing underneath yet: tied to the covering;
  from the second turn on it is tied to the previous wrap, TIE_TAPE).  Stations along the
  strip are ``u = x_end - j p/k`` (k elements per turn, ``info["helix"]["elements_per_turn"]``),
  so every station of wrap n is a station of wrap n-1 shifted by one pitch: each back-half
  node lies radially above a node of the wrap underneath, t (t/2 at the centre line and at
  the back edge, over the step) below it.  With unaligned stations the flat chords of the
  wrap underneath (76 deg of phi each at the quick resolution) sag up to r (1 - cos(dphi/2))
  ~ 1.5 mm below the node and no tie is found.  The remainder (taped length not a multiple
  of p/k) is one shorter first element, in the first turn, or, if under half a station, the
  strip starts that much later.  Every point of the
  taped length away from the strip ends is covered by exactly two tape layers, the helical
  edges (where debonding starts) exist, and nothing builds up beyond two layers.  Rejected:
  a helix of pitch w/2 whose radius grows t per turn (builds 11 layers), and two
  concentric continuous cylinders (no helical edges, wrong material axis).  With the
  stepped profile smeared over the centre elements the back half's mid-surface is between
  t/2 and t above the front half below (<= 0.05 mm initial overclosure at the step; that
  interface is a tie, so it does not matter).
* ``covering: none`` (taped wire bundles, TWBs of the branch model): no covering shells;
  with coarse/half-lap taping the helix runs over the whole sample on the wires (radius
  bundle radius + t_tape/2, tied to the wires) and there are no separate end bands; with
  ``none``/``ends`` taping only the end bands.
* A bundle that does not fit in the covering (38 wires in the 10.7 mm tube) raises
  ValueError: give the case ``d_i``/``d_o`` of the larger tube (e.g. 15.0 / 18.4).
* Tie candidates (``tie_nodes, tie_target, tie_area``): every tape node and what it is
  glued to (TIE_COVERING, TIE_WIRES, TIE_TAPE) with its tributary area (quarter element
  areas).  The bundle is hexagonal, not round: end-band nodes lie up to
  ``info["end_tape_wire_gap_max"]`` off the nearest wire surface; search with that tolerance.
* Rollers: centres touch the outermost surface (tape, tube or fabric, outer face, found on
  the mesh) at (x = +-63.5, bottom) and (x = 0, top); the rollers sit on the end bands'
  covering part (whose inner edge, x = +-61.9, is 1.6 mm inboard of the roller line): only
  the feeder starts on the bare tube / helix.

Resolution (``resolution`` dict; :data:`PRESETS`): ``wire_elements`` (per wire along 200),
``tube_circ`` / ``tube_axial`` (tube and fabric; fabric circumference gets
``round(tube_circ/4)`` elements per quarter wrap), ``tape_width`` (across the helix,
default 4), ``tape_axial`` (along the helix; default from ``tape_size`` or the tube's
axial element length), ``end_axial`` / ``end_circ`` (end bands), ``end_tape``, ``cut_at``.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

__all__ = ["HifiMesh", "build_mesh", "element_sizes", "coverage", "outer_surface_radius",
           "to_meshio", "write_vtu", "PRESETS", "PART_TUBE", "PART_TAPE", "PART_FABRIC",
           "TIE_COVERING", "TIE_WIRES", "TIE_TAPE"]

PART_TUBE, PART_TAPE, PART_FABRIC = 0, 1, 2
PART_NAMES = {PART_TUBE: "tube", PART_TAPE: "tape", PART_FABRIC: "fabric"}
TIE_COVERING, TIE_WIRES, TIE_TAPE = 1, 2, 3
GROUP_COVERING, GROUP_HELIX, GROUP_END_LEFT, GROUP_END_RIGHT = 0, 1, 2, 3
WIRE_CLEARANCE = 1.0e-3            # relative packing clearance (fraction of d)
TAPINGS = ("none", "coarse", "halflap", "ends")
CUT_PHI = {"top": 0.0, "side": 0.5 * np.pi, "bottom": np.pi}   # resolution["cut_at"]: angle of the open tube's slit from the top


def cut_angle(res: dict) -> float:
    """Angle of the open tube's slit from the top: ``res["cut_at"]`` (default side)."""
    where = res.get("cut_at", "side")
    if where not in CUT_PHI:
        raise ValueError(f"resolution cut_at: {where!r} is not one of {sorted(CUT_PHI)}")
    return CUT_PHI[where]


PRESETS = {
    # beams 19 x 32 = 608; shells 288 (closed) .. 512 (half-lap, 5 elements per turn)
    "quick": {"wire_elements": 32, "tube_circ": 12, "tube_axial": 16, "tape_width": 4,
              "end_axial": 6, "end_circ": 8},
    # beams 19 x 52 = 988; shells 672 (closed) .. 1076 (half-lap, 9 elements per turn)
    "default": {"wire_elements": 52, "tube_circ": 16, "tube_axial": 30, "tape_width": 4,
                "end_axial": 8, "end_circ": 12},
}


@dataclass
class HifiMesh:
    """Mesh of one hi-fi three-point bending model; plain numpy arrays (module docstring).

    Nodes: wires first (wire w, station i -> ``w * (n_el + 1) + i``), then shells.
    """

    X: np.ndarray                 # (n_nodes, 3) coordinates
    wire_nodes: np.ndarray        # (n_wires, n_el + 1) node ids along each wire (x increasing)
    beam_conn: np.ndarray         # (n_beam, 2)
    beam_wire: np.ndarray         # (n_beam,) wire index of each beam
    wire_type: np.ndarray         # (n_wires,) 1 or 2
    wire_radius: np.ndarray       # (n_wires,) d_outer / 2
    wire_yz: np.ndarray           # (n_wires, 2) cross-section position (y, z)
    shell_conn: np.ndarray        # (n_shell, 4) outward-ordered quads
    shell_part: np.ndarray        # (n_shell,) PART_TUBE / PART_TAPE / PART_FABRIC
    shell_group: np.ndarray       # (n_shell,) GROUP_COVERING / _HELIX / _END_LEFT / _END_RIGHT
    shell_thickness: np.ndarray   # (n_shell,) geometric (contact) thickness
    shell_axis: np.ndarray        # (n_shell, 3) unit material direction 1
    cut_pairs: np.ndarray         # (n_cut, 2) node pairs facing across the open tube's cut
    fabric_overlap_inner: np.ndarray  # node ids of the inner layer of the fabric overlap
    fabric_overlap_outer: np.ndarray  # node ids of the outer layer of the fabric overlap
    tie_nodes: np.ndarray         # (n_tie,) every tape node
    tie_target: np.ndarray        # (n_tie,) TIE_COVERING / TIE_WIRES / TIE_TAPE
    tie_area: np.ndarray          # (n_tie,) tributary area, mm^2
    rollers: dict                 # centres (3, 3) [roller -x, roller +x, feeder], axis, radius
    info: dict = field(default_factory=dict)
    cut_next: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))  # hoop neighbour of each cut_pairs[:, 0] node

    @property
    def n_nodes(self) -> int:
        return self.X.shape[0]

    @property
    def n_wires(self) -> int:
        return self.wire_nodes.shape[0]

    @property
    def n_wire_nodes(self) -> int:
        return self.wire_nodes.size

    def counts(self) -> dict:
        parts = {name: int(np.sum(self.shell_part == code)) for code, name in PART_NAMES.items()}
        return {"nodes": self.n_nodes, "wires": self.n_wires, "beams": int(self.beam_conn.shape[0]),
                "shells": int(self.shell_conn.shape[0]), **parts}


# --------------------------------------------------------------------------- helpers

def _cyl(x, rho, phi):
    """Cartesian points from (x, rho, phi): (x, rho cos phi, -rho sin phi)."""
    x, rho, phi = np.broadcast_arrays(np.asarray(x, float), np.asarray(rho, float),
                                      np.asarray(phi, float))
    return np.stack([x, rho * np.cos(phi), -rho * np.sin(phi)], axis=-1)


def _phi_of(X):
    return np.arctan2(-X[..., 2], X[..., 1])


def _grid(P, periodic: bool):
    """Quads on a structured (ni+1, nj+1, 3) point grid; index i runs along the first
    tangent, j along the second, normal = d/di x d/dj.  ``periodic``: column nj is column 0."""
    ni1, nj1 = P.shape[:2]
    nj = nj1 - 1
    ncol = nj if periodic else nj1
    ids = np.arange(ni1 * ncol).reshape(ni1, ncol)
    pts = P[:, :ncol].reshape(-1, 3)
    i, j = np.meshgrid(np.arange(ni1 - 1), np.arange(nj), indexing="ij")
    jp = (j + 1) % ncol if periodic else j + 1
    conn = np.stack([ids[i, j], ids[i + 1, j], ids[i + 1, jp], ids[i, jp]], axis=-1).reshape(-1, 4)
    return pts, conn, ids


def _hex_positions(n: int, d: float) -> np.ndarray:
    """n hexagonal lattice sites (y, z) of pitch d, centre first, ordered by distance then
    angle phi from the top; a partly used last shell is filled from the bottom."""
    k = int(np.ceil(np.sqrt(n))) + 2
    i, j = np.meshgrid(np.arange(-k, k + 1), np.arange(-k, k + 1), indexing="ij")
    y = (i + 0.5 * j).ravel() * d
    z = (np.sqrt(3.0) / 2.0 * j).ravel() * d
    dist = np.round(np.hypot(y, z) / d, 9)
    phi = np.round(np.mod(np.arctan2(-z, y), 2.0 * np.pi), 9)
    order = np.lexsort((phi, dist))
    y, z, dist = y[order], z[order], dist[order]
    last = dist[n - 1]
    full = np.flatnonzero(dist < last)
    shell = np.flatnonzero(dist == last)
    if full.size + shell.size > n:                       # partial shell: from the bottom
        shell = shell[np.lexsort((np.round(z[shell], 9), np.round(y[shell], 9)))]
    sel = np.concatenate([full, shell])[:n]
    return np.column_stack([y[sel], z[sel]])


def _interleave(counts: dict) -> np.ndarray:
    """Types for positions 0..N-1, spreading each type evenly (largest remaining quota)."""
    types = sorted(counts)
    N = sum(counts.values())
    out = np.empty(N, dtype=int)
    done = {t: 0 for t in types}
    for i in range(N):
        t = max(types, key=lambda t: ((i + 1) * counts[t] / N - done[t], -t))
        out[i] = t
        done[t] += 1
    return out


def _quad_area(X, conn):
    P = X[conn]
    return 0.5 * np.linalg.norm(np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 1]), axis=1)


# ----------------------------------------------------------------------- coverings

class _Covering:
    """Covering geometry: inner face, outer face and mid radius as functions of phi."""

    def __init__(self, name: str, cov: dict, t_tape: float):
        self.name = name
        self.cut = bool(cov.get("cut", False))
        if name == "none":                                # taped wire bundle (TWB): no covering
            self.kind = "none"
            self.r_bundle = float(cov["r_bundle"])
            self.t = 0.0
        elif "r1" in cov:                                   # fabric spiral
            self.kind = "fabric"
            self.r1, self.r2, self.wraps, self.t = cov["r1"], cov["r2"], cov["wraps"], cov["t"]
            self.phi0 = -np.pi * (self.wraps - 1.0)       # overlap centred on the top
            self.theta_end = 2.0 * np.pi * self.wraps
        else:                                             # ridged tube -> smooth equivalent
            self.kind = "tube"
            self.d_i, self.d_o, self.wall = cov["d_i"], cov["d_o"], cov["t"]
            self.R = 0.25 * (self.d_i + self.d_o)
            self.t = 0.5 * (self.d_o - self.d_i)
        self.t_tape = t_tape

    def spiral_radius(self, theta):
        return self.r1 + (self.r2 - self.r1) * np.asarray(theta) / self.theta_end

    def outer(self, phi):
        """Outer face radius of the covering at angle phi."""
        phi = np.asarray(phi, float)
        if self.kind == "none":
            return np.full(phi.shape, self.r_bundle)
        if self.kind == "tube":
            return np.full(phi.shape, 0.5 * self.d_o)
        th = np.mod(phi - self.phi0, 2.0 * np.pi)
        best = self.spiral_radius(th)
        k = 1
        while 2.0 * np.pi * k < self.theta_end:
            thk = th + 2.0 * np.pi * k
            best = np.where(thk <= self.theta_end + 1e-12, self.spiral_radius(np.minimum(thk, self.theta_end)), best)
            k += 1
        return best + 0.5 * self.t

    def inner_min(self):
        if self.kind == "none":
            return np.inf
        return 0.5 * self.d_i if self.kind == "tube" else self.r1 - 0.5 * self.t

    def tape_radius(self, phi):
        return self.outer(phi) + 0.5 * self.t_tape


# ------------------------------------------------------------------------ builder

def _wire_types(case: dict) -> dict:
    counts = {}
    for key, num in case["wires"].items():
        m = re.fullmatch(r"wire_type(\d+)", key)
        if not m or int(num) < 1:
            raise ValueError(f"case wires: bad entry {key!r}: {num!r} (expected wire_typeN: count)")
        counts[int(m.group(1))] = int(num)
    return counts


def build_mesh(case: dict, config: dict, resolution: dict | str = "quick") -> HifiMesh:
    """Mesh of the hi-fi three-point bending model of ``case`` (a config ``cases`` entry;
    optional ``d_i``/``d_o`` override the covering's diameters, e.g. a 15 mm tube for 38
    wires).  ``config``: the whole config dict.  ``resolution``: dict (module docstring) or
    a :data:`PRESETS` name; missing keys fall back to ``PRESETS["quick"]``."""
    res = dict(PRESETS["quick"])
    res.update(PRESETS[resolution] if isinstance(resolution, str) else resolution)
    tp = config["three_point"]
    L_s, span, l_tube, a = tp["sample_length"], tp["span"], tp["tube_length"], tp["taped_end"]
    pin_r = 0.5 * tp["pin_diameter"]
    tape_mat = config["materials"]["pvc_tape"]
    t_tape, w_tape = tape_mat["thickness"], tape_mat["width"]
    taping = case.get("taping", "none")
    if taping not in TAPINGS:
        raise ValueError(f"case taping {taping!r}: expected one of {TAPINGS}")
    cov_name = case["covering"]
    if cov_name != "none" and cov_name not in config["coverings"]:
        raise ValueError(f"case covering {cov_name!r} is not in config coverings (or 'none')")
    end_mode = res.get("end_tape", "stepped")
    if end_mode not in ("stepped", "wires"):
        raise ValueError(f"resolution end_tape {end_mode!r}: expected 'stepped' or 'wires'")
    x0, x1 = -0.5 * L_s, 0.5 * L_s
    xt0, xt1 = -0.5 * l_tube, 0.5 * l_tube
    if not (0 < a and x0 + a < xt1 and l_tube < L_s):
        raise ValueError("three_point: need tube_length < sample_length and a taped end inside the sample")

    # ---- wires
    counts = _wire_types(case)
    d_out = {t: config["materials"][f"wire_type{t}"]["d_outer"] for t in counts}
    d = max(d_out.values()) * (1.0 + WIRE_CLEARANCE)
    n_wires = sum(counts.values())
    yz = _hex_positions(n_wires, d)
    wtype = _interleave(counts) if len(counts) > 1 else np.full(n_wires, next(iter(counts)))
    wrad = np.array([0.5 * d_out[t] for t in wtype])
    r_bundle = float(np.max(np.hypot(yz[:, 0], yz[:, 1]) + wrad))
    if cov_name == "none":
        cov = _Covering("none", {"r_bundle": r_bundle}, t_tape)
    else:
        cov_cfg = dict(config["coverings"][cov_name])
        cov_cfg.update({k: case[k] for k in ("d_i", "d_o") if k in case})
        cov = _Covering(cov_name, cov_cfg, t_tape)
    if r_bundle >= cov.inner_min():
        raise ValueError(f"{n_wires} wires (bundle radius {r_bundle:.3f}) do not fit in {cov_name} "
                         f"(inner radius {cov.inner_min():.3f}); give the case a larger d_i/d_o")
    n_el = int(res["wire_elements"])
    xw = np.linspace(x0, x1, n_el + 1)
    Xw = np.concatenate([np.column_stack([xw, np.full_like(xw, p[0]), np.full_like(xw, p[1])])
                         for p in yz])
    wire_nodes = np.arange(n_wires * (n_el + 1)).reshape(n_wires, n_el + 1)
    beam_conn = np.stack([wire_nodes[:, :-1], wire_nodes[:, 1:]], axis=-1).reshape(-1, 2)
    beam_wire = np.repeat(np.arange(n_wires), n_el)

    offset = [Xw.shape[0]]
    X_parts = [Xw]
    conns, parts, groups, thick, axes = [], [], [], [], []
    tie_local = []       # (global node ids, target codes)

    def add(P, conn, part, group, t, axis):
        base = offset[0]
        X_parts.append(P)
        conns.append(conn + base)
        ne = conn.shape[0]
        parts.append(np.full(ne, part))
        groups.append(np.full(ne, group))
        thick.append(np.full(ne, t))
        axes.append(np.broadcast_to(axis, (ne, 3)).copy())
        offset[0] += P.shape[0]
        return base

    # ---- covering
    n_ax = int(res["tube_axial"])
    n_c = int(res["tube_circ"])
    xc = np.linspace(xt0, xt1, n_ax + 1)
    cut_pairs = np.zeros((0, 2), dtype=int)
    cut_next = np.zeros(0, dtype=int)
    ov_in = ov_out = np.zeros(0, dtype=int)
    ex = np.array([1.0, 0.0, 0.0])
    if cov.kind == "tube":
        phi_cut = cut_angle(res)
        phi = phi_cut + np.linspace(0.0, 2.0 * np.pi, n_c + 1)
        P = _cyl(xc[:, None], cov.R, phi[None, :])
        P[:, -1] = P[:, 0]                               # exact duplicates across the cut
        pts, conn, ids = _grid(P, periodic=not cov.cut)
        base = add(pts, conn, PART_TUBE, GROUP_COVERING, cov.t, ex)
        if cov.cut:
            cut_pairs = np.column_stack([ids[:, 0], ids[:, -1]]) + base
            cut_next = ids[:, 1] + base
    elif cov.kind == "fabric":
        n_q = max(1, int(round(n_c / 4)))
        n_th = max(2, int(round(4 * cov.wraps)) * n_q)
        theta = np.linspace(0.0, cov.theta_end, n_th + 1)
        P = _cyl(xc[:, None], cov.spiral_radius(theta)[None, :], (cov.phi0 + theta)[None, :])
        pts, conn, ids = _grid(P, periodic=False)
        base = add(pts, conn, PART_FABRIC, GROUP_COVERING, cov.t, ex)
        lap = 2.0 * np.pi * (cov.wraps - 1.0)
        ov_in = (ids[:, theta <= lap + 1e-9] + base).ravel()
        ov_out = (ids[:, theta >= 2.0 * np.pi - 1e-9] + base).ravel()

    # ---- end bands (all cases, Sec. 2.2)
    n_end = int(res["end_axial"])
    n_ec = int(res["end_circ"])
    phi_e = np.linspace(0.0, 2.0 * np.pi, n_ec + 1)
    r_wire_tape = r_bundle + 0.5 * t_tape
    twb_helix = cov.kind == "none" and taping in ("coarse", "halflap")
    for side, group in (() if twb_helix else ((-1.0, GROUP_END_LEFT), (1.0, GROUP_END_RIGHT))):
        if end_mode == "stepped" and cov.kind != "none":
            over_tube = a - (0.5 * L_s - 0.5 * l_tube)
            n_t = max(1, int(round(n_end * over_tube / a)))
            n_w = max(2, n_end - n_t)
            s_w = np.linspace(0.5 * L_s, 0.5 * l_tube, n_w + 1)        # distance from centre
            s_t = np.linspace(0.5 * l_tube, 0.5 * L_s - a, n_t + 1)[1:]
            s = np.concatenate([s_w, s_t])
            on_cov = np.concatenate([np.zeros(n_w, bool), np.ones(n_t + 1, bool)])
        else:
            s = np.linspace(0.5 * L_s, 0.5 * L_s - a, n_end + 1)
            on_cov = np.zeros(s.size, bool)
        xs = side * s
        if side > 0:                                      # keep x increasing along i
            xs, on_cov = xs[::-1], on_cov[::-1]
        rho = np.where(on_cov[:, None], cov.tape_radius(phi_e)[None, :], r_wire_tape)
        P = _cyl(xs[:, None], rho, phi_e[None, :])
        pts, conn, ids = _grid(P, periodic=True)
        cen = pts[conn].mean(axis=1)
        ph = _phi_of(cen)
        hoop = np.column_stack([np.zeros_like(ph), -np.sin(ph), -np.cos(ph)])
        base = add(pts, conn, PART_TAPE, group, t_tape, hoop)
        tgt = np.where(on_cov[:, None], TIE_COVERING, TIE_WIRES) * np.ones((1, n_ec), int)
        tie_local.append((ids.ravel() + base, tgt.ravel()))

    # ---- helix (coarse / half-lap)
    helix = {}
    if taping in ("coarse", "halflap"):
        xa, xb = -(0.5 * L_s - a), 0.5 * L_s - a                          # between the end bands
        if twb_helix:                                                     # TWB: taped all along
            xa, xb = x0, x1
        p = w_tape * (tp["coarse_pitch_over_width"] if taping == "coarse" else tp["halflap_overlap"])
        xc0, xc1 = xa + 0.5 * w_tape, xb - 0.5 * w_tape
        n_w_ = int(res.get("tape_width", 4))
        r_mean = float(np.mean(cov.tape_radius(np.linspace(0, 2 * np.pi, 64))))
        stretch = np.hypot(1.0, 2.0 * np.pi * r_mean / p)               # strip length per unit u
        h = float(res.get("tape_size", l_tube / n_ax))
        if taping == "halflap":
            # stations at u = xc1 - j p/k: wrap n's stations are wrap n-1's shifted by one pitch,
            # so each back-half node lies radially above a node of the wrap underneath (flat
            # chords of unaligned wraps sag up to r (1 - cos(dphi/2)) = 1.5 mm below it)
            turns = (xc1 - xc0) / p
            k = int(round(int(res["tape_axial"]) / turns)) if "tape_axial" in res else \
                int(round(p * stretch / h))
            k = max(3, k)
            du = p / k
            n_full = int(np.floor((xc1 - xc0) / du + 1e-9))
            u = xc1 - du * np.arange(n_full, -1, -1, dtype=float)
            if u[0] - xc0 >= 0.5 * du:               # remainder element at the start (first turn)
                u = np.concatenate([[xc0], u])
            else:                                    # tiny remainder: start the strip there
                xc0 = u[0]
            n_u = u.size - 1
            helix_k = k
        else:
            n_u = int(res["tape_axial"]) if "tape_axial" in res else \
                max(4, int(round((xc1 - xc0) * stretch / h)))
            u = np.linspace(xc0, xc1, n_u + 1)
            helix_k = None
        strip_len = (xc1 - xc0) * stretch
        eta = np.linspace(-0.5 * w_tape, 0.5 * w_tape, n_w_ + 1)
        phi_h = 2.0 * np.pi * (u - xc0) / p
        base_r = cov.tape_radius(phi_h)[None, :] * np.ones((eta.size, 1))
        on = TIE_WIRES if cov.kind == "none" else TIE_COVERING
        tgt = np.full((eta.size, u.size), on)
        if taping == "halflap":
            ramp = np.minimum(1.0, (u - xc0) / p)[None, :]
            lift = np.where(eta[:, None] < -1e-9, 1.0, np.where(eta[:, None] > 1e-9, 0.0, 0.5))
            base_r = base_r + t_tape * lift * ramp
            # tape underneath only from the second turn on (the first turn lies on the covering)
            tgt = np.where((eta[:, None] <= 1e-9) & (u[None, :] >= xc0 + p - 1e-9 * p), TIE_TAPE, on)
        P = _cyl(u[None, :] + eta[:, None], base_r, phi_h[None, :] * np.ones((eta.size, 1)))
        pts, conn, ids = _grid(P, periodic=False)
        # material axis: tangent of the helix centreline at the element's centreline station
        uc = 0.5 * (u[:-1] + u[1:])
        phc = 2.0 * np.pi * (uc - xc0) / p
        rc = cov.tape_radius(phc)
        tang = np.column_stack([np.ones_like(uc), -rc * np.sin(phc) * 2 * np.pi / p,
                                -rc * np.cos(phc) * 2 * np.pi / p])
        tang /= np.linalg.norm(tang, axis=1)[:, None]
        ax = np.tile(tang, (n_w_, 1))                    # element order: i (eta) major, j (u) minor
        base = add(pts, conn, PART_TAPE, GROUP_HELIX, t_tape, ax)
        tie_local.append((ids.ravel() + base, tgt.ravel()))
        helix = {"pitch": p, "x_range": (xa, xb), "turns": (xc1 - xc0) / p, "strip_length": strip_len,
                 "strip_x": (xc0 - 0.5 * w_tape, xc1 + 0.5 * w_tape), "elements_per_turn": helix_k}

    X = np.concatenate(X_parts)
    shell_conn = np.concatenate(conns)
    shell_part = np.concatenate(parts)
    shell_thickness = np.concatenate(thick).astype(float)
    shell_axis = np.concatenate(axes)
    Pq = X[shell_conn]                                   # project onto the element plane
    nrm = np.cross(Pq[:, 2] - Pq[:, 0], Pq[:, 3] - Pq[:, 1])
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    shell_axis = shell_axis - np.sum(shell_axis * nrm, axis=1)[:, None] * nrm
    shell_axis /= np.linalg.norm(shell_axis, axis=1)[:, None]
    area = _quad_area(X, shell_conn)
    node_area = np.zeros(X.shape[0])
    np.add.at(node_area, shell_conn.ravel(), np.repeat(0.25 * area, 4))
    tie_nodes = np.concatenate([t[0] for t in tie_local])
    tie_target = np.concatenate([t[1] for t in tie_local]).astype(int)

    # worst radial gap from a round end band to the hexagonal bundle (for tie search)
    phs = np.linspace(0.0, 2.0 * np.pi, 721)
    dirs = np.column_stack([np.cos(phs), -np.sin(phs)])
    proj = dirs @ yz.T                                            # support function per wire
    support = np.max(proj + wrad[None, :], axis=1)
    info = {
        "case": dict(case), "covering": cov_name, "covering_kind": cov.kind, "taping": taping,
        "end_tape": end_mode, "wire_pitch": d, "bundle_radius": r_bundle,
        "covering_inner_radius": cov.inner_min(), "clearance": cov.inner_min() - r_bundle,
        "tape_thickness": t_tape, "tape_width": w_tape, "end_tape_wire_radius": r_wire_tape,
        "end_tape_wire_gap_max": float(r_bundle - support.min()), "x_sample": (x0, x1),
        "x_tube": (xt0, xt1), "taped_end": a, "helix": helix,
    }
    if cov.kind == "tube":
        info.update(tube_mid_radius=cov.R, tube_contact_thickness=cov.t,
                    tape_radius=float(cov.tape_radius(np.zeros(1))[0]),
                    cut_phi=(cut_angle(res) if cov.cut else None))
    elif cov.kind == "fabric":
        info.update(fabric_r1=cov.r1, fabric_r2=cov.r2, fabric_wraps=cov.wraps, fabric_phi0=cov.phi0,
                    fabric_layer_gap=float(cov.spiral_radius(2 * np.pi) - cov.spiral_radius(0.0)))

    mesh = HifiMesh(
        X=X, wire_nodes=wire_nodes, beam_conn=beam_conn, beam_wire=beam_wire,
        wire_type=wtype.astype(int), wire_radius=wrad, wire_yz=yz,
        shell_conn=shell_conn, shell_part=shell_part, shell_group=np.concatenate(groups),
        shell_thickness=shell_thickness, shell_axis=shell_axis, cut_pairs=cut_pairs,
        fabric_overlap_inner=ov_in, fabric_overlap_outer=ov_out,
        tie_nodes=tie_nodes, tie_target=tie_target, tie_area=node_area[tie_nodes],
        rollers={}, info=info, cut_next=cut_next)

    # ---- pins, tangent to the outermost surface
    half = 0.5 * span
    r_bot = outer_surface_radius(mesh, np.array([-half, half]), np.array([np.pi, np.pi]))
    r_top = outer_surface_radius(mesh, np.array([0.0]), np.array([0.0]))[0]
    mesh.rollers = {
        "centres": np.array([[-half, -(r_bot[0] + pin_r), 0.0], [half, -(r_bot[1] + pin_r), 0.0],
                             [0.0, r_top + pin_r, 0.0]]),
        "names": ("roller_left", "roller_right", "feeder"),
        "axis": np.array([0.0, 0.0, 1.0]), "radius": pin_r,
    }
    return mesh


# ------------------------------------------------------------------ geometry queries

def _locate(mesh: HifiMesh, x, phi, elements=None, newton: int = 8):
    """For points (x, phi) on the unwrapped cylinder: which shell elements contain them.
    Returns a boolean (n_points, n_elem) mask, the interpolated mid radius (same shape;
    0 where outside) and the element ids.  Only point/element pairs whose x ranges overlap
    are inverted (bilinear map, Newton)."""
    el = np.arange(mesh.shell_conn.shape[0]) if elements is None else np.asarray(elements)
    P = mesh.X[mesh.shell_conn[el]]                                   # (ne, 4, 3)
    ex, eph = P[..., 0], _phi_of(P)
    erho = np.hypot(P[..., 1], P[..., 2])
    eph = eph[:, :1] + np.angle(np.exp(1j * (eph - eph[:, :1])))      # unwrap within element
    x = np.asarray(x, float)
    phi = np.asarray(phi, float)
    tol = 1e-9
    ip, ie = np.nonzero((x[:, None] >= ex.min(axis=1)[None, :] - tol)
                        & (x[:, None] <= ex.max(axis=1)[None, :] + tol))
    ex, eph, erho = ex[ie], eph[ie], erho[ie]
    cph = eph.mean(axis=1)
    xp = x[ip]
    ph = cph + np.angle(np.exp(1j * (phi[ip] - cph)))
    sg = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)
    s = np.zeros(ip.size)
    t = np.zeros(ip.size)

    def shape(s, t):
        N = 0.25 * (1 + s[:, None] * sg[:, 0]) * (1 + t[:, None] * sg[:, 1])
        Ns = 0.25 * sg[:, 0] * (1 + t[:, None] * sg[:, 1])
        Nt = 0.25 * sg[:, 1] * (1 + s[:, None] * sg[:, 0])
        return N, Ns, Nt

    for _ in range(newton):
        N, Ns, Nt = shape(s, t)
        fx = (N * ex).sum(-1) - xp
        fp = (N * eph).sum(-1) - ph
        a11, a12 = (Ns * ex).sum(-1), (Nt * ex).sum(-1)
        a21, a22 = (Ns * eph).sum(-1), (Nt * eph).sum(-1)
        det = a11 * a22 - a12 * a21
        det = np.where(np.abs(det) < 1e-300, 1e-300, det)
        s = np.clip(s - (a22 * fx - a12 * fp) / det, -2, 2)
        t = np.clip(t - (-a21 * fx + a11 * fp) / det, -2, 2)
    ok = (np.abs(s) <= 1 + 1e-9) & (np.abs(t) <= 1 + 1e-9)
    N, _, _ = shape(s, t)
    inside = np.zeros((x.size, el.size), bool)
    rho = np.zeros((x.size, el.size))
    inside[ip[ok], ie[ok]] = True
    rho[ip[ok], ie[ok]] = (N * erho).sum(-1)[ok]
    return inside, rho, el


def outer_surface_radius(mesh: HifiMesh, x, phi) -> np.ndarray:
    """Radius of the outermost shell outer face (mid radius + thickness/2) at points
    (x, phi); the wires' own outer surface if no shell is there."""
    x, phi = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(phi, float))
    inside, rho, el = _locate(mesh, x, phi)
    face = np.where(inside, rho + 0.5 * mesh.shell_thickness[el][None, :], -np.inf).max(axis=1)
    dirs = np.column_stack([np.cos(phi), -np.sin(phi)])
    wires = np.max(dirs @ mesh.wire_yz.T + mesh.wire_radius[None, :], axis=1)
    return np.maximum(face, wires)


def coverage(mesh: HifiMesh, elements, x_range, n_x: int = 121, n_phi: int = 72) -> np.ndarray:
    """Number of the given shell elements covering each point of a regular (x, phi) grid
    over ``x_range`` x [0, 2 pi); returns an (n_x, n_phi) integer array (points at element
    boundaries may count twice: the grid is offset by half a cell to avoid them)."""
    xs = np.linspace(x_range[0], x_range[1], n_x + 1)
    xs = 0.5 * (xs[:-1] + xs[1:]) + 1e-7
    ph = (np.arange(n_phi) + 0.5) * 2.0 * np.pi / n_phi + 1e-7
    Xg, Pg = np.meshgrid(xs, ph, indexing="ij")
    inside, _, _ = _locate(mesh, Xg.ravel(), Pg.ravel(), elements)
    return inside.sum(axis=1).reshape(n_x, n_phi)


def element_sizes(mesh: HifiMesh) -> dict:
    """Per-element sizes: ``beam_length`` (n_beam,), ``shell_area``, ``shell_min_edge``,
    ``shell_char_length`` (area / longest diagonal, the explicit step's L_e) (n_shell,)."""
    Xb = mesh.X[mesh.beam_conn]
    P = mesh.X[mesh.shell_conn]
    edges = np.linalg.norm(np.roll(P, -1, axis=1) - P, axis=2)
    diag = np.maximum(np.linalg.norm(P[:, 2] - P[:, 0], axis=1), np.linalg.norm(P[:, 3] - P[:, 1], axis=1))
    area = _quad_area(mesh.X, mesh.shell_conn)
    return {"beam_length": np.linalg.norm(Xb[:, 1] - Xb[:, 0], axis=1), "shell_area": area,
            "shell_min_edge": edges.min(axis=1), "shell_char_length": area / diag}


def shell_normals(mesh: HifiMesh, X=None) -> np.ndarray:
    """Unit normals (X2 - X1) x (X4 - X1) of the shells (outward for the undeformed mesh)."""
    X = mesh.X if X is None else X
    P = X[mesh.shell_conn]
    n = np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 1])
    return n / np.linalg.norm(n, axis=1)[:, None]


def to_meshio(mesh: HifiMesh, x=None):
    """meshio.Mesh with "line" (beams) and "quad" (shells) cells and cell data ``part``
    (-1 for beams), ``thickness`` (wire diameter for beams) and ``wire`` (-1 for shells).
    ``x``: optional current node positions (n_nodes, 3), not displacements."""
    import meshio

    pts = mesh.X if x is None else np.asarray(x, float).reshape(mesh.X.shape)
    nb, ns = mesh.beam_conn.shape[0], mesh.shell_conn.shape[0]
    part = [np.full(nb, -1), mesh.shell_part.astype(int)]
    thick = [2.0 * mesh.wire_radius[mesh.beam_wire], mesh.shell_thickness]
    return meshio.Mesh(pts, [("line", mesh.beam_conn), ("quad", mesh.shell_conn)],
                       cell_data={"part": part, "thickness": thick,
                                  "wire": [mesh.beam_wire.astype(int), np.full(ns, -1)]})


def write_vtu(path, mesh: HifiMesh, x=None) -> None:
    """Write the mesh (at positions ``x`` if given) as VTU."""
    to_meshio(mesh, x).write(str(path), file_format="vtu")
