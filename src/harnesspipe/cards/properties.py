"""The beam properties a card holds, read from a property table and the config.

A table is ``results/rom/table3.csv`` (``case,E,sigma_y,K,n,reference``) or a campaign's
``properties.csv`` (``case,E,sigma_y,K,n,r_o,...,status``).  Per row:

* E, sigma_Y, K, n (eq. 2, MPa): the table's columns;
* r_o (eq. 13's outer radius, mm): the ``r_o`` column when the table has one, else the
  config's ``cases.<case>.r_o`` (or ``hifi.extra_cases``) -- the radius the ROM stage was
  fitted with (:func:`harnesspipe.stages.stage_settings.rom`);
* nu: a ``nu`` column when present, else the ROM beam's (:class:`Material`, 0.39 =
  Table 1's wire nu, config ``materials.wire_type*.nu``), the value the properties were
  fitted with (it sets G = E / (2 (1 + nu)) of torsion only);
* rho (t/mm^3): a ``rho`` column when present, else the wires' mass smeared over the
  section, sum_i N_i rho_i (d_outer,i / 2)^2 / r_o^2 from the case's ``wires`` and config
  ``materials`` -- the lumped mass of the branch ROM (:mod:`harnesspipe.models.branch`),
  which leaves the covering and tape out (the closed tube's 0.27 mm wall, counted flat,
  would add about 7 %);
* span, deflection of the three-point deck (mm): ``span`` and ``deflection`` columns (a
  campaign's test geometry) when present, else the config's ``three_point``.

Rows whose ``status`` is not ``ok`` are skipped (a note names them); every other row must
be complete and physical, or :class:`TableError` names the file, row, case and column (a
file that is no CSV table: :class:`~harnesspipe.input_files.InputFileError`).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from harnesspipe.input_files import InputFileError, read_csv
from harnesspipe.models.rom_beam import Material
from harnesspipe.stages import chain_settings as chain
from harnesspipe.validate import deflection_problem, problem

REQUIRED = ("case", "E", "sigma_y", "K", "n")
CASE_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]{0,63}$")   # a folder and a solver label


class TableError(InputFileError):
    """A property table that cannot be carded (missing file, column or value)."""


@dataclass(frozen=True)
class BeamProperties:
    """One effective beam: eq. 2 law, eq. 13 radius, nu, rho and where each came from."""
    case: str
    E: float
    sigma_y: float
    K: float
    n: float
    r_o: float
    nu: float
    rho: float
    span: float            # of the three-point test the deck reproduces
    deflection: float
    sources: dict          # quantity -> where its value came from (README)

    @property
    def label(self) -> str:
        """Material/set name in a keyword deck: the case in capitals, '-' as '_'."""
        return self.case.upper().replace("-", "_")


def effective_density(wires: dict, materials: dict, r_o: float) -> float:
    """sum_i N_i rho_i (d_outer,i / 2)^2 / r_o^2: the wires' mass per length over pi r_o^2."""
    mass = sum(count * materials[w]["rho"] * (materials[w]["d_outer"] / 2.0) ** 2
               for w, count in wires.items())
    return mass / r_o**2


def read_table(path, config: dict, config_name: str = "config"
               ) -> tuple[list[BeamProperties], dict[str, str]]:
    """(properties of every ``ok`` row, {case: status} of the skipped rows) of the table
    at ``path``."""
    path = Path(path)
    if not path.is_file():
        raise TableError(f"{path}: property table not found")
    frame = read_csv(path, dtype={"case": str})
    missing = [c for c in REQUIRED if c not in frame.columns]
    if missing:
        raise TableError(f"{path}: missing column {', '.join(missing)} "
                         f"(expected columns {', '.join(REQUIRED)}, optional {', '.join(OPTIONAL)}, "
                         "status)")
    rows, skipped, seen = [], {}, set()
    for i, row in frame.iterrows():
        where = f"{path}: line {i + 2}"              # the header is line 1
        case = str(row["case"]).strip()
        if not CASE_NAME.match(case):
            raise TableError(f"{where}: case {case!r}: expected a name of letters, digits, '_' "
                             "or '-' starting with a letter (at most 64 characters)")
        if case in seen:
            raise TableError(f"{where}: case {case!r} appears twice")
        seen.add(case)
        status = str(row["status"]).strip() if "status" in frame.columns else "ok"
        if status != "ok":
            skipped[case] = status
            continue
        rows.append(_properties(row, case, f"{where} (case {case})", path, config, config_name))
    if not rows:
        raise TableError(f"{path}: no row with status ok: nothing to card")
    return rows, skipped


def _number(row, column: str, where: str) -> float:
    """A value of eq. 2's columns, checked by the shared validator (finite, in range)."""
    value = row[column]
    bad = problem(column, value)
    if bad:
        raise TableError(f"{where}: {column} = {value!r}: {bad}")
    return float(value)


def _properties(row, case: str, where: str, path: Path, config: dict,
                config_name: str) -> BeamProperties:
    law = {c: _number(row, c, where) for c in ("E", "sigma_y", "K", "n")}
    sources = {c: f"{path.name}, column {c}" for c in law}
    entry = chain.cases(config).get(case)
    section = "cases" if case in config["cases"] else "hifi.extra_cases"
    r_o = _optional(row, "r_o", where)
    if r_o is not None:
        sources["r_o"] = f"{path.name}, column r_o"
    elif entry is not None:
        r_o = float(entry["r_o"])
        sources["r_o"] = f"{config_name}: {section}.{case}.r_o (eq. 13 radius of the ROM fit)"
    else:
        raise TableError(f"{where}: no r_o column and no case {case!r} in {config_name} "
                         "(cases, hifi.extra_cases): the section radius is unknown")
    nu = _optional(row, "nu", where)
    if nu is None:
        nu = Material.nu
        sources["nu"] = ("the ROM beam's nu (harnesspipe.models.rom_beam.Material), Table 1's "
                         f"wire nu as in {config_name}: materials.wire_type*.nu")
    else:
        sources["nu"] = f"{path.name}, column nu"
    rho = _optional(row, "rho", where)
    if rho is not None:
        sources["rho"] = f"{path.name}, column rho"
    elif entry is not None:
        rho = effective_density(entry["wires"], config["materials"], r_o)
        wires = ", ".join(f"{n} x {w}" for w, n in entry["wires"].items())
        sources["rho"] = (f"{config_name}: the wires' mass ({wires}; materials.<type>.rho, "
                          f"d_outer) smeared over pi r_o^2, as the branch ROM's lumped mass")
    else:
        raise TableError(f"{where}: no rho column and no case {case!r} in {config_name} "
                         "(cases, hifi.extra_cases): the density is unknown (add a rho column, "
                         "t/mm^3, e.g. harnesspipe.cards.effective_density)")
    test = {}
    for key in ("span", "deflection"):
        test[key] = _optional(row, key, where)
        if test[key] is None:
            test[key] = float(config["three_point"][key])
            sources[key] = f"{config_name}: three_point.{key} (Sec. 2.2)"
        else:
            sources[key] = f"{path.name}, column {key}"
    bad = deflection_problem(test["deflection"], test["span"])
    if bad:
        raise TableError(f"{where}: deflection = {test['deflection']:g}: {bad}")
    return BeamProperties(case=case, r_o=r_o, nu=nu, rho=rho, sources=sources, **law, **test)


#: optional columns: (upper bound or None, what is expected)
OPTIONAL = {"r_o": (None, "a radius [mm] > 0"), "nu": (0.5, "a Poisson ratio in (0, 0.5)"),
            "rho": (None, "a density [t/mm^3] > 0"), "span": (None, "a span [mm] > 0"),
            "deflection": (None, "a deflection [mm] > 0")}


def _optional(row, column: str, where: str) -> float | None:
    """The value of an optional column (OPTIONAL), None when the table has no such column."""
    if column not in row.index:
        return None
    upper, expected = OPTIONAL[column]
    value = row[column]
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (v > 0.0 and math.isfinite(v) and (upper is None or v < upper)):
        raise TableError(f"{where}: {column} = {value!r}: expected {expected}")
    return v
