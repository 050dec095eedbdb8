"""A plan folder, ``OUTDIR/<scenario stem>/``: ``trajectory.csv``, ``trajectory.mcap`` and
``summary.json`` (and a rehearsal's ``simulation.json`` / ``simulation.mcap``), written atomically and
read back in one place: :func:`write_plan` and :func:`read_plan`. Every command that reads a plan
(``verify``, ``simulate``) reads it through :func:`read_plan`.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_csv import read_trajectory_csv, table_csv
from jethr1_plan.files.plan_mcap import read_trajectory_mcap, trajectory_mcap
from jethr1_plan.files.plan_table import columns, plan_table
from jethr1_plan.io.atomic import staged_directory
from jethr1_plan.io.json_text import json_text
from jethr1_plan.planning.results import PlanResult
from jethr1_plan.robot.model import RobotModel, load_robot
from jethr1_plan.scenario import Scenario, load_scenario, load_scenario_text
from jethr1_plan.swing_path import Carton

__all__ = ["PLAN_FILES", "PlanFolder", "plan_folder", "read_json", "read_plan", "write_plan", "write_summary_only"]

#: the files ``jethr1`` writes into a plan folder (any other file there is the user's and is kept)
PLAN_FILES = frozenset({"trajectory.csv", "trajectory.mcap", "summary.json", "simulation.json", "simulation.mcap"})
TRAJECTORY_FILES = ("trajectory.csv", "trajectory.mcap")


def plan_folder(outdir: Path, scenario: Scenario) -> Path:
    """OUTDIR/<scenario stem>/."""
    return Path(outdir) / Path(scenario.source).stem


def write_plan(result: PlanResult, outdir: Path, summary: dict, trajectory: bool = True,
               check: Callable[[str], None] | None = None) -> tuple[Path, list[str]]:
    """Write summary.json (and the trajectory files) into OUTDIR/<stem>/ atomically.

    ``check`` is given the CSV text of a feasible plan before anything is written (the self-check);
    if it raises, nothing is written. Returns the folder and the names of files in it that jethr1
    did not write (kept).
    """
    final = plan_folder(outdir, result.scenario)
    with staged_directory(final, PLAN_FILES) as staging:
        tmp = staging.path
        if trajectory and result.rows is not None:
            table = plan_table(result.robot, result.rows)  # both files carry this very table
            text = table_csv(table, columns(result.robot))
            if result.feasible and check is not None:
                check(text)
            (tmp / "trajectory.csv").write_text(text)
            (tmp / "trajectory.mcap").write_bytes(trajectory_mcap(result.robot, result.rows, result.scenario.cartons,
                                                                  [st.path_m for st in result.steps], table))
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


def read_json(path: Path) -> dict:
    """A JSON object from ``path``.

    Raises:
        InputError: unreadable, not JSON, or not an object.
    """
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(str(path), "", f"cannot read: {str(exc).splitlines()[0][:100]}") from None
    if not isinstance(doc, dict):
        raise InputError(str(path), "", "expected a JSON object")
    return doc


@dataclass
class PlanFolder:
    """A written plan as its readers see it (nothing of the planner's state)."""

    folder: Path
    files: list[Path]  # the trajectory files read, in the order given
    summary: dict | None  # summary.json (None where the folder has none)
    robot: RobotModel
    scenario: Scenario | None  # the scenario it was planned from, where it can be found
    tables: dict[Path, dict[str, np.ndarray]] = field(default_factory=dict)  # per file, its columns
    swing_paths: dict[Path, list[np.ndarray]] = field(default_factory=dict)  # per MCAP, its swing paths

    @property
    def table(self) -> dict[str, np.ndarray]:
        """The plan's columns: the CSV's where it was read, else the MCAP's."""
        csv = [f for f in self.files if f.suffix == ".csv"]
        return self.tables[csv[0] if csv else self.files[0]]

    @property
    def cartons(self) -> tuple[Carton, ...]:
        """The terrain the plan stands on: the scenario's, else the one summary.json records.

        Raises:
            InputError: summary.json's terrain is malformed.
        """
        if self.scenario is not None:
            return tuple(self.scenario.cartons)
        src = str(self.folder / "summary.json")
        try:
            return tuple(Carton(tuple(c["top_centre_m"]), tuple(c["size_m"]))
                         for c in (self.summary or {}).get("terrain", {}).get("cartons", []))
        except (KeyError, TypeError, ValueError, AttributeError):
            raise InputError(src, "terrain", "malformed cartons") from None


def trajectory_files(path: Path, suffixes: tuple[str, ...] = (".csv", ".mcap")) -> tuple[Path, list[Path]]:
    """(folder, trajectory files) of a plan folder or of one trajectory file.

    Raises:
        InputError: no such file, or no trajectory in the folder.
    """
    path = Path(path)
    if path.is_dir():
        files = [path / f for f in TRAJECTORY_FILES if (path / f).is_file() and Path(f).suffix in suffixes]
        if not files:
            wanted = " or ".join(f for f in TRAJECTORY_FILES if Path(f).suffix in suffixes)
            raise InputError(str(path), "", f"no {wanted} in this folder")
        return path, files
    if path.is_file():
        if path.suffix not in suffixes:
            raise InputError(str(path), "", "expected a .csv or .mcap trajectory, or a plan folder")
        return path.parent, [path]
    raise InputError(str(path), "", "no such file (expected trajectory.csv, trajectory.mcap or their folder)")


def plan_scenario(folder: Path, summary: dict | None, explicit: Path | None = None) -> Scenario | None:
    """The scenario of a written plan: ``explicit`` (must exist), else the file summary.json names (as
    written, then beside summary.json), else the copy summary.json holds."""
    if explicit is not None:
        if not Path(explicit).is_file():
            raise InputError(str(explicit), "--scenario", "no such file")
        return load_scenario(explicit)
    if not summary:
        return None
    named = summary.get("scenario_file")
    if isinstance(named, str) and named:
        for candidate in (Path(named), folder / named):
            if candidate.is_file():
                return load_scenario(candidate)
    text = summary.get("scenario_yaml")
    if isinstance(text, str) and text:
        return load_scenario_text(text, f"{folder / 'summary.json'} (scenario_yaml)")
    return None


def plan_robot(summary: dict | None, scenario: Scenario | None) -> RobotModel:
    """The robot a plan was made for: summary.json's robot YAML where it still exists, else the
    scenario's robot, else summary.json's robot name, else Jet-HR1."""
    name = (summary or {}).get("robot_yaml") or (summary or {}).get("robot") or (
        scenario.robot if scenario else "jethr1")
    if summary and not (isinstance(name, str) and Path(name).is_file()) and scenario is not None:
        name = scenario.robot  # the plan moved with its summary: the scenario names the robot
    return load_robot(name)


def read_plan(path: Path, scenario: Path | None = None, suffixes: tuple[str, ...] = (".csv", ".mcap")) -> PlanFolder:
    """Read a plan folder (or one of its trajectory files): summary, scenario, robot and the columns
    of each trajectory file with a suffix in ``suffixes``.

    Raises:
        InputError: a missing, unreadable or malformed file, a ``scenario`` that does not exist.
    """
    folder, files = trajectory_files(path, suffixes)
    summary_path = folder / "summary.json"
    summary = read_json(summary_path) if summary_path.is_file() else None
    sc = plan_scenario(folder, summary, scenario)
    robot = plan_robot(summary, sc)
    plan = PlanFolder(folder, files, summary, robot, sc)
    for f in files:
        try:
            data = f.read_bytes()
        except OSError as exc:
            raise InputError(str(f), "", f"cannot read: {exc.strerror or exc}") from None
        if f.suffix == ".csv":
            try:
                text = data.decode("utf-8")
            except UnicodeDecodeError:
                raise InputError(str(f), "", "not UTF-8 text") from None
            plan.tables[f] = read_trajectory_csv(text, str(f), robot, complete=True)
        else:
            plan.tables[f], plan.swing_paths[f] = read_trajectory_mcap(data, str(f), robot)
    return plan
