"""ROM extraction (Sec. 4.3): eq. 13 closed forms and recovery of Table 3 sets."""
import math

import numpy as np
import pytest

from harnesspipe import config as cfgmod
from harnesspipe.calibrate import eq13, hardening
from harnesspipe.calibrate import rom as rom_fit
from stage_checks import assert_intervals_and_replicate_band


def test_eq13_on_an_exact_beam_theory_curve():
    """A curve with slope 48 E I / L^3 returns E; F_2% L / (pi r^3) returns sigma_Y."""
    E, r, L = 15.7, 7.05, 127.0
    k = 48.0 * E * (math.pi * r**4 / 4.0) / L**3
    u = np.linspace(0.0, 30.0, 301)
    F = k * u
    assert eq13.effective_modulus(u, F, L, r) == pytest.approx(E, rel=1e-12)
    assert eq13.yield_stress(u, F, L, r) == pytest.approx(k * 0.02 * L * L / (math.pi * r**3), rel=1e-12)


def test_linear_part_is_the_window_below_one_percent_of_the_span():
    """A kink just above the window does not bias E; one inside it does, by design."""
    u = np.linspace(0.0, 30.0, 301)
    above = np.where(u <= 1.3, u, 1.3 + 0.2 * (u - 1.3))     # kink at 1.3 mm > 1.27 mm
    inside = np.where(u <= 0.6, u, 0.6 + 0.2 * (u - 0.6))    # kink at 0.6 mm
    assert eq13.linear_slope(u, above, 127.0) == pytest.approx(1.0, rel=1e-12)
    assert eq13.linear_slope(u, inside, 127.0) < 0.9


def test_linear_part_grows_to_the_end_of_the_elastic_range_under_noise():
    rng = np.random.default_rng(7)
    u = np.linspace(0.0, 30.0, 101)
    F = np.where(u <= 8.0, 0.7 * u, 5.6 + 0.2 * (u - 8.0)) + 0.02 * rng.standard_normal(u.size)
    assert eq13.noise_level(F) == pytest.approx(0.02, rel=0.3)
    slope, u_lin = eq13.linear_part(u, F, 127.0)
    assert slope == pytest.approx(0.7, rel=0.01)
    assert 6.0 <= u_lin <= 9.0


def test_noisy_linear_part_is_averaged():
    rng = np.random.default_rng(1)
    u = np.linspace(0.0, 30.0, 201)
    F = 0.7 * u + 0.01 * rng.standard_normal(u.size)
    assert eq13.linear_slope(u, F, 127.0) == pytest.approx(0.7, rel=0.02)


def test_too_coarse_a_curve_is_refused():
    u = np.linspace(0.0, 30.0, 11)
    with pytest.raises(ValueError, match=r"only 0 points with 0 < u <= 1.27 mm"):
        eq13.linear_slope(u, u, 127.0)
    with pytest.raises(ValueError, match="must reach 2.54 mm"):
        eq13.force_at(np.linspace(0, 2.0, 11), np.zeros(11), 2.54)


def test_flow_stress_coordinates_map_one_to_one():
    strains = (0.0005, 0.005, 0.05)
    for p in [(0.6, 1.59, 0.3), (0.2, 0.97, 0.13), (8.6, 25.6, 0.12), (10.0, 30.8, 0.6)]:
        s = hardening.flow_stresses(*p, strains)
        assert hardening.hardening_from_three(s, strains) == pytest.approx(p, rel=1e-10)
        assert hardening.hardening_from_two(p[0], s[1:], strains[1:]) == pytest.approx(p, rel=1e-10)
    assert hardening.hardening_from_three((0.5, 0.9, 1.0), strains) is None   # n < 0 (concave)
    assert hardening.hardening_from_two(0.6, (0.5, 0.9), strains[1:]) is None  # s_1 below sigma_Y


def settings_for(cfg, case, maxfev=250):
    rom = cfg["rom"]
    return {"r_o": cfg["cases"][case]["r_o"], "supports": "rollers", "mu": 0.0, "reference": "measured",
            "three_point": {k: cfg["three_point"][k] for k in ("span", "overhang", "deflection")},
            "rom": {k: rom[k] for k in ("model_consistent_E", "consistent_E_model", "linear_window", "yield_deflection",
                                        "simplex_parameters", "simplex_space", "reference_strains",
                                        "simplex", "initial_guess")},
            "mesh": cfg["profiles"]["quick"]["rom"], "maxfev": maxfev}


@pytest.mark.slow
@pytest.mark.parametrize("case", ["cwb19_t2_closed", "cwb19_t2_open_halflap", "cwb19_t2_open_coarse",
                                  "cwb19_t2_fabric", "cwb10t1_9t2_fabric"])
def test_recovers_table3_from_noise_free_curves(case):
    """E and sigma_Y within 2 %; the fitted curve within 1 % of the peak force everywhere."""
    cfg = cfgmod.load()
    truth = cfg["paper"]["table3"][case]
    settings = settings_for(cfg, case)
    curve = rom_fit.simulate(truth, settings)
    u = np.linspace(0.0, 30.0, 101)
    F = np.interp(u, curve["deflection_mm"], curve["force_N"])
    fit = rom_fit.fit(u, F, settings)
    p = fit.parameters
    assert p["E"] == pytest.approx(truth["E"], rel=0.02)
    assert p["sigma_y"] == pytest.approx(truth["sigma_y"], rel=0.02)
    refit = rom_fit.simulate(p, settings)
    F_fit = np.interp(u, refit["deflection_mm"], refit["force_N"])
    assert np.max(np.abs(F_fit - F)) < 0.01 * F.max()
    assert fit.E_eq13 == pytest.approx(truth["E"], rel=0.02)   # eq. 13 alone is close, too


def test_elastoplastic_window_recovers_E_where_the_window_runs_into_yield():
    """A noise-free coarse-taped curve (Table 3) with eq. 13's window forced to 10 % of the
    span, into yield: the elastic correction leaves E more than 2 % low, the whole fit with
    the elastoplastic window within 0.2 % of the truth.  Its Fisher gradient d ln E / dF
    matches a central difference of the estimator itself along a random perturbation of the
    rows, and reduces to eq. 13's own where the window ends before yield."""
    cfg = cfgmod.load()
    case = "cwb19_t2_open_coarse"
    truth = cfg["paper"]["table3"][case]
    settings = settings_for(cfg, case)
    settings["rom"]["linear_window"] = 0.1
    u = np.linspace(0.0, 30.0, 201)
    F = rom_fit.simulate_on(u, truth, settings)
    assert rom_fit.effective_modulus(u, F, settings)[0] < 0.98 * truth["E"]
    fit = rom_fit.fit(u, F, settings)
    assert fit.parameters["E"] == pytest.approx(truth["E"], rel=2e-3) and fit.refine_runs > 0

    G = rom_fit.elastoplastic_log_modulus_gradient(u, F, truth, settings)
    e = np.random.default_rng(0).normal(size=u.size) * 1e-3 * F.max()
    u_lin = eq13.linear_part(u, F, 127.0, 0.1)[1]
    assert eq13.linear_part(u, F + e, 127.0, 0.1)[1] == u_lin   # the window held
    up, down = (rom_fit.elastoplastic_window(u, F + sign * e, truth, settings)[0]["E"] for sign in (1, -1))
    assert 0.5 * math.log(up / down) == pytest.approx(G @ e, rel=0.03)   # central: first order

    settings["rom"]["linear_window"] = 0.01
    G = rom_fit.elastoplastic_log_modulus_gradient(u, F, truth, settings)
    assert G == pytest.approx(eq13.log_modulus_gradient(u, F, 127.0, 0.01), rel=1e-3, abs=1e-9)


def shipped_rows(case):
    """Every measured row of the shipped three-point specimens of ``case``: (u, forces n x N)."""
    from conftest import REPO

    from harnesspipe.data.experimental import load_all
    from harnesspipe.stages.data import Prepared
    (ts,) = [t for t in load_all(REPO / "data" / "experimental").values() if t.entry["item"] == case]
    samples = {s.name: {"displacement_mm": s.displacement, "force_N": s.force} for s in ts.samples}
    return Prepared(ts.test_id, ts.entry, ts.grid, ts.mean, ts.lo, ts.hi, samples).rows()


@pytest.mark.parametrize("case", ["cwb19_t2_closed", "cwb19_t2_open_halflap", "cwb19_t2_open_coarse",
                                  "cwb19_t2_fabric", "cwb10t1_9t2_fabric"])
def test_shipped_noisy_data_gives_E_within_5_percent(case):
    cfg = cfgmod.load()
    u, F = shipped_rows(case)
    settings = settings_for(cfg, case)
    settings["mesh"] = cfg["profiles"]["default"]["rom"]
    E, _ = rom_fit.effective_modulus(u, F.mean(axis=0), settings)
    assert E == pytest.approx(cfg["paper"]["table3"][case]["E"], rel=0.05)


# the criterion of issue 29: E, and the flow stress at plastic strains the test reaches
FLOW_STRAINS = (2e-3, 5e-3, 2e-2)
THREE_POINT_TESTS = ["bend_cwb19_t2_closed", "bend_cwb19_t2_open_halflap", "bend_cwb19_t2_open_coarse",
                     "bend_cwb19_t2_fabric", "bend_cwb10t1_9t2_fabric", "bend_cwb19_t1_open_coarse"]


def flow(p, eps_p):
    """Eq. 2 flow stress sigma_Y + K eps_p^n."""
    return p["sigma_y"] + p["K"] * eps_p ** p["n"]


@pytest.mark.slow
@pytest.mark.parametrize("test_id", THREE_POINT_TESTS)
def test_stage_meets_the_criterion_on_the_shipped_data(test_id, tmp_path):
    """The ROM stage on the shipped specimens, with the mesh the data were made with (default
    profile): every measured row is fitted; E within 5 % of truth and the flow stress within
    5 % at eps_p = 2e-3, 5e-3, 2e-2 (sigma_Y, K, n alone are not determined to 5 % by any
    estimator: bench/RESULTS.md, Identifiability); the model reproduces the specimens' mean to
    within the noise (chi-square passes), and the noise read off the rows is the twin's (0.5 %
    of each specimen's peak force, to 15 %: three sampling
    standard deviations of the estimate from 3 x 199 rows).

    Uncertainty: E is eq. 13 on each replicate, so the sandwich's standard error of ln E is
    the spread of these specimens' own E over sqrt(3) (their 4 % scatter: 1-5 %), to 30 %
    (eq. 13's noise on each replicate); without the 1/n of the mean it would be 1.7 times
    that, and the Fisher figure (load-cell noise only, ~0.1 %) is far below it."""
    import json

    from conftest import REPO

    from harnesspipe.data.experimental import read_manifest
    from harnesspipe.data.synthesize import read_truth
    from harnesspipe.stages import data as stage_data
    from harnesspipe.stages import rom as rom_stage
    data, cfg = REPO / "data" / "experimental", cfgmod.load()
    case = read_manifest(data)["tests"][test_id]["item"]
    stage_data.prepare_test(data, test_id, tmp_path / "ref.h5")
    settings = settings_for(cfg, case, maxfev=cfg["profiles"]["default"]["simplex_maxfev"])
    settings["mesh"] = cfg["profiles"]["default"]["rom"]
    rom_stage.fit_case(case, tmp_path / "ref.h5", settings, tmp_path / "fit")
    fit = json.loads((tmp_path / "fit" / "fit.json").read_text())
    p, truth = fit["parameters"], read_truth(data)[test_id]["parameters"]
    assert p["E"] == pytest.approx(truth["E"], rel=0.05)
    for eps_p in FLOW_STRAINS:
        assert flow(p, eps_p) == pytest.approx(flow(truth, eps_p), rel=0.05), eps_p
    _, F = stage_data.read_prepared(tmp_path / "ref.h5").rows()
    assert fit["rows"] == F.shape[1] == cfg["synthesize"]["rows"]
    assert fit["chi_square"]["pass"], fit["chi_square"]
    noise = cfg["synthesize"]["noise_fraction"] * np.sqrt(np.mean(F.max(axis=1) ** 2))
    assert fit["fisher"]["noise_sigma_N"] == pytest.approx(noise, rel=0.15)   # ~3 sd of the estimate
    E_k = [s["E"] for s in read_truth(data)[test_id]["samples"].values()]
    spread = np.std(np.log(E_k), ddof=1) / np.sqrt(len(E_k))
    assert fit["standard_error_dof"] == len(E_k) - 1
    assert fit["standard_error"]["E"] == pytest.approx(spread, rel=0.3)
    assert fit["fisher"]["standard_error"]["E"] < 0.2 * fit["standard_error"]["E"]
    rho = np.array(fit["fisher"]["correlation"], dtype=float)
    np.testing.assert_allclose(rho, rho.T)
    np.testing.assert_allclose(np.diag(rho), 1.0)
    assert_intervals_and_replicate_band(fit, tmp_path / "fit" / "curve.csv",
                                        *stage_data.read_prepared(tmp_path / "ref.h5").rows())
