"""Reduced-order beam models of Sec. 4.3: three-point bending and the cantilever.

The bundle is one effective elastoplastic beam (eq. 2 hardening, J2 fibres) of a
solid circular section of the outer radius r_o (I = pi r_o^4 / 4, the reading of
eq. 13), discretised by co-rotational fibre beams (:mod:`harnesspipe.fe.elements.beam`).
:class:`BeamSystem` holds the state and the loading and is the problem driven by
:func:`harnesspipe.fe.solvers.static.follow_path`; the builders below set up each test.

Three-point bending with ``supports="rollers"``: the 200 mm sample lies on two rigid
5 mm roller pins at +-span/2 and a 5 mm loading pin at midspan is pushed down, all in
penalty contact with the beam surface (frictionless unless ``mu`` > 0), so the bundle
slides over the rollers at large deflection.  Rigid-body motion along the axis is
removed by fixing the axial displacement of the midspan node (exact by symmetry);
the model is planar (out-of-plane translation and the two out-of-plane rotations
fixed).  ``supports="pinned"``: the span only, pinned at one end and on a roller
(free to slide) at the other, midspan deflection prescribed.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import pandas as pd

from harnesspipe.fe.contact.beam_cylinder import (BeamChain, ContactLaw, ContactState, Rollers,
                                                   assemble_contact)
from harnesspipe.fe.elements.beam import (NDOF_NODE, BeamMesh, FibreMaterial, FibreSection,
                                          assemble_beams, band_width, initial_frames,
                                          lobatto_points)
from harnesspipe.fe.materials.fiber import disc_fibres
from harnesspipe.fe.rotation import in_plane_angle, rotate_nodes
from harnesspipe.fe.solvers.static import NewtonSettings, band_matvec, constrain_band, follow_path

PIN_RADIUS = 2.5        # roller and loading pins, 5 mm diameter (Sec. 2.2)
PENALTY_FACTOR = 1.0    # contact stiffness / transverse stiffness 12 EI / h^3 of one element
UX, UY, UZ, RX, RY, RZ = range(6)


@dataclass(frozen=True)
class Material:
    """Effective elastoplastic properties: eq. 2 with E, sigma_y, K, n (MPa)."""
    E: float
    sigma_y: float = 1.0
    K: float = 0.0
    n: float = 1.0
    nu: float = 0.39
    elastic: bool = True

    @classmethod
    def of(cls, E, sigma_y, K, n, elastic, nu):
        if E is None or not E > 0.0:
            raise ValueError(f"E must be > 0, got {E}")
        if elastic:
            return cls(E=E, nu=nu)
        missing = [name for name, v in (("sigma_y", sigma_y), ("K", K), ("n", n)) if v is None]
        if missing:
            raise ValueError(f"{', '.join(missing)} required unless elastic=True")
        if not (sigma_y > 0.0 and K >= 0.0 and n > 0.0):
            raise ValueError(f"need sigma_y > 0, K >= 0, n > 0; got {sigma_y}, {K}, {n}")
        return cls(E=E, sigma_y=sigma_y, K=K, n=n, nu=nu, elastic=False)


@dataclass(frozen=True)
class Mesh:
    """Discretisation: elements along the beam, output increments, section and length rules."""
    n_elements: int = 40
    n_increments: int = 20
    n_rings: int = 4
    n_sectors: int = 12
    n_gauss: int = 3

    def __post_init__(self):
        if self.n_elements < 2 or self.n_increments < 1:
            raise ValueError(f"need n_elements >= 2 and n_increments >= 1, got {self}")


@dataclass
class Cylinders:
    """Rigid cylinders: start centres, final displacement (scaled by the load factor)."""
    centres: np.ndarray
    motion: np.ndarray
    axes: np.ndarray
    radii: np.ndarray
    mu: float = 0.0


class BeamSystem:
    """A chain of co-rotational fibre beams with supports, loads and contacts.

    Implements the problem interface of :mod:`harnesspipe.fe.solvers.static`.  ``fixed`` holds
    the constrained dof numbers (node * 6 + component); ``prescribed`` maps some of
    them to their final value (translations only); ``load`` is the final external
    force vector; everything is scaled by the load factor.
    """

    def __init__(self, X, material: Material, radius: float, mesh: Mesh, fixed,
                 prescribed=None, load=None, cylinders: Cylinders | None = None,
                 describe: Callable[[float], str] = lambda lam: f"load factor {lam:.4g}"):
        nn = X.shape[0]
        self.X = np.ascontiguousarray(X, dtype=float)
        self.conn = np.column_stack((np.arange(nn - 1), np.arange(1, nn))).astype(np.int64)
        self.R0 = initial_frames(self.X, self.conn)
        self.material = material
        self.radius = radius
        self.y, self.z, self.area = disc_fibres(radius, mesh.n_rings, mesh.n_sectors)
        self.xi_g, self.w_g = lobatto_points(mesh.n_gauss)
        G = material.E / (2.0 * (1.0 + material.nu))
        self.GJ = G * np.pi * radius**4 / 2.0
        self.EI = material.E * np.pi * radius**4 / 4.0
        self.ndof = NDOF_NODE * nn
        self.bandwidth = band_width(self.conn)
        self.fixed = np.unique(np.asarray(fixed, dtype=np.int64))
        self.prescribed = dict(prescribed or {})
        self.load = np.zeros(self.ndof) if load is None else np.asarray(load, dtype=float)
        self.cylinders = cylinders
        self.describe = describe
        ne, ng, nf = nn - 1, self.xi_g.size, self.y.size
        self.u = np.zeros((nn, 3))
        self.quat = np.zeros((nn, 4))
        self.quat[:, 0] = 1.0
        self.hist = np.zeros((2, ne, ng, nf))       # committed: signed eps_p, accumulated
        self.hist_trial = np.zeros((2, ne, ng, nf))
        self.f = np.zeros(self.ndof)
        self.band = np.zeros((2 * self.bandwidth + 1, self.ndof))
        self.reaction_dofs = np.zeros(self.fixed.size)
        self.pending = np.zeros(self.ndof)  # prescribed increment not yet applied
        self.lam = 0.0
        length = np.linalg.norm(self.X[-1] - self.X[0])
        self.force_floor = 1e-9 * self.EI / length**2
        if cylinders is not None:
            nc = cylinders.centres.shape[0]
            self.centres = cylinders.centres.astype(float).copy()
            self.ft = np.zeros((nc, ne))
            self.ft_trial = np.zeros((nc, ne))
            self.cyl_reactions = np.zeros((nc, 3))
            self.pressures = np.zeros(nc)
            self.status = np.zeros(ne, dtype=np.int64)
            self.bilateral = np.zeros(nc, dtype=np.bool_)  # loaded at the last converged state
            self.xis = np.zeros(ne)
            h = length / ne
            self.k_n = PENALTY_FACTOR * 12.0 * self.EI / h**3
        self._committed = self._snapshot()

    # -- state -----------------------------------------------------------------
    def _snapshot(self):
        centres = self.centres.copy() if self.cylinders is not None else None
        return {"u": self.u.copy(), "quat": self.quat.copy(), "lam": self.lam, "centres": centres}

    def accept(self) -> bool:
        """Check the frozen contact set at a converged state; release tensile cylinders."""
        if self.cylinders is None:
            return True
        tensile = self.bilateral & (self.pressures < 0.0)
        self.bilateral &= ~tensile
        return not tensile.any()

    def commit(self):
        self.hist[:] = self.hist_trial
        if self.cylinders is not None:
            self.ft[:] = self.ft_trial
            self.bilateral[:] = self.pressures > 0.0
        self._committed = self._snapshot()

    def revert(self):
        c = self._committed
        self.u[:], self.quat[:], self.lam = c["u"], c["quat"], c["lam"]
        self.pending[:] = 0.0
        if self.cylinders is not None:
            self.centres[:] = c["centres"]

    def set_load(self, lam: float):
        self.lam = lam
        for dof, value in self.prescribed.items():
            self.pending[dof] = lam * value - self.u[dof // NDOF_NODE, dof % NDOF_NODE]
        if self.cylinders is not None:
            self.centres[:] = self.cylinders.centres + lam * self.cylinders.motion

    def update(self, du):
        d = (du + self.pending).reshape(-1, NDOF_NODE)
        self.pending[:] = 0.0
        self.u += d[:, :3]
        rotate_nodes(self.quat, np.ascontiguousarray(d[:, 3:]))

    # -- physics ---------------------------------------------------------------
    def evaluate(self, want_tangent: bool):
        m = self.material
        assemble_beams(BeamMesh(self.X, self.conn, self.R0, self.xi_g, self.w_g), self.u,
                       self.quat, FibreSection(self.y, self.z, self.area, self.GJ),
                       FibreMaterial(m.E, m.sigma_y, m.K, m.n), m.elastic, self.hist,
                       self.hist_trial, want_tangent, self.f, self.band, self.bandwidth)
        ref = np.sqrt(self.f @ self.f)
        if self.cylinders is not None:
            c = self.cylinders
            last = self._committed
            assemble_contact(
                BeamChain(self.X, self.conn, self.R0, self.u, self.quat, last["u"], last["quat"]),
                Rollers(self.centres, last["centres"], c.axes, c.radii, self.bilateral),
                ContactLaw(self.radius, self.k_n, c.mu, self.k_n),
                ContactState(self.ft, self.ft_trial, self.cyl_reactions, self.pressures,
                             self.status, self.xis),
                want_tangent, self.f, self.band, self.bandwidth)
            ref = max(ref, np.sqrt(np.sum(self.cyl_reactions ** 2)))
        r = self.f - self.lam * self.load
        self.reaction_dofs[:] = r[self.fixed]
        if want_tangent and self.pending.any():  # linear predictor of the prescribed step
            band_matvec(self.band, self.pending, self.bandwidth, r)
        ref = max(ref, self.lam * np.sqrt(self.load @ self.load), self.force_floor)
        constrain_band(self.band, r, self.fixed, self.bandwidth)
        return r, ref, self.band

    # -- results ---------------------------------------------------------------
    def reaction(self, dof: int) -> float:
        """Internal force at a constrained dof (the force the support applies)."""
        return float(self.reaction_dofs[np.searchsorted(self.fixed, dof)])

    def positions(self) -> np.ndarray:
        return self.X + self.u


@dataclass
class RomRun:
    """Result of a ROM simulation: the curve and the bent shapes at chosen instants."""
    curve: pd.DataFrame
    shapes: dict = field(default_factory=dict)  # deflection (or load) -> node coords (n, 3)
    increments: int = 0


def _dof(node: int, comp: int) -> int:
    return NDOF_NODE * node + comp


def _planar(nn: int):
    """Out-of-plane translation and rotations of every node (planar bending in x-y)."""
    return [_dof(k, c) for k in range(nn) for c in (UZ, RX, RY)]


def _stops(n_increments: int, extra=()):
    stops = np.linspace(0.0, 1.0, n_increments + 1)[1:]
    return np.unique(np.round(np.concatenate((stops, np.asarray(extra, float))), 12))


def three_point_run(material: Material, radius: float, supports: str = "rollers",
                    span: float = 127.0, overhang: float = 36.5, deflection: float = 30.0,
                    mu: float = 0.0, mesh: Mesh = Mesh(), shape_at=(),
                    settings: NewtonSettings = NewtonSettings()) -> RomRun:
    """Three-point bending (Sec. 2.2, Fig. 15); force on the loading device vs its travel."""
    if supports not in ("rollers", "pinned"):
        raise ValueError(f"supports must be 'rollers' or 'pinned', got {supports!r}")
    if mesh.n_elements % 2:
        raise ValueError(f"n_elements must be even (a node at midspan), got {mesh.n_elements}")
    if not (radius > 0.0 and span > 0.0 and deflection > 0.0 and overhang >= 0.0):
        raise ValueError("radius, span, deflection must be > 0 and overhang >= 0")
    builder = _rollers if supports == "rollers" else _pinned
    system, force = builder(material, radius, span, overhang, deflection, mu, mesh)
    shape_fracs = [d / deflection for d in shape_at]
    rows, shapes = [(0.0, 0.0)], {}
    if 0.0 in shape_fracs:
        shapes[0.0] = system.positions()

    def record(lam):
        rows.append((lam * deflection, force(system)))
        if any(abs(lam - s) < 1e-9 for s in shape_fracs):
            shapes[round(lam * deflection, 9)] = system.positions()

    n = follow_path(system, _stops(mesh.n_increments, [s for s in shape_fracs if s > 0]),
                    settings, record)
    return RomRun(pd.DataFrame(rows, columns=["deflection_mm", "force_N"]), shapes, n)


def _rollers(material, radius, span, overhang, deflection, mu, mesh):
    ne = mesh.n_elements
    half = 0.5 * span + overhang
    X = np.zeros((ne + 1, 3))
    X[:, 0] = np.linspace(-half, half, ne + 1)
    mid = ne // 2
    gap0 = radius + PIN_RADIUS
    centres = np.array([[-0.5 * span, -gap0, 0.0], [0.5 * span, -gap0, 0.0], [0.0, gap0, 0.0]])
    motion = np.zeros((3, 3))
    motion[2, 1] = -deflection
    cyl = Cylinders(centres, motion, np.tile([0.0, 0.0, 1.0], (3, 1)), np.full(3, PIN_RADIUS), mu)
    fixed = _planar(ne + 1) + [_dof(mid, UX)]
    system = BeamSystem(X, material, radius, mesh, fixed, cylinders=cyl,
                        describe=lambda lam: f"loading-pin travel {lam * deflection:.6g} mm")
    return system, lambda s: float(s.cyl_reactions[2, 1])


def _pinned(material, radius, span, overhang, deflection, mu, mesh):
    ne = mesh.n_elements
    X = np.zeros((ne + 1, 3))
    X[:, 0] = np.linspace(0.0, span, ne + 1)
    mid = ne // 2
    load_dof = _dof(mid, UY)
    fixed = _planar(ne + 1) + [_dof(0, UX), _dof(0, UY), _dof(ne, UY), load_dof]
    system = BeamSystem(X, material, radius, mesh, fixed, prescribed={load_dof: -deflection},
                        describe=lambda lam: f"midspan deflection {lam * deflection:.6g} mm")
    return system, lambda s: -s.reaction(load_dof)


def cantilever_run(material: Material, radius: float, length: float, tip_load=None,
                   tip_displacement=None, mesh: Mesh = Mesh(n_elements=20),
                   settings: NewtonSettings = NewtonSettings(), shape_at=()) -> RomRun:
    """Cantilever clamped at x = 0 under a tip dead load along +y (fixed in space).

    Load control with ``tip_load`` P, or tip-deflection control with ``tip_displacement``
    (the +y tip displacement; the load is then the reaction).  Columns: load_N,
    tip_ux_mm (along the undeformed axis), tip_uy_mm (across), tip_rotation_rad.
    """
    if (tip_load is None) == (tip_displacement is None):
        raise ValueError("give exactly one of tip_load and tip_displacement")
    if not (radius > 0.0 and length > 0.0):
        raise ValueError("radius and length must be > 0")
    ne = mesh.n_elements
    X = np.zeros((ne + 1, 3))
    X[:, 0] = np.linspace(0.0, length, ne + 1)
    tip = _dof(ne, UY)
    fixed = [_dof(0, c) for c in range(6)]
    if tip_load is not None:
        load = np.zeros(NDOF_NODE * (ne + 1))
        load[tip] = tip_load
        system = BeamSystem(X, material, radius, mesh, fixed, load=load,
                            describe=lambda lam: f"tip load {lam * tip_load:.6g} N")
    else:
        system = BeamSystem(X, material, radius, mesh, fixed + [tip],
                            prescribed={tip: tip_displacement},
                            describe=lambda lam: f"tip deflection {lam * tip_displacement:.6g} mm")

    def force(lam):
        return lam * tip_load if tip_load is not None else system.reaction(tip)

    rows, shapes = [(0.0, 0.0, 0.0, 0.0)], {}

    def record(lam):
        ux, uy = system.u[ne, 0], system.u[ne, 1]
        rows.append((force(lam), ux, uy, in_plane_angle(system.quat[ne])))
        if any(abs(lam - s) < 1e-9 for s in shape_at):
            shapes[round(lam, 9)] = system.positions()

    n = follow_path(system, _stops(mesh.n_increments, shape_at), settings, record)
    curve = pd.DataFrame(rows, columns=["load_N", "tip_ux_mm", "tip_uy_mm", "tip_rotation_rad"])
    return RomRun(curve, shapes, n)
