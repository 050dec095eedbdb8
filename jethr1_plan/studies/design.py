"""``jethr1 design``: robot variants judged by the ditch curve, on one machine or a Dask cluster.

**A variant** (``studies.design_spec``) is written as a robot folder (``robot.variant``) and loaded through the
checks every robot passes (``robot.load.load_robot``), then judged (``studies.design_judge``: its widest ditch
crossed with the whole tolerance, with half of it and at all). A variant's plans are one task; the tasks run
one at a time (``-j 1``), ``jobs`` at a time on this machine or on a Dask cluster, and their results do not depend
on which. Wherever a task runs, it is judged in a child process that a new one replaces after every
:data:`VARIANTS_PER_PROCESS` variants (``io.recycled``): a sweep's memory does not grow with its length.

**The cache** (resumption): every variant's result is kept in ``<cache>/design/<key>.json`` as it arrives, keyed
by the SHA-256 of its robot files' bytes, the judge's settings, the package's version and the source of the code
that judges (:func:`variant_key`); a sweep run again (interrupted, extended, re-plotted) judges only the variants
it has no result for. ``<cache>`` is ``--cache DIR``, else ``$JETHR1_CACHE``, else ``$XDG_CACHE_HOME/jethr1``,
else ``~/.cache/jethr1`` (the route's maps' place).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from jethr1_plan import __version__
from jethr1_plan.errors import InputError
from jethr1_plan.studies.design_spec import DesignSpec, JudgeSettings, Variant

__all__ = ["CODE", "VARIANTS_PER_PROCESS", "VARIANT_BYTES", "Task", "cache_path", "check_cache", "check_first",
           "code_digest", "default_cache", "judge_here", "judge_task", "make_tasks", "read_cached", "run_tasks",
           "variant_key", "write_cached"]

FORMAT = 1  # the cached result's layout; part of the key
#: the package's code a variant's result depends on (its digest is part of the key)
CODE = ("control", "kinematics", "optimisers", "physics", "planning", "robot", "geometry.py", "reasons.py",
        "scenario.py", "swing_path.py", "studies/ditch_curve.py", "studies/design_judge.py")
#: variants one process judges before a new one takes over (each leaves PlaCo's models of its robot behind, about
#: 0.8 MB: ``robot.wrappers``)
VARIANTS_PER_PROCESS = 40
#: a variant held in memory until the files are written: its task's robot files (Jet-HR1's URDF and YAML, 14 kB;
#: 15 kB a variant measured over 20,000) and its result [bytes]
VARIANT_BYTES = 20_000
JUDGED_NAME = "variant"  # the robot name of the folder a task judges (the same for every variant: not in the key)


def code_digest(root: Path | None = None) -> bytes:
    """SHA-256 of the source files of :data:`CODE` (names and bytes, in name order)."""
    root = root or Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for part in CODE:
        paths = [root / part] if part.endswith(".py") else sorted((root / part).rglob("*.py"))
        for path in paths:
            rel = path.relative_to(root).as_posix().encode()
            data = path.read_bytes()
            h.update(len(rel).to_bytes(8, "little") + rel + len(data).to_bytes(8, "little") + data)
    return h.digest()


def variant_key(files: dict[str, bytes], judge: JudgeSettings, code: bytes) -> str:
    """The cache key of a variant's result: SHA-256 of its files (names and bytes), the judge's settings, the
    package's version, the code's digest (:func:`code_digest`) and this process's arithmetic
    (``arithmetic.signature``: a result computed with other kernels may differ in its last digits)."""
    from jethr1_plan.arithmetic import signature

    h = hashlib.sha256()
    parts = [f"jethr1-plan {__version__} design result {FORMAT}".encode(), code, signature().encode(),
             json.dumps(judge.as_dict(), sort_keys=True).encode()]
    for name in sorted(files):
        parts += [name.encode(), files[name]]
    for part in parts:
        h.update(len(part).to_bytes(8, "little"))
        h.update(part)
    return h.hexdigest()


def cache_path(cache: Path, key: str) -> Path:
    return Path(cache) / "design" / key[:2] / f"{key}.json"


@dataclass(frozen=True)
class Task:
    """One variant to judge: all it needs, so that it can run in any process, on any machine."""

    key: str
    files: dict[str, bytes]  # the variant's robot folder: {name.urdf, name.yaml}
    judge: JudgeSettings


def judge_task(task: Task) -> tuple[str, dict[str, Any], dict[str, float]]:
    """Judge one variant (:func:`judge_here`) in a child of the calling process's thread that is replaced after
    every :data:`VARIANTS_PER_PROCESS` variants (``io.recycled``): whichever process calls it (this command's, a
    Dask worker), the memory of the processes that judge does not grow with the sweep. Returns (key, result,
    {cpu_s, wall_s})."""
    from jethr1_plan.io.recycled import call

    return call("jethr1_plan.studies.design:judge_here", task, VARIANTS_PER_PROCESS)


def judge_here(task: Task) -> tuple[str, dict[str, Any], dict[str, float]]:
    """Judge one variant in this process: its files written to a folder of their own, loaded through every
    check of a robot folder, judged, and the folder removed. Returns (key, result, {cpu_s, wall_s})."""
    from jethr1_plan.robot.load import forget_robots, load_robot

    w0, c0 = time.perf_counter(), time.process_time()
    with tempfile.TemporaryDirectory(prefix="jethr1-design-") as tmp:
        folder = Path(tmp) / JUDGED_NAME
        folder.mkdir()
        for name, data in task.files.items():
            (folder / name).write_bytes(data)
        try:
            robot = load_robot(folder)
        except InputError as exc:
            result: dict[str, Any] = {"status": "refused", "reason": str(exc).replace(str(folder), "<variant>")}
        else:
            from jethr1_plan.studies.design_judge import judge_robot

            result = judge_robot(robot, task.judge)
        finally:
            forget_robots()  # the folder goes: nothing may load it from the caches again
    return task.key, result, {"cpu_s": time.process_time() - c0, "wall_s": time.perf_counter() - w0}


def make_tasks(spec: DesignSpec, variants: list[Variant], code: bytes | None = None
               ) -> tuple[list[str], dict[str, Task]]:
    """Per variant (in order) its key; and one task per distinct key.

    Raises:
        InputError: the base robot cannot be varied, or a variant's files do not pass the robot checks.
    """
    from jethr1_plan.robot.load import load_robot
    from jethr1_plan.robot.variant import variant_files

    try:
        base = load_robot(spec.base_robot)
    except InputError as exc:
        raise InputError(spec.source, "base_robot", str(exc)) from None
    code = code or code_digest()
    keys, tasks = [], {}
    for v in variants:
        try:
            files = variant_files(base.yaml_path, v.design, JUDGED_NAME,
                                  f"A design variant of {base.name} ({spec.name} {v.name}).")
        except InputError as exc:
            raise InputError(spec.source, f"variant {v.index}", str(exc)) from None
        key = variant_key(files, spec.judge, code)
        keys.append(key)
        if key not in tasks:
            tasks[key] = Task(key, files, spec.judge)
    return keys, tasks


def check_first(spec: DesignSpec, task: Task) -> None:
    """Load the first variant's robot folder through every check (as its task will), here and now: a design the
    checks refuse is one line before any work.

    Raises:
        InputError: the checks' first problem, naming the design file.
    """
    from jethr1_plan.robot.load import forget_robots, load_robot

    with tempfile.TemporaryDirectory(prefix="jethr1-design-") as tmp:
        folder = Path(tmp) / JUDGED_NAME
        folder.mkdir()
        for name, data in task.files.items():
            (folder / name).write_bytes(data)
        try:
            load_robot(folder)
        except InputError as exc:
            raise InputError(spec.source, "variant 0", "the robot checks refuse it: "
                             + str(exc).replace(str(folder), "<variant>")) from None
        finally:
            forget_robots()


def check_cache(cache: Path) -> None:
    """Refuse, before any work, a cache where results cannot be kept: ``<cache>/design`` (or the nearest of its
    folders that exists) a file, or a place that cannot be written; nothing is created.

    Raises:
        InputError: naming the cache (exit 2).
    """
    from jethr1_plan.io.record import check_writable

    try:
        check_writable(Path(cache) / "design")
    except InputError as exc:
        raise InputError(str(cache), "", f"cannot keep the design cache here: {exc.source}: {exc.problem} (--cache "
                         "DIR or $JETHR1_CACHE choose another place)") from None


def read_cached(cache: Path, key: str) -> dict[str, Any] | None:
    """The result cached under ``key``, or None (missing, unreadable, another key's)."""
    path = cache_path(cache, key)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    if not isinstance(doc, dict) or doc.get("key") != key or not isinstance(doc.get("result"), dict):
        return None
    return doc["result"]


def write_cached(cache: Path, key: str, result: dict[str, Any]) -> None:
    """Keep ``result`` under ``key``: written to a temporary file beside it and renamed into place (a cache entry
    is whole or absent; not an output of the command, so not named among them on an interrupt).

    Raises:
        InputError: the cache cannot be written (a full disk, a read-only place).
    """
    from jethr1_plan.io.json_text import json_text

    path = cache_path(cache, key)
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{key[:16]}-", suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(json_text({"key": key, "version": __version__, "result": result}))
        os.replace(tmp, path)
    except OSError as exc:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
        raise InputError(str(path.parent), "", f"cannot write the design cache: {exc.strerror or exc} (--cache DIR "
                         "or $JETHR1_CACHE choose another place)") from None


def _one_by_one(tasks: list[Task]) -> Iterator[tuple[str, dict[str, Any], dict[str, float]]]:
    for t in tasks:
        yield judge_task(t)


def _threads(tasks: list[Task], jobs: int) -> Iterator[tuple[str, dict[str, Any], dict[str, float]]]:
    """The tasks' outcomes as they arrive, ``jobs`` at a time: each thread judges through a child of its own."""
    from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

    with ThreadPoolExecutor(max_workers=jobs, thread_name_prefix="jethr1-design") as pool:
        pending = {pool.submit(judge_task, t) for t in tasks}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for f in done:
                    yield f.result()
        finally:
            for f in pending:
                f.cancel()
            from jethr1_plan.io.recycled import stop_all

            stop_all()  # the threads still waiting for a child's answer get WorkerLost and end


def run_tasks(tasks: dict[str, Task], cache: Path, jobs: int = 1, executor: str = "loky",
              scheduler: str | None = None, progress=None) -> tuple[dict[str, dict[str, Any]], dict[str, Any]]:
    """Every task's result: read from the cache, else judged (one at a time with ``jobs`` 1 and no Dask; ``jobs``
    at a time, each thread through a child process of its own; or on Dask: a local cluster of ``jobs`` workers, or
    the one at ``scheduler``), each kept in the cache as it arrives. Returns (key → result, timings: per judged key
    its CPU and wall time [s], and how many came from the cache)."""
    results: dict[str, dict[str, Any]] = {}
    for key in tasks:
        found = read_cached(cache, key)
        if found is not None:
            results[key] = found
    todo = [t for key, t in tasks.items() if key not in results]
    timings: dict[str, Any] = {"from_cache": len(results), "judged": {}}
    total = len(tasks)
    if progress:
        progress(f"{len(results)} from the cache", len(results), total)
    try:
        cache.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(str(cache), "", f"cannot create the design cache: {exc.strerror or exc} (--cache DIR or "
                         "$JETHR1_CACHE choose another place)") from None

    def collect(outcomes) -> None:
        for key, result, times in outcomes:
            results[key] = result
            timings["judged"][key] = times
            if result.get("status") == "ok":
                write_cached(cache, key, result)
            if progress:
                progress(f"{len(timings['judged'])} judged, {timings['from_cache']} from the cache", len(results),
                         total)

    if not todo:
        return results, timings
    if executor == "dask":
        from joblib import Parallel, delayed, parallel_config

        from jethr1_plan.io.cluster import dask_client

        with dask_client(scheduler, jobs), parallel_config(backend="dask"):
            collect(Parallel(return_as="generator_unordered")(delayed(judge_task)(t) for t in todo))
    else:
        from jethr1_plan.io.recycled import stop_all

        try:
            collect(_one_by_one(todo) if jobs == 1 else _threads(todo, min(jobs, len(todo))))
        finally:
            stop_all()
    return results, timings


def default_cache(given: Path | str | None = None) -> Path:
    """``given``, else $JETHR1_CACHE, else $XDG_CACHE_HOME/jethr1, else ~/.cache/jethr1 (the maps' cache too)."""
    from jethr1_plan.route.balance_map import cache_dir

    return cache_dir(given)
