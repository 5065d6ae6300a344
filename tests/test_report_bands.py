"""The report's bands (issue 29 item 6): the model's 95 % band beside the specimens', the
flow stress with its band, and the plain-words sentence generated from fit.json."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd

from harnesspipe.calibrate.uncertainty import Z95
from harnesspipe.report import plots
from harnesspipe.report.html import determination_sentence, fit_block

EPS = np.geomspace(1e-3, 0.1, 25)
SIGMA = 10.0 + 30.0 * EPS**0.4


def _fit(se: dict, rel_flow) -> dict:
    names = ["E", "sigma_y", "K", "n"]
    return {"stage": "tensile", "item": "closed_tube", "test_id": "T1",
            "parameters": {"E": 900.0, "sigma_y": 10.0, "K": 30.0, "n": 0.4},
            "error_l2": 1.0, "error_rel": 0.01, "nfev": 80, "converged": True, "wall_s": 2.0,
            "standard_error": None, "standard_error_dof": 2,
            "fisher": {"noise_sigma_N": 0.1, "names": names, "standard_error": se,
                       "correlation": np.eye(4).tolist()},
            "flow_stress": {"eps_p": EPS.tolist(), "sigma": SIGMA.tolist(),
                            "band": None if rel_flow is None else (Z95 * SIGMA * rel_flow).tolist()}}


POOR = {"E": 0.002, "sigma_y": 0.63, "K": 0.85, "n": None}
FLOW = np.where(EPS >= 0.0099, 0.01, 0.2)     # +-1 % over 1-10 % plastic strain, 20 % below


def test_sentence_says_what_the_data_determine_and_what_not():
    assert determination_sentence(_fit(POOR, FLOW)).startswith(
        "The curve determines E (\u00b10.2 %) and the flow stress at 1-10 % plastic strain "
        "(\u00b11 %); sigma_Y, K and n separately it does not (\u00b163 %, \u00b185 %, "
        "not determined).")
    well = determination_sentence(_fit({"E": 0.01, "sigma_y": 0.03, "K": 0.12, "n": 0.04}, None))
    assert well.startswith("The curve determines E (\u00b11 %), sigma_Y (\u00b13 %) and n (\u00b14 %); "
                           "K only roughly (\u00b112 %).")
    nothing = determination_sentence(_fit({"E": 0.1, "sigma_y": 0.5, "K": 0.2, "n": 0.2},
                                          np.full(EPS.size, 0.06)))
    assert nothing.startswith("The curve determines no quantity to within 5 %; sigma_Y it does not "
                              "(\u00b150 %); E, K and n only roughly (\u00b110 %, \u00b120 %, \u00b120 %).")
    assert determination_sentence({**_fit(POOR, FLOW), "fisher": None}) is None


def test_fit_figure_shades_the_models_band_beside_the_specimens():
    x = np.linspace(0.0, 10.0, 11)
    curve = pd.DataFrame({"displacement_mm": x, "force_N": 2.0 * x, "band_N": 0.1 * x})
    ax = plots.fit_figure(None, curve).axes[0]
    [band] = [c for c in ax.collections if c.get_label() == "model 95 % band (parameters, \u00b11 N at most)"]
    y = band.get_paths()[0].vertices[:, 1]
    assert y.min() == 0.0 and np.isclose(y.max(), 21.0)           # F + band at 10 mm
    assert not [c for c in plots.fit_figure(None, curve.drop(columns="band_N")).axes[0].collections]
    flow_ax = plots.flow_stress_figure(_fit(POOR, FLOW)["flow_stress"]).axes[0]
    [flow_band] = [c for c in flow_ax.collections if c.get_label() == "95 % band"]
    assert np.isclose(flow_band.get_paths()[0].vertices[:, 1].max(), SIGMA[-1] * (1 + Z95 * 0.01))


def test_fit_block_shows_the_band_figures_and_the_sentence(tmp_path):
    fit = _fit(POOR, FLOW)
    (tmp_path / "fit.json").write_text(json.dumps(fit))
    x = np.linspace(0.0, 10.0, 11)
    pd.DataFrame({"displacement_mm": x, "force_N": 2.0 * x, "band_N": 0.1 * x}).to_csv(
        tmp_path / "curve.csv", index=False)
    block = fit_block(fit, tmp_path, None, None, None)
    assert 'alt="fit closed_tube"' in block and 'alt="flow stress closed_tube"' in block
    assert ('<p class="determined">The curve determines E (\u00b10.2 %) and the flow stress at '
            "1-10 % plastic strain (\u00b11 %); sigma_Y, K and n separately it does not") in block
