"""``optimised_steps.json``: each step of a plan as the planner optimised it, kept in the plan folder
(written by ``jethr1 plan`` beside ``trajectory.csv``, :func:`~jethr1_plan.files.plan_folder.write_plan`),
so that executing the plan step by step (``jethr1 simulate``, :mod:`jethr1_plan.sim.stepwise`) starts
from the plan's own samples instead of optimising its steps again.

The file is one JSON object::

    {"format": "jethr1.optimised_steps", "version": 1,
     "key": "<SHA-256 hex>",                 # what the samples were optimised for (steps_key)
     "trajectory_sha256": "<SHA-256 hex>",   # the trajectory.csv written with them
     "steps": [{"index", "swing", "support", "fan_index": [int],
                "path_m": [[x, y, z], ...],  # the swing sole's samples (N, 3) [m]
                "samples": {"p_body_m": (N, 3), "q_rad": (N, J), "com_m": (N, 3), "thrust_n": (N,),
                            "zmp_xy_m": (N, 2), "edge_excess_rad": (N,), "violation": (N,) int,
                            "window_gap_n": (N,), "split_n": (N, F), "fitness": (N,),
                            "evaluations": (N,) int, "phase": (N,) str, "share": (N,)}}]}

Numbers are JSON numbers written as Python writes a float (the shortest text that reads back to the
same double: they round-trip exactly); a number that is not finite is the string ``"inf"``, ``"-inf"``
or ``"nan"``. ``key`` is :func:`steps_key`: the SHA-256 of the scenario's text, its balance policy and
timing mode (the options ``jethr1 plan`` may override), the robot YAML's and URDF's bytes, the optimiser
and the seed.

Reading (:func:`stored_steps`) never returns samples that are not the folder's plan's: a file that is
missing, of another version of the format, made for another scenario, robot or optimiser (``key``),
written with another ``trajectory.csv`` than the folder's, changed since jethr1 wrote it (the folder's
record, ``io.record``), or that does not read as the format says, gives no steps and the reason in one
line; the caller optimises the steps again (what it did before the file existed).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.io.input_file import read_input
from jethr1_plan.io.json_text import MAX_JSON_BYTES, json_document, json_text
from jethr1_plan.io.record import file_sha256, read_record

if TYPE_CHECKING:
    from jethr1_plan.optimisers.base import SampleResult

__all__ = ["FORMAT", "OPTIMISED_STEPS", "VERSION", "KeptStep", "optimised_steps_json", "read_optimised_steps",
           "scenario_steps_key", "steps_key", "stored_steps"]

OPTIMISED_STEPS = "optimised_steps.json"
FORMAT = "jethr1.optimised_steps"
VERSION = 1
SAMPLE_BYTES = 4_000  # a sample takes about 1.2 kB of the file (indented JSON); at most this [bytes]
SLACK_BYTES = 100_000
NOT_FINITE = {"inf": math.inf, "-inf": -math.inf, "nan": math.nan}

#: per sample: (name in the file, field of ``optimisers.problem.Candidates``, columns or None for one value)
#: with ``"J"``: the robot's joints; ``"F"``: the step's fans
CANDIDATE_FIELDS: tuple[tuple[str, str, int | str | None], ...] = (
    ("p_body_m", "p_body", 3), ("q_rad", "q", "J"), ("com_m", "com", 3), ("thrust_n", "thrust_n", None),
    ("zmp_xy_m", "zmp_xy", 2), ("edge_excess_rad", "edge_excess_rad", None), ("violation", "violation", None),
    ("window_gap_n", "window_gap_n", None), ("split_n", "split_n", "F"))
INTEGER_FIELDS = frozenset({"violation", "evaluations"})


@dataclass
class KeptStep:
    """One step as the file keeps it: the fields of ``planning.results.StepResult`` (which the planner's
    callers make of it)."""

    index: int
    swing: str
    support: str
    path_m: np.ndarray  # (N, 3) the swing sole's samples [m]
    samples: list[SampleResult]
    fan_index: tuple[int, ...]


class _Step(Protocol):
    """What the file keeps of a step (``planning.results.StepResult``, :class:`KeptStep`)."""

    @property
    def index(self) -> int: ...
    @property
    def swing(self) -> str: ...
    @property
    def support(self) -> str: ...
    @property
    def path_m(self) -> np.ndarray: ...
    @property
    def samples(self) -> Sequence[SampleResult]: ...
    @property
    def fan_index(self) -> tuple[int, ...]: ...


class _Robot(Protocol):
    @property
    def yaml_path(self) -> Path: ...
    @property
    def urdf_path(self) -> Path: ...


def steps_key(scenario_text: str, policy: str, timing_mode: str, robot: _Robot, method: str, seed: int) -> str:
    """What a plan's optimised samples depend on, as a SHA-256 (hex): the scenario's text, its balance
    ``policy`` and ``timing_mode`` as planned, the robot YAML's and URDF's bytes, the optimiser ``method``
    and the ``seed``.

    Raises:
        InputError: a robot file cannot be read.
    """
    h = hashlib.sha256()
    for part in (FORMAT, str(VERSION), scenario_text, policy, timing_mode, method, str(seed)):
        data = part.encode("utf-8")
        h.update(len(data).to_bytes(8, "little") + data)
    for path in (robot.yaml_path, robot.urdf_path):
        try:
            digest = file_sha256(Path(path))
        except OSError as exc:
            raise InputError(str(path), "", f"cannot read: {exc.strerror or exc}") from None
        h.update(digest.encode("ascii"))
    return h.hexdigest()


class _Balance(Protocol):
    @property
    def policy(self) -> str: ...


class _Timing(Protocol):
    @property
    def mode(self) -> str: ...


class _Scenario(Protocol):
    @property
    def text(self) -> str: ...
    @property
    def balance(self) -> _Balance: ...
    @property
    def timing(self) -> _Timing: ...
    @property
    def robot(self) -> _Robot: ...


def scenario_steps_key(scenario: _Scenario, method: str, seed: int) -> str:
    """:func:`steps_key` of ``scenario`` (its text, policy, timing mode and robot) planned by ``method``, ``seed``."""
    return steps_key(scenario.text, scenario.balance.policy, scenario.timing.mode, scenario.robot, method, seed)


def _number(x: float) -> float | str:
    x = float(x)
    if math.isfinite(x):
        return x
    return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")


def _numbers(a: np.ndarray) -> list:
    """An array as nested lists of JSON numbers (non-finite values as strings)."""
    a = np.asarray(a)
    if a.dtype.kind in "iu":
        return a.tolist()
    if bool(np.isfinite(a).all()):
        return a.astype(float).tolist()
    if a.ndim == 1:
        return [_number(v) for v in a]
    return [_numbers(row) for row in a]


def optimised_steps_json(steps: Sequence[_Step], key: str, trajectory_sha256: str) -> bytes:
    """The file's bytes for ``steps`` (a plan's ``PlanResult.steps``) optimised under ``key``
    (:func:`steps_key`), written with the ``trajectory.csv`` of SHA-256 ``trajectory_sha256``."""
    out = []
    for st in steps:
        samples: dict[str, Any] = {}
        for name, attr, _ in CANDIDATE_FIELDS:
            col = np.concatenate([getattr(s.best, attr) for s in st.samples]) if st.samples else np.zeros(0)
            samples[name] = _numbers(col)
        samples["fitness"] = [_number(s.fitness) for s in st.samples]
        samples["evaluations"] = [int(s.evaluations) for s in st.samples]
        samples["phase"] = [str(s.phase) for s in st.samples]
        samples["share"] = [_number(s.share) for s in st.samples]
        out.append({"index": int(st.index), "swing": str(st.swing), "support": str(st.support),
                    "fan_index": [int(f) for f in st.fan_index], "path_m": _numbers(st.path_m), "samples": samples})
    doc = {"format": FORMAT, "version": VERSION, "key": key, "trajectory_sha256": trajectory_sha256, "steps": out}
    return json_text(doc).encode("utf-8")


def _array(value: Any, where: str, src: str, rows: int, cols: int | None, integer: bool = False) -> np.ndarray:
    """``value`` as an array of ``rows`` (× ``cols``) numbers (float64, or int64 where ``integer``).

    Raises:
        InputError: not a list of that shape, or an item that is not such a number.
    """
    if not isinstance(value, list) or len(value) != rows:
        raise InputError(src, where, f"expected a list of {rows} {'rows' if cols else 'numbers'}")
    flat: list = value
    if cols is not None:
        if any(not isinstance(r, list) or len(r) != cols for r in value):
            raise InputError(src, where, f"expected {rows} rows of {cols} numbers")
        flat = [v for r in value for v in r]
    if integer:
        if any(type(v) is not int for v in flat):
            raise InputError(src, where, "expected whole numbers")
        out = np.array(flat, dtype=np.int64)
    else:
        for v in flat:
            if type(v) is str:
                if v not in NOT_FINITE:
                    raise InputError(src, where, f"{v[:20]!r} is not a number (\"inf\", \"-inf\" or \"nan\" only)")
            elif type(v) is not float and type(v) is not int:
                raise InputError(src, where, f"{json.dumps(v)[:20]} is not a number")
        out = np.array([NOT_FINITE[v] if type(v) is str else float(v) for v in flat], dtype=np.float64)
    return out if cols is None else out.reshape(rows, cols)


def read_optimised_steps(data: bytes, src: str, joints: int) -> tuple[dict, list[KeptStep]]:
    """The file's header (format, version, key, trajectory_sha256) and its steps, from its bytes; ``joints``:
    the robot's joint count (the width of ``q_rad``).

    Raises:
        InputError: not the format: the first problem, naming the key.
    """
    from jethr1_plan.optimisers.base import SampleResult
    from jethr1_plan.optimisers.problem import Candidates

    doc = json_document(data, src)
    if doc.get("format") != FORMAT:
        raise InputError(src, "format", f"expected {FORMAT!r}")
    if doc.get("version") != VERSION:
        raise InputError(src, "version", f"{doc.get('version')!r}: this jethr1 reads version {VERSION}")
    for name in ("key", "trajectory_sha256"):
        if not isinstance(doc.get(name), str):
            raise InputError(src, name, "expected a SHA-256 in hex")
    steps_doc = doc.get("steps")
    if not isinstance(steps_doc, list):
        raise InputError(src, "steps", "expected a list of steps")
    steps = []
    for k, sd in enumerate(steps_doc):
        at = f"steps[{k}]"
        if not isinstance(sd, dict):
            raise InputError(src, at, "expected an object")
        for name in ("swing", "support"):
            if sd.get(name) not in ("left", "right"):
                raise InputError(src, f"{at}.{name}", "expected 'left' or 'right'")
        if type(sd.get("index")) is not int:
            raise InputError(src, f"{at}.index", "expected a whole number")
        fans = sd.get("fan_index")
        if not isinstance(fans, list) or any(type(f) is not int or f < 0 for f in fans):
            raise InputError(src, f"{at}.fan_index", "expected a list of fan indices")
        path = sd.get("path_m")
        path_m = _array(path, f"{at}.path_m", src, len(path) if isinstance(path, list) else 0, 3)
        samples = sd.get("samples")
        if not isinstance(samples, dict):
            raise InputError(src, f"{at}.samples", "expected an object")
        n = len(samples["phase"]) if isinstance(samples.get("phase"), list) else 0
        widths = {"J": joints, "F": len(fans)}
        cols = {}
        for name, attr, width in CANDIDATE_FIELDS:
            w = widths[width] if isinstance(width, str) else width
            cols[attr] = _array(samples.get(name), f"{at}.samples.{name}", src, n, w, name in INTEGER_FIELDS)
        fitness = _array(samples.get("fitness"), f"{at}.samples.fitness", src, n, None)
        evaluations = _array(samples.get("evaluations"), f"{at}.samples.evaluations", src, n, None, True)
        share = _array(samples.get("share"), f"{at}.samples.share", src, n, None)
        phase = samples.get("phase")
        if not isinstance(phase, list) or len(phase) != n or any(not isinstance(p, str) for p in phase):
            raise InputError(src, f"{at}.samples.phase", f"expected a list of {n} names")
        out = [SampleResult(Candidates(**{f: c[i:i + 1].copy() for f, c in cols.items()}), float(fitness[i]),
                            int(evaluations[i]), phase[i], float(share[i])) for i in range(n)]
        steps.append(KeptStep(sd["index"], sd["swing"], sd["support"], path_m, out, tuple(fans)))
    return doc, steps


def stored_steps(folder: Path, summary: dict, key: str, joints: int) -> tuple[list[KeptStep] | None, str]:
    """The plan folder's optimised steps where its :data:`OPTIMISED_STEPS` holds those of its plan, optimised
    under ``key`` (:func:`steps_key` of the scenario, robot and optimiser the folder's plan is of now), and
    written with the folder's ``trajectory.csv`` (the digest ``summary`` records, which ``folders.plan.read_plan``
    checked against the file); else None and why, in one line (the module docstring). ``joints``: the robot's
    joint count."""
    path = Path(folder) / OPTIMISED_STEPS
    if not os.path.lexists(path):
        return None, f"{path}: missing (a folder written by an earlier jethr1, or not by jethr1 plan)"
    files = summary.get("files")
    traj = files.get("trajectory.csv") if isinstance(files, dict) else None
    traj_sha = traj.get("sha256") if isinstance(traj, dict) else None
    count = summary.get("sample_count")
    limit = (count * SAMPLE_BYTES + SLACK_BYTES if type(count) is int and count >= 0 else MAX_JSON_BYTES)
    try:
        data = read_input(path, min(limit, MAX_JSON_BYTES), f"an {OPTIMISED_STEPS}")
        rec = read_record(Path(folder)).get(OPTIMISED_STEPS)
        if rec is not None and (rec["bytes"] != len(data) or rec["sha256"] != hashlib.sha256(data).hexdigest()):
            return None, f"{path}: changed since jethr1 wrote it (not the file the folder's record names)"
        doc, steps = read_optimised_steps(data, str(path), joints)
    except InputError as exc:
        return None, str(exc)
    if doc["trajectory_sha256"] != traj_sha:
        return None, f"{path}: trajectory_sha256: written with another trajectory.csv than the folder's"
    if doc["key"] != key:
        return None, (f"{path}: key: optimised for another scenario, robot or optimiser than the folder's plan is "
                      "of now")
    return steps, ""

