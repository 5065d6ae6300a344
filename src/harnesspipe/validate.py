"""Ranges of the physical inputs, one table for every way a value comes in.

``--set`` and ``--interface`` of ``hifi three-point`` (stages/hifi.py), a ``--coverings``
Table 2 CSV, the config's semantic check (config.py), the ROM command line and
``check-data`` ask the same question here: :func:`problem` gives ``None`` for a good value
or what was expected ("expected a friction coefficient in [0, 2]"); the caller names
where the value came from and raises its own error (exit 2).  Plain Python, no model code.
"""
from __future__ import annotations

import math

#: fewest elements of a hi-fi mesh count (config schema: profiles.*.hifi)
MESH_MIN = {"wire_elements": 4, "tube_circ": 6, "tube_axial": 4, "n_rings": 1, "n_sectors": 3}

#: key -> (what it is, lower bound, lower bound allowed, upper bound (allowed) or None, whole number)
RULES = {
    **{k: ("a friction coefficient", 0.0, True, 2.0, False)
       for k in ("mu_rtb", "mu_rtp", "mu_s", "mu_k")},
    "E": ("a modulus [MPa]", 0.0, False, None, False),
    "sigma_y": ("a yield stress [MPa]", 0.0, False, None, False),
    "K": ("a hardening coefficient [MPa]", 0.0, True, None, False),
    "n": ("a hardening exponent", 0.0, False, 1.0, False),
    "delta0": ("a damage-initiation separation [mm]", 0.0, False, None, False),
    "delta_f": ("a failure separation [mm]", 0.0, False, None, False),
    "alpha_d": ("a damage-evolution rate", 0.0, False, None, False),   # eq. 10: 1 - exp(-alpha)
    "E2_over_E1": ("a weft-to-warp modulus ratio", 0.0, False, None, False),
    "d_c": ("a friction decay coefficient", 0.0, False, None, False),
    **{k: ("a cohesive stiffness [N/mm^3]", 0.0, False, None, False)
       for k in ("K_nn", "K_ss", "K_tt")},
    **{k: ("a mesh count", float(low), True, None, True) for k, low in MESH_MIN.items()},
    "t_total": ("a loading time [s]", 0.0, False, None, False),
    "rate_ramp": ("a fraction of the loading time", 0.0, True, 0.5, False),   # past half the run the rate is no longer the test's
    "stop_deflection": ("a deflection [mm]", 0.0, True, None, False),
    "f_m": ("a mass-scaling factor", 1.0, True, None, False),
    "safety": ("a fraction of the stable step", 0.0, False, 1.0, False),
    "mass_damping": ("a damping rate [1/s]", 0.0, True, None, False),
    **{k: ("a penalty factor", 0.0, False, 4.0, False) for k in ("penalty", "penalty_layers")},
    "search_margin": ("a search margin [mm]", 0.0, False, None, False),
    "tie_damping": ("a fraction of critical damping", 0.0, True, 1.0, False),
    "pack_angle": ("a turn of the wire pack [deg]", 0.0, True, 30.0, False),
    "wire_fill": ("a fraction", 0.0, True, 1.0, False),
    "tube_closure": ("a fraction", 0.0, True, 1.0, False),
    "sleeve_closure": ("a fraction", 0.0, True, 1.0, False),
    "end_tape_layers": ("a number of wraps of tape", 1.0, True, 10.0, False),
    "fabric_end_tape_layers": ("a number of wraps of tape", 1.0, True, 10.0, False),
    **{k: ("0 (the wires the end band touches) or 1 (every wire under it)", 0.0, True, 1.0, True)
       for k in ("end_tape_binds", "fabric_end_tape_binds")},
    "tape_tension": ("a wrapping tension [N]", 0.0, True, None, False),
    "pitch": ("a corrugation pitch [mm]", 0.0, False, None, False),
}


def _interval(low: float, closed: bool, high: float | None) -> str:
    if high is None:
        return (">= " if closed else "> ") + f"{low:g}"
    return f"in {'[' if closed else '('}{low:g}, {high:g}]"


def problem(key: str, value) -> str | None:
    """``None`` when ``value`` is valid for ``key`` (the key's last dotted part names the
    rule, so ``closed_tube.E`` is a modulus), else "expected ...".  Keys without a rule
    need only a finite number."""
    rule = RULES.get(key.rpartition(".")[2])
    try:
        v = float(value)
    except (TypeError, ValueError):
        return f"expected {rule[0] if rule else 'a value'}, a number"
    if rule is None:
        return None if math.isfinite(v) else "expected a finite number"
    what, low, closed, high, whole = rule
    if whole:
        what += ", a whole number"
    bad = (not math.isfinite(v) or v < low or (v == low and not closed)
           or (high is not None and v > high) or (whole and not v.is_integer()))
    return f"expected {what} {_interval(low, closed, high)}" if bad else None


def interface_problem(values: dict) -> str | None:
    """The relation of the cohesive law (eqs. 7-10): ``delta_f > delta0``."""
    d0, df = values.get("delta0"), values.get("delta_f")
    if d0 is not None and df is not None and not float(df) > float(d0):
        return f"delta_f={float(df):g}: expected a failure separation > delta0 ({float(d0):g})"
    return None


def deflection_problem(deflection: float, span: float) -> str | None:
    """A three-point stroke must stay below half the span (beyond it the loading pin pushes
    the specimen past the supports' line at 45 degrees: not a bending test)."""
    if not deflection < span / 2.0:
        return f"expected a deflection below half the {span:g} mm span (< {span / 2.0:g} mm)"
    return None


def stop_problem(stop: float, stroke: float, checked_from: float) -> str | None:
    """A run stopped early must still reach the part of the stroke where its quasi-static
    check starts (``checked_from`` of the stroke, KE/IE past it): 0 runs the whole stroke."""
    if 0.0 < stop < checked_from * stroke:
        return (f"expected 0 (the whole stroke) or a deflection of at least "
                f"{checked_from * stroke:g} mm ({checked_from:.0%} of the {stroke:g} mm stroke, "
                "where the quasi-static KE/IE check starts)")
    return None


def tape_tension_problem(tension: float, tape: dict) -> str | None:
    """A tape is wrapped below its yield force ``sigma_y w t`` (a prestress within the
    elastic range, :func:`harnesspipe.fe.elements.shell_bt.prestress`)."""
    limit = tape["sigma_y"] * tape["width"] * tape["thickness"]
    if not tension < limit:
        return f"expected a wrapping tension below the tape's yield force sigma_y w t = {limit:.3g} N"
    return None


def force_sign_problem(force, column: str = "force_N") -> str | None:
    """A test's force resists the imposed displacement and is positive; a curve whose force
    is mostly negative has the load cell's sign flipped."""
    negative = sum(1 for f in force if f < 0.0)
    if negative > 0.5 * len(force):
        return (f"{column}: {100.0 * negative / len(force):.0f} % of the rows are negative: "
                "expected a positive force resisting the displacement (load cell sign flipped?)")
    return None


def check(values: dict, prefix: str = "") -> list[str]:
    """Every problem of ``values`` as ``"<prefix><key>=<value>: expected ..."``, then the
    cohesive relation; ``prefix`` names the source (``"--set "``, ``"cfg.yaml: interfaces."``)."""
    out = [f"{prefix}{k}={v}: {msg}" for k, v in values.items() if (msg := problem(k, v))]
    relation = None if out else interface_problem(values)
    return out + ([prefix + relation] if relation else [])
