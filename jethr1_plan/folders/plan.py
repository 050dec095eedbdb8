"""A written plan folder read back whole (:func:`read_plan`): its files checked to belong together
(``files.plan_folder``), the scenario it was planned from found, its robot, and the columns of each
trajectory file. Every command that reads a plan (``verify``, ``simulate``) reads it through
:func:`read_plan`.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_csv import read_trajectory_csv
from jethr1_plan.files.plan_folder import (
    TRAJECTORY_FILES,
    check_digest,
    check_summary_record,
    file_bounds,
    lstat_or_none,
    recorded_digest,
    summary_rows,
    trajectory_files,
)
from jethr1_plan.files.plan_mcap import read_trajectory_mcap
from jethr1_plan.io.input_file import read_input
from jethr1_plan.io.json_text import MAX_JSON_BYTES, json_document
from jethr1_plan.io.yaml_input import check_schema, short
from jethr1_plan.records.plan_columns import PHASE, SAMPLE, STEP, SUPPORT, TIME, TOLERANCE_SHARE, ZMP_MARGIN
from jethr1_plan.robot.load import load_robot
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.scenario import Scenario, load_scenario, load_scenario_text
from jethr1_plan.scenario_schema import MAX_FILE_BYTES, MAX_ROWS, POLICIES
from jethr1_plan.swing_path import Carton

__all__ = ["SUMMARY_SCHEMA", "PlanFolder", "plan_robot", "plan_scenario", "read_plan"]


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
    summary_sha256: str = ""  # of summary.json's bytes as read

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
        rows = summary_rows(self.summary)
        for f, table in self.tables.items():
            n = len(table[TIME])
            if rows is not None and n != rows:
                out.append((f.name, min(n, rows), f"{n} rows, summary.json says {rows}"))
            t = table[TIME].astype(float)
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
            out += self._word_problems(f, table)
        return out

    def _word_problems(self, f: Path, table: dict[str, np.ndarray]) -> list[tuple[str, int, str]]:
        """The first row whose phase or support is not one of :data:`ROW_WORDS`, the first whose step is not
        one of summary.json's steps or the transfer after the last (0 to their count), the first whose sample
        is negative."""
        out = []
        for name, words in ROW_WORDS.items():
            col = table.get(name)
            if col is not None:
                bad = np.flatnonzero(~np.isin(col.astype(str), words))
                if len(bad):
                    out.append((f.name, int(bad[0]), f"{name} {short(str(col[bad[0]]))}: expected "
                                f"{', '.join(words)}"))
        steps = (self.summary or {}).get("steps")
        feasible = (self.summary or {}).get("feasible") is True  # (an infeasible plan's rows end where it failed)
        count = len(steps) if feasible and isinstance(steps, list) and steps else None
        for name, hi in ((STEP, count), (SAMPLE, None)):
            col = table.get(name)
            if col is None or col.dtype.kind not in "iuf":
                continue
            bad = np.flatnonzero((col < 0) | (col > hi) if hi is not None else col < 0)
            if len(bad):
                within = f"0 to {hi} (summary.json's {hi} steps, then the last transfer)" if hi is not None else \
                    "0 or more"
                value = col[bad[0]]
                text = f"{value:.0f}" if float(value).is_integer() else f"{value:g}"
                out.append((f.name, int(bad[0]), f"{name} {text}: expected {within}"))
        return out


#: the words a plan's rows take in their text columns (a plan of jethr1's: a swing or a transfer, on one sole or both)
ROW_WORDS = {PHASE: ("swing", "transfer"), SUPPORT: ("left", "right", "both")}
#: number columns that may be empty (NaN): no swing sole in a transfer, no thrust window, no tolerance
OPTIONAL_PREFIXES = ("swing_", "thrust_window_")  # the swing sole's and the window's columns (SWING, WINDOW)
OPTIONAL_NUMBER_COLUMNS = frozenset({ZMP_MARGIN, TOLERANCE_SHARE})


def plan_scenario(folder: Path, summary: dict | None, explicit: Path | None = None) -> Scenario | None:
    """The scenario of a written plan: ``explicit`` (must exist), else the file summary.json names (as
    written, then beside summary.json), else the copy summary.json holds."""
    if explicit is not None:
        return load_scenario(explicit)
    if not summary:
        return None
    named = summary.get("scenario_file")
    text = summary.get("scenario_yaml")
    if isinstance(named, str) and named:
        for candidate in (Path(named), folder / named):
            if candidate.is_file():
                sc = load_scenario(candidate)
                if not isinstance(text, str) or not text or sc.text == text:
                    return sc
                break  # edited since: the plan was made from the copy summary.json holds
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

    * a folder holds trajectory.csv, trajectory.mcap and summary.json, regular files (a walk's or a
      balance space's folder is named as such);
    * summary.json is a bounded JSON object whose fields the readers use have their types and bounds
      (:data:`SUMMARY_SCHEMA`: row counts up to the scenario's ``MAX_ROWS``, cartons as a list), every
      number finite;
    * the folder is one thing: summary.json is the one the folder's record (``io.atomic``) names, and the
      trajectory files (both, for a folder: also the one not parsed) are those summary.json records, size
      and SHA-256, checked before a byte of them is parsed or decompressed;
    * each file is read bounded by the rows summary.json states (the MCAP's chunks too, before they are
      decompressed);
    * the robot named by summary.json is the scenario's and its robot YAML's, and the files have
      exactly that robot's columns;
    * with ``strict``, the rows agree with summary.json and with themselves (:meth:`PlanFolder.problems`:
      the row count, time strictly increasing, finite numbers where numbers are required).

    Raises:
        InputError: the first problem (exit 2); ``purpose`` says what the folder was wanted for.
    """
    folder, files = trajectory_files(path, suffixes, purpose)
    whole = Path(path) != files[0] if files else True
    summary_path = folder / "summary.json"
    summary: dict | None = None
    summary_bytes = b""
    if whole or lstat_or_none(summary_path) is not None:
        summary_bytes = read_input(summary_path, MAX_JSON_BYTES, "a summary.json")
        summary = json_document(summary_bytes, str(summary_path))
        check_schema(summary, str(summary_path), SUMMARY_SCHEMA)
        check_summary_record(folder, summary_bytes)
    checked = [summary_path] if summary is not None else []
    sc = plan_scenario(folder, summary, scenario)
    if sc is not None and os.path.isfile(sc.source):
        checked.append(Path(sc.source))
    robot = plan_robot(summary, sc, str(summary_path))
    plan = PlanFolder(folder, files, summary, robot, sc, summary_sha256=hashlib.sha256(summary_bytes).hexdigest())
    bounds = file_bounds(summary, robot)
    data: dict[Path, bytes] = {}
    for f in ([folder / name for name in TRAJECTORY_FILES] if whole else files):
        data[f] = read_input(f, bounds[f.suffix], f"a plan's {f.suffix[1:].upper()}")
        if summary is not None:
            check_digest(f, data[f], recorded_digest(summary, summary_path, f.name))
    for f in files:
        try:
            if f.suffix == ".csv":
                try:
                    text = data[f].decode("utf-8")
                except UnicodeDecodeError:
                    raise InputError(str(f), "", "not UTF-8 text") from None
                plan.tables[f] = read_trajectory_csv(text, str(f), robot, complete=True)
            else:
                plan.tables[f], plan.swing_paths[f] = read_trajectory_mcap(data[f], str(f), robot,
                                                                           bounds.get("expanded"))
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
