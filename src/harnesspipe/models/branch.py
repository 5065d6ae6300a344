"""Reduced-order model of the Y-shaped branching harness (Sec. 2.3 and 5, Fig. 16, eqs. 14-15).

CWB and TWB portions are co-rotational fibre beams with effective eq. 2 properties; the
break-out joint is three 6-dof bushings with the eq. 14 stiffnesses (lambda = l / r) and
Kelvin-Voigt damping C = alpha K (eq. 15); the strand is a truss, and the force is its
tension.  Implicit Newmark dynamics in physical time (:mod:`harnesspipe.fe.solvers.newmark`).

Theory: docs/theory/branch_rom.md (parts, geometry assumptions, mass, size of the alpha effect).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from harnesspipe.fe.assembly.band import scatter_pair
from harnesspipe.fe.elements.beam import (NDOF_NODE, BeamMesh, FibreMaterial, FibreSection,
                                          assemble_beams, initial_frames, lobatto_points)
from harnesspipe.fe.elements.bushing import (Bushings, BushingState, bushing_forces,
                                             bushing_stiffness)
from harnesspipe.fe.elements.truss import truss_response
from harnesspipe.fe.materials.fiber import disc_fibres
from harnesspipe.fe.rotation import rotate_nodes
from harnesspipe.fe.solvers.newmark import NewmarkSettings, integrate, time_grid
from harnesspipe.models.rom_beam import Material


@dataclass(frozen=True)
class Geometry:
    """Fig. 16 dimensions [mm] and the strand; the pipeline passes config ``branch.geometry``."""
    L1: float = 140.0            # Fig. 16, S1 CWB
    L2: float = 203.0            # Fig. 16, S2 CWB
    L3: float = 111.0            # Fig. 16, S3 CWB
    Le: float = 38.0             # Fig. 16, taped wire end of S2
    l1: float = 13.0             # Fig. 16, break-out TWB portions
    l2: float = 30.0
    l3: float = 30.0
    H: float = 625.0             # Fig. 16, aramid strand
    angle_deg: float = 30.0      # Sec. 2.3: S2 and S3 30 deg apart
    strand_E: float = 70.0e3     # assumption: aramid cord, E 70 GPa ...
    strand_d: float = 1.0        # ... 1 mm diameter

    @property
    def strand_EA(self) -> float:
        return self.strand_E * math.pi * self.strand_d**2 / 4.0


RHO_WIRE = 4.34e-9                             # type 2 wire density (config materials)
R_WIRE = 0.70                                  # type 2 wire outer radius (Table 1)
NU = 0.39                                      # Table 1
# Newmark with numerical dissipation (gamma > 1/2, beta = (gamma + 1/2)^2 / 4): the strand's
# axial mode on the S2 tip mass (omega ~ 1e4 rad/s, omega dt >> 1) is damped out within a
# few steps; the average-acceleration rule keeps it ringing after the crosshead starts and
# the strand goes into compression.  Modes with omega dt << 1 (the bending of the harness)
# are barely touched; the beams themselves carry no physical damping.
SETTINGS = NewmarkSettings(gamma=0.7, beta=0.36)
LOAD_CASES = {"inplane": np.array([0.0, 1.0, 0.0]), "outofplane": np.array([0.0, 0.0, 1.0])}

WIRES = {"cwb38_t2_open_coarse": 38, "cwb19_t2_open_coarse": 19, "twb38_t2": 38, "twb19_t2": 19}

# Documented estimates, overridden by the caller's fitted properties (DESIGN sec. 3 case names):
# * cwb19_t2_open_coarse: Table 3 (coarse-taped open tube), r_o = 7.05 (the 10 mm tube is the
#   nominal size of the d_i 10.7 / d_o 14.1 tube of the CWB tests);
# * cwb38_t2_open_coarse: 15 mm nominal tube read as d_i 15, d_o 18.4 (same wall and ridge as
#   the 10 mm tube), r_o = 9.2; E I and the first-yield moment twice those of the 19-wire CWB
#   (twice the wires, same bundle/loose-wire ratio 2.24), n unchanged;
# * twb19_t2, twb38_t2: hexagonal bundles of 5 and 7 wire diameters plus 0.1 mm tape,
#   r = 3.6 and 5.0; E I and first-yield moment 1.2 times the sum over the loose wires
#   (taping binds them a little; the tubed CWB reaches 2.24); K scaled from the wires' K
#   like sigma_y, n of the wires.
DEFAULT_PROPERTIES = {
    "cwb38_t2_open_coarse": {"E": 12.90, "sigma_y": 0.414, "K": 2.89, "n": 0.43, "radius": 9.2},
    "cwb19_t2_open_coarse": {"E": 18.7, "sigma_y": 0.46, "K": 3.21, "n": 0.43, "radius": 7.05},
    "twb38_t2": {"E": 79.3, "sigma_y": 0.566, "K": 166.0, "n": 0.90, "radius": 5.0},
    "twb19_t2": {"E": 147.6, "sigma_y": 0.758, "K": 222.0, "n": 0.90, "radius": 3.6},
}


@dataclass(frozen=True)
class BranchMesh:
    """Beam element length target and the fibre section / Lobatto rule of every beam."""
    element_size: float = 10.0
    n_rings: int = 3
    n_sectors: int = 8
    n_gauss: int = 3


@dataclass
class BranchRun:
    """Curve (time_s, displacement_mm, force_N, reaction_N), S2 shapes, Newton iterations."""
    curve: pd.DataFrame
    shapes: dict = field(default_factory=dict)   # crosshead travel -> S2 node coordinates (n, 3)
    iterations: int = 0


# -- geometry --------------------------------------------------------------------------
@dataclass
class Layout:
    """Nodes and the parts that connect them (node numbers into X)."""
    X: np.ndarray
    beams: list          # (case, conn (ne, 2))
    bushings: list       # (case, twb length, node a = branch point, node b)
    s2_nodes: np.ndarray
    clamps: list
    tip: int
    head: int
    geometry: Geometry


def _chain(start, direction, lengths, size):
    """Points along a straight line: segment ends at cumulative ``lengths``, ~``size`` apart."""
    pts, ends, s0 = [np.asarray(start, float)], [], 0.0
    for length in lengths:
        n = max(1, round(length / size))
        pts += [start + direction * (s0 + length * k / n) for k in range(1, n + 1)]
        s0 += length
        ends.append(len(pts) - 1)
    return np.array(pts), ends


def build_layout(load_case: str, element_size: float, geometry: Geometry = Geometry()) -> Layout:
    """Node coordinates and connectivity of Fig. 16 (docs/theory/branch_rom.md).

    Node order keeps the tangent banded: S1 from its zip-tie to the joint, the branch
    point, then S2 and S3 interleaved from the joint outwards, the crosshead last.
    """
    g = geometry
    angle = math.radians(g.angle_deg)
    d1 = np.array([-1.0, 0.0, 0.0])
    d2 = np.array([1.0, 0.0, 0.0])
    d3 = np.array([math.cos(angle), -math.sin(angle), 0.0])
    s1, _ = _chain(g.l1 * d1, d1, [g.L1], element_size)
    s2, (cwb2_end, _) = _chain(g.l2 * d2, d2, [g.L2, g.Le], element_size)
    s3, _ = _chain(g.l3 * d3, d3, [g.L3], element_size)
    n1, n2, n3 = len(s1), len(s2), len(s3)
    order2 = [n1 + 1 + 2 * k if k < n3 else n1 + 1 + n3 + k for k in range(n2)]
    order3 = [n1 + 2 + 2 * k for k in range(n3)]
    nn = n1 + 1 + n2 + n3 + 1
    X = np.zeros((nn, 3))
    X[:n1] = s1[::-1]
    X[order2] = s2
    X[order3] = s3
    idx1 = np.arange(n1)[::-1]
    idx2, idx3 = np.array(order2), np.array(order3)
    hub, head = n1, nn - 1
    X[head] = s2[-1] + g.H * LOAD_CASES[load_case]

    def conn(idx):
        return np.column_stack((idx[:-1], idx[1:])).astype(np.int64)

    beams = [("cwb38_t2_open_coarse", conn(idx1)),
             ("cwb19_t2_open_coarse", conn(idx2[:cwb2_end + 1])),
             ("twb19_t2", conn(idx2[cwb2_end:])),
             ("cwb19_t2_open_coarse", conn(idx3))]
    bushings = [("twb38_t2", g.l1, hub, idx1[0]), ("twb19_t2", g.l2, hub, idx2[0]),
                ("twb19_t2", g.l3, hub, idx3[0])]
    return Layout(X, beams, bushings, idx2, [idx1[-1], idx3[-1]], idx2[-1], head, g)


# -- the problem -----------------------------------------------------------------------
class _Beams:
    """One beam portion: its elements, effective material and plastic history."""

    def __init__(self, X, conn, props, mesh: BranchMesh):
        self.conn = conn
        self.R0 = initial_frames(X, conn)
        r = props["radius"]
        self.material = Material.of(props["E"], props.get("sigma_y"), props.get("K"),
                                    props.get("n"), "sigma_y" not in props, props.get("nu", NU))
        self.y, self.z, self.area = disc_fibres(r, mesh.n_rings, mesh.n_sectors)
        self.GJ = self.material.E / (2.0 * (1.0 + self.material.nu)) * math.pi * r**4 / 2.0
        ng, nf = mesh.n_gauss, self.y.size
        self.hist = np.zeros((2, conn.shape[0], ng, nf))
        self.hist_trial = np.zeros_like(self.hist)


class YHarness:
    """The Y-harness ROM as a problem of :func:`harnesspipe.fe.solvers.newmark.integrate`."""

    def __init__(self, layout: Layout, properties: dict, alpha: float, pull, mesh: BranchMesh):
        self.layout = layout
        self.X = layout.X
        nn = self.X.shape[0]
        self.ndof = NDOF_NODE * nn
        self.pull = pull                      # t -> crosshead displacement vector
        self.xi_g, self.w_g = lobatto_points(mesh.n_gauss)
        self.beams = [_Beams(self.X, conn, properties[case], mesh) for case, conn in layout.beams]
        self.bushings = self._bushings(properties, layout.bushings, alpha)
        nb = len(layout.bushings)
        self.bushing_state = BushingState(np.zeros((3, nb, 6)), np.zeros((2, nb, 6)))
        pairs = [c for _, c in layout.beams] + [np.array([[a, b]]) for _, _, a, b in layout.bushings]
        pairs.append(np.array([[layout.tip, layout.head]]))
        self.bandwidth = NDOF_NODE * int(np.max(np.abs(np.diff(np.vstack(pairs), axis=1)))) + 5
        self.fixed = np.sort(np.concatenate(
            [np.arange(NDOF_NODE * k, NDOF_NODE * (k + 1)) for k in (*layout.clamps, layout.head)]))
        self.mass = self._lumped_mass(properties)
        self.u = np.zeros((nn, 3))
        self.quat = np.tile([1.0, 0.0, 0.0, 0.0], (nn, 1))
        self.f = np.zeros(self.ndof)
        self.band = np.zeros((2 * self.bandwidth + 1, self.ndof))
        self._f_part = np.zeros(self.ndof)
        self._band_part = np.zeros_like(self.band)
        self.tension = 0.0
        self.rates = None
        self._committed = (self.u.copy(), self.quat.copy())

    def _bushings(self, properties, joints, alpha) -> Bushings:
        """The break-out bushings: eq. 14 stiffnesses, frame axis 1 along each TWB."""
        pairs, dXs, frames, ks = [], [], [], []
        for case, l_twb, a, b in joints:
            props = properties[case]
            E, r = props["E"], props["radius"]
            ks.append(bushing_stiffness(E, E / (2.0 * (1.0 + props.get("nu", NU))), r, l_twb))
            dX = self.X[b] - self.X[a]
            e1 = dX / np.linalg.norm(dX)
            e3 = np.array([0.0, 0.0, 1.0])
            pairs.append((a, b))
            dXs.append(dX)
            frames.append(np.column_stack((e1, np.cross(e3, e1), e3)))
        return Bushings(np.array(pairs, dtype=np.int64), np.array(dXs), np.array(frames),
                        np.array(ks), float(alpha))

    def _lumped_mass(self, properties) -> np.ndarray:
        m = np.zeros((self.X.shape[0], NDOF_NODE))
        for (case, conn) in self.layout.beams:
            r = properties[case]["radius"]
            rho = RHO_WIRE * WIRES[case] * (R_WIRE / r) ** 2
            for a, b in conn:
                half = 0.5 * rho * np.linalg.norm(self.X[b] - self.X[a])
                for node in (a, b):
                    m[node, :3] += half * math.pi * r**2
                    m[node, 3:] += half * math.pi * r**4 / 2.0
        return m.ravel()

    # -- state ---------------------------------------------------------------------
    def begin_step(self, t, rates):
        self.rates = rates
        du = np.zeros((self.X.shape[0], NDOF_NODE))
        du[self.layout.head, :3] = self.pull(t) - self.u[self.layout.head]
        return du.ravel()

    def update(self, du):
        d = du.reshape(-1, NDOF_NODE)
        self.u += d[:, :3]
        rotate_nodes(self.quat, np.ascontiguousarray(d[:, 3:]))

    def commit(self):
        for part in self.beams:
            part.hist[:] = part.hist_trial
        r = self.rates
        committed, trial = self.bushing_state
        d_n, v_n, a_n = committed
        step = trial[0] - d_n
        committed[2] = r.a_d * step + r.a_v * v_n + r.a_a * a_n
        committed[:2] = trial
        self._committed = (self.u.copy(), self.quat.copy())

    def revert(self):
        self.u[:], self.quat[:] = self._committed

    # -- physics ---------------------------------------------------------------------
    def evaluate(self):
        """Internal force (beams, bushings with eq. 15 damping, strand) and its tangent."""
        self.f[:] = 0.0
        self.band[:] = 0.0
        for part in self.beams:
            m = part.material
            assemble_beams(BeamMesh(self.X, part.conn, part.R0, self.xi_g, self.w_g), self.u,
                           self.quat, FibreSection(part.y, part.z, part.area, part.GJ),
                           FibreMaterial(m.E, m.sigma_y, m.K, m.n), m.elastic, part.hist,
                           part.hist_trial, True, self._f_part, self._band_part, self.bandwidth)
            self.f += self._f_part
            self.band += self._band_part
        x = self.X + self.u
        bushing_forces(self.bushings, x, self.quat, self.rates, self.bushing_state, self.f,
                       self.band, self.bandwidth)
        fe, Ke = np.zeros(12), np.zeros((12, 12))
        tip, head = self.layout.tip, self.layout.head
        g = self.layout.geometry
        self.tension = truss_response(x[tip], x[head], g.H, g.strand_EA, fe, Ke)
        scatter_pair(tip, head, fe, Ke, self.f, self.band, self.bandwidth)
        return self.f, self.band

    # -- results ---------------------------------------------------------------------
    def crosshead_reaction(self) -> float:
        """Force the crosshead applies to the strand, along the strand (what the load cell reads)."""
        tip, head = self.layout.tip, self.layout.head
        x = self.X + self.u
        e = (x[head] - x[tip]) / np.linalg.norm(x[head] - x[tip])
        return float(self.f[NDOF_NODE * head:NDOF_NODE * head + 3] @ e)

    def s2_shape(self) -> np.ndarray:
        """Deformed S2 centre line, from the joint end of its CWB to the tip."""
        return (self.X + self.u)[self.layout.s2_nodes]


def run(load_case: str = "inplane", alpha: float = 0.2, properties: dict | None = None,
        n_steps: int = 60, dt_min: float = 0.02, stroke: float = 50.0, rate: float = 1.0,
        shape_at=(), mesh: BranchMesh = BranchMesh(), geometry: Geometry | dict = Geometry(),
        settings: NewmarkSettings = SETTINGS) -> BranchRun:
    """Pull the strand ``stroke`` mm at ``rate`` mm/s; curve at every time step.

    Time steps grow geometrically from ``dt_min`` (resolving the eq. 15 Kelvin-Voigt
    transient at the start) over ``n_steps`` steps; crosshead travels ``shape_at`` are
    added to the time grid and the S2 shape recorded there.
    """
    if load_case not in LOAD_CASES:
        raise ValueError(f"load_case must be one of {sorted(LOAD_CASES)}, got {load_case!r}")
    if not alpha >= 0.0:
        raise ValueError(f"alpha must be >= 0, got {alpha}")
    if not (stroke > 0.0 and rate > 0.0):
        raise ValueError(f"stroke and rate must be > 0, got {stroke}, {rate}")
    props = {**DEFAULT_PROPERTIES, **(properties or {})}
    geometry = geometry if isinstance(geometry, Geometry) else Geometry(**geometry)
    layout = build_layout(load_case, mesh.element_size, geometry)
    head0 = layout.X[layout.head].copy()
    direction = LOAD_CASES[load_case]
    model = YHarness(layout, props, alpha, lambda t: rate * t * direction, mesh)
    duration = stroke / rate
    shape_times = [s / rate for s in shape_at if 0.0 < s <= stroke]
    grid = time_grid(duration, n_steps, dt_min)
    extra = [t for t in shape_times if np.min(np.abs(grid - t)) > 1e-6 * duration]
    times = np.sort(np.concatenate((grid, extra)))
    rows = [(0.0, 0.0, 0.0, 0.0)]
    shapes = {0.0: model.s2_shape()} if 0.0 in shape_at else {}

    def record(t):
        travel = float((model.X[layout.head] + model.u[layout.head] - head0) @ direction)
        rows.append((t, travel, model.tension, model.crosshead_reaction()))
        for ts in shape_times:
            if abs(t - ts) <= 1e-6 * duration:
                shapes[round(ts * rate, 9)] = model.s2_shape()

    iterations = integrate(model, times, settings, record, length_scale=stroke,
                           force_floor=1e-9 * geometry.strand_EA / geometry.H)
    curve = pd.DataFrame(rows, columns=["time_s", "displacement_mm", "force_N", "reaction_N"])
    return BranchRun(curve, shapes, iterations)


def simulate(load_case: str = "inplane", alpha: float = 0.2, properties: dict | None = None,
             n_steps: int = 60, return_shapes: bool = False, shape_at=(10.0, 25.0, 50.0),
             **options):
    """Strand tension vs crosshead travel of the branch pull test (Sec. 5, Fig. 18).

    ``load_case``: ``"inplane"`` (Fig. 16) or ``"outofplane"`` (Fig. 20); ``alpha``: eq. 15
    damping coefficient of the break-out bushings [s]; ``properties``: per-case dicts
    ``E, sigma_y, K, n, radius`` overriding :data:`DEFAULT_PROPERTIES`; ``options``:
    ``dt_min, stroke, rate, mesh, settings`` of :func:`run`.

    Returns a DataFrame ``displacement_mm, force_N``; with ``return_shapes=True`` a tuple
    ``(curve, shapes)``, shapes mapping each crosshead travel of ``shape_at`` to the
    (n, 3) node coordinates of S2.
    """
    result = run(load_case, alpha, properties, n_steps,
                 shape_at=shape_at if return_shapes else (), **options)
    curve = result.curve[["displacement_mm", "force_N"]]
    return (curve, result.shapes) if return_shapes else curve
