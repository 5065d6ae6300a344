"""ROM three-point and cantilever models against results no one here computed.

References:
* small-deflection beam theory, midspan load: F/u = 48 E I / L^3;
* the elastica of a cantilever under a tip dead load: Bisshopp, K. E. & Drucker, D. C.
  (1945), "Large deflection of cantilever beams", Q. Appl. Math. 3(3), 272-275, values
  tabulated in Mattiasson, K. (1981), IJNME 17, 145-153: at P L^2/(E I) = 1,
  delta_v/L = 0.30172, delta_h/L = 0.05643; at 10, delta_v/L = 0.81061,
  delta_h/L = 0.55500.  The closed form (elliptic integrals) is re-evaluated below as a
  check on the transcription of the tabulated values;
* plastic collapse of a circular section: M_p = 4/3 sigma_Y r^3, F = 4 M_p / L.
"""
import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

import harnesspipe  # noqa: F401
from harnesspipe import rom
from harnesspipe.fe.solvers.static import ConvergenceError

R_O = 7.05
I_O = np.pi * R_O**4 / 4
CLOSED = dict(E=15.7, sigma_y=0.6, K=1.59, n=0.3)  # Table 3, closed tube
BISSHOPP_DRUCKER = {1.0: (0.30172, 0.05643), 10.0: (0.81061, 0.55500)}


def elastica(alpha):
    """(delta_v/L, delta_h/L) of the tip-loaded cantilever (Bisshopp & Drucker 1945)."""
    def phi1(m):
        return np.arcsin(1.0 / np.sqrt(2.0 * m))

    def residual(phi0):
        m = (1 + np.sin(phi0)) / 2
        return ellipk(m) - ellipkinc(phi1(m), m) - np.sqrt(alpha)

    phi0 = brentq(residual, 1e-9, np.pi / 2 - 1e-12)
    m = (1 + np.sin(phi0)) / 2
    dv = 1 - 2 / np.sqrt(alpha) * (ellipe(m) - ellipeinc(phi1(m), m))
    return dv, 1 - np.sqrt(2 * np.sin(phi0) / alpha)


@pytest.mark.parametrize("alpha", sorted(BISSHOPP_DRUCKER))
def test_tabulated_elastica_values_match_the_closed_form(alpha):
    assert elastica(alpha) == pytest.approx(BISSHOPP_DRUCKER[alpha], abs=1e-5)


@pytest.mark.parametrize("alpha", sorted(BISSHOPP_DRUCKER))
def test_cantilever_matches_bisshopp_drucker(alpha):
    E, r, L = 2000.0, 1.0, 100.0
    P = alpha * E * np.pi * r**4 / 4 / L**2
    tip = rom.cantilever(E=E, radius=r, length=L, tip_load=P, elastic=True).iloc[-1]
    dv, dh = BISSHOPP_DRUCKER[alpha]
    assert tip["load_N"] == pytest.approx(P)
    assert tip["tip_uy_mm"] / L == pytest.approx(dv, rel=5e-3)
    assert -tip["tip_ux_mm"] / L == pytest.approx(dh, rel=5e-3)


def test_cantilever_tip_displacement_control_gives_the_same_load():
    E, r, L, P = 2000.0, 1.0, 100.0, 0.5
    loaded = rom.cantilever(E=E, radius=r, length=L, tip_load=P, elastic=True).iloc[-1]
    driven = rom.cantilever(E=E, radius=r, length=L, tip_displacement=loaded["tip_uy_mm"],
                            elastic=True).iloc[-1]
    assert driven["load_N"] == pytest.approx(P, rel=1e-4)
    assert driven["tip_ux_mm"] == pytest.approx(loaded["tip_ux_mm"], rel=1e-4)


@pytest.mark.parametrize("supports", ["pinned", "rollers"])
def test_initial_slope_is_48EI_over_L3(supports):
    E, span = 15.7, 127.0
    curve = rom.three_point(E=E, radius=R_O, supports=supports, elastic=True, deflection=0.5,
                            n_increments=2)
    slope = curve["force_N"].iloc[1] / curve["deflection_mm"].iloc[1]
    assert slope == pytest.approx(48 * E * I_O / span**3, rel=1e-2)


def test_perfectly_plastic_limit_load_is_4Mp_over_L():
    E, sigma_y, span = 1.0e5, 1.0, 127.0
    F_y = 4 * sigma_y * np.pi * R_O**3 / 4 / span
    u_y = F_y * span**3 / (48 * E * I_O)  # first yield: ~2e-3 mm, small deflection throughout
    curve = rom.three_point(E=E, sigma_y=sigma_y, K=0.0, n=1.0, radius=R_O, supports="pinned",
                            deflection=100 * u_y, n_increments=20, n_rings=8, n_sectors=32)
    F_p = 4 * (4.0 / 3.0) * sigma_y * R_O**3 / span
    assert curve["force_N"].iloc[-1] == pytest.approx(F_p, rel=2e-2)
    assert curve["force_N"].max() <= 1.02 * F_p


def test_three_point_rollers_is_mirror_symmetric():
    curve, shapes = rom.three_point(**CLOSED, radius=R_O, return_shapes=True)
    assert sorted(shapes) == [0.0, 10.0, 20.0, 30.0]
    bent = shapes[30.0]
    assert np.allclose(bent[:, 0], -bent[::-1, 0], atol=1e-6)
    assert np.allclose(bent[:, 1], bent[::-1, 1], atol=1e-6)
    mid = bent.shape[0] // 2
    assert bent[mid, 1] == pytest.approx(-30.0, abs=0.05)  # under the pin (penalty penetration)


def _max_change(a, b):
    return np.max(np.abs(a["force_N"] - b["force_N"])) / b["force_N"].abs().max()


def test_mesh_convergence_rollers():
    coarse = rom.three_point(**CLOSED, radius=R_O, n_elements=40)
    fine = rom.three_point(**CLOSED, radius=R_O, n_elements=80)
    assert _max_change(coarse, fine) < 5e-3


def test_section_quadrature_convergence_rollers():
    coarse = rom.three_point(**CLOSED, radius=R_O, n_rings=4, n_sectors=12)
    fine = rom.three_point(**CLOSED, radius=R_O, n_rings=8, n_sectors=24)
    assert _max_change(coarse, fine) < 5e-3


def test_roller_friction_raises_the_force_at_large_deflection():
    free = rom.three_point(**CLOSED, radius=R_O, n_increments=10)
    rough = rom.three_point(**CLOSED, radius=R_O, n_increments=10, mu=0.3)
    assert rough["force_N"].iloc[-1] > 1.02 * free["force_N"].iloc[-1]
    assert rough["force_N"].iloc[1] == pytest.approx(free["force_N"].iloc[1], rel=2e-2)


def test_missing_plastic_parameters_are_reported():
    with pytest.raises(ValueError, match="sigma_y, K, n required unless elastic"):
        rom.three_point(E=10.0, radius=R_O)


def test_load_beyond_plastic_collapse_raises_convergence_error():
    # perfectly plastic cantilever: no equilibrium beyond P = M_p / L
    sigma_y, r, L = 1.0, 1.0, 100.0
    P_collapse = 4.0 / 3.0 * sigma_y * r**3 / L
    with pytest.raises(ConvergenceError) as info:
        rom.cantilever(E=1e4, radius=r, length=L, tip_load=1.5 * P_collapse, sigma_y=sigma_y,
                       K=0.0, n=1.0, n_increments=6)
    msg = str(info.value)
    assert "did not converge at increment" in msg and "relative residual history" in msg
    last = float(info.value.last_converged.split()[2])  # "tip load <P> N"
    assert 0.9 * P_collapse < last <= 1.1 * P_collapse  # the lever arm shortens as it bends


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_rollers_tangent_is_consistent_with_the_residual(mu):
    """The assembled tangent (beams + sliding contact) against central differences of the
    residual, in a bent state with all three pins loaded (elastic fibres: a plastic state
    sits on the yield kink, where central differences average two tangents)."""
    from harnesspipe.fe.solvers.static import follow_path
    from harnesspipe.models import rom_beam as rb
    material = rb.Material.of(**CLOSED, elastic=True, nu=0.39)
    system, _ = rb._rollers(material, R_O, 127.0, 36.5, 30.0, mu, rb.Mesh())
    follow_path(system, [0.25, 0.5])
    assert (system.pressures > 0.0).all()
    rng = np.random.default_rng(1)
    system.set_load(0.55)
    w = rng.standard_normal(system.ndof)  # off the converged state (a friction kink: slip 0)
    w[system.fixed] = 0.0
    system.update(1e-3 * w / np.abs(w).max())
    _, _, band = system.evaluate(True)
    bw = system.bandwidth
    K = np.zeros((system.ndof, system.ndof))
    for j in range(system.ndof):
        for i in range(max(0, j - bw), min(system.ndof, j + bw + 1)):
            K[i, j] = band[bw + i - j, j]
    v = rng.standard_normal(system.ndof)
    v[system.fixed] = 0.0
    v *= 1e-6 / np.abs(v).max()
    state = (system.u.copy(), system.quat.copy())

    def residual(dv):
        system.u[:], system.quat[:] = state
        system.update(dv)
        return system.evaluate(False)[0]

    fd = (residual(v) - residual(-v)) / 2.0
    assert np.linalg.norm(K @ v - fd) <= 1e-5 * np.linalg.norm(fd)
