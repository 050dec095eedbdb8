from __future__ import annotations

from pathlib import Path

import pytest

from jethr1_plan.robot.model import load_robot

ROOT = Path(__file__).resolve().parents[1]
#: Jet-HR1's joints as its URDF names them (CONTRACT.md), left leg then right, hip yaw to ankle roll
JOINT_NAMES = tuple(f"{side}_{j}" for side in ("left", "right")
                    for j in ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll"))


@pytest.fixture(scope="session")
def robot():
    return load_robot("jethr1")


@pytest.fixture(scope="session")
def reference(robot):
    from tests.oracles.urdf_reference import UrdfReference

    return UrdfReference(robot.urdf_path)


@pytest.fixture(scope="session")
def side_step_plan(tmp_path_factory):
    """configs/side_step.yaml planned once (a plan folder to copy and tamper with; do not edit it)."""
    from jethr1_plan.cli import run

    out = tmp_path_factory.mktemp("side_step_plan")
    assert run(["plan", str(ROOT / "configs" / "side_step.yaml"), "-o", str(out), "--no-progress"]) == 0
    return out / "side_step"
