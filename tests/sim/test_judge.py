"""sim.judge: where each landing is judged (the last row of the transfer after its swing), whether a sole stands
on a carton top (level, within 5 mm of its height, fully on it), and a run's record without its recording."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from jethr1_plan.sim.judge import ON_TOP_TOL_M, RunResult, landing_rows, on_cartons
from jethr1_plan.swing_path import Carton


class _Track(SimpleNamespace):
    def __len__(self) -> int:
        return len(self.phase)


def test_each_landing_is_judged_at_the_end_of_the_transfer_after_its_swing() -> None:
    phase = ["transfer"] * 3 + ["swing"] * 4 + ["transfer"] * 3 + ["swing"] * 4 + ["transfer"] * 2
    step = [0] * 3 + [0] * 4 + [1] * 3 + [1] * 4 + [2] * 2  # transfers carry the step they lead into
    support = ["both"] * 3 + ["right"] * 4 + ["both"] * 3 + ["left"] * 4 + ["both"] * 2
    track = _Track(phase=np.array(phase), step=np.array(step), support=np.array(support))
    assert landing_rows(track) == [(9, 0, "left"), (15, 1, "right")]


def _yaw_xmat(yaw: float, tilt: float = 0.0) -> np.ndarray:
    """A sole's rotation matrix, row-major (MuJoCo's xmat): yaw about z, then a tilt about x."""
    c, s, ct, st = math.cos(yaw), math.sin(yaw), math.cos(tilt), math.sin(tilt)
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, ct, -st], [0, st, ct]])
    return (Rz @ Rx).ravel()


def test_a_sole_is_on_a_carton_when_level_at_its_height_and_fully_on_it(robot) -> None:
    carton = Carton((0.3, 0.0, 0.14), (0.21, 0.11, 0.14))
    on = np.array([0.3, 0.0, 0.14 + 0.5 * ON_TOP_TOL_M])
    assert on_cartons(robot, (carton,), on, _yaw_xmat(0.0))
    assert not on_cartons(robot, (carton,), on + np.array([0.0, 0.0, 2 * ON_TOP_TOL_M]), _yaw_xmat(0.0))  # above it
    assert not on_cartons(robot, (carton,), on, _yaw_xmat(0.0, tilt=math.radians(10)))  # tipped
    assert not on_cartons(robot, (carton,), on + np.array([0.0, 0.05, 0.0]), _yaw_xmat(0.0))  # half off its side
    assert not on_cartons(robot, (carton,), on, _yaw_xmat(math.pi / 2))  # turned across a narrow top
    assert on_cartons(robot, (), np.array([1.0, 2.0, 0.001]), _yaw_xmat(1.0))  # no cartons: the ground


def test_a_runs_record_leaves_its_recording_out() -> None:
    run = RunResult("feedback", True, {}, True, None, 1.0, 0.5, 0.001, 0.02, None, [], {"left": True}, 20.0, 10.0,
                    1.0, record={"t": [0.0]}, law="imu_tilt_pid")
    doc = run.as_dict()
    assert "record" not in doc and doc["law"] == "imu_tilt_pid" and doc["survived"] is True
