"""Issue 25: the calibration chain's interface does not depend on the Numba thread count.

A hi-fi run is the same bit for bit at one and at two threads (the force lanes and the
parallel kernels commit in a fixed order), so the fits built on the runs are too: shown on
the quick chain's friction and cohesive steps (workflow/rules/hifi.smk's settings, the
shipped data), run with one and with two threads, and on one run of each covering the
chain fits on (closed tube, half-lap tape, fabric)."""
import copy

import numba
import numpy as np
import pandas as pd
import pytest

from harnesspipe.config import load
from harnesspipe.models.hifi import three_point
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


def _settings(cfg, step: dict, window) -> dict:
    """A fit step's settings as the rules make them (hifi_fit_settings), on the whole config."""
    pipe = cfg["hifi"]["pipeline"]
    stop = window[1] + pipe["stop_after_window"]
    budget = pipe["budgets"]["quick"]
    bounded = step["method"] == "bounded"
    return {**step, "window": window, "bounds": pipe["mu_bounds"] if bounded else None,
            "xatol": pipe["bounded_xatol"] if bounded else pipe["simplex"]["xatol"],
            "fatol": None if bounded else pipe["simplex"]["fatol"],
            "maxfev": budget["bounded_maxfev" if bounded else "simplex_maxfev"],
            "flat_factor": pipe["flat_factor"],
            "start": {k: v for k, v in cfg["hifi"]["parameters"].items() if k != "E2_over_E1"},
            "models": {c: copy.deepcopy(cfg) for c in step["cases"]},
            "set": {"stop_deflection": stop} if stop < cfg["three_point"]["deflection"] else {}}


@pytest.mark.slow
def test_the_quick_chains_fits_are_the_same_at_one_and_two_threads(tmp_path, threads):
    cfg = _quick()
    pipe = cfg["hifi"]["pipeline"]
    refs = {c: prepare_test(DATA, f"bend_{c}", tmp_path / f"{c}.h5")
            for c in ("cwb19_t2_closed", "cwb19_t2_open_halflap")}
    friction, cohesive = pipe["friction_window"], pipe["cohesive_window"]
    steps = [("mu_rtb", {"names": ["mu_rtb"], "cases": ["cwb19_t2_closed"], "method": "bounded"},
              friction),
             ("mu_rtp", {"names": ["mu_rtp"], "cases": ["cwb19_t2_open_halflap"],
                         "method": "bounded"}, friction),
             ("cohesive", {"names": ["delta0", "delta_f", "alpha_d"], "method": "simplex",
                           "cases": ["cwb19_t2_closed", "cwb19_t2_open_halflap"]}, cohesive)]
    found = {}
    for n in (1, 2):
        threads(n)
        priors, values = [], {}
        for name, step, window in steps:
            settings = _settings(cfg, step, window)
            out = tmp_path / f"threads{n}" / name
            fit = fit_step(name, settings, {c: refs[c] for c in step["cases"]}, out, priors=priors)
            priors.append(out / "fit.json")
            values.update(fit["parameters"])
        found[n] = values
    assert set(found[1]) == {"mu_rtb", "mu_rtp", "delta0", "delta_f", "alpha_d"}
    assert found[1] == found[2]
    assert all(np.isfinite(v) for v in found[1].values())
