"""The wires alone (models/free_wires.py): the lower bound of a bundle's three-point curve."""
import math

import numpy as np
import pytest

from harnesspipe.config import load
from harnesspipe.models.free_wires import coupling, free_wire_force, wire_force


@pytest.fixture(scope="module")
def cfg():
    return load(overrides={"profile": "default"})


def test_elastic_slope_is_the_sum_of_the_wires_48_E_I_over_L_cubed(cfg):
    """Small deflection: F = u sum_t n_t 48 E_t I_t / L^3, I_t = pi (d_outer/2)^4 / 4."""
    L = cfg["three_point"]["span"]
    case = "cwb10t1_9t2_fabric"
    k = sum(n * 48.0 * cfg["materials"][t]["E"] * math.pi * (0.5 * cfg["materials"][t]["d_outer"])**4
            / 4.0 / L**3 for t, n in cfg["cases"][case]["wires"].items())
    u = np.array([0.2, 0.5])
    assert free_wire_force(cfg, cfg["cases"][case]["wires"], u) / u == pytest.approx([k, k], rel=1e-3)


def test_a_perfectly_plastic_wire_reaches_the_limit_load_4_Mp_over_L(cfg):
    """K -> 0: the midspan moment saturates at M_p = 4/3 r^3 sigma_Y, F = 4 M_p / L (within the
    fibre section's 3 % before large rotations set in)."""
    wire = {**cfg["materials"]["wire_type2"], "K": 1e-6}
    r, L = 0.5 * wire["d_outer"], cfg["three_point"]["span"]
    F_limit = 4.0 * (4.0 / 3.0 * r**3 * wire["sigma_y"]) / L
    F = wire_force(wire, cfg["three_point"], cfg["profiles"]["default"]["rom"], np.array([6.0, 10.0]))
    assert F / F_limit == pytest.approx([1.0, 1.0], abs=0.03)


def test_coupling_is_force_over_free_force_and_undefined_at_zero():
    ratio = coupling([0.0, 3.0, 6.0], [0.0, 1.5, 2.0])
    assert np.isnan(ratio[0]) and ratio[1:] == pytest.approx([2.0, 3.0])
