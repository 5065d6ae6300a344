"""The settings the tensile, ROM and branch rules pass to their stages.

Each is a JSON text of the part of the config the stage reads (a rule passes it as a
param, so the rule reruns exactly when the settings of its run change).  ``profile``:
the resolved profile (:func:`harnesspipe.config.resolution`).  The hi-fi chain's are in
:mod:`harnesspipe.stages.chain_settings`.
"""
from __future__ import annotations

import json

from harnesspipe.stages import chain_settings as chain

ROM_KEYS = ("model_consistent_E", "consistent_E_model", "linear_window", "yield_deflection", "simplex_parameters",
            "simplex_space", "reference_strains", "simplex", "initial_guess")
BRANCH_KEYS = ("properties", "properties_source", "geometry", "n_steps", "dt_min", "stroke",
               "rate", "alpha_bounds", "alpha_xatol")


def tensile(config: dict, profile: dict, component: str) -> str:
    """Tensile fit of a covering (Sec. 3.2): mesh preset, Poisson ratio, ridge pitch, start
    values and simplex settings."""
    cov = config["coverings"][component]
    material = cov["material"]
    return json.dumps({
        "preset": profile["tensile"]["preset"],
        "nu": config["materials"][material]["nu"],
        "pitch": cov.get("pitch"),
        "initial": config["tensile"]["initial_guess"][material],
        "maxfev": profile["simplex_maxfev"],
        **config["tensile"]["simplex"],
    }, sort_keys=True)


def rom(config: dict, profile: dict, case: str) -> str:
    """ROM fit of a case (Sec. 4.3, eq. 13 + simplex) against ``rom.reference``."""
    tp = config["three_point"]
    return json.dumps({
        "r_o": chain.cases(config)[case]["r_o"],
        "supports": config["rom"]["supports"],
        "mu": config["rom"]["roller_friction"],
        "reference": config["rom"]["reference"],
        "three_point": {k: tp[k] for k in ("span", "overhang", "deflection")},
        "rom": {k: config["rom"][k] for k in ROM_KEYS},
        "mesh": profile["rom"],
        "maxfev": profile["simplex_maxfev"],
    }, sort_keys=True)


def rom_on_hifi(config: dict, profile: dict, case: str) -> str:
    """ROM fit of a case against its hi-fi virtual test."""
    return json.dumps({**json.loads(rom(config, profile, case)), "reference": "hifi"},
                      sort_keys=True)


def branch(config: dict) -> str:
    """Branch damping calibration (Sec. 5, eqs. 14-15)."""
    b = config["branch"]
    return json.dumps({k: b[k] for k in BRANCH_KEYS}, sort_keys=True)


def branch_hifi(config: dict, profile: dict) -> str:
    """The hi-fi Y harness on the pull test: both CWB cases' hi-fi models, the branch
    geometry and test, ``branch.hifi``."""
    model = chain.model(config, "cwb38_t2_open_coarse", profile)
    model["cases"].update(chain.model(config, "cwb19_t2_open_coarse", profile)["cases"])
    b, h = config["branch"], config["branch"]["hifi"]
    return json.dumps({
        "model": model, "geometry": b["geometry"], "stroke": b["stroke"], "rate": b["rate"],
        "load_case": h["load_case"], "t_total": h["t_total"], "resolution": h["resolution"],
        "interface": {k: v for k, v in config["paper"]["interface"].items() if k != "E2_over_E1"},
    }, sort_keys=True)
