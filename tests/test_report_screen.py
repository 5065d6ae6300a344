"""The hi-fi sensitivity screen's record in the report (report/screen.py, issue 27 item 3)."""
import json
from pathlib import Path

import pytest

from harnesspipe.report import screen
from harnesspipe.stages.chain_settings import STEPS

RECORD = Path(__file__).resolve().parents[1] / "bench" / "sensitivity.json"


def _record(tmp_path, **changes):
    record = {"profile": "quick", "commit": "abc1234", "date": "2026-11-29", "step": "+25 %",
              "rows": [{"case": "cwb19_t2_closed", "input": "end_tape_layers",
                        "S": {"friction": 0.263, "cohesive": 0.314}},
                       {"case": "cwb19_t2_closed", "input": "delta0",
                        "S": {"friction": 0.0, "cohesive": 0.0}},
                       {"case": "cwb19_t2_fabric", "input": "wire_fill", "S": {"fabric": 0.277}}]}
    record.update(changes)
    path = tmp_path / "sensitivity.json"
    path.write_text(json.dumps(record))
    return path


def test_the_record_is_shown_with_the_step_that_fits_each_input(tmp_path):
    text = screen.section(screen.read_record(_record(tmp_path)))
    assert "commit abc1234 on 2026-11-29, quick profile" in text
    assert "<td>end_tape_layers</td><td>friction <b>0.263</b>, cohesive <b>0.314</b></td><td>build</td>" in text
    assert "<td>delta0</td><td>friction <span class='note'>0.000</span>" in text
    assert "<td>wire_fill</td><td>fabric <b>0.277</b></td><td>kept</td>" in text
    assert screen.section(None) == "" and screen.read_record(tmp_path / "none.json") is None


def test_a_row_run_later_alone_names_its_own_commit(tmp_path):
    """bench_sensitivity.py --only merges a row into the record; the report says when it was run."""
    added = [{"case": "cwb19_t2_fabric", "input": "wire_fill", "commit": "def5678", "date": "2026-12-02"}]
    text = screen.section(screen.read_record(_record(tmp_path, added=added)))
    assert ("commit abc1234 on 2026-11-29, quick profile; the row cwb19_t2_fabric / wire_fill "
            "added at commit def5678 on 2026-12-02;") in text


def test_a_broken_record_is_refused_naming_the_file_and_the_field(tmp_path):
    path = _record(tmp_path)
    data = json.loads(path.read_text())
    del data["commit"]
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"sensitivity.json: expected .*missing: \['commit'\]"):
        screen.read_record(path)
    path = _record(tmp_path, rows=[{"case": "cwb19_t2_closed", "S": 0.2}])
    with pytest.raises(ValueError, match=r"rows \[0\] are not so"):
        screen.read_record(path)
    path = _record(tmp_path, rows=3)
    with pytest.raises(ValueError, match="rows is not a list"):
        screen.read_record(path)
    path.write_text("{not json")
    with pytest.raises(ValueError, match="it is not JSON"):
        screen.read_record(path)


def test_the_shipped_record_screens_every_input_the_chain_fits_on_its_cases():
    """bench/sensitivity.json covers each chain step's inputs on each of the step's cases, so
    the report's screen says, for every fitted input, how much its window sees it."""
    record = screen.read_record(RECORD)
    assert record is not None, "bench/sensitivity.json is missing: run bench/bench_sensitivity.py"
    screened = {(r["case"], r["input"]) for r in record["rows"]}
    wanted = {(case, name) for s in STEPS.values() for case in s["cases"] for name in s["names"]}
    assert wanted <= screened, sorted(wanted - screened)


def test_the_report_command_refuses_a_broken_record_and_writes_nothing(tmp_path, capsys):
    from harnesspipe import cli
    bad = tmp_path / "screen.json"
    bad.write_text(json.dumps({"rows": []}))
    out = tmp_path / "report" / "index.html"
    (tmp_path / "check.txt").write_text("data: OK\n")
    args = ["report", "--check", str(tmp_path / "check.txt"), "--out", str(out), "--screen"]
    assert cli.main(args + [str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"report --screen: {bad}: expected bench/bench_sensitivity.py's record" in err
    assert "missing: ['commit', 'profile', 'date', 'step']" in err
    with pytest.raises(SystemExit) as exc:                   # argparse: before anything runs
        cli.main(args + [str(tmp_path / "none.json")])
    assert exc.value.code == 2
    assert f"argument --screen: {tmp_path / 'none.json'}: no such file" in capsys.readouterr().err
    assert not out.exists()
