"""LS-DYNA keyword cards of an effective beam: MAT_024, its curve, a circular beam section.

Units mm, t, s, N, MPa (stated in the header comment).  Fixed format: every data card
has 8 fields of 10 characters, the points of *DEFINE_CURVE 2 fields of 20 (the manual's
formats).  Card order: *KEYWORD, *MAT_PIECEWISE_LINEAR_PLASTICITY (4 cards),
*DEFINE_CURVE (1 card, then the points), *SECTION_BEAM (2 cards), *PART (heading, 1 card),
*END.

* MAT_024 card 1 MID, RO, E, PR, SIGY, ETAN, FAIL, TDEL: SIGY = sigma_Y (the curve's first
  point, which governs when LCSS is set), ETAN 0 (unused with LCSS), FAIL 1e21 (no failure,
  the manual's default); card 2 C, P, LCSS, LCSR, VP: no rate effect (C = P = 0), LCSS the
  curve; cards 3-4 (EPS1-8, ES1-8) zero, unused with LCSS.
* DEFINE_CURVE LCID, SIDR, SFA, SFO, OFFA, OFFO, DATTYP, then (effective plastic strain,
  yield stress) pairs: eq. 2 tabulated as for CalculiX (:mod:`harnesspipe.cards.flow_curve`).
* SECTION_BEAM card 1 SECID, ELFORM, SHRF, QR/IRID, CST, SCOOR, NSM: ELFORM 1 (Hughes-Liu
  with cross-section integration), SHRF 1 (the manual's default; shear deformation is 1-3 %
  of the deflection at span / r_o = 18), QR 3 (3 x 3 Gauss: the elastoplastic section, as
  CalculiX's C3D20 expansion), CST 1 (tubular, i.e. circular); card 2 TS1, TS2, TT1, TT2:
  for CST 1 the outer diameters at nodes n1, n2 (2 r_o) and the inner diameters (0: a
  solid section).  Not run in LS-DYNA here (no licence); the keyword test checks the
  format, the order and the curve.

IDs: MID = SECID = PID = ``part_id`` and LCID = ``CURVE_ID_OFFSET`` + ``part_id``, so cards
of several cases load into one model side by side.
"""
from __future__ import annotations

import numpy as np

from harnesspipe.cards.flow_curve import STRAIN_RANGE, TOLERANCE, tabulate
from harnesspipe.cards.properties import BeamProperties

FIELD = 10                 # characters per field of a data card
CURVE_FIELD = 20           # characters per field of a *DEFINE_CURVE point
CURVE_ID_OFFSET = 1000


def field(value, width: int = FIELD) -> str:
    """``value`` right-aligned in ``width`` characters with at least one leading blank:
    an integer as it is, a real with as many significant digits (up to 12) as fit, always
    with a decimal point or exponent."""
    if isinstance(value, (int, np.integer)):
        text = str(value)
    else:
        for digits in range(min(width - 2, 12), 0, -1):
            text = f"{float(value):.{digits}g}"
            if not any(c in text for c in ".en"):      # n: inf, nan
                text += ".0"
            if len(text) < width:
                break
    if len(text) >= width:
        raise ValueError(f"{value!r} does not fit a {width}-character field")
    return text.rjust(width)


def card(*values, width: int = FIELD) -> str:
    return "".join(field(v, width) for v in values)


def comment(*names: str, width: int = FIELD) -> str:
    """A '$#' line naming the fields of the next card, aligned with them."""
    text = "".join(n.rjust(width) for n in names)
    return "$#" + text[2:]


def material_k(p: BeamProperties, part_id: int = 1) -> str:
    eps, sigma = tabulate(p.sigma_y, p.K, p.n)
    lcid = CURVE_ID_OFFSET + part_id
    lines = [
        "*KEYWORD",
        f"$ Effective beam of {p.case} (harnesspipe cards).",
        "$ Units: mm, t (tonne), s, N, MPa; density t/mm^3.",
        "$ README.md beside this file gives every number's source.",
        f"$ E {p.E:g} MPa, nu {p.nu:g}, rho {p.rho:.6g} t/mm^3, r_o {p.r_o:g} mm,",
        f"$ eq. 2: sigma = {p.sigma_y:g} + {p.K:g} eps_p^{p.n:g} MPa.",
        "*MAT_PIECEWISE_LINEAR_PLASTICITY",
        comment("mid", "ro", "e", "pr", "sigy", "etan", "fail", "tdel"),
        card(part_id, p.rho, p.E, p.nu, p.sigma_y, 0.0, 1.0e21, 0.0),
        comment("c", "p", "lcss", "lcsr", "vp"),
        card(0.0, 0.0, lcid, 0, 0.0),
        comment(*(f"eps{i}" for i in range(1, 9))),
        card(*([0.0] * 8)),
        comment(*(f"es{i}" for i in range(1, 9))),
        card(*([0.0] * 8)),
        "*DEFINE_CURVE",
        f"$ eq. 2 at {eps.size} plastic strains: 0, then geometric from {STRAIN_RANGE[0]:g}",
        f"$ to {STRAIN_RANGE[1]:g}, within {100 * TOLERANCE:g} % of eq. 2 there.",
        comment("lcid", "sidr", "sfa", "sfo", "offa", "offo", "dattyp"),
        card(lcid, 0, 1.0, 1.0, 0.0, 0.0, 0),
        comment("a1 (eps_p)", "o1 (sigma)", width=CURVE_FIELD),
        *(card(e, s, width=CURVE_FIELD) for e, s in zip(eps, sigma)),
        "*SECTION_BEAM",
        "$ Hughes-Liu (ELFORM 1), 3 x 3 Gauss (QR 3), circular (CST 1), solid (TT 0).",
        comment("secid", "elform", "shrf", "qr/irid", "cst", "scoor", "nsm"),
        card(part_id, 1, 1.0, 3.0, 1.0, 0.0, 0.0),
        comment("ts1", "ts2", "tt1", "tt2", "nsloc", "ntloc"),
        card(2.0 * p.r_o, 2.0 * p.r_o, 0.0, 0.0, 0.0, 0.0),
        "*PART",
        comment("heading", width=10),
        p.case,
        comment("pid", "secid", "mid", "eosid", "hgid", "grav", "adpopt", "tmid"),
        card(part_id, part_id, part_id, 0, 0, 0, 0, 0),
        "*END",
    ]
    return "\n".join(lines) + "\n"
