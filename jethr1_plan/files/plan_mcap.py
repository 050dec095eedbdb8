"""``trajectory.mcap``: a plan's columns (:mod:`.plan_table`) as messages, written and read here.

Topics: ``/robot_description`` (the URDF), ``/tf`` (world→trunk and every URDF joint's parent→child
link), ``/joint_states`` (positions, servo commands, static torques), ``/thrust`` (per fan, with the
window, the margin, the phase and the row's verdict), ``/p_body``, ``/com``, ``/zmp``, ``/terrain``
and ``/swing_path``, ``/analysis`` (κ per leg, yaw momentum). Times from the plan's start after the
fixed epoch of :mod:`.mcap`.
"""

from __future__ import annotations

import math

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.mcap import (
    EPOCH_NS,
    SCHEMAS,
    TOPICS,
    JsonMcap,
    frame_transforms,
    joint_rotations,
    pose_message,
    read_mcap,
    stamp,
    swing_path_update,
    terrain_update,
    thrust_schema,
)
from jethr1_plan.files.plan_table import BOOL_COLUMNS, TEXT_COLUMNS
from jethr1_plan.geometry import quat_axis_angle
from jethr1_plan.robot.model import RobotModel

__all__ = ["MAX_MCAP_BYTES", "read_trajectory_mcap", "trajectory_mcap"]

MAX_MCAP_BYTES = 500_000_000


def trajectory_mcap(robot: RobotModel, rows, cartons, paths) -> bytes:
    """The MCAP bytes of a planned trajectory (zstd-compressed chunks)."""
    fans = [f.name for f in robot.fans]
    out = JsonMcap({**SCHEMAS, "jethr1.Thrust": thrust_schema(fans)}, TOPICS)
    put = out.put
    put("/robot_description", 0.0, {"data": robot.urdf_path.read_text(encoding="utf-8")})
    put("/terrain", 0.0, terrain_update(cartons))
    put("/swing_path", 0.0, swing_path_update(paths))
    c = rows.columns
    names = list(robot.joint_names)
    rotations = joint_rotations(robot, np.asarray(c["q"])) if len(rows) else []
    for i in range(len(rows)):
        t = float(c["time_s"][i])
        p, yaw, q = c["p_body"][i], float(c["yaw"][i]), np.asarray(c["q"][i])
        put("/tf", t, frame_transforms(robot, t, p, quat_axis_angle((0, 0, 1), yaw), q, [r[i] for r in rotations]))
        put("/joint_states", t, {"timestamp": stamp(t), "name": names, "position_rad": [float(v) for v in q],
                                 "command_rad": [float(v) for v in c["q_cmd"][i]],
                                 "effort_nm": [float(v) for v in c["tau"][i]]})
        put("/analysis", t, {"timestamp": stamp(t), "kappa_left": float(c["kappa"][i][0]),
                             "kappa_right": float(c["kappa"][i][1]),
                             "yaw_momentum_nms": float(c["yaw_momentum"][i])})
        put("/thrust", t, {"timestamp": stamp(t), **{f"{f}_n": float(c[f"thrust_{f}"][i]) for f in fans},
                           "phase": c["phase"][i],
                           "support": c["support"][i], "step": int(c["step"][i]), "sample": int(c["sample"][i]),
                           "feasible": bool(c["feasible"][i]), "reason": c["reason"][i],
                           **{f"{f}_cmd_n": float(c[f"thrust_cmd_{f}"][i]) for f in fans},
                           "window_lo_n": _or_none(c["window"][i][0]), "window_hi_n": _or_none(c["window"][i][1]),
                           "zmp_margin_m": float(c["zmp_margin"][i])})
        put("/p_body", t, {"timestamp": stamp(t), "frame_id": "world",
                           "pose": pose_message(p, quat_axis_angle((0, 0, 1), yaw))})
        put("/com", t, {"timestamp": stamp(t), "frame_id": "world", "pose": pose_message(c["com"][i])})
        zmp = c["zmp"][i]
        put("/zmp", t, {"timestamp": stamp(t), "frame_id": "world",
                        "pose": pose_message((zmp[0], zmp[1], _ground(c, i)))})
    return out.finish()


def _or_none(x: float) -> float | None:
    """A number, or None (JSON null) where there is none (NaN)."""
    return None if math.isnan(x) else float(x)


def _ground(c: dict, i: int) -> float:
    """Height of the ZMP: the support sole's height (the lower sole in double support)."""
    return float(c["ground_z"][i]) if "ground_z" in c else 0.0



def read_trajectory_mcap(data: bytes, source: str, robot: RobotModel) -> tuple[dict[str, np.ndarray], list[np.ndarray]]:
    """A plan's table from its MCAP (the ``/joint_states``, ``/thrust``, ``/p_body``, ``/com``, ``/zmp`` and
    ``/analysis`` of each instant) and its swing paths."""
    if len(data) > MAX_MCAP_BYTES:
        raise InputError(source, "", f"{len(data):,} bytes: larger than any plan's MCAP")
    try:
        messages = read_mcap(data)
    except Exception as exc:  # the mcap reader raises many kinds on a corrupt file
        raise InputError(source, "", f"not a valid MCAP file ({type(exc).__name__}: {str(exc)[:80]})") from None
    by_time: dict[int, dict] = {}
    paths: list[np.ndarray] = []
    joints, fans = robot.joint_names, [f.name for f in robot.fans]
    per_row = ("/joint_states", "/thrust", "/p_body", "/com", "/zmp", "/analysis")
    try:
        for topic, _schema, msg, t in messages:
            if topic == "/swing_path":
                for ent in msg["entities"]:
                    for line in ent["lines"]:
                        paths.append(np.array([[p["x"], p["y"], p["z"]] for p in line["points"]], dtype=float))
            elif topic in per_row:
                row = by_time.setdefault(t, {})
                if topic in row:
                    raise InputError(source, topic, f"two messages at t = {(t - EPOCH_NS) / 1e9:.3f} s")
                row[topic] = msg
        times = sorted(by_time)
        cols: dict[str, list] = {}
        for t in times:
            r = by_time[t]
            lacking = [k for k in per_row if k not in r]
            if lacking:
                raise InputError(source, lacking[0], f"no message at t = {(t - EPOCH_NS) / 1e9:.3f} s")
            pose, com, zmp = r["/p_body"]["pose"], r["/com"]["pose"]["position"], r["/zmp"]["pose"]["position"]
            js, th, an = r["/joint_states"], r["/thrust"], r["/analysis"]
            pos = dict(zip(js["name"], js["position_rad"], strict=True))
            cmd = dict(zip(js["name"], js["command_rad"], strict=True))
            tau = dict(zip(js["name"], js["effort_nm"], strict=True))
            vals = {"time_s": (t - EPOCH_NS) / 1e9, "step": th["step"], "phase": th["phase"], "sample": th["sample"],
                    "support": th["support"], "feasible": th["feasible"], "reason": th["reason"],
                    "pelvis_x_m": pose["position"]["x"], "pelvis_y_m": pose["position"]["y"],
                    "pelvis_z_m": pose["position"]["z"], **{f"pelvis_q{k}": pose["orientation"][k] for k in "xyzw"},
                    **{f"{j}_rad": pos[j] for j in joints}, **{f"thrust_{f}_n": th[f"{f}_n"] for f in fans},
                    "com_x_m": com["x"], "com_y_m": com["y"], "com_z_m": com["z"],
                    "zmp_x_m": zmp["x"], "zmp_y_m": zmp["y"],
                    "thrust_window_lo_n": np.nan if th["window_lo_n"] is None else th["window_lo_n"],
                    "thrust_window_hi_n": np.nan if th["window_hi_n"] is None else th["window_hi_n"],
                    "zmp_margin_m": th["zmp_margin_m"], **{f"{j}_tau_nm": tau[j] for j in joints},
                    "kappa_left": an["kappa_left"], "kappa_right": an["kappa_right"],
                    "yaw_momentum_nms": an["yaw_momentum_nms"], **{f"{j}_cmd_rad": cmd[j] for j in joints},
                    **{f"thrust_cmd_{f}_n": th[f"{f}_cmd_n"] for f in fans}}
            for k, v in vals.items():
                cols.setdefault(k, []).append(v)
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(source, "", f"not a trajectory of this format ({type(exc).__name__}: "
                         f"{str(exc)[:60]})") from None
    out = {k: np.array(v, dtype=object if k in TEXT_COLUMNS else (bool if k in BOOL_COLUMNS else float))
           for k, v in cols.items()}
    return out, paths
