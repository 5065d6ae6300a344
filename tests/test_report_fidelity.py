"""The report's verdict on each virtual test: its error against the goal of its role."""
from __future__ import annotations

import json

from harnesspipe import config
from harnesspipe.report.html import _fidelity_table
from harnesspipe.report.verdict import hifi_fidelity


def _virtual(root, case, role, error_rel):
    folder = root / "virtual" / case
    folder.mkdir(parents=True)
    (folder / "summary.json").write_text(json.dumps(
        {"case": case, "role": role, "measured": {"test_id": case, "error_l2": 1.0,
                                                  "error_rel": error_rel}}))


def test_each_virtual_test_is_met_at_or_missed_by_its_roles_goal(tmp_path):
    cfg = config.load()
    assert cfg["hifi"]["pipeline"]["fidelity_goal"] == {"calibration": 0.10, "validation": 0.15,
                                                        "prediction": 0.15}
    assert cfg["hifi"]["pipeline"]["fidelity_spread"] == 0.01
    _virtual(tmp_path, "cwb19_t2_closed", "calibration", 0.085)       # below 10 - 1 %: met
    _virtual(tmp_path, "cwb19_t2_open_halflap", "calibration", 0.105)  # within 1 point of 10 %
    _virtual(tmp_path, "cwb19_t2_fabric", "calibration", 0.14)       # 14 % > 10 + 1 %: missed
    _virtual(tmp_path, "cwb19_t1_open_coarse", "validation", 0.13)   # 13 % <= 15 - 1 %: met
    html = _fidelity_table(tmp_path, cfg)
    rows = html.split("<tr>")[2:]
    assert [r.split("</td>")[0].removeprefix("<td>") for r in rows] == [
        "19 x type 1, open tube, coarse tape (cwb19_t1_open_coarse)",
        "19 x type 2, closed tube (cwb19_t2_closed)", "19 x type 2, fabric tube, taped ends (cwb19_t2_fabric)",
        "19 x type 2, open tube, half-lap tape (cwb19_t2_open_halflap)"]
    assert "<td>met</td>" in rows[0] and "<td>met</td>" in rows[1]
    assert "<td class='bad'>missed by 4.0 points</td>" in rows[2]
    assert "<td class='near'>at the goal within the run-to-run spread (\u00b11 point)</td>" in rows[3]
    assert _fidelity_table(tmp_path / "nothing", cfg) == ""


def test_the_table_gives_the_wires_own_force_each_curve_carries(tmp_path):
    """A virtual test at twice its wires' own force and a test at once it: '2.00x / 1.00x'."""
    import numpy as np
    import pandas as pd

    from harnesspipe.models.free_wires import free_wire_force
    from harnesspipe.stages.data import Prepared
    cfg = config.load()
    case = "cwb10t1_9t2_fabric"
    u = np.linspace(0.0, 30.0, 31)
    F_free = free_wire_force(cfg, cfg["cases"][case]["wires"], u)
    root = tmp_path / "hifi"
    _virtual(root, case, "validation", 0.40)
    pd.DataFrame({"deflection_mm": u, "force_N": 2.0 * F_free}).to_csv(
        root / "virtual" / case / "curve.csv", index=False)
    measured = {case: Prepared(case, {}, u, F_free, F_free, F_free, {})}
    row = _fidelity_table(root, cfg, hifi_fidelity(tmp_path, cfg, measured)).split("<tr>")[2]
    assert "<td>200 %</td><td>2.00x / 1.00x</td></tr>" in row


def test_a_run_block_says_how_far_the_wires_slid_and_whether_a_tie_damaged(tmp_path):
    import pandas as pd

    from harnesspipe.report.html import DEBOND_SEEN, SLIP_SEEN, _physical_rows
    pd.DataFrame({"wire": [0, 1, 2], "type": [1, 2, 2], "left_mm": [0.2, 1.5, 0.4],
                  "right_mm": [0.3, 0.1, 0.9]}).to_csv(tmp_path / "slip_out.csv", index=False)
    summary = {"tie_separation_max_mm": 0.006, "debonded_ties": 0, "interface": {"delta0": 0.03}}
    slip, ties = _physical_rows(tmp_path, summary)
    assert slip == ["wires slid out of the taped ends [mm] (largest; median)",
                    "1.50 (wire 1, type 2); 0.35", SLIP_SEEN]
    assert ties == ["tape ties: largest separation [mm]", "0.006",
                    f"no tie reached damage (0.2 of the onset delta0); {DEBOND_SEEN}"]
    summary.update(tie_separation_max_mm=0.05)
    assert _physical_rows(tmp_path, summary)[1][2].startswith("ties damaged (1.7 of the onset delta0), none")
    summary.update(debonded_ties=3)
    assert _physical_rows(tmp_path, summary)[1][2].startswith("3 ties debonded")
    # with the run's history, the opening once the feeder had reached 20 mm beside it
    pd.DataFrame({"deflection_mm": [0.0, 10.0, 30.0],
                  "tie_opening_mm": [0.0, 0.01, 0.05]}).to_csv(tmp_path / "energies.csv", index=False)
    assert _physical_rows(tmp_path, summary)[1][1] == "0.05 (0.03 at 20 mm)"
