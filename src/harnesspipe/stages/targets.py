"""What the workflow builds: its final targets, the fits of every stage and the report's inputs.

Snakemake's catalogue pattern: :func:`final_targets` (rule ``all``), :func:`stage_fits` and
:func:`report_extra` (rule ``report``) each build their list in one place, from the config, the
tests of the data manifest (``tests`` of ``<data_dir>/manifest.yaml``, as workflow/rules/common.smk
reads them) and the results folder ``res``.  No rule file adds to them, so they do not depend on
the order in which the Snakefile includes the rule files.  The rule files take the lists their
rules need (components, cases, load cases, target groups) from the functions below as well.
"""
from __future__ import annotations

from harnesspipe.stages import chain_settings as CHAIN

BRANCH_RUNS = ("inplane", "elastic", "outofplane")   # calibration, elastic joint, validation (Sec. 5)
BRANCH_LOAD_CASES = {"inplane", "outofplane"}         # the pull tests the branch stage needs


def tensile_components(tests: dict) -> list[str]:
    """The coverings with a tensile test (stage 2, Table 2)."""
    return sorted(e["item"] for e in tests.values() if e.get("kind") == "tensile")


def tensile_fits(tests: dict, res: str) -> list[str]:
    """fit.json of every tensile fit: the inputs of Table 2."""
    return [f"{res}/tensile/{c}/fit.json" for c in tensile_components(tests)]


def rom_cases(config: dict, tests: dict) -> list[str]:
    """The config's cases with a three-point test (stage 7, Table 3)."""
    return sorted(e["item"] for e in tests.values()
                  if e.get("kind") == "three_point" and e.get("item") in config["cases"])


def rom_fits(config: dict, tests: dict, res: str) -> list[str]:
    """fit.json of every ROM fit: the inputs of Table 3."""
    return [f"{res}/rom/{c}/fit.json" for c in rom_cases(config, tests)]


def branch_tests(tests: dict) -> dict:
    """Load case -> test id of the branch pull tests (stage 8)."""
    return {e.get("load_case"): t for t, e in tests.items() if e.get("kind") == "branch"}


def has_branch(tests: dict) -> bool:
    """Both pull tests exist, so the branch stage (calibration and validation) runs."""
    return BRANCH_LOAD_CASES <= set(branch_tests(tests))


def branch_fits(res: str) -> list[str]:
    """fit.json of the branch stage's runs."""
    return [f"{res}/branch/{run}/fit.json" for run in BRANCH_RUNS]


def branch_property_fits(config: dict, res: str) -> dict:
    """Case -> the hi-fi ROM fit.json a branch beam takes its properties from, with
    ``branch.properties_source: hifi`` (else none: the config's estimates)."""
    if config["branch"]["properties_source"] != "hifi":
        return {}
    return {c: f"{res}/hifi/virtual/{c}/rom/fit.json" for c in sorted(config["branch"]["properties"])}


def branch_hifi_targets(config: dict, tests: dict, res: str) -> list[str]:
    """The hi-fi Y harness's summary when it is in ``all``: the profile is in
    ``branch.hifi.in_all`` and the branch stage runs (else none)."""
    if config["profile"] in config["branch"]["hifi"]["in_all"] and has_branch(tests):
        return [f"{res}/branch/hifi/summary.json"]
    return []


def crosscheck_cases(config: dict) -> list[str]:
    """The cases of the hi-fi cross-check: the paper's Table 3 cases among the config's."""
    return sorted(c for c in config["paper"]["table3"] if c in config["cases"])


def crosscheck_targets(config: dict, res: str) -> list[str]:
    """Target group ``crosscheck`` (rule hifi_crosscheck_all): Table 3 from hi-fi runs at the
    paper's values and every run's summary."""
    return [f"{res}/hifi/crosscheck/table3.csv"] + [
        f"{res}/hifi/crosscheck/{c}/summary.json" for c in crosscheck_cases(config)]


def chain_targets(config: dict, res: str) -> list[str]:
    """Target group ``chain`` (rule hifi_chain_all): the calibrated interface and the virtual
    test of every hi-fi case."""
    return [f"{res}/hifi/interface.csv"] + [
        f"{res}/hifi/virtual/{c}/summary.json" for c in sorted(CHAIN.cases(config))]


def hifi_targets(config: dict, res: str) -> list[str]:
    """The hi-fi target groups ``hifi.pipeline.in_all`` names, crosscheck before chain."""
    in_all = config["hifi"]["pipeline"]["in_all"]
    groups = {"crosscheck": crosscheck_targets, "chain": chain_targets}
    return [p for name, group in groups.items() if name in in_all for p in group(config, res)]


def stage_fits(config: dict, tests: dict, res: str) -> dict[str, list[str]]:
    """Stage -> the results the report lists for it (``--fits stage=path``), for every stage in
    the workflow, in the order tensile, rom, branch, hifi.  They are the report's inputs, so the
    report is built after them (the hi-fi groups included)."""
    fits = {"tensile": tensile_fits(tests, res), "rom": rom_fits(config, tests, res),
            "branch": branch_fits(res) if has_branch(tests) else [],
            "hifi": hifi_targets(config, res)}
    return {stage: paths for stage, paths in fits.items() if paths}


def report_fit_args(fits: dict[str, list[str]]) -> list[str]:
    """``stage=path`` arguments of the report for :func:`stage_fits`."""
    return [f"{stage}={path}" for stage, paths in fits.items() for path in paths]


def summary_tables(config: dict, tests: dict, res: str) -> list[str]:
    """The summary tables of the stages that run (DESIGN sec. 5)."""
    tables = [(bool(tensile_components(tests)), f"{res}/tensile/table2.csv"),
              (bool(rom_cases(config, tests)), f"{res}/rom/table3.csv"),
              (has_branch(tests), f"{res}/branch/damping.csv")]
    return [path for included, path in tables if included]


def report_extra(config: dict, tests: dict, res: str) -> list[str]:
    """Further results the report shows or links: the summary tables and the hi-fi Y harness
    when it is in ``all``."""
    return summary_tables(config, tests, res) + branch_hifi_targets(config, tests, res)


def final_targets(config: dict, tests: dict, res: str) -> list[str]:
    """The inputs of rule ``all``: every stage's summary table, the hi-fi Y harness and the
    hi-fi groups when this profile includes them, and the report."""
    return (summary_tables(config, tests, res) + branch_hifi_targets(config, tests, res)
            + hifi_targets(config, res) + [f"{res}/report/index.html"])
