"""Parts of the high-fidelity bundle model: the wires (fibre beams) and the rigid pins.

Each part owns its state and history and adds its forces into the families of
:class:`harnesspipe.models.hifi.HifiSystem` (forces acting ON the nodes).
"""
from __future__ import annotations

import numba
import numpy as np

from harnesspipe.fe.elements.beam import initial_frames, lobatto_points
from harnesspipe.fe.elements.beam_explicit import (Beams, beam_forces, beam_lumped_mass,
                                                   beam_plastic_work, beam_stable_step)
from harnesspipe.fe.materials.fiber import disc_fibres
from harnesspipe.fe.solvers.central_difference import prescribed_work, rate_ramp


class Wires:
    """All wires of a bundle: 2-node co-rotational beams with J2 fibre sections.

    ``types``: one dict per wire type (E, sigma_y, K, n, nu, rho, d_outer), indexed by
    ``elem_type`` (n_el,); the section is the disc of diameter d_outer (Table 1 gives
    homogenised bending properties for it).
    """

    def __init__(self, X0, conn, elem_type, types, n_rings, n_sectors, n_gauss, f_m):
        self.X0 = np.ascontiguousarray(X0, dtype=float)
        self.conn = np.ascontiguousarray(conn, dtype=np.int64)
        self.sec_id = np.ascontiguousarray(elem_type, dtype=np.int64)
        self.R0 = initial_frames(self.X0, self.conn)
        self.xi_g, self.w_g = lobatto_points(n_gauss)
        secs = [disc_fibres(0.5 * t["d_outer"], n_rings, n_sectors) for t in types]
        self.sec_y, self.sec_z, self.sec_area = (np.ascontiguousarray(np.stack([s[k] for s in secs]))
                                                 for k in range(3))
        self.radius = np.array([0.5 * t["d_outer"] for t in types])
        G = np.array([t["E"] / (2.0 * (1.0 + t["nu"])) for t in types])
        self.sec_GJ = G * np.pi * self.radius**4 / 2.0
        self.G = G
        self.mats = np.array([[t["E"], t["sigma_y"], t["K"], t["n"]] for t in types])
        self.rho = np.array([f_m * t["rho"] for t in types])
        n_el, ng, nf = self.conn.shape[0], self.xi_g.size, self.sec_y.shape[1]
        eps_p, alpha, sa_h = np.zeros((3, n_el, ng, nf))   # fibre history (in place)
        self.beams = Beams(self.X0, self.conn, self.R0, self.xi_g, self.w_g, self.sec_y,
                           self.sec_z, self.sec_area, self.sec_GJ, self.sec_id, self.mats,
                           self.sec_id, eps_p, alpha, sa_h, np.zeros((n_el, 12)))
        self.n_chunks = numba.get_num_threads()   # element chunks (any number gives the same forces)
        self.nodes = np.unique(self.conn)

    def element_radius(self):
        return self.radius[self.sec_id]

    def add_mass(self, mass):
        r = self.element_radius()
        beam_lumped_mass(self.X0, self.conn, np.pi * r**2, np.pi * r**4 / 4.0,
                         self.rho[self.sec_id], mass)

    def stable_step(self, x):
        return float(self.element_steps(x).min())

    def element_steps(self, x):
        """Critical step of every element (Gershgorin bound, elastic stiffness)."""
        l = np.linalg.norm(x[self.conn[:, 1]] - x[self.conn[:, 0]], axis=1)
        r = self.element_radius()
        k = self.sec_id
        l0 = np.linalg.norm(self.X0[self.conn[:, 1]] - self.X0[self.conn[:, 0]], axis=1)
        # mass from the reference length (lumped once), stiffness at the current length
        return beam_stable_step(np.minimum(l, l0), np.pi * r**2, np.pi * r**4 / 4.0,
                                self.mats[k, 0], self.G[k], self.rho[k])

    def add_forces(self, x, quat, f_on_nodes):
        """Add the element forces ON the nodes (minus the internal force) into ``f_on_nodes``."""
        beam_forces(self.beams, x, quat, f_on_nodes, self.n_chunks, -1.0)

    def plastic_work(self):
        return beam_plastic_work(self.beams)


class Pins:
    """The rigid 5 mm pins of the three-point test: two fixed rollers and the feeder.

    The feeder (index ``feeder``) moves by ``-deflection`` along y over the run at the
    test's constant rate, reached from rest over the first ``ramp`` of the run
    (:func:`harnesspipe.fe.solvers.central_difference.rate_ramp`):
    ``y(t) = y0 - d S(t/T)``; the rollers stay.  The pins also keep the work they do on
    the system (:meth:`work`) and, as a load cell, the means of their forces and of the
    feeder's travel since the last reading (:meth:`read`).
    """

    def __init__(self, centres, radius, feeder, deflection, total_time, ramp):
        self.c0 = np.asarray(centres, dtype=float).copy()
        self.centres = self.c0.copy()
        self.axes = np.tile([0.0, 0.0, 1.0], (self.c0.shape[0], 1))
        self.radii = np.full(self.c0.shape[0], float(radius))
        self.velocity = np.zeros_like(self.c0)
        self.feeder = int(feeder)
        self.deflection = float(deflection)
        self.T = float(total_time)
        self.ramp = float(ramp)
        self.force = np.zeros_like(self.c0)        # force ON each pin (from the contacts)
        self.c_prev = self.c0.copy()               # centres before the last move
        self.f_prev = np.zeros_like(self.c0)       # force at the last step's end
        self.impulse = np.zeros_like(self.c0)      # since the last reading
        self.impulse_u = self.impulse_time = self.u_prev = 0.0

    def move_to(self, t):
        self.c_prev[...] = self.centres
        S, dS = rate_ramp(t / self.T, self.ramp)
        self.centres[self.feeder, 1] = self.c0[self.feeder, 1] - self.deflection * S
        self.velocity[self.feeder, 1] = -self.deflection * dS / self.T

    def feeder_displacement(self):
        return self.c0[self.feeder, 1] - self.centres[self.feeder, 1]

    def work(self, t0, t1) -> float:
        """Work of the pins on the system over the step t0 -> t1 (F on the system = -force
        on the pin, trapezoidal), and the step's impulse of the forces and of the travel."""
        h = 0.5 * (t1 - t0)
        w = prescribed_work(self.f_prev, self.force, self.c_prev, self.centres, self.impulse, h)
        u = self.feeder_displacement()
        self.impulse_u += h * (self.u_prev + u)
        self.impulse_time += t1 - t0
        self.u_prev = u
        return w

    def read(self) -> tuple[np.ndarray, float]:
        """(force on each pin, feeder travel): MEANS since the last reading (impulse / time),
        as a load cell averages -- the instantaneous penalty force chatters at the contact
        frequency; the instantaneous values before the first step."""
        span = self.impulse_time
        f = self.impulse / span if span > 0.0 else self.force.copy()
        u = self.impulse_u / span if span > 0.0 else self.feeder_displacement()
        self.impulse = np.zeros_like(self.force)
        self.impulse_u = self.impulse_time = 0.0
        return f, u
