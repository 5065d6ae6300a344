"""Equivalent smooth shell of the ridged (corrugated) plastic tube for the hi-fi models.

The tensile stage resolves the corrugation (:class:`~harnesspipe.models.tensile.TubeGeometry`:
sinusoidal mid-surface between the trough radius ``d_i/2 + t/2`` and the crest radius
``d_o/2 - t/2``, wall ``t``, pitch 3 mm).  In the three-point bending models the
corrugation pitch is far below any affordable explicit element size, so the tube is
meshed as a *smooth* cylinder (:mod:`harnesspipe.models.hifi_mesh`) and given the
properties returned by :func:`equivalent_shell`.

Homogenisation (per unit length / unit circumference of the mean cylinder of radius
``R = (r_trough + r_crest)/2 = (d_i + d_o)/4``):

(a) axial membrane stiffness ``k_ax = N / eps`` (N/mm per unit strain) of the ridged wall.
    Computed with the same axisymmetric shell the tensile stage uses
    (:func:`~harnesspipe.models.tensile.simulate_axisymmetric_tube`, elastic, strain 1e-5):
    ``k_ax = F / (2 pi R eps)``.  For the default geometry ``k_ax = 0.029 E t``: the
    corrugated wall stretches by unbending its ridges.  A closed form for comparison
    (:func:`strip_axial_stiffness`, Castigliano on a corrugated plane-strain strip) neglects
    the hoop restraint of the axisymmetric wall and is ~20 % softer (0.023 E t).
(b) hoop bending stiffness ``D_h = E I_w`` (N mm per unit length) of the ridged wall section
    for ring ovalisation, ``I_w`` the second moment of the corrugated wall section about the
    mean radius per unit axial length (:func:`ridged_section`, exact polygon integration of
    the wall region; ~ t A^2/2 x arc factor, ``A = (r_crest - r_trough)/2``): 54 x ``t^3/12``.

An isotropic shell with ``E_eq t_eq = k_ax`` and ``E_eq t_eq^3 / 12 = D_h`` matches both:
``t_eq = sqrt(12 D_h / k_ax)``, ``E_eq = k_ax / t_eq``.  The equivalent Poisson ratio is 0:
the corrugated wall has almost no axial-hoop coupling, and with nu = 0 the plate
(plane-strain) and ring (plane-stress) bending stiffnesses coincide, so (b) is matched
whichever the shell element sees.  Plasticity: ``sigma_y`` and ``K`` scaled by ``E_eq/E``,
``n`` unchanged, i.e. the equivalent yields at the material's yield strain.  Mass: ``rho_eq``
keeps the ridged wall's mass per unit area (``rho t arc/pitch``).

What the equivalent shell CANNOT represent (read before using it):

* ``t_eq`` is a *section* thickness only, 11.6 mm for the default tube (larger than the
  mid radius 6.2 mm!) with ``E_eq = 6.8e-4 E``.  It must not be used as a geometric/contact
  thickness: the contact envelope of the ridged tube is the mid radius ``R`` +-
  ``t_contact/2``, ``t_contact = (d_o-d_i)/2`` (inner face d_i/2, outer face d_o/2), returned as ``t_contact`` and used by the mesh.  A
  shell element with t_eq/R > 1 still integrates ``E t^3/12`` in bending but thin-shell
  curvature and transverse-shear corrections are meaningless at that ratio; the
  homogenisation is a stiffness fit, not a geometry.
* Hoop membrane stiffness becomes ``E_eq t_eq = k_ax``, the (soft) axial value, whereas the
  ridged wall is ~50 x stiffer in hoop membrane (``hoop_membrane_ratio``).  Loads carried by
  hoop tension/compression (internal pressure from wires pushed against the tube wall over
  a large arc) are therefore too soft; ovalisation under line loads is bending-dominated and
  is matched.  An orthotropic shell would fix this (E_hoop/E_axial ~ 50).
* Local ridge buckling/crushing, ridge-by-ridge contact (rollers sitting between crests),
  friction on a corrugated surface and the plastic hinge pattern of the corrugation are not
  represented.  Axial and hoop bending plasticity share one yield strain (the ridged wall
  first yields, at the ridge, at a different overall strain: ``first_yield_strain_ratio``).
* Axial *bending* of the wall itself (local kink of the tube wall, wavelength ~ sqrt(R t))
  gets ``E_eq t_eq^3/12`` = the hoop value; for the ridged wall it is lower.  Global beam
  bending of the tube is governed by (a) and is matched.
"""
from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import numpy as np

from harnesspipe.models.tensile import TubeGeometry, resolution, simulate_axisymmetric_tube

__all__ = ["equivalent_shell", "ridged_section", "strip_axial_stiffness", "axial_stiffness_fe",
           "ring_ovalisation", "from_config"]

RING_OVALISATION = 0.149  # diametral line load on a ring: delta = 0.149 P R^3 / (E I)


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


@lru_cache(maxsize=32)
def _unit_axial_stiffness(geometry: TubeGeometry, nu: float, meridian: int, strain: float) -> float:
    E = 1000.0
    g = replace(geometry, extension=strain * geometry.gauge)   # half model moves strain*gauge/2
    df = simulate_axisymmetric_tube(E, 1.0e3 * E, 0.0, 1.0, nu, geometry=g,
                                    res=resolution("quick", meridian=meridian, n_steps=1))
    force = float(df["force_N"].iloc[-1])
    R = 0.5 * sum(geometry.mid_radii)
    return force / (2.0 * np.pi * R * strain) / E


def axial_stiffness_fe(E: float, nu: float, geometry: TubeGeometry = TubeGeometry(),
                       meridian: int = 48, strain: float = 1.0e-5) -> float:
    """Axial membrane stiffness N/eps (N/mm per unit circumference) of the ridged tube from the
    tensile stage's axisymmetric shell (elastic, small strain; linear in E)."""
    return E * _unit_axial_stiffness(geometry, float(nu), int(meridian), float(strain))


def ring_ovalisation(P: float, radius: float, EI: float) -> float:
    """Change of diameter along a diametral line load P (N per unit length) of a ring."""
    return RING_OVALISATION * P * radius ** 3 / EI


def equivalent_shell(E: float, sigma_y: float, K: float, n: float,
                     geometry: TubeGeometry = TubeGeometry(), *, nu: float = 0.42,
                     rho: float | None = None, method: str = "fe", meridian: int = 48) -> dict:
    """Isotropic J2 shell equivalent to the ridged tube wall (module docstring).

    ``E, sigma_y, K, n``: material of the ridged wall (Table 2 / tensile stage).  ``nu``:
    material Poisson ratio (used for the ridged reference only).  ``rho``: material density
    (optional; gives ``rho``).  ``method``: ``"fe"`` (axisymmetric shell, default) or
    ``"strip"`` (closed form, softer) for the axial stiffness.

    Returns ``E, sigma_y, K, n, t, radius`` (the equivalent smooth shell: section thickness
    ``t``, mid radius ``radius``), ``nu`` (0.0), ``t_contact`` (geometric thickness for
    contact), ``rho`` (if given), and diagnostics ``axial_stiffness`` (N/mm),
    ``hoop_bending_stiffness`` (N mm), ``hoop_membrane_ratio`` (ridged/equivalent),
    ``first_yield_strain_ratio`` (overall axial strain at first yield of the ridged wall /
    that of the equivalent), ``strip_axial_stiffness``.
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
    scale = E_eq / E
    # ridged wall in tension (strip estimate): stress N/t + 6 N A/t^2 at the ridge reaches
    # sigma_y at N_y; overall strain N_y / k_ax.  Equivalent: sigma_y / E.
    t = geometry.wall
    N_y = sigma_y / (1.0 / t + 6.0 * sec["amplitude"] / t ** 2)
    out = {
        "E": E_eq, "sigma_y": sigma_y * scale, "K": K * scale, "n": n,
        "t": t_eq, "radius": sec["radius"], "nu": 0.0, "t_contact": sec["t_contact"],
        "axial_stiffness": float(k_ax), "hoop_bending_stiffness": float(D_h),
        "hoop_membrane_ratio": float(E * sec["area"] / k_ax),
        "first_yield_strain_ratio": float(N_y / k_ax / (sigma_y / E)) if sigma_y > 0 else float("nan"),
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
