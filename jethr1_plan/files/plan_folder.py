"""A plan folder, ``OUTDIR/<scenario stem>/``: ``trajectory.csv``, ``trajectory.mcap`` and
``summary.json`` (and a rehearsal's ``simulation.json`` / ``simulation.mcap``), written atomically and
read back in one place: :func:`write_plan` and :func:`read_plan`. Every command that reads a plan
(``verify``, ``simulate``) reads it through :func:`read_plan`.
"""

from __future__ import annotations

import errno
import hashlib
import os
import stat
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_csv import read_trajectory_csv, table_csv
from jethr1_plan.files.plan_mcap import MAX_MCAP_BYTES, read_trajectory_mcap, trajectory_mcap
from jethr1_plan.files.plan_table import columns, plan_table
from jethr1_plan.io.atomic import staged_directory
from jethr1_plan.io.csv_table import MAX_CSV_BYTES
from jethr1_plan.io.input_file import describe_kind, read_input
from jethr1_plan.io.json_text import MAX_JSON_BYTES, json_document, json_text
from jethr1_plan.io.json_text import read_json as read_json_document
from jethr1_plan.io.record import RECORD, file_sha256, read_record
from jethr1_plan.io.yaml_input import check_schema
from jethr1_plan.planning.results import PlanResult
from jethr1_plan.robot.load import load_robot
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.scenario import Scenario, load_scenario, load_scenario_text
from jethr1_plan.scenario_schema import MAX_FILE_BYTES, MAX_ROWS, POLICIES
from jethr1_plan.swing_path import Carton

__all__ = ["PLAN_FILES", "PLAN_WRITES", "SIMULATION_FILES", "SUMMARY_SCHEMA", "PlanFolder", "check_belongs",
           "file_digests", "folder_kind", "plan_folder", "read_json", "read_plan", "rehearsal_of", "trajectory_files",
           "write_plan", "write_summary_only"]

#: the files ``jethr1 simulate`` writes into a plan folder (both, or neither)
SIMULATION_FILES = frozenset({"simulation.json", "simulation.mcap"})
#: the files ``jethr1`` writes into a plan folder (any other file there is the user's and is kept)
PLAN_FILES = frozenset({"trajectory.csv", "trajectory.mcap", "summary.json"}) | SIMULATION_FILES
TRAJECTORY_FILES = ("trajectory.csv", "trajectory.mcap")
#: the files ``jethr1 plan`` writes (checked before the work: :func:`~jethr1_plan.io.record.check_writable`)
PLAN_WRITES = (*TRAJECTORY_FILES, "summary.json")
#: the key of summary.json that records the trajectory files' digests: name → {"sha256", "bytes"}
DIGESTS_KEY = "files"
CSV_ROW_BYTES = lambda columns: 32 * columns + 256  # noqa: E731  the longest a row of this many columns can be
MCAP_ROW_BYTES = 8_000  # a plan's MCAP holds ~0.8 kB a row (zstd), ~3 kB once expanded; at most this, each
MCAP_EXPANDED_ROW_BYTES = 20_000
FILE_SLACK_BYTES = 20_000_000  # beside the rows: the URDF, the schemas, the scenery


def file_digests(files: Mapping[str, bytes]) -> dict[str, dict[str, int | str]]:
    """Each file's SHA-256 (hex) and size, as summary.json records them (:data:`DIGESTS_KEY`)."""
    return {name: {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)} for name, data in files.items()}


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
            files = {"trajectory.csv": text.encode("utf-8"),
                     "trajectory.mcap": trajectory_mcap(result.robot, result.rows, result.scenario.cartons,
                                                        [st.path_m for st in result.steps], table)}
            summary[DIGESTS_KEY] = file_digests(files)  # the folder is one thing: the summary names its files
            for name, data in files.items():
                (tmp / name).write_bytes(data)
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


def _lstat(path: Path) -> os.stat_result | None:
    try:
        return os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise InputError(str(path), "", f"cannot read: {exc.strerror or exc}") from None


def trajectory_files(path: Path, suffixes: tuple[str, ...] = (".csv", ".mcap"), purpose: str = "") -> tuple[
        Path, list[Path]]:
    """(folder, trajectory files) of a plan folder or of one trajectory file. A folder must hold
    a whole plan: trajectory.csv, trajectory.mcap and summary.json, each a regular file.

    Raises:
        InputError: no such file, not a file (a FIFO, a device, a loop of links), a folder that is not a whole
            plan's.
    """
    path = Path(path)
    what = purpose or "expected trajectory.csv, trajectory.mcap and summary.json"
    try:
        st = os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ENOENT:
            raise InputError(str(path), "", "no such file (expected trajectory.csv, trajectory.mcap or their "
                             "folder)") from None
        problem = {errno.ELOOP: "a loop of symbolic links", errno.ENAMETOOLONG: "a name longer than the file "
                   "system allows", errno.ENOTDIR: "a path through something that is not a folder"}.get(
                       exc.errno or 0, f"cannot read: {exc.strerror or exc}")
        raise InputError(str(path), "", problem) from None
    if stat.S_ISDIR(st.st_mode):
        summary = _summary_if_any(path)
        kind = folder_kind(path, summary)
        if kind != "plan":
            raise InputError(str(path), "", _NOT_A_PLAN[kind].format(what=what))
        if (summary or {}).get("feasible") is False and not any(os.path.lexists(path / f) for f in TRAJECTORY_FILES):
            raise InputError(str(path / "summary.json"), "feasible", "false: the plan is not feasible and only its "
                             "summary was written (plan --write-infeasible writes the trajectory too)")
        for name in (*TRAJECTORY_FILES, "summary.json"):
            fst = _lstat(path / name)
            if fst is None:
                raise InputError(str(path / name), "", "missing: a plan folder holds trajectory.csv, "
                                 "trajectory.mcap and summary.json (give one trajectory file to check it alone)")
            if stat.S_ISLNK(fst.st_mode):
                fst = os.stat(path / name) if os.path.exists(path / name) else fst
            if not stat.S_ISREG(fst.st_mode):
                raise InputError(str(path / name), "", f"{describe_kind(fst.st_mode)}, not a file: a plan folder "
                                 "holds trajectory.csv, trajectory.mcap and summary.json as files")
        return path, [path / f for f in TRAJECTORY_FILES if Path(f).suffix in suffixes]
    if stat.S_ISREG(st.st_mode):
        if path.suffix not in suffixes:
            raise InputError(str(path), "", "expected a .csv or .mcap trajectory, or a plan folder")
        return path.parent, [path]
    raise InputError(str(path), "", f"{describe_kind(st.st_mode)}, not a file or a folder: expected "
                     "trajectory.csv, trajectory.mcap or their folder")


def _summary_if_any(folder: Path) -> dict | None:
    """summary.json of ``folder`` where it exists as a file and reads as an object (for telling folders apart)."""
    st = _lstat(folder / "summary.json")
    if st is None or not stat.S_ISREG(st.st_mode):
        return None
    try:
        return read_json_document(folder / "summary.json")
    except InputError:
        return None


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


def _file_bounds(summary: dict | None, robot: RobotModel) -> dict[str, int]:
    """The most bytes each trajectory file of a plan of ``summary``'s rows can hold (the CSV, the MCAP, the
    MCAP's chunks once expanded); the formats' own bounds where summary.json gives no rows."""
    rows = _summary_rows(summary)
    if rows is None:
        return {".csv": MAX_CSV_BYTES, ".mcap": MAX_MCAP_BYTES}
    return {".csv": min(MAX_CSV_BYTES, (rows + 1) * CSV_ROW_BYTES(len(columns(robot))) + 1_000_000),
            ".mcap": min(MAX_MCAP_BYTES, rows * MCAP_ROW_BYTES + FILE_SLACK_BYTES),
            "expanded": rows * MCAP_EXPANDED_ROW_BYTES + FILE_SLACK_BYTES}


def _check_summary_record(folder: Path, summary_bytes: bytes) -> None:
    """summary.json as jethr1 wrote it, where the folder keeps jethr1's record of its files.

    Raises:
        InputError: summary.json differs from the one the record names (edited, or another plan's).
    """
    rec = read_record(folder).get("summary.json")
    if rec is not None and (rec["bytes"] != len(summary_bytes) or
                            rec["sha256"] != hashlib.sha256(summary_bytes).hexdigest()):
        raise InputError(str(folder / "summary.json"), "", f"changed since jethr1 wrote it (its SHA-256 is not the "
                         f"one in the folder's record, {RECORD}): the folder's files do not belong together; plan "
                         "the scenario again")


def _recorded_digest(summary: dict, summary_path: Path, name: str) -> dict:
    """summary.json's record of trajectory file ``name``: {"sha256", "bytes"}.

    Raises:
        InputError: summary.json records no digests (written by an earlier jethr1), or none of this file.
    """
    files = summary.get(DIGESTS_KEY)
    rec = files.get(name) if isinstance(files, dict) else None
    if not isinstance(rec, dict) or not isinstance(rec.get("sha256"), str) or not isinstance(rec.get("bytes"), int):
        raise InputError(str(summary_path), DIGESTS_KEY, f"no digest of {name}: a plan folder written by an earlier "
                         "jethr1 (or not by jethr1) cannot show that its files belong together; plan the scenario "
                         "again")
    return rec


def _check_digest(path: Path, data: bytes, rec: dict) -> None:
    """Raises InputError where ``data`` (the bytes of ``path``) are not those summary.json records."""
    if rec["bytes"] != len(data) or rec["sha256"] != hashlib.sha256(data).hexdigest():
        raise InputError(str(path), "", f"not the {path.name} that summary.json records ({len(data):,} bytes, "
                         f"SHA-256 {hashlib.sha256(data).hexdigest()[:12]}...; recorded {rec['bytes']:,} bytes, "
                         f"{rec['sha256'][:12]}...): the folder's files do not belong together (another plan's, "
                         "cut or edited); plan the scenario again")


def check_belongs(folder: Path) -> dict:
    """Check that a plan folder is one thing, without reading its rows: summary.json as the folder's record
    names it, and trajectory.csv and trajectory.mcap those summary.json records (size and SHA-256); the
    summary returned. For the readers of a folder's files that do not parse the rows (``view``).

    Raises:
        InputError: a file missing, not a regular file, too large, or not the one recorded (exit 2).
    """
    folder, _ = trajectory_files(folder)
    summary_path = folder / "summary.json"
    summary_bytes = read_input(summary_path, MAX_JSON_BYTES, "a summary.json")
    summary = json_document(summary_bytes, str(summary_path))
    _check_summary_record(folder, summary_bytes)
    for name in TRAJECTORY_FILES:
        rec = _recorded_digest(summary, summary_path, name)
        p = folder / name
        st = os.stat(p)
        if st.st_size != rec["bytes"] or file_sha256(p) != rec["sha256"]:
            _check_digest(p, read_input(p, rec["bytes"] + 1, f"a {name}"), rec)
    return summary


def rehearsal_of(folder: Path, summary: dict) -> bool:
    """Whether the folder's ``simulation.json`` is a rehearsal of the plan ``summary`` (its summary.json) describes:
    it records the digests of the very trajectory files summary.json records (a rehearsal left by an earlier
    jethr1, or of an earlier plan, is not shown beside this one)."""
    try:
        doc = read_json_document(Path(folder) / "simulation.json")
    except InputError:
        return False
    files = summary.get(DIGESTS_KEY)
    return isinstance(files, dict) and bool(files) and doc.get("plan_files") == files


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
    if whole or _lstat(summary_path) is not None:
        summary_bytes = read_input(summary_path, MAX_JSON_BYTES, "a summary.json")
        summary = json_document(summary_bytes, str(summary_path))
        check_schema(summary, str(summary_path), SUMMARY_SCHEMA)
        _check_summary_record(folder, summary_bytes)
    checked = [summary_path] if summary is not None else []
    sc = plan_scenario(folder, summary, scenario)
    if sc is not None and os.path.isfile(sc.source):
        checked.append(Path(sc.source))
    robot = plan_robot(summary, sc, str(summary_path))
    plan = PlanFolder(folder, files, summary, robot, sc, summary_sha256=hashlib.sha256(summary_bytes).hexdigest())
    bounds = _file_bounds(summary, robot)
    data: dict[Path, bytes] = {}
    for f in ([folder / name for name in TRAJECTORY_FILES] if whole else files):
        data[f] = read_input(f, bounds[f.suffix], f"a plan's {f.suffix[1:].upper()}")
        if summary is not None:
            _check_digest(f, data[f], _recorded_digest(summary, summary_path, f.name))
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
