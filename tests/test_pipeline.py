"""The pipeline end to end (quick profile, the hi-fi chain included) in a temporary copy of the project.

Also: reruns follow inputs and code exactly, and the report renders in Chromium.  Every call
adds the overlay tests/pipeline_smoke.yaml: a coarser hi-fi mesh and chain fits on the first
9 mm (their runs stop at 10), so that the whole pipeline runs in CI's time; the quick
profile's own figures are bench/bench_pipeline.py's.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from conftest import ARTIFACTS, copy_project, job_stats

pytestmark = pytest.mark.pipeline

SMOKE = Path("tests") / "pipeline_smoke.yaml"


def snakemake(project: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(project / "src")}  # the copy's package, not the repo's
    return subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", "--config", "profile=quick",
                           "--configfile", str(project / SMOKE), *args],
                          cwd=project, env=env, capture_output=True, text=True)


def planned_jobs(project: Path) -> dict[str, int]:
    """Rule -> job count of a dry run ({} when nothing is to be done)."""
    return job_stats(snakemake(project, "--dry-run"))


@pytest.fixture(scope="module")
def project(tmp_path_factory) -> Path:
    project = copy_project(tmp_path_factory.mktemp("pipeline") / "project")
    run = snakemake(project)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-6000:]
    return project


def test_outputs_of_every_stage(project):
    res = project / "results"
    assert (res / "data" / "check.txt").read_text().startswith("data/experimental: OK: 11 tests")
    table2 = pd.read_csv(res / "tensile" / "table2.csv")
    assert list(table2.columns) == ["component", "E", "sigma_y", "K", "n"]
    assert sorted(table2["component"]) == ["closed_tube", "fabric_tube", "open_tube"]
    table3 = pd.read_csv(res / "rom" / "table3.csv")
    assert list(table3.columns) == ["case", "E", "sigma_y", "K", "n", "reference"]
    assert len(table3) == 6 and (table3[["E", "sigma_y", "K", "n"]] > 0).all().all()
    assert set(table3["reference"]) == {"hifi"}           # Sec. 4.3: the ROM of the virtual tests
    interface = pd.read_csv(res / "hifi" / "interface.csv")
    assert list(interface["parameter"]) == ["mu_rtb", "mu_rtp", "delta0", "delta_f", "alpha_d", "E2_over_E1",
                                            "end_tape_binds", "end_tape_layers", "tape_tension",
                                            "tube_closure", "fabric_end_tape_binds",
                                            "fabric_end_tape_layers"]  # the build state last
    assert sorted(p.name for p in (res / "hifi" / "virtual").iterdir()) == sorted(
        ["cwb19_t2_closed", "cwb19_t2_open_halflap", "cwb19_t2_open_coarse", "cwb19_t1_open_coarse",
         "cwb19_t2_fabric", "cwb10t1_9t2_fabric", "cwb38_t2_open_coarse", "twb19_t2", "twb38_t2"])
    damping = pd.read_csv(res / "branch" / "damping.csv")
    assert list(damping.columns) == ["parameter", "value"] and list(damping["parameter"]) == ["alpha"]
    html = (res / "report" / "index.html").read_text()
    for heading in ("Test data", "Component tensile fits", "Reduced-order beam properties",
                    "Branching harness", "High-fidelity model"):
        assert heading in html
    assert (res / "rom" / "cwb19_t2_closed" / "shapes.pvd").exists()
    assert "http://" not in html and "https://" not in html  # nothing to fetch: opens offline
    assert html.index("id='verdict'") < html.index("id='limitations'") < html.index("id='data'")
    ids = set(re.findall(r"id='([^']+)'", html))
    assert set(re.findall(r"href='#([^']+)'", html)) <= ids            # the contents' anchors exist
    links = re.findall(r'href="([^"#][^"]*)"', html)
    assert {"../rom/table3.csv", "../hifi/interface.csv", "../rom/cwb19_t2_closed/shapes.pvd"} <= set(links)
    assert all((res / "report" / link).is_file() for link in links)    # every result link resolves


def test_snakemake_report_collects_the_figures(project):
    out = project / "results" / "snakemake_report.html"
    run = snakemake(project, "--report", str(out))
    assert run.returncode == 0, run.stderr[-3000:]
    assert out.stat().st_size > 100_000 and "fit.png" in run.stdout + run.stderr


def test_untouched_tree_reruns_nothing(project):
    assert planned_jobs(project) == {}


def test_code_change_reruns_only_its_users(project):
    html_py = project / "src" / "harnesspipe" / "report" / "html.py"
    html_py.write_text(html_py.read_text() + "\n# a comment changes the code version\n")
    assert planned_jobs(project) == {"report": 1, "all": 1}
    assert snakemake(project).returncode == 0
    assert planned_jobs(project) == {}


def test_one_changed_csv_reruns_only_its_dependants(project):
    """A validation case's test: its virtual test (which reports the error against it) and the
    ROM fitted to that virtual test rerun; no fit of the chain does."""
    csv = project / "data" / "experimental" / "three_point" / "bend_cwb19_t1_open_coarse_s2.csv"
    lines = csv.read_text().splitlines()
    t, u, f = lines[50].split(",")
    lines[50] = f"{t},{u},{float(f) * 1.01:.6g}"
    csv.write_text("\n".join(lines) + "\n")
    assert planned_jobs(project) == {"check_data": 1, "prepare_test": 1, "hifi_virtual": 1, "rom_fit": 1,
                                     "table3": 1, "report": 1, "all": 1}


@pytest.mark.browser
def test_report_renders_in_chromium(project, in_ci):
    chromium = shutil.which("chromium")
    if chromium is None:
        if in_ci:
            pytest.fail("chromium is not installed; .ci/run installs the Debian package")
        pytest.skip("chromium not installed (apt-get install chromium); CI runs this test")
    from playwright.sync_api import sync_playwright
    page_path = project / "results" / "report" / "index.html"
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    errors, requests = [], []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=[
            "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-quic"])
        page = browser.new_page(viewport={"width": 1200, "height": 900})
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.on("request", lambda r: requests.append(r.url))
        page.goto(page_path.as_uri())
        page.wait_for_load_state("load")
        images = page.evaluate("Array.from(document.images).map(i => [i.alt, i.complete && i.naturalWidth > 0])")
        page.screenshot(path=str(ARTIFACTS / "report.png"), full_page=True)
        browser.close()
    assert errors == []
    assert len(images) >= 12 and [alt for alt, ok in images if not ok] == []
    assert all(url.startswith(("file:", "data:")) for url in requests)
