from __future__ import annotations

import fcntl
import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from jethr1_plan.robot.load import load_robot

ROOT = Path(__file__).resolve().parents[1]
#: Jet-HR1's joints as its URDF names them (docs/robots.md), left leg then right, hip yaw to ankle roll
JOINT_NAMES = tuple(f"{side}_{j}" for side in ("left", "right")
                    for j in ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll"))


def made_once(tmp_path_factory, key: str, make: Callable[[Path], Path]) -> Path:
    """``make(folder)``'s folder, made once per test run: under pytest-xdist once for all its workers (in the run's
    base temporary folder, under a lock: the others wait for it and read it), else once in this process. What is
    made so is read by tests, never edited (copy it to tamper with)."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        return make(tmp_path_factory.mktemp(key))
    root = tmp_path_factory.getbasetemp().parent / "made_once"  # the run's, shared by its workers
    root.mkdir(exist_ok=True)
    with open(root / f"{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        done = root / f"{key}.done"
        if done.exists():
            return Path(done.read_text())
        out = root / key
        shutil.rmtree(out, ignore_errors=True)  # what a worker that failed half-way left
        out.mkdir()
        made = make(out)
        done.write_text(str(made))
        return made


@pytest.fixture(scope="session")
def robot():
    return load_robot("jethr1")


@pytest.fixture(scope="session")
def reference(robot):
    from tests.oracles.urdf_reference import UrdfReference

    return UrdfReference(robot.urdf_path)


@pytest.fixture(scope="session")
def written(tmp_path_factory) -> dict[str, Path]:
    """One folder of each kind jethr1 writes MCAP files into, written by the commands themselves:
    ``plan`` (the side step, with its feed-forward rehearsal's simulation.mcap), ``walk`` (two steps
    of the DYROS walk, not rehearsed) and ``balance_space`` (Jet-HR1's right support, 10 cm grid)."""
    import yaml

    from jethr1_plan.cli import run

    def make(out: Path) -> Path:
        assert run(["plan", str(ROOT / "configs" / "side_step.yaml"), "-o", str(out), "--no-progress"]) == 0
        assert run(["simulate", str(out / "side_step"), "--no-progress"]) == 0
        doc = yaml.safe_load((ROOT / "configs" / "walks" / "dyros_walk.yaml").read_text())
        doc["footsteps"]["count"] = 2
        doc["name"] = "two_steps"
        walk = out / "two_steps.yaml"
        walk.write_text(yaml.safe_dump(doc))
        assert run(["walk", str(walk), "-o", str(out), "--no-rehearse"]) == 0
        assert run(["balance-space", "--resolution", "0.1", "-j", "1", "-o", str(out / "balance_space"),
                    "--no-progress"]) == 0
        return out

    out = made_once(tmp_path_factory, "written", make)
    return {"plan": out / "side_step", "walk": out / "two_steps", "balance_space": out / "balance_space"}


@pytest.fixture(scope="session")
def plan_of(tmp_path_factory):
    """``plan_of(name)``: the plan folder of ``configs/<name>.yaml`` as ``jethr1 plan`` writes it with its defaults,
    planned once per session for every test that reads it (copy it to tamper with; do not edit it)."""
    from jethr1_plan.cli import run

    folders: dict[str, Path] = {}

    def get(name: str) -> Path:
        if name not in folders:
            def make(out: Path) -> Path:
                assert run(["plan", str(ROOT / "configs" / f"{name}.yaml"), "-o", str(out), "--no-progress"]) == 0
                return out

            folders[name] = made_once(tmp_path_factory, f"plan_{name}", make) / name
        return folders[name]

    return get


@pytest.fixture(scope="session")
def side_step_plan(plan_of):
    """configs/side_step.yaml planned once (a plan folder to copy and tamper with; do not edit it)."""
    return plan_of("side_step")


#: a small carton field for ``jethr1 route`` (coarse 5 cm maps, 10 samples a swing, short timing: seconds; soles
#: 5 mm inside the carton edges, as on the random terrains: the twin survives it feed-forward)
SMALL_TERRAIN = """\
name: small
robot: jethr1
seed: 2
start:
  left: [0.0, 0.1125, 0.0]
  right: [0.0, -0.1125, 0.0]
terrain:
  cartons:
    - {name: start_left, top_centre_m: [0.0, 0.1125, 0.0]}
    - {name: start_right, top_centre_m: [0.0, -0.1125, 0.0]}
    - {name: a, top_centre_m: [0.3, 0.1125, 0.0]}
    - {name: b, top_centre_m: [0.3, -0.1125, 0.0]}
    - {name: goal, top_centre_m: [0.6, 0.0, 0.0], size_m: [0.21, 0.4, 0.14]}
goal: {region: {x_m: [0.495, 0.705], y_m: [-0.2, 0.2]}}
balance: {policy: robust, thrust_max_n: 23.0, sole_margin_m: 0.005}
timing: {swing_s: 2.0, transfer_s: 1.0, rate_hz: 20.0}
route: {map_resolution_m: 0.05, samples: 10, lift_m: 0.0, descent_m: 0.0}  # 2 s swings: no time for vertical ends
"""


@pytest.fixture(scope="session")
def route_cache(tmp_path_factory) -> Path:
    """A map cache for the tests (the 5 cm maps of SMALL_TERRAIN's settings are computed into it once)."""
    return tmp_path_factory.mktemp("route_cache")


@pytest.fixture(scope="session")
def small_route(tmp_path_factory, route_cache) -> Path:
    """SMALL_TERRAIN routed by ``jethr1 route`` (its folder; do not edit it)."""
    from jethr1_plan.cli import run

    out = tmp_path_factory.mktemp("small_route")
    (out / "small.yaml").write_text(SMALL_TERRAIN)
    assert run(["route", str(out / "small.yaml"), "-o", str(out), "--cache", str(route_cache), "--no-progress"]) == 0
    return out / "small"


def rewritten(folder: Path) -> Path:
    """A plan folder whose files were edited, made one thing again as if jethr1 had written them so: the
    trajectory files' digests recorded in summary.json anew, and jethr1's record of the folder (which names
    summary.json's digest) dropped, as a copy without its hidden files would be. What ``verify`` must still
    catch: a consistent folder of wrong rows."""
    import hashlib
    import json

    from jethr1_plan.io.record import RECORD

    summary = json.loads((folder / "summary.json").read_text())
    summary["files"] = {name: {"sha256": hashlib.sha256((folder / name).read_bytes()).hexdigest(),
                               "bytes": (folder / name).stat().st_size}
                        for name in ("trajectory.csv", "trajectory.mcap") if (folder / name).is_file()}
    (folder / "summary.json").write_text(json.dumps(summary, indent=2))
    (folder / RECORD).unlink(missing_ok=True)
    return folder
