"""``jethr1 design``: robot variants judged by the ditch curve, on one machine or a Dask cluster.

**A variant** (``studies.design_spec``) is written as a robot folder (``robot.variant``) and loaded through the
checks every robot passes (``robot.model.load_robot``). **The judge** (:func:`judge_robot`) plans Paper A's
forward step over ditches (``studies.ditch_curve``: the robust policy with the tolerance T as the objective,
``min_share`` 0, exactly what ``jethr1 ditch-curve`` plans) and finds, on a lattice of gaps, the widest ditch
crossed

* with the whole of T (every row's share ≥ 1 − 1e-9): ``whole``;
* with half of it (share ≥ 0.5): ``half``;
* at all (some share ≥ 0: a posture balances without errors, Paper A's minimal criterion): ``crossed``, where a
  plan under the minimal policy (Paper A's least thrust) gives the thrust Paper A would need;

and at each, the crossing's peak thrust, mean thrust, joints' energy and thrust impulse. The share of T that
crosses a ditch does not grow with its width (a wider ditch is not easier), so each widest gap is found by
bisection on the lattice (:func:`widest_gaps`), the three searches sharing their plans: about 10-14 plans per
variant at 10 mm over 0.2-0.7 m. A variant's plans are one task; the tasks run in this process (``-j 1``), in
worker processes (loky) or on a Dask cluster, and their results do not depend on which.

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
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from jethr1_plan import __version__
from jethr1_plan.errors import InfeasiblePlan, InputError
from jethr1_plan.physics.balance import Tolerance
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.studies.design_spec import DesignSpec, JudgeSettings, Variant

__all__ = ["CODE", "LEVELS", "Task", "cache_path", "check_first", "code_digest", "default_cache", "judge_robot",
           "judge_task", "make_tasks", "read_cached", "run_tasks", "variant_key", "widest_gaps", "write_cached"]

#: the widest-ditch levels, each the least share of the tolerance a crossing must hold at every row
LEVELS: dict[str, float] = {"crossed": 0.0, "half": 0.5, "whole": 1.0 - 1e-9}
FORMAT = 1  # the cached result's layout; part of the key
#: the package's code a variant's result depends on (its digest is part of the key)
CODE = ("control", "kinematics", "optimisers", "physics", "planning", "robot", "geometry.py", "reasons.py",
        "scenario.py", "swing_path.py", "studies/ditch_curve.py", "studies/design.py", "studies/design_spec.py")
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
    package's version and the code's digest (:func:`code_digest`)."""
    h = hashlib.sha256()
    parts = [f"jethr1-plan {__version__} design result {FORMAT}".encode(), code,
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


def widest_gaps(n: int, evaluate: Callable[[int], float | None]) -> dict[int, float | None]:
    """The share of each lattice gap :func:`widest_gaps` planned (index → share, None: not crossable), enough of
    them to place every level of :data:`LEVELS`: for each level (crossed, half, whole, in turn), the largest
    index whose share holds it and the next index planned fails it, found by bisection between the indices
    planned so far (-1 and ``n`` stand for "below" and "beyond" the lattice). Exact for shares that do not grow
    with the index; ``evaluate(k)`` is called at most once per index."""
    shares: dict[int, float | None] = {}
    for level in LEVELS.values():
        while True:
            lo, hi = _bracket(shares, level, n)
            if hi - lo <= 1:
                break
            k = (lo + hi) // 2
            shares[k] = evaluate(k)
    return shares


def _holds(share: float | None, level: float) -> bool:
    return share is not None and share >= level


def _bracket(shares: dict[int, float | None], level: float, n: int) -> tuple[int, int]:
    """(the largest planned index holding ``level`` or -1, the smallest planned index above it failing or n)."""
    lo = max((k for k, s in shares.items() if _holds(s, level)), default=-1)
    hi = min((k for k, s in shares.items() if k > lo and not _holds(s, level)), default=n)
    return lo, hi


def design_base(robot: RobotModel, judge: JudgeSettings):
    """The ditch curve's base scenario for ``robot`` under ``judge``'s optimiser, seed and tolerance."""
    from dataclasses import replace

    from jethr1_plan.studies.ditch_curve import default_base

    base = default_base(robot)
    return replace(base, seed=judge.seed, optimiser=replace(base.optimiser, method=judge.optimiser),
                   balance=replace(base.balance, robust=judge.tolerance))


def _minimal_crossing(scenario) -> dict[str, Any]:
    """Paper A's minimal plan of ``scenario``: its peak thrust over the rows [N], or the reason it is infeasible."""
    import numpy as np

    from jethr1_plan.planning.plan import plan

    try:
        result = plan(scenario)
    except InfeasiblePlan as exc:
        return {"feasible": False, "max_thrust_n": None, "reason": str(exc)}
    rows = result.rows
    assert rows is not None
    peak = max(float(np.max(rows.array(f"thrust_{f.name}"))) for f in scenario.robot.fans)
    return {"feasible": True, "max_thrust_n": peak, "reason": None}


def judge_robot(robot: RobotModel, judge: JudgeSettings) -> dict[str, Any]:
    """A robot's widest ditches (see the module): per level the widest gap crossed [m] (None: not even the
    narrowest), the next gap planned beyond it that fails (None: beyond the lattice's end) and that crossing's
    figures; every gap planned; Paper A's minimal plan at the widest gap crossed."""
    from jethr1_plan.studies.ditch_curve import ditch_scenario, share_of_gap

    base = design_base(robot, judge)
    lattice = judge.lattice()
    planned: dict[int, dict[str, Any]] = {}

    def evaluate(k: int) -> float | None:
        r = share_of_gap(ditch_scenario(base, float(lattice[k]), judge.tolerance, robot.sole_length_m), energy=True)
        planned[k] = r
        return r["share"]

    shares = widest_gaps(len(lattice), evaluate)
    widest: dict[str, Any] = {}
    for name, level in LEVELS.items():
        lo, hi = _bracket(shares, level, len(lattice))
        entry: dict[str, Any] = {"gap_m": float(lattice[lo]) if lo >= 0 else None,
                                 "next_failing_m": float(lattice[hi]) if hi < len(lattice) else None}
        if lo >= 0:
            r = planned[lo]
            entry.update({"share": r["share"], "max_thrust_n": r["max_thrust_n"], "mean_thrust_n": r["mean_thrust_n"],
                          "energy_j": r["energy_j"], "impulse_ns": r["impulse_ns"]})
        widest[name] = entry
    ordered = sorted(shares)
    monotone = all(not (_holds(shares[b], lv) and not _holds(shares[a], lv))
                   for lv in LEVELS.values() for i, a in enumerate(ordered) for b in ordered[i + 1:])
    minimal = None
    if widest["crossed"]["gap_m"] is not None:
        sc = ditch_scenario(base, widest["crossed"]["gap_m"], Tolerance(), robot.sole_length_m)
        minimal = {"gap_m": widest["crossed"]["gap_m"], **_minimal_crossing(sc)}
    gaps = []
    for k in ordered:
        r = planned[k]
        gaps.append({"gap_m": float(lattice[k]), "share": r["share"],
                     **({"max_thrust_n": r["max_thrust_n"], "mean_thrust_n": r["mean_thrust_n"],
                         "energy_j": r["energy_j"], "impulse_ns": r["impulse_ns"],
                         "least_at": r["share_at"]} if r["share"] is not None else {"reason": r["reason"]})})
    fans = [{"name": f.name, "mount": f.mount, "max_thrust_n": f.max_thrust_n, "offset_m": list(f.offset_m)}
            for f in robot.fans]
    return {"status": "ok", "mass_kg": robot.mass_kg, "fans": fans, "thrust_max_n": base.balance.thrust_max_n,
            "widest": widest, "minimal": minimal, "monotone": monotone, "plans": len(planned) + (minimal is not None),
            "gaps": gaps}


def judge_task(task: Task) -> tuple[str, dict[str, Any], dict[str, float]]:
    """Judge one variant (in any process): its files written to a folder of their own, loaded through every
    check of a robot folder, judged, and the folder removed. Returns (key, result, {cpu_s, wall_s})."""
    from jethr1_plan.robot.model import forget_robots, load_robot

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
    from jethr1_plan.robot.model import load_robot
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
    from jethr1_plan.robot.model import forget_robots, load_robot

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
    from jethr1_plan.io.atomic import write_text_atomic
    from jethr1_plan.io.json_text import json_text

    path = cache_path(cache, key)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, json_text({"key": key, "version": __version__, "result": result}))


def _in_process(tasks: list[Task]) -> Iterator[tuple[str, dict[str, Any], dict[str, float]]]:
    for t in tasks:
        yield judge_task(t)


def run_tasks(tasks: dict[str, Task], cache: Path, jobs: int = 1, executor: str = "loky",
              scheduler: str | None = None, progress=None) -> tuple[dict[str, dict[str, Any]], dict[str, Any]]:
    """Every task's result: read from the cache, else judged (in this process with ``jobs`` 1 and no Dask; in
    ``jobs`` loky workers; or on Dask: a local cluster of ``jobs`` workers, or the one at ``scheduler``), each
    kept in the cache as it arrives. Returns (key → result, timings: per judged key its CPU and wall time [s],
    and how many came from the cache)."""
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
    elif jobs == 1:
        collect(_in_process(todo))
    else:
        from joblib import Parallel, delayed

        with Parallel(n_jobs=min(jobs, len(todo)), return_as="generator_unordered") as par:
            collect(par(delayed(judge_task)(t) for t in todo))
    return results, timings


def default_cache(given: Path | str | None = None) -> Path:
    """``given``, else $JETHR1_CACHE, else $XDG_CACHE_HOME/jethr1, else ~/.cache/jethr1."""
    if given:
        return Path(given)
    if os.environ.get("JETHR1_CACHE"):
        return Path(os.environ["JETHR1_CACHE"])
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "jethr1"
