"""Words for the report: physical names of cases and components, labels of solver statistics.

Names are derived from the config's definitions (``cases``, ``hifi.extra_cases``,
``coverings``), so a case a user adds is named the same way without touching this module.
"""
from __future__ import annotations

import re

COVERINGS = {"closed_tube": "closed tube", "open_tube": "open tube", "fabric_tube": "fabric tube",
             "none": "no tube"}
TAPINGS = {"none": "", "halflap": "half-lap tape", "coarse": "coarse tape", "ends": "taped ends"}
COMPONENT_MATERIAL = {"polypropylene": "ridged polypropylene", "polyester": "woven polyester"}
BRANCH_LOAD_CASES = {"inplane": "Y harness, in-plane pull", "outofplane": "Y harness, out-of-plane pull"}


def _wires(wires: dict) -> str:
    """'19 x type 2' or '10 x type 1 + 9 x type 2' from {wire_type1: 10, wire_type2: 9}."""
    return " + ".join(f"{n} x type {re.sub(r'^wire_type', '', w)}" for w, n in wires.items())


def _case_name(d: dict) -> str:
    """A bundle of the config's ``cases`` / ``hifi.extra_cases``: wires, covering, taping."""
    covering = COVERINGS.get(d.get("covering", ""), str(d.get("covering", "")).replace("_", " "))
    if "d_i" in d and d.get("covering") not in (None, "none"):
        covering = f"{d['d_i']:g} mm {covering}"
    parts = [_wires(d.get("wires", {})), covering, TAPINGS.get(d.get("taping", ""), d.get("taping", ""))]
    return ", ".join(p for p in parts if p)


def physical_name(item: str, cfg: dict) -> str:
    """The physical name of a case, covering component, branch load case or test id, e.g.
    ``cwb19_t2_open_halflap`` -> '19 x type 2, open tube, half-lap tape'; a test id
    (``bend_<case>``, ``tensile_<component>``, ``branch_<load case>``) is named by its item;
    an unknown name is returned as it is."""
    cases = {**cfg.get("cases", {}), **cfg.get("hifi", {}).get("extra_cases", {})}
    if item in cases:
        return _case_name(cases[item])
    if item in cfg.get("coverings", {}):
        material = cfg["coverings"][item].get("material", "")
        covering = COVERINGS.get(item, item)
        return f"{covering} ({COMPONENT_MATERIAL.get(material, material)})"
    if item in BRANCH_LOAD_CASES:
        return BRANCH_LOAD_CASES[item]
    for prefix in ("bend_", "tensile_", "branch_", "hifi:"):
        if item.startswith(prefix):
            rest = item[len(prefix):]
            named = physical_name(rest, cfg)
            if named != rest:
                return named
    return item


def labelled(item: str, cfg: dict) -> str:
    """'<physical name> (<id>)', or the id alone when it has no physical name."""
    name = physical_name(item, cfg)
    return item if name == item else f"{name} ({item})"


def solver_statistics(cfg: dict) -> dict:
    """Summary key of a hi-fi run -> (label with unit and limits, limit above which the value
    is flagged or None).  Limits from the config's ``explicit`` block (Sec. 4.1)."""
    ex = cfg.get("explicit", {})
    ke_max, ke_fail, e_fail = ex.get("ke_ie_max"), ex.get("ke_ie_fail"), ex.get("energy_fail")
    return {
        "wall_s": ("wall time [s]", None),
        "steps": ("explicit time steps [-]", None),
        "dt": ("time step dt [s] (simulated, after mass scaling, eq. 11)", None),
        "t_total": ("simulated loading time [s]", None),
        "f_m": (f"mass scaling factor f_m [-] (paper {ex.get('f_m', 25):g})", None),
        "ke_ie_max": (f"KE/IE max [-] (limit {ke_max:g} / reject {ke_fail:g})"
                      if ke_max is not None and ke_fail is not None else "KE/IE max [-]", ke_max),
        "energy_error": (f"energy balance error [-] (of the external work; reject above {e_fail:g})"
                         if e_fail is not None else "energy balance error [-]", e_fail),
        "n_beam_elements": ("beam elements (wires) [-]", None),
        "n_shell_elements": ("shell elements (tube, tape) [-]", None),
        "contact_pairs_max": ("contact pairs, largest number at once [-]", None),
        "plastic_work": ("plastic work [N mm]", None),
    }
