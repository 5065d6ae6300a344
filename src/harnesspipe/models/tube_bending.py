"""The ridged tube alone in the three-point test: its corrugation resolved, or its smooth
equivalent shell (issue 27, item 1: the homogenisation's check in bending).

The hi-fi CWB model meshes the ridged plastic tube as a smooth cylinder with the equivalent
shell of :func:`harnesspipe.models.tube_equivalent.equivalent_shell` (docs/theory/
tube_equivalent.md).  This set-up tests that replacement where the CWB uses it: the tube
alone (length ``tube_length``) on the test's two rollers, pushed down at midspan by the
feeder (Sec. 2.2, 4.1; pins of 5 mm along z, the tube along x), once with

* ``wall="resolved"``: the corrugated wall itself, the tensile stage's sinusoidal
  mid-surface (:class:`harnesspipe.models.tensile.TubeGeometry`: trough d_i/2 + t/2, crest
  d_o/2 - t/2, wall t, the configured pitch; a crest at midspan) as Belytschko-Lin-Tsay
  shells of the Table 2 material (eq. 2, J2) and its thickness; and
* ``wall="equivalent"``: the smooth shell at the mean radius with E_eq, t_eq and the fitted
  plasticity, as the CWB model has it by default (``wall_law: isotropic``); or
* ``wall="resultant"``: the same smooth shell with the ridged wall's resultant law
  (:func:`harnesspipe.models.tube_equivalent.wall_resultants`, the CWB model's ``wall_law:
  resultant``): the cell's axial membrane laws, the section's hoop bending, the wall's own
  soft bending along the axis.

The test is symmetric about midspan (x = 0), and a closed tube's also about the loading plane
(z = 0): the model is its quarter x >= 0, z >= 0 (one roller, half the feeder), or for a
slit tube (``cut``, its slit at the side as in the CWB model) the half x >= 0; the force is
the whole tube's.
Both touch the pins at the tube's outer radius d_o/2 (the crests, or the equivalent's mid
surface plus half its contact thickness d_o/2 - d_i/2).  Both are driven like the CWB's
virtual test (the feeder's rate ramp, explicit central differences with the facets-on-pin
contact of :mod:`harnesspipe.fe.contact.facet_pins`); time is scaled by mass: the tube is
light and its first modes far above the loading rate, so a density factor brings the
stable step to ``dt_target`` and the run's KE/IE says whether it stayed quasi-static.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from harnesspipe.fe.contact.common import Cylinders
from harnesspipe.fe.contact.facet_pins import (PinFacetSet, facets_cylinder_contact,
                                              facets_cylinder_gaps)
from harnesspipe.fe.elements.shell_bt import (init_shell_state, shell_energies, shell_forces,
                                               shell_lumped_mass, shell_stable_step)
from harnesspipe.fe.elements.shell_bt_element import MAT_TUBE
from harnesspipe.fe.solvers.central_difference import DynamicsSettings, integrate, ramp_share
from harnesspipe.models.hifi_parts import Pins
from harnesspipe.models.tensile import TubeGeometry
from harnesspipe.models.tube_equivalent import equivalent_shell, wall_resultants, wall_row

FAMILIES = ("internal", "pin_contact", "pin_friction")
PIN_PATCHES = 8          # friction slots per pin (a resolved tube touches a pin on a few crests)
WALLS = ("resolved", "equivalent", "resultant")
MESH = {"resolved": {"n_circ": 16, "per_pitch": 8}, "equivalent": {"n_circ": 16, "n_axial": 32},
        "resultant": {"n_circ": 16, "n_axial": 32}}
RATE = 20.0              # mm/s of model time: KE/IE < 1 % of the resolved tube after the ramp
DT_TARGET = 2e-6         # s: the density factor's target step (the resolved tube's ~55)


@dataclass
class TubeShells:
    """A tube's shell mesh and its per-element material (fe/shell_bt layout)."""

    X: np.ndarray           # (n_nodes, 3), the tube's axis along x
    conn: np.ndarray        # (n_el, 4)
    thick: np.ndarray       # (n_el,) stiffness thickness
    contact_t: np.ndarray   # (n_el,) thickness the pins see
    mat: np.ndarray         # (n_el, 6) J2 rows (E, nu, sigma_y, K, n, 0), or tube-wall rows
    rho: np.ndarray         # (n_el,) density
    cut: bool               # slit along its length: the half model, else the quarter

    @property
    def copies(self) -> int:
        """How many of the modelled pieces make the whole tube."""
        return 2 if self.cut else 4


def _tube_grid(x: np.ndarray, radius: np.ndarray, n_circ: int, cut: bool):
    """The modelled piece of the tube surface at the stations ``x`` (0 .. length/2) of
    ``radius``: the half ring phi in [0, pi] from the top (``n_circ`` / 2 elements) of a
    closed tube, or the whole ring of a slit one, open at the side (phi = pi/2, where the
    CWB model's slit is: models/hifi_mesh.CUT_PHI), ``n_circ`` elements; y up, z = 0 the
    loading plane."""
    n_el = n_circ if cut else n_circ // 2
    phi = (0.5 * np.pi if cut else 0.0) + (2.0 if cut else 1.0) * np.pi * np.arange(n_el + 1) / n_el
    cos, sin = np.cos(phi), np.sin(phi)
    cos[np.isclose(cos, 0.0, atol=1e-12)] = 0.0      # the loading plane and the slit exactly
    sin[np.isclose(sin, 0.0, atol=1e-12)] = 0.0
    X = np.stack([np.repeat(x, n_el + 1), np.outer(radius, cos).ravel(),
                  np.outer(radius, sin).ravel()], axis=1)
    i, j = np.meshgrid(np.arange(x.size - 1), np.arange(n_el), indexing="ij")
    a = (i * (n_el + 1) + j).ravel()
    conn = np.stack([a, a + n_el + 1, a + n_el + 2, a + 1], axis=1)
    return X, np.ascontiguousarray(conn, dtype=np.int64)


def _row(E, nu, sigma_y, K, n, n_el) -> np.ndarray:
    return np.tile([E, nu, sigma_y, K, n, 0.0], (n_el, 1))


def resolved_tube(geometry: TubeGeometry, material: dict, length: float, n_circ: int,
                  per_pitch: int, cut: bool = False) -> TubeShells:
    """The corrugated wall: stations ``per_pitch`` to a pitch, a crest at x = 0."""
    n_ax = int(round(0.5 * length / geometry.pitch * per_pitch))
    x = np.linspace(0.0, 0.5 * length, n_ax + 1)
    radius = geometry.radius(x + 0.5 * geometry.pitch)         # TubeGeometry: trough at 0
    X, conn = _tube_grid(x, radius, n_circ, cut)
    n_el = conn.shape[0]
    t = np.full(n_el, geometry.wall)
    mat = _row(material["E"], material["nu"], material["sigma_y"], material["K"], material["n"], n_el)
    return TubeShells(X, conn, t, t.copy(), mat, np.full(n_el, material["rho"]), cut)


def _smooth_grid(geometry: TubeGeometry, eq: dict, length: float, n_circ: int, n_axial: int,
                 cut: bool):
    """The smooth cylinder at the equivalent shell's mean radius ``eq["radius"]``: its nodes,
    quads and the thickness the pins see (d_o/2 - d_i/2, the crests' reach)."""
    x = np.linspace(0.0, 0.5 * length, n_axial // 2 + 1)
    X, conn = _tube_grid(x, np.full(x.size, eq["radius"]), n_circ, cut)
    t_contact = np.full(conn.shape[0], 0.5 * (geometry.d_outer - geometry.d_inner))
    return X, conn, t_contact


def _equivalent(geometry: TubeGeometry, material: dict) -> dict:
    return equivalent_shell(material["E"], material["sigma_y"], material["K"], material["n"], geometry,
                            nu=material["nu"], rho=material["rho"])


def equivalent_tube(geometry: TubeGeometry, material: dict, length: float, n_circ: int,
                    n_axial: int, cut: bool = False) -> TubeShells:
    """The smooth equivalent shell (:func:`equivalent_shell`) at the mean radius."""
    eq = _equivalent(geometry, material)
    X, conn, t_contact = _smooth_grid(geometry, eq, length, n_circ, n_axial, cut)
    n_el = conn.shape[0]
    return TubeShells(X, conn, np.full(n_el, eq["t"]), t_contact,
                      _row(eq["E"], eq["nu"], eq["sigma_y"], eq["K"], eq["n"], n_el),
                      np.full(n_el, eq["rho"]), cut)


def resultant_tube(geometry: TubeGeometry, material: dict, length: float, n_circ: int,
                   n_axial: int, cut: bool = False) -> TubeShells:
    """The smooth shell of :func:`equivalent_tube` with the ridged wall's resultant law
    (:func:`harnesspipe.models.tube_equivalent.wall_row`; thickness: the wall area per
    unit length, which carries the mass); a ``cut`` tube's axial laws are the slit ring's,
    its lips free as the resolved wall's are."""
    w = wall_resultants(material["E"], material["sigma_y"], material["K"], material["n"], geometry,
                        nu=material["nu"], slit=cut)
    X, conn, t_contact = _smooth_grid(geometry, _equivalent(geometry, material), length, n_circ,
                                      n_axial, cut)
    n_el = conn.shape[0]
    return TubeShells(X, conn, np.full(n_el, w["mass_thickness"]), t_contact,
                      np.tile(wall_row(w, MAT_TUBE), (n_el, 1)), np.full(n_el, material["rho"]), cut)


class TubeBendingSystem:
    """The tube on the pins; the system protocol of
    :mod:`harnesspipe.fe.solvers.central_difference`."""

    families = FAMILIES
    driven = "pin_contact"

    def __init__(self, tube: TubeShells, three_point: dict, *, mu: float, total_time: float,
                 ramp: float, penalty: float, dt_target: float):
        self.tube, self.T = tube, float(total_time)
        self.x = tube.X.copy()
        self.state = init_shell_state(tube.X, tube.conn, tube.thick,
                                      np.tile([1.0, 0.0, 0.0], (tube.conn.shape[0], 1)))
        dt_el = shell_stable_step(tube.X, tube.conn, tube.thick, tube.mat, tube.rho)
        self.density_factor = max(1.0, (dt_target / dt_el) ** 2)
        self.rho = tube.rho * self.density_factor
        self.mass = np.zeros((tube.X.shape[0], 6))
        shell_lumped_mass(tube.X, tube.conn, tube.thick, self.rho, self.mass)
        self.dt0 = shell_stable_step(tube.X, tube.conn, tube.thick, tube.mat, self.rho)
        self.penalty = float(penalty)
        self.k_n = self.penalty * float(self.mass[:, 0].min()) / self.dt0**2
        self.mu = float(mu)
        self.pins = self._pins(three_point, ramp)
        self.free = np.ones_like(self.mass, dtype=np.bool_)
        self._hold_symmetry()
        self.F = np.zeros((len(FAMILIES),) + self.mass.shape)
        self.f_el = np.zeros((tube.conn.shape[0], 4, 6))
        n_pins = self.pins.c0.shape[0]
        self.hist_q = np.full((n_pins, PIN_PATCHES), -1, dtype=np.int64)
        self.hist_ft = np.zeros((n_pins, PIN_PATCHES, 3))
        # the contact's groups, once: the pins move and the patches' history changes in place
        self.facets = PinFacetSet(tube.conn, tube.contact_t, self.mu, np.zeros(n_pins), self.k_n,
                                  self.k_n, self.hist_q, self.hist_ft)
        p = self.pins
        self.cylinders = Cylinders(p.centres, p.axes, p.radii, p.velocity)

    def _pins(self, tp: dict, ramp: float) -> Pins:
        """The roller at x = span/2 below, the feeder at 0 above, each moved onto the tube's
        outer surface (its gap to the facets closed), so that the test starts touching."""
        r_pin = 0.5 * tp["pin_diameter"]
        r_out = float(np.max(np.hypot(self.x[:, 1], self.x[:, 2])) + 0.5 * self.tube.contact_t.max())
        c = np.array([[0.5 * tp["span"], -(r_out + r_pin), 0.0], [0.0, r_out + r_pin, 0.0]])
        axes = np.tile([0.0, 0.0, 1.0], (2, 1))
        gaps = facets_cylinder_gaps(self.x, self.tube.conn, self.tube.contact_t, c, axes, np.full(2, r_pin))
        c[:, 1] -= np.sign(c[:, 1]) * gaps
        return Pins(c, r_pin, 1, tp["deflection"], self.T, ramp)

    def _hold_symmetry(self) -> None:
        """The symmetry planes: x = 0 (midspan: u_x, theta_y, theta_z held) and, for the
        quarter of a closed tube, z = 0 (the loading plane: u_z, theta_x, theta_y held); the
        half model of a slit tube is held along z at its top and bottom node of midspan."""
        mid = np.flatnonzero(self.x[:, 0] == 0.0)
        self.free[np.ix_(mid, [0, 4, 5])] = False
        if self.tube.cut:
            ends = mid[self.x[mid, 2] == 0.0]
            self.free[ends, 2] = False
        else:
            self.free[np.ix_(np.flatnonzero(self.x[:, 2] == 0.0), [2, 3, 4])] = False

    def stable_step(self) -> float:
        """The shells' step with the pins' penalty added (omega^2 = penalty / dt0^2 each)."""
        dt = shell_stable_step(self.x, self.tube.conn, self.tube.thick, self.tube.mat, self.rho)
        return 2.0 / np.sqrt((2.0 / dt) ** 2 + 2.0 * self.penalty / self.dt0**2)

    def forces(self, t, v, dt):
        F = self.F
        F[...] = 0.0
        shell_forces(self.x, v, self.tube.conn, self.tube.thick, self.tube.mat, self.state, dt,
                     self.f_el, F[0], sign=-1.0)
        self.pins.force[...] = 0.0
        facets_cylinder_contact(self.x, v, self.facets, self.cylinders, dt, F[1], F[2],
                                self.pins.force)
        return F

    def advance(self, du, t):
        self.x += du[:, :3]
        self.pins.move_to(t)

    def external_work(self, t0, t1) -> float:
        return self.pins.work(t0, t1)

    def displacement_max(self) -> float:
        return float(np.max(np.abs(self.x - self.tube.X)))

    def observe(self, t) -> dict:
        """The feeder's force (the whole tube's: ``copies`` x the model's) and travel, the
        load cell's means since the last row (:meth:`Pins.read`)."""
        f, u = self.pins.read()
        return {"deflection_mm": u, "force_N": self.tube.copies * float(f[self.pins.feeder, 1]),
                "plastic": float(shell_energies(self.state)[2])}


@dataclass
class TubeBendingRun:
    curve: pd.DataFrame     # deflection_mm, force_N
    history: pd.DataFrame
    summary: dict


def tube_three_point(config: dict, covering: str, material: dict, wall: str, *,
                     resolution: dict | None = None, deflection: float | None = None,
                     rate: float = RATE, dt_target: float = DT_TARGET,
                     mu: float | None = None) -> TubeBendingRun:
    """The tube ``covering`` (a ridged tube of config ``coverings``) of eq. 2 ``material``
    (E, sigma_y, K, n; e.g. a Table 2 row) alone in the three-point test, ``wall`` one of
    :data:`WALLS`.  ``resolution``: ``n_circ`` and ``per_pitch`` (resolved) or ``n_axial``
    (equivalent), default :data:`MESH`.  ``deflection`` defaults to the test's; the feeder
    runs at ``rate`` mm per model second after the config's rate ramp; ``mu`` (pins on
    polypropylene) defaults to the paper's mu_rtb (config ``paper.interface``)."""
    if wall not in WALLS:
        raise ValueError(f"tube_three_point: wall {wall!r}: expected one of {WALLS}")
    cov = config["coverings"][covering]
    if "d_i" not in cov or "pitch" not in cov:
        raise ValueError(f"tube_three_point: covering {covering!r} is not a ridged tube (d_i, pitch)")
    geometry = TubeGeometry(d_inner=cov["d_i"], d_outer=cov["d_o"], wall=cov["t"], pitch=cov["pitch"])
    base = config["materials"][cov["material"]]
    mat = {"nu": base.get("nu", 0.42), "rho": base["rho"], **material}
    tp = dict(config["three_point"])
    if deflection is not None:
        tp["deflection"] = float(deflection)
    length = tp["tube_length"]
    resolution = MESH[wall] if resolution is None else resolution
    explicit = config["hifi"]["explicit"]
    total_time = tp["deflection"] / rate / ramp_share(explicit["rate_ramp"])
    if wall == "resolved":
        tube = resolved_tube(geometry, mat, length, int(resolution["n_circ"]),
                             int(resolution["per_pitch"]), bool(cov["cut"]))
    else:
        build = equivalent_tube if wall == "equivalent" else resultant_tube
        tube = build(geometry, mat, length, int(resolution["n_circ"]), int(resolution["n_axial"]),
                     bool(cov["cut"]))
    system = TubeBendingSystem(tube, tp, mu=config["paper"]["interface"]["mu_rtb"] if mu is None else mu,
                               total_time=total_time, ramp=explicit["rate_ramp"],
                               penalty=explicit["penalty"], dt_target=dt_target)
    res = integrate(system, total_time, DynamicsSettings(ke_ie_from=explicit["rate_ramp"]))
    h = res.history
    curve = h.loc[h["deflection_mm"] > 0.0, ["deflection_mm", "force_N"]].reset_index(drop=True)
    summary = {"wall": wall, "covering": covering, "n_elements": int(tube.conn.shape[0]),
               "steps": int(res.n_steps), "dt": float(res.dt), "wall_s": float(res.wall_s),
               "ke_ie_max": float(res.ke_ie_max), "energy_error": float(res.energy_error),
               "density_factor": float(system.density_factor), "rate": float(rate)}
    return TubeBendingRun(curve, h, summary)
