"""The campaign page: one HTML file beside the property library, offline (images embedded).

It shows the library (``properties.csv``), every construction's virtual test with the
fitted ROM's curve (from the folders the campaign rules write next to the library:
``<case>/hifi/curve.csv``, ``<case>/rom/curve.csv``), and the bending stiffness EI and the
curvature at first yield against the constructions' features: the wire count on the
abscissa, the covering by colour, the taping by marker.  Failed constructions are listed
with their message and plotted nowhere.
"""
from __future__ import annotations

import base64
import html
import math
from pathlib import Path

import pandas as pd

from harnesspipe.campaign.library import COLUMNS
from harnesspipe.input_files import InputFileError, read_csv
from harnesspipe.report import plots

COVER_COLOURS = {"closed": "tab:blue", "open": "tab:orange", "fabric": "tab:green", "none": "tab:gray"}
TAPING_MARKERS = {"none": "o", "coarse": "s", "half-lap": "^"}
TABLE = [("case", "construction", "{}"), ("wires", "wires", "{}"), ("covering", "covering", "{}"),
         ("taping", "taping", "{}"), ("E", "E [MPa]", "{:.4g}"), ("sigma_y", "σ_Y [MPa]", "{:.3g}"),
         ("K", "K [MPa]", "{:.3g}"), ("n", "n", "{:.3g}"), ("r_o", "r_o [mm]", "{:.3g}"),
         ("EI", "EI [N mm²]", "{:.4g}"), ("kappa_y", "κ_Y [1/mm]", "{:.3g}"),
         ("ke_ie", "KE/IE", "{:.3g}"), ("energy_error", "energy error", "{:.2g}"),
         ("force_drop", "force drop", "{:.0%}"),
         ("rom_error_rel", "ROM rel. error", "{:.3f}"), ("hifi_wall_s", "hi-fi wall [s]", "{:.0f}"),
         ("status", "status", "{}"), ("message", "message", "{}")]
STYLE = ("body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}"
         "table{border-collapse:collapse;font-size:13px}td,th{border:1px solid #bbb;padding:3px 6px}"
         "th{background:#eee}.failed{color:#b00}figure{display:inline-block;margin:4px}")


def _img(fig, alt: str) -> str:
    data = base64.b64encode(plots.png_bytes(fig)).decode()
    return f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"></figure>'


def _finish(fig, ax, xlabel: str, ylabel: str, title: str):
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6)
    fig.tight_layout()
    return fig


def _cell(value, fmt: str) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return html.escape(fmt.format(value))


def table(lib: pd.DataFrame) -> str:
    """The library as an HTML table (failed rows in red)."""
    head = "".join(f"<th>{html.escape(label)}</th>" for _, label, _ in TABLE)
    rows = []
    for rec in lib.to_dict("records"):
        cls = ' class="failed"' if rec["status"] != "ok" else ""
        rows.append(f"<tr{cls}>" + "".join(f"<td>{_cell(rec.get(k), fmt)}</td>" for k, _, fmt in TABLE)
                    + "</tr>")
    return f"<table><tr>{head}</tr>{''.join(rows)}</table>"


def curve_figure(case: str, folder: Path):
    """The construction's virtual test and its fitted ROM (force against deflection)."""
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(4.6, 3.3), dpi=100)
    hifi = pd.read_csv(folder / "hifi" / "curve.csv")
    ax.plot(hifi["deflection_mm"], hifi["force_N"], color="tab:blue", lw=1.5, label="hi-fi virtual test")
    rom = folder / "rom" / "curve.csv"
    if rom.is_file():
        c = pd.read_csv(rom)
        ax.plot(c["displacement_mm"], c["force_N"], color="tab:red", ls="--", lw=1.5, label="ROM (fitted)")
    return _finish(fig, ax, "deflection [mm]", "force [N]", case)


def feature_figure(ok: pd.DataFrame, column: str, ylabel: str):
    """``column`` against the wire count, coloured by covering, marked by taping (log scale)."""
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(4.8, 3.5), dpi=100)
    for (cov, tap), group in ok.groupby(["covering", "taping"]):
        ax.scatter(group["n_wires"], group[column], color=COVER_COLOURS.get(cov, "k"),
                   marker=TAPING_MARKERS.get(tap, "x"), s=40, label=f"{cov}, taping {tap}")
        for rec in group.to_dict("records"):
            ax.annotate(rec["case"], (rec["n_wires"], rec[column]), fontsize=6,
                        xytext=(3, 3), textcoords="offset points")
    ax.set_yscale("log")
    return _finish(fig, ax, "wires in the bundle", ylabel, f"{ylabel} by construction")


def sources(root: Path, lib: pd.DataFrame) -> str:
    """Where the virtual tests' interface and the coverings' eq. 2 properties came from (each
    run's ``hifi/result.json``)."""
    import json
    found = {"interface_source": [], "coverings_source": []}
    for case in lib["case"]:
        path = root / case / "hifi" / "result.json"
        run = json.loads(path.read_text()) if path.is_file() else {}
        for key, seen in found.items():
            if run.get(key) not in (None, "none", *seen):
                seen.append(run[key])
    return (f"<p>Interface of the virtual tests: {html.escape('; '.join(found['interface_source']))}. "
            f"Coverings' eq. 2 properties: {html.escape('; '.join(found['coverings_source']) or '-')}.</p>")


def build(library_csv: Path, out: Path, title: str = "") -> str:
    """Write the page for ``library_csv`` (the construction folders beside it) to ``out``."""
    library_csv, out = Path(library_csv), Path(out)
    lib = read_csv(library_csv, keep_default_na=False, na_values=[""])
    missing = [c for c in COLUMNS if c not in lib.columns]
    if missing:
        raise InputFileError(f"{library_csv}: missing columns {', '.join(missing)} (a "
                             "properties.csv as `harnesspipe campaign library` writes it)")
    root = library_csv.parent
    ok = lib[lib["status"] == "ok"]
    parts = [f"<h1>{html.escape(title or 'Virtual test campaign')}</h1>",
             f"<p>{len(lib)} constructions: {len(ok)} ok, {len(lib) - len(ok)} failed. Each: the hi-fi "
             "virtual three-point test at the campaign's interface, then eq. 13 + simplex (Sec. 4.3). "
             "EI = E π r_o⁴/4; κ_Y = σ_Y/(E r_o), the curvature at which the effective beam's outer fibre "
             "yields.  Library: <code>properties.csv</code>.</p>",
             sources(root, lib), "<h2>Property library</h2>", table(lib)]
    if len(ok):
        parts += ["<h2>Stiffness and yield curvature by construction</h2>",
                  _img(feature_figure(ok, "EI", "EI [N mm²]"), "EI by construction"),
                  _img(feature_figure(ok, "kappa_y", "κ_Y [1/mm]"), "yield curvature by construction"),
                  "<h2>Virtual tests and fitted ROMs</h2>"]
        parts += [_img(curve_figure(c, root / c), f"{c}: curves") for c in ok["case"]]
    failed = lib[lib["status"] != "ok"]
    if len(failed):
        parts += ["<h2>Failed constructions</h2><ul>"] + [
            f"<li class='failed'><b>{html.escape(r['case'])}</b>: {html.escape(str(r['message']))} "
            f"(diagnostics: <code>{html.escape(r['case'])}/property.json</code>)</li>"
            for r in failed.to_dict("records")] + ["</ul>"]
    text = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
            f"<style>{STYLE}</style></head><body>{''.join(parts)}</body></html>")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(text)
    tmp.replace(out)
    return str(out)
