"""Monte Carlo coverage of the reported 95 % intervals (issue 29).

The synthetic twin is regenerated at many seeds, each data set is fitted by the
stage itself, and every reported interval is checked against the truth it is meant
to contain:

* the Fisher interval (fit.json ``fisher``: load-cell noise read off the rows) is the
  uncertainty of the parameters *of the tested specimens*: its truth is the specimens'
  own mean parameters (the twin records each specimen's, ``truth.yaml`` ``samples``);
* the replicate sandwich (fit.json ``standard_error`` on ``standard_error_dof``) is the
  uncertainty of the population the specimens are drawn from: its truth is the twin's
  generating parameters (the config's paper table).

Standard errors are in ln p, so a nominal 95 % interval is ``estimate * exp(+-q SE)``
with q the normal quantile (Fisher) or Student's t on the sandwich's degrees of freedom.
Besides E, sigma_Y, K, n the study checks the eq. 2 flow stress sigma_Y + K eps_p^n at
plastic strains the test reaches (its SE from the covariance, by the delta method).

Data and fit use the same mesh (``preset``), so no mesh error mixes into the statistics.
"""
from __future__ import annotations

import json
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from scipy import stats

from harnesspipe.data import generators
from harnesspipe.data.synthesize import GENERATORS, read_truth, synthesize

TENSILE_STRAINS = (1e-2, 0.1)   # plastic strains of the issue-29 criterion (tube tensile tests)
# the fabric test reaches plastic strains of ~2.5 % only (calibrate.tensile.FABRIC_STRAINS)
STRAINS = {"closed_tube": TENSILE_STRAINS, "open_tube": TENSILE_STRAINS, "fabric_tube": (5e-3, 2.5e-2)}
ROM_STRAINS = (2e-3, 5e-3, 2e-2)   # plastic strains of the criterion (three-point tests)
PARAMETERS = ("E", "sigma_y", "K", "n")
Z95 = float(stats.norm.ppf(0.975))


@contextmanager
def _generator(name: str, fn):
    """``fn`` registered as synthesize generator ``name`` for the duration of the block."""
    GENERATORS[name] = fn
    try:
        yield name
    finally:
        GENERATORS.pop(name, None)


def tensile_twin(cfg: dict, seed: int, out: Path, components, preset: str = "quick") -> Path:
    """The twin's tensile tests of ``components`` at ``seed`` (specimen scatter and load-cell
    noise as the config's ``synthesize`` section), the curves made on the ``preset`` mesh,
    written into ``out`` (manifest, CSVs, truth.yaml) as ``harnesspipe synthesize`` does."""
    cfg = {**cfg, "synthesize": {**cfg["synthesize"], "seed": int(seed)}}

    def specs(c: dict):
        return [s for s in generators.tensile_tests(c, preset=preset) if s.item in components]

    with _generator("_coverage_tensile", specs) as name:
        return synthesize(cfg, Path(out), [name])


def fit_tensile(cfg: dict, data_dir: Path, component: str, work: Path, profile: str = "quick",
                maxfev: int | None = None) -> dict:
    """The tensile stage's fit (fit.json as a dict) of ``component`` in ``data_dir``, with the
    settings the pipeline passes for ``profile`` (``maxfev`` in place of its simplex budget)."""
    from harnesspipe.stages import stage_settings
    from harnesspipe.stages.data import prepare_test
    from harnesspipe.stages.tensile import fit_component
    settings = json.loads(stage_settings.tensile(cfg, cfg["profiles"][profile], component))
    if maxfev is not None:
        settings["maxfev"] = int(maxfev)
    ref = prepare_test(data_dir, f"tensile_{component}", Path(work) / "ref.h5")
    return fit_component(component, ref, settings, Path(work) / "fit")


def flow_stress(p: dict, eps_p: float) -> float:
    """Eq. 2: sigma_Y + K eps_p^n."""
    return p["sigma_y"] + p["K"] * eps_p ** p["n"]


def specimens_mean(truth_record: dict) -> dict:
    """The mean of the tested specimens' own parameters (truth.yaml ``samples``)."""
    samples = list(truth_record["samples"].values())
    return {k: float(np.mean([s[k] for s in samples])) for k in PARAMETERS}


def gauss_newton(on_rows, target: np.ndarray, p: dict, names: list[str],
                 iterations: int = 2) -> dict:
    """Least-squares parameters ``names`` of ``on_rows(p)`` against ``target`` by Gauss-Newton
    steps in ln p from ``p`` (the other parameters of ``p`` held)."""
    from harnesspipe.calibrate.uncertainty import log_sensitivities
    p = dict(p)
    for _ in range(iterations):
        J = log_sensitivities(on_rows, p, list(names))
        step, *_ = np.linalg.lstsq(J, target - on_rows(p), rcond=None)
        p.update({k: p[k] * float(np.exp(d)) for k, d in zip(names, step)})
    return p


def specimens_fit(cfg: dict, component: str, truth_record: dict, preset: str = "quick",
                  iterations: int = 2) -> dict:
    """What a fit to the specimens' mean curve finds without load-cell noise: the
    least-squares parameters of the mean of the specimens' noise-free curves (on the twin's
    rows), by Gauss-Newton steps in ln p from their mean parameters.  The Fisher interval
    describes the noise alone, so this is its truth; the specimens' mean parameters differ
    from it by the curvature of the model over the specimen scatter (second order in the 4 %
    scatter, yet comparable to Fisher SEs of 0.1-1 %)."""
    simulate = generators._tensile_simulator(cfg, component, preset)
    rows = int(cfg["synthesize"]["rows"])

    def on_rows(p: dict, u=None) -> np.ndarray:
        c = simulate(p)
        u = np.linspace(0.0, float(c.displacement[-1]), rows) if u is None else u
        return np.interp(u, c.displacement, c.force)

    target = np.mean([on_rows(s) for s in truth_record["samples"].values()], axis=0)
    return gauss_newton(on_rows, target, specimens_mean(truth_record), list(PARAMETERS), iterations)


def truths(truth_record: dict, specimens: dict | None = None) -> dict:
    """{"population": the generating parameters, "specimens": ``specimens`` (default: the
    specimens' mean parameters)} from one test's truth.yaml record."""
    return {"population": {k: float(truth_record["parameters"][k]) for k in PARAMETERS},
            "specimens": specimens or specimens_mean(truth_record)}


def covariance(se: dict, names: list[str], corr) -> np.ndarray | None:
    """Cov(ln p) from standard errors and a correlation matrix (None if any is missing)."""
    s = [se.get(k) for k in names]
    if corr is None or any(v is None for v in s) or any(c is None for row in corr for c in row):
        return None
    s = np.asarray(s, dtype=float)
    return np.asarray(corr, dtype=float) * np.outer(s, s)


def flow_stress_log_se(p: dict, names: list[str], cov: np.ndarray, eps_p: float) -> float:
    """SE of ln(sigma_Y + K eps_p^n) by the delta method from Cov(ln p) over ``names``."""
    s = flow_stress(p, eps_p)
    hard = p["K"] * eps_p ** p["n"]
    grad = {"sigma_y": p["sigma_y"] / s, "K": hard / s, "n": hard * p["n"] * np.log(eps_p) / s}
    g = np.array([grad.get(k, 0.0) for k in names])
    return float(np.sqrt(g @ cov @ g))


def quantities(p: dict, se: dict | None, names: list[str] | None, corr, strains) -> dict:
    """{quantity: (estimate, SE of its ln or None)} for E, sigma_y, K, n and the flow stress
    at each of ``strains`` (key ``flow@<eps>``)."""
    se = se or {}
    out = {k: (float(p[k]), se.get(k)) for k in PARAMETERS}
    cov = covariance(se, names, corr) if names else None
    for eps in strains:
        out[f"flow@{eps:g}"] = (flow_stress(p, eps),
                                None if cov is None else flow_stress_log_se(p, names, cov, eps))
    return out


def truth_values(p: dict, strains) -> dict:
    """The same quantities as :func:`quantities` at parameters ``p`` (no SE)."""
    return {**{k: float(p[k]) for k in PARAMETERS},
            **{f"flow@{eps:g}": flow_stress(p, eps) for eps in strains}}


def covers(estimate: float, se: float | None, truth: float, q: float) -> bool | None:
    """Whether estimate * exp(+-q se) contains ``truth`` (None without an SE)."""
    if se is None or not np.isfinite(se):
        return None
    return bool(abs(np.log(truth / estimate)) <= q * se)


def within(interval: dict, truth: float) -> bool:
    """Whether fit.json's ``interval95`` entry {lower, upper} (None: unbounded) holds ``truth``."""
    return ((interval["lower"] is None or interval["lower"] <= truth)
            and (interval["upper"] is None or truth <= interval["upper"]))


def interval_records(fit: dict, truth_record: dict, strains=TENSILE_STRAINS,
                     specimens: dict | None = None) -> list[dict]:
    """One row per quantity and kind of interval of one fit: estimate, truth, SE (ln),
    standardised error z = ln(estimate / truth) / SE, whether the 95 % interval covers and
    by which ``method``.  The Fisher kind of E, sigma_Y, K, n is the fit's reported
    ``interval95`` where it has one (Fisher or profile likelihood,
    :func:`harnesspipe.calibrate.profile.fit_intervals`), else estimate * exp(+-1.96 SE);
    the flow stresses and the sandwich: estimate * exp(+-q SE).  ``specimens``: the Fisher
    interval's truth (:func:`specimens_fit`; default the specimens' mean parameters)."""
    t = truths(truth_record, specimens)
    p = fit["parameters"]
    fisher = fit.get("fisher") or {}
    sandwich_corr = (fit.get("replicate_correlation") or {})
    reported = fit.get("interval95") or {}
    kinds = {
        "fisher": (quantities(p, fisher.get("standard_error"), fisher.get("names"),
                              fisher.get("correlation"), strains), t["specimens"], Z95),
        "sandwich": (quantities(p, fit.get("standard_error"), sandwich_corr.get("names"),
                                sandwich_corr.get("matrix"), strains), t["population"],
                     float(stats.t.ppf(0.975, fit["standard_error_dof"]))),
    }
    rows = []
    for kind, (values, truth_p, q) in kinds.items():
        truth = truth_values(truth_p, strains)
        for name, (est, se) in values.items():
            z = None if se is None or not se > 0 else float(np.log(est / truth[name]) / se)
            interval = reported.get(name) if kind == "fisher" else None
            if interval is not None:
                covered, method = within(interval, truth[name]), interval["method"]
            else:
                covered, method = covers(est, se, truth[name], q), "wald"
            rows.append({"kind": kind, "quantity": name, "estimate": est, "truth": truth[name],
                         "se": se, "q": q, "z": z, "covered": covered, "method": method,
                         "converged": bool(fit["converged"]), "nfev": int(fit["nfev"])})
    return rows


def tensile_seed(cfg: dict, seed: int, components, work: Path, preset: str = "quick",
                 profile: str = "quick", maxfev: int | None = None) -> list[dict]:
    """Regenerate the twin's tensile tests at ``seed`` and fit each component (``profile``'s
    settings, ``maxfev`` in place of its simplex budget); the :func:`interval_records` of
    every fit, tagged with seed and component."""
    data = tensile_twin(cfg, seed, Path(work) / "data", components, preset)
    truth = read_truth(data)
    rows = []
    for component in components:
        fit = fit_tensile(cfg, data, component, Path(work) / component, profile, maxfev)
        record = truth[f"tensile_{component}"]
        specimens = specimens_fit(cfg, component, record, preset)
        for r in interval_records(fit, record, STRAINS[component], specimens):
            rows.append({"seed": int(seed), "component": component, **r})
    return rows


def rom_twin(cfg: dict, seed: int, out: Path, cases, profile: str = "quick") -> Path:
    """The twin's three-point tests of ``cases`` at ``seed``, the curves made by the ROM on
    the mesh of the config's ``profile``, written into ``out`` as ``harnesspipe synthesize``
    does."""
    cfg = {**cfg, "synthesize": {**cfg["synthesize"], "seed": int(seed)}}

    def specs(c: dict):
        return [s for s in generators.three_point(c, profile) if s.item in cases]

    with _generator("_coverage_three_point", specs) as name:
        return synthesize(cfg, Path(out), [name])


def rom_settings(cfg: dict, case: str, profile: str = "quick", maxfev: int | None = None) -> dict:
    """The ROM stage's settings of ``case`` for ``profile``, fitted to the measured mean
    (``rom.reference: measured``), ``maxfev`` in place of the profile's simplex budget."""
    from harnesspipe.stages import stage_settings
    settings = json.loads(stage_settings.rom(cfg, cfg["profiles"][profile], case))
    settings["reference"] = "measured"
    if maxfev is not None:
        settings["maxfev"] = int(maxfev)
    return settings


def rom_specimens_fit(truth_record: dict, settings: dict, u, iterations: int = 2) -> dict:
    """The Fisher interval's truth for the ROM stage: what its estimator finds on the mean of
    the specimens' noise-free curves on the rows ``u`` -- E by eq. 13 with the model-consistent
    factor (:func:`harnesspipe.calibrate.rom.effective_modulus`), the least-squares hardening
    at that E by Gauss-Newton from the specimens' mean parameters, then, with
    ``consistent_E_model: elastoplastic``, the stage's elastoplastic window from there
    (:func:`harnesspipe.calibrate.rom.elastoplastic_window`)."""
    from harnesspipe.calibrate import rom as rom_fit
    u = np.asarray(u, dtype=float)

    def on_rows(p: dict) -> np.ndarray:
        return rom_fit.simulate_on(u, p, settings)

    target = np.mean([on_rows(s) for s in truth_record["samples"].values()], axis=0)
    p = {**specimens_mean(truth_record), "E": rom_fit.effective_modulus(u, target, settings)[0]}
    p = gauss_newton(on_rows, target, p, rom_fit.hardening_names(settings["rom"]), iterations)
    if rom_fit.elastoplastic(settings["rom"]):
        p = rom_fit.elastoplastic_window(u, target, p, settings)[0]
    return p


def rom_seed(cfg: dict, seed: int, cases, work: Path, profile: str = "quick",
             maxfev: int | None = None) -> list[dict]:
    """Regenerate the twin's three-point tests of ``cases`` at ``seed`` (ROM on ``profile``'s
    mesh) and fit each by the ROM stage (same mesh, measured reference); the
    :func:`interval_records` of every fit at the flow-stress strains ROM_STRAINS, tagged with
    seed and case (as ``component``)."""
    from harnesspipe.stages.data import prepare_test, read_prepared
    from harnesspipe.stages.rom import fit_case
    data = rom_twin(cfg, seed, Path(work) / "data", cases, profile)
    truth = read_truth(data)
    rows = []
    for case in cases:
        test_id = f"bend_{case}"
        settings = rom_settings(cfg, case, profile, maxfev)
        ref = prepare_test(data, test_id, Path(work) / case / "ref.h5")
        fit = fit_case(case, ref, settings, Path(work) / case / "fit")
        u, _ = read_prepared(ref).rows()
        specimens = rom_specimens_fit(truth[test_id], settings, u)
        for r in interval_records(fit, truth[test_id], ROM_STRAINS, specimens):
            rows.append({"seed": int(seed), "component": case, **r})
    return rows


def coverage_table(rows: list[dict]) -> list[dict]:
    """Coverage per (component, kind, quantity): intervals, covered, fraction, the mean
    square of the standardised errors z (1 when a Fisher SE is right; a sandwich's z is
    Student t on 2 dof, whose mean square is infinite) and their median |z| (0.67 for a right
    Fisher SE, 0.82 for a right sandwich on 2 dof)."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["component"], r["kind"], r["quantity"]), []).append(r)
    table = []
    for (component, kind, quantity), rs in groups.items():
        have = [r for r in rs if r["covered"] is not None]
        z = np.array([r["z"] for r in have if r["z"] is not None])
        table.append({"component": component, "kind": kind, "quantity": quantity,
                      "seeds": len(rs), "intervals": len(have),
                      "covered": sum(r["covered"] for r in have),
                      "coverage": (sum(r["covered"] for r in have) / len(have)) if have else None,
                      "mean_z2": float(np.mean(z**2)) if z.size else None,
                      "median_abs_z": float(np.median(np.abs(z))) if z.size else None})
    return table
