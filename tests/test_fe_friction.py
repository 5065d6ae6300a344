"""Eq. 6 rate-dependent Coulomb friction and the penalty stick/slip return map."""
import math

import numpy as np
import pytest

import harnesspipe  # noqa: F401
from harnesspipe.fe.materials.friction import (coulomb_return_map, equivalent_slip_rate,
                                               friction_coefficient, rate_dependent_friction)

MU_S, MU_K, D_C = 0.4, 0.1, 2.0   # wire-wire values (DESIGN sec. 3)
N = 5.0                           # normal force (N)
K_T = 1.0e4                       # tangential penalty (N/mm)


def test_eq6_at_known_slip_rates():
    assert friction_coefficient(MU_S, MU_K, D_C, 0.0) == pytest.approx(MU_S, rel=1e-15)
    assert friction_coefficient(MU_S, MU_K, D_C, 1.0e3) == pytest.approx(MU_K, rel=1e-15)
    assert friction_coefficient(MU_S, MU_K, D_C, 1.0 / D_C) == pytest.approx(
        MU_K + (MU_S - MU_K) / math.e, rel=1e-15)
    assert equivalent_slip_rate(0.3, 0.4) == pytest.approx(0.5, rel=1e-15)


def test_return_map_sticks_inside_and_returns_radially_outside_the_cone():
    f_new, ds = np.zeros(2), np.zeros(2)
    slipping, dW = coulomb_return_map(np.zeros(2), np.array([1e-5, 0.0]), K_T, MU_S, N, f_new, ds)
    assert not slipping and dW == 0.0 and np.all(ds == 0.0) and f_new[0] == pytest.approx(0.1)
    dg = np.array([3e-4, 4e-4])          # trial |f| = 5 N > mu_s N = 2 N
    slipping, dW = coulomb_return_map(np.zeros(2), dg, K_T, MU_S, N, f_new, ds)
    assert slipping
    assert np.allclose(f_new, MU_S * N * dg / np.linalg.norm(dg), rtol=1e-14)
    assert np.allclose(ds, (5.0 - 2.0) / K_T * dg / np.linalg.norm(dg), rtol=1e-12)
    assert np.allclose(f_new, K_T * (dg - ds), rtol=1e-12)   # elastic part carries the force
    assert dW == pytest.approx(f_new @ ds, rel=1e-14)
    # the cone is sharp: a trial force just inside sticks, just outside slips back onto it
    for ratio, slips in ((1.0 - 1e-9, False), (1.0 + 1e-9, True)):
        dg = np.array([ratio * MU_S * N / K_T, 0.0])
        slipping, _ = coulomb_return_map(np.zeros(2), dg, K_T, MU_S, N, f_new, ds)
        assert slipping == slips and f_new[0] <= MU_S * N * (1.0 + 1e-15)
    # no contact (tensile normal force): no friction, all motion is free slip
    slipping, dW = coulomb_return_map(np.zeros(2), dg, K_T, MU_S, -1.0, f_new, ds)
    assert np.all(f_new == 0.0) and np.allclose(ds, dg) and dW == 0.0


def push_block(mass, F_max, ramp_time, dt):
    """Explicit central-difference block on a rigid plane under F(t) = F_max t / ramp_time.

    Returns time, applied force, displacement, accumulated slip and friction force.
    """
    n = int(round(ramp_time / dt))
    f_old, f_new = np.zeros(1), np.zeros(1)
    dg, ds = np.zeros(1), np.zeros(1)
    u, v, slip = 0.0, 0.0, 0.0
    hist = np.zeros((n, 5))
    for j in range(n):
        t = (j + 1) * dt
        F = F_max * t / ramp_time
        a = (F - f_old[0]) / mass
        v += a * dt
        dg[0] = v * dt
        u += dg[0]
        rate_dependent_friction(f_old, dg, dt, K_T, MU_S, MU_K, D_C, N, f_new, ds)
        slip += ds[0]
        f_old[:] = f_new
        hist[j] = t, F, u, slip, f_new[0]
    return hist


def test_block_sticks_below_mu_s_n_and_slides_beyond():
    mass, dt = 1.0e-3, 2.0e-5          # omega = sqrt(k_t / m) = 3162 /s, dt omega = 0.06
    hist = push_block(mass, 2.0 * MU_S * N, ramp_time=2.0, dt=dt)
    t, F, u, slip, f = hist.T
    stick = F < 0.98 * MU_S * N
    assert np.all(slip[stick] == 0.0)
    # the block only stretches the penalty spring: u = F / k_t up to the small vibration
    # excited by the ramp (amplitude F_dot / (k_t omega) = 6.3e-8 mm), below mu_s N / k_t
    vib = 1.0e-7
    assert np.all(np.abs(u[stick] - F[stick] / K_T) <= vib)
    assert np.all(np.abs(u[stick]) <= MU_S * N / K_T)
    assert np.all(np.abs(f[stick] - F[stick]) <= K_T * vib)
    # beyond the static limit the block slides and keeps accelerating
    late = F > 1.1 * MU_S * N
    assert slip[late][0] > 0.0 and np.all(np.diff(slip[late]) > 0.0)
    assert u[-1] > 100.0 * MU_S * N / K_T
    # while sliding the friction force sits on the cone at mu(v) N, v the slip speed
    v = np.diff(u[late]) / dt
    mu_v = MU_K + (MU_S - MU_K) * np.exp(-D_C * v)
    assert np.allclose(f[late][1:], mu_v * N, rtol=1e-12)


def slide(velocity, distance, dt_solver, time_factor):
    """Drive a contact point at constant physical speed; solver time = physical / time_factor.

    Returns the friction force per step and the dissipated energy per step.
    """
    n = int(round(distance / (velocity * dt_solver * time_factor)))
    dg = np.array([velocity * dt_solver * time_factor, 0.0])   # same path per step
    f_old, f_new, ds = np.zeros(2), np.zeros(2), np.zeros(2)
    forces, work, mus = np.zeros(n), np.zeros(n), np.zeros(n)
    dt_phys = dt_solver * time_factor
    for j in range(n):
        mus[j], _, work[j] = rate_dependent_friction(
            f_old, dg, dt_phys, K_T, MU_S, MU_K, D_C, N, f_new, ds)
        f_old[:] = f_new
        forces[j] = np.linalg.norm(f_new)
    return forces, work, mus, dg[0]


@pytest.mark.parametrize("velocity", [0.05, 0.5, 5.0])
def test_steady_sliding_force_and_dissipation(velocity):
    mu_v = MU_K + (MU_S - MU_K) * math.exp(-D_C * velocity)
    forces, work, mus, step = slide(velocity, distance=2.0, dt_solver=1e-4, time_factor=1.0)
    assert np.all(mus == pytest.approx(mu_v, rel=1e-14))
    stuck = int(np.ceil(mu_v * N / (K_T * step)))     # steps to load the penalty spring
    assert np.allclose(forces[stuck + 1:], mu_v * N, rtol=1e-14)
    s = step * len(work[stuck + 1:])                   # distance slid in steady state
    assert work[stuck + 1:].sum() == pytest.approx(mu_v * N * s, rel=1e-6)
    assert work.sum() == pytest.approx(mu_v * N * (2.0 - mu_v * N / K_T), rel=1e-6)


def test_time_scaling_needs_the_physical_slip_rate():
    velocity, factor = 0.5, 25.0
    f_ref, w_ref, mu_ref, _ = slide(velocity, 1.0, dt_solver=1e-3, time_factor=1.0)
    f_sc, w_sc, mu_sc, _ = slide(velocity, 1.0, dt_solver=1e-3 / factor, time_factor=factor)
    assert mu_sc[-1] == pytest.approx(mu_ref[-1], rel=1e-14)
    assert f_sc[-1] == pytest.approx(f_ref[-1], rel=1e-14)
    assert w_sc.sum() == pytest.approx(w_ref.sum(), rel=1e-12)
    # passing the solver's (scaled) step instead would report a 25x faster slip
    f_new, ds = np.zeros(2), np.zeros(2)
    dg = np.array([velocity * 1e-3, 0.0])
    mu_wrong, _, _ = rate_dependent_friction(
        np.zeros(2), dg, 1e-3 / factor, K_T, MU_S, MU_K, D_C, N, f_new, ds)
    assert mu_wrong == pytest.approx(friction_coefficient(MU_S, MU_K, D_C, factor * velocity))
    assert abs(mu_wrong - mu_ref[-1]) > 0.1
