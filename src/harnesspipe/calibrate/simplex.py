"""Nelder-Mead calibration as used throughout the paper (Sec. 3.2, Fig. 5c).

The initial simplex is the initial guess plus 5 % of each component in turn
(Sec. 3.2).  Every evaluation -- parameters, error, wall time -- is kept in the
trace and, when ``log_path`` is given, appended to an HDF5 log as it happens, so
an interrupted calibration leaves its evaluations behind and a rerun with the
same log replays them instead of recomputing (the objective is deterministic).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
from scipy.optimize import minimize, minimize_scalar

SIMPLEX_STEP = 0.05  # Sec. 3.2: "adding 5% of each component"


@dataclass
class FitResult:
    """Outcome of a calibration: best point, its error and every evaluation made."""

    names: list[str]
    x: np.ndarray
    fun: float
    nfev: int
    converged: bool
    message: str
    trace: pd.DataFrame

    def params(self) -> dict[str, float]:
        return {k: float(v) for k, v in zip(self.names, self.x)}


def initial_simplex(x0: np.ndarray, step: float = SIMPLEX_STEP) -> np.ndarray:
    """Vertices x0 and x0 + step*x0[i]*e_i (a zero component gets an absolute step)."""
    x0 = np.asarray(x0, dtype=float)
    m = x0.size
    simplex = np.tile(x0, (m + 1, 1))
    for i in range(m):
        simplex[i + 1, i] += step * x0[i] if x0[i] != 0.0 else step
    return simplex


class EvaluationLog:
    """Append-only HDF5 log of (parameters, error, wall time); replays on rerun."""

    def __init__(self, path: Path | None, names: list[str], key: str = ""):
        self.path = Path(path) if path else None
        self.names = list(names)
        self.key = key
        self.rows: list[tuple[np.ndarray, float, float]] = []
        self._replay: list[tuple[np.ndarray, float, float]] = []
        if self.path and self.path.exists():
            self._replay = self._read()

    def _read(self):
        with h5py.File(self.path, "r") as f:
            stored = [n.decode() if isinstance(n, bytes) else n for n in f.attrs["names"]]
            if stored != self.names:
                raise ValueError(
                    f"{self.path}: evaluation log is for parameters {stored}, not {self.names}; "
                    "delete it to start afresh"
                )
            stale = f.attrs.get("key", "") != self.key
            x, err, wall = f["x"][...], f["error"][...], f["wall_s"][...]
        if stale:  # written for another objective: nothing to replay
            self.path.unlink()
            return []
        return [(x[i], float(err[i]), float(wall[i])) for i in range(len(err))]

    def lookup(self, x: np.ndarray):
        """Error of a replayed evaluation at exactly ``x`` (in order), else None."""
        k = len(self.rows)
        if k < len(self._replay) and np.array_equal(self._replay[k][0], x):
            return self._replay[k]
        self._replay = self._replay[:k]  # diverged: stop replaying
        return None

    def append(self, x: np.ndarray, error: float, wall_s: float) -> None:
        self.rows.append((np.array(x, dtype=float), float(error), float(wall_s)))
        if self.path is None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with h5py.File(self.path, "a") as f:
            if "x" not in f:
                f.attrs["names"] = self.names
                f.attrs["key"] = self.key
                f.create_dataset("x", shape=(0, len(self.names)), maxshape=(None, len(self.names)), dtype="f8")
                f.create_dataset("error", shape=(0,), maxshape=(None,), dtype="f8")
                f.create_dataset("wall_s", shape=(0,), maxshape=(None,), dtype="f8")
            n = len(self.rows)
            for key, val in (("x", x), ("error", error), ("wall_s", wall_s)):
                f[key].resize(n, axis=0)
                f[key][n - 1] = val

    def frame(self) -> pd.DataFrame:
        data = {name: [r[0][i] for r in self.rows] for i, name in enumerate(self.names)}
        data["error"] = [r[1] for r in self.rows]
        data["wall_s"] = [r[2] for r in self.rows]
        return pd.DataFrame(data)


class StopSearch(Exception):
    """Raised by a search's ``stop`` rule to end it early; the message says why."""


def check_stop(stop, log: EvaluationLog) -> None:
    """Raise :class:`StopSearch` if the rule ``stop(rows) -> reason | None`` says so."""
    reason = stop(log.rows) if stop is not None else None
    if reason:
        raise StopSearch(reason)


def best_logged(log: EvaluationLog) -> tuple[np.ndarray, float]:
    """The logged point of smallest finite error (inf error if none is finite)."""
    errors = np.array([r[1] if np.isfinite(r[1]) else np.inf for r in log.rows])
    i = int(np.argmin(errors))
    return log.rows[i][0], float(errors[i])


#: errors more than this many ties above the best weigh exp(-800), which is 0 in double
PICK_CLIP = 40.0


def admitted(errors, penalty: float = np.inf) -> np.ndarray:
    """Which errors are of runs that count: finite and below ``penalty`` (a rejected run's score)."""
    e = np.asarray(errors, dtype=float)
    return np.isfinite(e) & (e < penalty)


def pick_weights(errors, tie: float, penalty: float = np.inf) -> np.ndarray:
    """w_i = exp(-((e_i - e_min) / tie)^2 / 2) of the errors ``e_i``; a rejected point (not
    :func:`admitted`) weighs 0.  Continuous in every error: a point whose
    error moves by a little changes its weight by a little, wherever the best one lies."""
    e = np.asarray(errors, dtype=float)
    ok = admitted(e, penalty)
    w = np.zeros_like(e)
    if ok.any():
        z = np.minimum((e[ok] - e[ok].min()) / tie, PICK_CLIP)
        w[ok] = np.exp(-0.5 * z ** 2)
    return w


def weighted_pick(log: EvaluationLog, tie: float, penalty: float = np.inf) -> np.ndarray:
    """The mean of the logged points weighted by :func:`pick_weights` of their errors.

    Errors closer than ``tie`` (the uncertainty of the measured mean) do not tell points
    apart, and which of them comes out lowest can hinge on the last bits of the runs
    (explicit dynamics differs between CPUs in those).  A pick by a threshold -- the best
    point, or the one nearest the start among those within ``tie`` of the best -- jumps
    when an error crosses it; this mean moves continuously with the errors."""
    w = pick_weights([r[1] for r in log.rows], tie, penalty)
    if not w.sum() > 0.0:
        raise ValueError("no admitted evaluation to pick from")
    x = np.array([r[0] for r in log.rows])
    return (w[:, None] * x).sum(axis=0) / w.sum()


def rest_at_pick(log: EvaluationLog, objective, tie: float, resolution: float, scale=None,
                 penalty: float = np.inf) -> tuple[np.ndarray, float, str]:
    """(x, error, words) where a search that ran its course rests: at the :func:`weighted_pick`
    of its evaluations, evaluated there and logged (its run is the fit's run); at the admitted
    evaluated point nearest it instead when that lies within ``resolution`` (max norm of the
    difference / ``scale``), the search's own resolution.  If the run at the pick is rejected,
    at the best logged point."""
    x_w = weighted_pick(log, tie, penalty)
    scale = np.ones_like(x_w) if scale is None else np.asarray(scale, dtype=float)
    d, err, x = min((float(np.max(np.abs((x - x_w) / scale))), err, tuple(x))
                    for x, err, _ in log.rows if admitted(err, penalty))
    how = f"the mean of the evaluated points weighted by exp(-((e - e_min)/{tie:.3g} N)^2/2)"
    if d <= resolution:
        return np.array(x), float(err), f"rests at the evaluated point nearest {how}"
    err = logged_call(log, objective, x_w)
    if admitted(err, penalty):
        return x_w, float(err), f"rests at {how}, evaluated there"
    x_best, best = best_logged(log)
    return x_best, best, f"the run at {how} was rejected; the best point is kept"


def stopped_at(log: EvaluationLog, objective, keep) -> tuple[np.ndarray, float, str]:
    """Where a search that its stop rule ended rests: at ``keep`` when given (its error
    from the log if it was evaluated, else evaluated and logged), else at the best logged
    point; with the words for the message.  A search stopped because the data cannot tell
    its points apart keeps a given start value: which of the points came out best would
    hinge on the last bits of the runs."""
    if keep is None:
        return (*best_logged(log), "the best of them is kept")
    keep = np.asarray(keep, dtype=float)
    for x, err, _ in log.rows:
        if np.array_equal(x, keep):
            return keep, err, "the start value is kept"
    return keep, logged_call(log, objective, keep), "the start value is kept"


def logged_call(log: EvaluationLog, objective, x: np.ndarray) -> float:
    """objective(x), replayed from the log when it holds the same point next, and logged."""
    hit = log.lookup(x)
    if hit is not None:
        log.append(x, hit[1], hit[2])
        return hit[1]
    t0 = time.perf_counter()
    err = float(objective(x))
    log.append(x, err, time.perf_counter() - t0)
    return err


def nelder_mead(objective, x0, names, *, xatol=1e-4, fatol=1e-6, maxfev=200,
                log_path=None, key="", restarts=0, start_scaling=None,
                step=SIMPLEX_STEP, stop=None, keep=None, tie: float = 0.0,
                penalty: float = np.inf) -> FitResult:
    """Minimise ``objective(x) -> float`` by Nelder-Mead from the paper's simplex.

    ``xatol`` is relative to ``x0`` (the search runs on x / x0, so parameters of
    very different magnitude -- E in MPa and n -- get the same resolution);
    ``fatol`` is absolute on the error.  A non-finite error is a rejected point:
    it is logged and replaced by ``inf`` so the simplex moves away from it.
    ``restarts``: after a run ends, start again from its best point with a fresh
    +5 % simplex (a collapsed simplex is a known failure of Nelder-Mead in narrow
    valleys) while the budget ``maxfev`` lasts and a restart still improves by
    more than ``fatol``.
    ``start_scaling=(lo, hi)``: before the simplex, a bounded 1-D search for the
    factor c in [lo, hi] minimising objective(c x0) moves the start to c x0 (its
    evaluations are logged like all others).
    ``stop(rows) -> reason | None``, asked after every evaluation with the logged rows
    (parameters, error, wall time): a reason ends the search at once, at the best point
    so far (or at ``keep``, see :func:`stopped_at`), with the reason as its message.
    ``tie`` > 0: a search that runs its course rests at the mean of its evaluations weighted
    by how close their errors come to the best, on the scale ``tie`` (:func:`rest_at_pick`,
    resolution ``xatol``; errors at or above ``penalty`` weigh nothing).
    ``key`` identifies the objective (e.g. a hash of its data and settings): a log
    written under another key is discarded instead of replayed.
    """
    x0 = np.asarray(x0, dtype=float)
    scale = np.where(x0 != 0.0, np.abs(x0), 1.0)
    log = EvaluationLog(log_path, names, key)

    def wrapped(z):
        err = logged_call(log, objective, z * scale)
        check_stop(stop, log)
        return err if np.isfinite(err) else np.inf

    z, best, converged, message = x0 / scale, np.inf, False, ""
    try:
        if start_scaling is not None:
            line = minimize_scalar(lambda c: wrapped(c * z), bounds=start_scaling, method="bounded",
                                   options={"xatol": 1e-3})
            z = line.x * z
        for _ in range(restarts + 1):
            budget = maxfev - len(log.rows)
            if budget < len(x0) + 2:
                break
            res = minimize(wrapped, z, method="Nelder-Mead",
                           options={"initial_simplex": initial_simplex(z * scale, step) / scale,
                                    "xatol": xatol, "fatol": fatol, "maxfev": budget, "adaptive": False})
            improved = best - float(res.fun)
            if res.fun < best:
                z, best = res.x, float(res.fun)
            converged, message = bool(res.success), str(res.message)
            if improved <= fatol:
                break
        x = z * scale
        if tie > 0.0 and admitted([r[1] for r in log.rows], penalty).any():
            x, best, how = rest_at_pick(log, objective, tie, xatol, scale, penalty)
            message = f"{message}; {how}"
    except StopSearch as reason:
        x, best, kept = stopped_at(log, objective, keep)
        converged, message = False, f"{reason}; {kept}"
    return FitResult(names=list(names), x=x, fun=best, nfev=len(log.rows),
                     converged=converged, message=message, trace=log.frame())
