"""CalculiX and Abaqus keyword decks: the material card and a runnable three-point test.

Both solvers read the same keywords.  They differ in two places, and the writer follows
each one's manual:

* ``*BEAM SECTION, SECTION=CIRC``: CalculiX takes the lengths of the ellipse's principal
  axes, the diameter 2 r_o for a circle ("for a circular section it is the diameter",
  ccx manual, B32 element); Abaqus takes the radius r_o.
* Supports: CalculiX expands a B32 beam into 20-node bricks (C3D20, 3 x 3 Gauss points
  over the section, which resolves its elastoplastic bending); translations fixed on a
  beam node make a hinge, and the expanded end face holds the twist.  A fixed rotation
  on a beam node generates a mean-rotation constraint that clamps the section (measured:
  the pinned beam 41 % stiffer), so the CalculiX deck fixes translations only.  An Abaqus
  B32 is a true beam whose twist about its axis is a rigid-body mode: its pinned end
  also fixes rotation 4 (about the axis, global x), which leaves bending free.

The three-point deck (Sec. 2.2 at ideal supports, as ``harnesspipe rom three-point
--supports pinned``): the span along x, B32 elements, one end pinned, the other on a
roller free to slide along x, the mid-span node (set LOAD) pushed by the deflection
along -y under *STATIC with NLGEOM; *NODE PRINT of U and RF of LOAD at every increment.
Eq. 2 holds a jump of the tangent modulus at first yield; CalculiX's default Newton
control gives up there (a residual check after 4 iterations), so *CONTROLS allows 8
iterations before that check and 10 before the logarithmic convergence check, every
other parameter at its default.
"""
from __future__ import annotations

import numpy as np

from harnesspipe.cards.flow_curve import STRAIN_RANGE, TOLERANCE, tabulate
from harnesspipe.cards.properties import BeamProperties

SOLVERS = {"calculix": "CalculiX (ccx)", "abaqus": "Abaqus/Standard"}
ELEMENT = "B32"
N_ELEMENTS = 20            # B32 elements along the span (41 nodes): CalculiX within 1.3 % of the ROM
CONTROLS = "8, 10, 9, 16, 10, 4, 12, 5, 6, 3"   # I_0, I_R raised; the rest the defaults
STATIC = "0.01, 1.0, 1e-6, 0.01"                # first, total, smallest, largest increment


def _fmt(v: float) -> str:
    return f"{v:.8g}"


def units_header(fmt: str) -> list[str]:
    return [f"** Solver: {SOLVERS[fmt]}.  Units: mm, t (tonne), s, N, MPa; density in t/mm^3.",
            "** Written by `harnesspipe cards`; README.md beside this file gives every "
            "number's source."]


def material_inp(p: BeamProperties, fmt: str) -> str:
    """*MATERIAL (elastic, eq. 2 plastic table, density) and the circular *BEAM SECTION of
    element set ``p.label``."""
    eps, sigma = tabulate(p.sigma_y, p.K, p.n)
    dimension = f"{_fmt(2.0 * p.r_o)}, {_fmt(2.0 * p.r_o)}" if fmt == "calculix" else _fmt(p.r_o)
    meaning = ("principal axes = diameter 2 r_o" if fmt == "calculix" else "radius r_o")
    lines = [f"** Effective beam of {p.case}: E {p.E:g} MPa, nu {p.nu:g}, rho {p.rho:.6g} t/mm^3, "
             f"eq. 2 sigma = {p.sigma_y:g} + {p.K:g} eps_p^{p.n:g} MPa, r_o {p.r_o:g} mm.",
             *units_header(fmt),
             f"** *PLASTIC: eq. 2 at {eps.size} plastic strains, 0 then geometric from "
             f"{STRAIN_RANGE[0]:g} to {STRAIN_RANGE[1]:g}; linear interpolation stays within "
             f"{100 * TOLERANCE:g} % of eq. 2 there (below {STRAIN_RANGE[0]:g}: the chord from "
             "sigma_Y).",
             f"** *BEAM SECTION, SECTION=CIRC: {meaning}; the element set {p.label} must exist.",
             f"*MATERIAL, NAME={p.label}",
             "*ELASTIC", f"{_fmt(p.E)}, {_fmt(p.nu)}",
             "*PLASTIC", *(f"{_fmt(s)}, {_fmt(e)}" for e, s in zip(eps, sigma)),
             "*DENSITY", _fmt(p.rho),
             f"*BEAM SECTION, ELSET={p.label}, MATERIAL={p.label}, SECTION=CIRC",
             dimension, "0.0, 0.0, -1.0"]
    return "\n".join(lines) + "\n"


def three_point_inp(p: BeamProperties, fmt: str, span: float, deflection: float,
                    n_elements: int = N_ELEMENTS) -> str:
    """The runnable three-point deck of :mod:`this module <harnesspipe.cards.keyword>`; it
    includes ``material.inp`` from its own folder."""
    if n_elements < 2 or n_elements % 2:
        raise ValueError(f"n_elements {n_elements}: need an even number >= 2 (a node at mid-span)")
    nodes = np.linspace(0.0, span, 2 * n_elements + 1)
    last, mid = nodes.size, n_elements + 1
    pinned = ["SUPPORT_PIN, 1, 3"] + (["SUPPORT_PIN, 4, 4"] if fmt == "abaqus" else [])
    lines = [f"** Three-point bending of {p.case}: span {span:g} mm, pinned supports (node 1 "
             f"pinned, node {last} slides along x), {deflection:g} mm at mid-span (node {mid}).",
             *units_header(fmt),
             "*HEADING", f"{p.case}: three-point bending at ideal supports (harnesspipe cards)",
             "*NODE, NSET=NALL",
             *(f"{i}, {_fmt(x)}, 0.0, 0.0" for i, x in enumerate(nodes, start=1)),
             f"*ELEMENT, TYPE={ELEMENT}, ELSET={p.label}",
             *(f"{e}, {2 * e - 1}, {2 * e}, {2 * e + 1}" for e in range(1, n_elements + 1)),
             "*NSET, NSET=SUPPORT_PIN", "1", "*NSET, NSET=SUPPORT_SLIDE", str(last),
             "*NSET, NSET=LOAD", str(mid),
             "*INCLUDE, INPUT=material.inp",
             "*BOUNDARY", *pinned, "SUPPORT_SLIDE, 2, 3",
             "*STEP, NLGEOM=YES, INC=1000", "*STATIC", STATIC,
             "*CONTROLS, PARAMETERS=TIME INCREMENTATION", CONTROLS,
             "*BOUNDARY", f"LOAD, 2, 2, {_fmt(-deflection)}",
             "*NODE PRINT, NSET=LOAD, FREQUENCY=1", "U, RF",
             "*END STEP"]
    return "\n".join(lines) + "\n"
