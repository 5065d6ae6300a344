"""Single cohesive interface against the closed forms of eqs. 7-10 (Sec. 4.1)."""
import numpy as np
import pytest

import harnesspipe  # noqa: F401
from harnesspipe.fe.materials.cohesive import cohesive_dissipated_energy, cohesive_traction

K0, D0, DF, ALPHA = 30.0, 0.03, 0.08, 2.0   # paper values (DESIGN sec. 3)
K = np.full(3, K0)
DELTA0 = np.full(3, D0)


def damage_eq10(d, d0=D0, df=DF, alpha=ALPHA):
    """Eq. 10 written out independently of the kernel (d0 < d < df)."""
    x = (d - d0) / (df - d0)
    return 1.0 - d0 / d * (1.0 - (1.0 - np.exp(-alpha * x)) / (1.0 - np.exp(-alpha)))


def traction_path(path, component=0, K_=K, delta0=DELTA0):
    """Drive the kernel along a history of one separation component; return t, D, kappa."""
    t = np.zeros(3)
    delta = np.zeros(3)
    kappa, D = 0.0, 0.0
    out = np.zeros((len(path), 3))
    for j, d in enumerate(path):
        delta[:] = 0.0
        delta[component] = d
        D, kappa = cohesive_traction(delta, K_, delta0, DF, ALPHA, kappa, D, t)
        out[j] = t[component], D, kappa
    return out


@pytest.mark.parametrize("component", [0, 1, 2])
def test_monotonic_opening_follows_eqs_7_to_10(component):
    d = np.linspace(0.0, 0.1, 2001)
    t, D, _ = traction_path(d, component).T
    elastic = d <= D0
    assert np.allclose(t[elastic], K0 * d[elastic], rtol=1e-14, atol=0.0)
    assert np.all(D[elastic] == 0.0)
    i0 = np.searchsorted(d, D0)
    assert t[i0] == pytest.approx(K0 * D0, rel=1e-12)
    assert t.max() == pytest.approx(K0 * D0, rel=1e-12)
    soft = (d > D0) & (d < DF)
    expected = (1.0 - damage_eq10(d[soft])) * K0 * d[soft]
    assert np.allclose(t[soft], expected, rtol=1e-12, atol=0.0)
    assert np.allclose(D[soft], damage_eq10(d[soft]), rtol=1e-12)
    failed = d >= DF
    assert np.all(D[failed] == 1.0) and np.all(t[failed] == 0.0)


def test_per_direction_onset_of_eq8_in_shear():
    delta0 = np.array([0.03, 0.05, 0.04])
    for comp in (1, 2):
        d = np.array([0.99, 1.0, 1.2]) * delta0[comp]
        t, D, _ = traction_path(d, comp, delta0=delta0).T
        assert D[0] == 0.0 and D[1] == 0.0 and D[2] > 0.0
        assert D[2] == pytest.approx(damage_eq10(d[2], d0=delta0[comp]), rel=1e-12)
    # shear of either sign damages alike
    t_pos, D_pos, _ = traction_path([0.05], 1).T
    t_neg, D_neg, _ = traction_path([-0.05], 1).T
    assert D_pos[0] == D_neg[0] > 0.0 and t_neg[0] == -t_pos[0]


def test_unloading_and_reloading_follow_the_damaged_secant():
    d_peak = 0.05
    load = np.linspace(0.0, d_peak, 201)
    unload = np.linspace(d_peak, 0.0, 201)[1:]
    reload = np.linspace(0.0, d_peak, 201)[1:]
    further = np.linspace(d_peak, 0.07, 101)[1:]
    path = np.concatenate([load, unload, reload, further])
    t, D, kappa = traction_path(path).T
    D_peak = damage_eq10(d_peak)
    cycle = slice(len(load), len(load) + len(unload) + len(reload))
    assert np.all(D[cycle] == D[len(load) - 1])
    assert D[len(load) - 1] == pytest.approx(D_peak, rel=1e-12)
    assert np.allclose(t[cycle], (1.0 - D_peak) * K0 * path[cycle], rtol=1e-12, atol=1e-15)
    assert np.all(kappa[cycle] == d_peak)
    tail = slice(len(path) - len(further), None)
    assert np.allclose(t[tail], (1.0 - damage_eq10(path[tail])) * K0 * path[tail], rtol=1e-12)


def test_damage_never_decreases_on_a_random_history():
    rng = np.random.default_rng(20260521)
    delta0 = np.array([0.03, 0.04, 0.035])
    delta = np.zeros(3)
    t = np.zeros(3)
    kappa, D = 0.0, 0.0
    Ds = []
    for _ in range(5000):
        delta += rng.normal(0.0, 0.003, 3)
        np.clip(delta, -0.1, 0.1, out=delta)
        D_new, kappa_new = cohesive_traction(delta, K, delta0, DF, ALPHA, kappa, D, t)
        assert D_new >= D and kappa_new >= kappa
        dm = np.sqrt(max(delta[0], 0.0) ** 2 + delta[1] ** 2 + delta[2] ** 2)
        assert kappa_new == pytest.approx(max(kappa, dm), rel=1e-15)
        assert np.allclose(t[1:], (1.0 - D_new) * K[1:] * delta[1:], rtol=1e-14, atol=0.0)
        D, kappa = D_new, kappa_new
        Ds.append(D)
    assert 0.0 < Ds[len(Ds) // 10] and Ds[-1] == 1.0


def test_compression_is_undamaged():
    d = np.concatenate([np.linspace(0.0, 0.06, 61), np.linspace(0.06, -0.05, 111)])
    t, D, _ = traction_path(d).T
    comp = d < 0.0
    assert D[-1] == pytest.approx(damage_eq10(0.06), rel=1e-12) and D[-1] > 0.5
    assert np.allclose(t[comp], K0 * d[comp], rtol=1e-14, atol=0.0)
    # compression together with shear: shear damaged, normal not; damage from shear only
    delta = np.array([-0.02, 0.05, 0.0])
    tt = np.zeros(3)
    D_, kappa = cohesive_traction(delta, K, DELTA0, DF, ALPHA, 0.0, 0.0, tt)
    assert kappa == pytest.approx(0.05) and D_ == pytest.approx(damage_eq10(0.05), rel=1e-12)
    assert tt[0] == K0 * -0.02 and tt[1] == pytest.approx((1 - D_) * K0 * 0.05, rel=1e-14)


def test_work_of_separation_matches_closed_form():
    # closed form: 0.5 K d0^2 + K d0 (df - d0) int_0^1 [1 - (1 - e^{-a x}) / (1 - e^{-a})] dx
    G_closed = K0 * D0 * (0.5 * D0 + (DF - D0) * (1.0 / ALPHA - 1.0 / np.expm1(ALPHA)))
    # independent check of the closed form: fine quadrature of (1 - D) K d
    ds = np.linspace(D0, DF, 400001)
    G_quad = np.trapezoid((1.0 - damage_eq10(ds)) * K0 * ds, ds) + 0.5 * K0 * D0**2
    assert G_quad == pytest.approx(G_closed, rel=1e-9)
    # the kernel's traction integrated along a monotonic opening
    d = np.linspace(0.0, DF, 200001)
    t = traction_path(d)[:, 0]
    assert np.trapezoid(t, d) == pytest.approx(G_closed, rel=1e-8)
    assert cohesive_dissipated_energy(K0, D0, DF, ALPHA, DF) == pytest.approx(G_closed, rel=1e-14)
    assert cohesive_dissipated_energy(K0, D0, DF, ALPHA, 1.0) == pytest.approx(G_closed, rel=1e-14)


@pytest.mark.parametrize("kappa", [0.02, 0.03, 0.04, 0.06, 0.079])
def test_dissipated_energy_is_work_minus_recoverable_energy(kappa):
    d_load = np.linspace(0.0, kappa, 100001)
    t_load = traction_path(d_load)[:, 0]
    D = 0.0 if kappa <= D0 else damage_eq10(kappa)
    expected = np.trapezoid(t_load, d_load) - 0.5 * (1.0 - D) * K0 * kappa**2
    assert cohesive_dissipated_energy(K0, D0, DF, ALPHA, kappa) == pytest.approx(
        expected, rel=1e-7, abs=1e-14)
