"""The workflow's catalogue (stages/targets.py): final targets, stage fits and report inputs.

Checked on the shipped config and data for both profiles, against what a Snakemake dry run of a
copy of the project requests, also with the stage rule files included in reverse order.
"""
from __future__ import annotations

import copy
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from conftest import REPO, copy_project
from harnesspipe import config as hp_config
from harnesspipe.stages import targets

RES = "results"
STAGES = ["tensile", "rom", "branch", "hifi"]
STAGE_INCLUDES = [f'include: "workflow/rules/{s}.smk"' for s in STAGES]


def load(profile: str, **overrides) -> dict:
    return hp_config.load(overrides={"profile": profile, **overrides})


@pytest.fixture(scope="module")
def tests() -> dict:
    """The tests of the shipped manifest, as workflow/rules/common.smk reads them."""
    cfg = hp_config.load()
    return yaml.safe_load((REPO / cfg["data_dir"] / "manifest.yaml").read_text())["tests"]


@pytest.mark.parametrize("profile", ["default", "quick"])
def test_targets_hold_every_stage_table_and_end_with_the_report(profile, tests):
    final = targets.final_targets(load(profile), tests, RES)
    assert final[:3] == [f"{RES}/tensile/table2.csv", f"{RES}/rom/table3.csv", f"{RES}/branch/damping.csv"]
    assert f"{RES}/hifi/interface.csv" in final           # hifi.pipeline.in_all: [chain]
    assert f"{RES}/hifi/crosscheck/table3.csv" not in final
    assert final[-1] == f"{RES}/report/index.html"
    assert len(final) == len(set(final))


@pytest.mark.parametrize("profile", ["default", "quick"])
def test_report_lists_a_fit_of_every_stage(profile, tests):
    cfg = load(profile)
    fits = targets.stage_fits(cfg, tests, RES)
    assert list(fits) == STAGES and all(fits.values())
    coverings = ("closed_tube", "fabric_tube", "open_tube")
    assert fits["tensile"] == [f"{RES}/tensile/{c}/fit.json" for c in coverings]
    assert len(fits["rom"]) == 6 and fits["branch"][0] == f"{RES}/branch/inplane/fit.json"
    assert fits["hifi"] == targets.chain_targets(cfg, RES)
    args = targets.report_fit_args(fits)
    assert [a.split("=")[0] for a in args] == [s for s in STAGES for _ in fits[s]]


def test_hifi_y_harness_in_the_default_profile_only(tests):
    summary = f"{RES}/branch/hifi/summary.json"
    for profile, expected in (("default", [summary]), ("quick", [])):
        cfg = load(profile)
        assert targets.report_extra(cfg, tests, RES) == targets.summary_tables(cfg, tests, RES) + expected
        assert (summary in targets.final_targets(cfg, tests, RES)) == bool(expected)


def test_branch_targets_need_both_pull_tests(tests):
    """Without the out-of-plane test: no branch stage, so no damping, fits or Y harness either."""
    cfg = load("default")
    no_validation = {t: e for t, e in tests.items() if e.get("load_case") != "outofplane"}
    assert "branch" not in targets.stage_fits(cfg, no_validation, RES)
    assert targets.report_extra(cfg, no_validation, RES) == [f"{RES}/tensile/table2.csv", f"{RES}/rom/table3.csv"]
    final = targets.final_targets(cfg, no_validation, RES)
    assert not any(p.startswith(f"{RES}/branch/") for p in final)


@pytest.mark.parametrize("in_all, groups", [
    ([], []), (["chain"], ["chain"]), (["crosscheck"], ["crosscheck"]),
    (["chain", "crosscheck"], ["crosscheck", "chain"]),      # crosscheck first, whatever the order
])
def test_hifi_groups_follow_in_all(in_all, groups, tests):
    cfg = load("quick", hifi={"pipeline": {"in_all": in_all}})
    by_name = {"crosscheck": targets.crosscheck_targets, "chain": targets.chain_targets}
    expected = [p for g in groups for p in by_name[g](cfg, RES)]
    assert targets.stage_fits(cfg, tests, RES).get("hifi", []) == expected
    final = targets.final_targets(cfg, tests, RES)
    assert final[3:-1] == expected                           # quick: no Y harness


def test_functions_are_pure(tests):
    """Neither argument changes and the order of the calls does not matter."""
    cfg = load("default")
    cfg0, tests0 = copy.deepcopy(cfg), copy.deepcopy(tests)
    calls = [targets.final_targets, targets.stage_fits, targets.report_extra]
    first = [f(cfg, tests, RES) for f in calls]
    assert [f(cfg, tests, RES) for f in reversed(calls)] == first[::-1]
    assert cfg == cfg0 and tests == tests0


def dry_run(project: Path, profile: str) -> str:
    """Printed jobs and shell commands of ``snakemake -n -p`` in ``project``."""
    env = {**os.environ, "PYTHONPATH": str(project / "src")}
    run = subprocess.run([sys.executable, "-m", "snakemake", "-n", "-p", "--config", f"profile={profile}"],
                         cwd=project, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    return run.stdout + run.stderr


def requested(text: str) -> tuple[list[str], list[str]]:
    """The inputs of rule ``all`` and the report's ``--fits`` arguments of a dry run."""
    all_inputs = re.search(r"^(?:local)?rule all:\n\s+input: (.*)$", text, re.M).group(1).split(", ")
    fits = re.search(r"-m harnesspipe report .*--fits (.*) --out ", text).group(1).split()
    return all_inputs, fits


@pytest.fixture(scope="module")
def projects(tmp_path_factory) -> dict[str, Path]:
    """Copies of the project: as it is, and with the stage rule files included in reverse order."""
    base = copy_project(tmp_path_factory.mktemp("targets") / "project")
    reversed_ = copy_project(tmp_path_factory.mktemp("targets") / "reversed")
    snakefile = reversed_ / "Snakefile"
    text = snakefile.read_text()
    assert "\n".join(STAGE_INCLUDES) in text
    snakefile.write_text(text.replace("\n".join(STAGE_INCLUDES), "\n".join(reversed(STAGE_INCLUDES))))
    return {"as is": base, "reversed": reversed_}


@pytest.mark.parametrize("profile, layout",
                         [("default", "as is"), ("quick", "as is"), ("default", "reversed")])
def test_dry_run_requests_the_catalogue(profile, layout, projects, tests):
    cfg = load(profile)
    all_inputs, fits = requested(dry_run(projects[layout], profile))
    assert all_inputs == targets.final_targets(cfg, tests, RES)
    assert fits == targets.report_fit_args(targets.stage_fits(cfg, tests, RES))
