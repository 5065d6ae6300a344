"""Solver cards (issue 28 item 3): the eq. 2 table within 0.5 %, the LS-DYNA keyword format
read back by a small parser, where r_o, nu and rho come from, skipped rows, and bad input
(exit 2, one line naming the file, column or option, nothing written).  The CalculiX run of
the three-point deck is in test_cards_ccx.py."""
import math
import subprocess
import sys

import numpy as np
import pytest

from harnesspipe.cards import flow_curve, lsdyna, write_cards
from harnesspipe.cards.properties import effective_density
from harnesspipe.models.rom_beam import Material

LAW_KEYS = ("sigma_y", "K", "n")


def _table3_csv(config, path, cases=None, extra=""):
    """A Table 3 CSV from the config's published values (paper.table3), optional columns
    appended by ``extra`` (header suffix, then a dict case -> row suffix)."""
    rows = config["paper"]["table3"]
    header, suffix = (extra or ("", {}))
    lines = [f"case,E,sigma_y,K,n{header}"]
    for case in cases or rows:
        r = rows[case]
        lines.append(f"{case},{r['E']},{r['sigma_y']},{r['K']},{r['n']}{suffix.get(case, '')}")
    path.write_text("\n".join(lines) + "\n")
    return path


def _worst_deviation(eps, sigma, sigma_y, K, n, lo, hi, per_interval=200):
    """Largest |table - eq. 2| / eq. 2 on [lo, hi], the table's linear interpolant evaluated
    between every pair of its points."""
    worst = 0.0
    for a, b in zip(eps[:-1], eps[1:]):
        a, b = max(a, lo), min(b, hi)
        if a >= b:
            continue
        x = np.geomspace(a, b, per_interval)
        law = sigma_y + K * x**n
        worst = max(worst, float(np.max(np.abs(np.interp(x, eps, sigma) - law) / law)))
    return worst


# ----------------------------------------------------------------------------- eq. 2 table
@pytest.mark.parametrize("case", ["cwb19_t2_closed", "cwb19_t2_open_halflap", "cwb19_t2_open_coarse",
                                  "cwb19_t2_fabric", "cwb10t1_9t2_fabric"])
def test_plastic_table_stays_within_half_a_percent_of_eq2(config, case):
    law = {k: config["paper"]["table3"][case][k] for k in LAW_KEYS}
    eps, sigma = flow_curve.tabulate(**law)
    lo, hi = flow_curve.STRAIN_RANGE
    assert eps[0] == 0.0 and sigma[0] == law["sigma_y"]         # first yield
    assert eps[1] == pytest.approx(lo) and eps[-1] == pytest.approx(hi)
    assert np.all(np.diff(eps) > 0) and np.all(np.diff(sigma) > 0)
    assert _worst_deviation(eps, sigma, *law.values(), lo, hi) <= flow_curve.TOLERANCE
    # the check can fail: every other point dropped breaks the bound
    coarse = np.r_[eps[0], eps[1::2], eps[-1]], np.r_[sigma[0], sigma[1::2], sigma[-1]]
    assert _worst_deviation(*coarse, *law.values(), lo, hi) > flow_curve.TOLERANCE


@pytest.mark.parametrize("n", [0.05, 0.5, 0.9, 1.0])
def test_geometric_ratio_meets_the_tolerance_at_any_exponent(n):
    q = flow_curve.geometric_ratio(n)
    assert flow_curve.chord_deviation(q, n) <= flow_curve.TOLERANCE
    if q < flow_curve.Q_MAX:                                     # the largest such ratio
        assert flow_curve.chord_deviation(q * 1.01, n) > flow_curve.TOLERANCE
    eps, sigma = flow_curve.tabulate(1.0, 2.0, n)
    assert _worst_deviation(eps, sigma, 1.0, 2.0, n, *flow_curve.STRAIN_RANGE) <= 0.005


# ------------------------------------------------------------- LS-DYNA keyword parser
def parse_keyword(text):
    """[(keyword, [data lines])] of an LS-DYNA keyword file ('$' lines are comments)."""
    blocks = []
    for line in text.splitlines():
        assert len(line) <= 80, f"line over 80 characters: {line!r}"
        if line.startswith("$"):
            continue
        if line.startswith("*"):
            blocks.append((line.strip(), []))
        else:
            assert blocks, f"data line before the first keyword: {line!r}"
            blocks[-1][1].append(line)
    return blocks


def fields(line, width=10):
    """The numbers of a fixed-format card: every ``width``-character column holds one whole
    number, right-aligned (a number straddling two columns fails to parse)."""
    assert len(line) % width == 0, f"{line!r}: not whole {width}-character fields"
    chunks = [line[i:i + width] for i in range(0, len(line), width)]
    for c in chunks:
        assert c == c.rstrip() and c[0] == " ", f"{c!r} is not right-aligned in its column"
    return [float(c) for c in chunks]


def test_lsdyna_cards_parse_back(config, tmp_path):
    table = _table3_csv(config, tmp_path / "table3.csv", ["cwb19_t2_closed", "cwb10t1_9t2_fabric"])
    write_cards(table, "lsdyna", tmp_path / "dyna", config=config)
    for part_id, case in enumerate(["cwb19_t2_closed", "cwb10t1_9t2_fabric"], start=1):
        blocks = parse_keyword((tmp_path / "dyna" / case / "material.k").read_text())
        assert [k for k, _ in blocks] == ["*KEYWORD", "*MAT_PIECEWISE_LINEAR_PLASTICITY",
                                         "*DEFINE_CURVE", "*SECTION_BEAM", "*PART", "*END"]
        cards = dict(blocks)
        law = config["paper"]["table3"][case]
        r_o = config["cases"][case]["r_o"]
        mat = [fields(c) for c in cards["*MAT_PIECEWISE_LINEAR_PLASTICITY"]]
        assert len(mat) == 4 and all(len(c) == 8 for c in (mat[0], mat[2], mat[3]))
        mid, ro, E, pr, sigy = mat[0][:5]
        assert (mid, E, pr, sigy) == (part_id, law["E"], Material.nu, law["sigma_y"])
        rho = effective_density(config["cases"][case]["wires"], config["materials"], r_o)
        assert ro == pytest.approx(rho, rel=1e-3)
        lcss = mat[1][2]
        head, *points = cards["*DEFINE_CURVE"]
        assert fields(head)[0] == lcss                            # LCSS names the curve
        eps, sigma = np.array([fields(p, width=20) for p in points]).T
        assert np.all(np.diff(eps) > 0) and np.all(np.diff(sigma) >= 0)
        assert (eps[0], sigma[0]) == (0.0, law["sigma_y"])
        lo, hi = flow_curve.STRAIN_RANGE
        assert _worst_deviation(eps, sigma, law["sigma_y"], law["K"], law["n"], lo, hi) <= 0.005
        section = [fields(c) for c in cards["*SECTION_BEAM"]]
        secid, elform, _, qr, cst = section[0][:5]
        assert (secid, elform, qr, cst) == (part_id, 1, 3, 1)
        assert section[1][:4] == [pytest.approx(2 * r_o)] * 2 + [0.0, 0.0]   # solid circle
        heading, part = cards["*PART"]
        assert heading == case and fields(part)[:3] == [part_id] * 3


def test_field_formatting_keeps_ten_columns():
    for value in (8.12945e-10, 1e21, 15.7, 0.123456789012, 12345678.9, 3):
        text = lsdyna.field(value)
        assert len(text) == 10 and text[0] == " "
        assert float(text) == pytest.approx(value, rel=1e-3)
    with pytest.raises(ValueError, match="does not fit"):
        lsdyna.field(10**12)


# ------------------------------------------------------------- CalculiX and Abaqus decks
def _card_lines(text, keyword):
    lines = text.splitlines()
    i = next(k for k, line in enumerate(lines) if line.upper().startswith(keyword))
    return lines[i + 1:i + 3]


def test_keyword_decks_differ_only_where_the_solvers_do(config, tmp_path):
    """CIRC: CalculiX takes the diameter, Abaqus the radius; Abaqus also fixes the twist."""
    table = _table3_csv(config, tmp_path / "t.csv", ["cwb19_t2_fabric"])
    decks = {}
    for fmt in ("calculix", "abaqus"):
        write_cards(table, fmt, tmp_path / fmt, config=config)
        decks[fmt] = {f: (tmp_path / fmt / "cwb19_t2_fabric" / f).read_text()
                      for f in ("material.inp", "three_point.inp")}
    assert _card_lines(decks["calculix"]["material.inp"], "*BEAM SECTION")[0] == "10.6, 10.6"
    assert _card_lines(decks["abaqus"]["material.inp"], "*BEAM SECTION")[0] == "5.3"
    assert "SUPPORT_PIN, 4, 4" in decks["abaqus"]["three_point.inp"]
    assert "SUPPORT_PIN, 4, 4" not in decks["calculix"]["three_point.inp"]
    for deck in decks.values():
        mat = deck["material.inp"]
        assert _card_lines(mat, "*ELASTIC")[0] == "30.6, 0.39"
        assert "*DENSITY" in mat and "*PLASTIC" in mat
        tp = deck["three_point.inp"]
        for needed in ("*STEP, NLGEOM=YES", "*STATIC", "*NSET, NSET=LOAD", "LOAD, 2, 2, -30",
                       "*NODE PRINT, NSET=LOAD, FREQUENCY=1\nU, RF", "*INCLUDE, INPUT=material.inp"):
            assert needed in tp


# ------------------------------------------------------------- sources of r_o, nu, rho
def test_radius_density_and_nu_sources(config, tmp_path):
    cases = ["cwb19_t2_open_coarse", "cwb10t1_9t2_fabric"]
    table = _table3_csv(config, tmp_path / "t.csv", cases)
    write_cards(table, "calculix", tmp_path / "cx", config=config)
    readme = (tmp_path / "cx" / "cwb10t1_9t2_fabric" / "README.md").read_text()
    assert "cases.cwb10t1_9t2_fabric.r_o" in readme and "| r_o | 5.3 | mm |" in readme
    # the branch ROM's lumped mass of the same bundle (models/branch.py): 4.34e-9 x 19 x (0.7/r)^2
    from harnesspipe.models import branch
    rho = effective_density(config["cases"]["cwb19_t2_open_coarse"]["wires"], config["materials"], 7.05)
    assert rho == pytest.approx(branch.RHO_WIRE * 19 * (branch.R_WIRE / 7.05)**2)
    mixed = (10 * 4.97e-9 * 0.625**2 + 9 * 4.34e-9 * 0.7**2) / 5.3**2
    assert f"| rho | {mixed:.6g} | t/mm^3 |" in readme
    # the ROM's nu is Table 1's wire nu of the config
    assert {config["materials"][w]["nu"] for w in ("wire_type1", "wire_type2")} == {Material.nu}
    # columns win over the config
    table = _table3_csv(config, tmp_path / "t2.csv", ["cwb19_t2_closed"],
                        (",r_o,nu,rho", {"cwb19_t2_closed": ",6.0,0.3,1e-9"}))
    write_cards(table, "abaqus", tmp_path / "ab", config=config)
    mat = (tmp_path / "ab" / "cwb19_t2_closed" / "material.inp").read_text()
    assert _card_lines(mat, "*ELASTIC")[0] == "15.7, 0.3"
    assert _card_lines(mat, "*DENSITY")[0] == "1e-09"
    assert _card_lines(mat, "*BEAM SECTION")[0] == "6"


def test_campaign_test_geometry_sets_the_three_point_deck(config, tmp_path):
    table = _table3_csv(config, tmp_path / "t.csv", ["cwb19_t2_closed"],
                        (",span,deflection", {"cwb19_t2_closed": ",100,20"}))
    (folder,) = write_cards(table, "calculix", tmp_path / "cx", config=config)
    deck = (folder / "three_point.inp").read_text()
    assert "\n41, 100, 0.0, 0.0\n" in deck and "LOAD, 2, 2, -20\n" in deck
    assert "| span | 100 | mm | t.csv, column span |" in (folder / "README.md").read_text()


def test_campaign_rows_not_ok_are_skipped_with_a_note(config, tmp_path, capsys):
    table = tmp_path / "properties.csv"
    table.write_text("case,E,sigma_y,K,n,r_o,rho,status\n"
                     "demo_a,15.7,0.6,1.59,0.3,7.05,8e-10,ok\n"
                     "demo_b,,,,,,,failed\n")
    stale = tmp_path / "out" / "demo_b"
    stale.mkdir(parents=True)
    (stale / "material.k").write_text("from an earlier run")
    folders = write_cards(table, "lsdyna", tmp_path / "out", config=config)
    assert [f.name for f in folders] == ["demo_a"]
    assert f"{table}: case demo_b skipped: status 'failed' (no cards written)" in capsys.readouterr().out
    assert not stale.exists()
    assert "demo_b" in (tmp_path / "out" / "README.md").read_text()


# ------------------------------------------------------------- bad input on the CLI
def _cli(*args):
    r = subprocess.run([sys.executable, "-m", "harnesspipe", "cards", *map(str, args)],
                       capture_output=True, text=True)
    return r.returncode, r.stdout, r.stderr.strip().splitlines()


@pytest.mark.parametrize("content, fmt, message", [
    ("case,E,sigma_y,n\ncwb19_t2_closed,15.7,0.6,0.3\n", "calculix",
     "{t}: missing column K (expected columns case, E, sigma_y, K, n, optional r_o, nu, rho, span, "
     "deflection, status)"),
    ("case,E,sigma_y,K,n,span,deflection\ncwb19_t2_closed,15.7,0.6,1.59,0.3,100,50\n", "calculix",
     "{t}: line 2 (case cwb19_t2_closed): deflection = 50: expected a deflection below half the "
     "100 mm span (< 50 mm)"),
    ("case,E,sigma_y,K,n\ncwb19_t2_closed,15.7,0.6,1.59,0.3\ncwb19_t2_fabric,0,0.25,5.65,0.24\n",
     "lsdyna", "{t}: line 3 (case cwb19_t2_fabric): E = 0.0: expected a modulus [MPa] > 0"),
    ("case,E,sigma_y,K,n\ncwb19_t2_closed,15.7,0.6,1.59,0.3,0.4\n", "calculix",
     "{t}: line 2: 6 fields, expected 5 (case,E,sigma_y,K,n)"),
    ("case,E,sigma_y,K,n\nnew_bundle,15.7,0.6,1.59,0.3\n", "abaqus",
     "{t}: line 2 (case new_bundle): no r_o column and no case 'new_bundle' in config.yaml "
     "(cases, hifi.extra_cases): the section radius is unknown"),
    ("case,E,sigma_y,K,n\ncwb19_t2_closed,15.7,0.6,1.59,0.3\n", "nastran",
     "cards: --format 'nastran': expected one of calculix, abaqus, lsdyna"),
])
def test_bad_input_exits_2_with_one_line(tmp_path, content, fmt, message):
    table = tmp_path / "t.csv"
    table.write_text(content)
    code, out, err = _cli("--table", table, "--format", fmt, "--out", tmp_path / "out")
    assert code == 2 and out == ""
    assert err == [f"harnesspipe: error: {message.format(t=table)}"]
    assert not (tmp_path / "out").exists()


def test_parser_names_the_formats_without_importing_model_code():
    from harnesspipe.cards import FORMATS
    from harnesspipe.commands import cards as command
    assert command.FORMAT_CHOICES == "|".join(FORMATS)
    probe = subprocess.run([sys.executable, "-c", "import sys, harnesspipe.cli as c; c.build_parser(); "
                            "print('harnesspipe.cards' in sys.modules, 'numba' in sys.modules)"],
                           capture_output=True, text=True, check=True)
    assert probe.stdout.split() == ["False", "False"]


def test_missing_table_file_exits_2(tmp_path):
    code, _, err = _cli("--table", tmp_path / "none.csv", "--format", "calculix",
                        "--out", tmp_path / "out")
    assert code == 2
    assert err[-1] == f"harnesspipe cards: error: argument --table: {tmp_path / 'none.csv'}: no such file"
    assert not (tmp_path / "out").exists()


def test_default_strain_range_brackets_the_rom_reference_strains(config):
    """The guarantee covers the plastic strains the ROM fit works with (rom.reference_strains)."""
    lo, hi = flow_curve.STRAIN_RANGE
    strains = config["rom"]["reference_strains"]
    assert lo < min(strains) and max(strains) < hi and math.isclose(hi, 1.0)
