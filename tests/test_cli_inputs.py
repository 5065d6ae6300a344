"""Bad physical inputs on the command line (issue 30): each exits 2 with one line naming the
option, key or file and what was expected, before any simulation starts; the interface a
hi-fi run uses is chosen (--interface) and said; Ctrl-C ends with one line and exit 130."""
import io
import subprocess
import sys

import pytest
import yaml

from harnesspipe import cli, validate
from harnesspipe.config import SCHEMA_PATH, load
from harnesspipe.progress import Progress
from harnesspipe.stages.hifi import interface_choice, parameters


def _run(*args, cwd=None):
    """The console command in a fresh interpreter: exit code, stdout, stderr."""
    r = subprocess.run([sys.executable, "-m", "harnesspipe", *map(str, args)],
                       capture_output=True, text=True, cwd=cwd)
    return r.returncode, r.stdout, r.stderr


def _hifi(tmp_path, *args):
    return _run("hifi", "three-point", "--case", "cwb19_t2_closed", "--profile", "quick",
                "--out", tmp_path / "curve.csv", *args, cwd=tmp_path)


def _one_error_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    return lines[0]


@pytest.mark.parametrize("setting, message", [
    ("mu_rtb=-0.5", "--set mu_rtb=-0.5: expected a friction coefficient in [0, 2]"),
    ("closed_tube.E=-1559", "--set closed_tube.E=-1559: expected a modulus [MPa] > 0"),
    ("wire_elements=0", "--set wire_elements=0: expected a mesh count, a whole number >= 4"),
    ("delta_f=0.02", "--set delta_f=0.02: expected a failure separation > delta0 (0.03)"),
])
def test_hifi_set_out_of_range_exits_2(tmp_path, setting, message):
    code, out, err = _hifi(tmp_path, "--interface", "paper", "--set", setting)
    assert code == 2
    assert _one_error_line(err) == f"harnesspipe: error: {message}"
    assert out == "" and not (tmp_path / "curve.csv").exists()


def test_hifi_negative_modulus_in_coverings_exits_2(tmp_path):
    table2 = tmp_path / "table2.csv"
    table2.write_text("component,E,sigma_y,K,n\nclosed_tube,1559,8.6,25.6,0.12\n"
                      "open_tube,-698,8.8,23.1,0.83\n")
    code, _, err = _hifi(tmp_path, "--coverings", table2)
    assert code == 2
    assert _one_error_line(err) == (f"harnesspipe: error: {table2}: line 3: open_tube.E=-698: "
                                    "expected a modulus [MPa] > 0")


def test_rom_deflection_beyond_half_the_span_exits_2(tmp_path):
    code, _, err = _run("rom", "three-point", "--E", 15.7, "--sigma-y", 0.6, "--K", 1.59,
                        "--n", 0.3, "--radius", 7.05, "--deflection", 200,
                        "--out", tmp_path / "rom.csv")
    assert code == 2
    assert _one_error_line(err) == ("harnesspipe: error: rom three-point: --deflection 200: "
                                    "expected a deflection below half the 127 mm span (< 63.5 mm)")
    assert not (tmp_path / "rom.csv").exists()


def test_rom_hardening_exponent_above_one_exits_2(tmp_path, capsys):
    with pytest.raises(SystemExit) as stop:
        cli.main(["rom", "cantilever", "--E", "100", "--radius", "1", "--length", "50",
                  "--tip-load", "1", "--sigma-y", "5", "--K", "10", "--n", "1.3",
                  "--out", str(tmp_path / "c.csv")])
    assert stop.value.code == 2
    assert "argument --n: '1.3': expected a hardening exponent in (0, 1]" in capsys.readouterr().err


def test_check_data_refuses_a_flipped_force(good_data, capsys):
    path = good_data / "three_point" / "t_s2.csv"
    lines = path.read_text().splitlines()
    flipped = [lines[0]] + [",".join([*row.split(",")[:2], str(-float(row.split(",")[2]))])
                            for row in lines[1:]]
    path.write_text("\n".join(flipped) + "\n")
    assert cli.main(["check-data", str(good_data)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"harnesspipe: error: {path}: force_N: 98 % of the rows are negative: expected "
                   "a positive force resisting the displacement (load cell sign flipped?)"]


def test_broken_yaml_names_file_and_line(tmp_path):
    config = tmp_path / "config.yaml"
    config.write_text("profile: quick\nprofiles: [default\n  quick: 1\n")
    code, _, err = _hifi(tmp_path, "--config", config)
    assert code == 2
    assert _one_error_line(err) == (f"harnesspipe: error: {config}: line 3, column 8: not valid "
                                    "YAML: expected ',' or ']', but got ':'")


def test_broken_manifest_yaml_names_line(good_data, capsys):
    manifest = good_data / "manifest.yaml"
    manifest.write_text(manifest.read_text().replace("kind: three_point", "kind: [three_point"))
    assert cli.main(["check-data", str(good_data)]) == 2
    assert "manifest.yaml: line " in capsys.readouterr().err


@pytest.mark.parametrize("key, value, message", [
    ("hifi.parameters.mu_rtp", 2.5, "hifi.parameters.mu_rtp: 2.5: expected a friction coefficient"),
    ("paper.table2.open_tube.n", 1.5, "paper.table2.open_tube.n: 1.5: expected a hardening exponent"),
    ("hifi.parameters.delta_f", 0.01, "hifi.parameters.delta_f=0.01: expected a failure separation"),
    ("three_point.deflection", 70.0, "three_point.deflection: 70.0: expected a deflection below"),
])
def test_config_physical_ranges(tmp_path, key, value, message):
    cfg = yaml.safe_load(open(SCHEMA_PATH.parents[2] / "config" / "config.yaml"))
    tree = cfg
    *parents, last = key.split(".")
    for part in parents:
        tree = tree[part]
    tree[last] = value
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(cfg))
    code, _, err = _hifi(tmp_path, "--config", path)
    assert code == 2 and message in _one_error_line(err)


def test_mesh_minimums_agree_with_the_config_schema():
    schema = yaml.safe_load(SCHEMA_PATH.read_text())
    hifi = schema["$defs"]["profile"]["properties"]["hifi"]
    for key, low in validate.MESH_MIN.items():
        rule = hifi["properties"][key]
        assert rule.get("minimum", 1) == low, key


def test_interrupt_exits_130_with_one_line(monkeypatch, capsys):
    def interrupted(args):
        raise KeyboardInterrupt
    monkeypatch.setattr("harnesspipe.commands.data._check_data", interrupted)
    assert cli.main(["check-data"]) == 130
    assert capsys.readouterr().err.strip() == "harnesspipe: interrupted"


@pytest.mark.parametrize("args, key", [
    (["hifi-fit", "--step", "mu_rtb", "--reference", "cwb19_t2_closed=x.h5"], "names"),
    (["rom-fit", "--case", "cwb19_t2_closed", "--reference", "x.h5"], "reference"),
])
def test_stage_settings_without_a_key_exit_2_naming_it(tmp_path, capsys, args, key):
    """A stage step's --settings is valid JSON but lacks a key the step reads: one line
    naming the step and the key, exit 2, and no output folder left behind."""
    out = tmp_path / "out"
    assert cli.main(["stage", *args, "--settings", '{"unrelated": 1}', "--outdir", str(out)]) == 2
    assert _one_error_line(capsys.readouterr().err) == (
        f"harnesspipe: error: stage {args[0]}: --settings has no key {key!r} (the rule builds it "
        "from config/config.yaml)")
    assert not out.exists()


def test_a_key_error_inside_a_step_is_not_blamed_on_the_settings(monkeypatch):
    def broken(args):
        return {}["unrelated"]          # a key the settings do have: a bug, not bad input
    monkeypatch.setattr("harnesspipe.commands.stage._rom_fit", broken)
    with pytest.raises(KeyError):
        cli.main(["stage", "rom-fit", "--case", "c", "--reference", "x.h5",
                  "--settings", '{"unrelated": 1}', "--outdir", "o"])


# --------------------------------------------------------------------------- --interface

def test_interface_paper_start_and_file(tmp_path):
    cfg = load()
    label, paper = interface_choice(cfg, "paper")
    assert paper == {"mu_rtb": 0.3, "mu_rtp": 0.1, "delta0": 0.03, "delta_f": 0.08,
                     "alpha_d": 2.0, "E2_over_E1": 0.6} and label.startswith("paper")
    assert interface_choice(cfg, "start")[1] == cfg["hifi"]["parameters"]
    csv = tmp_path / "interface.csv"
    csv.write_text("parameter,value\nmu_rtb,0.35\nmu_rtp,0.15\ndelta0,0.04\ndelta_f,0.09\n"
                   "alpha_d,1.5\nE2_over_E1,0.7\nend_tape_layers,3.0\n")
    label, values = interface_choice(cfg, csv)
    p = parameters(cfg, {"mu_rtp": "0.12"}, None, values)
    assert label == str(csv)
    assert p["interface"]["mu_rtb"] == 0.35 and p["interface"]["mu_rtp"] == 0.12   # --set on top
    assert p["build"]["end_tape_layers"] == 3.0 and "end_tape_layers" not in p["interface"]
    # no interface: the config's start values, as the pipeline's stages rely on
    assert {k: parameters(cfg, {})["interface"][k] for k in paper} == cfg["hifi"]["parameters"]


def test_interface_file_with_a_bad_row_exits_2(tmp_path):
    csv = tmp_path / "interface.csv"
    csv.write_text("parameter,value\nmu_rtb,0.3\nmu_rtp,-0.1\n")
    code, _, err = _hifi(tmp_path, "--interface", csv)
    assert code == 2
    assert _one_error_line(err) == (f"harnesspipe: error: {csv}: line 3: mu_rtp=-0.1: expected a "
                                    "friction coefficient in [0, 2]")
    code, _, err = _hifi(tmp_path, "--interface", "calibrated")
    assert code == 2 and "--interface calibrated: expected paper, start or an interface.csv" in err


def test_default_interface_is_the_calibrated_one_when_present(tmp_path):
    """Without --interface the run takes results/hifi/interface.csv of the working directory,
    and says so first; a bad value in it stops the run before it starts."""
    calibrated = tmp_path / "results" / "hifi" / "interface.csv"
    calibrated.parent.mkdir(parents=True)
    calibrated.write_text("parameter,value\nmu_rtb,0.3\nalpha_d,0\n")
    code, _, err = _hifi(tmp_path)
    assert code == 2
    assert _one_error_line(err) == ("harnesspipe: error: results/hifi/interface.csv: line 3: "
                                    "alpha_d=0: expected a damage-evolution rate > 0")


# --------------------------------------------------------------------------- progress

class _Stream(io.StringIO):
    def __init__(self, tty):
        super().__init__()
        self.tty = tty

    def isatty(self):
        return self.tty


def _feed(progress, n=200):
    for k in range(n + 1):
        f = k / n
        progress(step=10 * k, time_fraction=f, deflection_mm=30.0 * f * f, force_N=5.0 * f,
                 stroke_mm=30.0)
    progress.close()


def test_progress_plain_lines_every_five_percent():
    stream = _Stream(tty=False)
    _feed(Progress("cwb19_t2_closed", stream, clock=iter(range(1000)).__next__))
    lines = stream.getvalue().splitlines()
    assert len(lines) == 21 and "\r" not in stream.getvalue()
    assert lines[0].startswith("cwb19_t2_closed:   0 %  deflection   0.00 of 30 mm")
    assert lines[-1].startswith("cwb19_t2_closed: 100 %  deflection  30.00 of 30 mm  force    5.000 N"
                                "  step 2000")
    assert "ETA 0 s" in lines[-1] and "elapsed" in lines[10]


def test_progress_on_a_terminal_updates_one_line():
    stream = _Stream(tty=True)
    _feed(Progress("case", stream, clock=iter(range(1000)).__next__))
    text = stream.getvalue()
    assert text.count("\r") == 21 and text.endswith("\n") and text.count("\n") == 1
    assert "[####################] case: 100 %" in text
