"""``jethr1 verify PATH``: a plan folder, one of its trajectory files, or a walk folder, re-checked
by the verifier of its kind."""

from __future__ import annotations

from pathlib import Path

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_folder import TRAJECTORY_FILES, read_json
from jethr1_plan.folders.plan import read_plan
from jethr1_plan.verify.common import Failures, csv_header, is_walk
from jethr1_plan.verify.plan import verify_plan

__all__ = ["verify_path"]


def verify_path(path: Path, scenario: Path | None = None) -> tuple[int, Failures, str, list[Path]]:
    """Verify a ``trajectory.csv``, a ``trajectory.mcap``, a plan folder (every file, the CSV and the
    MCAP checked against each other) or a walk folder; returns (rows, failures, what was checked,
    every file read).

    Raises:
        InputError: a missing, unreadable, malformed or inconsistent file, a ``--scenario`` that does
            not exist (see :func:`~jethr1_plan.folders.plan.read_plan`).
    """
    path = Path(path)
    folder = path if path.is_dir() else path.parent
    summary_path = folder / "summary.json"
    summary = read_json(summary_path) if summary_path.is_file() else None
    if is_walk(summary, None if summary is not None else csv_header(folder / "trajectory.csv")):
        if summary is None:
            raise InputError(str(summary_path), "", "a walk is verified against its summary.json, which is missing")
        if scenario is not None:
            raise InputError(str(scenario), "--scenario", "a walk has no scenario (its summary.json states the walk)")
        from jethr1_plan.verify.walk import verify_walk  # (the walk's verifier and what it needs: walks only)

        files = [folder / f for f in TRAJECTORY_FILES if (folder / f).is_file()]
        n, failures, what = verify_walk(folder, summary, files)
        return n, failures, what, [summary_path, folder / "trajectory.csv"]
    plan = read_plan(path, scenario)
    n, failures = verify_plan(plan)
    what = str(path) if len(plan.files) > 1 else str(plan.files[0])
    return n, failures, what, plan.checked
