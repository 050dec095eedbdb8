"""tools/check_vocabulary.py (``make lint``): the plan's column names spelled in one module, and files/
importing no planner. The checker passes on the code and fails on a planted violation of each rule."""

from __future__ import annotations

import importlib.util
import shutil
import sys

from tests.conftest import ROOT

_spec = importlib.util.spec_from_file_location("check_vocabulary", ROOT / "tools" / "check_vocabulary.py")
assert _spec is not None and _spec.loader is not None
cv = importlib.util.module_from_spec(_spec)
sys.modules["check_vocabulary"] = cv
_spec.loader.exec_module(cv)


def _vocabulary() -> set[str]:
    from jethr1_plan.records.plan_columns import FIXED_COLUMNS, SHARED_WORDS

    return set(FIXED_COLUMNS) - set(SHARED_WORDS)


def _tree(tmp_path):
    """A copy of the package's sources to plant violations in."""
    shutil.copytree(ROOT / "jethr1_plan", tmp_path / "jethr1_plan",
                    ignore=shutil.ignore_patterns("__pycache__", "*.json"))
    return tmp_path


def test_the_code_holds():
    assert cv.problems(ROOT, _vocabulary()) == []
    assert len(cv.stray_literals(ROOT, _vocabulary())) <= cv.MAX_STRAYS


def test_column_literals_beyond_the_limit_fail(tmp_path):
    root = _tree(tmp_path)
    before = len(cv.stray_literals(root, _vocabulary()))
    extra = cv.MAX_STRAYS - before + 1
    (root / "jethr1_plan" / "verify" / "planted.py").write_text(
        '"""A module that spells a column (its docstring says zmp_margin_m: not counted)."""\n'
        + "".join(f'X{k} = table["zmp_margin_m"]\n' for k in range(extra)))
    found = cv.problems(root, _vocabulary())
    assert any("literals of plan column names" in p and "planted.py" in p for p in found)
    assert len(cv.stray_literals(root, _vocabulary())) == before + extra


def test_a_docstring_naming_a_column_is_not_a_literal(tmp_path):
    root = _tree(tmp_path)
    (root / "jethr1_plan" / "verify" / "planted.py").write_text('"""pelvis_x_m"""\n\n\ndef f():\n    "pelvis_x_m"\n')
    assert not [s for s in cv.stray_literals(root, _vocabulary()) if "planted" in s[0]]


def test_a_column_missing_from_its_home_fails(tmp_path):
    root = _tree(tmp_path)
    home = root / cv.HOME
    home.write_text(home.read_text().replace('"yaw_momentum_nms"', '"yaw_momentum"'))
    assert any("does not spell the columns yaw_momentum_nms" in p for p in cv.problems(root, _vocabulary()))


def test_files_importing_the_planner_fail(tmp_path):
    root = _tree(tmp_path)
    files = root / "jethr1_plan" / "files"
    (files / "planted.py").write_text("from jethr1_plan.planning.results import PlanResult\n")
    (files / "planted_relative.py").write_text("def f():\n    from ..scenario import load_scenario\n")
    (files / "planted_fine.py").write_text("from jethr1_plan.records.plan_rows import Rows\nimport jethr1_plan.io\n")
    found = cv.problems(root, _vocabulary())
    assert any("planted.py" in p and "jethr1_plan.planning.results" in p for p in found)
    assert any("planted_relative.py" in p and "jethr1_plan.scenario" in p for p in found)
    assert not any("planted_fine.py" in p for p in found)


def test_the_retired_spelling_of_the_thrust_limit_fails(tmp_path):
    """``max_thrust_n`` anywhere in the package, a shipped robot or a config fails, but where the input reader
    names it as renamed."""
    root = _tree(tmp_path)
    for folder in ("robots", "configs"):
        shutil.copytree(ROOT / folder, root / folder)
    assert not cv.retired_spellings(root)
    (root / "jethr1_plan" / "sim" / "planted.py").write_text("def f(fan):\n    return fan.max_thrust_n\n")
    bot = root / "robots" / "jethr1" / "jethr1.yaml"
    bot.write_text(bot.read_text().replace("thrust_max_n", "max_thrust_n", 1))
    found = cv.problems(root, _vocabulary())
    assert any("sim/planted.py:2: max_thrust_n" in p for p in found)
    assert any("robots/jethr1/jethr1.yaml" in p and "max_thrust_n" in p for p in found)
    assert not any(cv.RETIRED_HOME in p for p in found)
