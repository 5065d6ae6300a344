"""The scripts in examples/ run and print what they claim, so they never rot."""
import re
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _run(name: str, *args: str) -> str:
    done = subprocess.run([sys.executable, str(EXAMPLES / name), *args], capture_output=True,
                          text=True, cwd=EXAMPLES.parent, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def _numbers(line: str) -> list[float]:
    return [float(v) for v in re.findall(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?", line)]


def test_rom_example_matches_the_small_deflection_stiffness():
    out = _run("rom_three_point.py")
    numbers = _numbers(out.splitlines()[-1])
    slope, theory = numbers[0], numbers[-1]
    assert slope == pytest.approx(theory, rel=0.01)                 # 48 E I / L^3
    forces = [_numbers(line)[-1] for line in out.splitlines()[:4]]
    assert forces == sorted(forces) and forces[-1] > 5.0            # loads up to 30 mm


def test_cantilever_example_matches_the_elastica():
    dv, dv_ref, dh, dh_ref = _numbers(_run("cantilever_elastica.py"))
    assert dv == pytest.approx(dv_ref, rel=2e-3) and dh == pytest.approx(dh_ref, rel=5e-3)


def test_tensile_example_recovers_table_2(tmp_path):
    out = _run("tensile_fit.py", str(tmp_path))
    numbers = _numbers(out.splitlines()[0])          # "E: 691 (Table 2: 698)"
    E, E_paper = numbers[0], numbers[-1]
    assert E == pytest.approx(E_paper, rel=0.05)
    assert (tmp_path / "open_tube" / "fit.json").exists()


@pytest.mark.slow
def test_hifi_example_runs_a_quasi_static_virtual_test():
    """The example's run loads up and is quasi-static by the paper's measure (KE/IE below
    Sec. 4.1's 2 %, ``explicit.ke_ie_max``) with its energy balance closed
    (``explicit.energy_fail``), as its last line prints them."""
    from harnesspipe.config import load
    limits = load()["explicit"]
    out = _run("hifi_quick.py", "12")
    *rows, last = out.splitlines()
    forces = [_numbers(r)[-1] for r in rows]
    assert len(forces) == 4 and all(f > 0.0 for f in forces) and forces == sorted(forces)
    ke_ie = float(re.search(r"KE/IE (\S+),", last).group(1))
    energy_error = float(re.search(r"energy error (\S+)$", last).group(1))
    assert 0.0 < ke_ie < limits["ke_ie_max"] and 0.0 <= energy_error < limits["energy_fail"]
