"""The files of a plan folder (CONTRACT.md): summary.json, trajectory.csv, trajectory.mcap, written atomically.

The trajectory is re-checked by :func:`jethr1_plan.verify.verify_rows` before anything is written: a
plan that fails its own independent check is a bug and leaves no file behind.
"""

from __future__ import annotations

from pathlib import Path

from jethr1_plan.errors import SelfCheckFailed
from jethr1_plan.io.atomic import staged_directory
from jethr1_plan.io.json_text import json_text
from jethr1_plan.planning.results import PlanResult
from jethr1_plan.scenario import Scenario

__all__ = ["PLAN_FILES", "plan_folder", "self_check", "write_plan_outputs", "write_summary_only"]

#: the files ``jethr1`` writes into a plan folder (any other file there is the user's and is kept)
PLAN_FILES = frozenset({"trajectory.csv", "trajectory.mcap", "summary.json", "simulation.json", "simulation.mcap"})


def self_check(csv_text: str, result: PlanResult, summary: dict, strict_torque: bool) -> None:
    """Run ``verify`` on the trajectory before anything is written.

    Raises:
        SelfCheckFailed: the plan fails its own re-check (a bug).
    """
    from jethr1_plan.io.trajectory_csv import read_trajectory_csv
    from jethr1_plan.verify import verify_rows

    _, failures = verify_rows(read_trajectory_csv(csv_text, robot=result.robot), result.robot, summary=summary,
                              scenario=result.scenario, torque_limits=strict_torque, max_failures=5)
    if failures:
        raise SelfCheckFailed("the planned trajectory fails its own re-check: " + "; ".join(map(str, failures)))


def plan_folder(outdir: Path, scenario: Scenario) -> Path:
    """OUTDIR/<scenario stem>/."""
    return Path(outdir) / Path(scenario.source).stem


def write_plan_outputs(result: PlanResult, outdir: Path, summary: dict, trajectory: bool = True,
                       strict_torque: bool = False) -> tuple[Path, list[str]]:
    """Write summary.json (and the trajectory files) into OUTDIR/<stem>/ atomically.

    Returns the folder and the names of files in it that jethr1 did not write (kept).
    """
    from jethr1_plan.io.mcap import trajectory_mcap
    from jethr1_plan.io.trajectory_csv import trajectory_csv

    final = plan_folder(outdir, result.scenario)
    with staged_directory(final, PLAN_FILES) as staging:
        tmp = staging.path
        if trajectory and result.rows is not None:
            text = trajectory_csv(result.robot, result.rows)
            if result.feasible:
                self_check(text, result, summary, strict_torque)
            (tmp / "trajectory.csv").write_text(text)
            (tmp / "trajectory.mcap").write_bytes(trajectory_mcap(result.robot, result.rows, result.scenario.cartons,
                                                                  [st.path_m for st in result.steps]))
        (tmp / "summary.json").write_text(json_text(summary))
    return final, staging.kept


def write_summary_only(scenario: Scenario, outdir: Path, summary: dict | None) -> tuple[Path, list[str]]:
    """summary.json alone (an infeasible plan), atomically; the folder and the files kept in it."""
    final = plan_folder(outdir, scenario)
    if summary is None:
        return final, []
    with staged_directory(final, PLAN_FILES) as staging:
        (staging.path / "summary.json").write_text(json_text(summary))
    return final, staging.kept
