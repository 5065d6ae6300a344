"""Explicit central difference for assembled multi-body systems, with energy accounting
per force family (Sec. 4.1, eq. 11).

The scheme is central differences in velocity-Verlet form (Belytschko, Liu & Moran
2014, sec. 6.2)::

    v_{n+1/2} = v_n + dt/2 a_n,    x_{n+1} = x_n + dt v_{n+1/2}  (rotations: exp map)
    a_{n+1} = M^-1 sum_p F_p(x_{n+1}, v_{n+1/2}),    v_{n+1} = v_{n+1/2} + dt/2 a_{n+1}

with a diagonal mass.  The system supplies its forces as *families* ``F_p`` (all forces
acting ON the nodes, e.g. element forces with a minus sign, contact normal, friction,
cohesive, damping) and the rigid bodies it moves (rollers, loading pin).  The work
of every family on the nodes is integrated by the trapezoidal rule,
``W_p += 1/2 (F_p,n + F_p,n+1) . du``, and the work done by the prescribed rigid bodies
on the system, ``W_ext``, likewise.  Since ``KE_n+1 - KE_n = sum_p 1/2 (F_p,n + F_p,n+1) . du``
up to the ``O(dt^2)`` term of the scheme, ``KE + sum_p (-W_p) = W_ext``: every family's
absorbed energy ``-W_p`` (internal energy, frictional and cohesive dissipation, penalty
energy, damping) is reported and the balance error ``|KE + sum_p (-W_p) - W_ext|`` is
monitored.  A run stops with :class:`ExplicitError` as soon as
the state is not finite, the balance error exceeds its tolerance or a displacement
exceeds its bound; it then returns nothing.

System protocol (duck-typed; see :class:`harnesspipe.models.hifi.HifiSystem`)::

    mass (n, 6), free (n, 6) bool, families: tuple of names
    forces(t, v_half, dt) -> (P, n, 6) array (ON the nodes), in ``families`` order; it
        advances every history (plastic fibres, friction, cohesive damage) in place: it
        is called once per step and an explicit step is never rejected; the integrator
        reads the returned array until the next call (one buffer may be reused)
    advance(du, t) -> None  (moves nodes by du (n, 6) and the rigid bodies to time t)
    external_work(t_old, t_new) -> work of the prescribed bodies on the system over the step
    driven (optional) -> name of the family the prescribed bodies act through
    displacement_max() -> largest nodal displacement (mm)
    stable_step() -> float (critical step of the current configuration)
    observe(t) -> dict of scalars for the history
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numba import njit


class ExplicitError(RuntimeError):
    """The explicit run blew up (energy balance, displacement or non-finite state)."""

    def __init__(self, reason: str, step: int, time: float, ke: float, ie: float, w_ext: float,
                 dt: float):
        self.reason, self.step, self.time = reason, step, time
        self.ke, self.ie, self.w_ext, self.dt = ke, ie, w_ext, dt
        super().__init__(
            f"explicit run stopped: {reason} at step {step}, t = {time:.6g} s (dt = {dt:.4g} s); "
            f"KE = {ke:.6g}, IE = {ie:.6g}, W_ext = {w_ext:.6g}, "
            f"W_ext - KE - IE = {w_ext - ke - ie:.6g} (N mm: dissipated or held by contacts "
            f"and ties)")

    def __reduce__(self):
        """Picklable with its diagnostics (a run in a worker process re-raises it whole)."""
        return (type(self), (self.reason, self.step, self.time, self.ke, self.ie, self.w_ext,
                             self.dt))


def smooth_step(x: float):
    """Amplitude S, dS/dx, d2S/dx2 of ``10 x^3 - 15 x^4 + 6 x^5`` (clamped to [0, 1])."""
    if x <= 0.0:
        return 0.0, 0.0, 0.0
    if x >= 1.0:
        return 1.0, 0.0, 0.0
    return (x**3 * (10.0 - 15.0 * x + 6.0 * x * x),
            30.0 * x * x * (1.0 - x) ** 2,
            60.0 * x * (1.0 - x) * (1.0 - 2.0 * x))


def ramp_share(ramp: float) -> float:
    """The part of the run the loading of :func:`rate_ramp` would need at its constant rate
    alone, ``1 - ramp / 2`` (the ramp covers half its time's travel); the constant rate is
    its inverse."""
    if not 0.0 <= ramp < 1.0:
        raise ValueError(f"rate ramp {ramp} outside [0, 1)")
    return 1.0 - 0.5 * ramp


def rate_ramp(x: float, ramp: float):
    """Stroke fraction S and dS/dx at the run fraction ``x`` of a loading at constant rate
    that starts from rest: the rate rises as the smooth step over the first ``ramp`` of the
    run, ``dS/dx = c R(x / ramp)``, and stays ``c = 1 / (1 - ramp / 2)`` from there to the
    end, where S(1) = 1 (the test's constant crosshead rate, Sec. 2.2).  Before the ramp's
    end ``S = c ramp s^4 (5/2 - 3 s + s^2)``, s = x / ramp, the integral of R; past the
    run S stays 1 at rest."""
    c = 1.0 / ramp_share(ramp)
    if x <= 0.0:
        return 0.0, 0.0
    if x > 1.0:
        return 1.0, 0.0
    if x < ramp:
        s = x / ramp
        return c * ramp * s**4 * (2.5 - 3.0 * s + s * s), c * smooth_step(s)[0]
    return c * (x - 0.5 * ramp), c


def rate_ramp_time(r: float, ramp: float) -> float:
    """The run fraction x at which :func:`rate_ramp` reaches ``S(x) = r`` (in closed form
    on the constant rate, by bisection on the ramp: S increases)."""
    if not 0.0 <= r <= 1.0:
        raise ValueError(f"stroke fraction {r} outside [0, 1]")
    c = 1.0 / ramp_share(ramp)
    if r >= 0.5 * c * ramp:
        return r / c + 0.5 * ramp
    lo, hi = 0.0, ramp
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if rate_ramp(mid, ramp)[0] < r:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@njit(cache=True)
def close_and_kick(F, du, du_next, W, W_end, v, minv, free, hdt, m, f, h_next):
    """The end of a step and the start of the next, with the forces ``F`` (P, n, 6) at the
    step's end: the total force ``f = sum_p F_p``, the closing half kick ``v += hdt M^-1 f``
    and the kinetic energy ``1/2 v . M v``; then the next step's opening half kick by
    ``h_next / 2`` and its drift ``du_next = h_next v``.  Every family's work takes its
    two halves with the same forces, ``W[p] += 1/2 F_p . du`` (closing this step; the
    closed works are copied to ``W_end``) and ``W[p] += 1/2 F_p . du_next`` (opening
    the next).  Returns the kinetic energy and ``sum_p W_end[p]``.  ``h_next = 0`` closes
    the last step (v and W unchanged by the opening, ``du_next = 0``).

    Three passes over memory: the total force, the velocities, and both halves of the
    work in one read of the families (:func:`_half_works`)."""
    P, n, k = F.shape
    N = n * k
    Fp = F.reshape(P, N)
    tot = f.reshape(N)
    vv = v.reshape(N)
    mi = minv.reshape(N)
    mm = m.reshape(N)
    fr = free.reshape(N)
    d1 = du_next.reshape(N)
    tot[:] = 0.0
    for p in range(P):          # family by family: contiguous memory
        for q in range(N):
            tot[q] += Fp[p, q]
    hdt_next = 0.5 * h_next
    ke = 0.0
    for q in range(N):
        if fr[q]:
            vv[q] += hdt * tot[q] * mi[q]
            ke += mm[q] * vv[q] * vv[q]
            vv[q] += hdt_next * tot[q] * mi[q]
        else:
            vv[q] = 0.0
        d1[q] = h_next * vv[q]
    w_total = _half_works(Fp, du.reshape(N), d1, W, W_end)
    return 0.5 * ke, w_total


@njit(cache=True)
def _half_works(Fp, d0, d1, W, W_end):
    """``W[p] += 1/2 F_p . d0``, ``W_end[p] = W[p]``, ``W[p] += 1/2 F_p . d1`` for every
    family (``Fp`` (P, N)), each dot product in four interleaved partial sums (one running sum
    waits on every addition's latency); returns ``sum_p W_end[p]``."""
    P, N = Fp.shape
    N4 = N - N % 4
    w_total = 0.0
    for p in range(P):
        a0 = a1 = a2 = a3 = 0.0
        b0 = b1 = b2 = b3 = 0.0
        for q in range(0, N4, 4):
            a0 += Fp[p, q] * d0[q]
            a1 += Fp[p, q + 1] * d0[q + 1]
            a2 += Fp[p, q + 2] * d0[q + 2]
            a3 += Fp[p, q + 3] * d0[q + 3]
            b0 += Fp[p, q] * d1[q]
            b1 += Fp[p, q + 1] * d1[q + 1]
            b2 += Fp[p, q + 2] * d1[q + 2]
            b3 += Fp[p, q + 3] * d1[q + 3]
        for q in range(N4, N):
            a0 += Fp[p, q] * d0[q]
            b0 += Fp[p, q] * d1[q]
        W[p] += 0.5 * ((a0 + a1) + (a2 + a3))
        W_end[p] = W[p]
        w_total += W[p]
        W[p] += 0.5 * ((b0 + b1) + (b2 + b3))
    return w_total


@njit(cache=True)
def prescribed_work(f_prev, f_now, c_prev, c_now, impulse, h):
    """Work of prescribed rigid bodies on the system over a step, trapezoidal:
    ``-1/2 sum (f_prev + f_now) . (c_now - c_prev)`` with ``f`` (n_b, 3) the contact
    forces ON the bodies and ``c`` their positions; also ``impulse += h (f_prev + f_now)``
    (``h`` half the step) and ``f_prev <- f_now`` in place.  For a system's
    ``external_work`` (a few small arrays per step: no NumPy temporaries)."""
    w = 0.0
    for i in range(f_now.shape[0]):
        for k in range(f_now.shape[1]):
            fs = f_prev[i, k] + f_now[i, k]
            w -= 0.5 * fs * (c_now[i, k] - c_prev[i, k])
            impulse[i, k] += h * fs
            f_prev[i, k] = f_now[i, k]
    return w


@dataclass(frozen=True)
class DynamicsSettings:
    safety: float = 0.8             # dt = safety * stable step
    recheck_every: int = 500        # steps between stable-step rechecks (mesh deforms)
    ke_ie_from: float = 0.1         # KE/IE monitored for t > ke_ie_from T (after the ramp)
    energy_stop: float = 0.5        # stop when the balance error > energy_stop max(|W_ext|, |IE|) + floor
    energy_floor: float = 1e-3      # N mm
    max_displacement: float = 1e3   # mm
    n_output: int = 200             # history rows


@dataclass
class DynamicsResult:
    history: pd.DataFrame           # time_s, KE, each family's absorbed energy, W_ext, observe()
    dt: float
    n_steps: int
    ke_ie_max: float                # max KE / IE_elements for t > ke_ie_from T
    energy_error: float             # max |balance| over the run / |W_ext| at its end
    wall_s: float


def integrate(system, total_time: float, settings: DynamicsSettings = DynamicsSettings(),
              internal: str = "internal", on_output=None) -> DynamicsResult:
    """Integrate ``system`` from rest over ``total_time`` (simulated seconds).

    ``internal`` names the family whose absorbed energy is the internal energy IE of
    the KE/IE check.  ``on_output(step, t)`` is called at every history row (shapes).
    The step is ``safety x stable_step()``, rechecked every ``recheck_every`` steps and
    lowered (never raised) when the mesh has deformed.

    Energy balance.  With the trapezoidal work of a step h, velocity Verlet satisfies
    ``KE_n+1 - KE_n = sum_p W_p + h^2/8 (|F_n+1|^2 - |F_n|^2)_M^-1`` (``|F|^2_M^-1 =
    sum F^2 / m`` over the free dofs), so the balance error is this term, summed: it
    does not accumulate in a stable run but is a few per cent of a still small ``W_ext``
    after an impact (a penalty contact closing on light nodes), and it grows without
    bound when the run goes unstable.  Hence two figures: the run stops (a blow-up) when
    the balance error exceeds ``energy_stop`` max(|W_ext|, |IE|) + ``energy_floor`` at any
    step (IE: a prestress -- the tape's wrapping tension -- moves energy between the
    internal and contact families before the loading does any work), and
    the reported ``energy_error`` is the largest balance error of the run relative to
    the external work at its end (the energy scale of the test), which callers judge.
    """
    t0 = time.perf_counter()
    names = tuple(system.families)
    i_int = names.index(internal)
    driven = getattr(system, "driven", None)
    i_drv = names.index(driven) if driven is not None else None
    m = system.mass
    minv = np.where(m > 0.0, 1.0 / np.where(m > 0.0, m, 1.0), 0.0)
    free = system.free
    v = np.zeros_like(m)
    du = np.zeros_like(m)           # this step's drift
    du_next = np.zeros_like(m)      # the next step's, made as this one closes
    W = np.zeros(len(names))        # families' work, with the next step's opening half
    W_end = np.zeros(len(names))    # families' work at the end of the last closed step
    dt = settings.safety * system.stable_step()
    F = system.forces(0.0, v, dt)
    f = np.zeros_like(m)                # total force on the nodes
    w_ext = 0.0
    ke_ie = bal_max = 0.0
    t = 0.0
    step = 0
    end = total_time * (1.0 - 1e-12)
    ke_ie_from = settings.ke_ie_from * total_time
    out_dt = total_time / settings.n_output
    next_out = out_dt
    rows = [_row(0.0, 0.0, -W, 0.0, names, system.observe(0.0))]
    if on_output is not None:
        on_output(0, 0.0)
    h = min(dt, total_time)
    close_and_kick(F, du, du_next, W, W_end, v, minv, free, 0.0, m, f, h)   # from rest
    du, du_next = du_next, du
    while t < end:
        step += 1
        t_new = t + h
        system.advance(du, t_new)
        F = system.forces(t_new, v, h)
        if (step + 1) % settings.recheck_every == 0:
            dt = min(dt, settings.safety * system.stable_step())
        h_next = min(dt, total_time - t_new) if t_new < end else 0.0
        ke, w_total = close_and_kick(F, du, du_next, W, W_end, v, minv, free, 0.5 * h, m, f,
                                     h_next)
        du, du_next = du_next, du
        w_ext += system.external_work(t, t_new)
        t = t_new
        # KE + sum_p (-W_p) = W_ext; the driven family's absorbed energy includes W_ext
        balance = abs(ke - w_total - (0.0 if i_drv is not None else w_ext))
        if not math.isfinite(balance):
            raise ExplicitError("non-finite state", step, t, ke, -W_end[i_int], w_ext, h)
        if balance > settings.energy_stop * max(abs(w_ext), abs(W_end[i_int])) + settings.energy_floor:
            raise ExplicitError(f"energy balance error {balance:.4g} > {settings.energy_stop:g} "
                                f"max(|W_ext|, |IE|) + {settings.energy_floor:g}", step, t, ke,
                                -W_end[i_int], w_ext, h)
        bal_max = max(bal_max, balance)
        if t > ke_ie_from:
            ie = -W_end[i_int]
            if ie > 0.0:
                ke_ie = max(ke_ie, ke / ie)
        if t >= next_out - 1e-12 * total_time or t >= end:
            absorbed = -W_end
            if i_drv is not None:
                absorbed[i_drv] += w_ext
            umax = system.displacement_max()
            if umax > settings.max_displacement:
                raise ExplicitError(f"displacement {umax:.4g} mm > {settings.max_displacement:g} mm",
                                    step, t, ke, absorbed[i_int], w_ext, h)
            rows.append(_row(t, ke, absorbed, w_ext, names, system.observe(t)))
            next_out += out_dt
            if on_output is not None:
                on_output(step, t)
        h = h_next
    history = pd.DataFrame(rows)
    err = bal_max / max(abs(w_ext), settings.energy_floor)
    return DynamicsResult(history, dt, step, ke_ie, err, time.perf_counter() - t0)


def _row(t, ke, absorbed, w_ext, names, extra):
    row = {"time_s": t, "KE": ke}
    row.update({name: float(a) for name, a in zip(names, absorbed)})
    row["W_ext"] = w_ext
    row["balance_error"] = ke + float(absorbed.sum()) - w_ext
    row.update(extra)
    return row
