"""Calibrate the open tube's J2 plasticity (eq. 2) on its shipped tensile tests (Sec. 3.2).

The three specimens are resampled to their mean, the shell model of the tensile test is fitted
by the paper's Nelder-Mead (+5 % simplex from a data-sheet guess), and the fit is written to a
folder (fit.json, curve.csv, trace.h5, fit.png) beside Table 2's values.

    python examples/tensile_fit.py [OUTDIR]
"""
import sys
import tempfile
from pathlib import Path

from harnesspipe.config import load
from harnesspipe.stages.data import prepare_test
from harnesspipe.stages.tensile import fit_component

cfg = load()
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="tensile_fit_"))
reference = prepare_test(cfg["data_dir"], "tensile_open_tube", out / "tensile_open_tube.h5")
tube = cfg["coverings"]["open_tube"]
settings = {"preset": "quick", "nu": cfg["materials"][tube["material"]]["nu"],
            "pitch": tube["pitch"], "initial": cfg["tensile"]["initial_guess"][tube["material"]],
            "maxfev": 300, **cfg["tensile"]["simplex"]}
fit = fit_component("open_tube", reference, settings, out / "open_tube")
paper = cfg["paper"]["table2"]["open_tube"]
for name, value in fit["parameters"].items():
    print(f"{name}: {value:.4g} (Table 2: {paper[name]:g})")
print(f"wrote {out / 'open_tube'}")
