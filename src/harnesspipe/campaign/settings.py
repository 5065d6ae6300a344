"""What the campaign rules (workflow/rules/campaign.smk) pass to the campaign stages.

The settings of a construction's run are a JSON text built from that construction's entry
alone (with the interface, the coverings' Table 2 and the profile it runs at): a rule passes
it as a param, so adding an entry or changing one reruns that entry only, and an unchanged
catalogue reruns nothing, whatever else changed in the file.

The interface of the virtual tests (:func:`interface`): config ``campaign_interface``
(``paper``, ``start`` or an interface.csv) when given, else the calibration chain's
``results/hifi/interface.csv`` when it exists, else the paper's Sec. 4.2 values.  The
coverings' eq. 2 properties (:func:`coverings`): the tensile stage's
``results/tensile/table2.csv`` when it exists, else the paper's Table 2.  Both are read when
the workflow is parsed and enter the settings as values (not as rule inputs: a campaign
does not make Snakemake rebuild the chain or the tensile fits).
"""
from __future__ import annotations

import json
from pathlib import Path

from harnesspipe.campaign.catalogue import Catalogue, load
from harnesspipe.config import ConfigError
from harnesspipe.stages import stage_settings
from harnesspipe.stages.hifi import BUILD_KEYS, covering_properties, interface_choice

NEUTRAL = {"E2_over_E1": 1.0}    # E2/E1 acts on fabric coverings only (stages/hifi_chain.py)


def catalogue(config: dict) -> Catalogue | None:
    """The catalogue of ``--config campaign=FILE`` (checked), or None without one."""
    path = config.get("campaign")
    return load(path, config) if path else None


def require(cat: Catalogue | None) -> Catalogue:
    """The catalogue, or ConfigError saying how to give one (target ``campaign`` without it)."""
    if cat is None:
        raise ConfigError("campaign: no catalogue: run with --config campaign=config/campaigns/demo.yaml "
                          "(or another catalogue, config/campaigns/README.md)")
    return cat


def interface(config: dict, results: str | Path) -> tuple[str, dict]:
    """(source label, values) of the interface every virtual test of the campaign uses."""
    chosen = config.get("campaign_interface")
    if chosen is None:
        calibrated = Path(results) / "hifi" / "interface.csv"
        chosen = str(calibrated) if calibrated.is_file() else "paper"
    try:
        return interface_choice(config, chosen)
    except ConfigError as exc:
        raise ConfigError(f"config campaign_interface: {exc}") from None


def coverings(config: dict, results: str | Path) -> tuple[str, dict]:
    """(source label, eq. 2 properties per covering) of the campaign's coverings."""
    table2 = Path(results) / "tensile" / "table2.csv"
    if table2.is_file():
        return str(table2), covering_properties(config, table2)
    return "paper (config paper.table2)", covering_properties({**config, "hifi": {
        **config["hifi"], "coverings": "paper"}}, None)


def hifi(cat: Catalogue, name: str, config: dict, resolution: dict, itf: tuple[str, dict],
         covs: tuple[str, dict]) -> str:
    """Settings of construction ``name``'s virtual test (``harnesspipe campaign hifi``): the
    model config (:func:`harnesspipe.campaign.catalogue.model_config`) with the interface as
    its parameters and the build state (config, then the interface's fitted build keys, then
    the entry's), and the eq. 2 properties of its covering."""
    from harnesspipe.campaign.catalogue import model_config
    model = model_config(name, cat, config, resolution)
    case = model["cases"][name]
    label, values = itf
    model["hifi"]["build"].update({k: v for k, v in values.items() if k in BUILD_KEYS})
    model["hifi"]["build"].update(cat.constructions[name]["build"])
    params = {k: v for k, v in values.items() if k not in BUILD_KEYS}
    if case["covering"] != "fabric_tube" or "E2_over_E1" not in params:
        params.update(NEUTRAL)          # a run without a fabric sleeve does not depend on E2/E1
    model["hifi"]["parameters"] = params
    cov_label, cov_values = covs
    cov = case["covering"]
    return json.dumps({
        "model": model, "interface_source": label,
        "coverings": {cov: cov_values[cov]} if cov != "none" else {},
        "coverings_source": cov_label if cov != "none" else "none",
    }, sort_keys=True)


def rom(cat: Catalogue, name: str, config: dict, resolution: dict) -> str:
    """Settings of eq. 13 + simplex on the construction's virtual test (``harnesspipe campaign
    rom``): the ROM stage's (:func:`harnesspipe.stages.stage_settings.rom`) with the entry's
    r_o and test, and the construction's features for the library."""
    from harnesspipe.campaign.catalogue import hifi_case, test_geometry
    entry = cat.constructions[name]
    case = hifi_case(entry, config, cat.wire_types, cat.tapes)
    cfg = {**config, "cases": {name: case}, "hifi": {**config["hifi"], "extra_cases": {}},
           "three_point": test_geometry(entry, config)}
    settings = json.loads(stage_settings.rom_on_hifi(cfg, resolution, name))
    settings["features"] = features(entry, case, {**config["materials"], **cat.wire_types})
    return json.dumps(settings, sort_keys=True)


def features(entry: dict, case: dict, materials: dict) -> dict:
    """What the library and the page show a construction by: wire counts, covering, taping;
    and the effective beam's r_o and density rho (the wires' mass smeared over pi r_o^2, as
    the branch ROM's lumped mass: :func:`harnesspipe.cards.effective_density`)."""
    from harnesspipe.cards import effective_density
    return {"n_wires": int(sum(entry["wires"].values())),
            "wires": " ".join(f"{k}:{v}" for k, v in sorted(entry["wires"].items())),
            "covering": entry["covering"]["type"], "taping": entry["taping"]["type"],
            "tape": entry["taping"]["tape"] if entry["taping"]["type"] != "none" else "",
            "span": entry["test"]["span"], "deflection": entry["test"]["deflection"],
            "r_o": case["r_o"], "rho": effective_density(entry["wires"], materials, case["r_o"])}


def folder(cat: Catalogue, results: str | Path) -> str:
    """results/campaign/<catalogue>."""
    return f"{results}/campaign/{cat.name}"


def targets(cat: Catalogue | None, results: str | Path) -> list[str]:
    """The outputs of target ``campaign``: the property library, the campaign page and the
    solver cards in every format (their index, ``cards/<format>/README.md``)."""
    from harnesspipe.cards import FORMATS
    root = folder(require(cat), results)
    return [f"{root}/properties.csv", f"{root}/index.html",
            *(f"{root}/cards/{fmt}/README.md" for fmt in FORMATS)]
