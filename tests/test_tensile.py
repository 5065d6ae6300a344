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
    E, sigma_y, K, n = truth
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


def test_fabric_calibration_recovers_table2():
    truth = TABLE2["fabric_tube"]
    measured = simulate("fabric_tube", *truth, n_steps=100)
    params, fit = calibrate_fabric(measured)
    for name, value in zip(("E", "sigma_y", "K", "n"), truth):
        assert params[name] == pytest.approx(value, rel=0.02)
    assert len(fit.trace) == fit.nfev


def test_simulate_rejects_bad_input():
    with pytest.raises(ValueError, match="component"):
        simulate("steel_tube", 1.0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="invalid material"):
        simulate("closed_tube", -1559.0, 8.6, 25.6, 0.12)
    with pytest.raises(ValueError, match="model"):
        simulate("fabric_tube", 93.5, 10.0, 30.8, 0.6, model="axisymmetric")


# what the shipped noisy data determine to 5 %: bench/RESULTS.md "Identifiability (Cramer-Rao
# bound)" -- the load-cell noise alone leaves sigma_Y, K, n of the closed tube uncertain by
# 20-63 % and K, n of the fabric by 5-7 %, whatever the estimator
WITHIN_5_PERCENT = {"closed_tube": ("E",), "open_tube": ("E", "sigma_y", "K", "n"),
                    "fabric_tube": ("E", "sigma_y")}


@pytest.mark.slow
@pytest.mark.parametrize("component", sorted(WITHIN_5_PERCENT))
def test_stage_calibrates_the_shipped_noisy_data(component, tmp_path):
    """The tensile stage (default preset) on the shipped means: what the data determine is
    within 5 % of truth, with a standard error below 10 %; the truth of every parameter with a
    standard error lies in its 95 % interval (Student t on the replicates' degrees of freedom;
    one the data do not determine has none, nor has a fit on a bound)."""
    import json
    import math

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
    from scipy.stats import t as student_t
    p, se = fit["parameters"], fit["standard_error"]
    on_bound = min(p[k] / truth[k] for k in p) < 1e-3
    for name in WITHIN_5_PERCENT[component]:
        assert p[name] == pytest.approx(truth[name], rel=0.05), name
        assert on_bound or se[name] < 0.1, name        # and the data say so
    if on_bound:       # closed tube: sigma_Y driven to ~0 (n = 0.12 hides the yield): no errors
        assert all(v is None for v in se.values())
    t95 = student_t.ppf(0.975, fit["standard_error_dof"])     # 4.30 for three replicates
    for name, s in se.items():
        if s is not None:
            assert abs(math.log(p[name] / truth[name])) < t95 * s, name
