"""The files of a walk folder (``jethr1 walk``): ``trajectory.csv``, ``trajectory.mcap``,
``summary.json`` and Paper B's figures (``yaw.png``: Figs. 8/9, ``momentum.png``: Figs. 12/16,
``kappa.png``: Fig. 13), written atomically into OUTDIR/<walk file stem>/.

``trajectory.csv`` has one row per control period; its columns (SI units in their names):
``time_s, step, support``, the trunk pose ``pelvis_x_m … pelvis_qw``, every joint ``<joint>_rad``,
the soles reached ``left_foot_x_m …``, the CoM of the posture ``com_*_m`` and of the LIPM
``com_ref_*_m``, the multibody ZMP ``zmp_*_m`` (from the joints' motion), (B-18)'s reference
``zmp_ref_*_m`` and the LIPM's ``zmp_lipm_*_m``, ``zmp_margin_m`` (inside the support polygon),
``yaw_ref_rad`` (B-30), ``yaw_rad`` and ``yaw_rate_rad_s`` (B-34..B-38), ``kappa`` (B-45), the yaw
momentum of the lower and the upper body ``h_lower_nms``/``h_upper_nms`` (B-41, B-42) and every
joint's torque ``<joint>_tau_nm`` by inverse dynamics, and the servo commands ``<joint>_cmd_rad``
(the row plus the sag its torque causes: what to send to position servos).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from jethr1_plan.files.mcap import (
    ROBOT_DESCRIPTION_SCHEMA,
    SCHEMAS,
    TIME,
    JsonMcap,
    frame_transforms,
    joint_rotations,
    pose_message,
    scene_entity,
    stamp,
)
from jethr1_plan.geometry import SIDES, quat_axis_angle, quaternion_from_matrix
from jethr1_plan.io.atomic import staged_directory
from jethr1_plan.io.csv_table import csv_text, number_text, read_csv_table
from jethr1_plan.io.json_text import json_text
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.walking.result import WalkResult

__all__ = ["WALK_FILES", "WALK_TOPICS", "read_walk_csv", "walk_columns", "walk_csv", "walk_figures", "walk_folder",
           "walk_mcap", "write_walk_outputs"]

#: the files ``jethr1 walk`` writes into a walk folder (any other file there is the user's and is kept)
WALK_FILES = frozenset({"trajectory.csv", "trajectory.mcap", "summary.json", "yaw.png", "momentum.png",
                        "kappa.png"})
_XYZ = ("x", "y", "z")
_FIXED_HEAD = ("time_s", "step", "support", *(f"pelvis_{a}_m" for a in _XYZ),
               *(f"pelvis_q{a}" for a in ("x", "y", "z", "w")))
_FIXED_TAIL = (*(f"{s}_foot_{a}_m" for s in SIDES for a in _XYZ), *(f"com_{a}_m" for a in _XYZ),
               "com_ref_x_m", "com_ref_y_m", "zmp_x_m", "zmp_y_m", "zmp_ref_x_m", "zmp_ref_y_m", "zmp_lipm_x_m",
               "zmp_lipm_y_m", "zmp_margin_m", "yaw_ref_rad", "yaw_rad", "yaw_rate_rad_s", "kappa", "h_lower_nms",
               "h_upper_nms")


def walk_columns(robot: RobotModel) -> list[str]:
    """The header of a walk's ``trajectory.csv`` for ``robot``."""
    return [*_FIXED_HEAD, *(f"{j}_rad" for j in robot.joint_names), *_FIXED_TAIL,
            *(f"{j}_tau_nm" for j in robot.joint_names), *(f"{j}_cmd_rad" for j in robot.joint_names)]


def walk_csv(result: WalkResult) -> str:
    """The CSV text of a walk (shortest round-tripping numbers)."""
    walk, a = result.walk, result.analysis
    num = number_text

    def row(i: int) -> list[str]:
        T = walk.base[i]
        vals = [num(round(float(walk.t[i]), 9)), str(int(walk.step[i])), str(walk.support[i]),
                *map(num, T[:3, 3]), *map(num, quaternion_from_matrix(T[:3, :3])), *map(num, walk.q[i]),
                *(num(v) for s in SIDES for v in walk.feet[s][i][:3, 3]), *map(num, walk.com[i]),
                *map(num, walk.com_ref[i][:2]), *map(num, a.zmp[i]), *map(num, walk.zmp_ref[i]),
                *map(num, walk.zmp_lipm[i]), num(a.zmp_margin[i]), num(walk.yaw_ref[i]), num(walk.yaw[i]),
                num(walk.yaw_rate[i]), num(a.kappa[i]), num(walk.h_low[i]), num(walk.h_up[i]), *map(num, a.tau[i]),
                *map(num, result.commands_rad[i])]
        return vals

    return csv_text(walk_columns(walk.robot), (row(i) for i in range(len(walk.t))))


def _walk_column(name: str) -> bool:
    return name in _FIXED_HEAD or name in _FIXED_TAIL or (name.endswith(("_rad", "_tau_nm", "_cmd_rad"))
                                                          and len(name) > 7)


def read_walk_csv(text: str, source: str = "trajectory.csv") -> dict[str, np.ndarray]:
    """A walk's ``trajectory.csv`` as columns (``support`` as text, the rest as floats).

    Raises:
        InputError: the header is not a walk's, a row is cut or a number does not parse.
    """
    return read_csv_table(text, source, _walk_column, ("support",))


# --- MCAP -------------------------------------------------------------------------------------

_ARRAY = {"type": "array", "items": {"type": "number"}}
_WALK_SCHEMAS = {
    "jethr1.YawHorizon": {"title": "jethr1.YawHorizon", "type": "object", "properties": {
        "timestamp": TIME, "dt_s": {"type": "number"}, "time_s": _ARRAY, "yaw_ref_rad": _ARRAY,
        "yaw_rad": {"type": "number"}, "yaw_rate_rad_s": {"type": "number"}},
        "required": ["timestamp", "dt_s", "time_s", "yaw_ref_rad", "yaw_rad", "yaw_rate_rad_s"]},
    "jethr1.WalkAnalysis": {"title": "jethr1.WalkAnalysis", "type": "object", "properties": {
        "timestamp": TIME, "support": {"enum": ["left", "right", "both"]}, "step": {"type": "integer"},
        "kappa": {"type": "number"}, "h_lower_nms": {"type": "number"}, "h_upper_nms": {"type": "number"},
        "zmp_margin_m": {"type": "number"}, "yaw_ref_rad": {"type": "number"}, "yaw_rad": {"type": "number"}},
        "required": ["timestamp", "support", "step", "kappa", "h_lower_nms", "h_upper_nms", "zmp_margin_m",
                     "yaw_ref_rad", "yaw_rad"]},
}
#: topics of a walk's ``trajectory.mcap`` and their schema names
WALK_TOPICS = {"/robot_description": ROBOT_DESCRIPTION_SCHEMA, "/tf": "foxglove.FrameTransforms",
               "/joint_states": "jethr1.JointState", "/footsteps": "foxglove.SceneUpdate",
               "/com": "foxglove.PoseInFrame", "/com_ref": "foxglove.PoseInFrame", "/zmp": "foxglove.PoseInFrame",
               "/zmp_ref": "foxglove.PoseInFrame", "/yaw_horizon": "jethr1.YawHorizon",
               "/walk_analysis": "jethr1.WalkAnalysis"}


def _footstep_cubes(robot: RobotModel, result: WalkResult) -> list[dict]:
    """The start soles (grey) and the footholds (blue: left, orange: right) as thin boxes."""
    tl = result.walk.timeline
    colors = {"left": {"r": 0.2, "g": 0.5, "b": 1.0, "a": 0.6}, "right": {"r": 1.0, "g": 0.55, "b": 0.1, "a": 0.6}}
    size = {"x": robot.sole_length_m, "y": robot.sole_width_m, "z": 0.004}
    cubes = [{"pose": pose_message(np.asarray(p) - [0, 0, 0.002]), "size": size,
              "color": {"r": 0.6, "g": 0.6, "b": 0.6, "a": 0.6}} for p in tl.start.values()]
    cubes += [{"pose": pose_message(np.asarray(st.position_m) - [0, 0, 0.002]), "size": size,
               "color": colors[st.side]} for st in tl.steps]
    return cubes


def walk_mcap(result: WalkResult) -> bytes:
    """The MCAP bytes of a walk: the robot moving, its footsteps, CoM and ZMP (planned and reached),
    and at every MPC update the yaw reference over the horizon (Fig. 7)."""
    walk, a = result.walk, result.analysis
    robot = walk.robot
    schemas = {**SCHEMAS, **_WALK_SCHEMAS}
    out = JsonMcap({name: schemas[name] for name in sorted(set(WALK_TOPICS.values()))}, WALK_TOPICS)
    put = out.put
    put("/robot_description", 0.0, {"data": robot.urdf_path.read_text(encoding="utf-8")})
    put("/footsteps", 0.0, {"deletions": [], "entities": [scene_entity(0.0, "footsteps",
                                                                       cubes=_footstep_cubes(robot, result))]})
    names = list(robot.joint_names)
    rotations = joint_rotations(robot, walk.q)
    dt_mpc = result.spec.com.dt_s
    per_update = max(1, round(dt_mpc * result.spec.timing.control_hz))
    for i in range(len(walk.t)):
        t = float(walk.t[i])
        T = walk.base[i]
        put("/tf", t, frame_transforms(robot, t, T[:3, 3], quaternion_from_matrix(T[:3, :3]), walk.q[i],
                                       [r[i] for r in rotations]))
        put("/joint_states", t, {"timestamp": stamp(t), "name": names,
                                 "position_rad": [float(v) for v in walk.q[i]],
                                 "command_rad": [float(v) for v in result.commands_rad[i]],
                                 "effort_nm": [float(v) for v in a.tau[i]]})
        yaw_q = quat_axis_angle((0, 0, 1), float(walk.yaw[i]))
        put("/com", t, {"timestamp": stamp(t), "frame_id": "world", "pose": pose_message(walk.com[i], yaw_q)})
        put("/com_ref", t, {"timestamp": stamp(t), "frame_id": "world", "pose": pose_message(walk.com_ref[i])})
        put("/zmp", t, {"timestamp": stamp(t), "frame_id": "world", "pose": pose_message((*a.zmp[i], 0.0))})
        put("/zmp_ref", t, {"timestamp": stamp(t), "frame_id": "world",
                            "pose": pose_message((*walk.zmp_ref[i], 0.0))})
        put("/walk_analysis", t, {"timestamp": stamp(t), "support": str(walk.support[i]), "step": int(walk.step[i]),
                                  "kappa": float(a.kappa[i]), "h_lower_nms": float(walk.h_low[i]),
                                  "h_upper_nms": float(walk.h_up[i]), "zmp_margin_m": float(a.zmp_margin[i]),
                                  "yaw_ref_rad": float(walk.yaw_ref[i]), "yaw_rad": float(walk.yaw[i])})
        u = i // per_update
        if i % per_update == 0 and u < len(walk.yaw_horizon):
            ref = walk.yaw_horizon[u]
            put("/yaw_horizon", t, {"timestamp": stamp(t), "dt_s": dt_mpc,
                                    "time_s": [t + dt_mpc * (k + 1) for k in range(len(ref))],
                                    "yaw_ref_rad": [float(v) for v in ref], "yaw_rad": float(walk.yaw[i]),
                                    "yaw_rate_rad_s": float(walk.yaw_rate[i])})
    return out.finish()


# --- figures ------------------------------------------------------------------------------------


def _phases(ax, result: WalkResult) -> None:
    """Shade the single-support phases (the left sole swinging: blue, the right: orange, as on /footsteps)."""
    for st in result.walk.timeline.steps:
        ax.axvspan(st.t_lift, st.t_land, color="tab:blue" if st.side == "left" else "tab:orange", alpha=0.08, lw=0)


def _png(fig) -> bytes:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def walk_figures(result: WalkResult) -> dict[str, bytes]:
    """Paper B's figures that apply to one walk, as PNG bytes by file name."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    walk, a = result.walk, result.analysis
    title = f"{result.spec.name}: {result.spec.robot.name}, steps of {result.spec.footsteps.step_length_m:g} m, " \
            f"pelvic rotation {result.spec.rotation.mode}"
    t = walk.t
    out = {}
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 6), sharex=True, constrained_layout=True)
    ax1.plot(t, np.degrees(walk.yaw_ref), color="0.5", ls="--", label="reference (B-30)")
    ax1.plot(t, np.degrees(walk.yaw), color="tab:red", label="yaw MPC (B-34..B-38)")
    ax1.set_ylabel("pelvic yaw [deg]")
    ax2.plot(t, np.degrees(walk.yaw_rate), color="tab:red")
    ax2.set_ylabel("yaw rate [deg/s]")
    ax2.set_xlabel("time [s]")
    for ax in (ax1, ax2):
        _phases(ax, result)
        ax.grid(alpha=0.3)
    ax1.legend(loc="upper right", fontsize=8)
    fig.suptitle(f"Pelvic rotation (Figs. 8, 9)\n{title}", fontsize=10)
    out["yaw.png"] = _png(fig)

    fig, ax = plt.subplots(figsize=(9, 4), constrained_layout=True)
    ax.plot(t, walk.h_low, color="tab:blue", label="lower body (B-41)")
    ax.plot(t, walk.h_up, color="tab:green", label="arms (B-42)")
    ax.plot(t, walk.h_low + walk.h_up, color="k", lw=1.5, label="total")
    _phases(ax, result)
    held = result.armless_peak_momentum_nms
    if held:
        ax.axhline(held, color="0.5", ls=":", label=f"peak with the arms held: {held:.3f} N·m·s")
        ax.axhline(-held, color="0.5", ls=":")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("yaw angular momentum [N·m·s]")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"Yaw momentum about the CoM (Figs. 12, 16)\n{title}", fontsize=10)
    out["momentum.png"] = _png(fig)

    fig, ax = plt.subplots(figsize=(9, 4), constrained_layout=True)
    ax.plot(t, a.kappa, color="tab:purple")
    _phases(ax, result)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("κ(J_low) (B-45)")
    ax.grid(alpha=0.3)
    ax.set_title(f"Condition number of the lower body's Jacobian (Fig. 13)\n{title}", fontsize=10)
    out["kappa.png"] = _png(fig)
    return out


# --- the folder ---------------------------------------------------------------------------------


def walk_folder(outdir: Path, source: str) -> Path:
    """OUTDIR/<walk file stem>/."""
    return Path(outdir) / Path(source).stem


def write_walk_outputs(result: WalkResult | None, source: str, outdir: Path, summary: dict,
                       trajectory: bool = True) -> tuple[Path, list[str]]:
    """Write summary.json (and, with ``trajectory``, the CSV, MCAP and figures) into OUTDIR/<stem>/
    atomically; the folder and the names of the files in it that jethr1 did not write (kept)."""
    final = walk_folder(outdir, source)
    with staged_directory(final, WALK_FILES) as staging:
        tmp = staging.path
        if trajectory and result is not None:
            (tmp / "trajectory.csv").write_text(walk_csv(result))
            (tmp / "trajectory.mcap").write_bytes(walk_mcap(result))
            for name, data in walk_figures(result).items():
                (tmp / name).write_bytes(data)
        (tmp / "summary.json").write_text(json_text(summary))
    return final, staging.kept
