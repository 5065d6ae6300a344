"""Throughput of a virtual test campaign: constructions per hour on N cores.

Stand-alone: ``.venv/bin/python bench/bench_campaign.py --profile quick|default
[--catalogue config/campaigns/demo.yaml] [--cores 2]``.  Copies the project (no results) to a
temporary folder, runs ``snakemake --cores N campaign --config campaign=CATALOGUE profile=P``
there and reads every job's start and end from Snakemake's log.  Two figures:

- end to end: constructions / the campaign's wall time (Numba warm-ups included: the
  cache is the user's, ``HARNESSPIPE_NUMBA_CACHE``; a warm cache only loads);
- steady state: N cores x 3600 s / the mean busy time of one construction (its hi-fi
  virtual test + its eq. 13 + simplex job): what a long campaign approaches, every core busy.

Writes them under "## Campaign throughput (<profile>)" in bench/RESULTS.md, with the machine's
load average (the machine may be shared: the figures are only as quiet as it was), keeping
the section's notes by hand.
"""
from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
from bench_pipeline import IGNORE, REPO, jobs_of
from benchlib import section_tail, write_section

PER_CONSTRUCTION = ("campaign_hifi", "campaign_rom")


def run_campaign(project: Path, catalogue: str, profile: str, cores: int) -> tuple[float, str]:
    env = {**os.environ, "PYTHONPATH": str(project / "src")}
    t0 = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "snakemake", "--cores", str(cores), "campaign", "--config",
                          f"campaign={catalogue}", f"profile={profile}"], cwd=project, env=env,
                         capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if run.returncode != 0:
        sys.exit(f"snakemake failed (exit {run.returncode}):\n{run.stderr[-3000:]}")
    return wall, run.stdout + run.stderr


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profile", default="quick")
    parser.add_argument("--catalogue", default="config/campaigns/demo.yaml")
    parser.add_argument("--cores", type=int, default=2)
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench_campaign_"))
    project = root / "project"
    shutil.copytree(REPO, project, ignore=IGNORE)
    load_before = os.getloadavg()[1]
    wall, log = run_campaign(project, args.catalogue, args.profile, args.cores)
    load_after = os.getloadavg()[1]
    jobs = jobs_of(log)
    busy: dict[str, float] = {}
    for j in jobs:
        if j["rule"] in PER_CONSTRUCTION:
            name = j["wildcards"].split("=", 1)[1]
            busy[name] = busy.get(name, 0.0) + (j["end"] - j["start"]).total_seconds()
    lib = pd.read_csv(project / "results" / "campaign" / Path(args.catalogue).stem / "properties.csv")
    n = len(lib)
    mean_busy = sum(busy.values()) / max(len(busy), 1)
    heading = f"## Campaign throughput ({args.profile})"
    rows = [f"| {r['case']} | {r['status']} | {r['hifi_wall_s']:.0f} | {r['rom_wall_s']:.0f} | "
            f"{busy.get(r['case'], float('nan')):.0f} |" for r in lib.to_dict("records")]
    text = "\n".join([
        heading, "",
        f"`bench/bench_campaign.py --profile {args.profile} --catalogue {args.catalogue}`, {dt.date.today()}, "
        f"{platform.machine()}, {args.cores} cores, fresh copy of the project (no results), Numba cache "
        f"{'from HARNESSPIPE_NUMBA_CACHE' if 'HARNESSPIPE_NUMBA_CACHE' in os.environ else 'of the user'}; "
        f"5-min load average {load_before:.1f} before, {load_after:.1f} after (2 = both cores busy).", "",
        f"- end to end: {n} constructions in **{wall / 60:.1f} min** "
        f"(`snakemake --cores {args.cores} campaign`, warm-ups included): "
        f"**{n * 3600.0 / wall:.0f} constructions per hour**",
        f"- steady state: {mean_busy:.0f} s of one core per construction (hi-fi virtual test + eq. 13 + "
        f"simplex jobs): **{args.cores * 3600.0 / mean_busy:.0f} constructions per hour** on {args.cores} cores",
        "", "| construction | status | hi-fi run [s] | ROM fit [s] | jobs' busy time [s] |", "|---|---|---|---|---|",
        *rows,
    ])
    tail = section_tail(heading)
    if tail:
        text += "\n\n" + tail
    write_section(heading, text)
    print(text)
    shutil.rmtree(root)


if __name__ == "__main__":
    main()
