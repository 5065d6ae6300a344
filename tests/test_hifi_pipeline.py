"""The hi-fi pipeline without the hi-fi model: calibration helpers, chain stages and rules.

A cheap analytic stand-in replaces the explicit model (a real run takes minutes); the
rules are checked by Snakemake itself in a temporary copy of the project where the
stand-in is patched in (so every hifi rule really runs, in seconds).
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest

from conftest import copy_project, job_stats
from harnesspipe.calibrate import hifi as hcal
from harnesspipe.config import load as load_config
from harnesspipe.stages import hifi_chain
from harnesspipe.stages.chain_settings import STEPS

# --------------------------------------------------------------------------- the stand-in model

FAKE_MODEL = '''
import os

import numpy as np
import pandas as pd
from dataclasses import dataclass, field

TRUTH = {"mu_rtb": 0.3, "mu_rtp": 0.1, "delta0": 0.03, "delta_f": 0.08, "alpha_d": 2.0, "E2_over_E1": 0.6}


@dataclass
class FakeRun:
    curve: pd.DataFrame
    history: pd.DataFrame
    slip_out: pd.DataFrame = None
    shapes: dict = field(default_factory=dict)
    summary: dict = field(default_factory=dict)
    mesh: object = None


def force(u, p, covering):
    """Analytic bending curve: friction scales the low part, cohesion the high part."""
    k = 1.0 + 2.0 * p.get("mu_rtb", 0.2) + 3.0 * p.get("mu_rtp", 0.2)
    if covering == "fabric_tube":
        k *= 0.5 + p.get("E2_over_E1", 1.0)
    soft = p.get("delta0", 0.05) * 10.0 + p.get("delta_f", 0.1) * 5.0 + 0.05 * p.get("alpha_d", 1.0)
    return k * u - soft * np.maximum(u - 20.0, 0.0) ** 1.5


def run(cfg, case, interface, overrides=None):
    if interface.get("mu_rtb", 0.0) > 0.36:
        raise RuntimeError("explicit run stopped: fake instability")
    covering = cfg["cases"][case]["covering"]
    u = np.linspace(0.0, 30.0, 121)
    F = force(u, interface, covering)
    t = u / 30.0
    hist = pd.DataFrame({"time_s": t, "KE": 1e-3 * F, "internal": 0.5 * F * u, "friction": 0.1 * F * u,
                         "cohesive": 0.05 * F * u, "W_ext": 0.65 * F * u + 1e-3 * F,
                         "deflection_mm": u, "force_N": F})
    summary = {"wall_s": 0.01, "steps": 100, "dt": 1e-5, "f_m": 25.0, "ke_ie_max": 0.01,
               "energy_error": 1e-4, "n_beam_elements": 10, "n_shell_elements": 0, "contact_pairs_max": 0,
               "pid": os.getpid()}
    if overrides and "fake_tie_separation" in overrides:
        summary["tie_separation_max_mm"] = float(overrides["fake_tie_separation"])
        power = float(overrides.get("fake_tie_power", 1.0))      # how late in the stroke the ties open
        hist["tie_opening_mm"] = float(overrides["fake_tie_separation"]) * (u / 30.0) ** power
    return FakeRun(pd.DataFrame({"deflection_mm": u, "force_N": F}), hist, summary=summary)


def runner(cfg, case, overrides, table2):
    """The fit stages' runner protocol (module level: picklable for a process pool)."""
    return run(cfg, case, cfg["hifi"]["parameters"], overrides)
'''


@pytest.fixture(scope="module")
def fake(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fake")
    (folder / "fake_hifi_model.py").write_text(FAKE_MODEL)
    sys.path.insert(0, str(folder))        # importable by name: spawned workers find it too
    import importlib
    yield importlib.import_module("fake_hifi_model")
    sys.path.remove(str(folder))
    sys.modules.pop("fake_hifi_model", None)


def runner_of(fake):
    return fake.runner


def write_prepared(path: Path, case: str, F: np.ndarray, grid: np.ndarray, scatter: float = 0.0) -> Path:
    """A prepared three-point test: one replicate ``F`` or, with ``scatter`` d, three
    replicates (1 - d, 1, 1 + d) F of mean F."""
    factors = (1.0 - scatter, 1.0, 1.0 + scatter) if scatter else (1.0,)
    with h5py.File(path, "w") as f:
        f.attrs["test_id"] = f"bend_{case}"
        f.attrs["entry"] = json.dumps({"kind": "three_point", "item": case})
        f["grid"], f["mean"], f["lo"], f["hi"] = grid, F, 0.95 * F, 1.05 * F
        for k, c in enumerate(factors):
            g = f.create_group(f"samples/s{k + 1}")
            g["time_s"], g["displacement_mm"], g["force_N"] = grid / 0.5, grid, c * F
    return path


# --------------------------------------------------------------------------- calibrate/hifi.py

GRID = np.linspace(0.0, 30.0, 61)


def analytic(u, c):
    return c * u + 0.02 * u**2


def test_bounded_fit_recovers_a_parameter(tmp_path):
    target = analytic(GRID, 0.37)
    obj = hcal.HifiObjective(lambda case, p: (GRID, analytic(GRID, p["c"])), [("a", GRID, target, (0.0, 20.0))],
                             fixed={}, names=["c"])
    res = hcal.bounded_fit(obj, "c", (0.0, 1.0), xatol=1e-5, log_path=tmp_path / "log.h5", maxfev=40)
    assert res.x[0] == pytest.approx(0.37, abs=1e-4)
    assert res.nfev == len(res.trace) and res.nfev <= 40


def test_standard_error_of_the_measured_mean(tmp_path):
    """Replicates (1 -+ d) F and F: sample deviation d F, standard error d F / sqrt(3)."""
    from harnesspipe.stages.data import read_prepared
    F = analytic(GRID, 0.4)
    three = read_prepared(write_prepared(tmp_path / "a.h5", "c", F, GRID, scatter=0.1))
    assert np.allclose(three.standard_error(), 0.1 * F / np.sqrt(3.0), rtol=1e-12, atol=1e-12)
    one = read_prepared(write_prepared(tmp_path / "b.h5", "c", F, GRID))
    assert np.all(one.standard_error() == 0.0)


@pytest.mark.parametrize("slope, stops", [(1e-3, True), (50.0, False)])
def test_flat_screen_ends_a_bounded_search_only_on_a_flat_error(tmp_path, slope, stops):
    """Brent's first two points (0.382, 0.618) differ by slope x 0.1 in error: below the
    floor 0.1 the search stops there, keeping the better one; above it, it goes on to the
    minimum."""
    def objective(x):
        return 10.0 + slope * abs(x[0] - 0.45)

    res = hcal.bounded_fit(objective, "mu", (0.0, 1.0), xatol=1e-4, maxfev=40,
                           log_path=tmp_path / "log.h5", stop=hcal.flat_screen(2, 0.1))
    if stops:
        assert res.nfev == 2 and "not identifiable" in res.message and not res.converged
        assert res.x[0] == pytest.approx(0.381966, abs=1e-5) and res.fun == res.trace["error"].min()
    else:
        assert res.nfev > 2 and res.x[0] == pytest.approx(0.45, abs=1e-3)


def test_flat_screen_compares_the_start_with_the_first_points(tmp_path):
    """Brent's first two points straddle the minimum at 0.5 with equal errors, but the start
    (0.05) is far worse: the data tell it apart, so the search goes on to the minimum
    instead of keeping the start; with a flat error everywhere it keeps the start after
    three evaluations (the start first)."""
    def vee(x):
        return 10.0 + 50.0 * abs(x[0] - 0.5)

    res = hcal.bounded_fit(vee, "layers", (0.0, 1.0), xatol=1e-4, maxfev=40,
                           log_path=tmp_path / "v.h5", stop=hcal.flat_screen(3, 0.1), keep=0.05)
    assert res.trace["layers"].iloc[0] == 0.05 and "not identifiable" not in res.message
    assert res.x[0] == pytest.approx(0.5, abs=1e-3) and res.fun == res.trace["error"].min()
    flat = hcal.bounded_fit(lambda x: 10.0 + 1e-4 * x[0], "layers", (0.0, 1.0), xatol=1e-4,
                            maxfev=40, log_path=tmp_path / "f.h5", stop=hcal.flat_screen(3, 0.1),
                            keep=0.05)
    assert flat.nfev == 3 and flat.x[0] == 0.05 and "start value is kept" in flat.message


def test_flat_screen_ends_nelder_mead_after_its_first_simplex(tmp_path):
    """Three parameters: the +5 % simplex is 4 evaluations; a flat error stops it there, a
    rejected point among them does not."""
    flat = hcal.simplex_fit(lambda x: 5.0 + 1e-4 * x.sum(), {"a": 1.0, "b": 2.0, "c": 3.0}, xatol=1e-6,
                            fatol=1e-9, maxfev=50, stop=hcal.flat_screen(4, 0.01))
    assert flat.nfev == 4 and "not identifiable" in flat.message
    assert flat.params() == {"a": 1.0, "b": 2.0, "c": 3.0}        # the lowest error: the start
    rejected = hcal.simplex_fit(lambda x: np.inf if x[0] > 1.01 else 5.0 + 1e-4 * x.sum(),
                                {"a": 1.0, "b": 2.0, "c": 3.0}, xatol=1e-6, fatol=1e-9, maxfev=12,
                                stop=hcal.flat_screen(4, 0.01))
    assert rejected.nfev > 4


@pytest.mark.parametrize("errors, picked", [((10.0, 9.5), 1.0), ((10.0, 9.95), 0.0), ((10.0, 10.5), 0.0),
                                            ((1e9, 12.0), 1.0), ((10.0, 1e9), 0.0)])
def test_a_choice_takes_the_other_value_only_when_the_data_tell_it_better(tmp_path, errors, picked):
    """Start 0 and the other value 1, tie 0.1: 1 wins only by more than the tie (0.5 better:
    yes; 0.05 better, within the uncertainty of the measured mean: the start stays; worse: the
    start stays); a rejected start (the penalty 1e9) gives way, a rejected other value never
    wins.  Both values are logged, the start first, and a rerun on the log replays them."""
    calls = []

    def objective(x):
        calls.append(float(x[0]))
        return errors[int(x[0])]

    log = tmp_path / "choice.h5"
    res = hcal.choice_fit(objective, "binds", [0, 1], keep=0.0, tie=0.1, log_path=log, penalty=1e9)
    assert calls == [0.0, 1.0] and list(res.trace["binds"]) == [0.0, 1.0]
    assert res.x[0] == picked and res.fun == errors[int(picked)] and res.nfev == 2
    again = hcal.choice_fit(objective, "binds", [0, 1], keep=0.0, tie=0.1, log_path=log, penalty=1e9)
    assert calls == [0.0, 1.0] and again.x[0] == picked


def test_the_report_gives_a_choice_step_its_values_errors_and_why():
    """A choice step's block names the values it chose among and says why it kept or
    replaced the start, not a search interval or a convergence status."""
    from harnesspipe.report.html import _step_text
    res = hcal.choice_fit(lambda x: (5.1, 3.2)[int(x[0])], "end_tape_binds", [0, 1], keep=0.0, tie=0.4)
    fit = {"item": "binding", "method": "choice", "cases": ["cwb19_t2_closed"], "window": [0, 30],
           "error_l2": res.fun, "error_rel": 0.1, "nfev": res.nfev, "converged": res.converged,
           "message": res.message, "parameters": res.params(), "choices": [0, 1], "bounds": None}
    text = _step_text(fit, {}, load_config())
    assert "errors 0: 5.1 N, 1: 3.2 N; end_tape_binds 1 beats the start by at least the standard " \
           "error of the measured mean (0.4 N)." in text
    assert "<td>search interval</td><td>one of [0, 1]</td>" in text and "did not converge" not in text


@pytest.mark.parametrize("method, errors, n_names, tie, margin", [
    ("bounded", (6.95, 4.78, 4.91), 1, 2.18, -0.01),    # the fill step of session 38: screened by 0.01 N
    ("bounded", (19.68, 18.90, 18.64, 19.0), 1, 4.38, -3.34),   # its first three only
    ("simplex", (13.0, 13.0, 12.0, 13.5, 11.0), 3, 3.0, -1.5),
    ("choice", (77.55, 27.10), 1, 4.38, 46.07),         # the binding step: 1 picked
    ("choice", (12.73, 14.69), 1, 2.20, -4.16),          # the closure step: the start kept
    ("choice", (5.0, 6.0, 4.0), 1, 0.5, 0.5),            # the best of the others
    ("bounded", (6.95, 4.78), 1, 2.18, None),            # fewer evaluations than the screen's
    ("bounded", (6.95, 1e9, 4.91), 1, 2.18, None),       # a rejected one: the screen does not act
    ("choice", (1e9, 3.0), 1, 2.18, None),               # a rejected start gives way, no threshold
    ("bounded", (6.95, 4.78, 4.91), 1, 0.0, None),       # no screen
])
def test_decision_margin_is_the_distance_of_a_steps_jump_from_its_threshold(method, errors, n_names,
                                                                           tie, margin):
    """A pick switches when the start's error exceeds the best other's by the tie; a search's
    screen keeps the start when its first evaluations spread by less than the tie: the margin
    is the signed distance from that threshold, None where no such decision was made."""
    got = hcal.decision_margin(method, errors, n_names, tie, penalty=1e9)
    assert got == (None if margin is None else pytest.approx(margin, abs=1e-9))


@pytest.mark.parametrize("method,n_names,errors", [
    ("bounded", 1, (6.95, 4.78, 4.91)), ("bounded", 1, (6.95, 4.78, 4.75)),
    ("simplex", 3, (3.0, 3.0, 3.0, 3.0)), ("simplex", 2, (9.0, 5.0, 7.0)),
])
def test_the_screen_stops_a_search_exactly_when_its_decision_margin_is_negative(method, n_names,
                                                                               errors):
    """The screen and the margin read the same first evaluations (hcal.screen_size): a search
    the screen ends has a negative margin, one it lets run a positive margin."""
    tie = 2.18
    n_first = hcal.screen_size(method, n_names)
    rows = [((0.0,) * n_names, e) for e in errors[:n_first]]
    stopped = hcal.flat_screen(n_first, tie)(rows) is not None
    assert stopped == (hcal.decision_margin(method, errors, n_names, tie) < 0.0)


def test_screen_size_refuses_a_pick():
    with pytest.raises(ValueError, match="choice"):
        hcal.screen_size("choice", 1)


def _pick_of(trace, tie, names, penalty=np.inf):
    """The weighted mean of a trace's rows before the last (the pick's own evaluation)."""
    rows = trace.iloc[:-1]
    e = rows["error"].to_numpy()
    ok = np.isfinite(e) & (e < penalty)
    w = np.where(ok, np.exp(-0.5 * (np.minimum((e - e[ok].min()) / tie, 40.0)) ** 2), 0.0)
    return (w[:, None] * rows[names].to_numpy()).sum(axis=0) / w.sum()


def test_a_search_rests_at_the_weighted_mean_of_its_evaluations(tmp_path):
    """A valley flat within 1e-6 over 0.3..0.7 (the data cannot tell those apart) tilted
    towards 0.3: Brent alone ends near 0.3, a threshold pick would take any of the flat
    points.  With a tie of 0.01 (the measured mean's uncertainty) the search rests at the
    mean of its evaluations weighted by exp(-((e - e_min)/tie)^2/2) -- inside the flat part,
    evaluated there and logged as its last row -- and says so; Nelder-Mead likewise."""
    def valley(x):
        return 10.0 + 1e-6 * x[0] + 50.0 * max(abs(x[0] - 0.5) - 0.2, 0.0) ** 2

    bare = hcal.bounded_fit(valley, "T", (0.0, 1.0), xatol=1e-5, maxfev=60, keep=0.95)
    assert bare.x[0] < 0.35 and bare.nfev == len(bare.trace)
    # no tie: the best logged point, the start included (evaluated before Brent's own points)
    at_start = hcal.bounded_fit(lambda x: (x[0] - 0.95) ** 2, "T", (0.0, 1.0), xatol=0.1, maxfev=3,
                                keep=0.95)
    assert (at_start.x[0], at_start.fun) == (0.95, 0.0)
    tied = hcal.bounded_fit(valley, "T", (0.0, 1.0), xatol=1e-5, maxfev=60, keep=0.95, tie=0.01,
                            log_path=tmp_path / "brent.h5")
    assert tied.x[0] == pytest.approx(_pick_of(tied.trace, 0.01, ["T"])[0], rel=1e-12)
    assert 0.3 < tied.x[0] < 0.7 and "weighted by" in tied.message
    assert (tied.trace["T"].iloc[-1], tied.trace["error"].iloc[-1]) == (tied.x[0], tied.fun)
    assert tied.fun == valley(tied.x)

    def bowl(x):
        return 5.0 + float(np.sum((x - np.array([2.0, 1.0])) ** 2))

    simplex = hcal.simplex_fit(bowl, {"a": 1.0, "b": 2.0}, xatol=1e-6, fatol=1e-9, maxfev=200,
                               keep_start=True, tie=0.5)
    np.testing.assert_allclose(simplex.x, _pick_of(simplex.trace, 0.5, ["a", "b"]), rtol=1e-12)
    np.testing.assert_array_equal(simplex.trace[["a", "b"]].iloc[-1], simplex.x)
    assert simplex.fun == bowl(simplex.x) < 5.0 + 0.5      # near the minimum, off it by the flat
    # the rest is replayed from the log on a rerun, not run again
    calls = []
    again = hcal.bounded_fit(lambda x: calls.append(1) or valley(x), "T", (0.0, 1.0), xatol=1e-5,
                             maxfev=60, keep=0.95, tie=0.01, log_path=tmp_path / "brent.h5")
    assert calls == [] and again.x[0] == tied.x[0] and again.fun == tied.fun


def test_failed_run_is_a_logged_rejected_point(tmp_path):
    calls = []

    def simulate(case, p):
        calls.append(p["c"])
        if p["c"] > 0.5:
            raise RuntimeError("explicit run stopped: unstable")
        return GRID, analytic(GRID, p["c"])

    target = analytic(GRID, 0.2)
    obj = hcal.HifiObjective(simulate, [("a", GRID, target, (0.0, 30.0))], fixed={"mu_rtp": 0.1}, names=["c"],
                             rejected_log=tmp_path / "rejected.jsonl", key="k1")
    res = hcal.bounded_fit(obj, "c", (0.0, 1.0), xatol=1e-4, maxfev=40)
    assert res.x[0] == pytest.approx(0.2, abs=1e-3)             # the fit went on
    rejected = hcal.read_rejected(tmp_path / "rejected.jsonl")
    assert rejected and len(rejected) == sum(c > 0.5 for c in calls) == obj.n_rejected
    assert all(r["parameters"]["c"] > 0.5 and r["parameters"]["mu_rtp"] == 0.1 for r in rejected)
    assert all("unstable" in r["reason"] and r["key"] == "k1" and r["case"] == "a" for r in rejected)
    assert np.isfinite(obj.penalty) and obj.penalty > 0
    assert hcal.read_rejected(tmp_path / "rejected.jsonl", key="other") == []


def test_inadmissible_cohesive_point_is_rejected_not_run(tmp_path):
    obj = hcal.HifiObjective(lambda case, p: pytest.fail("must not run"), [("a", GRID, GRID, (0.0, 30.0))],
                             fixed={"delta0": 0.05}, names=["delta_f"], rejected_log=tmp_path / "r.jsonl")
    assert obj(np.array([0.04])) == obj.penalty
    assert "inadmissible" in hcal.read_rejected(tmp_path / "r.jsonl")[0]["reason"]


def test_curve_short_of_the_window_is_rejected_slightly_short_is_not():
    F = analytic(GRID, 0.3)
    u = np.linspace(0.0, 29.8, 300)                   # the run stopped 0.2 mm short of 30 mm
    assert hcal.curve_error(u, analytic(u, 0.3), GRID, F, (20.0, 30.0)) < 0.5   # end value held
    with pytest.raises(hcal.RejectedRun):
        hcal.curve_error(GRID[GRID <= 25.0], F[GRID <= 25.0], GRID, F, (20.0, 30.0))


@pytest.mark.parametrize("method", ["bounded", "simplex"])
def test_interrupted_fit_is_replayed_without_simulating(tmp_path, method):
    target = analytic(GRID, 0.37)
    calls = []

    def simulate(case, p):
        calls.append(p["c"])
        if len(calls) == 6 and interrupt[0]:
            raise KeyboardInterrupt  # the job is killed mid-fit
        return GRID, analytic(GRID, p["c"])

    def fit():
        obj = hcal.HifiObjective(simulate, [("a", GRID, target, (0.0, 30.0))], fixed={}, names=["c"])
        if method == "bounded":
            return hcal.bounded_fit(obj, "c", (0.0, 1.0), xatol=1e-4, log_path=tmp_path / "log.h5",
                                    key="k", maxfev=30)
        return hcal.simplex_fit(obj, {"c": 0.5}, xatol=1e-4, fatol=1e-8, maxfev=30,
                                log_path=tmp_path / "log.h5", key="k")

    interrupt = [True]
    with pytest.raises(KeyboardInterrupt):
        fit()
    assert len(calls) == 6
    interrupt[0] = False
    first = fit()
    assert len(calls) - 6 == first.nfev - 5          # the 5 logged evaluations were replayed
    n = len(calls)
    again = fit()                                     # a complete log: nothing is simulated
    assert len(calls) == n and again.nfev == first.nfev
    assert again.x[0] == first.x[0] and again.x[0] == pytest.approx(0.37, abs=1e-3)


# --------------------------------------------------------------------------- stages/hifi_chain.py

MODEL = {"cases": {"cwb19_t2_closed": {"covering": "closed_tube"}, "cwb19_t2_fabric": {"covering": "fabric_tube"}},
         "hifi": {}}


def test_fit_step_and_interface_table(tmp_path, fake):
    u = np.linspace(0.0, 30.0, 101)
    truth = dict(fake.TRUTH)
    refs = {"cwb19_t2_closed": write_prepared(tmp_path / "closed.h5", "cwb19_t2_closed",
                                              fake.force(u, truth, "closed_tube"), u)}
    settings = {"names": ["mu_rtb"], "cases": ["cwb19_t2_closed"], "window": [0.0, 20.0], "method": "bounded",
                "bounds": [0.0, 0.6], "xatol": 1e-4, "fatol": None, "maxfev": 30,
                "start": {"mu_rtb": 0.2, "mu_rtp": 0.1, "delta0": 0.05, "delta_f": 0.1, "alpha_d": 1.0},
                "models": {"cwb19_t2_closed": MODEL}, "set": {}}
    out = tmp_path / "mu_rtb"
    fit = hifi_chain.fit_step("mu_rtb", settings, refs, out, runner=runner_of(fake))
    assert fit["parameters"]["mu_rtb"] == pytest.approx(0.3, abs=1e-3)
    assert fit["interface"]["mu_rtp"] == 0.1 and fit["role"] == "calibration"
    rejected = hcal.read_rejected(out / "rejected.jsonl")   # the fake is unstable above mu 0.36
    assert fit["rejected"] == len(rejected) > 0
    for name in ("fit.json", "curve.csv", "trace.h5", "rejected.jsonl", "fit.png",
                 "cwb19_t2_closed/summary.json", "cwb19_t2_closed/energies.csv", "cwb19_t2_closed/curve.csv"):
        assert (out / name).exists(), name
    assert list(pd.read_csv(out / "curve.csv").columns) == ["case", "displacement_mm", "force_N"]
    with h5py.File(out / "trace.h5") as f:
        assert f["error"].shape[0] == fit["nfev"]

    # a rerun replays the log (no new simulation), priors feed the next step
    calls = []
    counting = lambda *a: calls.append(a) or runner_of(fake)(*a)  # noqa: E731
    again = hifi_chain.fit_step("mu_rtb", settings, refs, out, runner=counting)
    assert again["parameters"] == fit["parameters"]
    assert len(calls) == 1                         # only the best point's artefacts are run again
    assert len(hcal.read_rejected(out / "rejected.jsonl")) == fit["rejected"]   # not duplicated

    refs["cwb19_t2_fabric"] = write_prepared(tmp_path / "fabric.h5", "cwb19_t2_fabric",
                                             fake.force(u, truth, "fabric_tube"), u)
    fab = {**settings, "names": ["E2_over_E1"], "cases": ["cwb19_t2_fabric"], "window": [0.0, 30.0],
           "bounds": [0.2, 1.2], "start": {"mu_rtp": 0.1, "delta0": 0.03, "delta_f": 0.08, "alpha_d": 2.0,
                                            "E2_over_E1": 1.0},
           "models": {"cwb19_t2_fabric": MODEL}}
    fit2 = hifi_chain.fit_step("fabric", fab, refs, tmp_path / "fabric", priors=[out / "fit.json"],
                               runner=runner_of(fake))
    assert fit2["parameters"]["E2_over_E1"] == pytest.approx(0.6, abs=1e-3)
    assert fit2["interface"]["mu_rtb"] == fit["parameters"]["mu_rtb"]

    coh = tmp_path / "cohesive" / "fit.json"
    coh.parent.mkdir()
    coh.write_text(json.dumps({"item": "cohesive", "parameters": {"delta0": 0.03, "delta_f": 0.08, "alpha_d": 2.0}}))
    rtp = tmp_path / "rtp.json"
    rtp.write_text(json.dumps({"item": "mu_rtp", "parameters": {"mu_rtp": 0.1}}))
    table = hifi_chain.interface_table([out / "fit.json", rtp, coh, tmp_path / "fabric" / "fit.json"],
                                       tmp_path / "interface.csv")
    assert list(table["parameter"]) == list(hifi_chain.INTERFACE)
    assert list(pd.read_csv(tmp_path / "interface.csv").columns) == ["parameter", "value"]


@pytest.mark.parametrize("scatter, flat_factor, screened", [(0.2, 1.0, True), (0.05, 1.0, False),
                                                            (0.2, 0.0, False)])
def test_fit_step_screens_against_the_scatter_of_the_measured_mean(tmp_path, fake, scatter,
                                                                   flat_factor, screened):
    """mu_rtb in [0, 0.3]: Brent's first points move the fake's error by 0.14 ||u||; three
    replicates +-20 % put the standard error of the mean at 0.22 ||u||: not identifiable,
    the step ends after 2 evaluations and says so; +-5 % (0.055 ||u||) or the screen off
    (flat_factor 0): the search goes on, to the bound 0.3 -- with the screen on it rests at
    the mean of its evaluations weighted on the scale 0.055 ||u||, below the bound, and
    evaluates it as its last logged point."""
    u = np.linspace(0.0, 30.0, 101)
    refs = {"cwb19_t2_closed": write_prepared(tmp_path / "closed.h5", "cwb19_t2_closed",
                                              fake.force(u, fake.TRUTH, "closed_tube"), u, scatter=scatter)}
    settings = {"names": ["mu_rtb"], "cases": ["cwb19_t2_closed"], "window": [0.0, 20.0], "method": "bounded",
                "bounds": [0.0, 0.3], "xatol": 1e-3, "fatol": None, "maxfev": 30, "flat_factor": flat_factor,
                "start": {"mu_rtb": 0.2, "mu_rtp": 0.1, "delta0": 0.05, "delta_f": 0.1,
                          "alpha_d": 1.0},
                "models": {"cwb19_t2_closed": MODEL}, "set": {}}
    fit = hifi_chain.fit_step("mu_rtb", settings, refs, tmp_path / "fit", runner=runner_of(fake))
    assert (fit["nfev"] == 3) == screened           # the start, then the two golden-section points
    assert ("not identifiable" in fit["message"]) == screened
    with h5py.File(tmp_path / "fit" / "trace.h5") as f:      # the screen's decision and its margin
        first = f["error"][:3]
    d = fit["decision"]
    assert d["margin_N"] == pytest.approx(first.max() - first.min() - d["threshold_N"]) if flat_factor else \
        d["margin_N"] is None
    assert (d["margin_N"] is not None and d["margin_N"] < 0) == screened and not d["marginal"]
    if screened:     # a near tie is no choice: the start value, exactly, and the message says so
        assert fit["parameters"]["mu_rtb"] == 0.2 and "start value is kept" in fit["message"]
    elif flat_factor == 0.0:
        assert fit["parameters"]["mu_rtb"] == pytest.approx(0.3, abs=2e-3)
    else:            # the search went to the bound; it rests at the weighted pick, run there
        assert 0.2 < fit["parameters"]["mu_rtb"] < 0.3 - 2e-3 and "weighted by" in fit["message"]
        with h5py.File(tmp_path / "fit" / "trace.h5") as f:
            assert f["x"][-1, 0] == fit["parameters"]["mu_rtb"] and f["x"].shape[0] == fit["nfev"]


@pytest.mark.parametrize("bits_spread", [0.0, 1.0])
def test_fit_step_flags_a_decision_within_the_runs_last_bits_spread(tmp_path, fake, bits_spread):
    """The screened step above (margin about -0.08 ||u||) with ``bits_spread`` the whole
    measured norm: its decision is within the spread, flagged in fit.json and its message;
    with none it is not."""
    u = np.linspace(0.0, 30.0, 101)
    refs = {"cwb19_t2_closed": write_prepared(tmp_path / "closed.h5", "cwb19_t2_closed",
                                              fake.force(u, fake.TRUTH, "closed_tube"), u, scatter=0.2)}
    settings = {"names": ["mu_rtb"], "cases": ["cwb19_t2_closed"], "window": [0.0, 20.0], "method": "bounded",
                "bounds": [0.0, 0.3], "xatol": 1e-3, "fatol": None, "maxfev": 30, "flat_factor": 1.0,
                "bits_spread": bits_spread,
                "start": {"mu_rtb": 0.2, "mu_rtp": 0.1, "delta0": 0.05, "delta_f": 0.1, "alpha_d": 1.0},
                "models": {"cwb19_t2_closed": MODEL}, "set": {}}
    fit = hifi_chain.fit_step("mu_rtb", settings, refs, tmp_path / "fit", runner=runner_of(fake))
    d = fit["decision"]
    assert d["margin_N"] < 0 and d["marginal"] == (bits_spread > 0)
    assert d["bits_spread_N"] == pytest.approx(bits_spread * fit["error_l2"] / fit["error_rel"])
    assert ("marginal: this decision lies" in fit["message"]) == (bits_spread > 0)
    assert fit["parameters"]["mu_rtb"] == 0.2          # the flag says; it changes nothing


def test_flat_screen_is_not_fooled_by_rejected_points():
    """Rejected runs score the objective's penalty: two of them are no flat error."""
    penalty = 1e3
    res = hcal.bounded_fit(lambda x: penalty if x[0] > 0.36 else 10.0 + x[0], "mu", (0.3, 0.6),
                           xatol=1e-3, maxfev=20, stop=hcal.flat_screen(2, 1.0, penalty))
    assert res.trace["error"].iloc[:2].tolist() == [penalty, penalty]
    assert res.nfev > 2 and "not identifiable" not in res.message


def test_cohesive_simplex_step_on_two_cases(tmp_path, fake):
    """The cohesive step's simplex on two cases of the analytic model: of its three
    parameters only the combination s = 10 delta0 + 5 delta_f + 0.05 alpha_d acts on the
    curve (the truth's 0.8, the start's 1.05); the fit recovers s and the curve."""
    u = np.linspace(0.0, 30.0, 101)
    truth = {**fake.TRUTH}
    refs = {c: write_prepared(tmp_path / f"{c}.h5", c, fake.force(u, truth, "closed_tube"), u)
            for c in ("cwb19_t2_closed", "cwb19_t2_open_halflap")}
    model = {"cases": {c: {"covering": "closed_tube"} for c in refs}, "hifi": {}}
    settings = {"names": ["delta0", "delta_f", "alpha_d"], "cases": list(refs), "window": [20.0, 30.0],
                "method": "simplex", "bounds": None, "xatol": 1e-3, "fatol": 1e-4, "maxfev": 60,
                "start": {"mu_rtb": 0.3, "mu_rtp": 0.1, "delta0": 0.05, "delta_f": 0.1, "alpha_d": 1.0},
                "models": {c: model for c in refs}, "set": {}}
    fit = hifi_chain.fit_step("cohesive", settings, refs, tmp_path / "cohesive", runner=runner_of(fake))
    p = fit["parameters"]
    assert 10.0 * p["delta0"] + 5.0 * p["delta_f"] + 0.05 * p["alpha_d"] == pytest.approx(0.8, rel=1e-3)
    assert fit["error_rel"] < 1e-3 and fit["nfev"] <= 60
    assert p["delta_f"] > p["delta0"]
    assert sorted(pd.read_csv(tmp_path / "cohesive" / "curve.csv")["case"].unique()) == sorted(refs)


SOFT = {"delta0": 0.008, "delta_f": 0.016, "alpha_d": 1.0}   # a truth that debonds early


@pytest.mark.parametrize("separation, power, truth, outcome", [
    (0.01, 1.0, {}, "kept"),          # ties below delta0 (0.05); debonding at the probe fits worse
    (0.01, 3.0, {}, "kept"),          # ... ties opening late: the probe's floor, half the largest
    (0.01, 1.0, SOFT, "probed"),      # the probe fits better: the search starts there
    (0.06, 1.0, {}, "searched"),      # a tie past delta0 at the start: damage acts, search on
])
def test_cohesive_fit_asks_the_data_whether_the_ties_debond(tmp_path, fake, separation, power, truth,
                                                              outcome):
    """Ties below delta0 in the first evaluation: the curve cannot depend on delta0, delta_f,
    alpha there, so the step runs a probe at delta0 = the opening at the window's start, 20 mm
    (2/3 of the largest for ties opening in step with the stroke; half the largest at least,
    for ties opening late: 0.3 of it at 20 mm), delta_f at the start's ratio, and keeps the
    start unless the probe is lower by the tie; a probe
    that is lower starts the simplex; a tie past delta0 starts the simplex at once.  No
    evaluation is run twice."""
    u = np.linspace(0.0, 30.0, 101)
    truth = {**fake.TRUTH, **truth}
    refs = {c: write_prepared(tmp_path / f"{c}.h5", c, fake.force(u, truth, "closed_tube"), u, scatter=0.02)
            for c in ("cwb19_t2_closed", "cwb19_t2_open_halflap")}
    model = {"cases": {c: {"covering": "closed_tube"} for c in refs}, "hifi": {}}
    start = {"mu_rtb": 0.3, "mu_rtp": 0.1, "delta0": 0.05, "delta_f": 0.1, "alpha_d": 1.0}
    settings = {"names": ["delta0", "delta_f", "alpha_d"], "cases": list(refs), "window": [20.0, 30.0],
                "method": "simplex", "bounds": None, "xatol": 1e-3, "fatol": 1e-4, "maxfev": 30,
                "start": start, "models": {c: model for c in refs}, "flat_factor": 1.0,
                "set": {"fake_tie_separation": separation, "fake_tie_power": power}}
    calls = []
    counting = lambda *a: calls.append(a) or runner_of(fake)(*a)  # noqa: E731
    fit = hifi_chain.fit_step("cohesive", settings, refs, tmp_path / "cohesive", runner=counting)
    assert len(calls) == 2 * fit["nfev"]          # every evaluation ran once, the probe too
    trace = hcal_trace(tmp_path / "cohesive" / "trace.h5")
    assert len(trace) == fit["nfev"] and fit["hifi_runs"] == len(calls)   # each one recorded and counted
    assert trace["delta0"].iloc[0] == 0.05          # the start first
    if outcome == "kept":
        assert fit["nfev"] == 2 and not fit["converged"]
        assert fit["parameters"] == {k: start[k] for k in settings["names"]}
        assert "not identifiable" in fit["message"] and "0.01 mm" in fit["message"]
        probe = "0.00667" if power == 1.0 else "0.005"
        assert f"delta0 {probe} mm" in fit["message"] and fit["decision"]["margin_N"] < 0.0
    elif outcome == "probed":
        assert "searched from there" in fit["message"] and fit["nfev"] > 2
        assert fit["parameters"]["delta0"] < 0.02      # from the probe (0.0067), not the start
        assert trace["delta0"].iloc[1] == pytest.approx(0.01 * 20.0 / 30.0)   # then the search from the probe
    else:
        assert fit["nfev"] >= 4 and "damage onset" not in fit["message"]   # the +5 % simplex at least


def hcal_trace(path: Path) -> pd.DataFrame:
    """A fit's trace.h5 (its evaluations in order) as a frame."""
    with h5py.File(path, "r") as f:
        names = [n.decode() if isinstance(n, bytes) else n for n in f.attrs["names"]]
        x = f["x"][...]
        return pd.DataFrame({n: x[:, i] for i, n in enumerate(names)} | {"error": f["error"][...]})


def test_cohesive_cases_side_by_side_match_serial(tmp_path, fake):
    """workers=2: the two cases of each evaluation run in worker processes; same search,
    same result, and the rejected points are still logged."""
    u = np.linspace(0.0, 30.0, 101)
    refs = {c: write_prepared(tmp_path / f"{c}.h5", c, fake.force(u, fake.TRUTH, "closed_tube"), u)
            for c in ("cwb19_t2_closed", "cwb19_t2_open_halflap")}
    model = {"cases": {c: {"covering": "closed_tube"} for c in refs}, "hifi": {}}
    settings = {"names": ["mu_rtb"], "cases": list(refs), "window": [0.0, 20.0], "method": "bounded",
                "bounds": [0.0, 0.6], "xatol": 1e-3, "fatol": None, "maxfev": 20,
                "start": {"mu_rtb": 0.2, "mu_rtp": 0.1, "delta0": 0.05, "delta_f": 0.1, "alpha_d": 1.0},
                "models": {c: model for c in refs}, "set": {}}
    serial = hifi_chain.fit_step("mu_rtb", settings, refs, tmp_path / "serial", runner=fake.runner)
    pooled = hifi_chain.fit_step("mu_rtb", settings, refs, tmp_path / "pooled", runner=fake.runner, workers=2)
    assert pooled["parameters"] == serial["parameters"]
    assert pooled["parameters"]["mu_rtb"] == pytest.approx(0.3, abs=2e-3)
    assert pooled["nfev"] == serial["nfev"] and pooled["rejected"] == serial["rejected"] > 0
    for case in refs:
        summary = json.loads((tmp_path / "pooled" / case / "summary.json").read_text())
        assert summary["pid"] != os.getpid()       # the best point's run came from a worker


def test_core_share():
    assert [hifi_chain.core_share(2, n, 8) for n in (0, 1, 2, 3)] == [2, 2, 1, 1]
    assert hifi_chain.core_share(8, 2, 3) == 3          # no more than Numba's threads
    assert hifi_chain.core_share(6, 4, 8) == 1


def test_a_run_left_alone_takes_the_pools_cores(monkeypatch):
    """A case worker's run counts itself among the pool's runs in progress and, at each
    history row, takes its share of the cores: both once its partner is done, one while
    another run goes on; back to one thread when it ends."""
    import multiprocessing

    import numba
    running = multiprocessing.Value("i", 0)
    monkeypatch.setattr(hifi_chain, "_CORES", (running, 2))
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        with hifi_chain._shared_cores() as share:
            assert running.value == 1
            share(step=1)
            assert numba.get_num_threads() == min(2, numba.config.NUMBA_NUM_THREADS)
            running.value += 1                       # a partner's run starts
            share(step=2)
            assert numba.get_num_threads() == 1
        assert running.value == 1 and numba.get_num_threads() == 1
    finally:
        numba.set_num_threads(before)


POOL_OWNER = """
import os, sys, time
from harnesspipe.stages import hifi_chain
with hifi_chain._case_pool(2, 2) as pool:
    pids = {pool.submit(os.getpid).result() for _ in range(8)}
    print(*sorted(pids), flush=True)
    time.sleep(600)
"""


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie waiting for a reaper does not count)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_case_workers_end_with_a_killed_fit():
    """A fit process killed outright (SIGKILL: no cleanup of its own runs) takes its
    case workers with it within a few poll periods; they do not run on as orphans."""
    owner = subprocess.Popen([sys.executable, "-c", POOL_OWNER], stdout=subprocess.PIPE, text=True)
    try:
        workers = [int(p) for p in owner.stdout.readline().split()]
        assert workers and all(_alive(p) for p in workers)
    finally:
        owner.kill()
        owner.wait()
    deadline = time.monotonic() + 20 * hifi_chain.PARENT_POLL_S
    while any(_alive(p) for p in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_alive(p) for p in workers), "case workers outlived the killed fit"


def test_run_case_writes_artefacts_and_error(tmp_path, fake):
    u = np.linspace(0.0, 30.0, 101)
    ref = write_prepared(tmp_path / "r.h5", "cwb19_t2_closed", fake.force(u, fake.TRUTH, "closed_tube"), u)
    fit = tmp_path / "fit.json"
    fit.write_text(json.dumps({"interface": dict(fake.TRUTH)}))
    s = hifi_chain.run_case("cwb19_t2_closed", {"model": MODEL, "interface": {"mu_rtb": 0.0}}, tmp_path / "v",
                            interface_fit=fit, reference=ref, role="validation", runner=runner_of(fake))
    assert s["interface"]["mu_rtb"] == 0.3 and s["role"] == "validation"
    assert s["measured"]["error_rel"] < 1e-3          # interpolation only
    assert list(pd.read_csv(tmp_path / "v" / "curve.csv").columns) == ["deflection_mm", "force_N"]
    assert (tmp_path / "v" / "energies.csv").exists()


def test_a_step_takes_the_run_an_earlier_step_made_at_its_start(tmp_path, fake):
    """A step starts where the previous one rested (its start values are the priors' picks):
    that run, the same run_key, is taken from the earlier step's folder, not run again; with
    any difference (here a --set key) it runs."""
    u = np.linspace(0.0, 30.0, 101)
    refs = {"cwb19_t2_closed": write_prepared(tmp_path / "closed.h5", "cwb19_t2_closed",
                                              fake.force(u, fake.TRUTH, "closed_tube"), u)}
    base = {"cases": ["cwb19_t2_closed"], "window": [0.0, 30.0], "method": "bounded", "xatol": 1e-3,
            "fatol": None, "maxfev": 12, "models": {"cwb19_t2_closed": MODEL}, "set": {},
            "start": {"mu_rtb": 0.2, "mu_rtp": 0.2, "delta0": 0.05, "delta_f": 0.1, "alpha_d": 1.0}}
    first = hifi_chain.fit_step("mu_rtb", {**base, "names": ["mu_rtb"], "bounds": [0.0, 0.35]}, refs,
                                tmp_path / "a", runner=runner_of(fake))
    calls = []
    counting = lambda *a: calls.append(a) or runner_of(fake)(*a)  # noqa: E731
    prior = [tmp_path / "a" / "fit.json"]
    second = hifi_chain.fit_step("mu_rtp", {**base, "names": ["mu_rtp"], "bounds": [0.0, 0.6]}, refs,
                                 tmp_path / "b", priors=prior, runner=counting)
    assert second["hifi_runs_reused"] == 1 and len(calls) == second["nfev"] - 1
    with h5py.File(tmp_path / "b" / "trace.h5") as f:    # its first evaluation: the earlier pick's run,
        assert f["x"][0, 0] == 0.2                         # its curve as written (8 digits)
        assert f["error"][0] == pytest.approx(first["error_l2"], rel=1e-7)
    alone = tmp_path / "alone" / "fit.json"      # the same prior without its runs: all run anew
    alone.parent.mkdir()
    shutil.copyfile(prior[0], alone)
    fresh = hifi_chain.fit_step("mu_rtp", {**base, "names": ["mu_rtp"], "bounds": [0.0, 0.6]}, refs,
                                tmp_path / "b2", priors=[alone], runner=runner_of(fake))
    assert fresh["hifi_runs_reused"] == 0
    assert second["parameters"]["mu_rtp"] == pytest.approx(fresh["parameters"]["mu_rtp"], rel=1e-6)
    calls.clear()
    third = hifi_chain.fit_step("mu_rtp", {**base, "names": ["mu_rtp"], "bounds": [0.0, 0.6], "set": {"x": 1}},
                                refs, tmp_path / "c", priors=prior, runner=counting)
    assert third["hifi_runs_reused"] == 0 and len(calls) == third["nfev"]


def test_virtual_test_reuses_the_fits_run_only_when_it_is_the_same_run(tmp_path, fake):
    """A virtual test at the interface a fit just ran on its whole stroke takes that run
    (same run_key: model, interface, --set, coverings); any difference runs it anew."""
    u = np.linspace(0.0, 30.0, 101)
    ref = write_prepared(tmp_path / "r.h5", "cwb19_t2_fabric", fake.force(u, fake.TRUTH, "fabric_tube"), u)
    model = {"cases": {"cwb19_t2_fabric": {"covering": "fabric_tube"}}, "hifi": {}}
    settings = {"names": ["E2_over_E1"], "cases": ["cwb19_t2_fabric"], "window": [0.0, 30.0],
                "method": "bounded", "bounds": [0.2, 1.2], "xatol": 1e-2, "fatol": None, "maxfev": 12,
                "start": {**fake.TRUTH, "E2_over_E1": 1.0},
                "models": {"cwb19_t2_fabric": model}, "set": {}}
    fit_dir = tmp_path / "fabric"
    hifi_chain.fit_step("fabric", settings, {"cwb19_t2_fabric": ref}, fit_dir, runner=runner_of(fake))
    calls = []
    counting = lambda *a: calls.append(a) or runner_of(fake)(*a)  # noqa: E731
    virtual = {"model": model, "interface": {}, "set": {}}
    s = hifi_chain.run_case("cwb19_t2_fabric", virtual, tmp_path / "v", interface_fit=fit_dir / "fit.json",
                            reference=ref, runner=counting, reuse=fit_dir / "cwb19_t2_fabric")
    assert calls == [] and s["reused_from"] == str(fit_dir / "cwb19_t2_fabric")
    best = pd.read_csv(fit_dir / "cwb19_t2_fabric" / "curve.csv")
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "v" / "curve.csv"), best)
    assert s["measured"]["error_rel"] < 0.05 and (tmp_path / "v" / "energies.csv").exists()
    for changed in ({**virtual, "set": {"t_total": 0.5}}, {**virtual, "interface": {"mu_rtb": 0.2}}):
        s = hifi_chain.run_case("cwb19_t2_fabric", {**changed}, tmp_path / "w", runner=counting,
                                interface_fit=None if changed["interface"] else fit_dir / "fit.json",
                                reuse=fit_dir / "cwb19_t2_fabric")
        assert "reused_from" not in s
    assert len(calls) == 2


def test_hifi_report_section(tmp_path, fake):
    from harnesspipe import config as cfgmod
    from harnesspipe.report.html import COHESIVE_MESH_NOTE, _measured_by_case, hifi_section
    cfg = cfgmod.load()
    assert "No hi-fi results yet" in hifi_section(tmp_path, cfg, {})
    u = np.linspace(0.0, 30.0, 101)
    ref = write_prepared(tmp_path / "r.h5", "cwb19_t2_closed", fake.force(u, fake.TRUTH, "closed_tube"), u)
    hifi_chain.run_case("cwb19_t2_closed", {"model": MODEL, "interface": dict(fake.TRUTH)},
                        tmp_path / "hifi" / "virtual" / "cwb19_t2_closed", reference=ref, runner=runner_of(fake))
    (tmp_path / "hifi" / "interface.csv").write_text(
        "parameter,value\n" + "".join(f"{k},{v}\n" for k, v in fake.TRUTH.items()))
    for item in ("mu_rtb", "cohesive"):        # two chain steps; only the cohesive one has the note
        step = tmp_path / "hifi" / "chain" / item
        step.mkdir(parents=True)
        (step / "fit.json").write_text(json.dumps(
            {"item": item, "method": "test", "cases": [], "window": [0.0, 30.0], "error_l2": 0.1,
             "error_rel": 0.01, "nfev": 1, "converged": True, "parameters": {"mu_rtb": 0.3}}))
        (step / "curve.csv").write_text("case,deflection_mm,force_N\n")
    page = hifi_section(tmp_path, cfg, _measured_by_case([ref]))
    assert "virtual test: 19 x type 2, closed tube (cwb19_t2_closed)" in page and "Calibrated interface" in page
    for key in cfg["hifi"]["build"]:        # the build inputs the chain does not fit: their config value
        assert f"<td>{key}</td>" in page
    assert "Cost" in page
    assert page.count("data:image/png;base64,") >= 2 and "281 min" in page
    cohesive = page.index("Calibration step cohesive")
    assert page.count(COHESIVE_MESH_NOTE) == 1 and page.index(COHESIVE_MESH_NOTE) > cohesive


# --------------------------------------------------------------------------- the rules

LAUNCHER = '''
"""harnesspipe with the hi-fi model and the ROM fit replaced by cheap stand-ins (tests only)."""
import sys, types
sys.path.insert(0, {fake_dir!r})
import numpy as np
import pandas as pd
import fake_hifi_model
from harnesspipe.stages import hifi_chain

hifi_chain.default_runner = lambda cfg, case, overrides, table2: fake_hifi_model.run(
    cfg, case, cfg["hifi"]["parameters"], overrides)

def rom_fit(u, F, settings, log_path):
    from harnesspipe.calibrate.simplex import EvaluationLog
    log = EvaluationLog(log_path, ["E"], "")
    log.append(np.array([1.0]), 0.0, 0.0)
    res = types.SimpleNamespace(nfev=1, converged=True)
    return types.SimpleNamespace(parameters={{"E": 20.0, "sigma_y": 0.5, "K": 2.0, "n": 0.3}},
                                 E_eq13=20.0, sigma_y_eq13=0.5, result=res, nfev=1)

hifi_chain._rom_fit = rom_fit
hifi_chain._rom_simulate = lambda p, s: pd.DataFrame({{"deflection_mm": [0.0, 30.0], "force_N": [0.0, 10.0]}})
if __name__ == "__main__":     # spawned workers of a fit import this file (with its patches)
    from harnesspipe.cli import main
    sys.exit(main(sys.argv[1:]))
'''


def snakemake(project: Path, *args: str, config=()) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(project / "src")}
    return subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", *args,
                           "--config", "profile=quick", *config],
                          cwd=project, env=env, capture_output=True, text=True)


planned = job_stats      # rule -> job count of a dry run (conftest)


def planned_wildcards(run: subprocess.CompletedProcess) -> set[str]:
    return set(re.findall(r"wildcards: (\S+)", run.stdout + run.stderr))


@pytest.fixture(scope="module")
def project(tmp_path_factory, fake):
    """A project copy whose upstream results (data, Table 2) exist and whose hifi rules ran
    with the stand-ins, so that Snakemake holds their params metadata."""
    root = tmp_path_factory.mktemp("hifi_rules")
    project = copy_project(root / "project")
    fake_dir = Path(fake.__file__).parent
    launcher = project / "fake_hp.py"
    launcher.write_text(LAUNCHER.format(fake_dir=str(fake_dir)))
    snakefile = project / "Snakefile"
    text = snakefile.read_text()
    assert "HP = f'\"{PY}\" -m harnesspipe'" in text
    snakefile.write_text(text.replace("HP = f'\"{PY}\" -m harnesspipe'", f"HP = f'\"{{PY}}\" {launcher}'"))
    # upstream outputs without running their (slow) rules: files present, then touched in DAG order
    run = snakemake(project, "--summary", "hifi_chain_all", "hifi_crosscheck_all")
    assert run.returncode == 0, run.stderr[-3000:]
    upstream = []
    for line in run.stdout.splitlines()[1:]:
        cols = line.split("\t")
        if len(cols) > 2 and not cols[2].startswith("hifi"):
            upstream.append(cols[0])
    from harnesspipe.stages.data import prepare_test
    from harnesspipe.stages.tensile import TABLE2_COLUMNS
    for path in upstream:
        target = project / path
        target.parent.mkdir(parents=True, exist_ok=True)
        m = re.fullmatch(r"results/data/(\w+)\.h5", path)
        if m:
            prepare_test(project / "data" / "experimental", m.group(1), target)
        elif path.endswith("table2.csv"):
            pd.DataFrame([{"component": c, "E": 1000.0, "sigma_y": 9.0, "K": 25.0, "n": 0.5}
                          for c in ("closed_tube", "open_tube", "fabric_tube")],
                         columns=TABLE2_COLUMNS).to_csv(target, index=False)
        else:
            target.write_text("placeholder\n")
    run = snakemake(project, "--touch", *upstream)
    assert run.returncode == 0, run.stderr[-3000:]
    run = snakemake(project, "hifi_chain_all", "hifi_crosscheck_all")
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-6000:]
    return project


def test_hifi_targets_resolve_and_run(project):
    res = project / "results" / "hifi"
    assert list(pd.read_csv(res / "interface.csv")["parameter"]) == [*hifi_chain.INTERFACE,
                                                                     *hifi_chain.BUILD]
    assert list(pd.read_csv(res / "crosscheck" / "table3.csv").columns) == ["case", "E", "sigma_y", "K", "n",
                                                                            "reference"]
    for step in ("binding", "build", "tension", "closure", "mu_rtb", "mu_rtp", "cohesive",
                 "fabric_binding", "fabric_build", "fabric"):
        for name in ("fit.json", "curve.csv", "trace.h5", "rejected.jsonl", "fit.png"):
            assert (res / "chain" / step / name).exists()
        # the friction fits (window < 20 mm) end their runs 1 mm past it; the others go to 30
        stop = json.loads((res / "chain" / step / "fit.json").read_text())["set"].get("stop_deflection")
        assert stop == (21.0 if step.startswith("mu_") else None), step
    virtual = sorted(p.name for p in (res / "virtual").iterdir())
    assert "twb19_t2" in virtual and "cwb10t1_9t2_fabric" in virtual and len(virtual) == 9
    s = json.loads((res / "virtual" / "cwb19_t1_open_coarse" / "summary.json").read_text())
    assert s["role"] == "validation" and "measured" in s
    assert "measured" not in json.loads((res / "virtual" / "twb19_t2" / "summary.json").read_text())
    assert planned(snakemake(project, "-n", "hifi_chain_all", "hifi_crosscheck_all")) == {}


@pytest.mark.parametrize("overlay, crosscheck, steps", [
    ("coverings:\n  fabric_tube:\n    nu12: 0.3\n", True,           # the fabric's Poisson ratio (eq. 12):
     {"fabric_binding", "fabric_build", "fabric"}),                   # every fit on the fabric CWB
    ("hifi:\n  pipeline:\n    E2_bounds: [0.3, 1.1]\n", False, {"fabric"}),   # read by the E2/E1 fit only
])
def test_fabric_parameter_reruns_only_fabric_fits(project, overlay, crosscheck, steps):
    path = project / "overlay.yaml"                 # merged over config/config.yaml
    path.write_text(overlay)
    run = snakemake(project, "hifi_chain_all", "hifi_crosscheck_all", "-n", "--configfile", str(path))
    jobs = planned(run)
    expected = {"hifi_fit": len(steps), "hifi_interface": 1, "hifi_virtual": 2, "hifi_chain_all": 1}
    fabric = {f"step={s}" for s in steps} | {"case=cwb19_t2_fabric", "case=cwb10t1_9t2_fabric"}
    if crosscheck:
        expected.update({"hifi_crosscheck": 2, "hifi_crosscheck_rom": 2, "hifi_crosscheck_table": 1,
                         "hifi_crosscheck_all": 1})
    assert jobs == expected
    assert planned_wildcards(run) == fabric


def test_rom_reference_hifi_fits_the_virtual_test(project):
    """rom.reference: hifi -- the ROM of a case is fitted to its hi-fi virtual test (not to the
    measured mean under another name)."""
    path = project / "rom_hifi.yaml"
    path.write_text("rom:\n  reference: hifi\n")
    target = "results/rom/cwb19_t2_closed/fit.json"
    run = snakemake(project, target, "--configfile", str(path))
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    fit = json.loads((project / target).read_text())
    assert fit["reference"] == "hifi" and fit["test_id"] == "hifi:cwb19_t2_closed"
    # its error is that against the virtual curve (on the uniform grid of the prepared tests)
    virtual = pd.read_csv(project / "results" / "hifi" / "virtual" / "cwb19_t2_closed" / "curve.csv")
    grid, F = hifi_chain.resample(virtual, 30.0)
    fitted = pd.read_csv(project / "results" / "rom" / "cwb19_t2_closed" / "curve.csv")
    F_fit = np.interp(grid, fitted["displacement_mm"], fitted["force_N"])
    assert fit["error_l2"] == pytest.approx(float(np.linalg.norm(F - F_fit)), rel=1e-6)
    from harnesspipe.config import ConfigError
    from harnesspipe.stages.rom import reference_curve
    measured = next((project / "results" / "data").glob("*.h5"))
    with pytest.raises(ConfigError, match="rom.reference"):
        reference_curve(measured, {"reference": "hifi"})


def test_branch_properties_from_hifi_virtual_tests(project):
    """branch.properties_source: hifi -- the Y-harness beams take E, sigma_y, K, n from eq. 13 +
    simplex on each case's hi-fi virtual test (Sec. 5), the radius from the config."""
    path = project / "branch_hifi.yaml"
    path.write_text("branch:\n  properties_source: hifi\n")
    run = snakemake(project, "results/branch/damping.csv", "--configfile", str(path))
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    used = json.loads((project / "results" / "branch" / "inplane" / "fit.json").read_text())["properties"]
    from harnesspipe.config import load
    estimates = load(project / "config" / "config.yaml")["branch"]["properties"]
    assert sorted(used) == sorted(estimates)
    for case in estimates:
        rom = json.loads((project / "results" / "hifi" / "virtual" / case / "rom" / "fit.json").read_text())
        assert {k: used[case][k] for k in ("E", "sigma_y", "K", "n")} == rom["parameters"]
        assert used[case]["radius"] == estimates[case]["radius"]
    from harnesspipe.config import ConfigError
    from harnesspipe.stages.branch import with_fitted_properties
    fit = project / "results" / "hifi" / "virtual" / "twb19_t2" / "rom" / "fit.json"
    with pytest.raises(ConfigError, match="branch.properties"):
        with_fitted_properties({"properties": estimates}, {"twb99": fit})


@pytest.mark.parametrize("in_all, reference, expected", [
    ("[chain]", "hifi", {"hifi_fit": len(STEPS), "hifi_virtual": 9}),
    ("[chain, crosscheck]", "hifi", {"hifi_fit": len(STEPS), "hifi_virtual": 9, "hifi_crosscheck": 5}),
    ("[]", "measured", {}),
])
def test_all_holds_the_hifi_groups_of_in_all(project, in_all, reference, expected):
    path = project / "in_all.yaml"
    path.write_text(f"hifi:\n  pipeline:\n    in_all: {in_all}\nrom:\n  reference: {reference}\n")
    jobs = planned(snakemake(project, "-n", "--forceall", "--configfile", str(path)))
    assert {r: n for r, n in jobs.items() if r in ("hifi_fit", "hifi_virtual", "hifi_crosscheck")} == expected


def test_virtual_tests_of_the_calibration_cases_reuse_the_fits_runs(project):
    virtual = project / "results" / "hifi" / "virtual"
    for case, step in (("cwb19_t2_closed", "cohesive"), ("cwb19_t2_open_halflap", "cohesive"),
                       ("cwb19_t2_fabric", "fabric")):
        s = json.loads((virtual / case / "summary.json").read_text())
        assert s["reused_from"] == f"results/hifi/chain/{step}/{case}", case
    for case in ("cwb19_t1_open_coarse", "cwb10t1_9t2_fabric", "twb19_t2"):
        assert "reused_from" not in json.loads((virtual / case / "summary.json").read_text()), case


def test_chain_settings_are_what_a_fit_step_needs():
    """The rules' settings of each chain step (stages/chain_settings.py): the start values
    include what the step fits (a search the data cannot steer keeps them), the friction fits'
    runs stop 1 mm past their window, and each case's model carries its own covering only."""
    import json as json_
    from harnesspipe.config import load
    from harnesspipe.stages import chain_settings as chain
    cfg = load()
    for step, spec in chain.STEPS.items():
        s = json_.loads(chain.fit_settings(cfg, step))
        assert set(spec["names"]) <= set(s["start"]) and s["cases"] == spec["cases"]
        assert s["window"] == cfg["hifi"]["pipeline"][spec["window"]]
        for case in s["cases"]:
            assert set(s["models"][case]["coverings"]) == {chain.cases(cfg)[case]["covering"]}
    rtb = json_.loads(chain.fit_settings(cfg, "mu_rtb"))
    assert rtb["set"]["stop_deflection"] == 21.0 and rtb["bounds"] == [0.05, 0.6]
    assert "stop_deflection" not in json_.loads(chain.fit_settings(cfg, "fabric"))["set"]
    assert chain.interface_of(cfg, "twb19_t2", {"mu_rtp": 0.1, "E2_over_E1": 0.6}) == {"mu_rtp": 0.1}
