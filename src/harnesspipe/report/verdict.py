"""The report's verdict: per stage and calibrated parameter, its value beside the paper's,
its standard error, the fit's error against the test and a status, and the limitations
that follow from those numbers.

Every status and every limitation is a condition on the result files (fit.json, the hi-fi
summaries, the curves) and the config; nothing here is prose about a particular run.

Statuses (a parameter can carry several; "determined" only when no other holds):

* *model does not match the test* -- the relative l2 error of the model against the
  measured mean exceeds the goal of its role (config ``hifi.pipeline.fidelity_goal``) by more
  than the error's run-to-run spread (:func:`judge`);
* *at the goal within the run-to-run spread* -- the error of a hi-fi run lies within
  ``hifi.pipeline.fidelity_spread`` of its goal, where another machine's last bits could put
  it on either side;
* *on a bound* -- the value lies within :data:`BOUND_TOL` of the width of its search
  interval (at least the search's tolerance) of an end of it; for a half-open interval
  (0, inf), within :data:`BOUND_TOL` of the paper's value of zero;
* *not identifiable* -- its relative standard error (of ln p) exceeds :data:`UNDETERMINED`
  or the fit's identifiability screen stopped it (fit.json ``message``);
* *no standard error* -- the fit gives none (a deterministic hi-fi search, a ROM fitted to
  one hi-fi curve): how well the data fix it is not known;
* *determined* (SE below :data:`DETERMINED`) or *roughly determined* (up to UNDETERMINED).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from harnesspipe.calibrate import eq13
from harnesspipe.calibrate.hardening import N_MAX
from harnesspipe.calibrate.hifi import covered
from harnesspipe.calibrate.objective import relative_l2_error
from harnesspipe.models.free_wires import coupling, free_wire_force
from harnesspipe.report.names import physical_name
from harnesspipe.stages.chain_settings import STEPS as CHAIN_STEPS
from harnesspipe.stages.chain_settings import budget as chain_budget
from harnesspipe.stages.chain_settings import chain_profile
from harnesspipe.stages.chain_settings import cases as chain_cases
from harnesspipe.stages.common import read_fit

DETERMINED, UNDETERMINED = 0.05, 0.3   # relative standard error: "determined" below, "not" above
BOUND_TOL = 0.01                       # "on a bound": within 1 % of the search interval

MISMATCH = "model does not match the test"
AT_GOAL = "at the goal within the run-to-run spread"
ON_BOUND = "on a bound"
NOT_IDENTIFIABLE = "not identifiable"
NO_SE = "no standard error"
ROUGH = "roughly determined"
OK = "determined"
STATUS_ORDER = (MISMATCH, AT_GOAL, ON_BOUND, NOT_IDENTIFIABLE, NO_SE, ROUGH, OK)
STATUS_CLASS = {MISMATCH: "st-mismatch", AT_GOAL: "st-near", ON_BOUND: "st-bound", NOT_IDENTIFIABLE: "st-unident",
                NO_SE: "st-nose", ROUGH: "st-rough", OK: "st-ok"}
STAGE_NAMES = {"tensile": "component tensile (Table 2)", "hifi": "hi-fi interface (Sec. 4.2)",
               "rom": "ROM beam (Table 3)", "branch": "branch damping (Sec. 5)"}
SYMBOLS = {"sigma_y": "sigma_Y"}     # parameter names as the paper writes them
HARDENING_BOUNDS = {"sigma_y": (0.0, math.inf), "K": (0.0, math.inf), "n": (0.0, N_MAX)}


@dataclass
class Row:
    """One calibrated parameter of the verdict."""
    stage: str
    item: str
    parameter: str
    value: float
    paper: float | None = None
    truth: float | None = None
    se: float | None = None           # relative standard error (of ln p)
    se_source: str = ""               # "Fisher" | "replicates"
    se_replicates: float | None = None  # the replicate sandwich's, shown beside Fisher's
    error: float | None = None        # relative l2 error of the model against the measured mean
    error_of: str = ""                # what the error is against
    goal: float | None = None         # the goal of that error
    spread: float = 0.0               # the error's run-to-run spread (judge)
    bound: tuple | None = None        # (lo, hi) the value sits on, when it does
    statuses: list = field(default_factory=list)

    @property
    def difference(self) -> float | None:
        """Relative difference to the paper's value (None without one)."""
        if self.paper in (None, 0) or not isinstance(self.paper, (int, float)):
            return None
        return (self.value - self.paper) / self.paper


def bound_hit(value: float, bounds, atol: float):
    """The end of the search interval ``bounds`` = (lo, hi) that ``value`` lies within
    ``atol`` of (None: neither)."""
    lo, hi = bounds
    for b in (lo, hi):
        if math.isfinite(b) and abs(value - b) <= atol:
            return b
    return None


MET, NEAR, MISSED = "met", "at the goal", "missed"


def judge(error: float, goal: float, spread: float = 0.0) -> str:
    """An error against its goal: MISSED above goal + spread, MET at or below goal - spread,
    NEAR in between.  ``spread`` is the error's run-to-run spread: an explicit run's last
    bits differ between machines (bench/RESULTS.md, 'Hi-fi outcome against the last bits'),
    and within it no machine's met or missed means more than another's; 0 for the implicit
    and closed-form fits, whose errors do not move so."""
    if error > goal + spread:
        return MISSED
    return MET if error <= goal - spread else NEAR


JUDGED_STATUS = {MISSED: MISMATCH, NEAR: AT_GOAL}   # the status a judged error gives (MET: none)


def statuses(*, se, on_bound, error, goal, spread: float = 0.0, screened: bool = False) -> list[str]:
    """The statuses of a parameter (see module docstring), most severe first."""
    judged = MET if error is None or goal is None else judge(error, goal, spread)
    out = [JUDGED_STATUS[judged]] if judged in JUDGED_STATUS else []
    if on_bound:
        out.append(ON_BOUND)
    if screened or (se is not None and se > UNDETERMINED):
        out.append(NOT_IDENTIFIABLE)
    elif se is None:
        out.append(NO_SE)
    if not out:
        out.append(OK if se < DETERMINED else ROUGH)
    return out


def _standard_error(fit: dict, name: str) -> tuple[float | None, str]:
    """(relative SE, source) of a parameter: Fisher's where it has one, else the replicate
    sandwich's, else (None, "")."""
    fisher = fit.get("fisher") or {}
    se = (fisher.get("standard_error") or {}).get(name)
    if se is not None and math.isfinite(se):
        return float(se), "Fisher"
    se = (fit.get("standard_error") or {}).get(name)
    if se is not None and math.isfinite(se):
        return float(se), "replicates"
    return None, ""


def _goal(cfg: dict, role: str) -> float:
    goals = cfg["hifi"]["pipeline"]["fidelity_goal"]
    return float(goals.get(role, goals["prediction"]))


def points(x: float) -> str:
    """A difference of relative errors in percentage points: "1 point", "0.7 points"."""
    text = f"{100.0 * x:.2g}"
    return f"{text} point" + ("" if text == "1" else "s")


def hifi_spread(cfg: dict) -> float:
    """The run-to-run spread of a hi-fi run's relative error (``hifi.pipeline.fidelity_spread``)."""
    return float(cfg["hifi"]["pipeline"]["fidelity_spread"])


def curve_error(curve: pd.DataFrame, prepared) -> float:
    """Relative l2 error of a model curve (displacement_mm or deflection_mm, force_N)
    against the measured mean, on the measured grid points the curve covers."""
    x = curve["deflection_mm"] if "deflection_mm" in curve else curve["displacement_mm"]
    x, F = np.asarray(x, dtype=float), np.asarray(curve["force_N"], dtype=float)
    order = np.argsort(x, kind="stable")
    x, F = x[order], F[order]
    mask = covered(prepared.grid, x)
    return relative_l2_error(prepared.mean[mask], np.interp(prepared.grid[mask], x, F))


def force_ratio(curve: pd.DataFrame, prepared) -> float:
    """Model force over measured force, summed over the measured grid the curve covers
    (how much of the test's force the model reaches)."""
    x = curve["deflection_mm"] if "deflection_mm" in curve else curve["displacement_mm"]
    x, F = np.asarray(x, dtype=float), np.asarray(curve["force_N"], dtype=float)
    order = np.argsort(x, kind="stable")
    mask = covered(prepared.grid, x)
    return float(np.interp(prepared.grid[mask], x[order], F[order]).sum() / prepared.mean[mask].sum())


def times(x: float) -> str:
    """A multiple in words: '2.53x'."""
    return f"{x:.2f}x"


def couplings(curve: pd.DataFrame, prepared, cfg: dict, case: str) -> tuple[float, float]:
    """(virtual test, test): each one's force at the end of the measured grid the curve
    covers over the force of the case's wires bending each on its own
    (:mod:`harnesspipe.models.free_wires`), i.e. how many times its wires' own force the
    covering, the tape and the friction make the bundle carry."""
    x = np.asarray(curve["deflection_mm"], dtype=float)
    u_end = min(float(x.max()), float(prepared.grid[-1]))
    F_free = free_wire_force(cfg, chain_cases(cfg)[case]["wires"], [u_end])
    F = [np.interp(u_end, x, np.asarray(curve["force_N"], dtype=float)),
         np.interp(u_end, prepared.grid, prepared.mean)]
    return tuple(float(c) for c in coupling(F, np.repeat(F_free, 2)))


def _row(stage, item, name, value, fit, *, paper, truth, error, error_of, goal, bounds, atol,
         spread=0.0, screened=False) -> Row:
    se, source = _standard_error(fit, name) if fit is not None else (None, "")
    rep = (fit or {}).get("standard_error") or {}
    se_rep = rep.get(name) if rep.get(name) is not None and math.isfinite(rep[name]) else None
    hit = bound_hit(value, bounds, atol) if bounds is not None and atol is not None else None
    return Row(stage, item, name, float(value), paper=paper, truth=truth, se=se, se_source=source,
               se_replicates=se_rep,
               error=error, error_of=error_of, goal=goal, spread=spread,
               bound=bounds if hit is not None else None,
               statuses=statuses(se=se, on_bound=hit is not None, error=error, goal=goal,
                                 spread=spread, screened=screened))


def _hardening_atol(name: str, paper: dict | None):
    """Tolerance of the hardening law's admissible set: BOUND_TOL of the width for n in
    (0, N_MAX]; BOUND_TOL of the paper's value for (0, inf) (None without a paper value)."""
    lo, hi = HARDENING_BOUNDS[name]
    if math.isfinite(hi):
        return BOUND_TOL * (hi - lo)
    value = (paper or {}).get(name)
    return BOUND_TOL * abs(float(value)) if value else None


def tensile_rows(paths, cfg: dict, truth: dict) -> list[Row]:
    rows = []
    for path in sorted(paths):
        fit = read_fit(path)
        paper = cfg["paper"].get("table2", {}).get(fit["item"])
        tr = truth.get(fit["test_id"], {}).get("parameters", {})
        for name, value in fit["parameters"].items():
            bounds = HARDENING_BOUNDS.get(name)
            rows.append(_row("tensile", fit["item"], name, value, fit,
                             paper=(paper or {}).get(name), truth=tr.get(name),
                             error=float(fit["error_rel"]), error_of=f"test {fit['test_id']}",
                             goal=_goal(cfg, "calibration"), bounds=bounds,
                             atol=_hardening_atol(name, paper) if bounds else None))
    return rows


def rom_errors(fit: dict, fit_dir: Path, results: Path, measured: dict, cfg: dict) -> dict:
    """A ROM fit's relative l2 errors: ``reference`` (the curve it was fitted to: fit.json),
    ``test`` (its curve against the case's measured mean; None without a test), the
    ``goal`` of the case's role (its virtual test's role; prediction without one), the
    test error's ``spread`` (a hi-fi run's, when the ROM is fitted to one; else 0) and, for
    a ROM fitted to a virtual test, ``test_window`` (:func:`test_window_moduli`)."""
    case = fit["item"]
    summary = results / "hifi" / "virtual" / case / "summary.json"
    role = "prediction"
    if summary.exists():
        role = str(json.loads(summary.read_text()).get("role", role))
    test = None
    if case in measured:
        test = curve_error(pd.read_csv(fit_dir / "curve.csv"), measured[case])
    hifi = fit["test_id"].startswith("hifi:")
    return {"reference": float(fit["error_rel"]), "test": test, "goal": _goal(cfg, role), "role": role,
            "spread": hifi_spread(cfg) if hifi else 0.0,
            "test_window": test_window_moduli(case, results, measured, cfg) if hifi else None,
            "fitted_to": "hi-fi virtual test" if fit["test_id"].startswith("hifi:") else f"test {fit['test_id']}"}


def test_window_moduli(case: str, results: Path, measured: dict, cfg: dict) -> dict | None:
    """eq. 13 read the same way on the virtual test and on its test: E over the test's own
    linear part 0 < u <= u_lin (u_lin of the measured mean, :func:`eq13.linear_part`), of the
    hi-fi curve (``E_hifi``) and of the measured mean (``E_test``).  The ROM's E reads each
    curve's own linear part; where a virtual test is not linear over the millimetres the
    test is, the two differ, and this says whether its stiffness over the test's linear part
    agrees.  None without a virtual test or a test of the case."""
    curve = Path(results) / "hifi" / "virtual" / case / "curve.csv"
    if case not in measured or not curve.exists():
        return None
    span, r_o = float(cfg["three_point"]["span"]), float(chain_cases(cfg)[case]["r_o"])
    test = measured[case]
    slope, u_lin = eq13.linear_part(test.grid, test.mean, span)
    hifi = pd.read_csv(curve)
    slope_hifi = eq13.slope_up_to(hifi["deflection_mm"], hifi["force_N"], u_lin)
    return {"u_lin": u_lin, "E_hifi": eq13.modulus_from_slope(slope_hifi, span, r_o),
            "E_test": eq13.modulus_from_slope(slope, span, r_o)}


def rom_rows(paths, cfg: dict, truth: dict, results: Path, measured: dict) -> list[Row]:
    rows = []
    for path in sorted(paths):
        fit = read_fit(path)
        paper = cfg["paper"].get("table3", {}).get(fit["item"])
        err = rom_errors(fit, path.parent, results, measured, cfg)
        test_id = measured[fit["item"]].test_id if fit["item"] in measured else fit["test_id"]
        tr = truth.get(test_id, {}).get("parameters", {})
        for name, value in fit["parameters"].items():
            bounds = HARDENING_BOUNDS.get(name)
            rows.append(_row("rom", fit["item"], name, value, fit, paper=(paper or {}).get(name),
                             truth=tr.get(name), error=err["test"], error_of=f"test {test_id}",
                             goal=err["goal"], spread=err["spread"], bounds=bounds,
                             atol=_hardening_atol(name, paper) if bounds else None))
    return rows


def _virtual_error(results: Path, case: str) -> float | None:
    path = results / "hifi" / "virtual" / case / "summary.json"
    if not path.exists():
        return None
    m = json.loads(path.read_text()).get("measured")
    return float(m["error_rel"]) if m else None


def hifi_rows(results: Path, cfg: dict) -> list[Row]:
    """The calibration chain's parameters (results/hifi/chain/*/fit.json), each with the
    largest error of the final virtual tests of the cases its step fitted on (else of the
    step's best point)."""
    pipe = cfg["hifi"]["pipeline"]
    paper = cfg["paper"].get("interface", {})
    rows = []
    order = list(CHAIN_STEPS)
    steps = sorted((results / "hifi" / "chain").glob("*/fit.json"),
                   key=lambda p: (order.index(p.parent.name) if p.parent.name in order else len(order), p.parent.name))
    for path in steps:
        fit = read_fit(path)
        errors = []
        for case in fit.get("cases", []):
            e = _virtual_error(results, case)
            if e is None:
                e = ((fit.get("per_case") or {}).get(case, {}).get("measured") or {}).get("error_rel")
            if e is not None:
                errors.append((float(e), case))
        error, worst = max(errors) if errors else (None, "")
        screened = "not identifiable" in str(fit.get("message", ""))
        bounds = tuple(fit["bounds"]) if fit.get("bounds") else None
        atol = max(BOUND_TOL * (bounds[1] - bounds[0]), float(pipe["bounded_xatol"])) if bounds else None
        for name, value in fit["parameters"].items():
            rows.append(_row("hifi", fit["item"], name, value, None, paper=paper.get(name), truth=None,
                             error=error, error_of=f"virtual test {worst}" if worst else "",
                             goal=_goal(cfg, "calibration"), spread=hifi_spread(cfg), bounds=bounds,
                             atol=atol, screened=screened))
    return rows


def branch_rows(paths, cfg: dict, truth: dict) -> list[Row]:
    """The calibrated alpha (role calibration); the fixed alpha = 0 and the validation run are
    not calibrations."""
    br = cfg["branch"]
    bounds = tuple(br["alpha_bounds"])
    atol = max(BOUND_TOL * (bounds[1] - bounds[0]), float(br.get("alpha_xatol", 0.0)))
    rows = []
    for path in sorted(paths):
        fit = read_fit(path)
        if fit.get("role", "calibration") != "calibration":
            continue
        tr = truth.get(fit["test_id"], {}).get("parameters", {})
        for name, value in fit["parameters"].items():
            rows.append(_row("branch", "Y harness", name, value, fit,
                             paper=cfg["paper"].get("damping", {}).get(name), truth=tr.get(name),
                             error=float(fit["error_rel"]), error_of=f"test {fit['test_id']}",
                             goal=_goal(cfg, "calibration"), bounds=bounds, atol=atol))
    return rows


def verdict_rows(cfg: dict, results: Path, fits: dict, truth: dict, measured: dict) -> list[Row]:
    """Every calibrated parameter, in the order of the chain: tensile, hi-fi, ROM, branch."""
    results = Path(results)
    return (tensile_rows(fits.get("tensile", []), cfg, truth) + hifi_rows(results, cfg)
            + rom_rows(fits.get("rom", []), cfg, truth, results, measured)
            + branch_rows(fits.get("branch", []), cfg, truth))


# --------------------------------------------------------------------------- limitations

def _pct(x: float) -> str:
    return f"{100.0 * x:.0f} %" if x >= 0.1 else f"{100.0 * x:.2g} %"


def _span(values) -> str:
    """'23-58 %' (or one value) of relative values."""
    lo, hi = _pct(min(values)), _pct(max(values))
    return lo if lo == hi else f"{lo.removesuffix(' %')}-{hi}"


def _listed(items: list[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _names(rows, cfg) -> str:
    """'sigma_Y, K and n of <item>; mu_rtb and delta0 (hi-fi interface); ...' (grouped by item,
    the hi-fi interface as one)."""
    groups: dict = {}
    for r in rows:
        key = "(hi-fi interface)" if r.stage == "hifi" else f"of {physical_name(r.item, cfg)}"
        groups.setdefault(key, []).append(SYMBOLS.get(r.parameter, r.parameter))
    return "; ".join(f"{_listed(names)} {key}" for key, names in groups.items())


def _fit_name(row: Row, cfg: dict) -> str:
    """'the hi-fi step mu_rtb', 'the component tensile (Table 2) fit of closed tube (...)'."""
    if row.stage == "hifi":
        return f"the hi-fi step {row.item}"
    return f"the {STAGE_NAMES[row.stage]} fit of {physical_name(row.item, cfg)}"


def _quasi_static(results: Path, cfg: dict) -> str | None:
    """The hi-fi virtual tests whose KE/IE exceeds the paper's quasi-static target
    (``explicit.ke_ie_max``, Sec. 4.1), or None."""
    target = cfg.get("explicit", {}).get("ke_ie_max")
    runs = {p.parent.name: json.loads(p.read_text()).get("ke_ie_max")
            for p in sorted((Path(results) / "hifi" / "virtual").glob("*/summary.json"))}
    above = {k: float(v) for k, v in runs.items() if v is not None and target is not None and v > target}
    if not above:
        return None
    return (f"{len(above)} of {len(runs)} hi-fi virtual tests exceed the quasi-static target KE/IE "
            f"{target:g} of Sec. 4.1 (up to {max(above.values()):.3g}; "
            f"{'; '.join(physical_name(k, cfg) for k in above)}): their inertia is not negligible.")


def _falls(results: Path, cfg: dict, measured: dict) -> str | None:
    """The hi-fi virtual tests whose force falls by a tenth of its peak or more
    (:func:`harnesspipe.models.hifi.is_fall`; a snap when within a few mm), and whether the
    measured means of those cases (``measured``: case -> prepared test) fall too; None when
    none falls."""
    from harnesspipe.models.hifi import FALL_FRACTION, SNAP_SPAN_MM, force_drop, is_fall, is_snap
    drops = {p.parent.name: json.loads(p.read_text()).get("force_drop")
             for p in sorted((Path(results) / "hifi" / "virtual").glob("*/summary.json"))}
    falls = {k: d for k, d in drops.items() if is_fall(d)}
    if not falls:
        return None
    listed = "; ".join(f"{physical_name(k, cfg)}: {d['drop_N']:.3g} N ({_pct(d['fraction'])}) between "
                       f"{d['from_mm']:.1f} and {d['to_mm']:.1f} mm{', a snap' if is_snap(d) else ''}"
                       for k, d in falls.items())
    tested = [k for k in falls if k in measured]
    steady = [k for k in tested if not is_fall(force_drop(measured[k].grid, measured[k].mean))]
    said = ""
    if tested:
        which = ("None of their measured means falls so" if len(steady) == len(tested) else
                 f"The measured means of {len(steady)} of these {len(tested)} cases do not fall so")
        said = (f" {which}: where a virtual fall happens decides much of its error, and it moves "
                "with the build and interface values, so a calibration on such curves partly fits it.")
    return (f"{len(falls)} of {len(drops)} hi-fi virtual tests fall by {_pct(FALL_FRACTION)} or more of "
            f"their peak force (a snap: within {SNAP_SPAN_MM:g} mm) ({listed})." + said)


def hifi_fidelity(results: Path, cfg: dict, measured: dict) -> list[dict]:
    """Each virtual test with a measured test: case, role, error, goal, its ``verdict``
    (:func:`judge` with the hi-fi spread), force ratio and ``coupling`` (:func:`couplings`)."""
    out = []
    for path in sorted((Path(results) / "hifi" / "virtual").glob("*/summary.json")):
        summary = json.loads(path.read_text())
        case, m = path.parent.name, summary.get("measured")
        if not m or case not in measured or not (path.parent / "curve.csv").exists():
            continue
        role = str(summary.get("role", "prediction"))
        error, goal = float(m["error_rel"]), _goal(cfg, role)
        curve = pd.read_csv(path.parent / "curve.csv")
        out.append({"case": case, "role": role, "error": error, "goal": goal,
                    "verdict": judge(error, goal, hifi_spread(cfg)),
                    "ratio": force_ratio(curve, measured[case]),
                    "coupling": couplings(curve, measured[case], cfg, case)})
    return out


def chain_mesh(cfg: dict) -> str | None:
    """The profile whose mesh the chain's fits ran on, when it is not the run's own
    (``hifi.pipeline.chain_profile``), else None."""
    chain = chain_profile(cfg)
    return None if chain == cfg["profile"] else chain


def limitations(rows: list[Row], cfg: dict, results: Path, fits: dict, truth: dict,
                measured: dict, fidelity: list[dict] | None = None) -> list[str]:
    """Sentences on what not to trust, each produced by a condition on the results;
    ``fidelity``: :func:`hifi_fidelity` when the caller has it already."""
    fid = hifi_fidelity(results, cfg, measured) if fidelity is None else fidelity
    out = _profile_limits(cfg) + _fidelity_limits(fid, cfg)
    out += _mismatch_limits(rows, cfg, covered={"rom"} | ({"hifi"} if fid else set()))
    out += _rom_limits(rows, fits) + _parameter_limits(rows, cfg) + _fit_limits(fits, results, cfg)
    out += [s for s in (_quasi_static(results, cfg), _falls(results, cfg, measured)) if s]
    if truth:
        out.append("The test data are the synthetic twin, generated from the paper's values "
                   "(data/experimental/README.md): agreement with the paper's tables is agreement "
                   "with the generator, not with a laboratory.")
    return out


def _profile_limits(cfg: dict) -> list[str]:
    """A reduced profile, and a chain run on another profile's mesh and budget."""
    out, profile = [], cfg.get("profile", "default")
    chain, budget = chain_mesh(cfg), chain_budget(cfg)
    searches = (f"hi-fi searches stop after {budget['bounded_maxfev']} (bounded) or "
                f"{budget['simplex_maxfev']} (simplex) evaluations" if budget else "")
    if profile != "default":
        out.append(f"This run is of the {profile} profile (coarser meshes"
                   + (f"; {searches}" if searches and not chain else "")
                   + "), not the default profile's reproduction.")
    if chain:
        out.append(f"The calibration chain ran on the {chain} profile's mesh"
                   + (f", with its budget ({searches})," if searches else "")
                   + f" and the virtual tests on the {profile} profile's (hifi.pipeline.chain_profile), "
                   "so a calibration case's error includes the difference between the meshes.")
    return out


def _fidelity_limits(fid: list[dict], cfg: dict) -> list[str]:
    """The virtual tests that miss their goal (with the coupling the wires see), and those
    within the run-to-run spread of it (:func:`hifi_fidelity`)."""
    out = []
    missed = [f for f in fid if f["verdict"] == MISSED]
    if missed:
        ratios = [f["ratio"] for f in missed]
        out.append(f"The hi-fi model does not match the bending tests: {len(missed)} of {len(fid)} virtual "
                   f"tests miss their goal, with relative errors of {_span([f['error'] for f in missed])}; "
                   f"their force is {_span(ratios)} of the measured force "
                   f"({'; '.join(physical_name(f['case'], cfg) + ': ' + _pct(f['ratio']) for f in missed)}).")
        out.append("At the test's end each carries this many times its wires' own force (the wires bending "
                   "each on its own; what the covering, the tape and the friction add), virtual test / test: "
                   + "; ".join(f"{physical_name(f['case'], cfg)} {times(f['coupling'][0])} / "
                               f"{times(f['coupling'][1])}" for f in missed)
                   + ". Where the two differ, what misses is what holds the wires together: the wires themselves are the same in both.")
    near = [f for f in fid if f["verdict"] == NEAR]
    if near:
        out.append(f"{len(near)} virtual test{'s lie' if len(near) > 1 else ' lies'} within the run-to-run "
                   f"spread ({points(hifi_spread(cfg))}, hifi.pipeline.fidelity_spread) of "
                   f"{'their' if len(near) > 1 else 'its'} goal, where another machine's last bits could "
                   "decide met or missed: "
                   + "; ".join(f"{physical_name(f['case'], cfg)} ({100 * f['error']:.1f} % against "
                               f"{_pct(f['goal'])})" for f in near) + ".")
    return out


def _mismatch_limits(rows: list[Row], cfg: dict, covered: set) -> list[str]:
    """Fits of the stages not ``covered`` by a sentence of their own that miss their test."""
    other = {(r.stage, r.item): r for r in rows if MISMATCH in r.statuses and r.stage not in covered}
    if not other:
        return []
    return ["The model misses its test by more than the goal for "
            + "; ".join(f"{_fit_name(r, cfg)} ({_pct(r.error)} against {_pct(r.goal)})"
                        for r in other.values())
            + ": its fitted values compensate for what the model lacks."]


def _rom_limits(rows: list[Row], fits: dict) -> list[str]:
    """The ROM fitted to the virtual tests: how far from them, and from the tests."""
    rom = [r for r in rows if r.stage == "rom"]
    rom_fits = [read_fit(p) for p in fits.get("rom", [])]
    if not (rom and any(f["test_id"].startswith("hifi:") for f in rom_fits)):
        return []
    errs = sorted({(r.item, r.error) for r in rom if r.error is not None})
    refs = [float(f["error_rel"]) for f in rom_fits]
    if not errs:
        return []
    return [f"The ROM properties (Table 3) are fitted to the hi-fi virtual tests "
            f"(rom.reference: hifi), not to the tests: they reproduce the hi-fi curves to "
            f"{_span(refs)} but the measured means only to {_span([e for _, e in errs])}."]


def _parameter_limits(rows: list[Row], cfg: dict) -> list[str]:
    """Parameters on a bound of their search, not determined, or without a standard error."""
    out = []
    bound = [r for r in rows if ON_BOUND in r.statuses]
    if bound:
        out.append(f"{len(bound)} parameter{'s sit' if len(bound) > 1 else ' sits'} on a bound of "
                   f"{'their' if len(bound) > 1 else 'its'} search, so the value reflects the bound, not the "
                   f"data: {_names(bound, cfg)}.")
    unident = [r for r in rows if NOT_IDENTIFIABLE in r.statuses]
    if unident:
        out.append(f"The data do not determine {_names(unident, cfg)} (relative standard error above "
                   f"{_pct(UNDETERMINED)}, or stopped by the fit's identifiability screen).")
    nose = [r for r in rows if NO_SE in r.statuses]
    if nose:
        stages = list(dict.fromkeys(STAGE_NAMES[r.stage] for r in nose))
        out.append(f"{len(nose)} parameter{'s carry' if len(nose) > 1 else ' carries'} no standard error "
                   f"({', '.join(stages)}): how well the data fix {'them' if len(nose) > 1 else 'it'} is not known.")
    return out


def _fit_limits(fits: dict, results: Path, cfg: dict) -> list[str]:
    """Residuals beyond the load-cell noise, searches stopped at their evaluation limit, and
    hi-fi chain decisions within the last-bits spread of their threshold."""
    out, unconverged, marginal = [], [], []
    for stage, paths in fits.items():
        if stage == "hifi":   # the chain's targets (interface.csv, summaries): its fits follow below
            continue
        for p in paths:
            fit = read_fit(p)
            chi = fit.get("chi_square") or {}
            if chi and chi.get("pass") is False:
                out.append(f"The residual of the {physical_name(fit['item'], cfg)} fit is larger than the "
                           f"load-cell noise (chi2/dof {chi['chi2_per_dof']:.3g}, p = {chi['p_value']:.2g}): "
                           "model error beyond the noise; its Fisher standard errors understate the "
                           "uncertainty.")
            if not fit.get("converged", True) and fit.get("role", "calibration") == "calibration":
                unconverged.append(f"{STAGE_NAMES[stage]} of {physical_name(fit['item'], cfg)} "
                                   f"({fit['nfev']} evaluations)")
    for p in sorted((Path(results) / "hifi" / "chain").glob("*/fit.json")):
        fit = read_fit(p)
        if not fit.get("converged", True) and "not identifiable" not in str(fit.get("message", "")):
            unconverged.append(f"hi-fi step {fit['item']} ({fit['nfev']} evaluations)")
        if (fit.get("decision") or {}).get("marginal"):
            marginal.append(fit["item"])
    if unconverged:
        out.append("The optimiser stopped at its evaluation limit without converging for: "
                   + "; ".join(unconverged) + ".")
    if marginal:
        out.append("Hi-fi chain decisions within the runs' last-bits spread of their threshold "
                   f"(another machine may decide them the other way): {', '.join(marginal)}.")
    return out
