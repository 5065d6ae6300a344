"""Tensile tests of the CWB coverings (Sec. 2.1, 3.2): model builders and ``simulate``.

Components (DESIGN.md section 5 names):

``closed_tube``
    Ridged polypropylene tube, d_i 10.7, d_o 14.1, wall t 0.27, sinusoidal
    corrugation of pitch ``pitch`` (3.0 mm by default; the paper does not give
    it).  The paper models half the gauge length (114.3/2) pulled by 25 mm.  A
    long uniform corrugated tube in tension deforms periodically, so one half
    pitch between a trough and a crest, with symmetry planes at both (u_z fixed
    or driven, no rotation), represents it exactly away from the grips: the
    half-gauge elongation U maps to U * (pitch/2) / (gauge/2) on the cell and the
    force is the cell's axial reaction.  Default model: axisymmetric shell
    (:mod:`harnesspipe.fe.elements.shell_axisym`); ``model="shell3d"`` runs the same cell
    with the 4-node 3D shell on half the circumference (used to verify it).
``open_tube``
    The same tube with a longitudinal cut.  ``model="shell3d"``: 3D shell cell
    on half the circumference, mirror symmetry on the plane through the axis and
    the cut, so that self-contact across the cut is contact of the cut edge with
    that plane (penalty); ``cut=False`` on the same mesh is the closed tube.
    The default (as for the calibration) is the axisymmetric model, i.e. the cut
    is neglected, as the paper finds it barely matters (Sec. 3.2).  Measured
    here: the cut lowers the initial stiffness by about 6 % (test_tensile.py,
    bench/bench_tensile.py); the calibrated E of the open tube absorbs it.
``fabric_tube``
    Unwrapped PET fabric sheet 150 x 49 x 0.6, gauge 75, modelled between the
    grips (75 x 49) with the 3D shell on a quarter (two symmetry planes).  The
    grips move the end axially and let it contract laterally: uniaxial stress,
    the condition under which eq. 3 holds.  The field is then homogeneous, so
    one element is exact and both presets use it.  Pulled by ``elongation`` (15 mm by
    default: 20 % strain, past yield and well into hardening for Table 2
    values; the test itself runs to breakage).

Each ``simulate`` returns a DataFrame with columns ``displacement_mm, force_N``
at ``n_steps + 1`` equally spaced displacements (start 0), deterministic.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from harnesspipe.fe.elements.shell import DOF_PER_NODE, Shell
from harnesspipe.fe.elements.shell_axisym import AxisymShell
from harnesspipe.fe.solvers.static_dense import Controls, solve

COMPONENTS = ("closed_tube", "open_tube", "fabric_tube")
POISSON = {"closed_tube": 0.42, "open_tube": 0.42, "fabric_tube": 0.4}  # PP, polyester (Sec. 3.2)


@dataclass(frozen=True)
class TubeGeometry:
    """Ridged tube and its test (Sec. 2.1, Fig. 5); lengths in mm."""

    d_inner: float = 10.7
    d_outer: float = 14.1
    wall: float = 0.27
    pitch: float = 3.0          # not given in the paper: documented default
    gauge: float = 114.3
    extension: float = 50.0     # crosshead travel; the half model moves extension/2

    @property
    def mid_radii(self) -> tuple[float, float]:
        """Mid-surface radius at the trough and at the crest."""
        return 0.5 * self.d_inner + 0.5 * self.wall, 0.5 * self.d_outer - 0.5 * self.wall

    def radius(self, z):
        """Sinusoidal mid-surface r(z): trough at z = 0, crest at z = pitch/2."""
        r_t, r_c = self.mid_radii
        return 0.5 * (r_t + r_c) - 0.5 * (r_c - r_t) * np.cos(2.0 * np.pi * z / self.pitch)

    def slope(self, z):
        """dr/dz of the mid-surface."""
        r_t, r_c = self.mid_radii
        k = 2.0 * np.pi / self.pitch
        return 0.5 * (r_c - r_t) * k * np.sin(k * z)

    def cell_displacement(self, half_model_displacement):
        """Elongation of the half-pitch cell for an elongation of the half model."""
        return half_model_displacement * (0.5 * self.pitch) / (0.5 * self.gauge)


@dataclass(frozen=True)
class FabricGeometry:
    """Unwrapped fabric tube sample (Sec. 2.1, Fig. 6b): 150 x 49 x 0.6, gauge 75."""

    gauge: float = 75.0
    width: float = 49.0
    thickness: float = 0.6
    elongation: float = 15.0

    @property
    def area(self) -> float:
        return self.width * self.thickness


@dataclass(frozen=True)
class Resolution:
    """Mesh and stepping: elements along the half pitch (meridian), around the half
    circumference (3D tube), along/across the fabric quarter, and load steps."""

    meridian: int
    circumference: int
    fabric_length: int
    fabric_width: int
    n_steps: int


PRESETS = {
    "quick": Resolution(meridian=12, circumference=8, fabric_length=1, fabric_width=1, n_steps=16),
    "default": Resolution(meridian=32, circumference=16, fabric_length=1, fabric_width=1, n_steps=25),
}


def resolution(preset: str | Resolution = "default", **overrides) -> Resolution:
    """A preset by name (``quick``/``default``) with optional field overrides."""
    res = preset if isinstance(preset, Resolution) else PRESETS[preset]
    return replace(res, **overrides) if overrides else res


def meridian_mesh(geom: TubeGeometry, n_elements: int):
    """Nodes (r, z) equally spaced in arc length from trough to crest, their
    normal angles Phi (normal = (cos Phi, sin Phi), outward) and 2-node connectivity."""
    z_fine = np.linspace(0.0, 0.5 * geom.pitch, 4001)
    r_fine = geom.radius(z_fine)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(z_fine), np.diff(r_fine)))])
    z = np.interp(np.linspace(0.0, arc[-1], n_elements + 1), arc, z_fine)
    X = np.column_stack([geom.radius(z), z])
    Phi = np.arctan2(-geom.slope(z), 1.0)
    conn = np.column_stack([np.arange(n_elements), np.arange(1, n_elements + 1)])
    return X, Phi, conn


def _curve(displacement, lam_hist, reaction_hist, n_steps):
    """Force at the n_steps + 1 equally spaced output displacements."""
    lam = np.linspace(0.0, 1.0, n_steps + 1)
    force = np.interp(lam, lam_hist, reaction_hist)
    return pd.DataFrame({"displacement_mm": lam * displacement, "force_N": force})


def simulate_axisymmetric_tube(E, sigma_y, K, n, nu=0.42, *, geometry=TubeGeometry(),
                               res: Resolution = PRESETS["default"]) -> pd.DataFrame:
    """Closed ridged tube, half-pitch cell, axisymmetric shell."""
    X, Phi, conn = meridian_mesh(geometry, res.meridian)
    model = AxisymShell(X, Phi, conn, geometry.wall, E, nu, sigma_y, K, n)
    top = res.meridian
    fixed = [1, 2, 3 * top + 2]            # trough plane: u_z = 0; both planes: theta = 0
    driven = [3 * top + 1]                 # crest plane: u_z driven
    half_model_u = 0.5 * geometry.extension
    hist = solve(model, fixed, driven, [geometry.cell_displacement(half_model_u)],
                 controls=Controls(n_steps=res.n_steps))
    return _curve(half_model_u, hist.lam, hist.reaction, res.n_steps)


def surface_mesh(u_values, v_values, surface):
    """Quadrilaterals on the parameter grid u x v mapped by ``surface(u, v) -> (x, y, z)``;
    node index = j * len(u) + i, element axes xi along u and eta along v."""
    X = np.array([surface(u, v) for v in v_values for u in u_values], dtype=float)
    nu_ = len(u_values)
    conn = np.array([[j * nu_ + i, j * nu_ + i + 1, (j + 1) * nu_ + i + 1, (j + 1) * nu_ + i]
                     for j in range(len(v_values) - 1) for i in range(nu_ - 1)])
    return X, conn


def _dofs(nodes, components):
    return (DOF_PER_NODE * np.asarray(nodes)[:, None] + np.asarray(components)[None, :]).ravel()


def simulate_shell_tube(E, sigma_y, K, n, nu=0.42, *, cut: bool, geometry=TubeGeometry(),
                        res: Resolution = PRESETS["default"], contact_stiffness: float | None = None,
                        lip_contact: bool = True):
    """Ridged tube, half-pitch cell on half the circumference (theta in [0, pi]), 3D shell.

    Planes z = 0 (trough) and z = pitch/2 (crest): symmetry (u_z fixed/driven,
    no rotation about x, y).  Plane y = 0 at theta = pi: mirror symmetry.  At
    theta = 0 the same symmetry for the closed tube; for the open tube the cut
    edge is free and, with ``lip_contact``, its contact with its mirror image (the other
    lip) is a penalty keeping y >= 0; without it the lips pass each other, and the wall's
    rings, open C's, change radius without hoop force.
    One u_x is held against rigid translation.  Force: twice the cell's reaction.
    """
    Xm, Phi, _ = meridian_mesh(geometry, res.meridian)
    theta = np.linspace(0.0, np.pi, res.circumference + 1)
    X, conn = surface_mesh(theta, np.arange(res.meridian + 1),
                           lambda t, k: (Xm[k, 0] * np.cos(t), Xm[k, 0] * np.sin(t), Xm[k, 1]))
    normals = np.array([(np.cos(Phi[k]) * np.cos(t), np.cos(Phi[k]) * np.sin(t), np.sin(Phi[k]))
                        for k in range(res.meridian + 1) for t in theta])
    nt = theta.size
    trough, crest = np.arange(nt), np.arange(res.meridian * nt, X.shape[0])
    cut_edge, far_edge = np.arange(0, X.shape[0], nt), np.arange(nt - 1, X.shape[0], nt)
    fixed = [_dofs(trough, [2, 3, 4]), _dofs(crest, [3, 4]),
             _dofs(far_edge, [1, 3, 5]), _dofs(far_edge[:1], [0])]
    contact = None
    if cut and lip_contact:
        k_c = contact_stiffness or 100.0 * E * geometry.wall
        contact = (cut_edge, 1, k_c)
    elif not cut:
        fixed.append(_dofs(cut_edge, [1, 3, 5]))
    fixed = np.unique(np.concatenate(fixed))
    driven = np.setdiff1d(_dofs(crest, [2]), fixed)
    model = Shell(X, conn, geometry.wall, E, nu, sigma_y, K, n, directors=normals, contact=contact)
    model.hold(fixed)
    half_model_u = 0.5 * geometry.extension
    hist = solve(model, fixed, driven, np.full(driven.size, geometry.cell_displacement(half_model_u)),
                 controls=Controls(n_steps=res.n_steps))
    return _curve(half_model_u, hist.lam, 2.0 * np.asarray(hist.reaction), res.n_steps)


def simulate_fabric(E, sigma_y, K, n, nu=0.4, *, geometry=FabricGeometry(),
                    res: Resolution = PRESETS["default"]) -> pd.DataFrame:
    """Unwrapped fabric between the grips, quarter model (x in [0, L/2], y in [0, w/2]).

    Symmetry on x = 0 and y = 0; the grip edge x = L/2 moves by half the
    elongation and slides laterally.  The sheet stays plane: u_z and the
    rotations are held.  Force: twice the quarter's reaction.
    """
    X, conn = surface_mesh(np.linspace(0.0, 0.5 * geometry.gauge, res.fabric_length + 1),
                           np.linspace(0.0, 0.5 * geometry.width, res.fabric_width + 1),
                           lambda x, y: (x, y, 0.0))
    nodes = np.arange(X.shape[0])
    grip = np.flatnonzero(np.isclose(X[:, 0], 0.5 * geometry.gauge))
    fixed = np.unique(np.concatenate([_dofs(nodes, [2, 3, 4, 5]),
                                      _dofs(np.flatnonzero(X[:, 0] == 0.0), [0]),
                                      _dofs(np.flatnonzero(X[:, 1] == 0.0), [1])]))
    driven = _dofs(grip, [0])
    model = Shell(X, conn, geometry.thickness, E, nu, sigma_y, K, n)
    model.hold(fixed)
    hist = solve(model, fixed, driven, np.full(driven.size, 0.5 * geometry.elongation),
                 controls=Controls(n_steps=res.n_steps))
    return _curve(geometry.elongation, hist.lam, 2.0 * np.asarray(hist.reaction), res.n_steps)


def crosshead_scale(component: str) -> float:
    """Crosshead travel per model displacement: 2 for the tubes' symmetric half model
    (Sec. 3.2: 25 mm on the half for the 50 mm test), 1 for the fabric sheet."""
    return 1.0 if component == "fabric_tube" else 2.0


def simulate(component: str, E: float, sigma_y: float, K: float, n: float, nu: float | None = None,
             *, preset: str | Resolution = "default", model: str | None = None,
             pitch: float = 3.0, elongation: float | None = None, **mesh) -> pd.DataFrame:
    """Force-displacement curve of the tensile test of ``component``.

    ``E, sigma_y, K, n``: eq. 2 material (MPa); ``nu`` defaults to 0.42 (PP) or
    0.4 (polyester).  ``preset``: ``"quick"`` or ``"default"`` (or a
    :class:`Resolution`); ``mesh`` overrides its fields (``meridian=``,
    ``circumference=``, ``fabric_length=``, ``fabric_width=``, ``n_steps=``).
    ``model``: ``"axisymmetric"`` (tubes' default, cut neglected) or ``"shell3d"`` (the
    fabric's only model).
    ``pitch``: corrugation pitch of the tubes.  ``elongation``: crosshead travel
    of the fabric test (default 15 mm); the tubes follow the paper (25 mm on the
    half model).  Displacement is that of the paper's model: the half model's
    end for the tubes, the grip separation for the fabric.
    """
    if component not in COMPONENTS:
        raise ValueError(f"unknown component {component!r}; expected one of {COMPONENTS}")
    if model not in (None, "axisymmetric", "shell3d") or (model == "axisymmetric"
                                                          and component == "fabric_tube"):
        raise ValueError(f"model {model!r} is not available for {component}")
    nu = POISSON[component] if nu is None else nu
    if not (E > 0 and sigma_y >= 0 and K >= 0 and n > 0 and -1.0 < nu < 0.5):
        raise ValueError(f"invalid material: E={E}, sigma_y={sigma_y}, K={K}, n={n}, nu={nu} "
                         "(need E > 0, sigma_y >= 0, K >= 0, n > 0, -1 < nu < 0.5)")
    res = resolution(preset, **mesh)
    if component in ("closed_tube", "open_tube") and model in (None, "axisymmetric"):
        return simulate_axisymmetric_tube(E, sigma_y, K, n, nu, geometry=TubeGeometry(pitch=pitch),
                                          res=res)
    if component in ("closed_tube", "open_tube"):
        return simulate_shell_tube(E, sigma_y, K, n, nu, cut=component == "open_tube",
                                   geometry=TubeGeometry(pitch=pitch), res=res)
    geometry = FabricGeometry() if elongation is None else FabricGeometry(elongation=elongation)
    return simulate_fabric(E, sigma_y, K, n, nu, geometry=geometry, res=res)
