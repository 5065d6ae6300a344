"""Stage 8, branching harness: the hi-fi Y harness beside the ROM (Sec. 5, Fig. 18a).

One explicit run of :mod:`harnesspipe.models.hifi_branch` on the pull test of
``settings["load_case"]`` (the in-plane test of Fig. 18a), with the tensile stage's
coverings and the interface values named in the settings; writes the curve
(``displacement_mm, force_N``), the energy history, S2's bent shapes and a summary
with the cost figures for the report.
"""
from __future__ import annotations

from pathlib import Path

from harnesspipe.config import ConfigError
from harnesspipe.models.branch import Geometry
from harnesspipe.stages.common import write_csv, write_json, write_shapes

#: settings keys (built by workflow/rules/branch.smk from config ``branch``)
SETTINGS_KEYS = ("model", "geometry", "stroke", "rate", "load_case", "t_total", "resolution",
                 "interface")


def settings_from_config(cfg: dict, load_case: str | None = None, t_total: float | None = None) -> dict:
    """The settings of a run from a whole config (command line, benchmark): config
    ``branch`` and ``branch.hifi``, the paper's interface values."""
    b = cfg["branch"]
    return {"model": cfg, "geometry": b["geometry"], "stroke": b["stroke"], "rate": b["rate"],
            "load_case": load_case or b["hifi"]["load_case"],
            "t_total": t_total if t_total is not None else b["hifi"]["t_total"],
            "resolution": b["hifi"]["resolution"],
            "interface": {k: v for k, v in cfg["paper"]["interface"].items() if k != "E2_over_E1"}}


def inputs(settings: dict, table2: Path | None):
    """The :class:`harnesspipe.models.hifi_bundle.HifiInputs` of the run (case: S1's, the 38-wire
    CWB; every segment's own case is read from ``model.cases``)."""
    from harnesspipe.stages.hifi import inputs as hifi_inputs
    from harnesspipe.stages.hifi_chain import model_config
    missing = [k for k in SETTINGS_KEYS if k not in settings]
    if missing:
        raise ConfigError(f"branch hi-fi settings: missing {missing}")
    overrides = {k: str(v) for k, v in settings["resolution"].items()}
    cfg = model_config(settings, settings["interface"])
    inp = hifi_inputs(cfg, "cwb38_t2_open_coarse", overrides, table2)
    inp.explicit.update(t_total=float(settings["t_total"]),
                        t_phys=float(settings["stroke"]) / float(settings["rate"]))
    return inp


def run(settings: dict, outdir: Path, table2: Path | None = None, curve_csv: Path | None = None,
        summary_json: Path | None = None, progress=None) -> dict:
    """Run the hi-fi pull test and write its artefacts under ``outdir`` (curve and summary
    there unless ``curve_csv`` / ``summary_json`` are given); returns the summary.
    ``progress``: the model's progress callback (:func:`harnesspipe.models.hifi_branch.pull`)."""
    from harnesspipe.models.hifi_branch import pull
    inp = inputs(settings, table2)
    res = pull(inp, Geometry(**settings["geometry"]), settings["load_case"],
               stroke=float(settings["stroke"]), progress=progress)
    outdir = Path(outdir)
    write_csv(outdir / "energies.csv", res.history)
    write_shapes(outdir, res.shapes)   # the model's x, y, z (z out of plane)
    summary = {**res.summary, "stroke": float(settings["stroke"]),
               "t_phys": inp.explicit["t_phys"],
               "parameters": {"interface": inp.interface, "explicit": inp.explicit,
                              "resolution": inp.resolution, "coverings": inp.coverings}}
    write_csv(curve_csv or outdir / "curve.csv", res.curve)
    write_json(summary_json or outdir / "summary.json", summary)
    return summary
