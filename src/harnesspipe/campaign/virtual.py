"""The campaign's hi-fi step: the virtual three-point test of one construction (rule
campaign_hifi, workflow/rules/campaign.smk).

:func:`virtual_test` runs it at the campaign's interface
(:func:`harnesspipe.stages.hifi.run_case`) and writes ``curve.csv``, ``summary.json``,
``energies.csv``, shapes and ``result.json`` with ``status`` ok or failed.  A run that fails
(unstable, not quasi-static, energy balance off) is a failed result with its diagnostics and
a ``curve.csv`` of no rows: it stops neither the campaign nor the other constructions.
"""
from __future__ import annotations

import time
import traceback
from pathlib import Path

import pandas as pd

from harnesspipe.config import ConfigError
from harnesspipe.stages.common import write_csv, write_json

#: errors of a run or fit that make a construction failed (a bad entry is caught before)
FAILURES = (RuntimeError, ArithmeticError, ValueError)


def diagnostics(exc: BaseException) -> dict:
    """What a failed step leaves to read: the error, its numbers (an explicit run's step,
    time, energies) and where it was raised."""
    out = {"error": f"{type(exc).__name__}: {exc}",
           "where": "".join(traceback.format_tb(exc.__traceback__, limit=-2)).strip()}
    for name in ("reason", "step", "time", "ke", "ie", "w_ext", "dt"):
        if hasattr(exc, name):
            out[name] = getattr(exc, name)
    return out


def virtual_test(name: str, settings: dict, outdir: Path) -> dict:
    """Run construction ``name``'s virtual test (module docstring); returns result.json's content."""
    from harnesspipe.stages.hifi import run_case
    outdir = Path(outdir)
    t0 = time.perf_counter()
    try:
        summary = run_case(settings["model"], name, {}, coverings=None, out_csv=outdir / "curve.csv",
                           summary_json=outdir / "summary.json", outdir=outdir,
                           interface=None, interface_source=settings["interface_source"],
                           covering_values=settings["coverings"])
    except ConfigError:
        raise                               # bad input: exit 2, not a failed construction
    except FAILURES as exc:
        result = {"case": name, "status": "failed", "stage": "hifi virtual test",
                  "wall_s": time.perf_counter() - t0, "diagnostics": diagnostics(exc)}
        write_csv(outdir / "curve.csv", pd.DataFrame(columns=["deflection_mm", "force_N"]))
    else:
        result = {"case": name, "status": "ok", "wall_s": summary["wall_s"], "steps": summary["steps"],
                  "ke_ie": summary["ke_ie_max"], "quasi_static": summary["quasi_static"],
                  "energy_error": summary["energy_error"], "force_drop": summary.get("force_drop")}
    result.update(interface_source=settings["interface_source"],
                  coverings_source=settings["coverings_source"])
    write_json(outdir / "result.json", result)
    return result
