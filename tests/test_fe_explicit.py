"""Explicit central difference (Sec. 4.1, eq. 11) on the pinned three-point beam."""
import time

import numpy as np
import pytest
from explicit_beam_driver import BeamExplicit, run_explicit

import harnesspipe  # noqa: F401
from harnesspipe import rom
from harnesspipe.fe.solvers.central_difference import smooth_step
from harnesspipe.models.rom_beam import BeamSystem, Material, Mesh

E, NU, RADIUS, SPAN, DEFL = 20.0, 0.39, 7.0, 127.0, 5.0
RHO = 2.0e-9       # t/mm^3
F_M = 25.0         # mass scaling (the paper's value)
NE = 20


def pinned_beam(ne=NE):
    """The pinned ROM set-up of rom_beam._pinned: planar, midspan deflection prescribed."""
    X = np.zeros((ne + 1, 3))
    X[:, 0] = np.linspace(0.0, SPAN, ne + 1)
    mid = ne // 2
    load_dof = 6 * mid + 1
    planar = [6 * k + c for k in range(ne + 1) for c in (2, 3, 4)]
    fixed = planar + [0, 1, 6 * ne + 1, load_dof]
    system = BeamSystem(X, Material(E=E, nu=NU), RADIUS, Mesh(n_elements=ne), fixed,
                        prescribed={load_dof: -DEFL})
    return system, load_dof


def first_period():
    """Simply supported Euler-Bernoulli beam, scaled density."""
    r_g = RADIUS / 2.0
    omega = (np.pi / SPAN) ** 2 * r_g * np.sqrt(E / (F_M * RHO))
    return 2.0 * np.pi / omega


def test_smooth_step():
    assert smooth_step(0.0) == (0.0, 0.0, 0.0) and smooth_step(1.0) == (1.0, 0.0, 0.0)
    s, ds, d2s = smooth_step(0.5)
    assert s == pytest.approx(0.5) and ds == pytest.approx(1.875) and d2s == pytest.approx(0.0)
    h = 1e-6
    assert ds == pytest.approx((smooth_step(0.5 + h)[0] - smooth_step(0.5 - h)[0]) / (2 * h))


def test_pinned_beam_quasi_static_matches_rom():
    system, load_dof = pinned_beam()
    problem = BeamExplicit(system, RHO, F_M)
    T = 40.0 * first_period()   # KE/IE of the ramp itself ~ (T1/T)^2
    t0 = time.perf_counter()
    res = run_explicit(problem, T)
    elapsed = time.perf_counter() - t0
    # the bending limit governs this thick, fine beam (documented in fe/solvers/central_difference.py)
    assert res.dt_beam < res.dt_wave
    assert res.dt <= 0.9 * min(res.dt_wave, res.dt_beam) * (1 + 1e-12)
    force = -res.reactions[load_dof]
    ref = rom.three_point(E=E, radius=RADIUS, supports="pinned", deflection=DEFL, elastic=True)
    f_ref = float(ref["force_N"].iloc[-1])
    print(f"explicit {force:.5f} N vs static {f_ref:.5f} N; steps {res.n_steps}, dt {res.dt:.3e}"
          f" (wave {res.dt_wave:.3e}, beam {res.dt_beam:.3e}); KE/IE {res.max_ke_ie:.2e}; "
          f"balance {res.max_balance_error:.2e}; {elapsed:.2f} s")
    assert force == pytest.approx(f_ref, rel=0.02)
    assert res.max_ke_ie < 0.02
    assert res.balance_error < 0.01 and res.max_balance_error < 0.01
    assert res.w_ext > 0.0 and res.ie == pytest.approx(res.w_ext, rel=0.01)
    assert system.u[load_dof // 6, 1] == pytest.approx(-DEFL)


@pytest.mark.parametrize("ramp", [0.0, 0.1, 0.25, 0.5])
def test_the_feeder_reaches_the_test_rate_from_rest_and_keeps_it(ramp):
    """rate_ramp: at rest at the start, S(1) = 1, S' the integral's derivative (central
    differences) and continuous through the ramp's end, constant 1 / (1 - ramp/2) after it;
    rate_ramp_time inverts it; a run's end_time for an early stop follows."""
    from harnesspipe.fe.solvers.central_difference import rate_ramp, rate_ramp_time
    from harnesspipe.models.hifi import end_time
    c = 1.0 / (1.0 - 0.5 * ramp)
    assert rate_ramp(0.0, ramp) == (0.0, 0.0) and rate_ramp(1.0, ramp) == (pytest.approx(1.0, abs=1e-15), c)
    h = 1e-6
    for x in np.linspace(0.01, 0.99, 37):
        S, dS = rate_ramp(x, ramp)
        assert dS == pytest.approx((rate_ramp(x + h, ramp)[0] - rate_ramp(x - h, ramp)[0]) / (2 * h), rel=1e-6, abs=1e-8)
        assert dS == pytest.approx(c) if x >= ramp else 0.0 <= dS < c
        assert rate_ramp_time(S, ramp) == pytest.approx(x, abs=1e-12)
    if ramp > 0.0:
        assert rate_ramp(ramp * (1 - 1e-12), ramp)[0] == pytest.approx(rate_ramp(ramp, ramp)[0], abs=1e-11)
        assert rate_ramp(0.5 * ramp, ramp)[1] == pytest.approx(0.5 * c)        # half the rate half-way
    assert end_time(1.0, 21.0, 30.0, ramp) == pytest.approx(0.7 / c + 0.5 * ramp)
    assert end_time(2.0, 0.0, 30.0, ramp) == end_time(2.0, 30.0, 30.0, ramp) == 2.0
    with pytest.raises(ValueError, match="outside"):
        rate_ramp_time(1.5, ramp)
    with pytest.raises(ValueError, match="outside"):
        rate_ramp(0.5, 1.0)



def test_explicit_error_survives_a_process_boundary():
    """A run that fails in a worker (multiprocessing, a campaign) re-raises with its diagnostics."""
    import pickle

    from harnesspipe.fe.solvers.central_difference import ExplicitError
    err = ExplicitError("non-finite state", 12, 0.25, 1.5, 3.0, 4.75, 1e-6)
    back = pickle.loads(pickle.dumps(err))
    assert isinstance(back, ExplicitError) and str(back) == str(err)
    assert (back.reason, back.step, back.time, back.ke, back.ie, back.w_ext, back.dt) == (
        "non-finite state", 12, 0.25, 1.5, 3.0, 4.75, 1e-6)
