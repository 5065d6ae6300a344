"""Tensile models of the coverings and their calibration (Sec. 3.2, Table 2)."""
import numpy as np
import pandas as pd
import pytest

import harnesspipe  # noqa: F401  (sets the Numba cache)
from harnesspipe.calibrate.tensile import (calibrate_fabric, calibrate_tube, force_error,
                                           linear_region)
from harnesspipe.fe.materials.hardening import flow_stress
from harnesspipe.models.tensile import (FabricGeometry, TubeGeometry, resolution, simulate,
                                        simulate_axisymmetric_tube, simulate_shell_tube)
from stage_checks import assert_intervals_and_replicate_band

TABLE2 = {"closed_tube": (1559.0, 8.6, 25.6, 0.12), "open_tube": (698.0, 8.8, 23.1, 0.83),
          "fabric_tube": (93.5, 10.0, 30.8, 0.60)}
ELASTIC = (1559.0, 1e30, 0.0, 1.0)


def test_simulate_returns_the_documented_frame():
    df = simulate("closed_tube", *TABLE2["closed_tube"], preset="quick")
    assert list(df.columns) == ["displacement_mm", "force_N"]
    assert df["displacement_mm"].iloc[0] == 0.0 and df["displacement_mm"].iloc[-1] == 25.0
    assert np.all(np.diff(df["force_N"]) > 0)
    again = simulate("closed_tube", *TABLE2["closed_tube"], preset="quick")
    assert again.equals(df)  # deterministic


def test_tube_force_converges_with_the_meridian_mesh():
    final = [simulate("closed_tube", *TABLE2["closed_tube"], meridian=m)["force_N"].iloc[-1]
             for m in (8, 16, 32, 64)]
    changes = np.abs(np.diff(final))
    assert np.all(changes[1:] < 0.5 * changes[:-1])  # at least first-order convergence
    assert changes[-1] / final[-1] < 0.01              # default mesh (32) within 1 %


def test_axisymmetric_cell_agrees_with_3d_shell_cell():
    """Initial (elastic) stiffness of the ridged cell: axisymmetric shell vs 4-node shell."""
    geom = TubeGeometry(extension=0.02)
    axi = simulate_axisymmetric_tube(*ELASTIC, geometry=geom,
                                     res=resolution("default", meridian=64, n_steps=1))
    shell = simulate_shell_tube(*ELASTIC, cut=False, geometry=geom,
                                res=resolution("default", meridian=16, circumference=24, n_steps=1))
    assert shell["force_N"].iloc[-1] == pytest.approx(axi["force_N"].iloc[-1], rel=0.01)


def test_cut_lowers_the_tube_stiffness_only_slightly():
    """The paper: the longitudinal cut has no notable impact.  3D cells with and without it."""
    geom = TubeGeometry(extension=0.02)
    res = resolution("default", meridian=8, circumference=12, n_steps=1)
    closed = simulate_shell_tube(*ELASTIC, cut=False, geometry=geom, res=res)["force_N"].iloc[-1]
    opened = simulate_shell_tube(*ELASTIC, cut=True, geometry=geom, res=res)["force_N"].iloc[-1]
    assert 0.85 < opened / closed < 1.0


def test_fabric_sheet_is_uniaxial_j2_at_finite_strain():
    E, sigma_y, K, n = TABLE2["fabric_tube"]
    geom = FabricGeometry()
    df = simulate("fabric_tube", E, sigma_y, K, n, preset="quick")
    stretch = 1 + df["displacement_mm"].to_numpy()[1:] / geom.gauge
    eps = np.log(stretch)
    tau = df["force_N"].to_numpy()[1:] * stretch / geom.area
    eps_p = eps - tau / E
    plastic = eps_p > 1e-9
    assert np.allclose(tau[~plastic], E * eps[~plastic], rtol=1e-6)
    assert np.allclose(tau[plastic], flow_stress_array(eps_p[plastic], sigma_y, K, n), rtol=1e-6)


def flow_stress_array(eps_p, sigma_y, K, n):
    return np.array([flow_stress(e, sigma_y, K, n) for e in eps_p])


def synthetic_fabric_curve(E, sigma_y, K, n, noise=0.0, seed=0):
    """Closed-form uniaxial curve (Hencky, J2, eq. 2) sampled like a load frame."""
    geom = FabricGeometry()
    u = np.linspace(0.0, geom.elongation, 301)
    eps = np.log1p(u / geom.gauge)
    tau = np.array([_uniaxial_tau(e, E, sigma_y, K, n) for e in eps])
    force = tau * geom.area / (1 + u / geom.gauge)
    force *= 1 + noise * np.random.default_rng(seed).standard_normal(u.size)
    return pd.DataFrame({"displacement_mm": u, "force_N": force})


def _uniaxial_tau(eps, E, sigma_y, K, n):
    from scipy.optimize import brentq
    if E * eps <= sigma_y:
        return E * eps
    ep = brentq(lambda ep: E * (eps - ep) - flow_stress(ep, sigma_y, K, n), 0.0, eps)
    return E * (eps - ep)


@pytest.mark.parametrize("truth", [(93.5, 10.0, 30.8, 0.60), (120.0, 6.0, 50.0, 1.4)])
def test_eq3_linear_region_and_departure_point(truth):
    E, sigma_y, _, _ = truth
    geom = FabricGeometry()
    region = linear_region(synthetic_fabric_curve(*truth), geom.gauge, geom.area)
    assert region.E == pytest.approx(E, rel=1e-3)
    assert region.sigma_y == pytest.approx(sigma_y, rel=0.005)
    assert region.u_dev == pytest.approx(geom.gauge * np.expm1(sigma_y / E), rel=0.005)
    noisy = linear_region(synthetic_fabric_curve(*truth, noise=0.002), geom.gauge, geom.area)
    assert noisy.sigma_y == pytest.approx(sigma_y, rel=0.03)


@pytest.mark.slow
@pytest.mark.parametrize("component", ["closed_tube", "open_tube"])
def test_tube_calibration_recovers_table2(component):
    truth = TABLE2[component]
    measured = simulate(component, *truth)
    params, fit = calibrate_tube(component, measured, maxfev=600, xatol=1e-6, fatol=1e-8)
    for name, value in zip(("E", "sigma_y", "K", "n"), truth):
        assert params[name] == pytest.approx(value, rel=0.02)
    assert fit.fun == pytest.approx(force_error(measured, simulate(component, *params.values())))


def twin_rows(component, params, rows=201):
    """A twin-like record: the default-preset model curve (as the shipped data are made)
    read at ``rows`` equally spaced rows of the model's displacement (like-for-like: the
    fits below use the same preset, so no mesh error mixes into the statistics)."""
    curve = simulate(component, *params, preset="default")
    u = np.linspace(0.0, curve["displacement_mm"].iloc[-1], rows)
    return u, np.interp(u, curve["displacement_mm"], curve["force_N"])


def test_fabric_calibration_recovers_table2():
    """Noise-free rows of the default model: eq. 3 then the simplex on all four give back
    Table 2's fabric to 0.5 % (eq. 3 alone is 0.1-0.2 % off on such a curve)."""
    truth = TABLE2["fabric_tube"]
    u, F = twin_rows("fabric_tube", truth)
    params, fit = calibrate_fabric(pd.DataFrame({"displacement_mm": u, "force_N": F}))
    for name, value in zip(("E", "sigma_y", "K", "n"), truth):
        assert params[name] == pytest.approx(value, rel=0.005), name
    assert len(fit.trace) == fit.nfev


def noisy_fabric_specimens(seed=41, noise_fraction=0.005, samples=3):
    """Three specimens at Table 2's fabric with the twin's load-cell noise (no parameter
    scatter: the truth is then what the fit to their mean should find)."""
    u, F = twin_rows("fabric_tube", TABLE2["fabric_tube"])
    rng = np.random.default_rng(seed)
    return u, F + noise_fraction * F.max() * rng.standard_normal((samples, u.size))


@pytest.mark.slow
def test_fabric_fit_is_efficient_on_noisy_specimens():
    """On three noisy specimens of one truth, the fit through their mean (every row) is within
    2.5 Fisher standard errors of the truth in every parameter, which the paper's route -- E
    and sigma_Y held at eq. 3, the simplex on (K, n) -- is not: its eq. 3 values carry the
    noise of a few rows, and K, n absorb it (bench/RESULTS.md, Identifiability, by hand)."""
    from harnesspipe.calibrate.uncertainty import fit_statistics
    u, R = noisy_fabric_specimens()
    measured = pd.DataFrame({"displacement_mm": u, "force_N": R.mean(axis=0)})
    names = ("E", "sigma_y", "K", "n")

    def on_rows(p):
        c = simulate("fabric_tube", *(p[k] for k in names))
        return np.interp(u, c["displacement_mm"], c["force_N"])

    def z_scores(params):
        se = fit_statistics(on_rows, {k: params[k] for k in names}, list(names), u, R)
        return {k: abs(np.log(params[k] / v)) / se["standard_error"][k]
                for k, v in zip(names, TABLE2["fabric_tube"])}, se
    z, stats = z_scores(calibrate_fabric(measured)[0])
    assert max(z.values()) < 2.5, z
    assert stats["chi_square"]["pass"]
    z_paper, _ = z_scores(calibrate_fabric(measured, simplex_parameters=("K", "n"))[0])
    assert max(z_paper.values()) > 2.5, z_paper


def test_fabric_fit_refuses_an_unknown_parameter_set():
    u, F = twin_rows("fabric_tube", TABLE2["fabric_tube"], rows=51)
    with pytest.raises(ValueError, match="simplex_parameters"):
        calibrate_fabric(pd.DataFrame({"displacement_mm": u, "force_N": F}),
                         simplex_parameters=("sigma_y", "K", "n"))


def test_eq4_reads_every_measured_row():
    """The model (26 nodes) is interpolated onto the measured rows, not the rows onto the
    model: a disturbance of one row between two nodes shows in eq. 4."""
    model = simulate("fabric_tube", *TABLE2["fabric_tube"], preset="default")
    u, F = twin_rows("fabric_tube", TABLE2["fabric_tube"])
    measured = pd.DataFrame({"displacement_mm": u, "force_N": F})
    assert force_error(measured, model) == pytest.approx(0.0, abs=1e-9)
    between = int(np.argmin(np.abs(u - 0.5 * (model["displacement_mm"][3] + model["displacement_mm"][4]))))
    measured.loc[between, "force_N"] += 2.0
    assert force_error(measured, model) == pytest.approx(2.0, rel=1e-9)


def test_simulate_rejects_bad_input():
    with pytest.raises(ValueError, match="component"):
        simulate("steel_tube", 1.0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="invalid material"):
        simulate("closed_tube", -1559.0, 8.6, 25.6, 0.12)
    with pytest.raises(ValueError, match="model"):
        simulate("fabric_tube", 93.5, 10.0, 30.8, 0.6, model="axisymmetric")


# the criterion of issue 29: E, and the flow stress at plastic strains the test reaches
FLOW_STRAINS = (1e-2, 0.1)


def flow(p, eps_p):
    """Eq. 2 flow stress sigma_Y + K eps_p^n."""
    return p["sigma_y"] + p["K"] * eps_p ** p["n"]


@pytest.mark.slow
@pytest.mark.parametrize("component", ["closed_tube", "open_tube", "fabric_tube"])
def test_stage_calibrates_the_shipped_noisy_data(component, tmp_path):
    """The tensile stage (default preset, as the data) on the shipped specimens: every
    measured row is fitted; E within 5 % of truth and the flow stress within 5 % at eps_p =
    1e-2 and 0.1; the model reproduces the specimens' mean to within the noise (chi-square
    passes), the noise read off the rows is the twin's (0.5 % of each specimen's peak, to
    15 %: three sampling standard deviations of the estimate from 3 x 199 rows), and the
    sandwich is on the replicates' two degrees of freedom."""
    import json

    from conftest import REPO

    from harnesspipe import config as cfgmod
    from harnesspipe.data.experimental import read_manifest
    from harnesspipe.data.synthesize import read_truth
    from harnesspipe.stages import data as stage_data
    from harnesspipe.stages.tensile import fit_component
    data, cfg = REPO / "data" / "experimental", cfgmod.load()
    (test_id,) = [t for t, e in read_manifest(data)["tests"].items()
                  if e["kind"] == "tensile" and e["item"] == component]
    stage_data.prepare_test(data, test_id, tmp_path / "ref.h5")
    cov = cfg["coverings"][component]
    settings = {"preset": "default", "nu": cfg["materials"][cov["material"]]["nu"], "pitch": cov.get("pitch"),
                "initial": cfg["tensile"]["initial_guess"][cov["material"]],
                "maxfev": cfg["profiles"]["default"]["simplex_maxfev"], **cfg["tensile"]["simplex"]}
    fit_component(component, tmp_path / "ref.h5", settings, tmp_path / "fit")
    fit = json.loads((tmp_path / "fit" / "fit.json").read_text())
    truth = read_truth(data)[test_id]["parameters"]
    p = fit["parameters"]
    assert p["E"] == pytest.approx(truth["E"], rel=0.05)
    for eps_p in FLOW_STRAINS:
        assert flow(p, eps_p) == pytest.approx(flow(truth, eps_p), rel=0.05), eps_p
    _, F = stage_data.read_prepared(tmp_path / "ref.h5").rows()
    assert fit["rows"] == F.shape[1] == cfg["synthesize"]["rows"]
    assert fit["chi_square"]["pass"] and fit["chi_square"]["dof"] == fit["rows"] - 4
    noise = cfg["synthesize"]["noise_fraction"] * np.sqrt(np.mean(F.max(axis=1) ** 2))
    assert fit["fisher"]["noise_sigma_N"] == pytest.approx(noise, rel=0.15)   # ~3 sd of the estimate
    assert fit["standard_error_dof"] == 2
    assert_intervals_and_replicate_band(fit, tmp_path / "fit" / "curve.csv",
                                        *stage_data.read_prepared(tmp_path / "ref.h5").rows())
