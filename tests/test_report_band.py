"""Table 3's E against its band over the build state in the report (report/band.py, issue 27
item 5)."""
import json
from pathlib import Path

import pytest

from harnesspipe import config
from harnesspipe.report import band
from harnesspipe.report.html import hifi_section

RECORD = Path(__file__).resolve().parents[1] / "bench" / "build_band.json"
CORNERS = [{"end_tape_layers": w, "tape_tension": T} for w in (1, 8) for T in (0.0, 4.0)]


def _record(tmp_path, **changes):
    record = {"profile": "quick", "commit": "abc1234", "date": "2026-12-02", "corners": CORNERS,
              "rows": [{"case": "cwb19_t2_closed", "E_eff": [8.8, 8.2, 12.8, 12.2], "table3_E": 15.7},
                       {"case": "cwb19_t2_fabric", "E_eff": [28.3, None, 35.7, 34.1], "table3_E": 30.6},
                       {"case": "cwb19_t2_open_halflap", "E_eff": [24.7, 52.1, 29.6, 53.4],
                        "table3_E": 20.6}]}
    record.update(changes)
    path = tmp_path / "build_band.json"
    path.write_text(json.dumps(record))
    return path


@pytest.mark.parametrize("E, where", [(15.7, "above the band"), (8.2, "inside"), (12.8, "inside"),
                                      (8.1, "below the band")])
def test_table3s_E_is_placed_against_the_runs_that_ran(E, where):
    assert band.placement(E, [8.8, 8.2, None, 12.8]) == where
    assert band.placement(E, [None, None]) == "no run"


def test_the_record_is_shown_beside_table3_with_where_its_E_lies(tmp_path):
    cfg = config.load()
    text = band.section(band.read_record(_record(tmp_path)), cfg)
    assert "<th>1 wrap, 0 N</th><th>1 wrap, 4 N</th><th>8 wraps, 0 N</th><th>8 wraps, 4 N</th>" in text
    assert ("<td>8.8</td><td>8.2</td><td>12.8</td><td>12.2</td><td>15.7</td>"
            "<td class='bad'>above the band</td>") in text
    assert "<td>28.3</td><td>failed</td><td>35.7</td><td>34.1</td><td>30.6</td><td>inside</td>" in text
    assert "inside the band for 1 of 3 cases" in text
    assert "commit abc1234 on 2026-12-02, quick profile" in text
    assert band.section(None, cfg) == "" and band.read_record(tmp_path / "none.json") is None


def test_the_hifi_section_shows_the_band_after_the_table3_cross_check(tmp_path):
    cfg = config.load()
    (tmp_path / "hifi" / "crosscheck").mkdir(parents=True)
    (tmp_path / "hifi" / "crosscheck" / "table3.csv").write_text(
        "case,E,sigma_y,K,n\ncwb19_t2_closed,9.6,0.3,20.0,0.5\n")
    text = hifi_section(tmp_path, cfg, {}, band_record=band.read_record(_record(tmp_path)))
    assert text.index("Table 3 from hi-fi curves") < text.index("Table 3's E against the band")


def test_a_broken_record_is_refused_naming_the_file_and_what_is_wrong(tmp_path):
    path = _record(tmp_path, rows=[{"case": "cwb19_t2_closed", "E_eff": [1.0, 2.0], "table3_E": 15.7}])
    with pytest.raises(ValueError, match=r"build_band.json: every row's E_eff needs one value per corner \(4\)"):
        band.read_record(path)
    path = _record(tmp_path, rows=[{"case": "cwb19_t2_closed", "E_eff": 3.0, "table3_E": 15.7}])
    with pytest.raises(ValueError, match=r"expected bench/bench_build_band.py's record.*rows \[0\] are not so"):
        band.read_record(path)
    path.write_text(json.dumps({"rows": []}))
    with pytest.raises(ValueError, match=r"missing: \['commit', 'profile', 'date', 'corners'\]"):
        band.read_record(path)


def test_the_report_command_refuses_a_missing_band_record_and_writes_nothing(tmp_path, capsys):
    from harnesspipe import cli
    out = tmp_path / "report" / "index.html"
    (tmp_path / "check.txt").write_text("data: OK\n")
    args = ["report", "--check", str(tmp_path / "check.txt"), "--out", str(out), "--band"]
    with pytest.raises(SystemExit) as exc:                   # argparse: before anything runs
        cli.main(args + [str(tmp_path / "none.json")])
    assert exc.value.code == 2
    assert f"argument --band: {tmp_path / 'none.json'}: no such file" in capsys.readouterr().err
    bad = tmp_path / "band.json"
    bad.write_text("{")
    assert cli.main(args + [str(bad)]) == 2
    assert "it is not JSON" in capsys.readouterr().err
    assert not out.exists()


def test_the_shipped_record_spans_every_table3_case_over_the_chains_build_bounds():
    """bench/build_band.json runs each Table 3 case at the corners of the bounds the chain
    fits the build inputs within, so the report's band is the one the chain can reach."""
    cfg = config.load()
    record = band.read_record(RECORD)
    assert record is not None, "bench/build_band.json is missing: run bench/bench_build_band.py"
    pipe = cfg["hifi"]["pipeline"]
    assert record["corners"] == [{"end_tape_layers": w, "tape_tension": T}
                                 for w in pipe["layers_bounds"] for T in pipe["tension_bounds"]]
    assert [r["case"] for r in record["rows"]] == list(cfg["paper"]["table3"])
    assert all(r["table3_E"] == cfg["paper"]["table3"][r["case"]]["E"] for r in record["rows"])
