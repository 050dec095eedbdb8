"""A plan folder, ``OUTDIR/<scenario stem>/``: ``trajectory.csv``, ``trajectory.mcap`` and
``summary.json`` (and a rehearsal's ``simulation.json`` / ``simulation.mcap``), written atomically and
read back in one place: :func:`write_plan` and :func:`read_plan`. Every command that reads a plan
(``verify``, ``simulate``) reads it through :func:`read_plan`.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_csv import read_trajectory_csv, table_csv
from jethr1_plan.files.plan_mcap import read_trajectory_mcap, trajectory_mcap
from jethr1_plan.files.plan_table import columns, plan_table
from jethr1_plan.io.atomic import staged_directory
from jethr1_plan.io.json_text import json_text
from jethr1_plan.io.json_text import read_json as read_json_document
from jethr1_plan.io.yaml_input import check_schema
from jethr1_plan.planning.results import PlanResult
from jethr1_plan.robot.model import RobotModel, load_robot
from jethr1_plan.scenario import MAX_FILE_BYTES, MAX_ROWS, POLICIES, Scenario, load_scenario, load_scenario_text
from jethr1_plan.swing_path import Carton

__all__ = ["PLAN_FILES", "SIMULATION_FILES", "SUMMARY_SCHEMA", "PlanFolder", "folder_kind", "plan_folder", "read_json",
           "read_plan", "trajectory_files", "write_plan", "write_summary_only"]

#: the files ``jethr1 simulate`` writes into a plan folder (both, or neither)
SIMULATION_FILES = frozenset({"simulation.json", "simulation.mcap"})
#: the files ``jethr1`` writes into a plan folder (any other file there is the user's and is kept)
PLAN_FILES = frozenset({"trajectory.csv", "trajectory.mcap", "summary.json"}) | SIMULATION_FILES
TRAJECTORY_FILES = ("trajectory.csv", "trajectory.mcap")


def plan_folder(outdir: Path, scenario: Scenario) -> Path:
    """OUTDIR/<scenario stem>/."""
    return Path(outdir) / Path(scenario.source).stem


def write_plan(result: PlanResult, outdir: Path, summary: dict, trajectory: bool = True,
               check: Callable[[str], None] | None = None, folder: Path | None = None,
               extra: Mapping[str, bytes] | None = None, own: frozenset[str] = PLAN_FILES) -> tuple[Path, list[str]]:
    """Write summary.json (and the trajectory files) into OUTDIR/<stem>/ (or ``folder``) atomically,
    with the ``extra`` files (name → bytes: a route's own files) in the same commit; ``own`` names every
    file the command writes into such a folder (:func:`~jethr1_plan.io.atomic.staged_directory`).

    ``check`` is given the CSV text of a feasible plan before anything is written (the self-check);
    if it raises, nothing is written. Returns the folder and the names of files in it that jethr1
    did not write (kept).
    """
    final = plan_folder(outdir, result.scenario) if folder is None else Path(folder)
    with staged_directory(final, own) as staging:
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
        for name, data in (extra or {}).items():
            (tmp / name).write_bytes(data)
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
    """A JSON object from ``path`` (bounded in size and depth; :func:`jethr1_plan.io.json_text.read_json`).

    Raises:
        InputError: unreadable, not JSON, nested too deeply, or not an object.
    """
    return read_json_document(path)


_vec3 = {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}
_unit = {"type": "number", "minimum": 0, "maximum": 0.9}
#: what the readers of a plan folder take from summary.json, and the types and bounds it must have
#: there (every other key is free: it is a report)
SUMMARY_SCHEMA = {
    "type": "object",
    "properties": {
        "robot": {"type": "string", "maxLength": 1000},
        "robot_yaml": {"type": ["string", "null"], "maxLength": 4096},
        "scenario_file": {"type": ["string", "null"], "maxLength": 4096},
        "scenario_yaml": {"type": ["string", "null"], "maxLength": MAX_FILE_BYTES},
        "feasible": {"type": "boolean"},
        "row_count": {"type": "integer", "minimum": 0, "maximum": MAX_ROWS},
        "thrust_max_n": {"type": "number", "minimum": 0, "maximum": 1e4},
        "trajectory": {"type": "object", "properties": {
            "rows": {"type": "integer", "minimum": 0, "maximum": MAX_ROWS},
            "rate_hz": {"type": "number", "exclusiveMinimum": 0, "maximum": 1000}}},
        "balance": {"type": "object", "properties": {
            "policy": {"enum": list(POLICIES)},
            "sole_margin_m": {"type": "number", "minimum": 0, "maximum": 0.1},
            "tolerance": {"type": "object", "properties": {"thrust_error": _unit, "mass_error": _unit,
                                                           "com_error_m": {"type": "number", "minimum": 0,
                                                                           "maximum": 0.1}}}}},
        "terrain": {"type": "object", "properties": {"cartons": {
            "type": "array", "maxItems": 200, "items": {
                "type": "object", "required": ["top_centre_m", "size_m"],
                "properties": {"top_centre_m": _vec3, "size_m": _vec3}}}}},
    },
}


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
    checked: list[Path] = field(default_factory=list)  # every file read: trajectories, summary, scenario

    @property
    def table(self) -> dict[str, np.ndarray]:
        """The plan's columns: the CSV's where it was read, else the MCAP's."""
        csv = [f for f in self.files if f.suffix == ".csv"]
        return self.tables[csv[0] if csv else self.files[0]]

    @property
    def cartons(self) -> tuple[Carton, ...]:
        """The terrain the plan stands on: the scenario's, else the one summary.json records."""
        if self.scenario is not None:
            return tuple(self.scenario.cartons)
        return tuple(Carton(tuple(c["top_centre_m"]), tuple(c["size_m"]))
                     for c in (self.summary or {}).get("terrain", {}).get("cartons", []))

    def problems(self) -> list[tuple[str, int, str]]:
        """Where the files disagree with themselves or with summary.json: (file, row, problem), the
        first of each kind: a row count other than summary.json's, a time that does not increase,
        a number that is not finite where a number is required. ``verify`` reports these as failing
        rows (exit 5); :func:`read_plan` with ``strict`` refuses the folder (exit 2)."""
        out = []
        rows = _summary_rows(self.summary)
        for f, table in self.tables.items():
            n = len(table["time_s"])
            if rows is not None and n != rows:
                out.append((f.name, min(n, rows), f"{n} rows, summary.json says {rows}"))
            t = table["time_s"].astype(float)
            back = np.flatnonzero(~(np.diff(t) > 0))
            if len(back):
                out.append((f.name, int(back[0]) + 1, f"time {t[back[0] + 1]:.9g} s does not come after "
                            f"{t[back[0]]:.9g} s"))
            for name, col in table.items():
                if col.dtype.kind != "f" or name in OPTIONAL_NUMBER_COLUMNS or name.startswith(OPTIONAL_PREFIXES):
                    continue
                bad = np.flatnonzero(~np.isfinite(col))
                if len(bad):
                    out.append((f.name, int(bad[0]), f"{name} is empty or not a finite number"))
                    break
        return out


#: number columns that may be empty (NaN): no swing sole in a transfer, no thrust window, no tolerance
OPTIONAL_PREFIXES = ("swing_", "thrust_window_")
OPTIONAL_NUMBER_COLUMNS = frozenset({"zmp_margin_m", "tolerance_share"})


def _summary_rows(summary: dict | None) -> int | None:
    traj = (summary or {}).get("trajectory")
    rows = traj.get("rows") if isinstance(traj, dict) else None
    return int(rows) if isinstance(rows, int | float) and not isinstance(rows, bool) else None


def folder_kind(folder: Path, summary: dict | None) -> str:
    """What wrote ``folder``: ``plan``, ``walk`` (``jethr1 walk``), ``balance-space``, ``sweep`` (a
    ditch curve, a comparison, a walk sweep) or ``unknown``."""
    names = {p.name for p in folder.iterdir()} if folder.is_dir() else set()
    if (summary or {}).get("kind") == "walk" or {"yaw.png", "kappa.png"} <= names:
        return "walk"
    if "balance_space.csv" in names or "bounds_m" in (summary or {}):
        return "balance-space"
    if names & {"ditch_curve.json", "compare.json", "pareto.json", "walk_sweep.json"}:
        return "sweep"
    if names & set(TRAJECTORY_FILES) or "scenario_yaml" in (summary or {}):
        return "plan"
    return "unknown"


_NOT_A_PLAN = {
    "walk": "a walk's folder (jethr1 walk), not a plan's: {what}",
    "balance-space": "a balance space's folder (jethr1 balance-space), not a plan's: {what}",
    "sweep": "a study's folder (ditch-curve, compare or walk-sweep), not a plan's: {what}",
    "unknown": "not a plan folder (no trajectory.csv, trajectory.mcap or summary.json in it): {what}",
}


def trajectory_files(path: Path, suffixes: tuple[str, ...] = (".csv", ".mcap"), purpose: str = "") -> tuple[
        Path, list[Path]]:
    """(folder, trajectory files) of a plan folder or of one trajectory file. A folder must hold
    a whole plan: trajectory.csv, trajectory.mcap and summary.json.

    Raises:
        InputError: no such file, not a file, a folder that is not a whole plan's.
    """
    path = Path(path)
    what = purpose or "expected trajectory.csv, trajectory.mcap and summary.json"
    if path.is_dir():
        summary = _summary_if_any(path)
        kind = folder_kind(path, summary)
        if kind != "plan":
            raise InputError(str(path), "", _NOT_A_PLAN[kind].format(what=what))
        if (summary or {}).get("feasible") is False and not any((path / f).exists() for f in TRAJECTORY_FILES):
            raise InputError(str(path / "summary.json"), "feasible", "false: the plan is not feasible and only its "
                             "summary was written (plan --write-infeasible writes the trajectory too)")
        for name in (*TRAJECTORY_FILES, "summary.json"):
            if not (path / name).is_file():
                raise InputError(str(path / name), "", "missing: a plan folder holds trajectory.csv, "
                                 "trajectory.mcap and summary.json (give one trajectory file to check it alone)")
        return path, [path / f for f in TRAJECTORY_FILES if Path(f).suffix in suffixes]
    if path.is_file():
        if path.suffix not in suffixes:
            raise InputError(str(path), "", "expected a .csv or .mcap trajectory, or a plan folder")
        return path.parent, [path]
    if path.exists():
        raise InputError(str(path), "", "not a file or a folder (a device, a pipe?): expected trajectory.csv, "
                         "trajectory.mcap or their folder")
    raise InputError(str(path), "", "no such file (expected trajectory.csv, trajectory.mcap or their folder)")


def _summary_if_any(folder: Path) -> dict | None:
    """summary.json of ``folder`` where it exists and reads as an object (for telling folders apart)."""
    try:
        return read_json_document(folder / "summary.json") if (folder / "summary.json").is_file() else None
    except InputError:
        return None


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


def plan_robot(summary: dict | None, scenario: Scenario | None, src: str = "summary.json") -> RobotModel:
    """The robot a plan was made for: summary.json's robot YAML where it still exists, else the
    scenario's robot, else summary.json's robot name, else Jet-HR1.

    Raises:
        InputError: summary.json names a robot other than the scenario's or its robot YAML's.
    """
    named = (summary or {}).get("robot")
    path = (summary or {}).get("robot_yaml")
    if isinstance(path, str) and Path(path).is_file():
        robot = load_robot(path)
    elif scenario is not None:
        robot = scenario.robot  # the plan moved with its summary: the scenario names the robot
    else:
        robot = load_robot(named or "jethr1")
    if isinstance(named, str) and named != robot.name:
        where = "its robot_yaml" if isinstance(path, str) and Path(path).is_file() else "the scenario"
        raise InputError(src, "robot", f"{named!r}, but {where} is robot {robot.name!r}: the folder's files do "
                         "not belong together")
    if scenario is not None and scenario.robot.name != robot.name:
        raise InputError(src, "robot", f"{robot.name!r}, but the scenario names robot {scenario.robot.name!r}")
    return robot


def read_plan(path: Path, scenario: Path | None = None, suffixes: tuple[str, ...] = (".csv", ".mcap"),
              strict: bool = False, purpose: str = "") -> PlanFolder:
    """Read a plan folder (or one of its trajectory files): summary, scenario, robot and the columns
    of each trajectory file with a suffix in ``suffixes``, everything checked before it is used:

    * a folder holds trajectory.csv, trajectory.mcap and summary.json (a walk's or a balance space's
      folder is named as such);
    * summary.json is a bounded JSON object whose fields the readers use have their types and bounds
      (:data:`SUMMARY_SCHEMA`: row counts up to the scenario's ``MAX_ROWS``, cartons as a list);
    * the robot named by summary.json is the scenario's and its robot YAML's, and the files have
      exactly that robot's columns;
    * with ``strict``, the rows agree with summary.json and with themselves (:meth:`PlanFolder.problems`:
      the row count, time strictly increasing, finite numbers where numbers are required).

    Raises:
        InputError: the first problem (exit 2); ``purpose`` says what the folder was wanted for.
    """
    folder, files = trajectory_files(path, suffixes, purpose)
    summary_path = folder / "summary.json"
    summary = read_json(summary_path) if summary_path.is_file() else None
    checked = [summary_path] if summary is not None else []
    if summary is not None:
        check_schema(summary, str(summary_path), SUMMARY_SCHEMA)
    sc = plan_scenario(folder, summary, scenario)
    if sc is not None and os.path.isfile(sc.source):
        checked.append(Path(sc.source))
    robot = plan_robot(summary, sc, str(summary_path))
    plan = PlanFolder(folder, files, summary, robot, sc)
    for f in files:
        try:
            data = f.read_bytes()
        except OSError as exc:
            raise InputError(str(f), "", f"cannot read: {exc.strerror or exc}") from None
        try:
            if f.suffix == ".csv":
                try:
                    text = data.decode("utf-8")
                except UnicodeDecodeError:
                    raise InputError(str(f), "", "not UTF-8 text") from None
                plan.tables[f] = read_trajectory_csv(text, str(f), robot, complete=True)
            else:
                plan.tables[f], plan.swing_paths[f] = read_trajectory_mcap(data, str(f), robot)
        except InputError as exc:
            if exc.key == "header" and summary is not None:
                raise InputError(str(f), "header", f"{exc.problem}: not the columns of robot {robot.name!r} that "
                                 "summary.json names") from None
            raise
    plan.checked = [*files, *checked]
    if strict:
        for name, row, problem in plan.problems()[:1]:
            raise InputError(str(folder / name), f"row {row + 1}", f"{problem}: the plan folder is not one jethr1 "
                             "wrote, or was edited since")
    return plan
