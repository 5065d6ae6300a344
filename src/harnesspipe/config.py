"""Loading and validating config/config.yaml against workflow/schemas/config.schema.yaml.

Errors name the file and the dotted key, e.g.
``config/config.yaml: materials.wire_type1.E: -5.0 is not > 0``.
"""
from __future__ import annotations

import copy
from pathlib import Path

import yaml
from jsonschema import Draft202012Validator

from harnesspipe.validate import (deflection_problem, interface_problem, problem,
                                  tape_tension_problem)

REPO_ROOT = Path(__file__).resolve().parents[2]
SCHEMA_PATH = REPO_ROOT / "workflow" / "schemas" / "config.schema.yaml"
DEFAULT_CONFIG = REPO_ROOT / "config" / "config.yaml"


class ConfigError(ValueError):
    """A configuration value is missing, misnamed, of the wrong type or out of range."""


def _dotted(path) -> str:
    return ".".join(str(p) for p in path) or "(top level)"


def _describe(error) -> str:
    """One line naming the offending key for a jsonschema ValidationError."""
    where = _dotted(error.absolute_path)
    if error.validator == "additionalProperties":
        known = sorted(error.schema.get("properties", {}))
        extra = sorted(set(error.instance) - set(known)) if isinstance(error.instance, dict) else []
        keys = ", ".join(f"{where}.{k}" if error.absolute_path else k for k in extra)
        hint = f" (allowed: {', '.join(known)})" if known else ""
        return f"unknown key {keys}{hint}"
    if error.validator == "exclusiveMinimum":
        return f"{where}: {error.instance!r} must be > {error.validator_value}"
    if error.validator == "minimum":
        return f"{where}: {error.instance!r} must be >= {error.validator_value}"
    if error.validator == "type":
        return f"{where}: {error.instance!r} is not of type {error.validator_value}"
    if error.validator == "required":
        return f"{where}: {error.message}"
    return f"{where}: {error.message}"


def load_schema() -> dict:
    with open(SCHEMA_PATH) as f:
        return yaml.safe_load(f)


def validate(config: dict, source: str = "config") -> dict:
    """Validate ``config`` in place-free fashion; return it.  Raises ConfigError."""
    validator = Draft202012Validator(load_schema())
    errors = sorted(validator.iter_errors(config), key=lambda e: list(map(str, e.absolute_path)))
    if errors:
        lines = "; ".join(_describe(e) for e in errors[:5])
        more = f" (+{len(errors) - 5} more)" if len(errors) > 5 else ""
        raise ConfigError(f"{source}: {lines}{more}")
    _check_semantics(config, source)
    return config


#: config sections whose values are physical inputs (checked by harnesspipe.validate)
PHYSICAL = ("materials", "coverings", "interfaces", "hifi.parameters", "hifi.build", "paper.table2",
            "paper.table3", "paper.interface")


def _leaves(tree, prefix: str):
    """(dotted key, value) of every number under ``tree``."""
    if isinstance(tree, dict):
        for k, v in tree.items():
            yield from _leaves(v, f"{prefix}.{k}")
    elif isinstance(tree, (int, float)) and not isinstance(tree, bool):
        yield prefix, tree


def _check_physical(cfg: dict, source: str) -> None:
    """Signs and ranges of the physical inputs, and the cohesive law's delta_f > delta0."""
    sections = [*PHYSICAL, *(f"profiles.{name}.hifi" for name in cfg["profiles"])]
    for section in sections:
        tree = cfg
        for part in section.split("."):
            tree = tree[part]
        for key, value in _leaves(tree, section):
            bad = problem(key, value)
            if bad:
                raise ConfigError(f"{source}: {key}: {value!r}: {bad}")
    for section in ("hifi.parameters", "paper.interface"):
        group, name = section.split(".")
        bad = interface_problem(cfg[group][name])
        if bad:
            raise ConfigError(f"{source}: {section}.{bad}")
    tp = cfg["three_point"]
    bad = deflection_problem(tp["deflection"], tp["span"])
    if bad:
        raise ConfigError(f"{source}: three_point.deflection: {tp['deflection']!r}: {bad}")
    tension = cfg["hifi"]["build"]["tape_tension"]
    bad = tape_tension_problem(tension, cfg["materials"]["pvc_tape"])
    if bad:
        raise ConfigError(f"{source}: hifi.build.tape_tension: {tension!r}: {bad} (materials.pvc_tape)")


def _check_semantics(cfg: dict, source: str) -> None:
    _check_physical(cfg, source)
    if cfg["profile"] not in cfg["profiles"]:
        raise ConfigError(f"{source}: profile: {cfg['profile']!r} is not one of "
                          f"{sorted(cfg['profiles'])} (defined under profiles)")
    unknown = sorted(set(cfg["branch"]["hifi"]["in_all"]) - set(cfg["profiles"]))
    if unknown:
        raise ConfigError(f"{source}: branch.hifi.in_all: {unknown} not among the profiles "
                          f"{sorted(cfg['profiles'])}")
    for name in ("wire_type1", "wire_type2"):
        w = cfg["materials"][name]
        if w["d_core"] >= w["d_outer"]:
            raise ConfigError(f"{source}: materials.{name}.d_core: {w['d_core']} must be < d_outer {w['d_outer']}")
    for name in ("closed_tube", "open_tube"):
        c = cfg["coverings"][name]
        if c["d_i"] >= c["d_o"]:
            raise ConfigError(f"{source}: coverings.{name}.d_i: {c['d_i']} must be < d_o {c['d_o']}")
    e0, e1, e2 = cfg["rom"]["reference_strains"]
    if not (e0 < e1 < e2 and abs(e1 * e1 - e0 * e2) <= 1e-9 * e1 * e1):
        raise ConfigError(f"{source}: rom.reference_strains: {e0}, {e1}, {e2} must increase "
                          "in geometric progression")
    if cfg["interfaces"]["mu_k"] > cfg["interfaces"]["mu_s"]:
        raise ConfigError(f"{source}: interfaces.mu_k: {cfg['interfaces']['mu_k']} must be <= mu_s")


def load(path: str | Path = DEFAULT_CONFIG, overrides: dict | None = None) -> dict:
    """Read, merge ``overrides`` (nested dicts) and validate a config file."""
    path = Path(path)
    if not path.exists():
        raise ConfigError(f"{path}: config file not found")
    cfg = read_yaml(path)
    if not isinstance(cfg, dict):
        raise ConfigError(f"{path}: expected a mapping at the top level")
    if overrides:
        cfg = merge(cfg, overrides)
    return validate(cfg, source=str(path))


def yaml_problem(path, exc: yaml.YAMLError) -> str:
    """One line for a YAML syntax error: the file, line and column, and what is wrong."""
    mark = getattr(exc, "problem_mark", None)
    where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
    what = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    return f"{path}: {where}not valid YAML: {what}"


def read_yaml(path: Path):
    """A YAML file's content; a syntax error raises ConfigError naming the file and line."""
    try:
        with open(path) as f:
            return yaml.safe_load(f)
    except yaml.YAMLError as exc:
        raise ConfigError(yaml_problem(path, exc)) from None


def merge(base: dict, extra: dict) -> dict:
    """Recursive dict merge, ``extra`` wins; returns a new dict."""
    out = copy.deepcopy(base)
    for k, v in extra.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def resolution(cfg: dict) -> dict:
    """Settings of the active resolution profile (``profiles[profile]``)."""
    return cfg["profiles"][cfg["profile"]]
