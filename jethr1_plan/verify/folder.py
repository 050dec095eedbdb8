"""``jethr1 verify PATH``: a plan folder, one of its trajectory files, or a walk folder, re-checked
by the verifier of its kind."""

from __future__ import annotations

from pathlib import Path

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_folder import read_json, read_plan, trajectory_files
from jethr1_plan.verify.common import Failure, csv_header
from jethr1_plan.verify.plan import verify_plan
from jethr1_plan.verify.walk import is_walk, verify_walk

__all__ = ["verify_path"]


def verify_path(path: Path, scenario: Path | None = None) -> tuple[int, list[Failure], str]:
    """Verify a ``trajectory.csv``, a ``trajectory.mcap``, a plan folder (both files, checked against
    each other) or a walk folder; returns (rows, failures, what was checked).

    Raises:
        InputError: a missing, unreadable or malformed file, a ``--scenario`` that does not exist.
    """
    folder, files = trajectory_files(path)
    summary_path = folder / "summary.json"
    summary = read_json(summary_path) if summary_path.is_file() else None
    if is_walk(summary, None if summary is not None else csv_header(folder / "trajectory.csv")):
        if summary is None:
            raise InputError(str(summary_path), "", "a walk is verified against its summary.json, which is missing")
        if scenario is not None:
            raise InputError(str(scenario), "--scenario", "a walk has no scenario (its summary.json states the walk)")
        return verify_walk(folder, summary, files)
    plan = read_plan(path, scenario)
    n, failures = verify_plan(plan)
    what = str(path) if len(plan.files) > 1 else str(plan.files[0])
    return n, failures, what
