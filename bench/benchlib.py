"""Helpers shared by the benchmark scripts: fresh-process JIT timing and RESULTS.md sections."""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "RESULTS.md"


def fresh_process_seconds(script: str, cache: str) -> list[float]:
    """Run ``script`` in a new interpreter with the Numba cache at ``cache`` (one thread);
    return the numbers it prints on its last line (its own timings of the first calls)."""
    env = {**os.environ, "HARNESSPIPE_NUMBA_CACHE": cache, "NUMBA_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", script], env=env, check=True,
                         capture_output=True, text=True)
    return [float(v) for v in out.stdout.strip().splitlines()[-1].split()]


def jit_seconds(script: str) -> tuple[list[float], list[float]]:
    """(first calls with an empty Numba cache, first calls loading from that cache)."""
    with tempfile.TemporaryDirectory() as cache:
        cold = fresh_process_seconds(script, cache)
        return cold, fresh_process_seconds(script, cache)


BY_HAND = "### By hand"   # sub-heading of a section's notes that a rerun of its bench keeps


def section_tail(heading: str) -> str:
    """The section ``heading`` of RESULTS.md from its BY_HAND sub-heading on ('' if none):
    the notes written by hand, which a bench rewriting the section keeps."""
    old = RESULTS.read_text() if RESULTS.exists() else ""
    start = old.find(heading + "\n")
    if start < 0:
        return ""
    nxt = old.find("\n## ", start + len(heading))
    section = old[start:nxt] if nxt >= 0 else old[start:]
    mark = section.find(BY_HAND)
    return section[mark:].rstrip() if mark >= 0 else ""


def write_section(heading: str, text: str) -> None:
    """Replace the section ``heading`` of RESULTS.md in place (append it if new)."""
    old = RESULTS.read_text() if RESULTS.exists() else "# Benchmark results\n"
    start = old.find(heading + "\n")
    if start < 0:
        RESULTS.write_text(old.rstrip() + "\n\n" + text.rstrip() + "\n")
        return
    nxt = old.find("\n## ", start + len(heading))
    tail = old[nxt:] if nxt >= 0 else "\n"
    RESULTS.write_text(old[:start] + text.rstrip() + "\n" + tail)


def hifi_run(case: str, profile: str, sets: dict, table2=None):
    """One hi-fi three-point run of ``case`` at ``profile`` with the ``--set`` values ``sets``
    (strings) and, when given, a tensile stage's ``table2`` csv: on one Numba thread, as the
    pipeline's virtual tests run, with one stored shape.  For a process pool's worker."""
    os.environ["NUMBA_NUM_THREADS"] = "1"
    from harnesspipe.config import load
    from harnesspipe.models.hifi import three_point
    from harnesspipe.stages.hifi import inputs
    cfg = load(overrides={"profile": profile})
    return three_point(inputs(cfg, case, sets, table2=None if table2 is None else Path(table2)),
                       n_shapes=1)
