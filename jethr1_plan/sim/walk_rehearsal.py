"""A generated walk rehearsed in the MuJoCo twin (``sim.twin``): the position servos follow the walk's
joint rows (or their sag-compensated commands) from its first posture, and the run falls when the trunk tilts more than
``FALL_TILT_DEG`` from level or sinks more than ``FALL_DROP_M`` below the plan; it ends with both
soles measured against their last footholds.
"""

from __future__ import annotations

import math

import numpy as np

from jethr1_plan.sim.twin import build_twin
from jethr1_plan.walking.result import WalkRun

__all__ = ["FALL_DROP_M", "FALL_TILT_DEG", "rehearse_walk"]

FALL_TILT_DEG = 10.0  # a trunk tilted more than this from level has fallen [deg]
FALL_DROP_M = 0.10  # a trunk this far below its planned height has fallen [m]
SETTLE_S = 0.5  # the first posture held before the walk starts [s]
HOLD_S = 1.0  # the last posture held after it [s]


def _tilt_deg(R: np.ndarray) -> float:
    """The angle between a frame's z axis and the vertical [deg]."""
    return math.degrees(math.acos(float(np.clip(R[2, 2], -1.0, 1.0))))


def rehearse_walk(walk, commands_rad: np.ndarray | None = None) -> WalkRun:
    """Replay ``walk`` (a ``walking.generator.Walk``) in the twin of its robot on flat ground, the
    servos following ``commands_rad`` (N, J) (default: the joint rows themselves)."""
    import mujoco

    robot = walk.robot
    twin = build_twin(robot, ())
    m = twin.model
    d = mujoco.MjData(m)

    def place(i: int) -> None:
        T = walk.base[i]
        d.qpos[:3] = T[:3, 3]
        w, x, y, z = _wxyz(T[:3, :3])
        d.qpos[3:7] = [w, x, y, z]
        d.qpos[twin.qpos_adr] = walk.q[i]

    cmd = walk.q if commands_rad is None else np.asarray(commands_rad, dtype=float)
    place(0)
    mujoco.mj_forward(m, d)
    # the first posture rests its soles on the floor: lift or lower the whole robot onto it
    lowest = min(d.xpos[twin.foot_bodies[s]][2] for s in twin.foot_bodies)
    d.qpos[2] -= lowest
    mujoco.mj_forward(m, d)
    dt = m.opt.timestep
    rows = len(walk.t)
    rate = 1.0 / float(walk.t[1] - walk.t[0])
    n_settle, n_walk, n_hold = round(SETTLE_S / dt), round(float(walk.t[-1]) / dt), round(HOLD_S / dt)
    z_offset = -lowest
    max_tilt = 0.0
    for k in range(n_settle + n_walk + n_hold):
        t = (k - n_settle) * dt
        x = min(max(t * rate, 0.0), rows - 1.0)
        i = min(int(x), rows - 2)
        a = x - i
        d.ctrl[:] = (1 - a) * cmd[i] + a * cmd[i + 1]
        mujoco.mj_step(m, d)
        if k % 10:
            continue
        R = d.xmat[twin.trunk].reshape(3, 3)
        tilt = _tilt_deg(R)
        max_tilt = max(max_tilt, tilt)
        planned_z = (1 - a) * walk.base[i][2, 3] + a * walk.base[i + 1][2, 3] + z_offset
        if tilt > FALL_TILT_DEG or d.xpos[twin.trunk][2] < planned_z - FALL_DROP_M:
            reason = (f"trunk tilted {tilt:.1f} deg" if tilt > FALL_TILT_DEG else
                      f"trunk {planned_z - d.xpos[twin.trunk][2]:.2f} m below the plan")
            return WalkRun(False, max(t, 0.0), reason, max_tilt, math.nan, (k + 1) * dt)
    last = walk.timeline.footholds()
    error = max(float(np.linalg.norm(d.xpos[twin.foot_bodies[s]][:2] - last[s][-1][:2])) for s in last)
    return WalkRun(True, None, "", max_tilt, error, (n_settle + n_walk + n_hold) * dt)


def _wxyz(R: np.ndarray) -> tuple[float, float, float, float]:
    """MuJoCo's quaternion (w, x, y, z) of a rotation matrix."""
    import mujoco

    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).ravel())
    return float(q[0]), float(q[1]), float(q[2]), float(q[3])
