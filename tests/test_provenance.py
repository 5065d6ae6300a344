"""Rules rerun when the code they can reach changes (provenance.code_hash), and only then.

A rule's ``code`` param hashes the import closure of the stage module it runs, so a hand-kept
file list cannot drift: changing ``report/plots.py`` changes the hash of every rule that
draws, and a file no rule's module reaches changes none."""
import re
import shutil
from pathlib import Path

import pytest

from harnesspipe.provenance import PACKAGE_DIR, code_hash, import_closure

ROOT = Path(__file__).resolve().parents[1]
CODE_PARAM = re.compile(r'code_hash\("([\w.]+)", "([\w/.]+)"\)')


def _rule_hashes():
    """(module, entry file) of every code_hash in the workflow's rule files."""
    calls = set()
    for smk in sorted((ROOT / "workflow" / "rules").glob("*.smk")):
        calls.update(CODE_PARAM.findall(smk.read_text()))
    return sorted(calls)


def test_every_rule_param_hashes_an_import_closure():
    calls = _rule_hashes()
    modules = {m for m, _ in calls}
    assert {"harnesspipe.stages.tensile", "harnesspipe.stages.rom", "harnesspipe.stages.hifi_chain",
            "harnesspipe.stages.branch", "harnesspipe.stages.data",
            "harnesspipe.report.html"} <= modules
    for smk in (ROOT / "workflow" / "rules").glob("*.smk"):
        assert "code=source_hash(" not in smk.read_text(), smk.name   # no hand-kept lists


def test_the_closure_follows_imports_inside_functions():
    files = {p.relative_to(PACKAGE_DIR).as_posix() for p in import_closure("harnesspipe.stages.tensile")}
    # fit.png is drawn by report/plots.py, imported inside fit_component; the fit's kernels
    assert {"stages/tensile.py", "report/plots.py", "models/tensile.py", "calibrate/tensile.py",
            "fe/materials/hardening.py", "__init__.py"} <= files
    assert "models/hifi.py" not in files and "stages/branch.py" not in files


@pytest.fixture
def package_copy(tmp_path):
    copy = tmp_path / "harnesspipe"
    shutil.copytree(PACKAGE_DIR, copy, ignore=shutil.ignore_patterns("__pycache__"))
    return copy


def test_a_changed_plotting_module_reruns_every_rule_that_draws(package_copy):
    calls = _rule_hashes()
    before = {c: code_hash(*c, root=package_copy) for c in calls}
    assert before == {c: code_hash(*c) for c in calls}          # the copy hashes as the package
    with open(package_copy / "report" / "plots.py", "a") as f:
        f.write("\n# a change\n")
    changed = {c for c in calls if code_hash(*c, root=package_copy) != before[c]}
    # all but the data check, the campaign's virtual tests (shapes.png drawn by stages/hifi.py
    # itself) and the solver cards
    quiet = {"harnesspipe.stages.data", "harnesspipe.campaign.virtual", "harnesspipe.cards"}
    drawing = {c for c in calls if c[0] not in quiet}
    assert changed == drawing


def test_an_unreached_module_reruns_nothing(package_copy):
    calls = _rule_hashes()
    before = {c: code_hash(*c, root=package_copy) for c in calls}
    (package_copy / "commands" / "rom.py").write_text("# the ROM command line, no rule runs it\n")
    assert {c: code_hash(*c, root=package_copy) for c in calls} == before
