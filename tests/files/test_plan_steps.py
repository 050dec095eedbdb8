"""``optimised_steps.json``: a plan's optimised steps kept in its folder, read back to the bit, and never
taken for another plan's (its key, its trajectory, jethr1's record of the folder)."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_steps import (
    OPTIMISED_STEPS,
    optimised_steps_json,
    read_optimised_steps,
    steps_key,
    stored_steps,
)
from jethr1_plan.planning.plan import plan
from jethr1_plan.scenario import load_scenario_text
from tests.sim.test_stepwise import TWO_STEPS

KEY, TRAJ = "k" * 64, "t" * 64


def assert_same_steps(a, b) -> None:
    """Every field of every step and sample equal to the bit, with the same dtypes and shapes."""
    assert len(a) == len(b)
    for sa, sb in zip(a, b, strict=True):
        assert (sa.index, sa.swing, sa.support, tuple(sa.fan_index)) == (sb.index, sb.swing, sb.support,
                                                                          tuple(sb.fan_index))
        assert sa.path_m.dtype == sb.path_m.dtype and sa.path_m.tobytes() == sb.path_m.tobytes()
        assert len(sa.samples) == len(sb.samples)
        for xa, xb in zip(sa.samples, sb.samples, strict=True):
            assert (xa.evaluations, xa.phase) == (xb.evaluations, xb.phase)
            assert np.float64(xa.fitness).tobytes() == np.float64(xb.fitness).tobytes()
            assert np.float64(xa.share).tobytes() == np.float64(xb.share).tobytes()
            for f in xa.best.__dataclass_fields__:
                va, vb = getattr(xa.best, f), getattr(xb.best, f)
                assert va.dtype == vb.dtype and va.shape == vb.shape and va.tobytes() == vb.tobytes(), f


@pytest.fixture(scope="module")
def planned():
    sc = load_scenario_text(TWO_STEPS, "two_steps.yaml")
    return sc, plan(sc)


def test_steps_read_back_to_the_bit_non_finite_values_too(planned):
    sc, result = planned
    steps = [replace(st) for st in result.steps]
    x = steps[1].samples[3]
    odd = replace(x.best, thrust_n=np.array([math.inf]), window_gap_n=np.array([-math.inf]),
                  split_n=np.full_like(x.best.split_n, math.nan), com=x.best.com * 0.0 * -1.0,
                  p_body=x.best.p_body + 1e-17)  # -0.0, and a last bit that only repr keeps
    steps[1] = replace(steps[1], samples=[*steps[1].samples[:3], replace(x, best=odd, fitness=math.inf),
                                          *steps[1].samples[4:]])
    data = optimised_steps_json(steps, KEY, TRAJ)
    doc, back = read_optimised_steps(data, "f.json", len(sc.robot.joint_names))
    assert (doc["key"], doc["trajectory_sha256"]) == (KEY, TRAJ)
    assert_same_steps(back, steps)
    s = json.loads(data)["steps"][1]["samples"]
    assert s["thrust_n"][3] == "inf" and s["window_gap_n"][3] == "-inf" and s["split_n"][3][0] == "nan"
    assert math.copysign(1.0, back[1].samples[3].best.com[0, 0]) == -1.0


def test_the_key_changes_with_everything_the_samples_depend_on(tmp_path):
    (tmp_path / "r.yaml").write_text("name: r\n")
    (tmp_path / "r.urdf").write_text("<robot/>\n")
    robot = SimpleNamespace(yaml_path=tmp_path / "r.yaml", urdf_path=tmp_path / "r.urdf")
    args = ("name: s\n", "robust", "fixed", robot, "sqp", 1)
    base = steps_key(*args)
    assert steps_key(*args) == base
    others = [steps_key("name: s \n", *args[1:]), steps_key(args[0], "minimal", *args[2:]),
              steps_key(*args[:2], "fastest", *args[3:]), steps_key(*args[:4], "gas", 1), steps_key(*args[:5], 2),
              steps_key("", "name: s\nrobust", *args[2:])]  # parts do not run into one another
    (tmp_path / "r.yaml").write_text("name: r \n")
    others.append(steps_key(*args))
    (tmp_path / "r.yaml").write_text("name: r\n")
    (tmp_path / "r.urdf").write_text("<robot />\n")
    others.append(steps_key(*args))
    assert len({base, *others}) == len(others) + 1


def _bad(data: bytes, sc) -> InputError:
    with pytest.raises(InputError) as exc:
        read_optimised_steps(data, "f.json", len(sc.robot.joint_names))
    return exc.value


@pytest.mark.parametrize(("edit", "key", "problem"), [
    (lambda d: d.update(version=2), "version", "reads version 1"),
    (lambda d: d.update(format="x"), "format", "expected"),
    (lambda d: d["steps"][1]["samples"]["q_rad"][2].pop(), "steps[1].samples.q_rad", "rows of 12 numbers"),
    (lambda d: d["steps"][0]["samples"]["p_body_m"][0].__setitem__(1, "0.1"), "steps[0].samples.p_body_m",
     "is not a number"),
    (lambda d: d["steps"][0]["samples"]["share"].__setitem__(0, True), "steps[0].samples.share", "is not a number"),
    (lambda d: d["steps"][0]["samples"]["violation"].__setitem__(0, 0.5), "steps[0].samples.violation", "whole"),
    (lambda d: d["steps"][1]["samples"]["phase"].pop(), "steps[1].samples", "expected a list of 15"),
    (lambda d: d["steps"][0].update(swing="up"), "steps[0].swing", "'left' or 'right'"),
    (lambda d: d["steps"][0]["samples"]["split_n"].__setitem__(0, []), "steps[0].samples.split_n", "rows of 1"),
])
def test_a_file_not_of_the_format_names_its_key(planned, edit, key, problem):
    sc, result = planned
    doc = json.loads(optimised_steps_json(result.steps, KEY, TRAJ))
    edit(doc)
    exc = _bad(json.dumps(doc).encode(), sc)
    assert exc.key.startswith(key) and problem in exc.problem, str(exc)
    assert _bad(b"{not json", sc).key == ""


def _folder(tmp_path: Path, result, key: str, traj: bytes = b"rows\n") -> tuple[Path, dict]:
    folder = tmp_path / "p"
    folder.mkdir(exist_ok=True)
    (folder / "trajectory.csv").write_bytes(traj)
    (folder / OPTIMISED_STEPS).write_bytes(optimised_steps_json(result.steps, key, hashlib.sha256(traj).hexdigest()))
    summary = {"files": {"trajectory.csv": {"sha256": hashlib.sha256(traj).hexdigest(), "bytes": len(traj)}},
               "sample_count": sum(len(st.samples) for st in result.steps)}
    return folder, summary


def test_stored_steps_are_used_only_where_they_are_the_folders_plans(planned, tmp_path):
    _, result = planned
    folder, summary = _folder(tmp_path, result, KEY)
    steps, why = stored_steps(folder, summary, KEY, 12)
    assert why == "" and steps is not None
    assert_same_steps(steps, result.steps)
    # optimised for another scenario, robot or optimiser
    steps, why = stored_steps(folder, summary, "x" * 64, 12)
    assert steps is None and why.startswith(f"{folder / OPTIMISED_STEPS}: key: ")
    # written with another trajectory.csv than the folder's
    other = {**summary, "files": {"trajectory.csv": {"sha256": "0" * 64, "bytes": 5}}}
    steps, why = stored_steps(folder, other, KEY, 12)
    assert steps is None and "trajectory_sha256" in why
    # changed since jethr1 wrote it (the folder's record names other bytes)
    from jethr1_plan.io.record import RECORD, record_text

    data = (folder / OPTIMISED_STEPS).read_bytes()
    (folder / RECORD).write_text(record_text({OPTIMISED_STEPS: {"sha256": "0" * 64, "bytes": len(data)}}))
    steps, why = stored_steps(folder, summary, KEY, 12)
    assert steps is None and "changed since jethr1 wrote it" in why
    (folder / RECORD).unlink()
    # missing: a folder of an earlier jethr1
    (folder / OPTIMISED_STEPS).unlink()
    steps, why = stored_steps(folder, summary, KEY, 12)
    assert steps is None and "missing" in why


def test_not_a_file_where_the_steps_are_kept_is_said_and_not_read(planned, tmp_path):
    import os

    _, result = planned
    folder, summary = _folder(tmp_path, result, KEY)
    (folder / OPTIMISED_STEPS).unlink()
    os.mkfifo(folder / OPTIMISED_STEPS)  # a read would block
    steps, why = stored_steps(folder, summary, KEY, 12)
    assert steps is None and why.startswith(f"{folder / OPTIMISED_STEPS}: a FIFO")


def test_a_users_file_of_the_name_is_refused_before_planning(tmp_path, capsys, monkeypatch):
    from jethr1_plan.cli import run
    from jethr1_plan.pipeline import plan as pipeline

    monkeypatch.setattr(pipeline, "plan", pytest.fail)  # refused before any planning
    (tmp_path / "two_steps.yaml").write_text(TWO_STEPS)
    (tmp_path / "o" / "two_steps").mkdir(parents=True)
    (tmp_path / "o" / "two_steps" / OPTIMISED_STEPS).write_text("mine")
    assert run(["plan", str(tmp_path / "two_steps.yaml"), "-o", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert OPTIMISED_STEPS in err and "Traceback" not in err
    assert sorted(p.name for p in (tmp_path / "o" / "two_steps").iterdir()) == [OPTIMISED_STEPS]
    assert (tmp_path / "o" / "two_steps" / OPTIMISED_STEPS).read_text() == "mine"
