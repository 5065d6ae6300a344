"""Generators of the synthetic twin, one per test kind (DESIGN sec. 4).

Importing this module registers them with :mod:`harnesspipe.data.synthesize`.

three_point
    The CWB bending tests of Sec. 2.2: the reduced-order beam with roller supports
    at the paper's Table 3 properties (the paper reports ROM = hi-fi = test).
    The validation case ``cwb19_t1_open_coarse`` has no Table 3 row; its truth is
    an assumption: the coarse-taped type-2 set with E, sigma_Y and K scaled by the
    ratio of the wires' summed bending stiffness, sum(E I) type 1 / type 2 (Table 1),
    n unchanged.
"""
from __future__ import annotations

import math

import numpy as np

from harnesspipe.data.synthesize import Curve, TestSpec, register

MARKERS = 9                           # reflective markers along the sample (Sec. 2.2)
MARKER_DEFLECTIONS = (10.0, 20.0, 30.0)  # crosshead positions of the recorded frames [mm]


def wire_bending_stiffness(wire: dict) -> float:
    """E I of one wire with its outer diameter (Table 1 properties are homogenised)."""
    return wire["E"] * math.pi * wire["d_outer"] ** 4 / 64.0


def three_point_truth(cfg: dict) -> dict[str, dict]:
    truth = {case: dict(p) for case, p in cfg["paper"]["table3"].items() if case in cfg["cases"]}
    if "cwb19_t1_open_coarse" in cfg["cases"]:
        m = cfg["materials"]
        ratio = wire_bending_stiffness(m["wire_type1"]) / wire_bending_stiffness(m["wire_type2"])
        base = cfg["paper"]["table3"]["cwb19_t2_open_coarse"]
        truth["cwb19_t1_open_coarse"] = {"E": base["E"] * ratio, "sigma_y": base["sigma_y"] * ratio,
                                         "K": base["K"] * ratio, "n": base["n"]}
    return truth


def _three_point_simulator(cfg: dict, case: str, profile: str = "default"):
    from harnesspipe import rom
    tp = cfg["three_point"]
    r_o = cfg["cases"][case]["r_o"]
    mesh = cfg["profiles"][profile]["rom"]

    def simulate(p: dict) -> Curve:
        curve, shapes = rom.three_point(E=p["E"], sigma_y=p["sigma_y"], K=p["K"], n=p["n"],
                                        radius=r_o, supports="rollers", span=tp["span"],
                                        overhang=tp["overhang"], deflection=tp["deflection"],
                                        return_shapes=True, shape_at=MARKER_DEFLECTIONS, **mesh)
        markers = marker_rows(shapes, tp["sample_length"])
        return Curve(curve["deflection_mm"].to_numpy(), curve["force_N"].to_numpy(), markers)
    return simulate


def marker_rows(shapes: dict, sample_length: float) -> np.ndarray:
    """Marker rows (deflection, index, x, y) of the bent shapes.

    Markers sit evenly along the sample (5 % to 95 % of its length); each follows
    the beam's centre line, interpolated by the arc length of the deformed nodes.
    """
    s_marker = np.linspace(0.05, 0.95, MARKERS) * sample_length
    rows = []
    for d in MARKER_DEFLECTIONS:
        x, y = shapes[d][:, 0], shapes[d][:, 1]
        s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
        s *= sample_length / s[-1]
        for k, sm in enumerate(s_marker):
            rows.append((d, k, np.interp(sm, s, x), np.interp(sm, s, y)))
    return np.array(rows)


@register("three_point")
def three_point(cfg: dict, profile: str = "default") -> list[TestSpec]:
    """The CWB three-point tests (Sec. 2.2) from the ROM at Table 3, on the ROM mesh of the
    config's ``profile`` (the shipped data: ``default``; a like-for-like study with a quick
    fit: ``quick``)."""
    tp = cfg["three_point"]
    protocol = {"stroke_mm": tp["deflection"], "rate_mm_s": tp["rate"], "load_cell_N": tp["load_cell_N"]}
    return [TestSpec(test_id=f"bend_{case}", kind="three_point", item=case, protocol=protocol,
                     truth={k: round(float(v), 6) for k, v in truth.items()},
                     simulate=_three_point_simulator(cfg, case, profile), folder="three_point",
                     extra_truth={"model": f"ROM, roller supports, {profile} profile"})
            for case, truth in three_point_truth(cfg).items()]


def _tensile_simulator(cfg: dict, component: str, preset: str = "default"):
    from harnesspipe.models import tensile
    cov = cfg["coverings"][component]
    nu = cfg["materials"][cov["material"]]["nu"]
    scale = tensile.crosshead_scale(component)
    extra = ({"pitch": cov["pitch"]} if component != "fabric_tube"
             else {"elongation": cfg["tensile"]["fabric"]["extension"]})

    def simulate(p: dict) -> Curve:
        curve = tensile.simulate(component, p["E"], p["sigma_y"], p["K"], p["n"], nu,
                                 preset=preset, **extra)
        return Curve(scale * curve["displacement_mm"].to_numpy(), curve["force_N"].to_numpy())
    return simulate


@register("tensile")
def tensile_tests(cfg: dict, preset: str = "default") -> list[TestSpec]:
    """The coverings' tensile tests (Sec. 2.1) from the tensile models at Table 2, on the
    ``preset`` mesh (the shipped data: ``default``; a like-for-like study with a quick fit:
    ``quick``)."""
    specs = []
    for component, truth in cfg["paper"]["table2"].items():
        t = cfg["tensile"]["fabric" if component == "fabric_tube" else "tube"]
        protocol = {"stroke_mm": t["extension"], "rate_mm_s": t["rate"], "load_cell_N": t["load_cell_N"]}
        specs.append(TestSpec(test_id=f"tensile_{component}", kind="tensile", item=component,
                              protocol=protocol, truth=dict(truth),
                              simulate=_tensile_simulator(cfg, component, preset), folder="tensile",
                              extra_truth={"model": "tensile model (axisymmetric tube cell / fabric "
                                                    f"sheet), {preset} preset"}))
    return specs
