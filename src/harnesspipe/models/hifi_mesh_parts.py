"""The parts of a hi-fi three-point bending mesh, each built on its own (pure numpy).

:func:`harnesspipe.models.hifi_mesh.build_mesh` numbers and assembles them; the choices
behind each part (where the paper is silent) are listed in that module's docstring.

* :func:`wire_bundle`: the bundle's cross-section, hexagonally packed wires of pitch d,
  :func:`turn_bundle` (its orientation), :func:`spread_bundle` (its fill of the covering);
  :func:`wire_beams`: their beam elements along the sample (nodes 0 .. first).
* :func:`covering`: the covering's radii around the bundle (:class:`Covering`);
  :func:`tube_shell` (closed or open tube), :func:`fabric_shell` (spiral sheet).
* :func:`end_band` (taped ends), :func:`helix_strip` (coarse / half-lap tape).
* :func:`end_band_ties`, :func:`helix_ties`: what every tape node is glued to.

Every shell part is a :class:`ShellPart` with local node numbering 0 .. n - 1.
Notation (Sec. 2.2, 4.1, eq. 5): sample length L_s, tube length l, taped end a, tape
thickness t and width w, helix pitch p; x along the bundle, ``phi`` from the top (+y)
towards -z, ``(y, z) = rho (cos phi, -sin phi)``.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

PART_TUBE, PART_TAPE, PART_FABRIC = 0, 1, 2
PART_NAMES = {PART_TUBE: "tube", PART_TAPE: "tape", PART_FABRIC: "fabric"}
TIE_COVERING, TIE_WIRES, TIE_TAPE = 1, 2, 3
GROUP_COVERING, GROUP_HELIX, GROUP_END_LEFT, GROUP_END_RIGHT = 0, 1, 2, 3
MAX_SLEEVE_WRAPS = 2.0             # a curled fabric sleeve's layers at most (Covering.curl_onto)
WIRE_CLEARANCE = 1.0e-3            # relative packing clearance (fraction of d)
EX = np.array([1.0, 0.0, 0.0])     # the bundle axis: material direction 1 of the coverings


# --------------------------------------------------------------------------- geometry

def cylindrical(x, rho, phi):
    """Cartesian points (..., 3) from (x, rho, phi): (x, rho cos phi, -rho sin phi)."""
    x, rho, phi = np.broadcast_arrays(np.asarray(x, float), np.asarray(rho, float),
                                      np.asarray(phi, float))
    return np.stack([x, rho * np.cos(phi), -rho * np.sin(phi)], axis=-1)


def phi_of(X):
    """Angle phi of points X (..., 3) from the top."""
    return np.arctan2(-X[..., 2], X[..., 1])


def quad_area(X, conn):
    """Areas (n_el,) of the quads ``conn`` (n_el, 4): half the diagonals' cross product."""
    P = X[conn]
    return 0.5 * np.linalg.norm(np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 1]), axis=1)


def _grid(P, periodic: bool):
    """Quads on a structured (ni+1, nj+1, 3) point grid; index i runs along the first
    tangent, j along the second, normal = d/di x d/dj.  ``periodic``: column nj is column 0.
    Returns the points (n, 3), the quads (ni nj, 4) and the node ids (ni+1, nj or nj+1)."""
    ni1, nj1 = P.shape[:2]
    nj = nj1 - 1
    ncol = nj if periodic else nj1
    ids = np.arange(ni1 * ncol).reshape(ni1, ncol)
    pts = P[:, :ncol].reshape(-1, 3)
    i, j = np.meshgrid(np.arange(ni1 - 1), np.arange(nj), indexing="ij")
    jp = (j + 1) % ncol if periodic else j + 1
    conn = np.stack([ids[i, j], ids[i + 1, j], ids[i + 1, jp], ids[i, jp]], axis=-1).reshape(-1, 4)
    return pts, conn, ids


def tape_material(config: dict, case: dict) -> dict:
    """The materials entry of the case's tape: ``case["tape"]`` (a campaign construction's
    tape, :mod:`harnesspipe.campaign.catalogue`), by default ``pvc_tape`` (Table 1)."""
    return config["materials"][case.get("tape", "pvc_tape")]


@dataclass(frozen=True)
class Sample:
    """Axial layout of the three-point sample (config ``three_point``) and the tape
    (:func:`tape_material`), mm."""

    L_s: float       # sample length
    l_tube: float    # tube (covering) length l
    a: float         # taped end: tape band from each sample end
    span: float      # roller distance
    pin_r: float     # pin radius
    t_tape: float    # tape thickness t
    w_tape: float    # tape width w

    @classmethod
    def from_config(cls, config: dict, case: dict | None = None) -> "Sample":
        tp, tape = config["three_point"], tape_material(config, case or {})
        return cls(tp["sample_length"], tp["tube_length"], tp["taped_end"], tp["span"],
                   0.5 * tp["pin_diameter"], tape["thickness"], tape["width"])

    @property
    def x_sample(self) -> tuple:
        return -0.5 * self.L_s, 0.5 * self.L_s

    @property
    def x_tube(self) -> tuple:
        return -0.5 * self.l_tube, 0.5 * self.l_tube


@dataclass
class ShellPart:
    """Quads of one part with local node numbering 0 .. n_nodes - 1."""

    X: np.ndarray                  # (n_nodes, 3) coordinates
    conn: np.ndarray               # (n_el, 4) outward-ordered quads, local node ids
    part: int                      # PART_TUBE / PART_TAPE / PART_FABRIC
    group: int                     # GROUP_COVERING / _HELIX / _END_LEFT / _END_RIGHT
    thickness: float               # geometric (contact) thickness
    axis: np.ndarray               # (3,) or (n_el, 3) material direction 1 (not yet in plane)
    tie_target: np.ndarray | None = None   # (n_nodes,) TIE_* of every node of a tape part
    node_sets: dict = field(default_factory=dict)   # name -> local node ids (cut, overlap)


# ---------------------------------------------------------------------------- wires

@dataclass
class WireBundle:
    """Cross-section of the bundle: n_wires wires on a hexagonal lattice of pitch d."""

    yz: np.ndarray          # (n_wires, 2) centre of each wire (y, z)
    wire_type: np.ndarray   # (n_wires,) type number N of materials.wire_typeN
    radius: np.ndarray      # (n_wires,) d_outer / 2
    pitch: float            # d = max d_outer (1 + WIRE_CLEARANCE)
    r_bundle: float         # max over the wires of |yz| + radius

    def round_gap_max(self) -> float:
        """Worst radial gap between the circle of radius ``r_bundle`` and the hexagonal
        bundle: r_bundle - min over phi of the support function max_w (e . yz_w + r_w)."""
        phs = np.linspace(0.0, 2.0 * np.pi, 721)
        dirs = np.column_stack([np.cos(phs), -np.sin(phs)])
        support = np.max(dirs @ self.yz.T + self.radius[None, :], axis=1)
        return float(self.r_bundle - support.min())


@dataclass
class WireBeams:
    """Beam elements of the wires: wire w, station i -> node ``w (n_el + 1) + i``."""

    X: np.ndarray           # (n_wires (n_el + 1), 3) node coordinates
    wire_nodes: np.ndarray  # (n_wires, n_el + 1) node ids along each wire (x increasing)
    beam_conn: np.ndarray   # (n_wires n_el, 2)
    beam_wire: np.ndarray   # (n_wires n_el,) wire index of each beam


def _wire_types(case: dict) -> dict:
    """Wire counts by type number from the case's ``wires: {wire_typeN: count}``."""
    counts = {}
    for key, num in case["wires"].items():
        m = re.fullmatch(r"wire_type(\d+)", key)
        if not m or int(num) < 1:
            raise ValueError(f"case wires: bad entry {key!r}: {num!r} (expected wire_typeN: count)")
        counts[int(m.group(1))] = int(num)
    return counts


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


def wire_bundle(case: dict, config: dict) -> WireBundle:
    """The bundle of ``case["wires"]``: positions by :func:`_hex_positions`, mixed types
    interleaved over them by :func:`_interleave`, radii ``d_outer / 2`` of the materials."""
    counts = _wire_types(case)
    d_out = {t: config["materials"][f"wire_type{t}"]["d_outer"] for t in counts}
    d = max(d_out.values()) * (1.0 + WIRE_CLEARANCE)
    n_wires = sum(counts.values())
    yz = _hex_positions(n_wires, d)
    wtype = _interleave(counts) if len(counts) > 1 else np.full(n_wires, next(iter(counts)))
    wrad = np.array([0.5 * d_out[t] for t in wtype])
    r_bundle = float(np.max(np.hypot(yz[:, 0], yz[:, 1]) + wrad))
    return WireBundle(yz, wtype.astype(int), wrad, d, r_bundle)


def spread_bundle(bundle: WireBundle, r_inner: float, fill: float) -> WireBundle:
    """The bundle's lattice scaled about the axis so that its radius moves the fraction
    ``fill`` (0..1) of the way from the packed bundle to the covering's inner face
    ``r_inner`` (less the packing clearance): the wires' arrangement in the tube, a build
    state the paper does not give.  0: the packed bundle, centred, clear of the wall all
    round; 1: the outer wires touch the wall, the others spread out with them."""
    if not 0.0 <= fill <= 1.0:
        raise ValueError(f"wire_fill {fill}: expected a fraction in [0, 1]")
    if fill == 0.0:
        return bundle
    target = bundle.r_bundle + fill * (r_inner - WIRE_CLEARANCE * bundle.pitch - bundle.r_bundle)
    rho = np.hypot(bundle.yz[:, 0], bundle.yz[:, 1])
    out = rho > 0.0
    scale = float(np.min((target - bundle.radius[out]) / rho[out]))
    yz = bundle.yz * scale
    r_bundle = float(np.max(np.hypot(yz[:, 0], yz[:, 1]) + bundle.radius))
    return WireBundle(yz, bundle.wire_type, bundle.radius, bundle.pitch * scale, r_bundle)


def turn_bundle(bundle: WireBundle, angle: float) -> WireBundle:
    """The bundle's cross-section turned about its axis by ``angle`` degrees (``phi`` of every
    wire grows by it): the pack's orientation in the test, a build state the paper does not
    give.  At 0 (and every 30) the packed lattice is mirror-symmetric about the loading plane
    (x, y); a wire pushed sideways under the feeder then has no side to go to, and which side
    it takes, and when, is decided by round-off (bench/RESULTS.md 'Hi-fi outcome against the
    last bits').  A turn of a few degrees decides it by the geometry: a seed imperfection."""
    if angle == 0.0:
        return bundle
    a = np.radians(angle)
    y, z = bundle.yz[:, 0], bundle.yz[:, 1]
    yz = np.column_stack([y * np.cos(a) + z * np.sin(a), z * np.cos(a) - y * np.sin(a)])
    return WireBundle(yz, bundle.wire_type, bundle.radius, bundle.pitch, bundle.r_bundle)


def wire_beams(bundle: WireBundle, x0: float, x1: float, n_el: int) -> WireBeams:
    """Straight wires from x0 to x1 at their cross-section positions, n_el beams each."""
    n_wires = bundle.yz.shape[0]
    xw = np.linspace(x0, x1, n_el + 1)
    X = np.concatenate([np.column_stack([xw, np.full_like(xw, p[0]), np.full_like(xw, p[1])])
                        for p in bundle.yz])
    wire_nodes = np.arange(n_wires * (n_el + 1)).reshape(n_wires, n_el + 1)
    beam_conn = np.stack([wire_nodes[:, :-1], wire_nodes[:, 1:]], axis=-1).reshape(-1, 2)
    return WireBeams(X, wire_nodes, beam_conn, np.repeat(np.arange(n_wires), n_el))


# ------------------------------------------------------------------------ coverings

class Covering:
    """Covering geometry: inner face, outer face and mid radius as functions of phi.
    ``kind``: "tube" (smooth equivalent of the ridged tube, mid radius R = (d_i + d_o)/4,
    contact thickness (d_o - d_i)/2), "fabric" (spiral r1 -> r2 over ``wraps`` turns) or
    "none" (taped wire bundle: the bundle's radius stands in for the outer face)."""

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
        self.layers = 1.0            # walls stacked in the shell (a slit tube rolled tighter)
        self.t_tape = t_tape

    def close_onto(self, r_bundle: float, closure: float, clearance: float) -> None:
        """Roll a slit tube tighter by the fraction ``closure`` of the way from its moulded
        diameter to the bundle (inner face at ``r_bundle + clearance`` at 1), the ridge depth
        kept.  Its lips then overlap: the wall's moulded circumference 2 pi R lies around the
        smaller 2 pi R' as ``layers`` = R / R' walls (the shell's stiffness and mass scale
        with it, :func:`harnesspipe.models.hifi_bundle.shell_materials`), and the section is
        closed (``cut`` False).  0 leaves the tube as moulded, its slit free to open."""
        if not 0.0 <= closure <= 1.0:
            raise ValueError(f"tube_closure {closure}: expected a fraction in [0, 1]")
        if self.kind != "tube" or not self.cut or closure == 0.0:
            return
        R0 = self.R
        d_i = self.d_i - closure * (self.d_i - 2.0 * (r_bundle + clearance))
        self.d_o, self.d_i = d_i + (self.d_o - self.d_i), d_i
        self.R = 0.25 * (self.d_i + self.d_o)
        self.layers = R0 / self.R
        self.cut = False

    def curl_onto(self, r_bundle: float, closure: float, clearance: float) -> None:
        """Curl a self-wrapping fabric sleeve (Sec. 2.1: its weft is pre-twisted) the fraction
        ``closure`` of the way from its free spiral (r1, Fig. 6b) onto the bundle: the inner
        layer's mid radius r1' = r1 - closure (r1 - (r_bundle + clearance + t/2)).  The woven
        sheet keeps its length L = 2 pi wraps (r1 + r2)/2 and its growth per wrap
        g = (r2 - r1)/wraps, so it wraps more: wraps' solves pi g w^2 + 2 pi r1' w = L, and
        r2' = r1' + g wraps'; at most ``MAX_SLEEVE_WRAPS`` (the fabric's self-contact pairs
        two layers, :func:`fabric_shell`), where a small bundle stops the curl short of it
        (r1' from L at two wraps).  0 leaves the sleeve as the paper models it."""
        if not 0.0 <= closure <= 1.0:
            raise ValueError(f"sleeve_closure {closure}: expected a fraction in [0, 1]")
        if self.kind != "fabric" or closure == 0.0:
            return
        g = (self.r2 - self.r1) / self.wraps
        L = self.theta_end * 0.5 * (self.r1 + self.r2)
        r1 = self.r1 - closure * (self.r1 - (r_bundle + clearance + 0.5 * self.t))
        wraps = (np.sqrt((np.pi * r1) ** 2 + np.pi * g * L) - np.pi * r1) / (np.pi * g)
        if wraps > MAX_SLEEVE_WRAPS:
            wraps = MAX_SLEEVE_WRAPS
            r1 = L / (2.0 * np.pi * wraps) - 0.5 * g * wraps
        self.r1, self.r2, self.wraps = r1, r1 + g * wraps, float(wraps)
        self.phi0 = -np.pi * (self.wraps - 1.0)
        self.theta_end = 2.0 * np.pi * self.wraps

    def spiral_radius(self, theta):
        """Fabric mid-surface r(theta) = r1 + (r2 - r1) theta / (2 pi wraps)."""
        return self.r1 + (self.r2 - self.r1) * np.asarray(theta) / self.theta_end

    def outer(self, phi):
        """Outer face radius of the covering at angle phi (the outermost fabric layer)."""
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
        """Smallest radius of the inner face (inf without a covering)."""
        if self.kind == "none":
            return np.inf
        return 0.5 * self.d_i if self.kind == "tube" else self.r1 - 0.5 * self.t

    def tape_radius(self, phi):
        """Mid radius of a tape lying on the covering: outer face + t/2."""
        return self.outer(phi) + 0.5 * self.t_tape


def covering(case: dict, config: dict, bundle: WireBundle, t_tape: float) -> Covering:
    """The case's covering (config ``coverings``, the case's ``d_i``/``d_o`` override those
    of a tube) around ``bundle``, a slit tube closed onto it by config
    ``hifi.build.tube_closure`` (:meth:`Covering.close_onto`), a fabric sleeve curled onto it
    by ``hifi.build.sleeve_closure`` (:meth:`Covering.curl_onto`); ValueError if the bundle
    does not fit inside."""
    name = case["covering"]
    if name == "none":
        return Covering("none", {"r_bundle": bundle.r_bundle}, t_tape)
    cfg = dict(config["coverings"][name])
    cfg.update({k: case[k] for k in ("d_i", "d_o") if k in case})
    cov = Covering(name, cfg, t_tape)
    if bundle.r_bundle >= cov.inner_min():
        raise ValueError(f"{bundle.yz.shape[0]} wires (bundle radius {bundle.r_bundle:.3f}) do not "
                         f"fit in {name} (inner radius {cov.inner_min():.3f}); give the case a "
                         f"larger d_i/d_o")
    build = config.get("hifi", {}).get("build", {})
    clearance = WIRE_CLEARANCE * bundle.pitch
    cov.close_onto(bundle.r_bundle, float(build.get("tube_closure", 0.0)), clearance)
    cov.curl_onto(bundle.r_bundle, float(build.get("sleeve_closure", 0.0)), clearance)
    return cov


def tube_shell(cov: Covering, xc: np.ndarray, n_circ: int, phi_cut: float) -> ShellPart:
    """The tube's mid surface: (n_ax + 1) x n_circ nodes at radius R on the axial stations
    ``xc`` (n_ax + 1,), n_ax n_circ quads.  The hoop starts at ``phi_cut``; an open tube
    (``cov.cut``) gets one more node column there, a duplicate of the first: node sets
    ``cut_pairs`` (n_ax + 1, 2) (node at phi_cut, node at phi_cut + 2 pi) and ``cut_next``
    (n_ax + 1,) (the hoop neighbour of each pair's first node)."""
    phi = phi_cut + np.linspace(0.0, 2.0 * np.pi, n_circ + 1)
    P = cylindrical(xc[:, None], cov.R, phi[None, :])
    P[:, -1] = P[:, 0]                               # exact duplicates across the cut
    pts, conn, ids = _grid(P, periodic=not cov.cut)
    sets = {}
    if cov.cut:
        sets = {"cut_pairs": np.column_stack([ids[:, 0], ids[:, -1]]), "cut_next": ids[:, 1]}
    return ShellPart(pts, conn, PART_TUBE, GROUP_COVERING, cov.t, EX, node_sets=sets)


def fabric_shell(cov: Covering, xc: np.ndarray, n_circ: int) -> ShellPart:
    """The fabric's spiral mid surface r(theta), theta in [0, 2 pi wraps], at
    phi = phi0 + theta: (n_ax + 1) x (n_theta + 1) nodes, round(n_circ / 4) elements per
    quarter wrap.  Node sets ``fabric_overlap_inner`` / ``_outer``: the nodes of the two
    layers of the overlap (theta <= 2 pi (wraps - 1), theta >= 2 pi), (n_ax + 1) x m each."""
    n_q = max(1, int(round(n_circ / 4)))
    n_th = max(2, int(round(4 * cov.wraps)) * n_q)
    theta = np.linspace(0.0, cov.theta_end, n_th + 1)
    P = cylindrical(xc[:, None], cov.spiral_radius(theta)[None, :], (cov.phi0 + theta)[None, :])
    pts, conn, ids = _grid(P, periodic=False)
    lap = 2.0 * np.pi * (cov.wraps - 1.0)
    sets = {"fabric_overlap_inner": ids[:, theta <= lap + 1e-9].ravel(),
            "fabric_overlap_outer": ids[:, theta >= 2.0 * np.pi - 1e-9].ravel()}
    return ShellPart(pts, conn, PART_FABRIC, GROUP_COVERING, cov.t, EX, node_sets=sets)


# ---------------------------------------------------------------------------- tapes

def end_band_value(build: dict, fabric: bool, name: str) -> float:
    """A build value of the end bands (config ``hifi.build``), ``name`` (``end_tape_layers``,
    ``end_tape_binds``): on a fabric-sleeved CWB its own ``fabric_<name>`` when that is set
    (its tape is only at the ends, Sec. 4.2.2), else ``name``."""
    own = build.get(f"fabric_{name}") if fabric else None
    return float(build[name] if own is None else own)


def end_band_profile(sample: Sample, n_end: int, stepped: bool):
    """Stations of an end band as distances s from the centre, from the sample end
    L_s/2 to L_s/2 - a, and whether each lies on the covering.  ``stepped``: over the bare
    wires down to the tube end l/2 (>= 2 elements), then over the tube (the last
    a - (L_s - l)/2, >= 1 element); otherwise all n_end elements on the wires."""
    L_s, l_tube, a = sample.L_s, sample.l_tube, sample.a
    if not stepped:
        s = np.linspace(0.5 * L_s, 0.5 * L_s - a, n_end + 1)
        return s, np.zeros(s.size, bool)
    over_tube = a - (0.5 * L_s - 0.5 * l_tube)
    n_t = max(1, int(round(n_end * over_tube / a)))
    n_w = max(2, n_end - n_t)
    s_w = np.linspace(0.5 * L_s, 0.5 * l_tube, n_w + 1)        # distance from centre
    s_t = np.linspace(0.5 * l_tube, 0.5 * L_s - a, n_t + 1)[1:]
    return np.concatenate([s_w, s_t]), np.concatenate([np.zeros(n_w, bool), np.ones(n_t + 1, bool)])


def end_band_ties(on_cov: np.ndarray, n_circ: int) -> np.ndarray:
    """Tie targets (n_stations n_circ,) of an end band's nodes, station-major: the covering
    where the station lies on it, else the wires."""
    return (np.where(on_cov[:, None], TIE_COVERING, TIE_WIRES) * np.ones((1, n_circ), int)).ravel()


def end_band(side: float, group: int, bundle: WireBundle, cov: Covering, sample: Sample,
             res: dict) -> ShellPart:
    """The tape band at the sample end ``side`` (-1 or +1): a closed cylinder of
    n_stations x end_circ nodes along :func:`end_band_profile` (x increasing; stepped unless
    ``res["end_tape"] == "wires"`` or there is no covering), at the covering's tape radius
    where on the covering, else at bundle radius + t/2; end_axial x end_circ quads, the hoop
    as material direction, every node a tie candidate (:func:`end_band_ties`)."""
    stepped = res.get("end_tape", "stepped") == "stepped" and cov.kind != "none"
    phi_e = np.linspace(0.0, 2.0 * np.pi, int(res["end_circ"]) + 1)
    s, on_cov = end_band_profile(sample, int(res["end_axial"]), stepped)
    xs = side * s
    if side > 0:                                      # keep x increasing along i
        xs, on_cov = xs[::-1], on_cov[::-1]
    r_wires = bundle.r_bundle + 0.5 * sample.t_tape
    rho = np.where(on_cov[:, None], cov.tape_radius(phi_e)[None, :], r_wires)
    pts, conn, _ = _grid(cylindrical(xs[:, None], rho, phi_e[None, :]), periodic=True)
    ph = phi_of(pts[conn].mean(axis=1))
    hoop = np.column_stack([np.zeros_like(ph), -np.sin(ph), -np.cos(ph)])
    return ShellPart(pts, conn, PART_TAPE, group, sample.t_tape, hoop,
                     tie_target=end_band_ties(on_cov, phi_e.size - 1))


def helix_range(cov: Covering, sample: Sample) -> tuple:
    """Axial range (xa, xb) of the helix: between the end bands, x in
    [-(L_s/2 - a), L_s/2 - a]; without a covering (TWB) the whole sample."""
    if cov.kind == "none":
        return sample.x_sample
    return -(0.5 * sample.L_s - sample.a), 0.5 * sample.L_s - sample.a


def halflap_stations(xc0: float, xc1: float, p: float, k: int):
    """Centre-line stations of a half-lap strip, u = xc1 - j p/k back to xc0, so that the
    stations of wrap n are those of wrap n - 1 shifted by one pitch.  The remainder is one
    shorter first element, or, if under half a station, the strip starts later.  Returns the
    stations (n_u + 1,) and the strip's start."""
    du = p / k
    n_full = int(np.floor((xc1 - xc0) / du + 1e-9))
    u = xc1 - du * np.arange(n_full, -1, -1, dtype=float)
    if u[0] - xc0 >= 0.5 * du:               # remainder element at the start (first turn)
        return np.concatenate([[xc0], u]), xc0
    return u, u[0]                           # tiny remainder: start the strip there


def helix_stations(xc0: float, xc1: float, p: float, stretch: float, halflap: bool,
                   sample: Sample, res: dict):
    """Centre-line stations u (n_u + 1,) of a helix strip from xc0 to xc1, the strip's start
    and the elements per turn k (None for coarse).  Element length along the strip (stretch
    per unit u): ``res["tape_size"]``, default the tube's axial element length; or
    ``res["tape_axial"]`` elements over the strip.  Half-lap: :func:`halflap_stations`, k >= 3;
    coarse: evenly spaced, >= 4 elements."""
    h = float(res.get("tape_size", sample.l_tube / int(res["tube_axial"])))
    if halflap:
        turns = (xc1 - xc0) / p
        k = int(round(int(res["tape_axial"]) / turns)) if "tape_axial" in res else \
            int(round(p * stretch / h))
        k = max(3, k)
        return (*halflap_stations(xc0, xc1, p, k), k)
    n_u = int(res["tape_axial"]) if "tape_axial" in res else \
        max(4, int(round((xc1 - xc0) * stretch / h)))
    return np.linspace(xc0, xc1, n_u + 1), xc0, None


def helix_ties(eta: np.ndarray, u: np.ndarray, xc0: float, p: float, on: int,
               halflap: bool) -> np.ndarray:
    """Tie targets (n_eta n_u,) of the helix nodes, eta-major: all ``on`` (the covering, or
    the wires of a TWB); half-lap: the back half (eta <= 0, centre line included) from the
    second turn on lies on the previous wrap, TIE_TAPE."""
    if not halflap:
        return np.full((eta.size, u.size), on).ravel()
    on_tape = (eta[:, None] <= 1e-9) & (u[None, :] >= xc0 + p - 1e-9 * p)
    return np.where(on_tape, TIE_TAPE, on).ravel()


def _helix_tangents(u: np.ndarray, xc0: float, p: float, cov: Covering) -> np.ndarray:
    """Unit tangents (n_u - 1, 3) of the centre line (x = u, phi = 2 pi (u - xc0)/p, at the
    tape radius) at the elements' mid stations."""
    uc = 0.5 * (u[:-1] + u[1:])
    phc = 2.0 * np.pi * (uc - xc0) / p
    rc = cov.tape_radius(phc)
    tang = np.column_stack([np.ones_like(uc), -rc * np.sin(phc) * 2 * np.pi / p,
                            -rc * np.cos(phc) * 2 * np.pi / p])
    return tang / np.linalg.norm(tang, axis=1)[:, None]


def helix_strip(cov: Covering, sample: Sample, p: float, halflap: bool, res: dict):
    """One helical tape strip of width w and pitch p (coarse: p = 2 w, eq. 5; half-lap:
    p = w/2) over :func:`helix_range`.  Centre-line stations u (n_u + 1,) from xc0 = xa + w/2
    to xc1 = xb - w/2 at phi = 2 pi (u - xc0)/p, tape_width elements across eta in
    [-w/2, w/2]; node (eta, u) at x = u + eta.  Half-lap: the back half (eta < 0) at
    r + t, the centre line at r + t/2, ramping up over the first turn.  Returns the
    ShellPart ((tape_width + 1) x (n_u + 1) nodes, eta-major; material axis along the
    helix; tie targets :func:`helix_ties`) and the helix's info dict."""
    w, t = sample.w_tape, sample.t_tape
    xa, xb = helix_range(cov, sample)
    xc1 = xb - 0.5 * w
    r_mean = float(np.mean(cov.tape_radius(np.linspace(0, 2 * np.pi, 64))))
    stretch = np.hypot(1.0, 2.0 * np.pi * r_mean / p)               # strip length per unit u
    u, xc0, k = helix_stations(xa + 0.5 * w, xc1, p, stretch, halflap, sample, res)
    n_eta = int(res.get("tape_width", 4))
    eta = np.linspace(-0.5 * w, 0.5 * w, n_eta + 1)
    phi_h = 2.0 * np.pi * (u - xc0) / p
    r = cov.tape_radius(phi_h)[None, :] * np.ones((eta.size, 1))
    if halflap:
        ramp = np.minimum(1.0, (u - xc0) / p)[None, :]
        lift = np.where(eta[:, None] < -1e-9, 1.0, np.where(eta[:, None] > 1e-9, 0.0, 0.5))
        r = r + t * lift * ramp
    P = cylindrical(u[None, :] + eta[:, None], r, phi_h[None, :] * np.ones((eta.size, 1)))
    pts, conn, _ = _grid(P, periodic=False)
    on = TIE_WIRES if cov.kind == "none" else TIE_COVERING
    part = ShellPart(pts, conn, PART_TAPE, GROUP_HELIX, t,
                     np.tile(_helix_tangents(u, xc0, p, cov), (n_eta, 1)),   # i (eta) major
                     tie_target=helix_ties(eta, u, xc0, p, on, halflap))
    info = {"pitch": p, "x_range": (xa, xb), "turns": (xc1 - xc0) / p,
            "strip_length": (xc1 - xc0) * stretch, "strip_x": (xc0 - 0.5 * w, xc1 + 0.5 * w),
            "elements_per_turn": k}
    return part, info
