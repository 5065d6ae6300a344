"""Solver cards of the ROM's effective beams (issue 28): CalculiX, Abaqus, LS-DYNA.

``write_cards(table, fmt, out)`` reads a property table (:mod:`.properties`) and writes,
per case, ``out/<case>/``:

* ``calculix`` / ``abaqus``: ``material.inp`` (*MATERIAL with *ELASTIC, the eq. 2
  *PLASTIC table, *DENSITY, and the circular *BEAM SECTION) and ``three_point.inp``, a
  runnable three-point test of the beam at ideal supports (:mod:`.keyword`);
* ``lsdyna``: ``material.k`` (MAT_024, its *DEFINE_CURVE, *SECTION_BEAM, *PART;
  :mod:`.lsdyna`);
* ``README.md``: every number with its source;

and ``out/README.md``, the index.  The whole table is checked before anything is
written; each file is written atomically.
"""
from __future__ import annotations

from pathlib import Path

from harnesspipe.cards import keyword, lsdyna
from harnesspipe.cards.flow_curve import STRAIN_RANGE, TOLERANCE, tabulate
from harnesspipe.cards.properties import BeamProperties, TableError, effective_density, read_table

FORMATS = ("calculix", "abaqus", "lsdyna")
CARD_FILES = {"calculix": ("material.inp", "three_point.inp"),
              "abaqus": ("material.inp", "three_point.inp"), "lsdyna": ("material.k",)}
SOLVER_NAMES = {**keyword.SOLVERS, "lsdyna": "LS-DYNA"}

__all__ = ["FORMATS", "BeamProperties", "TableError", "effective_density", "read_table",
           "write_cards"]


def write_cards(table, fmt: str, out, config=None, log=print) -> list[Path]:
    """Write the cards of every ``ok`` row of ``table`` (a CSV path) in format ``fmt`` to
    ``out``; returns the case folders.  ``config``: a config dict or file (default: the
    repository's config/config.yaml), the source of r_o, rho and the test's span and
    deflection where the table has none.  ``log`` receives the notes on skipped rows."""
    from harnesspipe import config as config_module
    if fmt not in FORMATS:
        raise TableError(f"format {fmt!r}: expected one of {', '.join(FORMATS)}")
    if config is None or isinstance(config, (str, Path)):
        config_path = Path(config or config_module.DEFAULT_CONFIG)
        config, config_name = config_module.load(config_path), config_path.name
    else:
        config_name = "config"
    rows, skipped = read_table(table, config, config_name)
    out = Path(out)
    notes = [f"{table}: case {case} skipped: status {status!r} (no cards written)"
             for case, status in skipped.items()]
    for case, note in zip(skipped, notes):
        log(note)
        _remove_stale(out / case)
    files = {}                            # every text first: an error writes nothing
    for part_id, p in enumerate(rows, start=1):
        cards = {**_cards(p, fmt, part_id), "README.md": case_readme(p, fmt, Path(table), part_id)}
        files.update({out / p.case / name: text for name, text in cards.items()})
    files[out / "README.md"] = index_readme(rows, notes, fmt, Path(table))
    blocked = [str(f) for path in files for f in (path, path.parent)
               if f.exists() and f.is_dir() == (f == path)]
    if blocked:
        raise TableError(f"{out}: {blocked[0]} is in the way (a folder where a card goes or a "
                         "file where a case's folder goes): nothing written")
    for path, text in files.items():
        _write(path, text)
    return [out / p.case for p in rows]


def _cards(p: BeamProperties, fmt: str, part_id: int) -> dict:
    if fmt == "lsdyna":
        return {"material.k": lsdyna.material_k(p, part_id)}
    return {"material.inp": keyword.material_inp(p, fmt),
            "three_point.inp": keyword.three_point_inp(p, fmt, p.span, p.deflection)}


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    tmp.replace(path)


def _remove_stale(folder: Path) -> None:
    """Cards an earlier run wrote for a case now skipped (only files this module writes)."""
    ours = {name for files in CARD_FILES.values() for name in files} | {"README.md"}
    if folder.is_dir() and {f.name for f in folder.iterdir()} <= ours:
        for f in folder.iterdir():
            f.unlink()
        folder.rmdir()


def case_readme(p: BeamProperties, fmt: str, table: Path, part_id: int) -> str:
    """README.md of one case folder: what each file holds, every number and its source."""
    eps, _ = tabulate(p.sigma_y, p.K, p.n)
    rows = [("E", f"{p.E:.6g}", "MPa", p.sources["E"]),
            ("sigma_Y", f"{p.sigma_y:.6g}", "MPa", p.sources["sigma_y"] + " (eq. 2)"),
            ("K", f"{p.K:.6g}", "MPa", p.sources["K"] + " (eq. 2)"),
            ("n", f"{p.n:.6g}", "-", p.sources["n"] + " (eq. 2)"),
            ("r_o", f"{p.r_o:.6g}", "mm", p.sources["r_o"] + "; I = pi r_o^4 / 4 as in eq. 13"),
            ("nu", f"{p.nu:.6g}", "-", p.sources["nu"]),
            ("rho", f"{p.rho:.6g}", "t/mm^3", p.sources["rho"])]
    if fmt != "lsdyna":
        rows += [("span", f"{p.span:g}", "mm", p.sources["span"]),
                 ("deflection", f"{p.deflection:g}", "mm", p.sources["deflection"])]
    lines = [f"# {SOLVER_NAMES[fmt]} cards of {p.case}", "",
             f"The effective beam of `{p.case}` (reduced-order model, Sec. 4.3 of the paper), "
             f"written by `harnesspipe cards --format {fmt}` from `{table}`.  Units: mm, t, s, "
             "N, MPa (density in t/mm^3).", "",
             "| quantity | value | unit | source |", "|---|---|---|---|",
             *(f"| {q} | {v} | {u} | {s} |" for q, v, u, s in rows), "",
             f"Hardening (eq. 2, sigma = sigma_Y + K eps_p^n) as {eps.size} points: eps_p = 0, "
             f"then geometric from {STRAIN_RANGE[0]:g} to {STRAIN_RANGE[1]:g}, the ratio "
             f"chosen so that linear interpolation stays within {100 * TOLERANCE:g} % of eq. 2 "
             "over that range (harnesspipe.cards.flow_curve).", "", "Files:", ""]
    if fmt == "lsdyna":
        lines += [f"- `material.k`: *MAT_PIECEWISE_LINEAR_PLASTICITY (MID {part_id}), its "
                  f"*DEFINE_CURVE (LCID {lsdyna.CURVE_ID_OFFSET + part_id}, effective plastic "
                  f"strain vs yield stress), *SECTION_BEAM (SECID {part_id}: Hughes-Liu, "
                  "circular, outer diameter 2 r_o, solid) and *PART (PID "
                  f"{part_id}) tying them; fixed 10-character fields.  Not run in LS-DYNA "
                  "here."]
    else:
        dim = "diameter 2 r_o" if fmt == "calculix" else "radius r_o"
        lines += [f"- `material.inp`: *MATERIAL {p.label} (*ELASTIC E, nu; *PLASTIC; *DENSITY) "
                  f"and *BEAM SECTION, SECTION=CIRC ({dim}) for element set {p.label}.",
                  f"- `three_point.inp`: runnable test including material.inp: "
                  f"{keyword.N_ELEMENTS} {keyword.ELEMENT} elements over the span, node 1 "
                  "pinned, the last node sliding along x, the mid-span node (set LOAD) "
                  "pushed along -y under *STATIC, NLGEOM; *NODE PRINT of U and RF of LOAD at "
                  "every increment.  The force should match `harnesspipe rom three-point "
                  "--supports pinned` with the values above."]
        if fmt == "calculix":
            lines += ["", "Run in this folder: `ccx -i three_point` (writes three_point.dat)."]
        else:
            lines += ["", "Run in this folder: `abaqus job=three_point`.  Not run in Abaqus here; the "
                      "CalculiX deck of the same beam is tested against the ROM."]
    return "\n".join(lines) + "\n"


def index_readme(rows: list[BeamProperties], notes: list[str], fmt: str, table: Path) -> str:
    lines = [f"# {SOLVER_NAMES[fmt]} cards", "",
             f"Written by `harnesspipe cards --table {table} --format {fmt}`.  One folder per "
             "case; its README.md gives every number's source.", "",
             "| case | E [MPa] | sigma_Y [MPa] | K [MPa] | n | r_o [mm] |", "|---|---|---|---|---|---|",
             *(f"| {p.case} | {p.E:.6g} | {p.sigma_y:.6g} | {p.K:.6g} | {p.n:.6g} | {p.r_o:.6g} |"
               for p in rows)]
    if notes:
        lines += ["", "Skipped (no cards):", "", *(f"- {n}" for n in notes)]
    return "\n".join(lines) + "\n"
