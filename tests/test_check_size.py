"""tools/check_size.py (run by ``make lint``) holds every room of the package to its size: no module over 400
lines, no function over 80. It passes on this checkout and fails on a planted module or function too big."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "check_size.py"
sys.path.insert(0, str(ROOT / "tools"))
import check_size  # noqa: E402


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(TOOL), *args], capture_output=True, text=True, check=False)


def _package(tmp_path: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        p = tmp_path / "jethr1_plan" / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text, encoding="utf-8")
    return tmp_path


def _function(name: str, body_lines: int, indent: str = "") -> str:
    """A function of 1 + body_lines lines (its def line and its body)."""
    return f"{indent}def {name}():\n" + "".join(f"{indent}    x{i} = {i}\n" for i in range(body_lines))


def test_this_checkout_is_within_the_limits() -> None:
    r = _run()
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout == ""


def test_a_planted_long_module_fails(tmp_path: Path) -> None:
    root = _package(tmp_path, {"ok.py": "x = 1\n" * 400, "big.py": "x = 1\n" * 401})
    r = _run("--root", str(root))
    assert r.returncode == 1
    assert r.stdout.splitlines() == ["jethr1_plan/big.py has 401 lines (at most 400)"]


def test_a_planted_long_function_or_method_fails(tmp_path: Path) -> None:
    text = (_function("fits", 79) + _function("too_long", 80)
            + "class Room:\n" + _function("method", 80, "    ") + _function("short", 3, "    "))
    root = _package(tmp_path, {"sub/mod.py": text})
    r = _run("--root", str(root))
    assert r.returncode == 1
    assert r.stdout.splitlines() == [
        "jethr1_plan/sub/mod.py:81 too_long has 81 lines (at most 80)",
        "jethr1_plan/sub/mod.py:163 Room.method has 81 lines (at most 80)",
    ]


def test_nested_functions_count_inside_their_outer_function() -> None:
    text = "def outer():\n" + _function("inner", 85, "    ") + "    return inner\n"
    found = {name: n for name, _, n in check_size.functions(__import__("ast").parse(text))}
    assert found == {"outer": 88, "outer.inner": 86}


def test_the_allow_list_skips_only_what_it_names(tmp_path: Path) -> None:
    big = "x = 1\n" * 500
    root = _package(tmp_path, {"files/any.py": big, "planning/plan.py": big, "planning/other.py": big})
    allowed = frozenset({"jethr1_plan/files/", "jethr1_plan/planning/plan.py"})
    modules, functions = check_size.problems(root, allowed)
    assert modules == ["jethr1_plan/planning/other.py has 500 lines (at most 400)"]
    assert functions == []
    modules, _ = check_size.problems(root)  # the shipped allow-list is empty
    assert len(modules) == 3
