"""The demo campaign end to end (quick profile) in a temporary copy of the project: the property
library, the campaign page, the solver cards, the reruns (none for an unchanged catalogue, one construction for an
added entry) and a construction whose run fails (recorded, the others untouched)."""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
import yaml

from conftest import copy_project, job_stats

pytestmark = pytest.mark.pipeline

DEMO = "config/campaigns/demo.yaml"


def snakemake(project: Path, *args: str, catalogue: str = DEMO) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(project / "src")}  # the copy's package, not the repo's
    return subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", "campaign", "--config",
                           f"campaign={catalogue}", "profile=quick", *args], cwd=project, env=env,
                          capture_output=True, text=True)


@pytest.fixture(scope="module")
def project(tmp_path_factory) -> Path:
    project = copy_project(tmp_path_factory.mktemp("campaign") / "project")
    run = snakemake(project)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-6000:]
    return project


def _library(project: Path) -> pd.DataFrame:
    return pd.read_csv(project / "results" / "campaign" / "demo" / "properties.csv")


def test_property_library(project):
    lib = _library(project)
    names = list(yaml.safe_load((project / DEMO).read_text())["constructions"])
    assert list(lib["case"]) == names and (lib["status"] == "ok").all(), lib.to_string()
    assert (lib[["E", "sigma_y", "K", "n", "r_o"]] > 0).all().all()
    assert (lib["n"] <= 1.0).all()
    EI = lib["E"] * math.pi * lib["r_o"] ** 4 / 4.0
    assert ((lib["EI"] - EI).abs() <= 1e-6 * EI).all()
    kappa = lib["sigma_y"] / (lib["E"] * lib["r_o"])
    assert ((lib["kappa_y"] - kappa).abs() <= 1e-6 * kappa).all()
    assert (lib["ke_ie"] < 0.1).all() and (lib["energy_error"] < 0.01).all()   # config explicit limits
    # every bundle is stiffer in bending than its loose wires, each bending on its own (DESIGN sec. 3)
    materials = yaml.safe_load((project / "config" / "config.yaml").read_text())["materials"]
    for row in lib.to_dict("records"):
        loose = sum(int(count) * materials[w]["E"] * math.pi * (materials[w]["d_outer"] / 2) ** 4 / 4
                    for w, count in (item.split(":") for item in row["wires"].split()))
        assert row["EI"] > loose, row


def test_solver_cards_of_every_construction(project):
    """The library carded in the three formats (harnesspipe cards): the eq. 2 law and the
    section radius of each row in its CalculiX deck, one LS-DYNA file per construction."""
    cards = project / "results" / "campaign" / "demo" / "cards"
    for rec in _library(project).to_dict("records"):
        for fmt in ("calculix", "abaqus"):
            deck = (cards / fmt / rec["case"] / "material.inp").read_text()
            assert "*PLASTIC" in deck and f"E {rec['E']:g} MPa" in deck
            assert f"r_o {rec['r_o']:g} mm" in deck and f"rho {rec['rho']:.6g} t/mm^3" in deck
        assert (cards / "lsdyna" / rec["case"] / "material.k").is_file()


def test_campaign_page_is_offline_with_every_construction(project):
    html = (project / "results" / "campaign" / "demo" / "index.html").read_text()
    for name in _library(project)["case"]:
        assert name in html
    assert html.count("data:image/png;base64,") == 2 + 3      # EI, kappa_y; one curve per construction
    assert "http://" not in html and "https://" not in html
    # a fresh copy has no calibrated interface (results/hifi/interface.csv): the paper's values
    assert "Interface of the virtual tests: paper (Sec. 4.2" in html


def test_unchanged_catalogue_reruns_nothing(project):
    assert job_stats(snakemake(project, "--dry-run")) == {}


def test_added_unstable_entry_runs_alone_and_fails_cleanly(project):
    """An added construction runs that construction only; loaded 20x too fast it is not
    quasi-static (KE/IE above explicit.ke_ie_fail): a failed row with the diagnostics, no
    numbers, and the other rows as they were."""
    before = _library(project)
    catalogue = yaml.safe_load((project / DEMO).read_text())
    catalogue["constructions"]["w7_too_fast"] = {
        "wires": {"wire_type2": 7}, "covering": "closed", "loading_time_scale": 0.05}
    (project / DEMO).write_text(yaml.safe_dump(catalogue, sort_keys=False))
    planned = job_stats(snakemake(project, "--dry-run"))
    assert planned == {"campaign_hifi": 1, "campaign_rom": 1, "campaign_library": 1,
                       "campaign_page": 1, "campaign_cards": 3, "campaign": 1}
    run = snakemake(project)
    assert run.returncode == 0, run.stderr[-4000:]
    after = _library(project)
    pd.testing.assert_frame_equal(after.iloc[:3], before)
    failed = after.set_index("case").loc["w7_too_fast"]
    assert failed["status"] == "failed" and "KE/IE" in failed["message"]
    assert failed[["E", "sigma_y", "K", "n", "EI", "kappa_y"]].isna().all()
    diagnostics = yaml.safe_load((project / "results" / "campaign" / "demo" / "w7_too_fast"
                                  / "property.json").read_text())["diagnostics"]
    assert diagnostics["reason"].startswith("max KE/IE") and diagnostics["step"] > 0
    assert "w7_too_fast" in (project / "results" / "campaign" / "demo" / "index.html").read_text()
    assert not (project / "results" / "campaign" / "demo" / "cards" / "calculix" / "w7_too_fast").exists()


def test_bad_entry_stops_snakemake_naming_it(project):
    bad = project / "config" / "campaigns" / "bad.yaml"
    bad.write_text(yaml.safe_dump({"constructions": {"w7_x": {"wires": {"wire_type2": 7},
                                                              "covering": "closed", "taping": "spiral"}}}))
    run = snakemake(project, "--dry-run", catalogue="config/campaigns/bad.yaml")
    assert run.returncode != 0
    assert "construction w7_x: taping: 'spiral': expected one of" in run.stdout + run.stderr
