"""The offline HTML report: one self-contained file, figures embedded as PNG data URIs.

It opens with the verdict (:mod:`harnesspipe.report.verdict`): every calibrated
parameter with its standard error, its fit's error against the test and a status, and the
limitations generated from those numbers; then a table of contents, and a section per
stage that has results.  Every fit shows the measured band and mean, the simulated curve,
the error norm, the fitted values beside the paper's and (for the synthetic twin) the
truth, the parameter correlations and the optimiser trace; raw data and repeated runs are
folded into ``<details>``; result files are linked relative to the report's folder.
"""
from __future__ import annotations

import base64
import html
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np
import pandas as pd

from harnesspipe import __version__
from harnesspipe.calibrate.uncertainty import Z95
from harnesspipe.data.synthesize import read_truth
from harnesspipe.report import band, links, plots, screen, verdict
from harnesspipe.report.names import labelled, physical_name, solver_statistics
from harnesspipe.stages.chain_settings import STEPS
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
body{font-family:system-ui,sans-serif;max-width:1240px;margin:1.5em auto;padding:0 1em;color:#222;line-height:1.4}
h1{font-size:1.6em;margin-bottom:.2em} h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;margin:.6em 0} td,th{border:1px solid #ccc;padding:.25em .6em;text-align:right}
th{background:#f3f3f3} td:first-child,th:first-child{text-align:left}
.wide{overflow-x:auto;max-width:100%}
.fit{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start;margin:1em 0 2em}
.fit img,img{max-width:100%;height:auto;border:1px solid #eee} .note{color:#555;font-size:.92em}
.bad{color:#b00} .near{color:#8a5a00} .files{font-size:.92em} code{font-size:.92em}
nav.toc{background:#f7f7f7;border:1px solid #ddd;padding:.4em 1em;margin:1em 0;font-size:.95em}
nav.toc ul{margin:.2em 0;padding-left:1.2em} nav.toc>ul{columns:2 22em}
.limits{background:#fff6e5;border:1px solid #e0a030;border-left:6px solid #e0a030;padding:.3em 1em;margin:1em 0}
.limits h2{border:0;margin-top:.4em}
.status{display:inline-block;padding:0 .4em;margin:1px;border-radius:3px;font-size:.88em;white-space:nowrap}
.st-mismatch{background:#f8d0d0;color:#800} .st-bound{background:#e8d8f8;color:#4b1a80}
.st-unident{background:#fde2c4;color:#7a3b00} .st-nose{background:#e8e8e8;color:#444}
.st-rough{background:#e6f2d0;color:#3a5a00} .st-ok{background:#cdeccd;color:#0a5a0a}
.st-near{background:#fbeec0;color:#6a4a00}
details{margin:1em 0;border:1px solid #ddd;padding:.3em .8em} summary{cursor:pointer;font-weight:600}
table.corr td{text-align:center;min-width:3.5em} table.files td{text-align:left}
table.verdict{font-size:.93em} table.verdict td{vertical-align:top;text-align:right;white-space:nowrap}
table.verdict td.txt{white-space:normal}
table.rom td{vertical-align:top;white-space:nowrap} table.rom td.txt{white-space:normal;text-align:left} table.verdict .status{white-space:normal}
table.verdict td:last-child{min-width:11em} table.verdict tr.stage td{background:#eef3f8;font-weight:600} table.verdict td.txt{text-align:left}
"""


class Raw(str):
    """A table cell that is HTML already (not escaped)."""


def _img(fig, alt: str) -> str:
    """A figure as an embedded PNG, shown at its own pixel size (never squeezed: the
    figures are laid out for their shown width, legends >= 8 pt)."""
    width = int(round(fig.get_size_inches()[0] * fig.dpi))
    data = base64.b64encode(plots.png_bytes(fig)).decode()
    return f'<img alt="{html.escape(alt)}" width="{width}" src="data:image/png;base64,{data}">'


def _table(header: list[str], rows: list[list]) -> str:
    def cell(v):
        if isinstance(v, Raw):
            return str(v)
        if isinstance(v, float):
            return f"{v:.4g}"
        return html.escape(str(v)).replace(" %", "&nbsp;%")   # a number and its % on one line
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{cell(v)}</td>" for v in r) + "</tr>" for r in rows)
    return f"<div class='wide'><table><tr>{head}</tr>{body}</table></div>"


def _load_trace(path: Path) -> pd.DataFrame | None:
    if not path.exists():
        return None
    with h5py.File(path, "r") as f:
        if "error" not in f:
            return None
        return pd.DataFrame({"error": f["error"][...], "wall_s": f["wall_s"][...]})


def data_section(summary: str, prepared_paths: list[Path], truth: dict, cfg: dict | None = None) -> str:
    """The tests: a table, and their raw curves folded into a <details>."""
    rows, figs = [], []
    for p in sorted(prepared_paths):
        pr = read_prepared(p)
        prov = pr.entry.get("provenance", {})
        name = physical_name(pr.test_id, cfg or {})
        rows.append([pr.test_id, pr.entry["kind"], name, len(pr.samples),
                     prov.get("kind", "?"), prov.get("generator_version", "")])
        figs.append(_img(plots.fit_figure(pr, title=f"{name} ({pr.test_id})"), pr.test_id))
    synthetic = " The data set is the synthetic twin (data/experimental/README.md)." if truth else ""
    return (f"<h2 id='data'>Test data</h2><p>{html.escape(summary)}.{synthetic}</p>"
            + _table(["test", "kind", "specimen", "samples", "provenance", "generator"], rows)
            + f"<details><summary>Raw data: the {len(figs)} tests' specimens, band and mean</summary>"
            + '<div class="fit">' + "".join(figs) + "</div></details>")


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
    if not se and fit.get("reference") == "hifi":    # no noise: a standard error has no meaning
        return ["none (fitted to one hi-fi curve)"] * len(names)
    if not se:
        return ["n/a"] * len(names)
    return [_standard_error(se[k]) if k in se else "" for k in names]


DETERMINED, UNDETERMINED = verdict.DETERMINED, verdict.UNDETERMINED   # SE of ln p: "determines" below, "not" above
SYMBOLS = {"E": "E", "sigma_y": "sigma_Y", "K": "K", "n": "n"}


def _pct(se) -> str:
    if se is None:
        return "not determined"
    return "> 100 %" if se > 1.0 else f"\u00b1{100.0 * se:.2g} %"


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


def correlation_table(fit: dict) -> str:
    """The Fisher correlation matrix of a fit's parameters (fit.json ``fisher.correlation``)
    as a small table shaded by |r| (red positive, blue negative); "" without one."""
    fisher = fit.get("fisher") or {}
    names, matrix = fisher.get("names"), fisher.get("correlation")
    if not names or matrix is None:
        return ""

    def cell(r):
        if r is None or not math.isfinite(r):
            return "<td>-</td>"
        colour = "200,40,40" if r > 0 else "40,80,200"
        return f"<td style='background:rgba({colour},{0.55 * min(abs(r), 1.0):.2f})'>{r:+.2f}</td>"
    head = "".join(f"<th>{html.escape(SYMBOLS.get(k, k))}</th>" for k in names)
    body = "".join(f"<tr><th>{html.escape(SYMBOLS.get(k, k))}</th>" + "".join(cell(r) for r in row) + "</tr>"
                   for k, row in zip(names, matrix))
    return ("<p class='note'>Parameter correlations (Fisher, of ln p): near +-1, the curve fixes only "
            "a combination of the two.</p>"
            f"<table class='corr'><tr><th></th>{head}</tr>{body}</table>")


def _trace_or_count(trace: pd.DataFrame | None, title: str, alt: str) -> tuple[str, str]:
    """(figure, text): the optimiser trace when there are more than two evaluations, else
    a note with their number (a trace of one or two points says nothing)."""
    if trace is None or not len(trace):
        return "", ""
    if len(trace) <= 2:
        n = len(trace)
        return "", f"<p class='note'>Optimiser: {n} evaluation{'s' if n > 1 else ''} (no trace drawn).</p>"
    return _img(plots.trace_figure(trace, title=title), alt), ""


def fit_block(fit: dict, fit_dir: Path, prepared, paper: dict | None, truth: dict | None,
              reference: pd.DataFrame | None = None, *, cfg: dict | None = None,
              report_dir: Path | None = None, errors: dict | None = None) -> str:
    """One fit: values beside truth and paper, the curve (with its 95 % band) against the
    measured band (``prepared``, may be None) and, for a ROM fitted to a hi-fi virtual test,
    that ``reference`` curve (``errors``: :func:`verdict.rom_errors`); the flow stress with its
    band, :func:`determination_sentence`, the parameter correlations and links to its files
    (``report_dir``: the report's folder)."""
    cfg = cfg or {}
    curve = pd.read_csv(fit_dir / "curve.csv")
    names = list(fit["parameters"])
    role = fit.get("role", "calibration")
    label = {"calibration": "fitted", "validation": "used (validation, no refit)"}.get(role, f"fixed ({role}, no fit)")
    rows = [[label] + [fit["parameters"][k] for k in names]]
    shown = "standard_error" in fit and fit.get("reference") != "hifi"
    if shown:
        rows.append(["standard error (replicates)"] + _standard_error_cells(fit, names))
    if truth:
        rows.append([("truth of the test (synthetic)" if reference is not None else "truth (synthetic)")]
                    + [truth.get(k, "") for k in names])
    if paper:
        rows.append(["paper"] + [paper.get(k, "") for k in names])
    status = "" if fit["converged"] else ' <span class="bad">(optimiser did not converge)</span>'
    against = "the hi-fi virtual test" if reference is not None else f"test <code>{html.escape(fit['test_id'])}</code>"
    verb = "Fitted to" if role == "calibration" else "Against"
    text = (f"<h3>{html.escape(labelled(fit['item'], cfg))}</h3>"
            f"<p>{verb} {against}: "
            f"||e||<sub>l2</sub> = {fit['error_l2']:.4g} N (relative {100 * fit['error_rel']:.2f} %), "
            f"{fit['nfev']} evaluation{'s' if fit['nfev'] != 1 else ''}, {fit['wall_s']:.1f} s.{status}")
    if errors and errors.get("test") is not None and prepared is not None:
        css, words = judged(errors["test"], errors["goal"], errors["spread"])
        text += (f" Against the measured mean (test <code>{html.escape(prepared.test_id)}</code>): "
                 f"<span class='{css}'>relative {100 * errors['test']:.1f} %</span> "
                 f"(goal {100 * errors['goal']:.0f} %, {html.escape(errors['role'])}: {words}).")
    text += "</p>" + _table(["", *names], rows)
    text += SE_NOTE.format(dof=fit.get("standard_error_dof", "?")) if shown else ""
    sentence = determination_sentence(fit)
    text += f'<p class="determined">{html.escape(sentence)}</p>' if sentence else ""
    text += correlation_table(fit)
    title = physical_name(fit["item"], cfg)
    model = "ROM (fitted)" if fit.get("stage") == "rom" else "simulated"
    figs = [_img(plots.fit_figure(prepared, curve, title=title, reference=reference, label=model),
                 f"fit {fit['item']}")]
    if fit.get("flow_stress"):
        figs.append(_img(plots.flow_stress_figure(fit["flow_stress"], title=f"{title}: flow stress"),
                         f"flow stress {fit['item']}"))
    if ((fit_dir / "shapes.csv").exists() and prepared is not None
            and any("markers" in s for s in prepared.samples.values())):
        shapes = pd.read_csv(fit_dir / "shapes.csv")
        shapes = shapes[shapes["displacement_mm"] > 0]
        vertical = "z" if fit.get("load_case") == "outofplane" else "y"   # the markers' axis
        figs.append(_img(plots.shape_figure(prepared, shapes, title=f"{title}: bent shapes",
                                            vertical=vertical),
                         f"shapes {fit['item']}"))
    fig, note = _trace_or_count(_load_trace(fit_dir / "trace.h5"), f"{title}: Nelder-Mead", f"trace {fit['item']}")
    figs += [fig] if fig else []
    text += note
    if report_dir is not None:
        text += links.folder_links(fit_dir, report_dir)
    return f'<div>{text}<div class="fit">{"".join(figs)}</div></div>'


def _status_badges(statuses) -> str:
    return " ".join(f"<span class='status {verdict.STATUS_CLASS[st]}'>{html.escape(st)}</span>"
                    for st in statuses)


JUDGED_CLASS = {verdict.MET: "", verdict.NEAR: "near", verdict.MISSED: "bad"}


def judged(error: float, goal: float, spread: float) -> tuple[str, str]:
    """(CSS class, words) of an error against its goal (:func:`verdict.judge`): met, at the
    goal within the run-to-run spread, or missed and by how much."""
    state = verdict.judge(error, goal, spread)
    words = {verdict.MET: "met",
             verdict.NEAR: f"at the goal within the run-to-run spread (\u00b1{verdict.points(spread)})",
             verdict.MISSED: f"missed by {100 * (error - goal):.1f} points"}[state]
    return JUDGED_CLASS[state], words


def _fitted_cell(row: "verdict.Row | None", value) -> Raw:
    """A fitted value, flagged when the verdict puts it on a bound."""
    text = html.escape(f"{value:.4g}" if isinstance(value, float) else str(value))
    if row is not None and verdict.ON_BOUND in row.statuses:
        text += "<br>" + _status_badges([verdict.ON_BOUND])
    return Raw(text)


def stage_section(stage: str, fits: list[Path], results: Path, cfg: dict, truth: dict,
                  measured: dict, *, rows: list | None = None, report_dir: Path | None = None) -> str:
    """A stage's fits; ``measured``: three-point tests by case (:func:`_measured_by_case`),
    the band shown beside a hi-fi reference; ``rows``: the verdict's rows (bound flags)."""
    heading, _, table_name = STAGES[stage]
    flags = {(r.item, r.parameter): r for r in (rows or []) if r.stage == stage}
    blocks, summary, rom_rows = [], [], []
    for path in sorted(fits):
        fit = read_fit(path)
        prepared, reference = _reference_of(fit, results, measured)
        paper = paper_values(cfg, stage, fit["item"])
        tr = truth.get(prepared.test_id if prepared is not None else fit["test_id"], {}).get("parameters")
        errors = verdict.rom_errors(fit, path.parent, Path(results), measured, cfg) if stage == "rom" else None
        blocks.append(fit_block(fit, path.parent, prepared, paper, tr, reference, cfg=cfg,
                                report_dir=report_dir, errors=errors))
        if stage == "branch":
            summary.append([physical_name(fit["test_id"], cfg), fit["item"], fit.get("role", "calibration"),
                            fit["parameters"].get("alpha", ""), f"{100 * fit['error_rel']:.2f} %",
                            (paper or {}).get("alpha", "")])
            continue
        if errors:
            rom_rows.append(_rom_rows(fit, errors, paper, tr, flags, cfg))
            continue
        cells = _standard_error_cells(fit, list(fit["parameters"]))
        fitted_to = [errors["fitted_to"]] if errors else []
        for (k, v), cell in zip(fit["parameters"].items(), cells):
            summary.append([physical_name(fit["item"], cfg), k, _fitted_cell(flags.get((fit["item"], k)), v),
                            *fitted_to, cell, tr.get(k, "") if tr else "", paper.get(k, "") if paper else ""])
    if stage == "branch":
        table = (_table(["test", "run", "role", "alpha [s]", "relative error vs test", "paper (Sec. 5)"], summary)
                 + _branch_overlay(fits, results, cfg))
    elif stage == "rom":
        table = ROM_NOTE + _rom_table(rom_rows)
    else:
        table = _table(["item", "parameter", "fitted", "standard error (replicates)", "truth (synthetic)",
                        f"paper ({table_name})"], summary)
    return f"<h2 id='{stage}'>{html.escape(heading)}</h2>{table}{''.join(blocks)}"


ROM_NOTE = ("<p class='note'>Each ROM is fitted to the curve in its first row (config "
            "<code>rom.reference</code>); its relative l2 error is given against that curve and "
            "against the measured mean of the case's test, beside the goal of the case's role "
            "(<code>hifi.pipeline.fidelity_goal</code>). A ROM fitted to one deterministic hi-fi "
            "curve has no standard error (no noise to propagate). Its E is eq. 13 on the linear part "
            "of that curve; a virtual test's first millimetres are often not linear where the test's "
            "are (a toe while the bundle takes up its clearance, or a stiff start while the tape "
            "sticks), so its linear part is shorter. The row 'E over the test's linear part' reads eq. "
            "13 on the virtual test over the millimetres the test's E was read on: the same data "
            "reduction on both curves.</p>")
ROM_SYMBOLS = ("E", "sigma_y", "K", "n")


def _rom_rows(fit: dict, errors: dict, paper: dict | None, truth: dict | None, flags: dict, cfg: dict) -> str:
    """The rows of one case in the ROM table: fitted (bound flags, errors against its
    reference and the test), the paper's and the test's truth."""
    test = errors["test"]
    if test is None:
        verdict_cell = "no test"
    else:
        badge = verdict.JUDGED_STATUS.get(verdict.judge(test, errors["goal"], errors["spread"]))
        verdict_cell = (f"{100 * test:.1f} % ({100 * errors['goal']:.0f} %, {html.escape(errors['role'])})"
                        + (" " + _status_badges([badge]) if badge else ""))
    lines = [(f"fitted to the {html.escape(errors['fitted_to'])}",
              [str(_fitted_cell(flags.get((fit["item"], k)), fit["parameters"][k])) for k in ROM_SYMBOLS],
              [f"{100 * errors['reference']:.1f} %", verdict_cell])]
    window = errors.get("test_window")
    if window:
        lines.append((html.escape(f"E over the test's linear part (0-{window['u_lin']:.1f} mm): virtual / test"),
                      [f"{window['E_hifi']:.3g} / {window['E_test']:.3g}", "", "", ""], ["", ""]))
    if paper:
        lines.append(("paper (Table 3)", [f"{paper[k]:g}" if k in paper else "" for k in ROM_SYMBOLS], ["", ""]))
    if truth:
        lines.append(("truth of the test (synthetic)", [f"{truth[k]:.4g}" if k in truth else "" for k in ROM_SYMBOLS], ["", ""]))
    name = (f"<td class='txt' rowspan='{len(lines)}'>{html.escape(physical_name(fit['item'], cfg))}<br>"
            f"<code class='note'>{html.escape(fit['item'])}</code></td>")
    return "".join(f"<tr>{name if k == 0 else ''}<td class='txt'>{label}</td>"
                   + "".join(f"<td>{c}</td>" for c in values + errs[:1]) + f"<td class='txt'>{errs[1]}</td></tr>"
                   for k, (label, values, errs) in enumerate(lines))


def _rom_table(rows: list[str]) -> str:
    """The ROM table: per case its fitted, paper's and true properties and its errors."""
    head = "".join(f"<th>{h}</th>" for h in ("case", "", "E [MPa]", "sigma_Y [MPa]", "K [MPa]", "n [-]",
                                             "rel. error vs its reference", "vs the test (goal)"))
    return f"<div class='wide'><table class='rom'><tr>{head}</tr>{''.join(rows)}</table></div>"


BRANCH_ZOOM_MM = 5.0   # the second panel of the alpha overlay: where damping shows (eq. 15)


def _branch_overlay(fits: list[Path], results: Path, cfg: dict) -> str:
    """The in-plane test with the elastic joint (alpha = 0) and the calibrated alpha overlaid."""
    runs = {read_fit(p).get("role"): (read_fit(p), p.parent) for p in fits}
    inplane = [(f, d) for f, d in runs.values() if f.get("load_case") == "inplane"]
    if len(inplane) < 2:
        return ""
    test_id = inplane[0][0]["test_id"]
    prepared = read_prepared(Path(results) / "data" / f"{test_id}.h5")
    curves = {f"{'calibrated' if f.get('role') == 'calibration' else 'elastic joint'}: alpha = "
              f"{f['parameters']['alpha']:.3g} s": pd.read_csv(d / "curve.csv")
              for f, d in sorted(inplane, key=lambda fd: fd[0]["parameters"]["alpha"])}
    fig = plots.overlay_figure(curves, prepared, title=f"{physical_name(test_id, cfg)}: damping of the joint",
                               zoom=BRANCH_ZOOM_MM)
    return '<div class="fit">' + _img(fig, "branch alpha overlay") + "</div>"


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


def solver_table(summary: dict, cfg: dict) -> list[list]:
    """Rows (quantity with unit and limits, value, check) of a hi-fi run's summary numbers;
    a value above its limit (``explicit``) is flagged."""
    rows = []
    for key, (label, limit) in solver_statistics(cfg).items():
        if key not in summary or summary[key] is None:
            continue
        v = summary[key]
        check = ""
        if limit is not None:
            check = (Raw(f"<span class='bad'>above {float(limit):g}</span>") if float(v) > float(limit)
                     else f"within {float(limit):g}")
        rows.append([label, f"{v:.3g}" if isinstance(v, float) else v, check])
    return rows


def _negative_energy_note(history: pd.DataFrame, summary: dict) -> str:
    """A note for energy families that end below zero (the energy a family absorbs is minus
    the work its forces do on the nodes, integrated over the run, not a stored potential)."""
    labels = dict(plots.ENERGY_COLUMNS)
    low = {k: float(history[k].min()) for k in ("contact", "pin_contact", "friction", "cohesive")
           if k in history and float(history[k].min()) < 0.0}
    w_ext = float(history["W_ext"].iloc[-1]) if "W_ext" in history else float("nan")
    low = {k: v for k, v in low.items() if abs(v) > 1e-3 * abs(w_ext)}
    if not low:
        return ""
    listed = ", ".join(f"{labels.get(k, k)} {v:.3g} N mm" for k, v in low.items())
    balance = summary.get("energy_error")
    closes = f" to {balance:.2g} of the external work" if balance is not None else ""
    return (f"<p class='note'>Below zero ({listed}; external work {w_ext:.3g} N mm): each energy curve is "
            "the work absorbed by that family of forces, integrated over the run; it goes negative when "
            "those forces return more work to the nodes than they took. The balance KE + absorbed "
            f"energies = external work closes{closes}.</p>")


def _force_drop_rows(summary: dict) -> list[list]:
    """The run's largest force drop below its running peak, flagged when it is a fall
    (:func:`harnesspipe.models.hifi.is_fall`), named a snap when sudden."""
    from harnesspipe.models.hifi import is_fall, is_snap
    d = summary.get("force_drop")
    if not d:
        return []
    where = f"from {d['from_mm']:.1f} to {d['to_mm']:.1f} mm"
    check = where
    if is_fall(d):
        check = Raw(f"<span class='bad'>{'a snap' if is_snap(d) else 'a fall'}, {html.escape(where)}</span>")
    return [["largest force drop below its running peak [N]",
             f"{d['drop_N']:.3g} ({100.0 * d['fraction']:.0f} % of the peak)", check]]


SLIP_SEEN = "the paper saw some wires slide out of the taped ends (Sec. 4.2.1, Fig. 12)"
DEBOND_FROM_MM = 20.0   # Sec. 4.2.1: debonding seen in the tests past this deflection
DEBOND_SEEN = f"the paper saw the tape debond past about {DEBOND_FROM_MM:g} mm (Sec. 4.2.1)"


def _physical_rows(folder: Path, summary: dict) -> list[list]:
    """The run's physical checks beside the paper's observations: how far the wires slid out
    of the taped ends (slip_out.csv: each wire end against the covering's), and whether a
    tape tie reached damage (its largest separation against the onset delta0; with the
    opening it had reached at ``DEBOND_FROM_MM`` when energies.csv records it)."""
    rows = []
    if (folder / "slip_out.csv").exists():
        slip = pd.read_csv(folder / "slip_out.csv")
        ends = slip[["left_mm", "right_mm"]].to_numpy()
        w = int(np.argmax(ends.max(axis=1)))
        rows.append(["wires slid out of the taped ends [mm] (largest; median)",
                     f"{ends.max():.2f} (wire {int(slip['wire'][w])}, type {int(slip['type'][w])}); "
                     f"{np.median(ends):.2f}", SLIP_SEEN])
    sep, delta0 = summary.get("tie_separation_max_mm"), summary.get("interface", {}).get("delta0")
    if sep is not None and delta0 is not None:
        n = int(summary.get("debonded_ties", 0))
        reach = f"{sep / delta0:.2g} of the onset delta0"
        state = (f"{n} ties debonded" if n else f"ties damaged ({reach}), none debonded"
                 if sep > delta0 else f"no tie reached damage ({reach})")
        rows.append(["tape ties: largest separation [mm]", f"{sep:.3g}{_opening_note(folder)}",
                     f"{state}; {DEBOND_SEEN}"])
    return rows


def _opening_note(folder: Path) -> str:
    """The ties' largest opening once the feeder had reached ``DEBOND_FROM_MM`` (energies.csv
    ``tie_opening_mm``) as ``" (x at 20 mm)"``; empty when the run does not record it."""
    from harnesspipe.models.hifi import tie_opening_at
    if not (folder / "energies.csv").exists():
        return ""
    at = tie_opening_at(pd.read_csv(folder / "energies.csv"), DEBOND_FROM_MM)
    return "" if at is None else f" ({at:.3g} at {DEBOND_FROM_MM:g} mm)"


def _hifi_run_block(title: str, folder: Path, measured, cfg: dict | None = None,
                    report_dir: Path | None = None) -> tuple[str, dict | None]:
    """Curve vs measured band, energies and the summary numbers of one hi-fi run."""
    summary = _read_json(folder / "summary.json")
    if summary is None or not (folder / "curve.csv").exists():
        return "", None
    curve = pd.read_csv(folder / "curve.csv")
    figs = [_img(plots.hifi_curve_figure({"hi-fi": curve}, measured, title=title), f"hi-fi {title}")]
    energy_note = ""
    if (folder / "energies.csv").exists():
        history = pd.read_csv(folder / "energies.csv")
        figs.append(_img(plots.energies_figure(history, title=f"{title}: energies"), f"energies {title}"))
        energy_note = _negative_energy_note(history, summary)
    if (folder / "shapes.png").exists():
        data = base64.b64encode((folder / "shapes.png").read_bytes()).decode()
        figs.append(f'<img alt="shapes {html.escape(title)}" src="data:image/png;base64,{data}">')
    numbers = solver_table(summary, cfg or {}) + _force_drop_rows(summary) + _physical_rows(folder, summary)
    m = summary.get("measured")
    if m:
        numbers.append([f"||e||_l2 vs test {m['test_id']} [N]", m["error_l2"], ""])
        goals = (cfg or {}).get("hifi", {}).get("pipeline", {}).get("fidelity_goal", {})
        role = str(summary.get("role", "prediction")).split()[0]     # "calibration (mu_rtb)": a fit's run
        goal = goals.get(role, goals.get("prediction"))
        check = ""
        if goal is not None:
            css, words = judged(m["error_rel"], goal, verdict.hifi_spread(cfg))
            check = Raw(f"<span class='{css}'>goal {100 * goal:.0f} %: {html.escape(words)}</span>")
        numbers.append(["relative l2 error vs test", f"{100 * m['error_rel']:.1f} %", check])
    text = f"<h4>{html.escape(title)}</h4>" + _table(["quantity", "value", "check"], numbers) + energy_note
    if report_dir is not None:
        text += links.folder_links(folder, report_dir, links.RUN_FILES)
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
CHAIN_ORDER = {step: i for i, step in enumerate(STEPS)}     # the chain's order
RUN_GROUPS = (("virtual", "Virtual tests at the calibrated interface"),   # single runs, in section order
              ("crosscheck", "Cross-check runs at the paper's parameters"),
              ("chain", "Calibration runs at the best points"))


def _chain_mesh_note(cfg: dict) -> str:
    """A sentence when the chain's fits ran on another profile's mesh than the virtual tests."""
    chain = verdict.chain_mesh(cfg)
    if not chain:
        return ""
    profile = cfg.get("profile", "default")
    return (f" The chain's fits ran on the <b>{html.escape(chain)}</b> profile's mesh "
            f"(config hifi.pipeline.chain_profile), the virtual tests below on the "
            f"{html.escape(profile)} profile's: the calibration cases' errors include the "
            "difference between the two meshes.")


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


def _crosscheck_table(root: Path, cfg: dict) -> str:
    """Table 3 by eq. 13 + simplex on the cross-check curves beside the paper's."""
    t3 = root / "crosscheck" / "table3.csv"
    if not t3.exists():
        return ""
    rows = []
    for r in pd.read_csv(t3).itertuples():
        ref = cfg.get("paper", {}).get("table3", {}).get(r.case, {})
        for k in ("E", "sigma_y", "K", "n"):
            rows.append([physical_name(r.case, cfg), k, getattr(r, k), ref.get(k, ""), _rel(getattr(r, k), ref.get(k))])
    return ("<h3>Table 3 from hi-fi curves at the paper's parameters</h3>"
            "<p>eq. 13 + simplex (the ROM stage's fit) on each hi-fi curve "
            "(<code>results/hifi/crosscheck/table3.csv</code>).</p>"
            + _table(["case", "parameter", "hi-fi + ROM fit", "paper (Table 3)", "difference"], rows))


def _crosscheck_rom_figures(root: Path, cfg: dict) -> str:
    """The ROM fitted to each cross-check curve, over that curve."""
    figs = []
    for fit_path in sorted(root.glob("crosscheck/*/rom/fit.json")):
        fit = read_fit(fit_path)
        hifi_curve = fit_path.parent.parent / "curve.csv"
        if hifi_curve.exists():
            figs.append(_img(plots.hifi_rom_figure(pd.read_csv(hifi_curve), pd.read_csv(fit_path.parent / "curve.csv"),
                                                   title=f"{physical_name(fit['item'], cfg)}: ROM on the hi-fi curve"),
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
    names += [k for k in cfg.get("hifi", {}).get("build", {}) if k not in names]     # kept, not fitted
    guess = {k: ("" if v is None else v) for k, v in guess.items()}      # null: another key's value
    rows = [[k, fitted.get(k, ""), guess.get(k, ""), pi.get(k, ""), _rel(fitted.get(k), pi.get(k))]
            for k in names]
    src = "results/hifi/interface.csv" if iface.exists() else "chain fits so far (interface.csv not written yet)"
    return (f"<h3>Calibrated interface (Sec. 4.2) and build state</h3><p>From <code>{html.escape(src)}</code>; "
            "the build state (end_tape_layers: wraps of the end bands; fabric_end_tape_layers: "
            "those of a fabric-sleeved CWB, empty: end_tape_layers; tape_tension: the tape's "
            "wrapping tension, N; pack_angle: the wire pack turned about its axis, deg; wire_fill: "
            "the wires spread in the covering; end_tape_binds: 1 when the end bands bind every wire, "
            "0 only those they touch; fabric_end_tape_binds: those of a fabric-sleeved CWB; tube_closure: a slit "
            "tube rolled onto its bundle; sleeve_closure: a fabric sleeve curled onto its bundle) "
            "is not in the paper; a build input without a calibrated "
            "value keeps its config value (initial guess)." + _chain_mesh_note(cfg) + "</p>"
            + _table(["parameter", "calibrated", "initial guess", "paper (Sec. 4.2)", "difference"], rows))


@dataclass
class _HifiContext:
    """What the hi-fi section's parts share: the config, the measured tests by case, the
    report's folder (links) and the cost table they fill."""
    cfg: dict
    measured: dict
    report_dir: Path | None = None
    cost: _HifiCost = field(default_factory=_HifiCost)


def _pick_words(message: str) -> str:
    """The part of a fit's message that says where its search rests
    (:func:`harnesspipe.calibrate.simplex.rest_at_pick`), as a sentence; "" if none."""
    part = next((p for p in message.split("; ") if p.startswith("rests at") or "was rejected" in p), "")
    if not part:
        return ""
    return (f" The fit {html.escape(part)} (the scale: the standard error of the measured mean, "
            "l2 over the window; points the data do not tell apart share the weight).")


def _marginal_words(fit: dict) -> str:
    """A sentence when the step's pick or identifiability screen lies within the runs'
    last-bits spread of its threshold (fit.json ``decision``), else ""."""
    d = fit.get("decision") or {}
    if not d.get("marginal"):
        return ""
    return (f' <span class="bad">Marginal: this decision lies {abs(d["margin_N"]):.3g} N from its '
            f'threshold ({d["threshold_N"]:.3g} N, the standard error of the measured mean), within '
            f'the runs\' last-bits spread ({d["bits_spread_N"]:.3g} N, hifi.pipeline.fidelity_spread): '
            "on another machine it may go the other way, and every later step with it.</span>")


def _step_text(fit: dict, paper: dict, cfg: dict) -> str:
    """Heading, method, window, error, cost and fitted values of one calibration step."""
    message = fit.get("message", "").split("; marginal:")[0]      # said by _marginal_words
    ended = ("stopped at its budget of evaluations (hifi.pipeline.budgets)"
             if message.startswith("Maximum number of function") else "did not converge")
    status = "" if fit.get("converged") else f' <span class="bad">(search {ended})</span>'
    if "not identifiable" in message:
        status = f' <span class="bad">{html.escape(message)}.</span>'
    status += _pick_words(message)
    if fit.get("method") == "choice":            # the pick between a few values: its errors and why
        status = f" {html.escape(message)}."
    status += _marginal_words(fit)
    searched = (str(fit["bounds"]) if fit.get("bounds") else
                f"one of {fit['choices']}" if fit.get("choices") else "")
    cases = "; ".join(labelled(c, cfg) for c in fit.get("cases", []))
    text = (f"<h3>Calibration step {html.escape(fit['item'])}</h3><p>{html.escape(fit.get('method', ''))} "
            f"on {html.escape(cases)}, deflection window "
            f"{fit.get('window')} mm: ||e||<sub>l2</sub> = {fit['error_l2']:.4g} N (relative "
            f"{100 * fit['error_rel']:.2f} %), {fit['nfev']} evaluation{'s' if fit['nfev'] != 1 else ''}, "
            f"{fit.get('rejected', 0)} rejected, "
            f"{fit.get('hifi_wall_s', 0.0) / 60:.1f} min of hi-fi runs.{status}</p>"
            + _table(["", *fit["parameters"]], [["fitted", *fit["parameters"].values()],
                                                 ["search interval", *[searched for _ in fit["parameters"]]],
                                                 ["paper", *[paper.get("interface", {}).get(k, "not in the paper")
                                                             for k in fit["parameters"]]]]))
    if fit["item"] == "cohesive":
        text += COHESIVE_MESH_NOTE
    return text


def _step_figures(folder: Path, fit: dict, ctx: _HifiContext) -> tuple[list[str], str]:
    """The step's curves against the measured cases and its optimiser trace (or, for one or
    two evaluations, a note instead)."""
    figs = []
    curve = pd.read_csv(folder / "curve.csv")
    preps = {c: ctx.measured[c] for c in fit.get("cases", []) if c in ctx.measured}
    if preps:
        figs.append(_img(plots.hifi_cases_figure(preps, {c: g for c, g in curve.groupby("case")},
                                                 title=f"step {fit['item']}", window=fit.get("window"),
                                                 names={c: physical_name(c, ctx.cfg) for c in preps}),
                         f"chain {fit['item']}"))
    fig, note = _trace_or_count(_load_trace(folder / "trace.h5"), f"{fit['item']}: optimiser trace",
                                f"trace {fit['item']}")
    return figs + ([fig] if fig else []), note


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


def _calibration_step(path: Path, paper: dict, ctx: _HifiContext) -> str:
    """One step of the chain (its fit.json at ``path``); its runs go to the cost table."""
    fit = read_fit(path)
    text = _step_text(fit, paper, ctx.cfg)
    figs, note = _step_figures(path.parent, fit, ctx)
    rej = _step_rejections(path.parent, fit)
    n = int(fit.get("hifi_runs", fit["nfev"])) - int(fit.get("hifi_runs_reused", 0))   # reused: no cost
    wall = float(fit.get("hifi_wall_s", 0.0))
    ctx.cost.add(f"fit {fit['item']}", n, wall, wall / max(n, 1))
    files = links.folder_links(path.parent, ctx.report_dir) if ctx.report_dir is not None else ""
    return f'<div>{text}{note}{rej}{files}<div class="fit">{"".join(figs)}</div></div>'


def _single_run(path: Path, root: Path, ctx: _HifiContext) -> tuple[str, str]:
    """(group, block) of one single run (its summary.json at ``path``; block "" if it has
    no curve); cross-check and virtual runs go to the cost table (a reused run at no cost)."""
    folder = path.parent
    group = folder.parent.name if folder.parent.parent == root else "chain"
    case = folder.name
    name = labelled(case, ctx.cfg)
    title = {"crosscheck": f"cross-check: {name} at the paper's values", "virtual": f"virtual test: {name}",
             "chain": f"fit {folder.parent.name}: {name} at the best point"}[group]
    block, summary = _hifi_run_block(title, folder, ctx.measured.get(case), ctx.cfg, ctx.report_dir)
    if not block:
        return group, ""
    if summary.get("role"):
        block = block.replace("</h4>", f" <span class='note'>({html.escape(summary['role'])})</span></h4>", 1)
    if group != "chain" and summary.get("reused_from"):      # the fit's run, counted there
        ctx.cost.rows.append([f"{title} (the fit's best-point run)", 0, 0.0, 0.0])
    elif group != "chain":
        wall = float(summary.get("wall_s", 0.0))
        ctx.cost.add(title, 1, wall, wall)
    return group, block


def _single_runs(root: Path, runs: list[Path], ctx: _HifiContext) -> str:
    """The single runs by group, each group folded (<details>): the virtual tests (summed up
    by the fidelity table above), the cross-check runs and the best points of the fits
    (repeats of runs shown in their fit)."""
    blocks = {group: [] for group, _ in RUN_GROUPS}
    for path in runs:
        group, block = _single_run(path, root, ctx)
        if block:
            blocks[group].append(block)
    out = []
    for group, head in RUN_GROUPS:
        if blocks[group]:
            out.append(f"<h3>{head}</h3><details><summary>{len(blocks[group])} runs: curves, energies, "
                       f"shapes and solver statistics</summary>" + "".join(blocks[group]) + "</details>")
    return "".join(out)


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


def _fidelity_table(root: Path, cfg: dict, fidelity: list[dict] | None = None) -> str:
    """Each virtual test's relative l2 error against its measured mean beside the goal of its
    role (config ``hifi.pipeline.fidelity_goal``): met, or missed and by how much; for the
    cases with a measured test (``fidelity``: :func:`verdict.hifi_fidelity`), the share of the
    measured force the model reaches and the wires' own force each curve carries."""
    goals = cfg["hifi"]["pipeline"]["fidelity_goal"]
    tested = {f["case"]: f for f in fidelity or ()}
    rows = []
    for path in sorted((root / "virtual").glob("*/summary.json")):
        summary = _read_json(path)
        m = (summary or {}).get("measured")
        if not m:
            continue
        case = path.parent.name
        role = str(summary.get("role", "prediction"))
        goal = goals.get(role, goals["prediction"])
        err = float(m["error_rel"])
        css, words = judged(err, goal, verdict.hifi_spread(cfg))
        cell = f"<td class='{css}'>{html.escape(words)}</td>" if css else f"<td>{words}</td>"
        ratio = carried = ""
        if case in tested:
            ratio = f"{100 * tested[case]['ratio']:.0f} %"
            carried = " / ".join(map(verdict.times, tested[case]["coupling"]))
        rows.append(f"<tr><td>{html.escape(labelled(case, cfg))}</td><td>{html.escape(role)}</td>"
                    f"<td>{100 * err:.1f}&nbsp;%</td><td>{100 * goal:.0f}&nbsp;%</td>{cell}<td>{ratio}</td>"
                    f"<td>{carried}</td></tr>")
    if not rows:
        return ""
    head = "".join(f"<th>{h}</th>" for h in ("case", "role", "relative error", "goal", "verdict",
                                             "model force / measured",
                                             "wires' own force carried at the end: model / test"))
    return ("<h3>Virtual tests against the bending tests</h3><p class='note'>Relative l2 error of "
            "each virtual test's force against the measured mean over its window; the goal is "
            "the project's (calibration cases fitted on, the others predicted with no refit); an error "
            "within the run-to-run spread of its goal (hifi.pipeline.fidelity_spread: explicit runs "
            "differ in their last bits between machines) is at the goal, neither met nor missed; the "
            "column 'model force / measured' sums the model's force over the measured grid against the "
            "test's; the last gives how many times its wires' own force (each wire bending on its own, "
            "Table 1: the bundle with nothing holding it together) each curve carries at the test's end, "
            "what the covering, the tape and the friction add: where model and test differ there, the "
            "miss is in what holds the wires together, not in the wires.</p>"
            f"<div class='wide'><table><tr>{head}</tr>{''.join(rows)}</table></div>")


def hifi_section(results: Path, cfg: dict, measured: dict, report_dir: Path | None = None,
                 screen_record: dict | None = None, band_record: dict | None = None,
                 fidelity: list[dict] | None = None) -> str:
    """Everything of results/hifi that exists: cross-check Table 3 (and the record of its
    band over the build state), the calibration chain, the interface beside the paper's, the
    sensitivity screen's record, the virtual tests, their energies and the cost.
    ``fidelity``: :func:`verdict.hifi_fidelity` when the caller has it already."""
    heading = f"<h2 id='hifi'>{html.escape(STAGES['hifi'][0])}</h2>"
    root = Path(results) / "hifi"
    runs = sorted(root.glob("*/*/summary.json")) + sorted(root.glob("chain/*/*/summary.json"))
    fits = sorted(root.glob("chain/*/fit.json"),
                  key=lambda p: (CHAIN_ORDER.get(p.parent.name, 9), p.parent.name))
    if not runs and not fits and not (root / "crosscheck" / "table3.csv").exists():
        return heading + NO_HIFI_NOTE
    paper = cfg.get("paper", {})
    ctx = _HifiContext(cfg, measured, report_dir)
    if fidelity is None:
        fidelity = verdict.hifi_fidelity(results, cfg, measured)
    parts = [heading, HIFI_INTRO, _fidelity_table(root, cfg, fidelity), _crosscheck_table(root, cfg),
             band.section(band_record, cfg), _crosscheck_rom_figures(root, cfg),
             _interface_table(root, fits, cfg), screen.section(screen_record)]
    parts += [_calibration_step(p, paper, ctx) for p in fits]
    parts += [_single_runs(root, runs, ctx), _cost_table(ctx.cost, paper.get("cost", {}))]
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
    cost = solver_table(summary, cfg)
    for name, (fit, _) in roms.items():
        cost.append([f"ROM {name} run: wall time [s]", f"{fit['wall_s']:.2f}", ""])
    text = ("<h3>Hi-fi Y harness beside the ROM (Fig. 18a)</h3><p class='note'>The mesoscale model "
            "(every wire a fibre beam, open tubes and tape as shells, contact-friction, cohesive tape; "
            "<code>models/hifi_branch.py</code>) at the paper's interface values and the tensile "
            "stage's coverings, against the ROM with the same geometry. The paper finds hi-fi and "
            "elastic-joint ROM alike and both below the test for u &lt; 10 mm.</p>"
            + _table(header, [[f"{v:.4g}" if isinstance(v, float) else v for v in r] for r in rows])
            + _table(["cost and checks", "value", "check"], cost))
    return f'<div>{text}<div class="fit">{"".join(figs)}</div></div>'


def _read_json_line(line: str) -> dict | None:
    import json
    try:
        return json.loads(line)
    except ValueError:
        return None


BRANCH_RUNS = {"inplane": "Y harness, in-plane pull: alpha calibrated",
               "elastic": "Y harness, in-plane pull: elastic joint (alpha = 0)",
               "outofplane": "Y harness, out-of-plane pull: validation at the calibrated alpha",
               "hifi": "Y harness, in-plane pull: hi-fi model"}


def folder_name(rel: str, cfg: dict) -> str:
    """What a result folder (path below results/) holds, in words."""
    parts = rel.split("/")
    if parts[0] == "branch":
        return BRANCH_RUNS.get(parts[-1], parts[-1])
    if parts[:2] == ["hifi", "chain"]:
        return f"hi-fi calibration step {parts[-1]}"
    prefix = {"virtual": "hi-fi virtual test: ", "crosscheck": "hi-fi at the paper's values: "}.get(
        parts[1] if len(parts) > 2 else "", "")
    return prefix + physical_name(parts[-1], cfg)


SECTION_ORDER = ("tensile", "hifi", "rom", "branch")   # the chain's order (DESIGN sec. 2)
STATUS_MEANING = {
    verdict.MISMATCH: "relative l2 error against the measured mean above the goal of its role "
                      "(hifi.pipeline.fidelity_goal) by more than its run-to-run spread",
    verdict.AT_GOAL: "a hi-fi run's relative l2 error within its run-to-run spread of the goal "
                     "(hifi.pipeline.fidelity_spread): another machine's last bits could put it on "
                     "either side",
    verdict.ON_BOUND: f"within {100 * verdict.BOUND_TOL:.0f} % of an end of its search interval",
    verdict.NOT_IDENTIFIABLE: f"standard error above {100 * verdict.UNDETERMINED:.0f} %, or stopped by the "
                              "fit's identifiability screen",
    verdict.NO_SE: "the fit gives no standard error",
    verdict.ROUGH: f"standard error {100 * verdict.DETERMINED:.0f}-{100 * verdict.UNDETERMINED:.0f} %",
    verdict.OK: f"standard error below {100 * verdict.DETERMINED:.0f} %",
}


def _se_cell(se) -> str:
    if se is None:
        return "none"
    return "> 100 %" if se > 1.0 else f"\u00b1{100.0 * se:.2g} %"


def _counts(rows) -> str:
    return ", ".join(f"{_status_badges([st])}&nbsp;{n}" for st in verdict.STATUS_ORDER
                     if (n := sum(st in r.statuses for r in rows)))


def verdict_section(rows: list, cfg: dict) -> str:
    """The verdict's summary: what was calibrated, per stage how well against the tests and
    how many parameters carry which status."""
    if not rows:
        return "<h2 id='verdict'>Verdict</h2><p>No calibrated parameter in these results yet.</p>"
    body = []
    for stage in SECTION_ORDER:
        sr = [r for r in rows if r.stage == stage]
        if not sr:
            continue
        items = sorted({r.item for r in sr})
        errs = [r.error for r in sr if r.error is not None]
        goals = sorted({r.goal for r in sr if r.goal is not None})
        err = "" if not errs else (f"{100 * min(errs):.1f}-{100 * max(errs):.1f} %" if max(errs) > min(errs)
                                   else f"{100 * errs[0]:.1f} %")
        bad = any(verdict.MISMATCH in r.statuses for r in sr)
        body.append(f"<tr><td><a href='#{stage}'>{html.escape(verdict.STAGE_NAMES[stage])}</a></td>"
                    f"<td>{len(sr)} in {len(items)} item{'s' if len(items) > 1 else ''}</td>"
                    f"<td class='{'bad' if bad else ''}'>{err}</td>"
                    f"<td style='white-space:nowrap'>{' / '.join(f'{100 * g:.0f} %' for g in goals)}</td>"
                    f"<td style='text-align:left'>{_counts(sr)}</td></tr>")
    head = "".join(f"<th>{h}</th>" for h in ("stage", "calibrated parameters", "fit error vs the tests",
                                             "goal", "status of the parameters"))
    return (f"<h2 id='verdict'>Verdict</h2><p><b>{len(rows)} calibrated parameters</b> "
            f"(profile {html.escape(cfg.get('profile', ''))}): {_counts(rows)}. "
            "<a href='#parameters'>Every parameter</a> below the limitations.</p>"
            f"<div class='wide'><table><tr>{head}</tr>{''.join(body)}</table></div>")


def parameters_section(rows: list, cfg: dict, truth: dict) -> str:
    """The verdict per parameter: value, the paper's, their difference, standard errors, the
    fit's error against the test (its goal) and the statuses, grouped by stage and item."""
    if not rows:
        return ""
    header = ["item", "parameter", "value", "paper", "difference", "SE (Fisher)", "SE (replicates)"]
    header += ["truth (synthetic)"] if truth else []
    header += ["fit error (goal)", "status"]
    body, groups = [], {}
    for r in rows:
        groups.setdefault((r.stage, r.item), []).append(r)
    stage_of_last = None
    for (stage, item), group in groups.items():
        if stage != stage_of_last:   # a row naming the stage above its items
            body.append(f"<tr class='stage'><td class='txt' colspan='{len(header)}'>"
                        f"{html.escape(verdict.STAGE_NAMES[stage])}</td></tr>")
            stage_of_last = stage
        for k, r in enumerate(group):
            cells = ""
            if k == 0:
                span = f" rowspan='{len(group)}'"
                cells += (f"<td class='txt'{span}>{html.escape(physical_name(item, cfg))}<br>"
                          f"<code class='note'>{html.escape(item)}</code></td>")
            fisher = r.se if r.se_source == "Fisher" else None
            cells += f"<td class='txt'>{html.escape(SYMBOLS.get(r.parameter, r.parameter))}</td>"
            values = [f"{r.value:.4g}",
                      "" if r.paper is None else f"{r.paper:g}",
                      "" if r.difference is None else f"{100 * r.difference:+.1f} %",
                      _se_cell(fisher), _se_cell(r.se_replicates)]
            values += ["" if r.truth is None else f"{r.truth:.4g}"] if truth else []
            values += ["" if r.error is None else f"{100 * r.error:.1f} % ({100 * r.goal:.0f} %)"]
            cells += "".join(f"<td>{html.escape(v)}</td>" for v in values)
            badges = _status_badges(r.statuses)
            if r.bound:   # the interval right after its badge
                badge = _status_badges([verdict.ON_BOUND])
                badges = badges.replace(badge, f"{badge} <span class='note'>[{r.bound[0]:g}, {r.bound[1]:g}]</span>")
            cells += f"<td class='txt'>{badges}</td>"
            body.append(f"<tr>{cells}</tr>")
    legend = ("<p class='note'>" + "; ".join(f"{_status_badges([st])} {html.escape(m)}"
                                             for st, m in STATUS_MEANING.items())
              + ". Standard errors are relative (of ln p): Fisher's from the load-cell noise (the tested "
              "specimens), the replicates' sandwich on 2 degrees of freedom (the population); the status "
              "uses Fisher's where there is one. The fit error is the relative l2 error of the model "
              "against the measured mean of the test (for a hi-fi step: the worst of its cases' virtual "
              "tests; for a ROM: its curve against the case's test).</p>")
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    return (f"<h2 id='parameters'>Verdict per parameter</h2>{legend}"
            f"<div class='wide'><table class='verdict'><tr>{head}</tr>{''.join(body)}</table></div>")


def limitations_section(sentences: list[str]) -> str:
    items = "".join(f"<li>{html.escape(t)}</li>" for t in sentences)
    text = f"<ul>{items}</ul>" if sentences else "<p>None of the report's checks found a limitation.</p>"
    return f"<div class='limits'><h2 id='limitations'>Limitations</h2>{text}</div>"


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", html.unescape(re.sub(r"<[^>]+>", "", text)).lower()).strip("-")


def with_toc(body: str, first: str = "verdict") -> tuple[str, str]:
    """Give every <h3> of ``body`` an id and return (body, table of contents) of its <h2 id>
    sections and their <h3> subsections (those outside <details>)."""
    used: set[str] = set()

    def unique(base: str) -> str:
        k, name = 1, base or "section"
        while name in used:
            k += 1
            name = f"{base}-{k}"
        used.add(name)
        return name
    used.update(re.findall(r"<h2 id='([^']+)'", body))
    body = re.sub(r"<h3>(.*?)</h3>", lambda m: f"<h3 id='{unique(_slug(m.group(1)))}'>{m.group(1)}</h3>", body)
    toc, depth = [], 0
    for m in re.finditer(r"<h([23]) id='([^']+)'>(.*?)</h\1>|<details>|</details>", body):
        if m.group(0) == "<details>":
            depth += 1
            continue
        if m.group(0) == "</details>":
            depth -= 1
            continue
        if depth == 0:
            toc.append((int(m.group(1)), m.group(2), re.sub(r"<[^>]+>", "", m.group(3))))
    out, open_sub = [], False
    for level, anchor, title in toc:
        if level == 2:
            if open_sub:
                out.append("</ul></li>")
                open_sub = False
            elif out:
                out.append("</li>")
            out.append(f"<li><a href='#{anchor}'>{title}</a>")
        else:
            if not open_sub:
                out.append("<ul>")
                open_sub = True
            out.append(f"<li><a href='#{anchor}'>{title}</a></li>")
    out.append("</ul></li>" if open_sub else "</li>")
    return body, "<nav class='toc' id='contents'><b>Contents</b><ul>" + "".join(out) + "</ul></nav>"


def build(out: Path, *, cfg: dict, results: Path, check_summary: Path,
          prepared: list[Path], fits: dict[str, list[Path]], screen_record: dict | None = None,
          band_record: dict | None = None) -> Path:
    """Write the report to ``out`` (atomically) and return its path; ``screen_record``: the
    sensitivity screen's (:func:`harnesspipe.report.screen.read_record`), ``band_record``:
    Table 3's band over the build state (:func:`harnesspipe.report.band.read_record`), if any."""
    results, out = Path(results), Path(out)
    report_dir = out.parent
    truth = read_truth(Path(cfg["data_dir"]))
    measured = _measured_by_case(prepared)
    rows = verdict.verdict_rows(cfg, results, fits, truth, measured)
    fidelity = verdict.hifi_fidelity(results, cfg, measured)     # free-wire ROM runs: once
    sections = [verdict_section(rows, cfg),
                limitations_section(verdict.limitations(rows, cfg, results, fits, truth, measured,
                                                        fidelity)),
                parameters_section(rows, cfg, truth),
                data_section(Path(check_summary).read_text().strip(), prepared, truth, cfg)]
    for stage in SECTION_ORDER:
        if stage == "hifi":
            sections.append(hifi_section(results, cfg, measured, report_dir, screen_record, band_record,
                                         fidelity))
        elif fits.get(stage):
            sections.append(stage_section(stage, fits[stage], results, cfg, truth, measured, rows=rows,
                                          report_dir=report_dir))
            if stage == "branch":
                sections.append(branch_hifi_section(results, cfg))
    files = links.files_section(results, report_dir, lambda rel: folder_name(rel, cfg))
    if files:
        sections.append("<h2 id='files'>Result files</h2>" + files)
    body, toc = with_toc("".join(sections[3:]))
    top = "".join(sections[:3])
    jump = " \u00b7 ".join(f"<a href='#{a}'>{html.escape(t)}</a>" for a, t in
                           re.findall(r"<h2 id='([^']+)'>(.*?)</h2>", top + body))
    head = (f"<h1>harnesspipe report</h1><p class='note'>harnesspipe {__version__}, "
            f"profile <b>{html.escape(cfg['profile'])}</b>. Units mm, N, MPa, s. "
            f"<a href='#contents'>Contents</a>: {jump}</p>")
    body = top + toc + body
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width, initial-scale=1'>"
            "<title>harnesspipe report</title><style>" + CSS + "</style></head><body>"
            + head + body + "</body></html>\n")
    report_dir.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(page)
    tmp.replace(out)
    return out
