"""Wall time of the whole pipeline (``snakemake --cores 2``), job by job.

Stand-alone: ``.venv/bin/python bench/bench_pipeline.py --profile quick|default``.  Copies the
project (as a user's fresh checkout: no results, no Snakemake metadata) to a temporary
folder, runs ``snakemake --cores N --config profile=P`` there with this interpreter, and
reads every job's start and end from Snakemake's log.  The Numba cache is the user's (set
``HARNESSPIPE_NUMBA_CACHE`` to an empty folder for a cold compile; the source files are in a
new place either way, so Numba's index compiles them afresh).  Writes the total, the time
per rule and the hi-fi runs per stage under "## Pipeline (<profile>)" in bench/RESULTS.md (keeping the section's notes
by hand, "### By hand"), and the issue's goals measured on this run (:func:`goals`): each
virtual test's relative l2 error against its goal (met, at the goal within the run-to-run
spread, or missed), Table 3's E from the virtual tests against the paper's, and the wall
time against the profile's.
"""
from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

from benchlib import section_tail, write_section

REPO = Path(__file__).resolve().parents[1]
IGNORE = shutil.ignore_patterns("results", ".snakemake", ".venv", ".cache", "__pycache__", "*.egg-info",
                                "artifacts", ".git", ".pytest_cache")
TABLE3_TOLERANCE = 0.15                      # issue 27: Table 3's E within 15 % of the paper's
WALL_GOAL_MIN = {"quick": 10.0, "default": 45.0}   # issue 27: the pipeline's wall time
STAMP = re.compile(r"^\[(\w{3} \w{3} +\d+ \d\d:\d\d:\d\d \d{4})\]$")


def jobs_of(log: str) -> list[dict]:
    """(rule, wildcards, threads, start, end) of every finished job of a Snakemake log."""
    now, open_jobs, done, current = None, {}, [], None
    for line in log.splitlines():
        m = STAMP.match(line.strip())
        if m:
            now = dt.datetime.strptime(m.group(1), "%a %b %d %H:%M:%S %Y")
            continue
        m = re.match(r"(?:local)?rule (\w+):", line)
        if m:
            current = {"rule": m.group(1), "wildcards": "", "threads": 1, "start": now}
            continue
        m = re.match(r"\s+(jobid|wildcards|threads): (.*)", line)
        if m and current is not None:
            key, value = m.groups()
            if key == "jobid":
                open_jobs[value] = current
            else:
                current[key] = int(value) if key == "threads" else value
            continue
        m = re.match(r"Finished jobid: (\d+)", line)
        if m and m.group(1) in open_jobs:
            job = open_jobs.pop(m.group(1))
            done.append({**job, "end": now})
    return done


def hifi_runs(results: Path) -> list[str]:
    """One line per hi-fi stage (and the hi-fi branch run): runs made and their wall time."""
    lines = []
    for fit in sorted((results / "hifi" / "chain").glob("*/fit.json")):
        f = json.loads(fit.read_text())
        lines.append(f"- fit {f['item']}: {f['nfev']} evaluations, {f.get('hifi_runs_this_process', '?')} "
                     f"hi-fi runs, {f.get('hifi_wall_s', 0.0) / 60:.1f} min of runs "
                     f"({f.get('message', '')[:60]})")
    for summary in sorted((results / "hifi" / "virtual").glob("*/summary.json")):
        s = json.loads(summary.read_text())
        how = "the fit's run, reused" if s.get("reused_from") else f"{s['wall_s']:.0f} s, {s['steps']} steps"
        lines.append(f"- virtual test {s['case']}: {how}")
    branch = results / "branch" / "hifi" / "summary.json"
    if branch.exists():
        s = json.loads(branch.read_text())
        lines.append(f"- hi-fi Y harness ({s['load_case']}): {s['wall_s']:.0f} s, {s['steps']} steps, "
                     f"KE/IE {s['ke_ie_max']:.3g}")
    return lines


def goals(results: Path, profile: str, wall_min: float) -> list[str]:
    """The issue's goals measured on a finished run's results, as Markdown lines: the virtual
    tests' errors (the report's verdict, :func:`harnesspipe.report.verdict.hifi_fidelity`),
    Table 3's E (the ROM's, and eq. 13 over the test's linear part,
    :func:`harnesspipe.report.verdict.test_window_moduli`) and the wall time."""
    import pandas as pd

    from harnesspipe import config
    from harnesspipe.report import verdict
    from harnesspipe.report.html import _measured_by_case, judged
    cfg = config.load(results / "config.yaml")
    measured = _measured_by_case(sorted((results / "data").glob("bend_*.h5")))
    lines = ["Goals (issue 27) on this run:", "",
             "| virtual test | role | relative l2 error | goal | verdict |", "|---|---|---|---|---|"]
    for f in verdict.hifi_fidelity(results, cfg, measured):
        words = judged(f["error"], f["goal"], verdict.hifi_spread(cfg))[1]   # the report's words
        lines.append(f"| {f['case']} | {f['role']} | {100 * f['error']:.1f} % | {100 * f['goal']:.0f} % | {words} |")
    paper = cfg["paper"]["table3"]
    table3 = pd.read_csv(results / "rom" / "table3.csv").set_index("case")
    rows, within = [], 0
    for case in sorted(set(paper) & set(table3.index)):
        E, E_paper = float(table3.loc[case, "E"]), float(paper[case]["E"])
        window = verdict.test_window_moduli(case, results, measured, cfg)
        ok = abs(E / E_paper - 1.0) <= TABLE3_TOLERANCE
        within += ok
        rows.append(f"| {case} | {E:.1f} | {E_paper:g} | {100 * (E / E_paper - 1.0):+.0f} % | "
                    f"{'yes' if ok else 'no'} | "
                    + (f"{window['E_hifi']:.1f} / {window['E_test']:.1f} (0-{window['u_lin']:.1f} mm)" if window else "")
                    + " |")
    lines += ["", f"Table 3's E from the virtual tests (the ROM stage's, rom.reference "
              f"{cfg['rom']['reference']}): {within} of {len(rows)} within {100 * TABLE3_TOLERANCE:.0f} % "
              "of the paper's; beside it eq. 13 over the test's linear part, virtual test / test:", "",
              "| case | E [MPa] | paper | difference | within | over the test's linear part |",
              "|---|---|---|---|---|---|", *rows]
    goal = WALL_GOAL_MIN.get(profile)
    if goal is not None:
        lines += ["", f"Wall time {wall_min:.1f} min against the goal of {goal:g} min: "
                  + ("met." if wall_min <= goal else f"missed by {wall_min - goal:.1f} min.")]
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profile", default="quick")
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--keep", type=Path, default=None, help="run in this folder and keep it")
    args = parser.parse_args()
    root = args.keep or Path(tempfile.mkdtemp(prefix="bench_pipeline_"))
    project = root / "project"
    if project.exists():
        shutil.rmtree(project)
    shutil.copytree(REPO, project, ignore=IGNORE)
    env = {**os.environ, "PYTHONPATH": str(project / "src")}
    t0 = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "snakemake", "--cores", str(args.cores), "--config",
                          f"profile={args.profile}"], cwd=project, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    (root / "snakemake.log").write_text(run.stdout + run.stderr)
    if run.returncode != 0:
        sys.exit(f"snakemake failed (exit {run.returncode}); log in {root / 'snakemake.log'}")
    jobs = jobs_of(run.stdout + run.stderr)
    per_rule = defaultdict(lambda: [0, 0.0])
    for j in jobs:
        per_rule[j["rule"]][0] += 1
        per_rule[j["rule"]][1] += (j["end"] - j["start"]).total_seconds()
    start = min(j["start"] for j in jobs)
    rows = [f"| {j['rule']} | {j['wildcards']} | {j['threads']} | "
            f"{(j['start'] - start).total_seconds() / 60:.1f} | {(j['end'] - start).total_seconds() / 60:.1f} |"
            for j in sorted(jobs, key=lambda j: (j["start"], j["end"])) if (j["end"] - j["start"]).seconds >= 20]
    heading = f"## Pipeline ({args.profile})"
    text = "\n".join([
        heading,
        "",
        f"`bench/bench_pipeline.py --profile {args.profile}`, {dt.date.today()}, {platform.machine()}, "
        f"{args.cores} cores, fresh copy of the project (no results), Numba cache "
        f"{'from HARNESSPIPE_NUMBA_CACHE' if 'HARNESSPIPE_NUMBA_CACHE' in os.environ else 'of the user'}.",
        "",
        f"- total wall time of `snakemake --cores {args.cores} --config profile={args.profile}`: "
        f"**{wall / 60:.1f} min** ({len(jobs)} jobs)",
        "- busy time per rule (jobs, sum of job walls): "
        + "; ".join(f"{r} {n} / {s / 60:.1f} min" for r, (n, s) in sorted(per_rule.items(), key=lambda kv: -kv[1][1])
                    if s >= 1.0),
        *hifi_runs(project / "results"),
        "",
        *goals(project / "results", args.profile, wall / 60),
        "",
        "Jobs of 20 s or more (minutes from the first job's start):",
        "",
        "| rule | wildcards | threads | start | end |",
        "|---|---|---|---|---|",
        *rows,
    ])
    tail = section_tail(heading)            # the notes by hand, kept
    if tail:
        text += "\n\n" + tail
    write_section(heading, text)
    print(text)


if __name__ == "__main__":
    main()
