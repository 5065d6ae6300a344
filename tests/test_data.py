"""Test-data validation: every bad-data case gives one line naming file and row."""
import subprocess
import sys

import numpy as np
import pytest
import yaml

from harnesspipe.data.experimental import DataError, load_all
from harnesspipe.stages.data import check_data, prepare_test, read_prepared
from conftest import bilinear, write_curve


def problems_of(root):
    with pytest.raises(DataError) as err:
        check_data(root)
    return err.value.problems


def edit_line(path, line_no, new):
    lines = path.read_text().splitlines()
    lines[line_no - 1] = new
    path.write_text("\n".join(lines) + "\n")


def test_good_data_passes_with_summary(good_data):
    summary = check_data(good_data)
    assert "OK: 1 tests (1 three_point), 3 samples, 183 rows" in summary


def test_missing_file(good_data):
    (good_data / "three_point" / "t_s2.csv").unlink()
    (line,) = problems_of(good_data)
    assert line.endswith("three_point/t_s2.csv: file not found")


@pytest.mark.parametrize("name, header, missing", [
    ("t_s1.csv", "time_s,displacement_mm,load_N", "force_N"),
    ("t_s1_markers.csv", "time_s,displacement_mm,marker,x_mm", "y_mm"),
])
def test_misnamed_column(good_data, name, header, missing):
    edit_line(good_data / "three_point" / name, 1, header)
    (line,) = problems_of(good_data)
    assert f"{name}: line 1: missing column(s) {missing}" in line
    assert f"found {header}" in line


def test_non_numeric_cell(good_data):
    edit_line(good_data / "three_point" / "t_s3.csv", 17, "15.0,7.5,1;25")  # decimal comma export
    (line,) = problems_of(good_data)
    assert line.endswith("t_s3.csv: line 17: force_N: '1;25' is not a number")


def test_nan_and_empty_cells(good_data):
    edit_line(good_data / "three_point" / "t_s1.csv", 5, "1.6,0.8,nan")
    edit_line(good_data / "three_point" / "t_s2.csv", 9, "6.4,3.2,")
    lines = problems_of(good_data)
    assert any("t_s1.csv: line 5: force_N: nan is not a finite number" in x for x in lines)
    assert any("t_s2.csv: line 9: force_N: empty cell" in x for x in lines)


def test_duplicated_and_decreasing_displacement(good_data):
    edit_line(good_data / "three_point" / "t_s1.csv", 12, "20.0,5.0,3.1")   # line k holds u = 0.5 (k - 2)
    edit_line(good_data / "three_point" / "t_s1.csv", 13, "20.0,5.0,3.2")   # repeats 5.0
    edit_line(good_data / "three_point" / "t_s2.csv", 20, "36.0,1.0,1.0")   # decreases
    lines = problems_of(good_data)
    assert any("t_s1.csv: line 13: displacement_mm 5 repeats 5" in x for x in lines)
    assert any("t_s2.csv: line 20: displacement_mm 1 decreases from 8.5" in x for x in lines)


def test_metres_and_kilonewtons(good_data):
    u = np.linspace(0.0, 0.030, 61)  # metres
    write_curve(good_data / "three_point" / "t_s1.csv", u, bilinear(u * 1e3))
    u = np.linspace(0.0, 30.0, 61)
    write_curve(good_data / "three_point" / "t_s2.csv", u, bilinear(u) * 1e-3)  # kN
    lines = problems_of(good_data)
    assert any("t_s1.csv: displacement_mm peaks at 0.03 for a 30 mm stroke: values look like metres" in x
               for x in lines)
    assert any("t_s2.csv: force_N peaks at" in x and "values look like kN" in x for x in lines)


def test_force_beyond_load_cell(good_data):
    u = np.linspace(0.0, 30.0, 61)
    write_curve(good_data / "three_point" / "t_s3.csv", u, bilinear(u) * 1e3)  # mN written as N
    (line,) = problems_of(good_data)
    assert "t_s3.csv: force_N reaches" in line and "beyond the 222.4 N load cell" in line


def test_too_few_rows(good_data):
    u = np.linspace(0.0, 30.0, 9)
    write_curve(good_data / "three_point" / "t_s2.csv", u, bilinear(u))
    (line,) = problems_of(good_data)
    assert line.endswith("t_s2.csv: 9 data rows, at least 10 needed")




def test_manifest_schema_errors_name_the_field(good_data):
    m = yaml.safe_load((good_data / "manifest.yaml").read_text())
    m["tests"]["tp_case"]["protocol"]["stroke_mm"] = -30
    del m["tests"]["tp_case"]["provenance"]
    (good_data / "manifest.yaml").write_text(yaml.safe_dump(m))
    lines = problems_of(good_data)
    assert any("manifest.yaml: tests.tp_case.protocol.stroke_mm: -30 is less than or equal to" in x
               for x in lines)
    assert any("tests.tp_case: 'provenance' is a required property" in x for x in lines)


def test_resampling_mean_and_band(good_data, tmp_path):
    (ts,) = load_all(good_data, n_grid=31).values()
    assert ts.grid[0] == 0.0 and ts.grid[-1] == pytest.approx(30.0)
    exact = bilinear(ts.grid)
    np.testing.assert_allclose(ts.mean, exact * (0.97 + 1.0 + 1.04) / 3, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(ts.lo, 0.97 * exact, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(ts.hi, 1.04 * exact, rtol=1e-5, atol=1e-6)
    out = prepare_test(good_data, "tp_case", tmp_path / "tp.h5")
    pr = read_prepared(out)
    assert pr.entry["item"] == "cwb19_t2_closed"
    assert pr.samples["s1"]["markers"].shape == (27, 5)


def test_check_data_cli_exit_codes(good_data):
    ok = subprocess.run([sys.executable, "-m", "harnesspipe", "check-data", str(good_data)],
                        capture_output=True, text=True)
    assert ok.returncode == 0 and "OK: 1 tests" in ok.stdout
    (good_data / "three_point" / "t_s3.csv").unlink()
    bad = subprocess.run([sys.executable, "-m", "harnesspipe", "check-data", str(good_data)],
                         capture_output=True, text=True)
    assert bad.returncode == 2
    assert bad.stderr.strip().splitlines() == [
        f"harnesspipe: error: {good_data}/three_point/t_s3.csv: file not found"]
