"""Files handed to the command line: an output path that cannot be written stops the command
before anything runs, naming the option; a file that cannot be read as what it should be is one
line naming it and what was expected (exit 2), not a parser's traceback; nothing is left
half-written."""
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from test_cli_inputs import _hifi, _one_error_line, _run

from harnesspipe.config import DEFAULT_CONFIG

REPO = Path(__file__).resolve().parents[1]
TABLE2 = ("component,E,sigma_y,K,n\nclosed_tube,1559,8.6,25.6,0.12\nopen_tube,698,8.8,23.1,0.83\n"
          "fabric_tube,28.9,1.4,67.7,0.5\n")
INTERFACE = "parameter,value\nmu_rtb,0.3\nmu_rtp,0.1\ndelta0,0.03\ndelta_f,0.08\nalpha_d,2\nE2_over_E1,0.6\n"


def _argparse_error(err: str) -> str:
    """The error line of an argparse failure (after its usage lines)."""
    return [line for line in err.splitlines() if ": error: " in line][-1]


@pytest.mark.parametrize("option, value, message", [
    ("--out", "afile/curve.csv", "afile/curve.csv: afile is a file, not a folder"),
    ("--summary", "afile/summary.json", "afile/summary.json: afile is a file, not a folder"),
    ("--outdir", "afile", "afile: is a file, expected a folder"),
    ("--out", ".", ".: is a folder, expected a file name"),
    ("--coverings", "missing.csv", "missing.csv: no such file"),
])
def test_hifi_paths_are_checked_before_the_run(tmp_path, option, value, message):
    (tmp_path / "afile").write_text("")
    args = ["hifi", "three-point", "--case", "cwb19_t2_closed", "--profile", "quick"]
    args += [] if option == "--out" else ["--out", "curve.csv"]
    code, out, err = _run(*args, option, value, cwd=tmp_path)
    assert code == 2 and out == ""
    assert _argparse_error(err).endswith(f"error: argument {option}: {message}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]      # nothing written


def test_hifi_default_outdir_in_the_way_stops_before_the_run(tmp_path):
    (tmp_path / "curve_files").write_text("")
    code, out, err = _hifi(tmp_path, "--interface", "paper")
    assert code == 2 and _one_error_line(err) == (
        f"harnesspipe: error: --out {tmp_path / 'curve.csv'}: {tmp_path / 'curve_files'} (the "
        "default --outdir) is a file, expected a folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["curve_files"]


@pytest.mark.parametrize("option, text, message", [
    ("--coverings", "", "{f}: empty, expected a CSV table with a header line"),
    ("--coverings", TABLE2.replace("closed_tube,1559,8.6,25.6,0.12\n", ""),
     "{f}: no row for closed_tube: expected a Table 2 row per covering (closed_tube, open_tube, "
     "fabric_tube)"),
    ("--coverings", TABLE2.replace("0.12\n", "0.12,9\n"),
     "{f}: line 2: 6 fields, expected 5 (component,E,sigma_y,K,n)"),
    ("--interface", "parameter,value\n",
     "{f}: no row for mu_rtb, mu_rtp, delta0, delta_f, alpha_d, E2_over_E1: an interface.csv "
     "gives every Sec. 4.2 parameter (to change one, --set it on top of --interface paper or start)"),
    ("--interface", INTERFACE.replace("delta_f,0.08", "delta_f,0.01"),
     "{f}: delta_f=0.01: expected a failure separation > delta0 (0.03)"),
    ("--interface", INTERFACE + "mu_rtb,0.2\n", "{f}: line 8: mu_rtb given twice"),
])
def test_hifi_unreadable_table2_or_interface_is_named(tmp_path, option, text, message):
    given = tmp_path / "given.csv"
    given.write_text(text)
    code, _, err = _hifi(tmp_path, option, given)
    assert code == 2
    assert _one_error_line(err) == "harnesspipe: error: " + message.format(f=given)


def test_a_tape_tension_beyond_the_tapes_yield_stops_the_config_and_the_catalogue(tmp_path):
    """Checked where it is given: the config's hifi.build and a catalogue's construction
    (`campaign check`, before a campaign runs), not when a run reaches it."""
    cfg = yaml.safe_load(DEFAULT_CONFIG.read_text())
    cfg["hifi"]["build"]["tape_tension"] = 100.0
    overlay = tmp_path / "config.yaml"
    overlay.write_text(yaml.safe_dump(cfg))
    code, _, err = _hifi(tmp_path, "--config", overlay)
    assert code == 2
    assert _one_error_line(err) == (
        f"harnesspipe: error: {overlay}: hifi.build.tape_tension: 100.0: expected a wrapping "
        "tension below the tape's yield force sigma_y w t = 4.51 N (materials.pvc_tape)")
    catalogue = yaml.safe_load((REPO / "config" / "campaigns" / "demo.yaml").read_text())
    name = next(iter(catalogue["constructions"]))
    catalogue["constructions"][name]["build"] = {"tape_tension": 1000}
    path = tmp_path / "catalogue.yaml"
    path.write_text(yaml.safe_dump(catalogue))
    code, _, err = _run("campaign", "check", path)
    assert code == 2
    assert f"{path}: construction {name}: build.tape_tension: 1000: expected a wrapping tension " \
           "below the tape's yield force" in _one_error_line(err)


def test_unreadable_records_are_named(tmp_path):
    """A truncated prepared test (report), a JSON row that is not JSON (campaign library), a
    library without its status column (campaign page)."""
    prepared = tmp_path / "bend.h5"
    with h5py.File(prepared, "w") as f:
        f["grid"] = np.linspace(0.0, 30.0, 1000)
    prepared.write_bytes(prepared.read_bytes()[:1500])
    check = tmp_path / "check.txt"
    check.write_text("data: OK\n")
    code, _, err = _run("report", "--check", check, "--prepared", prepared, "--out", tmp_path / "r.html")
    assert code == 2 and _one_error_line(err) == (
        f"harnesspipe: error: {prepared}: cannot be read as a prepared test (HDF5) (truncated)")
    assert not (tmp_path / "r.html").exists()
    row = tmp_path / "property.json"
    row.write_text('{"case": "w7"\n"E": 1}')
    code, _, err = _run("campaign", "library", "--rows", row, "--out", tmp_path / "lib.csv")
    assert code == 2 and _one_error_line(err) == (
        f"harnesspipe: error: {row}: not valid JSON: line 2, column 1: Expecting ',' delimiter")
    library = tmp_path / "properties.csv"
    library.write_text("case,E\nw7,12.0\n")
    code, _, err = _run("campaign", "page", "--library", library, "--out", tmp_path / "p.html")
    assert code == 2 and _one_error_line(err).startswith(
        f"harnesspipe: error: {library}: missing columns sigma_y, K, n,")
    assert not (tmp_path / "lib.csv").exists() and not (tmp_path / "p.html").exists()


def test_synthesize_refuses_to_drop_the_other_tests_of_a_data_set(tmp_path):
    data = tmp_path / "data"
    shutil.copytree(REPO / "data" / "experimental", data)
    before = {p: p.read_bytes() for p in data.rglob("*") if p.is_file()}
    code, _, err = _run("synthesize", "--only", "tensile", "--out", data)
    assert code == 2 and _one_error_line(err).startswith(
        f"harnesspipe: error: {data}: its manifest.yaml lists 8 test(s) these generators do not make")
    assert {p: p.read_bytes() for p in data.rglob("*") if p.is_file()} == before
    code, _, err = _run("synthesize", "--only", "bogus", "--out", tmp_path / "new")
    assert code == 2 and "synthesize --only: unknown generator(s) ['bogus']" in _one_error_line(err)
    assert not (tmp_path / "new").exists()


def test_check_data_finds_a_stroke_in_the_wrong_unit_and_tests_the_config_does_not_use(tmp_path):
    data = tmp_path / "data"
    shutil.copytree(REPO / "data" / "experimental", data)
    manifest = yaml.safe_load((data / "manifest.yaml").read_text())
    manifest["tests"]["bend_cwb19_t2_closed"]["item"] = "cwb19_t9_closed"
    (data / "manifest.yaml").write_text(yaml.safe_dump(manifest, sort_keys=False))
    code, out, _ = _run("check-data", data, "--config", DEFAULT_CONFIG)
    assert code == 0 and out.strip().endswith(
        "; not used by the config: bend_cwb19_t2_closed (item 'cwb19_t9_closed' is not a case "
        "of the config)")
    entry = manifest["tests"]["bend_cwb19_t2_open_coarse"]      # its own protocol (not an alias)
    entry["protocol"] = {**entry["protocol"], "stroke_mm": 0.03}
    (data / "manifest.yaml").write_text(yaml.safe_dump(manifest, sort_keys=False))
    code, _, err = _run("check-data", data)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 3 and all(
        line.endswith("displacement_mm reaches 30, beyond the 0.03 mm stroke of protocol.stroke_mm: "
                      "the stroke or the unit (expected mm) is wrong") for line in lines)


def test_cards_write_nothing_when_a_case_folder_is_a_file(tmp_path):
    table = tmp_path / "table3.csv"
    table.write_text("case,E,sigma_y,K,n,r_o,rho\ncwb_a,15.7,0.6,1.59,0.3,7.05,1.5e-9\n"
                     "cwb_b,20.6,0.8,2.0,0.3,7.05,1.5e-9\n")
    out = tmp_path / "cards"
    out.mkdir()
    (out / "cwb_b").write_text("")
    code, _, err = _run("cards", "--table", table, "--format", "lsdyna", "--out", out)
    assert code == 2 and _one_error_line(err) == (
        f"harnesspipe: error: {out}: {out / 'cwb_b'} is in the way (a folder where a card goes or "
        "a file where a case's folder goes): nothing written")
    assert sorted(p.name for p in out.iterdir()) == ["cwb_b"]
