"""Equivalent smooth shell of the ridged tube (models/tube_equivalent.py): the equivalent and
the resolved (ridged) wall agree in tension (elastic and into the plastic range) and in ring
bending on a short segment."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import yaml
from scipy.spatial import cKDTree

from harnesspipe.models.tensile import (TubeGeometry, resolution, simulate_axisymmetric_tube,
                                        simulate_shell_tube)
from harnesspipe.models.tube_equivalent import (axial_stiffness_fe, equivalent_shell, from_config,
                                                ridged_section, ring_ovalisation,
                                                strip_axial_stiffness, uniaxial_stress)
from conftest import REPO

CLOSED = dict(E=1559.0, sigma_y=8.6, K=25.6, n=0.12)    # Table 2
OPEN = dict(E=698.0, sigma_y=8.8, K=23.1, n=0.83)


@pytest.fixture(scope="module")
def config():
    return yaml.safe_load((REPO / "config" / "config.yaml").read_text())


def test_both_conditions_matched():
    eq = equivalent_shell(**CLOSED)
    sec = ridged_section()
    assert eq["E"] * eq["t"] == pytest.approx(eq["axial_stiffness"], rel=1e-12)
    assert eq["E"] * eq["t"] ** 3 / 12.0 == pytest.approx(CLOSED["E"] * sec["I"], rel=1e-12)
    assert eq["radius"] == pytest.approx(0.25 * (10.7 + 14.1))
    assert eq["t_contact"] == pytest.approx(1.7)
    assert eq["nu"] == 0.0
    # the corrugated wall yields overall far later than its material
    assert eq["yield_strain"] > 3.0 * CLOSED["sigma_y"] / CLOSED["E"]
    # the corrugation: axially ~3 % of a smooth wall, hoop bending ~50 x t^3/12
    assert 0.02 < eq["axial_stiffness"] / (CLOSED["E"] * 0.27) < 0.04
    assert 40 < sec["I"] / (0.27 ** 3 / 12) < 70


def test_tension_equivalent_vs_ridged_axisymmetric():
    """Ridged axisymmetric shell (finer mesh and a different strain than the homogenisation)
    vs. the smooth equivalent's closed form F = 2 pi R t_eq E_eq eps, within 3 %."""
    for mat in (CLOSED, OPEN):
        eq = equivalent_shell(**mat)
        eps = 5.0e-5
        g = replace(TubeGeometry(), extension=eps * TubeGeometry().gauge)
        df = simulate_axisymmetric_tube(mat["E"], 1e3 * mat["E"], 0.0, 1.0, 0.42, geometry=g,
                                        res=resolution("quick", meridian=96, n_steps=2))
        F_ridged = float(df["force_N"].iloc[-1])
        F_eq = 2.0 * np.pi * eq["radius"] * eq["t"] * eq["E"] * eps
        assert F_eq == pytest.approx(F_ridged, rel=0.03)


@pytest.mark.parametrize("mat", [CLOSED, OPEN], ids=["closed", "open"])
def test_membrane_law_follows_the_ridged_cell_into_the_plastic_range(mat):
    """Uniform axial strain to +-12 %: the equivalent's membrane force t_eq sigma(eps) against
    the ridged axisymmetric cell run independently (finer meridian, other load steps than the
    fit): within 3 % of the mean of tension and compression from 1 % strain, and each within
    the cell's own tension-compression asymmetry (an isotropic law is symmetric)."""
    eq = equivalent_shell(**mat)
    eps_max, steps = 0.12, 20
    R = eq["radius"]
    N = {}
    for sign in (1, -1):
        g = replace(TubeGeometry(), extension=sign * eps_max * TubeGeometry().gauge)
        df = simulate_axisymmetric_tube(mat["E"], mat["sigma_y"], mat["K"], mat["n"], 0.42,
                                        geometry=g, res=resolution("quick", meridian=48,
                                                                   n_steps=steps))
        N[sign] = np.abs(df["force_N"].to_numpy()) / (2.0 * np.pi * R)
    eps = np.linspace(0.0, eps_max, steps + 1)
    N_eq = eq["t"] * uniaxial_stress(eps, eq["E"], eq["sigma_y"], eq["K"], eq["n"])
    mean = 0.5 * (N[1] + N[-1])
    late = eps >= 0.01
    assert np.max(np.abs(N_eq[late] / mean[late] - 1.0)) < 0.03
    half_gap = 0.5 * np.abs(N[1][late] - N[-1][late]) / mean[late]
    assert np.all(np.abs(N_eq[late] / mean[late] - 1.0) <= half_gap + 0.03)
    assert N[1][-1] > 1.2 * N[-1][-1]                       # tension stiffer: ridges straighten
    assert eq["membrane_fit_error"] < 0.03


@pytest.mark.parametrize("mat", [CLOSED, OPEN], ids=["closed", "open"])
def test_hoop_yield_moment_of_the_cell_fitted_law(mat):
    """First hoop yield moment sigma_y t_eq^2/6 of the equivalent against the ridged wall
    section's sigma_y I / (A + t/2): the material yield strain scaled by E_eq/E put it 7-10x
    too low; the cell-fitted law brings it within a factor 3 (closed 0.75x, open 0.39x of the
    ridged section: one isotropic law cannot match both the axial membrane and the hoop
    bending yield -- docs/theory/tube_equivalent.md)."""
    eq = equivalent_shell(**mat)
    scaled = mat["sigma_y"] * eq["E"] / mat["E"] * eq["t"] ** 2 / 6.0
    ratio = eq["hoop_yield_moment"] / eq["hoop_yield_moment_ridged"]
    assert 1.0 / 3.0 < ratio < 1.2
    assert eq["hoop_yield_moment"] > 2.5 * scaled


def test_ring_bending_equivalent_vs_ridged_section():
    """Ovalisation under a diametral line load: equivalent E_eq t_eq^3/12 vs. the ridged
    wall's E I, I integrated independently on a point grid over the wall region."""
    g = TubeGeometry()
    eq = equivalent_shell(**CLOSED)
    z = np.linspace(0.0, g.pitch, 20001)
    tree = cKDTree(np.column_stack([z, g.radius(z)]))
    R = eq["radius"]
    h = 0.004
    zz, rr = np.meshgrid(np.arange(0.5 * h, g.pitch, h), np.arange(R - 1.0, R + 1.0, h), indexing="ij")
    dist, _ = tree.query(np.column_stack([zz.ravel(), rr.ravel()]))
    wall = dist <= 0.5 * g.wall
    I_grid = np.sum((rr.ravel()[wall] - R) ** 2) * h * h / g.pitch
    EI_ridged = CLOSED["E"] * I_grid
    EI_eq = eq["E"] * eq["t"] ** 3 / 12.0
    P = 0.1                                                # N/mm
    d_ridged = ring_ovalisation(P, R, EI_ridged)
    d_eq = ring_ovalisation(P, R, EI_eq)
    assert d_eq == pytest.approx(d_ridged, rel=0.03)
    assert ridged_section()["area"] == pytest.approx(wall.sum() * h * h / g.pitch, rel=0.02)


def test_flat_wall_limit_recovers_the_material():
    """No corrugation (d_o - d_i = 2 t): the equivalent is the wall itself."""
    g = TubeGeometry(d_inner=12.4 - 0.27, d_outer=12.4 + 0.27)
    eq = equivalent_shell(1000.0, 10.0, 20.0, 0.5, g)
    assert eq["t"] == pytest.approx(0.27, rel=5e-3)
    assert eq["E"] == pytest.approx(1000.0, rel=5e-3)


def test_closed_form_strip_is_softer_but_close():
    eq = equivalent_shell(**CLOSED)
    k_strip = strip_axial_stiffness(CLOSED["E"], 0.42)
    assert k_strip == pytest.approx(eq["strip_axial_stiffness"])
    assert 0.7 < k_strip / eq["axial_stiffness"] < 1.0      # no hoop restraint -> softer
    eq_s = equivalent_shell(**CLOSED, method="strip")
    assert eq_s["t"] > eq["t"]


def test_slit_ring_with_free_lips_stretches_as_the_free_strip():
    """A slit tube whose lips pass each other has no hoop force to hold its ridges from
    flattening: its 3D cell's elastic axial stiffness is the free corrugated strip's closed
    form (Castigliano, no hoop restraint), well below the closed cell's; with its lips
    bearing on each other (the tensile stage's slit cell) it lies between the two."""
    E, nu = 1000.0, 0.42
    k_closed = axial_stiffness_fe(E, nu)
    k_slit = axial_stiffness_fe(E, nu, slit=True)
    k_strip = strip_axial_stiffness(E, nu)
    assert k_slit == pytest.approx(k_strip, rel=0.03)
    assert k_slit / k_closed < 0.85
    strain = 1e-4
    g = replace(TubeGeometry(), extension=strain * TubeGeometry().gauge)
    df = simulate_shell_tube(E, 1e3 * E, 0.0, 1.0, nu, cut=True, geometry=g,
                             res=resolution("default", n_steps=1))
    k_lips = float(df["force_N"].iloc[-1]) / (2.0 * np.pi * ridged_section()["radius"] * strain)
    assert k_slit * 1.05 < k_lips < k_closed


def test_mass_per_area_and_config(config):
    eq = from_config(config, "closed_tube", CLOSED)
    sec = ridged_section()
    assert eq["rho"] * eq["t"] == pytest.approx(0.9e-9 * sec["area"])
    eq_o = from_config(config, "open_tube", OPEN)
    assert eq_o["t"] == pytest.approx(eq["t"])              # same geometry
    assert eq_o["E"] / eq["E"] == pytest.approx(OPEN["E"] / CLOSED["E"])
    with pytest.raises(ValueError):
        from_config(config, "fabric_tube", CLOSED)
    with pytest.raises(ValueError):
        equivalent_shell(-1.0, 1.0, 1.0, 0.5)
