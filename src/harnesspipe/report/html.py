"""The offline HTML report: one self-contained file, figures embedded as PNG data URIs.

A section per stage that has results.  Every fit shows the measured band and
mean, the simulated curve, the error norm, the fitted values beside the paper's
and (for the synthetic twin) the truth, and the optimiser trace.
"""
from __future__ import annotations

import base64
import html
import math
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np
import pandas as pd

from harnesspipe import __version__
from harnesspipe.calibrate.uncertainty import Z95
from harnesspipe.data.synthesize import read_truth
from harnesspipe.report import plots
from harnesspipe.stages.common import read_fit
from harnesspipe.stages.data import read_prepared

STAGES = {  # stage -> (heading, paper table key, paper section)
    "tensile": ("Component tensile fits (Sec. 3.2, Table 2)", "table2", "Table 2"),
    "rom": ("Reduced-order beam properties (Sec. 4.3, eq. 13 + simplex, Table 3)", "table3", "Table 3"),
    "branch": ("Branching harness: break-out joint damping (Sec. 5, eqs. 14-15)", "damping", "Sec. 5"),
    # listed from results/hifi by hifi_section (its --fits are only the rule's dependencies)
    "hifi": ("High-fidelity model (Sec. 4.1-4.3)", "interface", "Sec. 4.2"),
}


def paper_values(cfg: dict, stage: str, item: str) -> dict | None:
    """The paper's values for a fitted item (tables keyed by item; damping for every item)."""
    table = cfg["paper"].get(STAGES[stage][1], {})
    if stage == "branch":
        return table
    return table.get(item)

CSS = """
body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}
h1{font-size:1.6em} h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;margin:.6em 0} td,th{border:1px solid #ccc;padding:.25em .6em;text-align:right}
th{background:#f3f3f3} td:first-child,th:first-child{text-align:left}
.fit{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start;margin:1em 0 2em}
.fit img{max-width:520px;border:1px solid #eee} .note{color:#555;font-size:.92em}
.bad{color:#b00}
"""


def _img(fig, alt: str) -> str:
    data = base64.b64encode(plots.png_bytes(fig)).decode()
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'


def _table(header: list[str], rows: list[list]) -> str:
    def cell(v):
        if isinstance(v, float):
            return f"{v:.4g}"
        return html.escape(str(v))
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{cell(v)}</td>" for v in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _load_trace(path: Path) -> pd.DataFrame | None:
    if not path.exists():
        return None
    with h5py.File(path, "r") as f:
        if "error" not in f:
            return None
        return pd.DataFrame({"error": f["error"][...], "wall_s": f["wall_s"][...]})


def data_section(summary: str, prepared_paths: list[Path], truth: dict) -> str:
    rows, figs = [], []
    for p in sorted(prepared_paths):
        pr = read_prepared(p)
        prov = pr.entry.get("provenance", {})
        rows.append([pr.test_id, pr.entry["kind"], pr.entry["item"], len(pr.samples),
                     prov.get("kind", "?"), prov.get("generator_version", "")])
        figs.append(_img(plots.fit_figure(pr, title=pr.test_id), pr.test_id))
    synthetic = " The data set is the synthetic twin (data/experimental/README.md)." if truth else ""
    return (f"<h2>Test data</h2><p>{html.escape(summary)}.{synthetic}</p>"
            + _table(["test", "kind", "item", "samples", "provenance", "generator"], rows)
            + '<div class="fit">' + "".join(figs) + "</div>")


SE_NOTE = ('<p class="note">Standard error: how far the parameter could move for the scatter of '
           'the measured replicates ({dof} degrees of freedom: a rough figure with few replicates), '
           'closed-form parameters evaluated on each replicate, the others through the linearised '
           'least-squares problem (calibrate/uncertainty.py). "Not determined": the curve fixes only '
           'a combination of this parameter with others, or the fit sits on a bound, so its value, '
           'and its distance from truth or paper, carries no information on its own. "n/a": a '
           'perturbed simulation failed.</p>')


def _standard_error(s_ln) -> str:
    """A standard error of ln p as '+-x %'; 'not determined' where there is none (None) or
    it exceeds 100 % (a factor e either way)."""
    if s_ln is None or not math.isfinite(s_ln) or s_ln > 1.0:
        return "not determined"
    return f"\u00b1{100.0 * s_ln:.2g} %"


def _standard_error_cells(fit: dict, names) -> list[str]:
    """The 'standard error' cells of a fit's parameters: 'n/a' when the fit has none (a hi-fi
    reference, a failed perturbed run), '' for a parameter it does not list."""
    se = fit.get("standard_error")
    if not se:
        return ["n/a"] * len(names)
    return [_standard_error(se[k]) if k in se else "" for k in names]


DETERMINED, UNDETERMINED = 0.05, 0.3   # standard error of ln p: "determines" below, "does not" above
SYMBOLS = {"E": "E", "sigma_y": "sigma_Y", "K": "K", "n": "n"}


def _pct(se) -> str:
    return "not determined" if se is None else f"\u00b1{100.0 * se:.2g} %"


def _listed(items: list[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _determined_flow(flow: dict | None) -> str | None:
    """'the flow stress at a-b % plastic strain (+-x %)' over the longest run of plastic strains
    whose relative standard error band / (Z95 sigma) is below DETERMINED (None: no such run)."""
    if not flow or flow.get("band") is None:
        return None
    rel = np.asarray(flow["band"], dtype=float) / (Z95 * np.asarray(flow["sigma"], dtype=float))
    best, start = (0, 0), None
    for i, ok in enumerate(list(rel < DETERMINED) + [False]):
        if ok and start is None:
            start = i
        elif not ok and start is not None:
            best, start = max(best, (start, i), key=lambda r: r[1] - r[0]), None
    if best[1] == best[0]:
        return None
    eps = flow["eps_p"][best[0]:best[1]]
    return (f"the flow stress at {100 * eps[0]:.2g}-{100 * eps[-1]:.2g} % plastic strain "
            f"({_pct(float(rel[best[0]:best[1]].max()))})")


def determination_sentence(fit: dict) -> str | None:
    """What the fit's data determine, in plain words, from fit.json's Fisher standard errors
    (load-cell noise, ln p) and ``flow_stress`` band: parameters (and the longest plastic
    strain range of the flow stress) with an SE below DETERMINED, those above UNDETERMINED or
    without one, and the rest "only roughly".  None when the fit has no Fisher errors."""
    fisher = fit.get("fisher")
    if not fisher:
        return None
    se = {k: fisher["standard_error"].get(k) for k in fisher["names"]}
    good = [f"{SYMBOLS.get(k, k)} ({_pct(v)})" for k, v in se.items() if v is not None and v < DETERMINED]
    flow = _determined_flow(fit.get("flow_stress"))
    good += [flow] if flow else []
    bad = [k for k, v in se.items() if v is None or v > UNDETERMINED]
    rough = [k for k in se if k not in bad and se[k] >= DETERMINED]
    parts = [f"The curve determines {_listed(good)}" if good
             else f"The curve determines no quantity to within {100 * DETERMINED:.0f} %"]
    if bad:
        parts.append(f"{_listed([SYMBOLS.get(k, k) for k in bad])} "
                     f"{'separately ' if len(bad) > 1 else ''}it does not "
                     f"({', '.join(_pct(se[k]) for k in bad)})")
    if rough:
        parts.append(f"{_listed([SYMBOLS.get(k, k) for k in rough])} only roughly "
                     f"({', '.join(_pct(se[k]) for k in rough)})")
    return ("; ".join(parts) + ". (Fisher standard errors from the load-cell noise; the "
            "shaded bands are 95 %.)")


def fit_block(fit: dict, fit_dir: Path, prepared, paper: dict | None, truth: dict | None,
              reference: pd.DataFrame | None = None) -> str:
    """One fit: values beside truth and paper, the curve (with its 95 % band) against the
    measured band (``prepared``, may be None) and, for a ROM fitted to a hi-fi virtual test,
    that ``reference`` curve; the flow stress with its band and :func:`determination_sentence`."""
    curve = pd.read_csv(fit_dir / "curve.csv")
    names = list(fit["parameters"])
    label = "fitted" if fit.get("role", "calibration") == "calibration" else f"used ({fit['role']}, no refit)"
    rows = [[label] + [fit["parameters"][k] for k in names]]
    shown = "standard_error" in fit and fit.get("reference") != "hifi"
    if shown:
        rows.append(["standard error"] + _standard_error_cells(fit, names))
    if truth:
        rows.append(["truth (synthetic)"] + [truth.get(k, "") for k in names])
    if paper:
        rows.append(["paper"] + [paper.get(k, "") for k in names])
    status = "" if fit["converged"] else ' <span class="bad">(optimiser did not converge)</span>'
    text = (f"<h3>{html.escape(fit['item'])}</h3>"
            f"<p>Reference: test <code>{html.escape(fit['test_id'])}</code>. "
            f"||e||<sub>l2</sub> = {fit['error_l2']:.4g} N (relative {100 * fit['error_rel']:.2f} %), "
            f"{fit['nfev']} evaluations, {fit['wall_s']:.1f} s.{status}</p>"
            + _table(["", *names], rows)
            + (SE_NOTE.format(dof=fit.get("standard_error_dof", "?")) if shown else ""))
    sentence = determination_sentence(fit)
    text += f'<p class="determined">{html.escape(sentence)}</p>' if sentence else ""
    figs = [_img(plots.fit_figure(prepared, curve, title=fit["item"], reference=reference), f"fit {fit['item']}")]
    if fit.get("flow_stress"):
        figs.append(_img(plots.flow_stress_figure(fit["flow_stress"], title=f"{fit['item']}: flow stress"),
                         f"flow stress {fit['item']}"))
    if ((fit_dir / "shapes.csv").exists() and prepared is not None
            and any("markers" in s for s in prepared.samples.values())):
        shapes = pd.read_csv(fit_dir / "shapes.csv")
        shapes = shapes[shapes["displacement_mm"] > 0]
        vertical = "z" if fit.get("load_case") == "outofplane" else "y"   # the markers' axis
        figs.append(_img(plots.shape_figure(prepared, shapes, title=f"{fit['item']}: bent shapes",
                                            vertical=vertical),
                         f"shapes {fit['item']}"))
    trace = _load_trace(fit_dir / "trace.h5")
    if trace is not None and len(trace):
        figs.append(_img(plots.trace_figure(trace, title=f"{fit['item']}: Nelder-Mead"),
                         f"trace {fit['item']}"))
    return f'<div>{text}<div class="fit">{"".join(figs)}</div></div>'


def stage_section(stage: str, fits: list[Path], results: Path, cfg: dict, truth: dict,
                  measured: dict) -> str:
    """A stage's fits; ``measured``: three-point tests by case (:func:`_measured_by_case`),
    the band shown beside a hi-fi reference."""
    heading, _, table_name = STAGES[stage]
    blocks, summary = [], []
    for path in sorted(fits):
        fit = read_fit(path)
        prepared, reference = _reference_of(fit, results, measured)
        paper = paper_values(cfg, stage, fit["item"])
        tr = truth.get(prepared.test_id if prepared is not None else fit["test_id"], {}).get("parameters")
        blocks.append(fit_block(fit, path.parent, prepared, paper, tr, reference))
        cells = _standard_error_cells(fit, list(fit["parameters"]))
        for (k, v), cell in zip(fit["parameters"].items(), cells):
            summary.append([fit["item"], k, v, cell, tr.get(k, "") if tr else "",
                            paper.get(k, "") if paper else ""])
    table = _table(["item", "parameter", "recovered", "standard error", "truth", f"paper ({table_name})"],
                   summary)
    return f"<h2>{html.escape(heading)}</h2>{table}{''.join(blocks)}"


def _reference_of(fit: dict, results: Path, measured: dict):
    """(measured test or None, hi-fi curve or None) a fit is shown against: its prepared test,
    or for a ROM fitted to a hi-fi virtual test (test id ``hifi:<case>``, rom.reference: hifi)
    that curve and the case's measured test, if any."""
    if not fit["test_id"].startswith("hifi:"):
        return read_prepared(results / "data" / f"{fit['test_id']}.h5"), None
    case = fit["test_id"].split(":", 1)[1]
    curve = pd.read_csv(results / "hifi" / "virtual" / case / "curve.csv")
    return measured.get(case), curve.rename(columns={"deflection_mm": "displacement_mm"})


# --------------------------------------------------------------------------- hi-fi section

HIFI_INTERFACE = ("mu_rtb", "mu_rtp", "delta0", "delta_f", "alpha_d", "E2_over_E1")
HIFI_RUN_NUMBERS = ("wall_s", "steps", "dt", "ke_ie_max", "energy_error", "n_beam_elements",
                    "n_shell_elements", "contact_pairs_max")


def _read_json(path: Path) -> dict | None:
    import json
    try:
        return json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None


def _rel(value, ref) -> str:
    try:
        return f"{100.0 * (float(value) - float(ref)) / float(ref):+.1f} %"
    except (TypeError, ValueError, ZeroDivisionError):
        return ""


def _measured_by_case(prepared: list[Path]) -> dict:
    """The prepared three-point tests by case (the first test of a case, in path order)."""
    out = {}
    for p in sorted(prepared):
        pr = read_prepared(p)
        if pr.entry.get("kind") == "three_point":
            out.setdefault(pr.entry["item"], pr)
    return out


def _hifi_run_block(title: str, folder: Path, measured) -> tuple[str, dict | None]:
    """Curve vs measured band, energies and the summary numbers of one hi-fi run."""
    summary = _read_json(folder / "summary.json")
    if summary is None or not (folder / "curve.csv").exists():
        return "", None
    curve = pd.read_csv(folder / "curve.csv")
    figs = [_img(plots.hifi_curve_figure({"hi-fi": curve}, measured, title=title), f"hi-fi {title}")]
    if (folder / "energies.csv").exists():
        figs.append(_img(plots.energies_figure(pd.read_csv(folder / "energies.csv"),
                                               title=f"{title}: energies"), f"energies {title}"))
    if (folder / "shapes.png").exists():
        data = base64.b64encode((folder / "shapes.png").read_bytes()).decode()
        figs.append(f'<img alt="shapes {html.escape(title)}" src="data:image/png;base64,{data}">')
    numbers = [[k, summary[k]] for k in HIFI_RUN_NUMBERS if k in summary]
    m = summary.get("measured")
    if m:
        numbers.append([f"||e||_l2 vs {m['test_id']} [N]", m["error_l2"]])
        numbers.append(["relative error", f"{100 * m['error_rel']:.2f} %"])
    text = (f"<h4>{html.escape(title)}</h4>" + _table(["quantity", "value"], numbers))
    return f'<div>{text}<div class="fit">{"".join(figs)}</div></div>', summary


COHESIVE_MESH_NOTE = (
    "<p class='note'>The cohesive window spans the tape's debonding, an instability whose onset "
    "moves with the mesh and with the mass scaling: on the coarse-taped CWB a finer mesh differs "
    "from the default one by up to 8 % of the peak at 21-25 mm, and f_m 10 from the paper's f_m 25 "
    "by up to 22 % beyond 20 mm (the lighter model debonds further), while below 20 mm they agree "
    "within 3.4 % (mesh) and 2.7 % on 1 mm means (f_m) (bench/RESULTS.md, taped CWB). The fitted "
    "cohesive values carry an uncertainty of that order.</p>")


NO_HIFI_NOTE = (
    "<p class='note'>No hi-fi results yet: <code>snakemake --cores 2 "
    "hifi_crosscheck_all</code> (Table 3 at the paper's values) and <code>hifi_chain_all</code> "
    "(the Sec. 4.2 calibration chain and the virtual tests) write them under "
    "<code>results/hifi/</code>; hours at the default profile.</p>")
HIFI_INTRO = (
    "<p class='note'>Explicit mesoscale model of the three-point test (Sec. 4.1). "
    "The cross-check runs use the paper's Table 2 and interface values; the calibration chain "
    "fits the interface to the measured means (Sec. 4.2) with the tensile stage's Table 2.</p>")
CHAIN_ORDER = {"build": 0, "mu_rtb": 1, "mu_rtp": 2, "cohesive": 3, "fabric": 4}   # stages/chain_settings.STEPS
RUN_GROUPS = (("virtual", "Virtual tests at the calibrated interface"),   # single runs, in section order
              ("crosscheck", "Cross-check runs at the paper's parameters"),
              ("chain", "Calibration runs at the best points"))


@dataclass
class _HifiCost:
    """The hi-fi runs behind the section, in section order, for its cost table."""
    rows: list = field(default_factory=list)
    n_runs: int = 0
    wall: float = 0.0

    def add(self, label: str, n: int, wall_s: float, per_run: float) -> None:
        self.n_runs += n
        self.wall += wall_s
        self.rows.append([label, n, per_run, wall_s / 60.0])


def _crosscheck_table(root: Path, paper: dict) -> str:
    """Table 3 by eq. 13 + simplex on the cross-check curves beside the paper's."""
    t3 = root / "crosscheck" / "table3.csv"
    if not t3.exists():
        return ""
    rows = []
    for r in pd.read_csv(t3).itertuples():
        ref = paper.get("table3", {}).get(r.case, {})
        for k in ("E", "sigma_y", "K", "n"):
            rows.append([r.case, k, getattr(r, k), ref.get(k, ""), _rel(getattr(r, k), ref.get(k))])
    return ("<h3>Table 3 from hi-fi curves at the paper's parameters</h3>"
            "<p>eq. 13 + simplex (the ROM stage's fit) on each hi-fi curve "
            "(<code>results/hifi/crosscheck/table3.csv</code>).</p>"
            + _table(["case", "parameter", "hi-fi + ROM fit", "paper (Table 3)", "difference"], rows))


def _crosscheck_rom_figures(root: Path) -> str:
    """The ROM fitted to each cross-check curve, over that curve."""
    figs = []
    for fit_path in sorted(root.glob("crosscheck/*/rom/fit.json")):
        fit = read_fit(fit_path)
        hifi_curve = fit_path.parent.parent / "curve.csv"
        if hifi_curve.exists():
            figs.append(_img(plots.hifi_rom_figure(pd.read_csv(hifi_curve), pd.read_csv(fit_path.parent / "curve.csv"),
                                                   title=f"{fit['item']}: ROM on the hi-fi curve"),
                             f"rom crosscheck {fit['item']}"))
    return '<div class="fit">' + "".join(figs) + "</div>" if figs else ""


def _interface_table(root: Path, fits: list[Path], cfg: dict) -> str:
    """The calibrated interface (interface.csv, else the chain's fits so far) beside the
    initial guess and the paper's."""
    iface = root / "interface.csv"
    fitted = {}
    if iface.exists():
        fitted = dict(zip(*pd.read_csv(iface)[["parameter", "value"]].T.values))
    else:
        for p in fits:
            fitted.update(read_fit(p)["parameters"])
    if not fitted:
        return ""
    pi = cfg.get("paper", {}).get("interface", {})
    guess = {**cfg.get("hifi", {}).get("parameters", {}), **cfg.get("hifi", {}).get("build", {})}
    names = list(HIFI_INTERFACE) + [k for k in fitted if k not in HIFI_INTERFACE]   # build state
    rows = [[k, fitted.get(k, ""), guess.get(k, ""), pi.get(k, ""), _rel(fitted.get(k), pi.get(k))]
            for k in names]
    src = "results/hifi/interface.csv" if iface.exists() else "chain fits so far (interface.csv not written yet)"
    return (f"<h3>Calibrated interface (Sec. 4.2) and build state</h3><p>From <code>{html.escape(src)}</code>; "
            "the build state (end_tape_layers: wraps of the end bands) is not in the paper.</p>"
            + _table(["parameter", "calibrated", "initial guess", "paper (Sec. 4.2)", "difference"], rows))


def _step_text(fit: dict, paper: dict) -> str:
    """Heading, method, window, error, cost and fitted values of one calibration step."""
    status = "" if fit.get("converged") else ' <span class="bad">(search did not converge)</span>'
    if "not identifiable" in fit.get("message", ""):
        status = f' <span class="bad">{html.escape(fit["message"])}.</span>'
    text = (f"<h3>Calibration step {html.escape(fit['item'])}</h3><p>{html.escape(fit.get('method', ''))} "
            f"on {html.escape(', '.join(fit.get('cases', [])))}, deflection window "
            f"{fit.get('window')} mm: ||e||<sub>l2</sub> = {fit['error_l2']:.4g} N (relative "
            f"{100 * fit['error_rel']:.2f} %), {fit['nfev']} evaluations, {fit.get('rejected', 0)} rejected, "
            f"{fit.get('hifi_wall_s', 0.0) / 60:.1f} min of hi-fi runs.{status}</p>"
            + _table(["", *fit["parameters"]], [["fitted", *fit["parameters"].values()],
                                                 ["paper", *[paper.get("interface", {}).get(k, "")
                                                             for k in fit["parameters"]]]]))
    if fit["item"] == "cohesive":
        text += COHESIVE_MESH_NOTE
    return text


def _step_figures(folder: Path, fit: dict, measured: dict) -> list[str]:
    """The step's curves against the measured cases and its optimiser trace."""
    figs = []
    curve = pd.read_csv(folder / "curve.csv")
    preps = {c: measured[c] for c in fit.get("cases", []) if c in measured}
    if preps:
        figs.append(_img(plots.hifi_cases_figure(preps, {c: g for c, g in curve.groupby("case")},
                                                 title=f"step {fit['item']}", window=fit.get("window")),
                         f"chain {fit['item']}"))
    trace = _load_trace(folder / "trace.h5")
    if trace is not None and len(trace):
        figs.append(_img(plots.trace_figure(trace, title=f"{fit['item']}: optimiser trace"),
                         f"trace {fit['item']}"))
    return figs


def _step_rejections(folder: Path, fit: dict) -> str:
    """The first ten rejected evaluations of a step (rejected.jsonl) as a table."""
    rejected = []
    if (folder / "rejected.jsonl").exists():
        for line in (folder / "rejected.jsonl").read_text().splitlines()[:10]:
            r = _read_json_line(line)
            if r:
                rejected.append([r.get("case") or "", ", ".join(f"{k}={v:.4g}" for k, v in r["parameters"].items()
                                                                if k in fit["parameters"]), r.get("reason", "")])
    return _table(["case", "parameters", "reason"], rejected) if rejected else ""


def _calibration_step(path: Path, paper: dict, measured: dict, cost: _HifiCost) -> str:
    """One step of the chain (its fit.json at ``path``); its runs go to ``cost``."""
    fit = read_fit(path)
    text = _step_text(fit, paper)
    figs = _step_figures(path.parent, fit, measured)
    rej = _step_rejections(path.parent, fit)
    n = int(fit.get("hifi_runs", fit["nfev"]))
    wall = float(fit.get("hifi_wall_s", 0.0))
    cost.add(f"fit {fit['item']}", n, wall, wall / max(n, 1))
    return f'<div>{text}{rej}<div class="fit">{"".join(figs)}</div></div>'


def _single_run(path: Path, root: Path, measured: dict, cost: _HifiCost) -> tuple[str, str]:
    """(group, block) of one single run (its summary.json at ``path``; block "" if it has
    no curve); cross-check and virtual runs go to ``cost`` (a reused run at no cost)."""
    folder = path.parent
    group = folder.parent.name if folder.parent.parent == root else "chain"
    case = folder.name
    title = {"crosscheck": f"cross-check {case} (paper's values)", "virtual": f"virtual test {case}",
             "chain": f"fit {folder.parent.name}: {case} at the best point"}[group]
    block, summary = _hifi_run_block(title, folder, measured.get(case))
    if not block:
        return group, ""
    if summary.get("role"):
        block = block.replace("</h4>", f" <span class='note'>({html.escape(summary['role'])})</span></h4>", 1)
    if group != "chain" and summary.get("reused_from"):      # the fit's run, counted there
        cost.rows.append([f"{title} (the fit's best-point run)", 0, 0.0, 0.0])
    elif group != "chain":
        wall = float(summary.get("wall_s", 0.0))
        cost.add(title, 1, wall, wall)
    return group, block


def _single_runs(root: Path, runs: list[Path], measured: dict, cost: _HifiCost) -> str:
    """The single runs by group: virtual tests, cross-check runs, best points of the fits."""
    blocks = {group: [] for group, _ in RUN_GROUPS}
    for path in runs:
        group, block = _single_run(path, root, measured, cost)
        if block:
            blocks[group].append(block)
    return "".join(f"<h3>{head}</h3>" + "".join(blocks[group]) for group, head in RUN_GROUPS if blocks[group])


def _cost_table(cost: _HifiCost, paper_cost: dict) -> str:
    """Runs and wall time of every item and in total, beside the paper's cost."""
    if not cost.rows:
        return ""
    rows = cost.rows + [["total", cost.n_runs, cost.wall / max(cost.n_runs, 1), cost.wall / 60.0]]
    paper_line = (f"Paper (Sec. 4.3): one hi-fi run {paper_cost.get('hifi_wall_min', '?')} min on "
                  f"{paper_cost.get('hifi_cores', '?')} cores (= {float(paper_cost.get('hifi_wall_min', 0)) * float(paper_cost.get('hifi_cores', 0)) / 60:.0f} "
                  f"core-hours); here each run uses one core.") if paper_cost else ""
    return ("<h3>Cost</h3><p>" + html.escape(paper_line) + "</p>"
            + _table(["item", "hi-fi runs", "wall per run [s]", "wall total [min]"], rows))


def _fidelity_table(root: Path, cfg: dict) -> str:
    """Each virtual test's relative l2 error against its measured mean beside the goal of its
    role (config ``hifi.pipeline.fidelity_goal``): met, or missed and by how much."""
    goals = cfg["hifi"]["pipeline"]["fidelity_goal"]
    rows = []
    for path in sorted((root / "virtual").glob("*/summary.json")):
        summary = _read_json(path)
        m = (summary or {}).get("measured")
        if not m:
            continue
        role = str(summary.get("role", "prediction"))
        goal = goals.get(role, goals["prediction"])
        err = float(m["error_rel"])
        verdict = ("<td>met</td>" if err <= goal else
                   f"<td class='bad'>missed by {100 * (err - goal):.1f} points</td>")
        rows.append(f"<tr><td>{html.escape(path.parent.name)}</td><td>{html.escape(role)}</td>"
                    f"<td>{100 * err:.1f} %</td><td>{100 * goal:.0f} %</td>{verdict}</tr>")
    if not rows:
        return ""
    head = "".join(f"<th>{h}</th>" for h in ("case", "role", "relative error", "goal", "verdict"))
    return ("<h3>Virtual tests against the bending tests</h3><p class='note'>Relative l2 error of "
            "each virtual test's force against the measured mean over its window; the goal is "
            "the project's (calibration cases fitted on, the others predicted with no refit).</p>"
            f"<table><tr>{head}</tr>{''.join(rows)}</table>")


def hifi_section(results: Path, cfg: dict, measured: dict) -> str:
    """Everything of results/hifi that exists: cross-check Table 3, the calibration chain,
    the interface beside the paper's, the virtual tests, their energies and the cost."""
    heading = f"<h2>{html.escape(STAGES['hifi'][0])}</h2>"
    root = Path(results) / "hifi"
    runs = sorted(root.glob("*/*/summary.json")) + sorted(root.glob("chain/*/*/summary.json"))
    fits = sorted(root.glob("chain/*/fit.json"),
                  key=lambda p: (CHAIN_ORDER.get(p.parent.name, 9), p.parent.name))
    if not runs and not fits and not (root / "crosscheck" / "table3.csv").exists():
        return heading + NO_HIFI_NOTE
    paper = cfg.get("paper", {})
    cost = _HifiCost()
    parts = [heading, HIFI_INTRO, _fidelity_table(root, cfg), _crosscheck_table(root, paper),
             _crosscheck_rom_figures(root),
             _interface_table(root, fits, cfg)]
    parts += [_calibration_step(p, paper, measured, cost) for p in fits]
    parts += [_single_runs(root, runs, measured, cost), _cost_table(cost, paper.get("cost", {}))]
    return "".join(parts)


BRANCH_HIFI_AT = (5.0, 10.0, 25.0, 50.0)   # crosshead travels of the Fig. 18a comparison table


def branch_hifi_section(results: Path, cfg: dict) -> str:
    """The hi-fi Y harness beside the ROM and the in-plane test (Fig. 18a), with the cost of
    each; a note naming the target when the hi-fi run (rule branch_hifi) is not part of this
    profile's run (a result left in the folder by another run is not shown: it may rest on
    another profile's tensile fits) or has not run yet."""
    folder = Path(results) / "branch" / "hifi"
    summary = _read_json(folder / "summary.json")
    head = "<h3>Hi-fi Y harness beside the ROM (Fig. 18a)</h3><p class='note'>"
    run_it = ("<code>snakemake --cores 2 branch_hifi_all</code> runs it "
              "(results/branch/hifi/).</p>")
    if cfg["profile"] not in cfg["branch"]["hifi"]["in_all"]:
        return (f"{head}Not part of the {html.escape(cfg['profile'])} profile's run (config "
                f"<code>branch.hifi.in_all</code>); {run_it}")
    if summary is None:
        return f"{head}Not run yet: {run_it}"
    hifi = pd.read_csv(folder / "curve.csv")
    curves = {"hi-fi (mesoscale)": hifi}
    roms = {}
    for name, label in (("elastic", "ROM, elastic joint"), ("inplane", "ROM, calibrated alpha")):
        fit_path = Path(results) / "branch" / name / "fit.json"
        if fit_path.exists():
            fit = read_fit(fit_path)
            roms[name] = (fit, pd.read_csv(fit_path.parent / "curve.csv"))
            curves[f"{label} (alpha = {fit['parameters']['alpha']:.3g} s)"] = roms[name][1]
    prepared = None
    if "inplane" in roms and summary.get("load_case") == "inplane":
        prepared = read_prepared(Path(results) / "data" / f"{roms['inplane'][0]['test_id']}.h5")
    figs = [_img(plots.hifi_curve_figure(curves, prepared, title="Y harness, in-plane pull (Fig. 18a)",
                                         xlabel="crosshead displacement [mm]"), "Fig. 18a"),
            _img(plots.energies_figure(pd.read_csv(folder / "energies.csv"), title="hi-fi Y harness: energies"),
                 "hi-fi branch energies")]
    if (folder / "shapes.csv").exists() and prepared is not None:
        shapes = pd.read_csv(folder / "shapes.csv")
        figs.append(_img(plots.shape_figure(prepared, shapes[shapes["displacement_mm"] > 0],
                                            title="hi-fi Y harness: S2 bent shapes"), "hi-fi branch shapes"))
    header = ["crosshead [mm]"] + (["measured mean"] if prepared is not None else []) + list(curves)
    rows = []
    for u in BRANCH_HIFI_AT:
        row = [u] + ([float(np.interp(u, prepared.grid, prepared.mean))] if prepared is not None else [])
        rows += [row + [float(np.interp(u, c["displacement_mm"], c["force_N"])) for c in curves.values()]]
    cost = [["hi-fi run (wall, s)", f"{summary['wall_s']:.0f}"], ["explicit steps", summary["steps"]],
            ["dt [s]", f"{summary['dt']:.3g}"], ["simulated time [s]", summary["t_total"]],
            ["beam / shell elements", f"{summary['n_beam_elements']} / {summary['n_shell_elements']}"],
            ["max KE/IE (after a third of the stroke)", f"{summary['ke_ie_max']:.3g}"],
            ["energy balance error", f"{summary['energy_error']:.2g}"],
            ["plastic work [N mm]", f"{summary['plastic_work']:.3g}"]]
    for name, (fit, _) in roms.items():
        cost.append([f"ROM {name} run (wall, s)", f"{fit['wall_s']:.2f}"])
    text = ("<h3>Hi-fi Y harness beside the ROM (Fig. 18a)</h3><p class='note'>The mesoscale model "
            "(every wire a fibre beam, open tubes and tape as shells, contact-friction, cohesive tape; "
            "<code>models/hifi_branch.py</code>) at the paper's interface values and the tensile "
            "stage's coverings, against the ROM with the same geometry. The paper finds hi-fi and "
            "elastic-joint ROM alike and both below the test for u &lt; 10 mm.</p>"
            + _table(header, [[f"{v:.4g}" if isinstance(v, float) else v for v in r] for r in rows])
            + _table(["cost and checks", "value"], cost))
    return f'<div>{text}<div class="fit">{"".join(figs)}</div></div>'


def _read_json_line(line: str) -> dict | None:
    import json
    try:
        return json.loads(line)
    except ValueError:
        return None


def build(out: Path, *, cfg: dict, results: Path, check_summary: Path,
          prepared: list[Path], fits: dict[str, list[Path]]) -> Path:
    """Write the report to ``out`` (atomically) and return its path."""
    results = Path(results)
    truth = read_truth(Path(cfg["data_dir"]))
    parts = [f"<h1>harnesspipe report</h1><p class='note'>harnesspipe {__version__}, "
             f"profile <b>{html.escape(cfg['profile'])}</b>. Units mm, N, MPa.</p>",
             data_section(Path(check_summary).read_text().strip(), prepared, truth)]
    measured = _measured_by_case(prepared)
    for stage in STAGES:
        if stage == "hifi":
            parts.append(hifi_section(results, cfg, measured))
        elif fits.get(stage):
            parts.append(stage_section(stage, fits[stage], results, cfg, truth, measured))
            if stage == "branch":
                parts.append(branch_hifi_section(results, cfg))
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            "<title>harnesspipe report</title><style>" + CSS + "</style></head><body>"
            + "".join(parts) + "</body></html>\n")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(page)
    tmp.replace(out)
    return out
