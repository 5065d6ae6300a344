"""Construction catalogues: load, check and map each entry onto the hi-fi model's case.

A catalogue (YAML, schema ``workflow/schemas/campaign.schema.yaml``, documented in
``config/campaigns/README.md``) names bundle constructions: wire counts by type, covering,
taping, build state and test geometry.  :func:`load` validates it against the schema and
then against the config (a wire type or tape that exists, diameters in order, the bundle
fitting inside its covering, a stroke below half the span); every error names the file,
the construction and the key, e.g.
``demo.yaml: construction w7_closed: covering.d_i: 5.0: 7 wires (bundle radius 2.10 mm) ...``.

:func:`hifi_case` maps an entry onto what :mod:`harnesspipe.models.hifi_mesh` builds from a
config ``cases`` entry (``wires``, ``covering`` as a ``coverings`` name, ``taping``, ``tape``,
``r_o``, ``t_total_scale``), and :func:`model_config` gives the part of the config a run of
it reads, with the construction's covering geometry, materials and test in it.  Nothing
else of the config enters a construction's run, so a changed entry reruns that entry only.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

import yaml
from jsonschema import Draft202012Validator

from harnesspipe.config import REPO_ROOT, ConfigError, read_yaml
from harnesspipe.validate import deflection_problem, problem, tape_tension_problem

SCHEMA_PATH = REPO_ROOT / "workflow" / "schemas" / "campaign.schema.yaml"
COVERINGS = {"closed": "closed_tube", "open": "open_tube", "fabric": "fabric_tube", "none": "none"}
TAPINGS = {"none": "none", "coarse": "coarse", "half-lap": "halflap"}
TUBE_KEYS = ("d_i", "d_o", "t", "pitch")
FABRIC_KEYS = ("r1", "r2", "wraps", "t")
DEFAULT_TAPE = "pvc_tape"


@dataclass(frozen=True)
class Catalogue:
    """A checked catalogue: ``name`` (the file's stem: results/campaign/<name>/), the user's
    ``wire_types`` and ``tapes``, and every construction with the defaults and the config's
    values filled in (:func:`normalise`)."""

    path: Path
    name: str
    wire_types: dict
    tapes: dict
    constructions: dict


def _where(path) -> tuple[str, str]:
    """(construction or section, dotted key) of a schema error's path."""
    parts = [str(p) for p in path]
    if len(parts) >= 2 and parts[0] == "constructions":
        return f"construction {parts[1]}", ".".join(parts[2:])
    return (parts[0] if parts else "(top level)"), ".".join(parts[1:])


def _schema_message(error) -> str:
    """One line for a schema error: the construction (or section), the key and the problem."""
    owner, key = _where(error.absolute_path)
    if error.validator == "additionalProperties":
        known = sorted(error.schema.get("properties", {}))
        extra = sorted(set(error.instance) - set(known))
        keys = ", ".join(f"{key}.{k}" if key else k for k in extra)
        return f"{owner}: unknown key {keys} (allowed: {', '.join(known)})"
    if error.validator == "required":
        missing = error.message.split("'")[1]
        return f"{owner}: {f'{key}.' if key else ''}{missing}: missing (a required key)"
    if "propertyNames" in error.schema_path:       # a key (or name) not allowed there
        return f"{owner}: {f'{key}.' if key else ''}{error.instance}: not allowed here ({error.message})"
    if error.validator in ("enum", "const"):
        return f"{owner}: {key}: {error.instance!r}: expected one of {error.validator_value}"
    return f"{owner}: {key}: {error.instance!r}: {error.message}"


def _schema_errors(data) -> list[str]:
    with open(SCHEMA_PATH) as f:
        validator = Draft202012Validator(yaml.safe_load(f))
    errors = sorted(validator.iter_errors(data), key=lambda e: [str(p) for p in e.absolute_path])
    return [_schema_message(e) for e in errors]


def _as_dict(value, key: str = "type") -> dict:
    """A shorthand string (``covering: closed``) as its mapping (``{type: closed}``)."""
    return {key: value} if isinstance(value, str) else dict(value)


def normalise(entry: dict, defaults: dict, config: dict) -> dict:
    """An entry with the catalogue's ``defaults`` and the config's values filled in:
    ``covering`` (type and every diameter of its kind, from config ``coverings``),
    ``taping`` (type, tape), ``build`` (only the keys the catalogue sets: the rest comes from
    the interface's or the config's build state at run time), ``test`` (span, deflection
    from config ``three_point``), ``r_o`` when given, ``loading_time_scale``."""
    cov = _as_dict(entry["covering"])
    name = COVERINGS[cov["type"]]
    if name != "none":
        keys = FABRIC_KEYS if name == "fabric_tube" else TUBE_KEYS
        cov = {"type": cov["type"], **{k: float(cov.get(k, config["coverings"][name][k])) for k in keys}}
    taping = {"type": "none", "tape": DEFAULT_TAPE, **_as_dict(defaults.get("taping", {})),
              **_as_dict(entry.get("taping", {}))}
    tp = config["three_point"]
    test = {"span": tp["span"], "deflection": tp["deflection"], **defaults.get("test", {}),
            **entry.get("test", {})}
    out = {"wires": dict(entry["wires"]), "covering": cov, "taping": taping,
           "build": {**defaults.get("build", {}), **entry.get("build", {})},
           "test": {k: float(v) for k, v in test.items()},
           "loading_time_scale": float(entry.get("loading_time_scale",
                                                 defaults.get("loading_time_scale", 1.0)))}
    if "r_o" in entry:
        out["r_o"] = float(entry["r_o"])
    if "description" in entry:
        out["description"] = entry["description"]
    return out


def _materials(config: dict, wire_types: dict, tapes: dict) -> dict:
    return {**config["materials"], **wire_types, **tapes}


def hifi_case(entry: dict, config: dict, wire_types: dict | None = None,
              tapes: dict | None = None) -> dict:
    """The hi-fi model's case of a normalised entry (a config ``cases`` entry:
    :func:`harnesspipe.models.hifi_mesh.build_mesh`): wires, covering (a ``coverings``
    name), taping, tape, ``r_o`` (the entry's, else :func:`outer_radius`) and
    ``t_total_scale`` (the entry's loading time factor)."""
    case = {"wires": dict(entry["wires"]), "covering": COVERINGS[entry["covering"]["type"]],
            "taping": TAPINGS[entry["taping"]["type"]], "tape": entry["taping"]["tape"],
            "t_total_scale": entry["loading_time_scale"]}
    case["r_o"] = entry.get("r_o") or outer_radius(entry, config, wire_types or {}, tapes or {})
    return case


def outer_radius(entry: dict, config: dict, wire_types: dict, tapes: dict) -> float:
    """r_o of eq. 13 where the entry gives none, as DESIGN sec. 3 reads it for the paper's
    cases: a tube's d_o / 2, a fabric sleeve's r2, a taped wire bundle's packed radius plus
    the tape's thickness (the bundle's alone without a helix: only its ends are taped)."""
    cov = entry["covering"]
    if cov["type"] in ("closed", "open"):
        return 0.5 * cov["d_o"]
    if cov["type"] == "fabric":
        return cov["r2"]
    from harnesspipe.models.hifi_mesh_parts import wire_bundle
    mats = _materials(config, wire_types, tapes)
    r = wire_bundle({"wires": entry["wires"]}, {"materials": mats}).r_bundle
    return r + (mats[entry["taping"]["tape"]]["thickness"] if entry["taping"]["type"] != "none" else 0.0)


def test_geometry(entry: dict, config: dict) -> dict:
    """Config ``three_point`` for the entry's span and deflection: the same overhang beyond
    the rollers and the same bare wire ends beyond the covering as the paper's sample (Sec.
    2.2: 200 mm over a 127 mm span, 152.4 mm tube), the same taped ends."""
    tp = dict(config["three_point"])
    bare = tp["sample_length"] - tp["tube_length"]
    span = entry["test"]["span"]
    tp.update(span=span, deflection=entry["test"]["deflection"],
              sample_length=span + 2.0 * tp["overhang"])
    tp["tube_length"] = tp["sample_length"] - bare
    return tp


def model_config(name: str, catalogue: Catalogue, config: dict, resolution: dict) -> dict:
    """The part of the config a hi-fi run of construction ``name`` reads (as
    :func:`harnesspipe.stages.chain_settings.model` for the paper's cases): its case, its
    covering with the entry's geometry, the materials it uses (wire types, tape, covering
    material), its test, the explicit settings and ``resolution`` (the profile's,
    :func:`harnesspipe.config.resolution`).  The build state is the config's; the campaign
    settings put the interface's and the entry's over it."""
    entry = catalogue.constructions[name]
    case = hifi_case(entry, config, catalogue.wire_types, catalogue.tapes)
    mats = _materials(config, catalogue.wire_types, catalogue.tapes)
    used = {**{k: mats[k] for k in case["wires"]}, case["tape"]: mats[case["tape"]]}
    coverings = {}
    if case["covering"] != "none":
        geometry = {k: v for k, v in entry["covering"].items() if k != "type"}
        coverings = {case["covering"]: {**config["coverings"][case["covering"]], **geometry}}
        material = coverings[case["covering"]]["material"]
        used[material] = mats[material]
    return {
        "profile": config["profile"],
        "profiles": {config["profile"]: {"hifi": resolution["hifi"]}},
        "cases": {name: case},
        "hifi": {"coverings": "paper", "explicit": config["hifi"]["explicit"],
                 "build": dict(config["hifi"]["build"]), "extra_cases": {}},
        "interfaces": config["interfaces"],
        "explicit": config["explicit"],
        "materials": used,
        "coverings": coverings,
        "three_point": test_geometry(entry, config),
    }


# --------------------------------------------------------------------------- checks

def _check_types(data: dict, config: dict) -> list[str]:
    """The catalogue's own wire types and tapes: new names, diameters in order, ranges."""
    out = []
    for name in data.get("wire_types", {}):
        if name in config["materials"]:
            out.append(f"wire_types: {name}: already a wire type of config materials: "
                       "give the new type another number")
    for name in data.get("tapes", {}):
        if name in config["materials"]:
            out.append(f"tapes: {name}: already a material of config materials: give the tape "
                       "another name")
    for section in ("wire_types", "tapes"):
        for name, props in data.get(section, {}).items():
            out += [f"{section}: {name}.{k}: {v!r}: {msg}" for k, v in props.items()
                    if (msg := problem(k, v))]
            if section == "wire_types" and props["d_core"] >= props["d_outer"]:
                out.append(f"wire_types: {name}.d_core: {props['d_core']} must be < d_outer {props['d_outer']}")
    return out


def _check_entry(name: str, raw: dict, entry: dict, config: dict, wire_types: dict,
                 tapes: dict) -> list[str]:
    """Problems of one normalised entry, each ``construction <name>: <key>: ...``."""
    where = f"construction {name}"
    mats = _materials(config, wire_types, tapes)
    out = [f"{where}: wires.{k}: not a wire type of config materials or the catalogue's wire_types"
           for k in entry["wires"] if k not in mats]
    tape = entry["taping"]["tape"]
    if tape not in mats or not {"thickness", "width"} <= set(mats[tape]):
        out.append(f"{where}: taping.tape: {tape!r}: not a tape (config materials.pvc_tape or the "
                   "catalogue's tapes)")
    cov = entry["covering"]
    if cov["type"] in ("closed", "open") and cov["d_i"] >= cov["d_o"]:
        out.append(f"{where}: covering.d_i: {cov['d_i']:g} must be < d_o {cov['d_o']:g}")
    if cov["type"] == "fabric" and cov["r1"] >= cov["r2"]:
        out.append(f"{where}: covering.r1: {cov['r1']:g} must be < r2 {cov['r2']:g}")
    bad = deflection_problem(entry["test"]["deflection"], entry["test"]["span"])
    if bad:
        out.append(f"{where}: test.deflection: {entry['test']['deflection']:g}: {bad}")
    out += [f"{where}: build.{k}: {v!r}: {msg}" for k, v in entry["build"].items() if (msg := problem(k, v))]
    tension = entry["build"].get("tape_tension")
    if (tension is not None and not problem("tape_tension", tension)
            and {"sigma_y", "width", "thickness"} <= set(mats.get(tape, {}))):
        bad = tape_tension_problem(float(tension), mats[tape])
        if bad:
            out.append(f"{where}: build.tape_tension: {tension!r}: {bad} (tape {tape})")
    if not out:
        out += _check_fit(where, raw, entry, config, wire_types, tapes)
    return out


def _check_fit(where: str, raw: dict, entry: dict, config: dict, wire_types: dict,
               tapes: dict) -> list[str]:
    """The packed bundle fits inside the covering (the mesh builder's own check)."""
    from harnesspipe.models.hifi_mesh_parts import covering, wire_bundle
    case = hifi_case(entry, config, wire_types, tapes)
    cfg = {"materials": _materials(config, wire_types, tapes),
           "coverings": {**config["coverings"], case["covering"]: {
               **config["coverings"].get(case["covering"], {}),
               **{k: v for k, v in entry["covering"].items() if k != "type"}}}}
    bundle = wire_bundle(case, cfg)
    try:
        covering(case, cfg, bundle, cfg["materials"][case["tape"]]["thickness"])
    except ValueError:
        key = "covering.r1" if entry["covering"]["type"] == "fabric" else "covering.d_i"
        given = "" if isinstance(raw["covering"], dict) and key.split(".")[1] in raw["covering"] \
            else " (the config's)"
        inner = entry["covering"].get("r1", entry["covering"].get("d_i", 0.0))
        return [f"{where}: {key}: {inner:g}{given}: {bundle.yz.shape[0]} wires (bundle radius "
                f"{bundle.r_bundle:.2f} mm) do not fit inside the covering: give a larger {key}"]
    return []


def check(data, config: dict, source: str) -> Catalogue:
    """A :class:`Catalogue` of the parsed YAML ``data``, or ConfigError listing every
    problem (``source: construction <name>: <key>: ...``, one per line)."""
    problems = _schema_errors(data) if isinstance(data, dict) else ["expected a mapping at the top level"]
    if problems:
        raise ConfigError("\n".join(f"{source}: {p}" for p in problems))
    wire_types, tapes = data.get("wire_types", {}), data.get("tapes", {})
    problems = _check_types(data, config)
    defaults = data.get("defaults", {})
    entries = {}
    for name, raw in data["constructions"].items():
        entries[name] = normalise(raw, defaults, config)
        problems += _check_entry(name, raw, entries[name], config, wire_types, tapes)
    if problems:
        raise ConfigError("\n".join(f"{source}: {p}" for p in problems))
    return Catalogue(Path(source), Path(source).stem, copy.deepcopy(wire_types),
                     copy.deepcopy(tapes), entries)


def load(path: str | Path, config: dict) -> Catalogue:
    """Read and check the catalogue file ``path`` (see :func:`check`)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"campaign {path}: catalogue file not found")
    return check(read_yaml(path), config, str(path))
