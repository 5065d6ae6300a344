"""Links from the report to the result files a user takes away.

Links are relative to the report's folder (results/report/), so the report and its
results can be moved or zipped together; only files that exist are linked.
"""
from __future__ import annotations

import html
import os
from pathlib import Path

SUMMARY_TABLES = (  # DESIGN sec. 5: the tables other tools read
    ("tensile/table2.csv", "Table 2: covering properties (component,E,sigma_y,K,n)"),
    ("rom/table3.csv", "Table 3: effective beam properties (case,E,sigma_y,K,n,reference)"),
    ("hifi/interface.csv", "calibrated interface (parameter,value)"),
    ("branch/damping.csv", "branch damping alpha (parameter,value)"),
    ("hifi/crosscheck/table3.csv", "Table 3 from hi-fi curves at the paper's values"),
)
FIT_FILES = (  # a fit folder's take-away files, with what each holds
    ("fit.json", "fitted values, errors, standard errors, correlations"),
    ("curve.csv", "fitted curve"),
    ("shapes.pvd", "bent shapes (ParaView, VTU series)"),
    ("shapes.csv", "bent shapes (table)"),
)
RUN_FILES = (  # a hi-fi run folder's
    ("curve.csv", "force-deflection curve"),
    ("summary.json", "solver statistics"),
    ("energies.csv", "energy history"),
    ("slip_out.csv", "wire slip-out at the ends"),
    ("shapes.pvd", "deformed shapes (ParaView, VTU series)"),
)


def href(target: Path, report_dir: Path) -> str:
    """``target``'s path relative to the report's folder, with forward slashes."""
    return Path(os.path.relpath(Path(target).resolve(), Path(report_dir).resolve())).as_posix()


def link(target: Path, report_dir: Path, text: str | None = None, title: str = "") -> str:
    """An <a> to ``target`` (its file name as text unless given; ``title``: what it holds)."""
    tip = f' title="{html.escape(title)}"' if title else ""
    return (f'<a href="{html.escape(href(target, report_dir))}"{tip}>'
            f"{html.escape(text or Path(target).name)}</a>")


def folder_links(folder: Path, report_dir: Path, files=FIT_FILES) -> str:
    """'fit.json · curve.csv · ...' for the files of ``files`` that exist in ``folder``."""
    found = [link(Path(folder) / name, report_dir, title=what) for name, what in files
             if (Path(folder) / name).exists()]
    return ('<p class="files">Files: ' + " \u00b7 ".join(found) + "</p>") if found else ""


def _cards(results: Path) -> list[Path]:
    """Solver cards, when a stage wrote them (results/**/cards/*)."""
    return sorted(p for p in Path(results).glob("**/cards/*") if p.is_file())


def files_section(results: Path, report_dir: Path, label) -> str:
    """Every take-away file that exists: the summary tables, each fit's and each hi-fi run's
    files, and solver cards; ``label(path)`` names a fit or run folder (its path below
    ``results``)."""
    results = Path(results)
    rows = [(link(results / rel, report_dir, rel), html.escape(what))
            for rel, what in SUMMARY_TABLES if (results / rel).exists()]
    rows += [(link(p, report_dir, p.relative_to(results).as_posix()), "solver card") for p in _cards(results)]
    for pattern, files in (("tensile/*/fit.json", FIT_FILES), ("rom/*/fit.json", FIT_FILES),
                           ("branch/*/fit.json", FIT_FILES), ("hifi/chain/*/fit.json", FIT_FILES),
                           ("hifi/virtual/*/summary.json", RUN_FILES),
                           ("hifi/crosscheck/*/summary.json", RUN_FILES),
                           ("branch/hifi/summary.json", RUN_FILES)):
        for p in sorted(results.glob(pattern)):
            folder = p.parent
            found = [link(folder / name, report_dir, title=what) for name, what in files
                     if (folder / name).exists()]
            rel = folder.relative_to(results).as_posix()
            rows.append((f"<code>{html.escape(rel)}/</code>",
                         html.escape(label(rel)) + ": " + " \u00b7 ".join(found)))
    if not rows:
        return ""
    body = "".join(f"<tr><td>{a}</td><td>{b}</td></tr>" for a, b in rows)
    return ("<p class='note'>Relative links into <code>results/</code>: keep the report in "
            "<code>results/report/</code> beside them. VTU/PVD files open in ParaView.</p>"
            f"<table class='files'><tr><th>file or folder</th><th>content</th></tr>{body}</table>")
