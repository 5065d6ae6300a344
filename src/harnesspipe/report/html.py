"""The offline HTML report: one self-contained file, figures embedded as PNG data URIs.

A section per stage that has results.  Every fit shows the measured band and
mean, the simulated curve, the error norm, the fitted values beside the paper's
and (for the synthetic twin) the truth, and the optimiser trace.
"""
from __future__ import annotations

import base64
import html
from pathlib import Path

import h5py
import pandas as pd

from harnesspipe import __version__
from harnesspipe.data.synthesize import read_truth
from harnesspipe.report import plots
from harnesspipe.stages.common import read_fit
from harnesspipe.stages.data import read_prepared

STAGES = {  # stage -> (heading, paper table key, paper section)
    "tensile": ("Component tensile fits (Sec. 3.2, Table 2)", "table2", "Table 2"),
    "rom": ("Reduced-order beam properties (Sec. 4.3, eq. 13 + simplex, Table 3)", "table3", "Table 3"),
    "branch": ("Branching harness: break-out joint damping (Sec. 5, eqs. 14-15)", "damping", "Sec. 5"),
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


def fit_block(fit: dict, fit_dir: Path, prepared, paper: dict | None, truth: dict | None) -> str:
    curve = pd.read_csv(fit_dir / "curve.csv")
    names = list(fit["parameters"])
    label = "fitted" if fit.get("role", "calibration") == "calibration" else f"used ({fit['role']}, no refit)"
    rows = [[label] + [fit["parameters"][k] for k in names]]
    if truth:
        rows.append(["truth (synthetic)"] + [truth.get(k, "") for k in names])
    if paper:
        rows.append(["paper"] + [paper.get(k, "") for k in names])
    status = "" if fit["converged"] else ' <span class="bad">(optimiser did not converge)</span>'
    text = (f"<h3>{html.escape(fit['item'])}</h3>"
            f"<p>Reference: test <code>{html.escape(fit['test_id'])}</code>. "
            f"||e||<sub>l2</sub> = {fit['error_l2']:.4g} N (relative {100 * fit['error_rel']:.2f} %), "
            f"{fit['nfev']} evaluations, {fit['wall_s']:.1f} s.{status}</p>"
            + _table(["", *names], rows))
    figs = [_img(plots.fit_figure(prepared, curve, title=fit["item"]), f"fit {fit['item']}")]
    if (fit_dir / "shapes.csv").exists() and any("markers" in s for s in prepared.samples.values()):
        shapes = pd.read_csv(fit_dir / "shapes.csv")
        shapes = shapes[shapes["displacement_mm"] > 0]
        figs.append(_img(plots.shape_figure(prepared, shapes, title=f"{fit['item']}: bent shapes"),
                         f"shapes {fit['item']}"))
    trace = _load_trace(fit_dir / "trace.h5")
    if trace is not None and len(trace):
        figs.append(_img(plots.trace_figure(trace, title=f"{fit['item']}: Nelder-Mead"),
                         f"trace {fit['item']}"))
    return f'<div>{text}<div class="fit">{"".join(figs)}</div></div>'


def stage_section(stage: str, fits: list[Path], results: Path, cfg: dict, truth: dict) -> str:
    heading, _, table_name = STAGES[stage]
    blocks, summary = [], []
    for path in sorted(fits):
        fit = read_fit(path)
        prepared = read_prepared(results / "data" / f"{fit['test_id']}.h5")
        paper = paper_values(cfg, stage, fit["item"])
        tr = truth.get(fit["test_id"], {}).get("parameters")
        blocks.append(fit_block(fit, path.parent, prepared, paper, tr))
        for k, v in fit["parameters"].items():
            summary.append([fit["item"], k, v, tr.get(k, "") if tr else "", paper.get(k, "") if paper else ""])
    table = _table(["item", "parameter", "recovered", "truth", f"paper ({table_name})"], summary)
    return f"<h2>{html.escape(heading)}</h2>{table}{''.join(blocks)}"


def build(out: Path, *, cfg: dict, results: Path, check_summary: Path,
          prepared: list[Path], fits: dict[str, list[Path]]) -> Path:
    """Write the report to ``out`` (atomically) and return its path."""
    results = Path(results)
    truth = read_truth(Path(cfg["data_dir"]))
    parts = [f"<h1>harnesspipe report</h1><p class='note'>harnesspipe {__version__}, "
             f"profile <b>{html.escape(cfg['profile'])}</b>. Units mm, N, MPa.</p>",
             data_section(Path(check_summary).read_text().strip(), prepared, truth)]
    for stage in STAGES:
        if fits.get(stage):
            parts.append(stage_section(stage, fits[stage], results, cfg, truth))
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            "<title>harnesspipe report</title><style>" + CSS + "</style></head><body>"
            + "".join(parts) + "</body></html>\n")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(page)
    tmp.replace(out)
    return out
