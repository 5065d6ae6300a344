"""Equivalent smooth shell of the ridged (corrugated) plastic tube for the hi-fi models.

An isotropic J2 shell with the ridged wall's axial membrane stiffness k_ax and hoop
bending stiffness D_h = E I_w: t_eq = sqrt(12 D_h / k_ax), E_eq = k_ax / t_eq, nu 0.  Its
hardening law (eq. 2) is fitted to the ridged cell's axial membrane law N(eps), the mean
of tension and compression up to CELL_STRAIN (:func:`cell_membrane_law`); rho_eq keeps
the mass per unit area.  t_eq is a section thickness, not a geometry (contact:
t_contact = (d_o - d_i)/2), and the hoop membrane stiffness is ~50 x too soft.

Theory and limits: docs/theory/tube_equivalent.md.
"""
from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import numpy as np
from scipy.optimize import brentq, least_squares

from harnesspipe.models.tensile import (TubeGeometry, resolution, simulate_axisymmetric_tube,
                                        simulate_shell_tube)

__all__ = ["equivalent_shell", "ridged_section", "strip_axial_stiffness", "axial_stiffness_fe",
           "cell_membrane_law", "uniaxial_stress", "ring_ovalisation", "from_config",
           "hoop_moment_curvature", "wall_resultants", "wall_row"]

RING_OVALISATION = 0.149  # diametral line load on a ring: delta = 0.149 P R^3 / (E I)
CELL_STRAIN = 0.12        # the membrane law is fitted over |eps| <= 12 % (the wall's range in the test)
CELL_STEPS = 48           # load steps of the cell to CELL_STRAIN (a point every 0.25 %)
CELL_MERIDIAN = 32        # elements on the cell's half-pitch meridian (the tensile stage's default)
SLIT_CELL_CIRCUMFERENCE = 16   # elements on the slit cell's half ring (the tensile stage's default)
HOOP_STRAIN = 0.12        # the hoop moment-curvature law is fitted up to this strain at the crest fibre
HOOP_POINTS = 48          # curvatures of that fit


def ridged_section(geometry: TubeGeometry = TubeGeometry(), n: int = 4001) -> dict:
    """Geometric properties of one corrugation pitch of the ridged wall.

    Returns ``radius`` (mean mid radius R), ``amplitude`` A, ``arc_factor`` (arc length /
    pitch), ``I`` (second moment about r = R of the wall section per unit axial length,
    mm^3: exact for the wall region between the offset curves mid +- t/2 along the normal,
    by polygon integration), ``I_thin`` (thin-wall estimate ``t (r-R)^2 + t^3 cos^2/12``
    along the arc; 2.6 % lower for the default tube, the crest curvature radius 0.32 mm is
    comparable with t), ``area`` (wall area per unit axial length, mm), ``t_contact`` =
    (d_o-d_i)/2.
    """
    z = np.linspace(0.0, geometry.pitch, n)
    r = geometry.radius(z)
    drdz = geometry.slope(z)
    ds = np.sqrt(1.0 + drdz ** 2)                       # ds/dz
    t = geometry.wall
    p = geometry.pitch
    R = 0.5 * sum(geometry.mid_radii)
    normal = np.column_stack([-drdz / ds, 1.0 / ds])
    mid = np.column_stack([z, r])
    poly = np.vstack([mid + 0.5 * t * normal, (mid - 0.5 * t * normal)[::-1]])
    zp, v = poly[:, 0], poly[:, 1] - R
    zn, vn = np.roll(zp, -1), np.roll(v, -1)
    cross = zp * vn - zn * v                             # clockwise polygon: negative
    area = -0.5 * cross.sum()
    I_poly = -(cross * (v * v + v * vn + vn * vn)).sum() / 12.0
    cos2 = 1.0 / ds ** 2                                 # cos^2 of the wall angle to the axis
    I_thin = np.trapezoid(t * (r - R) ** 2 * ds + t ** 3 / 12.0 * cos2 * ds, z) / p
    return {
        "radius": R,
        "amplitude": 0.5 * (geometry.mid_radii[1] - geometry.mid_radii[0]),
        "arc_factor": np.trapezoid(ds, z) / p,
        "I": float(I_poly / p),
        "I_thin": float(I_thin),
        "area": float(area / p),
        "t_contact": 0.5 * (geometry.d_outer - geometry.d_inner),
    }


def strip_axial_stiffness(E: float, nu: float, geometry: TubeGeometry = TubeGeometry(),
                          n: int = 4001) -> float:
    """Closed form (Castigliano) axial stiffness N/eps (N/mm) of a corrugated plane-strain
    strip of unit width with the tube's wall profile: bending by M = N (r - R) plus
    membrane N cos(phi); the hoop restraint of the real tube is neglected (softer)."""
    z = np.linspace(0.0, geometry.pitch, n)
    r = geometry.radius(z)
    ds = np.sqrt(1.0 + geometry.slope(z) ** 2)
    t = geometry.wall
    Ep = E / (1.0 - nu ** 2)
    D = Ep * t ** 3 / 12.0
    R = 0.5 * sum(geometry.mid_radii)
    compliance = np.trapezoid(((r - R) ** 2 / D + 1.0 / ds ** 2 / (Ep * t)) * ds, z) / geometry.pitch
    return 1.0 / compliance


def _cell(E, sigma_y, K, n, nu, geometry: TubeGeometry, slit: bool, meridian: int, n_steps: int):
    """The ridged wall's cell at ``geometry.extension``: the tensile stage's axisymmetric
    half-pitch cell, or for a ``slit`` wall its 3D half-pitch cell of the slit ring with the
    lips passing each other (no hoop force: each ring of the wall is an open C that changes
    its radius by opening).  Returns the tube's force curve (``simulate_*`` frames)."""
    res = resolution("default", meridian=meridian, n_steps=n_steps,
                     circumference=SLIT_CELL_CIRCUMFERENCE)
    if slit:
        return simulate_shell_tube(E, sigma_y, K, n, nu, cut=True, geometry=geometry, res=res,
                                   lip_contact=False)
    return simulate_axisymmetric_tube(E, sigma_y, K, n, nu, geometry=geometry, res=res)


@lru_cache(maxsize=32)
def _unit_axial_stiffness(geometry: TubeGeometry, nu: float, meridian: int, strain: float,
                          slit: bool) -> float:
    E = 1000.0
    g = replace(geometry, extension=strain * geometry.gauge)   # half model moves strain*gauge/2
    df = _cell(E, 1.0e3 * E, 0.0, 1.0, nu, g, slit, meridian, 1)
    force = float(df["force_N"].iloc[-1])
    R = 0.5 * sum(geometry.mid_radii)
    return force / (2.0 * np.pi * R * strain) / E


def axial_stiffness_fe(E: float, nu: float, geometry: TubeGeometry = TubeGeometry(),
                       meridian: int = 48, strain: float = 1.0e-5, slit: bool = False) -> float:
    """Axial membrane stiffness N/eps (N/mm per unit circumference) of the ridged tube from the
    tensile stage's axisymmetric shell (elastic, small strain; linear in E); of a ``slit``
    tube from its 3D cell with free lips (:func:`_cell`), ~0.78 x the closed tube's for
    the default geometry, as the free strip (:func:`strip_axial_stiffness`) has it: the
    closed rings' hoop force, which holds the ridges from flattening, is gone."""
    return E * _unit_axial_stiffness(geometry, float(nu), int(meridian), float(strain), bool(slit))


@lru_cache(maxsize=32)
def cell_membrane_law(E: float, sigma_y: float, K: float, n: float, nu: float,
                      geometry: TubeGeometry = TubeGeometry(), strain: float = CELL_STRAIN,
                      n_steps: int = CELL_STEPS, meridian: int = CELL_MERIDIAN, slit: bool = False):
    """Axial membrane force per unit circumference N (N/mm) of the ridged tube under uniform
    axial strain, from the tensile stage's axisymmetric half-pitch cell with the wall's eq. 2
    material (finite strain, J2), or a ``slit`` tube's 3D cell with free lips (:func:`_cell`):
    returns ``eps`` (n_steps + 1,) from 0 to ``strain`` and ``N_t``, ``N_c`` (n_steps + 1,),
    the magnitudes in tension and in compression.

    The corrugated wall stretches by unbending its ridges: it stays nearly linear to a few
    per cent, far beyond the material's yield strain, and it is stiffer in tension (the
    ridges straighten) than in compression (they fold)."""
    forces = []
    for sign in (1.0, -1.0):
        g = replace(geometry, extension=sign * strain * geometry.gauge)
        df = _cell(E, sigma_y, K, n, nu, g, slit, meridian, n_steps)
        forces.append(np.abs(df["force_N"].to_numpy()) / (np.pi * sum(geometry.mid_radii)))
    eps = np.linspace(0.0, strain, n_steps + 1)
    return eps, forces[0], forces[1]


def uniaxial_stress(eps, E: float, sigma_y: float, K: float, n: float) -> np.ndarray:
    """Stress (magnitude) of the eq. 2 J2 law under monotonic uniaxial strain ``eps`` (>= 0):
    ``sigma = E eps`` up to sigma_y, then ``sigma = sigma_y + K (eps - sigma / E)^n``."""
    eps = np.asarray(eps, dtype=float)
    out = np.minimum(E * eps, sigma_y) if sigma_y > 0 else np.zeros_like(eps)
    for i, e in enumerate(eps):
        if E * e > sigma_y:
            out[i] = brentq(lambda s: s - sigma_y - K * max((E * e - s) / E, 0.0) ** n,
                            sigma_y, E * e, xtol=1e-14, rtol=1e-13)
    return out


def fit_membrane_plasticity(eps, N, E_eq: float, t_eq: float) -> tuple[float, float, float]:
    """(sigma_y, K, n) of the equivalent shell whose membrane force ``t_eq sigma(eps)``
    (:func:`uniaxial_stress` at E_eq) fits ``N(eps)`` in least squares; eps > 0 points."""
    sel = eps > 0.0
    e, target = eps[sel], N[sel]
    scale = float(target.max())

    def residual(p):
        return (t_eq * uniaxial_stress(e, E_eq, *p) - target) / scale

    start = [0.5 * scale / t_eq, scale / t_eq, 0.5]
    fit = least_squares(residual, start, bounds=([1e-9, 0.0, 0.02], [np.inf, np.inf, 1.0]),
                        x_scale=[start[0], start[1], 0.5], xtol=1e-12, ftol=1e-12)
    return float(fit.x[0]), float(fit.x[1]), float(fit.x[2])


def ring_ovalisation(P: float, radius: float, EI: float) -> float:
    """Change of diameter along a diametral line load P (N per unit length) of a ring."""
    return RING_OVALISATION * P * radius ** 3 / EI


def equivalent_shell(E: float, sigma_y: float, K: float, n: float,
                     geometry: TubeGeometry = TubeGeometry(), *, nu: float = 0.42,
                     rho: float | None = None, method: str = "fe", meridian: int = 48) -> dict:
    """Isotropic J2 shell equivalent to the ridged tube wall (docs/theory/tube_equivalent.md).

    ``E, sigma_y, K, n``: material of the ridged wall (Table 2 / tensile stage).  ``nu``:
    material Poisson ratio (used for the ridged reference only).  ``rho``: material density
    (optional; gives ``rho``).  ``method``: ``"fe"`` (axisymmetric shell, default) or
    ``"strip"`` (closed form, softer) for the axial stiffness.

    Returns ``E, sigma_y, K, n, t, radius`` (the equivalent smooth shell: section thickness
    ``t``, mid radius ``radius``; the hardening law fitted to the ridged cell's mean membrane
    law, :func:`cell_membrane_law`), ``nu`` (0.0), ``t_contact`` (geometric thickness for
    contact), ``rho`` (if given), and diagnostics ``axial_stiffness`` (N/mm),
    ``hoop_bending_stiffness`` (N mm), ``hoop_membrane_ratio`` (ridged/equivalent),
    ``membrane_fit_error`` (largest relative error of the equivalent's membrane force
    against the cell's mean from 1 % strain), ``tension_over_compression`` (the cell's
    N_t / N_c at CELL_STRAIN, which one isotropic law cannot follow), ``yield_strain``
    (the equivalent's, against the material's ``material_yield_strain``),
    ``hoop_yield_moment`` and ``hoop_yield_moment_ridged`` (N mm/mm: sigma_y t^2/6 of the
    equivalent; first yield of the ridged wall section, sigma_y I / (A + t/2)),
    ``strip_axial_stiffness``.
    """
    if not (E > 0 and sigma_y >= 0 and K >= 0 and n > 0):
        raise ValueError(f"invalid tube material: E={E}, sigma_y={sigma_y}, K={K}, n={n}")
    sec = ridged_section(geometry)
    k_strip = strip_axial_stiffness(E, nu, geometry)
    if method == "fe":
        k_ax = axial_stiffness_fe(E, nu, geometry, meridian=meridian)
    elif method == "strip":
        k_ax = k_strip
    else:
        raise ValueError(f"method must be 'fe' or 'strip', not {method!r}")
    D_h = E * sec["I"]
    t_eq = float(np.sqrt(12.0 * D_h / k_ax))
    E_eq = float(k_ax / t_eq)
    eps, N_t, N_c = cell_membrane_law(float(E), float(sigma_y), float(K), float(n), float(nu),
                                      geometry)
    N_mean = 0.5 * (N_t + N_c)
    sy_eq, K_eq, n_eq = fit_membrane_plasticity(eps, N_mean, E_eq, t_eq)
    N_eq = t_eq * uniaxial_stress(eps, E_eq, sy_eq, K_eq, n_eq)
    from_1 = eps >= 0.01
    out = {
        "E": E_eq, "sigma_y": sy_eq, "K": K_eq, "n": n_eq,
        "t": t_eq, "radius": sec["radius"], "nu": 0.0, "t_contact": sec["t_contact"],
        "axial_stiffness": float(k_ax), "hoop_bending_stiffness": float(D_h),
        "hoop_membrane_ratio": float(E * sec["area"] / k_ax),
        "membrane_fit_error": float(np.max(np.abs(N_eq[from_1] / N_mean[from_1] - 1.0))),
        "tension_over_compression": float(N_t[-1] / N_c[-1]),
        "yield_strain": sy_eq / E_eq, "material_yield_strain": sigma_y / E,
        "hoop_yield_moment": sy_eq * t_eq ** 2 / 6.0,
        "hoop_yield_moment_ridged": float(sigma_y * sec["I"]
                                          / (sec["amplitude"] + 0.5 * geometry.wall)),
        "strip_axial_stiffness": float(k_strip),
    }
    if rho is not None:
        out["rho"] = float(rho * sec["area"] / t_eq)
    return out


def from_config(config: dict, covering: str, material: dict) -> dict:
    """:func:`equivalent_shell` for a ``coverings`` entry of the config (closed/open tube) and
    an eq. 2 material dict ``{E, sigma_y, K, n}`` (e.g. the tensile stage's Table 2 row)."""
    cov = config["coverings"][covering]
    if "d_i" not in cov:
        raise ValueError(f"covering {covering!r} is not a ridged tube")
    geom = TubeGeometry(d_inner=cov["d_i"], d_outer=cov["d_o"], wall=cov["t"], pitch=cov["pitch"])
    mat = config["materials"][cov["material"]]
    return equivalent_shell(material["E"], material["sigma_y"], material["K"], material["n"], geom,
                            nu=mat.get("nu", 0.42), rho=mat.get("rho"))


def _wall_cells(geometry: TubeGeometry, n_arc: int = 1201, n_thick: int = 12):
    """Cells of the ridged wall region over one pitch: centroid distance ``v = r - R`` from
    the mean mid radius and area (n_cells,), from a grid of the offset curves
    mid + s normal, s in [-t/2, t/2] (each cell's area from its diagonals)."""
    z = np.linspace(0.0, geometry.pitch, n_arc)
    r = geometry.radius(z)
    drdz = geometry.slope(z)
    ds = np.sqrt(1.0 + drdz ** 2)
    normal = np.column_stack([-drdz / ds, 1.0 / ds])
    s = np.linspace(-0.5 * geometry.wall, 0.5 * geometry.wall, n_thick + 1)
    P = np.column_stack([z, r])[:, None, :] + s[None, :, None] * normal[:, None, :]
    d1 = P[1:, 1:] - P[:-1, :-1]
    d2 = P[:-1, 1:] - P[1:, :-1]
    area = 0.5 * np.abs(d1[..., 0] * d2[..., 1] - d1[..., 1] * d2[..., 0])
    v = 0.25 * (P[1:, 1:, 1] + P[:-1, :-1, 1] + P[:-1, 1:, 1] + P[1:, :-1, 1])
    return (v - 0.5 * sum(geometry.mid_radii)).ravel(), area.ravel()


def hoop_moment_curvature(E: float, sigma_y: float, K: float, n: float,
                          geometry: TubeGeometry = TubeGeometry(), strain: float = HOOP_STRAIN,
                          n_points: int = HOOP_POINTS):
    """Hoop bending moment per unit axial length M(kappa) (N mm/mm) of the ridged wall
    section under a change of ring curvature ``kappa`` (1/mm): the fibre at ``v = r - R``
    strains ``kappa v`` (plane sections of the ring wall) and carries the uniaxial eq. 2
    stress of the material, M = (1/p) integral sigma v dA.  Returns ``kappa`` (n_points +
    1,) up to the curvature at which the crest fibre reaches ``strain``, and ``M``."""
    v, dA = _wall_cells(geometry)
    kappa = np.linspace(0.0, strain / np.max(np.abs(v)), n_points + 1)
    eps_table = np.linspace(0.0, strain * 1.001, 4001)
    sig_table = uniaxial_stress(eps_table, E, sigma_y, K, n)
    M = np.array([np.sum(np.sign(v) * np.interp(np.abs(k * v), eps_table, sig_table) * v * dA)
                  for k in kappa]) / geometry.pitch
    return kappa, M


def flow_table(x, y, k: float, n_tab: int) -> tuple[np.ndarray, np.ndarray]:
    """Piecewise-linear flow table (alpha_j, H_j), n_tab points, of a monotonic loading
    curve ``y(x)`` (x from 0) for a 1D elastoplastic law with unloading stiffness ``k``
    (at least the curve's steepest tangent): alpha = x - y / k.  The table starts at the
    curve's last point with alpha = 0 (the elastic limit; (0, 0) if there is none) and
    samples the rest quadratically in x (dense at the knee, where eq. 2's slope is
    steepest), so that monotonic loading of the law reproduces the curve's linear
    interpolation through those points."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    alpha = x - y / k
    if np.any(np.diff(alpha) < -1e-12 * x[-1]):
        raise ValueError("flow_table: the curve is steeper than the unloading stiffness")
    i0 = int(np.flatnonzero(alpha <= 1e-9 * x[-1]).max())
    xs = x[i0] + (x[-1] - x[i0]) * np.linspace(0.0, 1.0, n_tab) ** 2   # dense at the knee
    ys = np.interp(xs, x, y)
    a = np.maximum(xs - ys / k, 0.0)
    a[0] = 0.0
    return a, ys


def wall_resultants(E: float, sigma_y: float, K: float, n: float,
                    geometry: TubeGeometry = TubeGeometry(), *, nu: float = 0.42,
                    slit: bool = False) -> dict:
    """Resultant stiffnesses and flow tables of the ridged wall for the shell law of
    :mod:`harnesspipe.fe.materials.tube_wall` (docs/theory/tube_equivalent.md), per unit
    length of the mean cylinder (radius ``R``):

    * ``k_ax`` the axial membrane stiffness of the ridged cell (:func:`axial_stiffness_fe`);
      ``tension`` and ``compression``: flow tables (:func:`flow_table`) of the cell's
      N_t and N_c (:func:`cell_membrane_law`) against the logarithmic strain (the shell
      integrates its strain rate: ln(1 + eps) of the cell's extension / gauge), at the
      unloading stiffness ``k_e`` (k_ax, or the cell's steepest tangent if larger: in
      tension the straightening ridges stiffen the wall by up to ~10 % before it yields);
    * ``k_h = E A_w`` the hoop membrane stiffness (A_w the wall area per unit length) and
      ``k_s = G t / arc`` the in-plane shear stiffness of the corrugated wall (its shear
      flow runs along the arc);
    * ``D_h = E I_w`` the hoop bending stiffness and ``hoop``: the flow table of
      :func:`hoop_moment_curvature`;
    * ``D_x = E t^3 / (12 arc)`` the wall's own bending along the axis (the corrugated
      wall bends across its ridges through the wall alone: compliance ds / (E I));
    * ``kGt = 5/6 G t`` its transverse shear stiffness; ``mass_thickness = A_w``
      (the shell's thickness: mass per area rho A_w);
    * ``cell``: the cell's (eps, N_t, N_c) and ``hoop_curve`` the section's (kappa, M),
      the references the law is checked against.

    ``slit``: the axial laws of a tube slit along its length whose lips are free (the tube
    alone on the pins), from the slit ring's cell (:func:`cell_membrane_law`): ~0.78 x the
    closed wall's, since open rings do not hold the ridges from flattening by hoop force.
    Where the lips bear on each other (a slit tube rolled shut onto its bundle) the closed
    cell stands nearer: the tensile stage's slit cell with its lips in contact carries
    0.93 x the closed one elastically.
    """
    from harnesspipe.fe.materials.tube_wall import N_TAB
    if not (E > 0 and sigma_y >= 0 and K >= 0 and n > 0):
        raise ValueError(f"invalid tube material: E={E}, sigma_y={sigma_y}, K={K}, n={n}")
    sec = ridged_section(geometry)
    G = E / (2.0 * (1.0 + nu))
    k_ax = axial_stiffness_fe(E, nu, geometry, slit=slit)
    eps, N_t, N_c = cell_membrane_law(float(E), float(sigma_y), float(K), float(n), float(nu),
                                      geometry, slit=bool(slit))
    tangent = max(np.max(np.diff(N_t) / np.diff(np.log1p(eps))),
                  np.max(np.diff(N_c) / np.diff(-np.log1p(-eps))))
    k_e = max(k_ax, 1.02 * tangent)
    kappa, M = hoop_moment_curvature(E, sigma_y, K, n, geometry)
    v, dA = _wall_cells(geometry)
    D_h = float(E * np.sum(v * v * dA) / geometry.pitch)   # E I_w of the same cells (I: 0.03 %)
    return {"k_ax": float(k_ax), "k_e": float(k_e), "k_h": float(E * sec["area"]),
            "k_s": float(G * geometry.wall / sec["arc_factor"]), "D_h": D_h,
            "D_x": float(E * geometry.wall ** 3 / 12.0 / sec["arc_factor"]),
            "kGt": float(5.0 / 6.0 * G * geometry.wall), "mass_thickness": float(sec["area"]),
            "radius": sec["radius"], "t_contact": sec["t_contact"],
            "tension": flow_table(np.log1p(eps), N_t, k_e, N_TAB),
            "compression": flow_table(-np.log1p(-eps), N_c, k_e, N_TAB),
            "hoop": flow_table(kappa, M, D_h, N_TAB),
            "cell": (eps, N_t, N_c), "hoop_curve": (kappa, M)}


def wall_row(w: dict, kind: float) -> np.ndarray:
    """The shell material row (fe.materials.tube_wall layout, material kind ``kind`` at
    index 5) of :func:`wall_resultants` ``w``."""
    from harnesspipe.fe.materials import tube_wall as tw
    row = np.zeros(tw.ROW_WIDTH)
    row[[tw.W_KE, tw.W_DH, tw.W_DX, tw.W_KH, tw.W_KS, tw.W_KGT]] = [
        w["k_e"], w["D_h"], w["D_x"], w["k_h"], w["k_s"], w["kGt"]]
    row[5] = kind
    for o, key in ((tw.TAB_TENSION, "tension"), (tw.TAB_COMPRESSION, "compression"),
                   (tw.TAB_HOOP, "hoop")):
        row[o:o + tw.N_TAB], row[o + tw.N_TAB:o + 2 * tw.N_TAB] = w[key]
    return row


def wall_from_config(config: dict, covering: str, material: dict) -> dict:
    """:func:`wall_resultants` of a ``coverings`` entry (as :func:`from_config`), with the
    material density ``rho``; a ``cut`` tube's axial laws are the slit ring's (the CWB
    model takes this law for a slit tube only as moulded, its lips apart)."""
    cov = config["coverings"][covering]
    geom = TubeGeometry(d_inner=cov["d_i"], d_outer=cov["d_o"], wall=cov["t"], pitch=cov["pitch"])
    mat = config["materials"][cov["material"]]
    out = wall_resultants(material["E"], material["sigma_y"], material["K"], material["n"], geom,
                          nu=mat.get("nu", 0.42), slit=bool(cov.get("cut", False)))
    out["rho"] = float(mat["rho"])
    return out
