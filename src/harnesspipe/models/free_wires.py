"""The wires alone: the three-point curve of a bundle whose wires do not act together.

A bundle's wires bend about their own axes when nothing couples them (no covering, no tape,
no friction between them).  Each then carries what a single wire carries on the rollers, and
the bundle's force is the sum over its wires,

    F_free(u) = sum_t n_t F_t(u),

with n_t the case's count of wire type t and F_t the three-point curve of one wire of that
type: a beam of radius d_outer / 2 with the homogenised bending law of Table 1 (eq. 2, E,
sigma_Y, K, n) on the test's rollers, computed by the ROM beam (:func:`harnesspipe.rom.
three_point`).  This is the lower bound of Sec. 4.3's physical check (E_eff I of a bundle
exceeds the sum of its wires' E I), taken past the elastic range: the covering, the tape and
the friction between the wires can only add to it.  ``coupling`` = F / F_free measures how
much they add, for a test or a virtual test alike.
"""
from __future__ import annotations

import numpy as np

from harnesspipe import rom


def wire_force(material: dict, three_point: dict, mesh: dict, u) -> np.ndarray:
    """F_t(u) of one wire of ``material`` (materials.wire_typeN) on the rollers of
    ``three_point`` (config three_point), ROM mesh ``mesh`` (a profile's rom)."""
    curve = rom.three_point(E=material["E"], sigma_y=material["sigma_y"], K=material["K"],
                            n=material["n"], radius=0.5 * material["d_outer"], nu=material["nu"],
                            supports="rollers", span=three_point["span"],
                            overhang=three_point["overhang"], deflection=three_point["deflection"],
                            **mesh)
    return np.interp(u, curve["deflection_mm"].to_numpy(), curve["force_N"].to_numpy())


def free_wire_force(config: dict, wires: dict, u, mesh: dict | None = None) -> np.ndarray:
    """F_free(u) of the bundle ``wires`` ({wire_typeN: count}, a case's ``wires``) at the
    run's ROM mesh (``profiles[profile].rom``) unless ``mesh`` is given."""
    if mesh is None:
        mesh = config["profiles"][config["profile"]]["rom"]
    return sum(count * wire_force(config["materials"][name], config["three_point"], mesh, u)
               for name, count in wires.items())


def coupling(F, F_free) -> np.ndarray:
    """F / F_free where F_free > 0 (NaN elsewhere): how many times the wires' own force the
    bundle carries."""
    F, F_free = np.asarray(F, dtype=float), np.asarray(F_free, dtype=float)
    return np.divide(F, F_free, out=np.full(F.shape, np.nan), where=F_free > 0.0)
