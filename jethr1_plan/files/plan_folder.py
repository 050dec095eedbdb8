"""A plan folder, ``OUTDIR/<scenario stem>/``: ``trajectory.csv``, ``trajectory.mcap`` and
``summary.json`` (and a rehearsal's ``simulation.json`` / ``simulation.mcap``), written atomically
(:func:`write_plan`), and the checks that its files belong together. Reading a folder back whole, with
the scenario it was planned from, is :func:`jethr1_plan.folders.plan.read_plan`'s.
"""

from __future__ import annotations

import errno
import hashlib
import os
import stat
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Protocol

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_csv import table_csv
from jethr1_plan.files.plan_mcap import MAX_MCAP_BYTES, trajectory_mcap
from jethr1_plan.files.plan_steps import OPTIMISED_STEPS
from jethr1_plan.files.plan_table import columns, plan_table
from jethr1_plan.io.atomic import staged_directory
from jethr1_plan.io.csv_table import MAX_CSV_BYTES
from jethr1_plan.io.input_file import describe_kind, read_input
from jethr1_plan.io.json_text import MAX_JSON_BYTES, json_document, json_text
from jethr1_plan.io.json_text import read_json as read_json_document
from jethr1_plan.io.record import RECORD, file_sha256, read_record
from jethr1_plan.records.plan_rows import Rows
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.swing_path import Carton

__all__ = [
    "PLAN_FILES",
    "PLAN_WRITES",
    "SIMULATION_FILES",
    "TRAJECTORY_FILES",
    "WrittenPlan",
    "check_belongs",
    "check_digest",
    "check_summary_record",
    "file_bounds",
    "file_digests",
    "folder_kind",
    "lstat_or_none",
    "plan_folder",
    "read_json",
    "recorded_digest",
    "rehearsal_of",
    "summary_rows",
    "trajectory_files",
    "write_plan",
    "write_summary_only",
]

#: the files ``jethr1 simulate`` writes into a plan folder (both, or neither)
SIMULATION_FILES = frozenset({"simulation.json", "simulation.mcap"})
#: the files ``jethr1`` writes into a plan folder (any other file there is the user's and is kept)
PLAN_FILES = frozenset({"trajectory.csv", "trajectory.mcap", "summary.json", OPTIMISED_STEPS}) | SIMULATION_FILES
TRAJECTORY_FILES = ("trajectory.csv", "trajectory.mcap")
#: the files ``jethr1 plan`` writes (checked before the work: :func:`~jethr1_plan.io.record.check_writable`)
PLAN_WRITES = (*TRAJECTORY_FILES, "summary.json", OPTIMISED_STEPS)
#: the key of summary.json that records the trajectory files' digests: name → {"sha256", "bytes"}
DIGESTS_KEY = "files"
CSV_ROW_BYTES = lambda columns: 32 * columns + 256  # noqa: E731  the longest a row of this many columns can be
MCAP_ROW_BYTES = 8_000  # a plan's MCAP holds ~0.8 kB a row (zstd), ~3 kB once expanded; at most this, each
MCAP_EXPANDED_ROW_BYTES = 20_000
FILE_SLACK_BYTES = 20_000_000  # beside the rows: the URDF, the schemas, the scenery


def file_digests(files: Mapping[str, bytes]) -> dict[str, dict[str, int | str]]:
    """Each file's SHA-256 (hex) and size, as summary.json records them (:data:`DIGESTS_KEY`)."""
    return {name: {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)} for name, data in files.items()}


class _Source(Protocol):
    @property
    def source(self) -> str: ...  # the scenario file's path


class _Scenario(_Source, Protocol):
    @property
    def cartons(self) -> Sequence[Carton]: ...


class _Step(Protocol):
    @property
    def path_m(self) -> np.ndarray: ...  # (N, 3) the swing sole's samples [m]


class WrittenPlan(Protocol):
    """What :func:`write_plan` writes of a plan (``planning.results.PlanResult``)."""

    @property
    def scenario(self) -> _Scenario: ...
    @property
    def robot(self) -> RobotModel: ...
    @property
    def steps(self) -> Sequence[_Step]: ...
    @property
    def rows(self) -> Rows | None: ...
    @property
    def feasible(self) -> bool: ...


def plan_folder(outdir: Path, scenario: _Source) -> Path:
    """OUTDIR/<scenario stem>/."""
    return Path(outdir) / Path(scenario.source).stem


def write_plan(result: WrittenPlan, outdir: Path, summary: dict, trajectory: bool = True,
               check: Callable[[str], None] | None = None, folder: Path | None = None,
               extra: Mapping[str, bytes] | None = None, own: frozenset[str] = PLAN_FILES,
               steps_key: str | None = None) -> tuple[Path, list[str]]:
    """Write summary.json (and the trajectory files) into OUTDIR/<stem>/ (or ``folder``) atomically,
    with the ``extra`` files (name → bytes: a route's own files) in the same commit; ``own`` names every
    file the command writes into such a folder (:func:`~jethr1_plan.io.atomic.staged_directory`).
    With ``steps_key`` (:func:`~jethr1_plan.files.plan_steps.steps_key`), a feasible plan's optimised steps
    go with it (:data:`~jethr1_plan.files.plan_steps.OPTIMISED_STEPS`, bound to its trajectory.csv).

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
            if steps_key is not None and result.feasible:
                from jethr1_plan.files.plan_steps import optimised_steps_json

                files[OPTIMISED_STEPS] = optimised_steps_json(
                    result.steps, steps_key, str(summary[DIGESTS_KEY]["trajectory.csv"]["sha256"]))  # type: ignore[arg-type]
            for name, data in files.items():
                (tmp / name).write_bytes(data)
        (tmp / "summary.json").write_text(json_text(summary))
        for name, data in (extra or {}).items():
            (tmp / name).write_bytes(data)
    return final, staging.kept


def write_summary_only(scenario: _Source, outdir: Path, summary: dict | None) -> tuple[Path, list[str]]:
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


def summary_rows(summary: dict | None) -> int | None:
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


def lstat_or_none(path: Path) -> os.stat_result | None:
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
            fst = lstat_or_none(path / name)
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
    st = lstat_or_none(folder / "summary.json")
    if st is None or not stat.S_ISREG(st.st_mode):
        return None
    try:
        return read_json_document(folder / "summary.json")
    except InputError:
        return None


def check_summary_record(folder: Path, summary_bytes: bytes) -> None:
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


def recorded_digest(summary: dict, summary_path: Path, name: str) -> dict:
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


def check_digest(path: Path, data: bytes, rec: dict) -> None:
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
    check_summary_record(folder, summary_bytes)
    for name in TRAJECTORY_FILES:
        rec = recorded_digest(summary, summary_path, name)
        p = folder / name
        st = os.stat(p)
        if st.st_size != rec["bytes"] or file_sha256(p) != rec["sha256"]:
            check_digest(p, read_input(p, rec["bytes"] + 1, f"a {name}"), rec)
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


def file_bounds(summary: dict | None, robot: RobotModel) -> dict[str, int]:
    """The most bytes each trajectory file of a plan of ``summary``'s rows can hold (the CSV, the MCAP, the
    MCAP's chunks once expanded); the formats' own bounds where summary.json gives no rows."""
    rows = summary_rows(summary)
    if rows is None:
        return {".csv": MAX_CSV_BYTES, ".mcap": MAX_MCAP_BYTES}
    return {".csv": min(MAX_CSV_BYTES, (rows + 1) * CSV_ROW_BYTES(len(columns(robot))) + 1_000_000),
            ".mcap": min(MAX_MCAP_BYTES, rows * MCAP_ROW_BYTES + FILE_SLACK_BYTES),
            "expanded": rows * MCAP_EXPANDED_ROW_BYTES + FILE_SLACK_BYTES}
