from __future__ import annotations

from pathlib import Path

import pytest

from jethr1_plan.robot.model import load_robot

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def robot():
    return load_robot("jethr1")


@pytest.fixture(scope="session")
def reference(robot):
    from tests.urdf_reference import UrdfReference

    return UrdfReference(robot.urdf_path)
