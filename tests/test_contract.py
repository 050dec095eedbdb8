"""docs/contract.md is what the code does: the page is regenerated from the commands, the column and topic
contracts and the exit codes, and must match; the exit codes it lists are the ones the CLI returns."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from jethr1_plan.errors import EXIT_CODES, InfeasiblePlan, InputError, Jethr1Error

ROOT = Path(__file__).resolve().parents[1]


def test_contract_page_matches_the_code() -> None:
    """`python tools/contract.py --check` exits 0 only when docs/contract.md equals what the code generates."""
    r = subprocess.run([sys.executable, str(ROOT / "tools" / "contract.py"), "--check"], capture_output=True, text=True,
                       cwd=ROOT, check=False)
    assert r.returncode == 0, r.stdout + r.stderr


def test_every_error_class_exit_code_is_documented() -> None:
    """Each expected failure maps to a code the contract explains."""
    classes = [InputError, InfeasiblePlan, Jethr1Error]
    for cls in classes:
        assert cls.exit_code in EXIT_CODES, cls


def test_bad_input_exits_with_the_documented_code(tmp_path: Path) -> None:
    """A scenario that is not UTF-8 and a folder that does not exist are bad input (2): one line, nothing written."""
    bad = tmp_path / "bad.yaml"
    bad.write_bytes(b"\xff\xfe: [")
    jethr1 = [sys.executable, "-c", "from jethr1_plan.cli import entry; entry()"]
    for args in (["plan", str(bad), "-o", str(tmp_path / "out")], ["verify", str(tmp_path / "missing")]):
        r = subprocess.run([*jethr1, *args], capture_output=True, text=True, check=False)
        assert r.returncode == 2, (args, r.stderr)
        assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not (tmp_path / "out").exists()
