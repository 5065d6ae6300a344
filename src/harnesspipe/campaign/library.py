"""The campaign's library: each construction's row, then ``properties.csv`` (rules
campaign_rom and campaign_library, workflow/rules/campaign.smk).

* :func:`properties` -- eq. 13 + simplex (the ROM stage's fit,
  :func:`harnesspipe.stages.hifi_chain.rom_crosscheck`) on the construction's virtual test
  (:mod:`harnesspipe.campaign.virtual`), and its row (``property.json``): E, sigma_Y, K, n,
  r_o, rho, the bending stiffness EI = E pi r_o^4 / 4 and the curvature at first yield
  kappa_Y = sigma_Y / (E r_o) (the outer fibre at sigma_Y), the run's cost and quality
  (KE/IE, energy error, the largest force drop as a fraction of its peak).  A
  failed run gives a failed row with empty values.
* :func:`library` -- ``properties.csv``, one row per construction.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import pandas as pd

from harnesspipe.campaign.virtual import FAILURES, diagnostics
from harnesspipe.config import ConfigError
from harnesspipe.stages.common import read_fit, write_csv, write_json

PARAMETERS = ("E", "sigma_y", "K", "n")
COLUMNS = ["case", "E", "sigma_y", "K", "n", "r_o", "rho", "EI", "kappa_y", "n_wires", "wires",
           "covering", "taping", "tape", "span", "deflection", "hifi_wall_s", "rom_wall_s",
           "ke_ie", "energy_error", "force_drop", "rom_error_rel", "status", "message"]


def bending_stiffness(E: float, r_o: float) -> float:
    """EI of the effective beam, I = pi r_o^4 / 4 (eq. 13's section), N mm^2."""
    return E * math.pi * r_o**4 / 4.0


def yield_curvature(E: float, sigma_y: float, r_o: float) -> float:
    """Curvature at first yield of the effective beam, kappa_Y = M_Y / EI = sigma_Y / (E r_o), 1/mm."""
    return sigma_y / (E * r_o)


def properties(name: str, hifi_dir: Path, settings: dict, outdir: Path) -> dict:
    """The library row of construction ``name`` (module docstring) -> ``outdir/property.json``;
    the ROM fit's artefacts in ``outdir/rom/``."""
    from harnesspipe.stages.hifi_chain import rom_crosscheck
    outdir = Path(outdir)
    run = json.loads((Path(hifi_dir) / "result.json").read_text())
    f = settings["features"]
    row = {"case": name, **dict.fromkeys((*PARAMETERS, "EI", "kappa_y", "rom_wall_s", "rom_error_rel")),
           **{k: f[k] for k in ("r_o", "rho", "n_wires", "wires", "covering", "taping", "tape",
                                "span", "deflection")},
           "hifi_wall_s": run["wall_s"], "ke_ie": run.get("ke_ie"), "energy_error": run.get("energy_error"),
           "force_drop": (run.get("force_drop") or {}).get("fraction"),
           "status": run["status"], "message": ""}
    if run["status"] != "ok":
        row["message"] = f"{run['stage']}: {run['diagnostics']['error']}"
        return _write_row(outdir, row, run.get("diagnostics"))
    try:
        fit = rom_crosscheck(name, Path(hifi_dir) / "curve.csv", settings, outdir / "rom",
                             label="hi-fi virtual test")
    except ConfigError:
        raise
    except FAILURES as exc:
        found = diagnostics(exc)
        row.update(status="failed", message=f"eq. 13 + simplex: {found['error']}")
        return _write_row(outdir, row, found)
    p = fit["parameters"]
    row.update({k: p[k] for k in PARAMETERS}, EI=bending_stiffness(p["E"], f["r_o"]),
               kappa_y=yield_curvature(p["E"], p["sigma_y"], f["r_o"]), rom_wall_s=fit["wall_s"],
               rom_error_rel=fit["error_rel"])
    row["message"] = quality_message(run)
    return _write_row(outdir, row, None)


def quality_message(run: dict) -> str:
    """What to doubt in a virtual test that ran (result.json ``run``): KE/IE above the paper's
    2 %, a fall of its force (:func:`harnesspipe.models.hifi.is_fall`); "" when neither."""
    from harnesspipe.models.hifi import is_fall, is_snap
    notes = []
    if not run.get("quasi_static", True):
        notes.append(f"KE/IE {run['ke_ie']:.3g} above the paper's 2 % (below the rejection limit)")
    drop = run.get("force_drop")
    if is_fall(drop):
        notes.append(f"the virtual test's force falls {100.0 * drop['fraction']:.0f} % between "
                     f"{drop['from_mm']:.1f} and {drop['to_mm']:.1f} mm{' (a snap)' if is_snap(drop) else ''}, "
                     "and the beam is fitted through it")
    return "; ".join(notes)


def _write_row(outdir: Path, row: dict, diagnostics: dict | None) -> dict:
    write_json(Path(outdir) / "property.json", {**row, "diagnostics": diagnostics})
    return row


def library(property_paths: list[Path], out_csv: Path) -> pd.DataFrame:
    """``properties.csv``: the rows of every construction's property.json, in the given order."""
    rows = [{k: read_fit(p).get(k) for k in COLUMNS} for p in property_paths]
    frame = pd.DataFrame(rows, columns=COLUMNS)
    write_csv(out_csv, frame)
    return frame
