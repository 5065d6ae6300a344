"""A single-system explicit driver for co-rotational beams: the tests' reference for
the beam element in explicit dynamics (free vibration, wave speed, energy balance).

Not used by a run: the hi-fi models integrate with
:func:`harnesspipe.fe.solvers.central_difference.integrate`.

The integrator is the central-difference method in its velocity-Verlet form
(Belytschko, Liu & Moran 2014, sec. 6.2)::

    v_{n+1/2} = v_n + dt/2 a_n
    u_{n+1}   = u_n + dt v_{n+1/2}           (rotations: q <- exp(dt w_{n+1/2}) q)
    a_{n+1}   = M^{-1} (f_ext(t_{n+1}) - f_int(u_{n+1}))
    v_{n+1}   = v_{n+1/2} + dt/2 a_{n+1}

with a diagonal (lumped) mass, no damping.  Prescribed dofs follow
``value * S(t / T)`` exactly (displacement, velocity and acceleration), with the
smooth step ``S(x) = 10 x^3 - 15 x^4 + 6 x^5`` (zero velocity and acceleration at
both ends, the "smooth step" amplitude of common FE codes); external loads use the
same amplitude.  Fixed dofs stay at zero.

Stable step
-----------
``dt = safety * min(dt_wave, dt_beam)``:

* ``dt_wave = min L_e / c_d`` (eq. 11), ``c_d = sqrt(E (1-nu) / (rho' (1+nu)(1-2nu)))``,
  ``rho' = f_m rho`` (mass scaling).  For a beam the fastest axial wave is the bar
  wave ``sqrt(E/rho') < c_d``, so eq. 11 bounds the axial/torsional limit.
* ``dt_beam = 2 / omega_max`` with ``omega_max^2`` bounded from above by the
  Gershgorin bound of ``M^{-1/2} K M^{-1/2}`` (K the tangent at the start, free dofs
  only).  This is needed for beams: with lumped translational mass ``rho A l/2`` the
  bending dofs of a Bernoulli element have ``omega^2 ~ (24..48) E r_g^2 / (rho l^4)``
  (r_g = radius of gyration), i.e. ``dt ~ 0.2..0.3 l^2 / (r_g c)``, which for the thick,
  finely meshed bundles of the ROM (r_g ~ l) is several times *smaller* than eq. 11;
  the lumped rotary dofs give ``omega^2 ~ 12 E / (rho l^2)`` in addition.  The
  Gershgorin bound covers all of these without a closed form (it is an upper bound
  of omega_max, so the step is conservative); geometric stiffening during the run is
  covered by ``safety`` (< 1).

Rotations (co-rotational beam)
------------------------------
Each node carries a spatial angular velocity ``w`` (3) and a *scalar* rotary inertia
``J = rho' (l/2) I_p`` (half of each adjacent element; I_p = polar moment, the
largest of the section's moments, so J overestimates the bending rotary inertia
``rho' (l/2) I`` by 2 for a disc -- a mild rotary-inertia scaling that never lowers
the stable step).  With an isotropic inertia the Euler equations carry no gyroscopic
term, ``J dw/dt = m`` holds exactly in the spatial frame, so the moments of
:func:`harnesspipe.fe.elements.beam.assemble_beams` (conjugate to spatial spins) drive ``w``
directly and the quaternions are updated by the exponential map
``q_{n+1} = exp(dt w_{n+1/2}) q_n`` (:func:`harnesspipe.fe.rotation.rotate_nodes`).
The approximation is the isotropic rotary inertia; it only matters for dynamics
dominated by rotary inertia, not for quasi-static runs.

Energies
--------
Kinetic ``KE = 1/2 v.M v``; internal ``IE = sum 1/2 (f_int,n + f_int,n+1) . du``
(trapezoidal work of the internal forces; rotational parts with the spin increment);
external ``W = sum 1/2 (f_ext,n + f_ext,n+1) . du + sum 1/2 (R_n + R_n+1) . du_p`` with
the reaction ``R = M a + f_int - f_ext`` at prescribed dofs.  Balance error
``|KE + IE - W|`` (with the trapezoid rule the velocity-Verlet balance error is
``dt^2/8 (a.M a)`` at the current step -- it telescopes -- so it vanishes at rest and
the *maximum* over the run is the meaningful measure).  ``KE/IE`` is monitored once ``t > ke_ie_from * T`` (the initial
ramp, where IE ~ 0, is excluded as in common practice).  The run stops with
:class:`ExplicitError` (step, time, energies) as soon as the state is not finite, a
displacement exceeds ``max_displacement`` or the balance error exceeds
``energy_tol * |W| + energy_floor`` -- no result is returned then.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numba import njit

from harnesspipe.fe.elements.beam import (NDOF_NODE, BeamMesh, FibreMaterial, FibreSection,
                                          assemble_beams)
from harnesspipe.fe.rotation import rotate_nodes
from harnesspipe.fe.solvers.central_difference import ExplicitError, smooth_step


def dilatational_speed(E: float, nu: float, rho: float) -> float:
    """``c_d`` of eq. 11."""
    return float(np.sqrt(E * (1.0 - nu) / (rho * (1.0 + nu) * (1.0 - 2.0 * nu))))


def wave_step(min_length: float, E: float, nu: float, rho: float) -> float:
    """``dt_stable = min L_e / c_d`` (eq. 11); pass the scaled density ``f_m rho``."""
    return float(min_length / dilatational_speed(E, nu, rho))


# -- kernels -------------------------------------------------------------------
@njit(cache=True)
def lumped_beam_mass(X, conn, rho, A, Ip, m):
    """Lumped diagonal per dof (6 per node): rho A l/2 on translations, the scalar
    rotary inertia rho I_p l/2 on rotations, from each adjacent element."""
    m[:] = 0.0
    for e in range(conn.shape[0]):
        a = conn[e, 0]
        b = conn[e, 1]
        d0 = X[b, 0] - X[a, 0]
        d1 = X[b, 1] - X[a, 1]
        d2 = X[b, 2] - X[a, 2]
        h = 0.5 * rho * np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        for node in (a, b):
            o = 6 * node
            for k in range(3):
                m[o + k] += h * A
                m[o + 3 + k] += h * Ip


@njit(cache=True)
def gershgorin_omega2(band, bw, m, free):
    """Upper bound of the largest eigenvalue of M^-1/2 K M^-1/2 on the free dofs."""
    n = m.shape[0]
    best = 0.0
    for i in range(n):
        if not free[i]:
            continue
        s = 0.0
        for j in range(max(0, i - bw), min(n, i + bw + 1)):
            if free[j]:
                s += abs(band[bw + i - j, j]) / np.sqrt(m[i] * m[j])
        if s > best:
            best = s
    return best


@njit(cache=True)
def kick(v, a, fint, fext, minv, free, hdt):
    """a = M^-1 (f_ext - f_int) and v += hdt a on the free dofs."""
    for i in range(v.shape[0]):
        if free[i]:
            a[i] = (fext[i] - fint[i]) * minv[i]
            v[i] += hdt * a[i]


@njit(cache=True)
def half_work(f0, f1, du, idx):
    """sum over idx of 1/2 (f0 + f1) du (all dofs when idx is empty is not used)."""
    s = 0.0
    for k in range(idx.shape[0]):
        i = idx[k]
        s += 0.5 * (f0[i] + f1[i]) * du[i]
    return s


# -- problem -------------------------------------------------------------------
class BeamExplicit:
    """Explicit view of a :class:`harnesspipe.models.rom_beam.BeamSystem`-like object.

    Uses its geometry, section, material, ``u``/``quat`` state, plastic history,
    ``fixed``, ``prescribed`` (final values) and ``load`` (final vector).  Contact
    cylinders are not supported here.  ``rho`` is the physical density (t/mm^3);
    the mass uses ``f_m rho``.
    """

    def __init__(self, system, rho: float, f_m: float = 1.0):
        if getattr(system, "cylinders", None) is not None:
            raise NotImplementedError("contact cylinders are not supported by the explicit beam")
        if not (rho > 0.0 and f_m > 0.0):
            raise ValueError(f"need rho > 0 and f_m > 0, got {rho}, {f_m}")
        self.s = system
        self.rho, self.f_m = rho, f_m
        self.ndof = system.ndof
        A = float(np.sum(system.area))
        Ip = float(np.sum(system.area * (system.y**2 + system.z**2)))
        self.mass = np.zeros(self.ndof)
        lumped_beam_mass(system.X, system.conn, f_m * rho, A, Ip, self.mass)
        self.fixed = np.asarray(system.fixed, dtype=np.int64)
        self.prescribed = dict(system.prescribed)
        self.load = np.asarray(system.load, dtype=float)
        lengths = np.linalg.norm(system.X[system.conn[:, 1]] - system.X[system.conn[:, 0]], axis=1)
        self.min_length = float(lengths.min())
        self.size = float(np.linalg.norm(np.ptp(system.X, axis=0)))
        self._f = np.zeros(self.ndof)

    def internal_force(self, want_tangent: bool = False):
        s, m = self.s, self.s.material
        assemble_beams(BeamMesh(s.X, s.conn, s.R0, s.xi_g, s.w_g), s.u, s.quat,
                       FibreSection(s.y, s.z, s.area, s.GJ),
                       FibreMaterial(m.E, m.sigma_y, m.K, m.n), m.elastic, s.hist, s.hist_trial,
                       want_tangent, self._f, s.band, s.bandwidth)
        return self._f

    def tangent(self):
        self.internal_force(True)
        return self.s.band, self.s.bandwidth

    def commit(self):
        self.s.hist[:] = self.s.hist_trial

    def move(self, du):
        d = du.reshape(-1, NDOF_NODE)
        self.s.u += d[:, :3]
        rotate_nodes(self.s.quat, np.ascontiguousarray(d[:, 3:]))

    def dt_wave(self):
        m = self.s.material
        return wave_step(self.min_length, m.E, m.nu, self.f_m * self.rho)

    def energy_scale(self):
        """E V: strain energy of the beam at unit strain (N mm), the scale of the floor."""
        return self.s.material.E * float(np.sum(self.s.area)) * self.size

    def displacement_max(self):
        return float(np.max(np.abs(self.s.u)))


# -- solver --------------------------------------------------------------------
@dataclass(frozen=True)
class ExplicitSettings:
    safety: float = 0.9            # dt = safety * min(dt_wave, dt_beam)
    dt: float | None = None        # override the step (tests of the blow-up guard)
    ke_ie_from: float = 0.1        # KE/IE monitored for t > ke_ie_from * T
    energy_tol: float = 0.05       # stop when |KE + IE - W| > energy_tol |W| + floor
    energy_floor: float | None = None  # default 1e-9 E V (strain energy at unit strain)
    max_displacement: float | None = None  # default 10 x model size
    n_output: int = 200            # rows of the history


@dataclass
class ExplicitResult:
    history: pd.DataFrame          # time_s, amplitude, KE, IE, W_ext, balance_error
    reactions: dict                # dof -> force applied by the support at the end
    dt: float
    dt_wave: float                 # eq. 11
    dt_beam: float                 # Gershgorin bending/rotary limit
    n_steps: int
    max_ke_ie: float               # max KE/IE for t > ke_ie_from T
    balance_error: float           # |KE + IE - W| / |W| at the end
    max_balance_error: float       # max |KE + IE - W| / |W| for t > ke_ie_from T
    ke: float
    ie: float
    w_ext: float


def stable_step(problem):
    """(dt_wave of eq. 11, dt_beam = 2 / omega_max from the Gershgorin bound)."""
    free = np.ones(problem.ndof, dtype=np.bool_)
    free[problem.fixed] = False
    band, bw = problem.tangent()
    w2 = gershgorin_omega2(band, bw, problem.mass, free)
    return problem.dt_wave(), (2.0 / np.sqrt(w2) if w2 > 0.0 else np.inf)


def run_explicit(problem, total_time: float, settings: ExplicitSettings = ExplicitSettings(),
                 ) -> ExplicitResult:
    """Integrate from rest over ``total_time`` with the smooth-step amplitude over it."""
    if not total_time > 0.0:
        raise ValueError(f"total_time must be > 0, got {total_time}")
    n = problem.ndof
    dt_wave, dt_beam = stable_step(problem)
    dt = settings.dt if settings.dt is not None else settings.safety * min(dt_wave, dt_beam)
    n_steps = int(np.ceil(total_time / dt))
    dt = total_time / n_steps
    free = np.ones(n, dtype=np.bool_)
    free[problem.fixed] = False
    p_dofs = np.array(sorted(problem.prescribed), dtype=np.int64)
    p_vals = np.array([problem.prescribed[d] for d in p_dofs], dtype=float)
    all_dofs = np.arange(n, dtype=np.int64)
    M = problem.mass
    minv = np.where(M > 0.0, 1.0 / np.where(M > 0.0, M, 1.0), 0.0)
    floor = settings.energy_floor
    if floor is None:
        floor = 1e-9 * problem.energy_scale()
    u_max = settings.max_displacement or 10.0 * problem.size

    v = np.zeros(n)
    a = np.zeros(n)
    du = np.zeros(n)
    fint = problem.internal_force().copy()
    problem.commit()
    fext = np.zeros(n)
    R = np.zeros(n)            # reactions at the constrained dofs
    ke = ie = w = 0.0
    max_ratio = max_bal = 0.0
    t_mon = settings.ke_ie_from * total_time
    out_every = max(1, n_steps // settings.n_output)
    rows = [(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)]
    g_prev = np.zeros(p_dofs.size)
    fixed = problem.fixed
    for step in range(1, n_steps + 1):
        t = step * dt
        S, dS, d2S = smooth_step(t / total_time)
        # drift
        v_half = v  # v was kicked by dt/2 at the end of the previous step (or is zero)
        du[:] = dt * v_half
        du[fixed] = 0.0
        g = S * p_vals
        du[p_dofs] = g - g_prev
        g_prev = g
        problem.move(du)
        fint_new = problem.internal_force()
        problem.commit()
        fext_new = S * problem.load
        # prescribed kinematics and reactions
        v[fixed] = 0.0
        a[fixed] = 0.0
        v[p_dofs] = dS / total_time * p_vals
        a[p_dofs] = d2S / total_time**2 * p_vals
        R_new = M * a + fint_new - fext_new
        # energies (trapezoid on the step)
        ie += half_work(fint, fint_new, du, all_dofs)
        w += half_work(fext, fext_new, du, all_dofs) + half_work(R, R_new, du, p_dofs)
        kick(v, a, fint_new, fext_new, minv, free, 0.5 * dt)   # v_{n+1}
        ke = 0.5 * float(np.sum(M * v * v))
        fint[:] = fint_new
        fext, R = fext_new, R_new
        err = abs(ke + ie - w)
        if not np.isfinite(err) or not np.isfinite(ke):
            raise ExplicitError("non-finite state", step, t, ke, ie, w, dt)
        if err > settings.energy_tol * abs(w) + floor:
            raise ExplicitError(f"energy balance error {err:.3g} > "
                                f"{settings.energy_tol:g} |W_ext| + {floor:.3g}",
                                step, t, ke, ie, w, dt)
        umax = problem.displacement_max()
        if umax > u_max:
            raise ExplicitError(f"displacement {umax:.4g} mm > {u_max:.4g} mm",
                                step, t, ke, ie, w, dt)
        if t > t_mon and ie > 0.0:
            max_ratio = max(max_ratio, ke / ie)
            max_bal = max(max_bal, err / max(abs(w), floor))
        if step % out_every == 0 or step == n_steps:
            rows.append((t, S, ke, ie, w, err))
        if step < n_steps:
            kick(v, a, fint, fext, minv, free, 0.5 * dt)       # v_{n+3/2} half kick
    history = pd.DataFrame(rows, columns=["time_s", "amplitude", "KE", "IE", "W_ext",
                                          "balance_error"])
    reactions = {int(d): float(R[d]) for d in fixed}
    return ExplicitResult(history, reactions, dt, dt_wave, dt_beam, n_steps, max_ratio,
                          abs(ke + ie - w) / max(abs(w), floor), max_bal, ke, ie, w)
