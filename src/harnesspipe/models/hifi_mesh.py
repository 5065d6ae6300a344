"""Geometry and meshes of the high-fidelity three-point bending models (Sec. 2.2, 4.1, Fig. 7).

Pure numpy.  :func:`build_mesh` turns a config ``cases`` entry into a :class:`HifiMesh`:
beam elements for the wires, 4-node shells for the covering (tube or fabric) and the PVC
tape, plus tie candidates, self-contact node sets and the three pins.  Each part is built
on its own in :mod:`harnesspipe.models.hifi_mesh_parts`; :func:`build_mesh` numbers and
assembles them.  Bundle axis x, loading in -y, pin axes along z; quads ordered so that
``(X2 - X1) x (X4 - X1)`` points away from the bundle axis.

Theory: the coordinates, every choice where the paper is silent (wire packing, the
equivalent tube's radius, the open tube's cut, the fabric spiral, taped ends, coarse and
half-lap helices, tie candidates, rollers) and the resolution keys are in
docs/theory/hifi_mesh.md.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from harnesspipe.models.hifi_mesh_parts import (  # noqa: F401 -- constants re-exported
    GROUP_COVERING, GROUP_END_LEFT, GROUP_END_RIGHT, GROUP_HELIX, PART_FABRIC, PART_NAMES,
    PART_TAPE, PART_TUBE, TIE_COVERING, TIE_TAPE, TIE_WIRES, WIRE_CLEARANCE, Sample, ShellPart,
    WireBeams, covering, end_band, fabric_shell, helix_strip, phi_of, quad_area, spread_bundle,
    tube_shell, turn_bundle, wire_beams, wire_bundle)

__all__ = ["HifiMesh", "build_mesh", "element_sizes", "coverage", "outer_surface_radius",
           "to_meshio", "write_vtu", "PRESETS", "PART_TUBE", "PART_TAPE", "PART_FABRIC",
           "TIE_COVERING", "TIE_WIRES", "TIE_TAPE"]

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
    wire_type: np.ndarray         # (n_wires,) type number N of materials.wire_typeN
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


# ------------------------------------------------------------------------- assembly

class _MeshParts:
    """Global node numbering of a mesh's parts: the wires' nodes first, then each shell
    part's nodes in the order added; collects the shell, tie and node-set arrays."""

    def __init__(self, wires: WireBeams):
        self.X = [wires.X]
        self.n_nodes = wires.X.shape[0]
        self.shells: list[tuple[int, ShellPart]] = []      # (node offset, part)

    def add(self, part: ShellPart) -> int:
        """Append ``part``; returns its node offset (global id of its local node 0)."""
        base = self.n_nodes
        self.X.append(part.X)
        self.shells.append((base, part))
        self.n_nodes += part.X.shape[0]
        return base

    def _per_element(self, value) -> np.ndarray:
        return np.concatenate([np.full(p.conn.shape[0], value(p)) for _, p in self.shells])

    def node_set(self, name: str, empty: np.ndarray) -> np.ndarray:
        """Global ids of the parts' node set ``name`` (``empty`` if no part has one)."""
        sets = [p.node_sets[name] + base for base, p in self.shells if name in p.node_sets]
        return np.concatenate(sets) if sets else empty

    def shell_arrays(self) -> dict:
        """Nodes X (n_nodes, 3) and per shell: conn (global ids), part, group, thickness
        and material direction 1 projected onto the element plane (n_shell, 3)."""
        X = np.concatenate(self.X)
        conn = np.concatenate([p.conn + base for base, p in self.shells])
        axes = np.concatenate([np.broadcast_to(p.axis, (p.conn.shape[0], 3)).copy()
                               for _, p in self.shells])
        return {"X": X, "shell_conn": conn, "shell_part": self._per_element(lambda p: p.part),
                "shell_group": self._per_element(lambda p: p.group),
                "shell_thickness": self._per_element(lambda p: p.thickness).astype(float),
                "shell_axis": _in_plane(X, conn, axes)}

    def ties(self, X: np.ndarray, shell_conn: np.ndarray) -> dict:
        """Tie candidates: every node of a part with tie targets, its target and its
        tributary area (a quarter of each adjacent quad's area)."""
        tied = [(np.arange(p.X.shape[0]) + base, p.tie_target)
                for base, p in self.shells if p.tie_target is not None]
        nodes = np.concatenate([n for n, _ in tied])
        area = np.zeros(X.shape[0])
        np.add.at(area, shell_conn.ravel(), np.repeat(0.25 * quad_area(X, shell_conn), 4))
        return {"tie_nodes": nodes, "tie_target": np.concatenate([t for _, t in tied]).astype(int),
                "tie_area": area[nodes]}


def _in_plane(X, conn, axes) -> np.ndarray:
    """Unit vectors ``axes`` (n_el, 3) projected onto the planes of the quads ``conn``
    (normal: the diagonals' cross product)."""
    Pq = X[conn]
    nrm = np.cross(Pq[:, 2] - Pq[:, 0], Pq[:, 3] - Pq[:, 1])
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    axes = axes - np.sum(axes * nrm, axis=1)[:, None] * nrm
    return axes / np.linalg.norm(axes, axis=1)[:, None]


# ------------------------------------------------------------------------ builder

def _resolution(resolution: dict | str) -> dict:
    """The resolution dict: a :data:`PRESETS` name or a dict over ``PRESETS["quick"]``."""
    res = dict(PRESETS["quick"])
    res.update(PRESETS[resolution] if isinstance(resolution, str) else resolution)
    return res


def _check_case(case: dict, config: dict, res: dict, sample: Sample) -> str:
    """Validate the case's taping and covering, the end-tape mode and the sample's layout;
    returns the taping."""
    taping = case.get("taping", "none")
    if taping not in TAPINGS:
        raise ValueError(f"case taping {taping!r}: expected one of {TAPINGS}")
    cov_name = case["covering"]
    if cov_name != "none" and cov_name not in config["coverings"]:
        raise ValueError(f"case covering {cov_name!r} is not in config coverings (or 'none')")
    end_mode = res.get("end_tape", "stepped")
    if end_mode not in ("stepped", "wires"):
        raise ValueError(f"resolution end_tape {end_mode!r}: expected 'stepped' or 'wires'")
    x0, xt1 = sample.x_sample[0], sample.x_tube[1]
    if not (0 < sample.a and x0 + sample.a < xt1 and sample.l_tube < sample.L_s):
        raise ValueError("three_point: need tube_length < sample_length and a taped end inside the sample")
    return taping


def build_mesh(case: dict, config: dict, resolution: dict | str = "quick") -> HifiMesh:
    """Mesh of the hi-fi three-point bending model of ``case`` (a config ``cases`` entry;
    optional ``d_i``/``d_o`` override the covering's diameters, e.g. a 15 mm tube for 38
    wires).  ``config``: the whole config dict.  ``resolution``: dict (module docstring) or
    a :data:`PRESETS` name; missing keys fall back to ``PRESETS["quick"]``.

    Parts, numbered in this order: the wires' beams, the covering (tube or fabric), the
    end bands (left, right; none on a TWB with a helix) and the helical tape."""
    res = _resolution(resolution)
    sample = Sample.from_config(config, case)
    taping = _check_case(case, config, res, sample)
    build = config["hifi"]["build"]
    bundle = turn_bundle(wire_bundle(case, config), build["pack_angle"])
    cov = covering(case, config, bundle, sample.t_tape)
    if cov.kind != "none":
        bundle = spread_bundle(bundle, cov.inner_min(), build["wire_fill"])
    wires = wire_beams(bundle, *sample.x_sample, int(res["wire_elements"]))
    parts = _MeshParts(wires)
    xc = np.linspace(*sample.x_tube, int(res["tube_axial"]) + 1)
    phi_cut = None
    if cov.kind == "tube":
        phi_cut = cut_angle(res)
        parts.add(tube_shell(cov, xc, int(res["tube_circ"]), phi_cut))
    elif cov.kind == "fabric":
        parts.add(fabric_shell(cov, xc, int(res["tube_circ"])))
    helical = taping in ("coarse", "halflap")
    if not (helical and cov.kind == "none"):                # a TWB's helix covers its ends
        parts.add(end_band(-1.0, GROUP_END_LEFT, bundle, cov, sample, res))
        parts.add(end_band(1.0, GROUP_END_RIGHT, bundle, cov, sample, res))
    helix = {}
    if helical:
        tp = config["three_point"]
        p = sample.w_tape * (tp["coarse_pitch_over_width"] if taping == "coarse" else tp["halflap_overlap"])
        strip, helix = helix_strip(cov, sample, p, taping == "halflap", res)
        parts.add(strip)
    shells = parts.shell_arrays()
    mesh = HifiMesh(
        wire_nodes=wires.wire_nodes, beam_conn=wires.beam_conn, beam_wire=wires.beam_wire,
        wire_type=bundle.wire_type, wire_radius=bundle.radius, wire_yz=bundle.yz, **shells,
        cut_pairs=parts.node_set("cut_pairs", np.zeros((0, 2), dtype=int)),
        cut_next=parts.node_set("cut_next", np.zeros(0, dtype=int)),
        fabric_overlap_inner=parts.node_set("fabric_overlap_inner", np.zeros(0, dtype=int)),
        fabric_overlap_outer=parts.node_set("fabric_overlap_outer", np.zeros(0, dtype=int)),
        **parts.ties(shells["X"], shells["shell_conn"]), rollers={},
        info=_info(case, res, taping, sample, bundle, cov, helix, phi_cut))
    mesh.rollers = _pins(mesh, sample)
    return mesh


def _info(case, res, taping, sample, bundle, cov, helix, phi_cut) -> dict:
    """``HifiMesh.info``: the case, the geometry's key radii and ranges, the helix."""
    info = {
        "case": dict(case), "covering": cov.name, "covering_kind": cov.kind, "taping": taping,
        "end_tape": res.get("end_tape", "stepped"), "wire_pitch": bundle.pitch,
        "bundle_radius": bundle.r_bundle, "covering_inner_radius": cov.inner_min(),
        "clearance": cov.inner_min() - bundle.r_bundle, "tape_thickness": sample.t_tape,
        "tape_width": sample.w_tape, "end_tape_wire_radius": bundle.r_bundle + 0.5 * sample.t_tape,
        "end_tape_wire_gap_max": bundle.round_gap_max(), "x_sample": sample.x_sample,
        "x_tube": sample.x_tube, "taped_end": sample.a, "helix": helix,
    }
    if cov.kind == "tube":
        info.update(tube_mid_radius=cov.R, tube_contact_thickness=cov.t, tube_layers=cov.layers,
                    tape_radius=float(cov.tape_radius(np.zeros(1))[0]),
                    cut_phi=(phi_cut if cov.cut else None))
    elif cov.kind == "fabric":
        info.update(fabric_r1=cov.r1, fabric_r2=cov.r2, fabric_wraps=cov.wraps, fabric_phi0=cov.phi0,
                    fabric_layer_gap=float(cov.spiral_radius(2 * np.pi) - cov.spiral_radius(0.0)))
    return info


def _pins(mesh: HifiMesh, sample: Sample) -> dict:
    """The rollers (x = -+span/2, below) and the feeder (x = 0, on top), pins of radius
    ``pin_r`` along z whose surfaces touch the outermost surface of the mesh."""
    half, pin_r = 0.5 * sample.span, sample.pin_r
    r_bot = outer_surface_radius(mesh, np.array([-half, half]), np.array([np.pi, np.pi]))
    r_top = outer_surface_radius(mesh, np.array([0.0]), np.array([0.0]))[0]
    return {
        "centres": np.array([[-half, -(r_bot[0] + pin_r), 0.0], [half, -(r_bot[1] + pin_r), 0.0],
                             [0.0, r_top + pin_r, 0.0]]),
        "names": ("roller_left", "roller_right", "feeder"),
        "axis": np.array([0.0, 0.0, 1.0]), "radius": pin_r,
    }


# ------------------------------------------------------------------ geometry queries

def _locate(mesh: HifiMesh, x, phi, elements=None, newton: int = 8):
    """For points (x, phi) on the unwrapped cylinder: which shell elements contain them.
    Returns a boolean (n_points, n_elem) mask, the interpolated mid radius (same shape;
    0 where outside) and the element ids.  Only point/element pairs whose x ranges overlap
    are inverted (bilinear map, Newton)."""
    el = np.arange(mesh.shell_conn.shape[0]) if elements is None else np.asarray(elements)
    P = mesh.X[mesh.shell_conn[el]]                                   # (ne, 4, 3)
    ex, eph = P[..., 0], phi_of(P)
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
    area = quad_area(mesh.X, mesh.shell_conn)
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
