"""Hi-fi pipeline stages (DESIGN stages 3-7 on the mesoscale model; rules in workflow/rules/hifi.smk).

* :func:`run_case` -- one virtual three-point test (cross-check at the paper's values,
  or at the calibrated interface) with its artefacts: ``curve.csv``
  (``deflection_mm,force_N``), ``summary.json``, ``energies.csv``, ``slip_out.csv``,
  ``shapes/`` and ``shapes.png``; against a measured test also its error (eq. 4).
* :func:`fit_step` -- one step of the calibration chain of Sec. 4.2: a bounded 1-D
  search (one parameter), the paper's Nelder-Mead (several) or a pick among a few values
  (one) of the interface on
  the measured means of one or two CWBs in a deflection window.  Writes
  ``fit.json``, ``curve.csv`` (``case,displacement_mm,force_N`` at the best point),
  ``trace.h5`` (every evaluation), ``rejected.jsonl`` (failed runs, parameters and
  reason), ``fit.png`` and per case ``<case>/summary.json`` and ``energies.csv``.
  The live evaluation log is ``replay/evaluations.h5`` -- not a Snakemake output, so
  it survives an interrupted or failed job and the rerun replays it.  A run an earlier
  step of the chain already made (the same ``run_key``: typically a step's start, which is
  the previous step's pick) is taken from that step's folder, not run again
  (:class:`StoredRun`).
* :func:`rom_crosscheck` -- eq. 13 + simplex (exactly the ROM stage's
  :func:`harnesspipe.calibrate.rom.fit`) on a hi-fi curve instead of a measured mean.
* :func:`interface_table` -- ``results/hifi/interface.csv`` (``parameter,value``).

``settings`` (JSON built by the rules) carries ``model``: the part of the config a
hi-fi run of the case reads (see ``hifi_model`` in hifi.smk: so that an unrelated
config change reruns nothing) and ``set``: extra ``--set``-style overrides.  The
hi-fi model itself is reached through ``runner(model_cfg, case, interface, table2)
-> HifiRun``; tests pass a cheap fake.
"""
from __future__ import annotations

import contextlib
import copy
import hashlib
import json
import multiprocessing
import os
import shutil
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from harnesspipe.calibrate import hifi as hcal
from harnesspipe.calibrate.objective import l2_error, objective_key, relative_l2_error
from harnesspipe.calibrate.simplex import EvaluationLog, FitResult, logged_call
from harnesspipe.config import ConfigError
from harnesspipe.stages.chain_settings import BUILD   # build-state inputs a chain step may fit
from harnesspipe.stages.common import read_fit, write_csv, write_fit, write_json

INTERFACE = ("mu_rtb", "mu_rtp", "delta0", "delta_f", "alpha_d", "E2_over_E1")
#: interface values a run needs but a case does not use: E2/E1 acts on fabric coverings only
NEUTRAL = {"E2_over_E1": 1.0}
N_GRID = 101   # points of the deflection grid a hi-fi curve is resampled to for eq. 13 (as prepare_test)


# --------------------------------------------------------------------------- running the model

def model_config(settings: dict, interface: dict) -> dict:
    """The config dict :func:`harnesspipe.stages.hifi.inputs` reads, with ``interface`` as the
    run's interface parameters."""
    cfg = copy.deepcopy(settings["model"])
    cfg.setdefault("hifi", {})["parameters"] = {**NEUTRAL, **interface}
    return cfg


def default_runner(cfg: dict, case: str, overrides: dict, table2: Path | None):
    """The real hi-fi model: :func:`harnesspipe.models.hifi.three_point` (in a case worker,
    on the cores the pool's other runs leave it: :func:`_shared_cores`)."""
    from harnesspipe.models.hifi import three_point
    from harnesspipe.stages.hifi import inputs
    inp = inputs(cfg, case, {k: str(v) for k, v in overrides.items()}, table2)
    with _shared_cores() as progress:
        return three_point(inp, progress=progress)


def run_key(model: dict, interface: dict, overrides: dict, table2: Path | None) -> str:
    """Identity of a hi-fi run: everything its result depends on besides the code -- the
    model config, the interface, the ``--set`` overrides and the covering table."""
    text = json.dumps({"model": model, "interface": {**NEUTRAL, **interface}, "set": overrides,
                       "coverings": Path(table2).read_text() if table2 else "paper"}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _run(settings, case, interface, table2, runner):
    """One virtual test at ``interface``; its build-state values (``BUILD``) go to the run as
    ``--set`` keys, the rest as the interface."""
    build = {k: v for k, v in interface.items() if k in BUILD}
    cfg = model_config(settings, {k: v for k, v in interface.items() if k not in BUILD})
    return (runner or default_runner)(cfg, case, {**settings.get("set", {}), **build}, table2)


def write_run(run, outdir: Path, summary: dict) -> None:
    """Artefacts of one run (energies, slip-out, shapes when the run has a mesh, curve, summary);
    the curve and summary last, so a failure leaves no valid-looking result."""
    outdir = Path(outdir)
    write_csv(outdir / "energies.csv", run.history)
    if getattr(run, "slip_out", None) is not None:
        write_csv(outdir / "slip_out.csv", run.slip_out)
    if getattr(run, "mesh", None) is not None and getattr(run, "shapes", None):
        from harnesspipe.stages.hifi import write_shapes
        write_shapes(outdir, run)
    write_csv(outdir / "curve.csv", run.curve[["deflection_mm", "force_N"]])
    write_json(outdir / "summary.json", summary)


def curve_vs_measured(curve: pd.DataFrame, prepared) -> dict:
    """eq. 4 of a hi-fi curve against a measured mean, on the measured grid points it covers."""
    u, F = curve["deflection_mm"].to_numpy(float), curve["force_N"].to_numpy(float)
    order = np.argsort(u, kind="stable")
    u, F = u[order], F[order]
    grid = prepared.grid
    mask = hcal.covered(grid, u)
    f = np.interp(grid[mask], u, F)
    return {"test_id": prepared.test_id, "error_l2": l2_error(prepared.mean[mask], f),
            "error_rel": relative_l2_error(prepared.mean[mask], f),
            "coverage_mm": [float(grid[mask].min()), float(grid[mask].max())] if mask.any() else None}


def run_case(case: str, settings: dict, outdir: Path, *, table2: Path | None = None,
             interface_fit: Path | None = None, reference: Path | None = None,
             role: str = "virtual", runner=None, reuse: Path | None = None) -> dict:
    """One virtual test at ``settings["interface"]`` updated by the ``interface`` of a chain
    fit (``interface_fit``); writes the run's artefacts to ``outdir``; returns the summary.
    ``reuse``: a folder of an earlier run (a fit's best point, ``<fit>/<case>/``); when its
    ``run_key`` is this run's, its artefacts are taken instead of running again."""
    interface = dict(settings.get("interface", {}))
    source = "settings"
    if interface_fit is not None:
        fit = read_fit(interface_fit)
        if "interface" not in fit:
            raise ConfigError(f"--interface {interface_fit}: no 'interface' in it (not the fit.json "
                              "of a hi-fi chain step)")
        interface.update(fit["interface"])
        source = str(interface_fit)
    overrides = settings.get("set", {})
    key = run_key(settings["model"], interface, overrides, table2)
    summary = {"case": case, "role": role, "interface_source": source,
               "coverings_source": str(table2) if table2 else "paper (config paper.table2)"}
    earlier = _reusable(reuse, key)
    if earlier is not None:
        stored = StoredRun.load(Path(reuse), earlier)
        curve = stored.curve
        summary.update({**stored.summary, **summary})
    else:
        run = _run(settings, case, interface, table2, runner)
        curve = run.curve
        summary.update(run.summary)
    summary.update({"interface": {**NEUTRAL, **interface}, "set": overrides, "run_key": key})
    if reference is not None:
        from harnesspipe.stages.data import read_prepared
        summary["measured"] = curve_vs_measured(curve, read_prepared(reference))
    if earlier is not None:
        _copy_run(Path(reuse), Path(outdir), summary)
    else:
        write_run(run, outdir, summary)
    return summary


#: summary keys that describe where a run was used, not the run (a reused run gets its own)
RUN_ENVELOPE = ("case", "role", "interface", "set", "run_key", "measured", "reused_from",
                "interface_source", "coverings_source")


@dataclass
class StoredRun:
    """A finished run read back from the folder :func:`write_run` wrote: its curve and its
    own summary (``reused_from`` the folder); the rest of its artefacts stay there and are
    copied where the run is kept (:func:`_copy_run`)."""
    folder: Path
    curve: pd.DataFrame
    summary: dict

    @classmethod
    def load(cls, folder: Path, earlier: dict) -> "StoredRun":
        own = {k: v for k, v in earlier.items() if k not in RUN_ENVELOPE}
        return cls(Path(folder), pd.read_csv(Path(folder) / "curve.csv"), {**own, "reused_from": str(folder)})


def _reusable(folder: Path | None, key: str) -> dict | None:
    """The summary of the run in ``folder`` if it is the run ``key`` and complete, else None."""
    if folder is None or not (Path(folder) / "summary.json").exists():
        return None
    earlier = json.loads((Path(folder) / "summary.json").read_text())
    return earlier if earlier.get("run_key") == key and (Path(folder) / "curve.csv").exists() else None


def _copy_run(src: Path, dst: Path, summary: dict) -> None:
    """The artefacts of the run in ``src`` into ``dst`` with a new summary (written last)."""
    dst.mkdir(parents=True, exist_ok=True)
    for item in sorted(src.iterdir()):
        if item.name == "summary.json":
            continue
        if item.is_dir():
            shutil.copytree(item, dst / item.name, dirs_exist_ok=True)
        else:
            shutil.copyfile(item, dst / item.name)
    write_json(dst / "summary.json", summary)


# --------------------------------------------------------------------------- calibration chain

def _live_rejected(path: Path, key: str) -> None:
    """Keep only the rejected points of this objective (another key: a stale log)."""
    rows = hcal.read_rejected(path, key)
    if path.exists():
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text("".join(json.dumps(r) + "\n" for r in rows))
        tmp.replace(path)


def _copy_atomic(src: Path, dst: Path) -> None:
    tmp = dst.with_name(dst.name + ".tmp")
    if src.exists():
        shutil.copyfile(src, tmp)
    else:
        tmp.write_text("")
    tmp.replace(dst)


def fit_step(step: str, settings: dict, references: dict[str, Path], outdir: Path, *,
             table2: Path | None = None, priors: list[Path] = (), runner=None, workers: int = 1) -> dict:
    """One calibration step (see module docstring).

    ``settings``: ``names`` (fitted parameters), ``cases``, ``window`` ([lo, hi] mm),
    ``method`` (``bounded`` | ``simplex`` | ``choice``), ``bounds`` (bounded), ``choices``
    (choice), ``xatol``, ``fatol`` (simplex), ``maxfev``, ``start`` (interface values before this step: the config's
    initial guesses), ``models`` (case -> model config), ``set``, ``flat_factor``
    (optional, 0 if absent: the identifiability screen :func:`hcal.flat_screen` stops a
    search whose first evaluations differ by less than this many times the l2 standard
    error of the measured means over the window), ``bits_spread`` (optional, 0 if absent: a
    decision of the search within this fraction of the measured means' l2 norm of its
    threshold is flagged ``marginal``, :func:`_decision`).  ``priors``: fit.json
    of the earlier steps, whose fitted parameters replace the start values.  ``workers``
    > 1: the cases of each evaluation run side by side in that many processes
    (``runner`` must then be picklable).
    """
    from harnesspipe.report import plots
    from harnesspipe.stages.data import read_prepared
    outdir = Path(outdir)
    names, cases = list(settings["names"]), list(settings["cases"])
    fixed, prior_ids = _start_values(step, settings, priors)
    refs = {c: read_prepared(references[c]) for c in cases}
    window = tuple(float(w) for w in settings["window"])
    live = outdir / "replay"
    live.mkdir(parents=True, exist_ok=True)
    targets = [(c, refs[c].grid, refs[c].mean, window) for c in cases]
    coverings_text = Path(table2).read_text() if table2 else "paper"
    key = objective_key(np.concatenate([refs[c].grid for c in cases]),
                        np.concatenate([refs[c].mean for c in cases]),
                        {"step": step, "settings": {k: v for k, v in settings.items() if k != "bits_spread"},
                         "fixed": fixed, "coverings": coverings_text})

    runs: dict = {}
    simulate = CaseRun(settings, table2, runner,
                       earlier={c: [Path(p).parent / c for p in priors] for c in cases})
    rejected_live = live / "rejected.jsonl"
    _live_rejected(rejected_live, key)
    with _case_pool(min(workers, len(cases)), workers) as pool:
        objective = hcal.HifiObjective(simulate, targets, fixed, names, rejected_log=rejected_live, key=key,
                                       pool=pool, on_run=lambda c, p, run: runs.update({(c, _pkey(p)): run}))
        t0 = time.perf_counter()
        tie = _mean_uncertainty(refs, window) * float(settings.get("flat_factor", 0.0))
        runs_at = _RunsAt(runs, simulate)     # the fit's runs, and those run outside its search
        onset = _onset_check(settings, objective, names, fixed, live, key, runs_at, tie)
        res = onset.result
        if res is None:
            res = _search(step, settings, objective, names, onset.start, live, key, tie)
            res.message, res.nfev = onset.words + res.message, res.nfev + len(onset.extra)
    best = objective.params(res.x)
    rejected_keys = {_pkey(r["parameters"]) for r in hcal.read_rejected(rejected_live, key)}
    if not res.fun < objective.penalty or _pkey(best) in rejected_keys:
        raise hcal.RejectedRun(f"hifi fit {step}: the best point is a rejected one: no evaluation "
                               f"succeeded (see {rejected_live})")
    curve, per_case = _keep_best_runs(step, settings, best, runs_at, refs, window, table2, outdir)
    trace = res.trace
    _write_trace(outdir / "trace.h5", live / "evaluations.h5", trace, key, onset.extra)
    _copy_atomic(rejected_live, outdir / "rejected.jsonl")
    norm = sum(float(np.linalg.norm(F[hcal.window_mask(u, w)])) for _, u, F, w in targets)
    decision = _decision(onset.method, settings, trace, len(names), tie, objective.penalty, norm)
    if decision["marginal"]:
        res.message += (f"; marginal: this decision lies {abs(decision['margin_N']):.3g} N from its "
                        f"threshold, within the runs' last-bits spread ({decision['bits_spread_N']:.3g} N): "
                        "on another machine it may go the other way")
    reused = sum(isinstance(r, StoredRun) for k, r in runs.items() if k not in runs_at.made)
    path = write_fit(
        outdir, stage="hifi", item=step, test_id=",".join(refs[c].test_id for c in cases),
        parameters={k: best[k] for k in names}, error_l2=res.fun, error_rel=res.fun / max(norm, 1e-300),
        nfev=res.nfev, converged=res.converged, wall_s=time.perf_counter() - t0, curve=curve,
        extra={"role": "calibration", "method": settings["method"], "cases": cases, "window": list(window),
               "bounds": settings.get("bounds"), "choices": settings.get("choices"),
               "interface": {**NEUTRAL, **best}, "priors": prior_ids,
               "per_case": per_case, "message": res.message, "decision": decision,
               "hifi_runs": int((len(trace) + len(onset.extra)) * len(cases) + runs_at.fresh),   # upper bound: a rejection stops early
               "hifi_runs_this_process": int(objective.n_runs + runs_at.fresh - reused),
               "hifi_runs_reused": int(reused),
               "hifi_wall_s": float(np.nansum(trace["wall_s"]) + sum(r[2] for r in onset.extra)),
               "rejected": len(hcal.read_rejected(rejected_live, key)),
               "set": settings.get("set", {})})
    plots.save(plots.hifi_cases_figure({c: refs[c] for c in cases},
                                       {c: g for c, g in curve.groupby("case")},
                                       title=f"hi-fi fit {step}", window=window), outdir / "fit.png")
    return read_fit(path)


def _start_values(step: str, settings: dict, priors) -> tuple[dict, list]:
    """The interface where the step starts: the config's start values with the earlier
    steps' fitted parameters (``priors``, their fit.json) over them; and what each prior gave."""
    fixed, prior_ids = dict(settings["start"]), []
    for p in priors:
        prior = read_fit(p)
        fixed.update(prior["parameters"])
        prior_ids.append({"step": prior["item"], "parameters": prior["parameters"]})
    missing = [k for k in settings["names"] if k not in fixed]
    if missing:   # the search starts there; a search the data cannot steer keeps it
        raise ConfigError(f"hifi fit {step}: no start value for {missing}")
    return fixed, prior_ids


def _keep_best_runs(step, settings, best, runs_at, refs, window, table2, outdir):
    """The best point's run of each case (from this process, else run again: replayed
    evaluations) kept in ``outdir/<case>`` with its summary; returns the step's curve
    (``case,displacement_mm,force_N``) and each case's error over ``window``."""
    curves, per_case = [], {}
    for case in settings["cases"]:
        run = runs_at(case, best)
        err = hcal.curve_error(run.curve["deflection_mm"], run.curve["force_N"], refs[case].grid,
                               refs[case].mean, window)
        per_case[case] = {"test_id": refs[case].test_id, "error_l2_window": err,
                          "measured": curve_vs_measured(run.curve, refs[case])}
        summary = {"case": case, "role": f"calibration ({step})", **run.summary,
                   "interface": {**NEUTRAL, **best}, "set": settings.get("set", {}),
                   "run_key": run_key(settings["models"][case], best, settings.get("set", {}), table2)}
        if isinstance(run, StoredRun):
            _copy_run(run.folder, outdir / case, summary)
        else:
            write_run(run, outdir / case, summary)
        c = run.curve.rename(columns={"deflection_mm": "displacement_mm"})[["displacement_mm", "force_N"]]
        curves.append(c.assign(case=case)[["case", "displacement_mm", "force_N"]])
    return pd.concat(curves, ignore_index=True), per_case


class CaseRun:
    """``simulate(case, params) -> (u, F, run)`` of a fit: picklable, so that a process
    pool can run the cases of one evaluation side by side.  ``earlier``: per case, folders
    of earlier steps' runs; a run with the same ``run_key`` there is taken
    (:class:`StoredRun`) instead of running again."""

    def __init__(self, settings: dict, table2: Path | None, runner=None, earlier: dict | None = None):
        self.settings, self.table2, self.runner = settings, table2, runner
        self.earlier = earlier or {}

    def __call__(self, case: str, params: dict):
        model = self.settings["models"][case]
        key = run_key(model, params, self.settings.get("set", {}), self.table2)
        for folder in self.earlier.get(case, ()):
            earlier = _reusable(folder, key)
            if earlier is not None:
                run = StoredRun.load(folder, earlier)
                break
        else:
            run = _run({**self.settings, "model": model}, case, params, self.table2, self.runner)
        return run.curve["deflection_mm"].to_numpy(float), run.curve["force_N"].to_numpy(float), run


PARENT_POLL_S = 1.0   # how often a case worker checks that the fit process still lives


def _exit_with(parent_pid: int) -> None:
    """Poll until the process ``parent_pid`` is no longer this process's parent, then end
    this process at once: a fit that is killed (Snakemake interrupt, kill -9) takes its
    case workers with it instead of leaving them to run their hi-fi cases to the end."""
    while os.getppid() == parent_pid:
        time.sleep(PARENT_POLL_S)
    os._exit(1)


_CORES = None   # in a case worker: (the pool's count of runs in progress, the pool's cores)


def _case_worker_init(parent_pid: int, running, cores: int) -> None:
    """Initializer of a case worker: one Numba thread, the pool's shared count of runs in
    progress (:func:`_shared_cores`), and exit with the parent."""
    import numba
    global _CORES
    numba.set_num_threads(1)
    _CORES = (running, cores)
    threading.Thread(target=_exit_with, args=(parent_pid,), daemon=True).start()


def core_share(cores: int, running: int, most: int) -> int:
    """Numba threads of one of ``running`` runs sharing ``cores``: an equal share, at least
    one, at most ``most`` (the threads Numba has)."""
    return max(1, min(most, cores // max(running, 1)))


@contextlib.contextmanager
def _shared_cores():
    """In a case worker, count this run among the pool's runs in progress and yield the
    ``progress`` callback of :func:`harnesspipe.models.hifi.three_point` that, at every
    history row, sets this process's Numba threads to its share of the pool's cores
    (:func:`core_share`): a run left alone, its partner done, takes both cores.  A run's
    result does not depend on its thread count (tests/test_hifi_threads.py).  Elsewhere
    yields None."""
    if _CORES is None:
        yield None
        return
    import numba
    running, cores = _CORES
    most = numba.config.NUMBA_NUM_THREADS

    def share(**_):
        n = core_share(cores, running.value, most)
        if n != numba.get_num_threads():
            numba.set_num_threads(n)

    with running.get_lock():
        running.value += 1
    try:
        yield share
    finally:
        with running.get_lock():
            running.value -= 1
        numba.set_num_threads(1)


@contextlib.contextmanager
def _case_pool(workers: int, cores: int):
    """A pool of ``workers`` fresh processes of one Numba thread each (none for one worker),
    sharing ``cores`` (:func:`_shared_cores`).  Fresh (spawned) processes: no OpenMP state
    inherited through a fork.  The workers end when the process that made the pool ends,
    however it ends (:func:`_exit_with`)."""
    if workers < 2:
        yield None
        return
    ctx = multiprocessing.get_context("spawn")
    running = ctx.Value("i", 0)
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_case_worker_init,
                             initargs=(os.getpid(), running, cores)) as pool:
        yield pool


def _mean_uncertainty(refs: dict, window) -> float:
    """l2 norm of the standard error of the measured mean over ``window``, summed over the
    cases like the error (eq. 4): the floor of the identifiability screen."""
    return sum(float(np.linalg.norm(r.standard_error()[hcal.window_mask(r.grid, window)]))
               for r in refs.values())


def _decision(method: str, settings: dict, trace: pd.DataFrame, n_names: int, tie: float,
              penalty: float, norm: float) -> dict:
    """The step's threshold decision (:func:`hcal.decision_margin`, ``method`` the rule that
    made it: the step's own, or ``choice`` for the cohesive step's onset pick) against the runs' last-bits
    spread, ``bits_spread`` x the measured means' l2 norm over the window (config
    ``hifi.pipeline.fidelity_spread``: five last-bit copies of one run spread by 0.66 % of it):
    ``marginal`` when the margin is smaller."""
    errors = trace["error"].to_numpy(float) if len(trace) else np.zeros(0)
    margin = hcal.decision_margin(method, errors, n_names, tie, penalty)
    spread = float(settings.get("bits_spread", 0.0)) * norm
    return {"margin_N": margin, "bits_spread_N": spread, "threshold_N": tie,
            "marginal": margin is not None and abs(margin) < spread}


def _search(step, settings, objective, names, fixed, live, key, floor):
    """The bounded search (one parameter), Nelder-Mead (several) or the pick among a few
    values (``choice``: :func:`hcal.choice_fit`, the same floor) of a fit step, with the
    identifiability screen :func:`hcal.flat_screen` at ``floor`` (the measured mean's standard
    error x ``flat_factor``) over the start and the first points; a search the screen ends keeps the start values (``fixed``),
    whatever its first points gave; one that runs its course rests at the mean of its
    evaluations weighted by exp(-((e - e_min)/tie)^2/2), tie the same tolerance, evaluated
    there (:func:`harnesspipe.calibrate.simplex.rest_at_pick`): a pick that moves
    continuously with the errors, where a threshold's pick could hinge on the runs' last
    bits."""
    log = live / "evaluations.h5"
    if settings["method"] == "bounded":
        if len(names) != 1:
            raise ConfigError(f"hifi fit {step}: a bounded search fits one parameter, not {names}")
        return hcal.bounded_fit(objective, names[0], settings["bounds"], xatol=settings["xatol"],
                                log_path=log, key=key, maxfev=settings["maxfev"],
                                stop=_screen(settings, names, floor, objective),
                                keep=float(fixed[names[0]]), tie=floor,
                                penalty=objective.penalty)
    if settings["method"] == "simplex":
        return hcal.simplex_fit(objective, {k: fixed[k] for k in names}, xatol=settings["xatol"],
                                fatol=settings["fatol"], maxfev=settings["maxfev"], log_path=log, key=key,
                                stop=_screen(settings, names, floor, objective),
                                keep_start=True, tie=floor, penalty=objective.penalty)
    if settings["method"] == "choice":
        if len(names) != 1:
            raise ConfigError(f"hifi fit {step}: a choice picks one parameter, not {names}")
        return hcal.choice_fit(objective, names[0], settings["choices"], keep=float(fixed[names[0]]),
                               tie=floor, log_path=log, key=key, penalty=objective.penalty)
    raise ConfigError(f"hifi fit {step}: method {settings['method']!r} is not bounded|simplex|choice")


def _screen(settings, names, floor, objective):
    """The search's identifiability screen over its first evaluations (:func:`hcal.screen_size`,
    the count :func:`hcal.decision_margin` reads its margin from)."""
    return hcal.flat_screen(hcal.screen_size(settings["method"], len(names)), floor, objective.penalty)


ONSET_PROBE = 0.5   # the debonding probe's delta0: at least this fraction of the ties' largest opening


class _RunsAt:
    """``(case, params) -> run`` from the fit's runs, else run (:class:`CaseRun`) and kept;
    ``made``: the keys run here, ``fresh``: how many of them were run, not taken."""

    def __init__(self, runs: dict, simulate):
        self.runs, self.simulate, self.made, self.fresh = runs, simulate, set(), 0

    def __call__(self, case: str, params: dict):
        k = (case, _pkey(params))
        if k not in self.runs:
            run = self.simulate(case, params)[2]
            self.runs[k], self.fresh = run, self.fresh + (not isinstance(run, StoredRun))
            self.made.add(k)
        return self.runs[k]


@dataclass
class _Onset:
    """Where the cohesive fit stands after its onset check (:func:`_onset_check`)."""
    result: FitResult | None     # the step's result when the check ends it
    start: dict                  # else the search's start
    method: str                  # the rule of the step's threshold decision
    words: str = ""              # what the check found, for the search's message
    extra: list = field(default_factory=list)   # its evaluations (x, error, wall) not in the search's log


def _onset_check(settings, objective, names, fixed, live, key, runs_at, tie) -> _Onset:
    """Whether the cohesive fit's search can start where it is (eqs. 7-9).

    Its first evaluation, at the start values, shows how far the tape ties open (run summary
    ``tie_separation_max_mm``, the largest over the cases).  A tie at or past delta0: damage
    acts, and the simplex searches from the start like any step.  All below: every tie
    stays on the law's linear elastic part whatever delta0, delta_f and alpha, so the curve
    does not depend on them there and the simplex's +5 % moves could only find that.  The
    data are asked instead whether the tape should debond where the paper saw it debond,
    past the window's start (Sec. 4.2.1: 20 mm): a probe with delta0 at the opening the
    ties had reached there (history ``tie_opening_mm``, the largest over the cases), at
    least ``ONSET_PROBE`` x the largest opening so that the probe's ties do pass onset;
    delta_f at the start's ratio to delta0, alpha as started.  It runs against the start, by
    the pick rule of :func:`hcal.choice_fit` (lower by at least ``tie``).  Not lower: the
    step ends, the start values kept, the two errors in its message.  Lower: the simplex
    searches from the probe.  Both evaluations are logged (``onset.h5``) and replayed on a rerun."""
    if settings["method"] != "simplex" or "delta0" not in names:
        return _Onset(None, fixed, settings["method"])
    onset = EvaluationLog(live / "onset.h5", names, key)
    x0 = np.array([fixed[k] for k in names], dtype=float)
    e0 = logged_call(onset, objective, x0)
    cases = [c for c, *_ in objective.targets]
    starts = [] if e0 >= objective.penalty else [runs_at(c, objective.params(x0)) for c in cases]
    seps = [r.summary.get("tie_separation_max_mm") for r in starts]
    if not seps or any(v is None for v in seps) or max(seps) >= fixed["delta0"]:
        _seed(live / "evaluations.h5", names, key, onset.rows[0])    # the search's first point
        return _Onset(None, fixed, "simplex")
    from harnesspipe.models.hifi import tie_opening_at
    opening, u_on = max(seps), float(settings["window"][0])
    at_onset = max((v for v in (tie_opening_at(_history(r), u_on) for r in starts) if v is not None),
                   default=0.0)
    probe = {k: fixed[k] for k in names}
    probe["delta0"] = max(at_onset, ONSET_PROBE * opening)
    probe["delta_f"] = probe["delta0"] * fixed["delta_f"] / fixed["delta0"]
    xp = np.array([probe[k] for k in names], dtype=float)
    ep = logged_call(onset, objective, xp)
    words = (f"no tape tie reaches damage onset at the start values (largest opening {opening:.3g} mm "
             f"< delta0 {fixed['delta0']:g} mm), where the curve does not depend on delta0, delta_f "
             f"and alpha; with the ties debonding (delta0 {probe['delta0']:.3g} mm: their opening at "
             f"{u_on:g} mm, where the paper saw the tape debond, {at_onset:.3g} mm, at least "
             f"{ONSET_PROBE:g} x the largest; delta_f {probe['delta_f']:.3g} mm) the error is "
             f"{ep:.4g} N against {e0:.4g} N")
    if ep < objective.penalty and ep <= e0 - tie:
        _seed(live / "evaluations.h5", names, key, onset.rows[-1])   # the search's first point
        return _Onset(None, {**fixed, **probe}, "simplex",
                      f"{words}, lower by at least the standard error of the measured mean "
                      f"({tie:.3g} N): searched from there; ", extra=onset.rows[:1])
    _copy_atomic(live / "onset.h5", live / "evaluations.h5")
    message = (f"not identifiable: {words}, not lower by the standard error of the measured mean "
               f"({tie:.3g} N): the data do not call for debonding; the tape stays bonded and "
               f"delta0, delta_f and alpha keep their start values")
    return _Onset(FitResult(list(names), x0, e0, len(onset.rows), False, message, onset.frame()),
                  fixed, "choice")


def _history(run) -> pd.DataFrame:
    """A run's history: its own, or a stored run's energies.csv (empty when there is none)."""
    if getattr(run, "history", None) is not None:
        return run.history
    folder = getattr(run, "folder", None)
    path = Path(folder) / "energies.csv" if folder is not None else None
    return pd.read_csv(path) if path is not None and path.exists() else pd.DataFrame()


def _seed(path: Path, names, key: str, row) -> None:
    """Make the evaluation ``row`` (x, error, wall) the first of the log at ``path``, unless it
    is already, so that a search starting there replays it instead of running it again."""
    log = EvaluationLog(path, names, key)
    if log.lookup(row[0]) is None:
        log.append(*row)


def _write_trace(path: Path, evaluations: Path, trace: pd.DataFrame, key: str, extra: list) -> None:
    """The step's ``trace.h5``: its search's log (``evaluations``), preceded by the
    evaluations made before the search and not in that log (``extra``, rows (x, error,
    wall); ``trace``: the search's evaluations as a frame), written whole or not at all."""
    if not extra:
        _copy_atomic(evaluations, path)
        return
    names = [c for c in trace.columns if c not in ("error", "wall_s")]
    searched = [(r[names].to_numpy(float), r["error"], r["wall_s"]) for _, r in trace.iterrows()]
    part = path.with_name(path.name + ".part")
    part.unlink(missing_ok=True)
    log = EvaluationLog(part, names, key)
    for row in [*extra, *searched]:
        log.append(*row)
    os.replace(part, path)


def _pkey(params: dict) -> tuple:
    return tuple(sorted((k, float(v)) for k, v in params.items()))


def interface_table(fit_paths: list[Path], out_csv: Path) -> pd.DataFrame:
    """results/hifi/interface.csv: ``parameter,value`` for the six interface parameters
    (DESIGN sec. 5), each from the fit that calibrated it, then the build-state inputs the
    chain fitted."""
    values = {}
    for p in fit_paths:
        values.update(read_fit(p)["parameters"])
    missing = [k for k in INTERFACE if k not in values]
    if missing:
        raise ConfigError(f"interface table: no fit gives {missing}")
    names = list(INTERFACE) + [k for k in BUILD if k in values]
    frame = pd.DataFrame({"parameter": names, "value": [float(values[k]) for k in names]})
    write_csv(out_csv, frame)
    return frame


# --------------------------------------------------------------------------- ROM cross-check

def _rom_fit(u, F, settings, log_path):
    from harnesspipe.calibrate import rom as rom_fit
    return rom_fit.fit(u, F, settings, log_path=log_path)


def _rom_names(rs):
    from harnesspipe.calibrate import rom as rom_fit
    return rom_fit.hardening_names(rs)


def _rom_simulate(params, settings):
    from harnesspipe.calibrate import rom as rom_fit
    return rom_fit.simulate(params, settings)


def resample(curve: pd.DataFrame, deflection: float, n: int = N_GRID,
             source: str = "hi-fi curve") -> tuple[np.ndarray, np.ndarray]:
    """A hi-fi curve on the uniform grid 0..deflection (as the prepared tests); ``source``
    names it in the error."""
    u, F = curve["deflection_mm"].to_numpy(float), curve["force_N"].to_numpy(float)
    order = np.argsort(u, kind="stable")
    u, F = u[order], F[order]
    if u[-1] < (1.0 - hcal.END_TOLERANCE) * deflection:
        raise RuntimeError(f"{source} ends at {u[-1]:.4g} mm, short of the {deflection:g} mm test")
    grid = np.linspace(0.0, deflection, n)
    return grid, np.interp(grid, u, F)


def rom_crosscheck(case: str, curve_csv: Path, settings: dict, outdir: Path,
                   label: str = "hi-fi (paper's parameters)") -> dict:
    """eq. 13 + simplex on the hi-fi curve of ``case``: fit.json, curve.csv, trace.h5, fit.png."""
    from harnesspipe.report import plots
    outdir = Path(outdir)
    hifi = pd.read_csv(curve_csv)
    grid, F = resample(hifi, settings["three_point"]["deflection"], source=str(curve_csv))
    t0 = time.perf_counter()
    result = _rom_fit(grid, F, settings, outdir / "trace.h5")
    curve = _rom_simulate(result.parameters, settings).rename(columns={"deflection_mm": "displacement_mm"})
    F_fit = np.interp(grid, curve["displacement_mm"], curve["force_N"])
    path = write_fit(outdir, stage="hifi_rom", item=case, test_id=f"hifi:{case}",
                     parameters={k: result.parameters[k] for k in ("E", "sigma_y", "K", "n")},
                     error_l2=l2_error(F, F_fit), error_rel=relative_l2_error(F, F_fit),
                     nfev=result.nfev, converged=result.result.converged,
                     wall_s=time.perf_counter() - t0, curve=curve,
                     extra={"E_eq13": result.E_eq13, "sigma_y_eq13": result.sigma_y_eq13,
                            "reference": "hifi", "hifi_curve": str(curve_csv),
                            "fitted": _rom_names(settings["rom"])})
    plots.save(plots.hifi_rom_figure(hifi, curve, title=f"{case}: ROM on the hi-fi curve", label=label),
               outdir / "fit.png")
    return read_fit(path)
