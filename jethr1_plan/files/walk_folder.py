"""The files of a walk folder (``jethr1 walk``): ``trajectory.csv``, ``trajectory.mcap``,
``summary.json`` and Paper B's figures (``yaw.png``: Figs. 8/9, ``momentum.png``: Figs. 12/16,
``kappa.png``: Fig. 13), written atomically into OUTDIR/<walk file stem>/.

``trajectory.csv`` has one row per control period; its columns (SI units in their names):
``time_s, step, support``, the trunk pose ``pelvis_x_m … pelvis_qw``, every joint ``<joint>_rad``,
the soles reached ``left_foot_x_m …``, the CoM of the posture ``com_*_m`` and of the LIPM
``com_ref_*_m``, the multibody ZMP ``zmp_*_m`` (the ground's wrench by inverse dynamics of the rows'
second central differences), (B-18)'s reference ``zmp_ref_*_m`` and the LIPM's ``zmp_lipm_*_m``,
``zmp_margin_m`` (inside the support polygon), ``friction_ratio`` (the ground force's horizontal
over its vertical part), ``yaw_ref_rad`` (B-30), ``yaw_rad`` and ``yaw_rate_rad_s`` (B-34..B-38),
``kappa`` (B-45), each leg's ``kappa_leg_<side>`` and knee bend ``knee_bend_<side>_rad`` (from
straight), the yaw momentum of the lower and the upper body ``h_lower_nms``/``h_upper_nms`` (B-41,
B-42) and every joint's torque ``<joint>_tau_nm`` by inverse dynamics, and the servo commands
``<joint>_cmd_rad`` (the row plus the sag its torque causes: what to send to position servos).
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from jethr1_plan.files.mcap import MARKERS, POSE, STRING, TF, Ros2Mcap, Topic
from jethr1_plan.files.messages import (
    cube_marker,
    header,
    joint_state,
    joint_trajectory,
    pose_stamped,
    robot_transforms,
    urdf_message,
    yaw_quaternions,
)
from jethr1_plan.geometry import SIDES, quaternion_from_matrix
from jethr1_plan.io.atomic import staged_directory
from jethr1_plan.io.csv_table import csv_text, number_text, read_csv_table
from jethr1_plan.io.json_text import json_text
from jethr1_plan.records import topics as tp
from jethr1_plan.records.plan_columns import SUPPORT, ZMP_MARGIN
from jethr1_plan.records.walk_columns import is_walk_column, walk_columns
from jethr1_plan.robot.model import RobotModel

__all__ = ["WALK_FILES", "WALK_TOPICS", "WalkResult", "read_walk_csv", "walk_columns", "walk_csv", "walk_figures",
           "walk_folder", "walk_mcap", "write_walk_outputs"]

class WalkResult(Protocol):
    """What these files write of a walk (``walking.result.WalkResult``)."""

    @property
    def spec(self) -> Any: ...  # walking.spec.WalkSpec: its name, robot, footsteps, rotation, com, timing, success
    @property
    def walk(self) -> Any: ...  # walking.generator.Walk: the rows' arrays, per control period
    @property
    def analysis(self) -> Any: ...  # walking.analysis.WalkAnalysis: the multibody ZMP, κ, torques per row
    @property
    def commands_rad(self) -> np.ndarray: ...  # (N, J) the servo commands [rad]
    @property
    def armless_peak_momentum_nms(self) -> float | None: ...  # the walk's peak |yaw momentum| with the arms held


#: the files ``jethr1 walk`` writes into a walk folder (any other file there is the user's and is kept)
WALK_FILES = frozenset({"trajectory.csv", "trajectory.mcap", "summary.json", "yaw.png", "momentum.png",
                        "kappa.png"})
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
                *map(num, walk.zmp_lipm[i]), num(a.zmp_margin[i]), num(a.friction_ratio[i]), num(walk.yaw_ref[i]),
                num(walk.yaw[i]), num(walk.yaw_rate[i]), num(a.kappa[i]), *map(num, a.kappa_leg[i]),
                *map(num, a.knee_bend_rad[i]), num(walk.h_low[i]), num(walk.h_up[i]), *map(num, a.tau[i]),
                *map(num, result.commands_rad[i])]
        return vals

    return csv_text(walk_columns(walk.robot), (row(i) for i in range(len(walk.t))))


def read_walk_csv(text: str, source: str = "trajectory.csv") -> dict[str, np.ndarray]:
    """A walk's ``trajectory.csv`` as columns (``support`` as text, the rest as floats).

    Raises:
        InputError: the header is not a walk's, a row is cut or a number does not parse.
    """
    return read_csv_table(text, source, is_walk_column, (SUPPORT,))


# --- MCAP ---------------------------------------------------------------------------------------

#: the topics of a walk's ``trajectory.mcap`` (ROS 2 profile, :mod:`.mcap`), in the order the file registers them
WALK_TOPICS: dict[str, Topic] = {
    tp.ROBOT_DESCRIPTION: Topic(STRING, True, "the robot's URDF (viewers build the robot from it)"),
    tp.TF_STATIC: Topic(TF, True, "every fixed joint's parent → child link"),
    tp.TF_TOPIC: Topic(TF, False, "per control period: world → trunk and every moving joint's parent → child link"),
    "/footsteps": Topic(MARKERS, True, "a thin CUBE per sole: the start (grey), the footholds (left blue, "
                                       "right orange)"),
    tp.JOINT_TRAJECTORY: Topic("trajectory_msgs/msg/JointTrajectory", False,
                               "once, at the start: the servo commands `<joint>_cmd_rad`, a point per period"),
    tp.JOINT_STATES: Topic("sensor_msgs/msg/JointState", False,
                           "per period: joint angles (position) and torques by inverse dynamics (effort)"),
    tp.COM: Topic(POSE, False, "per period: the posture's centre of mass, turned by the pelvic yaw"),
    "/com_ref": Topic(POSE, False, "per period: the LIPM's centre of mass"),
    tp.ZMP: Topic(POSE, False, "per period: the multibody ZMP (from the joints' motion), on the ground"),
    "/zmp_ref": Topic(POSE, False, "per period: the ZMP reference (B-18), on the ground"),
    "/yaw_horizon": Topic("jethr1_msgs/msg/YawHorizon", False,
                          "per MPC update: the pelvic yaw reference over the horizon (Fig. 7)"),
    "/walk_analysis": Topic("jethr1_msgs/msg/WalkAnalysis", False,
                            "per period: support, step, κ, yaw momentum of the lower body and the arms, ZMP "
                            "margin, pelvic yaw and its reference"),
}


def _footstep_markers(robot: RobotModel, result: WalkResult) -> dict:
    """The start soles (grey) and the footholds (blue: left, orange: right) as thin boxes on the ground."""
    tl = result.walk.timeline
    size = (robot.sole_length_m, robot.sole_width_m, 0.004)
    colors = {"left": (0.2, 0.5, 1.0, 0.6), "right": (1.0, 0.55, 0.1, 0.6)}
    feet = [cube_marker("start", k, np.asarray(p) - [0, 0, 0.002], size, (0.6, 0.6, 0.6, 0.6))
            for k, p in enumerate(tl.start.values())]
    feet += [cube_marker(f"footholds_{st.side}", k, np.asarray(st.position_m) - [0, 0, 0.002], size, colors[st.side])
             for k, st in enumerate(tl.steps)]
    return {"markers": feet}


def walk_mcap(result: WalkResult) -> bytes:
    """The MCAP bytes of a walk (topics :data:`WALK_TOPICS`): the robot moving, its servo commands as
    one JointTrajectory, its footsteps, CoM and ZMP (planned and reached), the walk's figures, and at
    every MPC update the yaw reference over the horizon. Built from the walk's arrays, a message per row."""
    walk, a = result.walk, result.analysis
    robot = walk.robot
    out = Ros2Mcap(WALK_TOPICS)
    out.write(tp.ROBOT_DESCRIPTION, 0.0, urdf_message(robot))
    out.write("/footsteps", 0.0, _footstep_markers(robot, result))
    t = np.asarray(walk.t, dtype=float)
    n = len(t)
    if not n:
        return out.finish()
    names = list(robot.joint_names)
    base = np.asarray(walk.base, dtype=float).reshape(n, 4, 4)
    trunk_q = np.array([quaternion_from_matrix(T[:3, :3]) for T in base]).reshape(n, 4)
    tf, tf_static = robot_transforms(robot, t, base[:, :3, 3], trunk_q, walk.q)
    out.write(tp.TF_STATIC, 0.0, tf_static)
    out.write_rows(tp.TF_TOPIC, t, tf)
    out.write(tp.JOINT_TRAJECTORY, 0.0, joint_trajectory(names, t, result.commands_rad))
    out.write_rows(tp.JOINT_STATES, t, joint_state(t, names, walk.q, a.tau))
    out.write_rows(tp.COM, t, pose_stamped(t, "world", walk.com, yaw_quaternions(walk.yaw)))
    out.write_rows("/com_ref", t, pose_stamped(t, "world", np.asarray(walk.com_ref, dtype=float)[:, :3]))
    ground = np.zeros((n, 1))
    out.write_rows(tp.ZMP, t, pose_stamped(t, "world", np.hstack([np.asarray(a.zmp, dtype=float), ground])))
    out.write_rows("/zmp_ref", t, pose_stamped(t, "world", np.hstack([np.asarray(walk.zmp_ref, dtype=float), ground])))
    out.write_rows("/walk_analysis", t, {
        "header": header(t), "support": [str(s) for s in walk.support], "step": np.asarray(walk.step, dtype=np.int32),
        "kappa": np.asarray(a.kappa, dtype=float), "h_lower_nms": np.asarray(walk.h_low, dtype=float),
        "h_upper_nms": np.asarray(walk.h_up, dtype=float), ZMP_MARGIN: np.asarray(a.zmp_margin, dtype=float),
        "yaw_ref_rad": np.asarray(walk.yaw_ref, dtype=float), "yaw_rad": np.asarray(walk.yaw, dtype=float)})
    dt_mpc = result.spec.com.dt_s
    per_update = max(1, round(dt_mpc * result.spec.timing.control_hz))
    at = np.arange(0, n, per_update)[:len(walk.yaw_horizon)]
    if len(at):
        refs = [np.asarray(walk.yaw_horizon[u], dtype=float) for u in range(len(at))]
        out.write_rows("/yaw_horizon", t[at], {
            "header": header(t[at]), "dt_s": float(dt_mpc),
            "time_s": [t[i] + dt_mpc * np.arange(1, len(r) + 1) for i, r in zip(at, refs, strict=True)],
            "yaw_ref_rad": refs, "yaw_rad": np.asarray(walk.yaw, dtype=float)[at],
            "yaw_rate_rad_s": np.asarray(walk.yaw_rate, dtype=float)[at]})
    return out.finish()


# --- figures ------------------------------------------------------------------------------------


def _phases(ax, result: WalkResult) -> None:
    """Shade the single-support phases (the left sole swinging: blue, the right: orange, as on /footsteps)."""
    for st in result.walk.timeline.steps:
        ax.axvspan(st.t_lift, st.t_land, color="tab:blue" if st.side == "left" else "tab:orange", alpha=0.08, lw=0)


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, metadata={"Software": None})
    return buf.getvalue()


def walk_figures(result: WalkResult) -> dict[str, bytes]:
    """Paper B's figures that apply to one walk, as PNG bytes by file name (drawn by matplotlib's Agg
    renderer on figures of their own: no pyplot, no window, nothing left open)."""
    from matplotlib.figure import Figure

    walk, a = result.walk, result.analysis
    title = f"{result.spec.name}: {result.spec.robot.name}, steps of {result.spec.footsteps.step_length_m:g} m, " \
            f"pelvic rotation {result.spec.rotation.mode}"
    t = walk.t
    out = {}
    fig = Figure(figsize=(9, 6), constrained_layout=True)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
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

    fig = Figure(figsize=(9, 4), constrained_layout=True)
    ax = fig.subplots()
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

    fig = Figure(figsize=(9, 6), constrained_layout=True)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.semilogy(t, a.kappa, color="tab:purple", label="κ(J_low) (B-45)")
    ax2.axhline(result.spec.success.knee_margin_rad, color="0.3", ls=":", lw=1,
                label=f"margin {result.spec.success.knee_margin_rad:g} rad")
    for k, (side, color) in enumerate((("left", "tab:blue"), ("right", "tab:orange"))):
        ax1.semilogy(t, a.kappa_leg[:, k], color=color, lw=0.8, label=f"{side} leg's sole Jacobian")
        ax2.plot(t, a.knee_bend_rad[:, k], color=color, lw=1, label=f"{side} knee")
    ax1.set_ylabel("condition number")
    ax2.set_ylabel("knee bend from straight [rad]")
    ax2.set_xlabel("time [s]")
    for ax in (ax1, ax2):
        _phases(ax, result)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    fig.suptitle(f"Condition numbers and the straight-leg singularity (Fig. 13)\n{title}", fontsize=10)
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
