"""Issue 25: the calibration chain's interface does not depend on the Numba thread count.

A hi-fi run is the same bit for bit at one and at two threads (the force lanes and the
parallel kernels commit in a fixed order), so the fits built on the runs are too: shown on
the quick chain's friction and cohesive steps (the rules' settings, stages/chain_settings.py, the
shipped data), run with one and with two threads, and on one run of each covering the
chain fits on (closed tube, half-lap tape, fabric)."""
import json

import numba
import numpy as np
import pandas as pd
import pytest

from harnesspipe.config import load, resolution
from harnesspipe.models.hifi import three_point
from harnesspipe.stages import chain_settings
from harnesspipe.stages.data import prepare_test
from harnesspipe.stages.hifi import inputs
from harnesspipe.stages.hifi_chain import fit_step

DATA = load()["data_dir"]


@pytest.fixture
def threads():
    before = numba.get_num_threads()
    yield numba.set_num_threads
    numba.set_num_threads(before)


def _quick():
    cfg = load()
    cfg["profile"] = "quick"
    return cfg


@pytest.mark.slow
@pytest.mark.parametrize("case", ["cwb19_t2_closed", "cwb19_t2_open_halflap", "cwb19_t2_fabric"])
def test_a_run_is_the_same_at_one_and_two_threads(case, threads):
    runs = []
    for n in (1, 2):
        threads(n)
        runs.append(three_point(inputs(_quick(), case, {"stop_deflection": "12"}), n_shapes=1))
    assert runs[1].summary["threads"] == 2
    pd.testing.assert_frame_equal(runs[0].history, runs[1].history, check_exact=True)


@pytest.mark.slow
def test_the_quick_chains_fits_are_the_same_at_one_and_two_threads(tmp_path, threads):
    """The chain's first three steps with the settings the rules pass (chain_settings), on
    the shipped tests and the paper's Table 2 coverings."""
    cfg = _quick()
    table2 = tmp_path / "table2.csv"
    pd.DataFrame([{"component": k, **v} for k, v in cfg["paper"]["table2"].items()]).to_csv(
        table2, index=False)
    refs = {c: prepare_test(DATA, f"bend_{c}", tmp_path / f"{c}.h5")
            for c in ("cwb19_t2_closed", "cwb19_t2_open_halflap")}
    found = {}
    for n in (1, 2):
        threads(n)
        priors, values = [], {}
        for step in ("mu_rtb", "mu_rtp", "cohesive"):
            settings = json.loads(chain_settings.fit_settings(cfg, step, resolution(cfg)))
            out = tmp_path / f"threads{n}" / step
            fit = fit_step(step, settings, {c: refs[c] for c in settings["cases"]}, out,
                           table2=table2, priors=priors)
            priors.append(out / "fit.json")
            values.update(fit["parameters"])
        found[n] = values
    assert set(found[1]) == {"mu_rtb", "mu_rtp", "delta0", "delta_f", "alpha_d"}
    assert found[1] == found[2]
    assert all(np.isfinite(v) for v in found[1].values())
