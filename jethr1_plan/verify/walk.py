"""``jethr1 verify`` of a walk folder (``jethr1 walk``'s output): an independent re-check of what was
written, never the generator's state nor its analysis's code.

Each row's trunk pose and joints go into a fresh PlaCo robot; against ``summary.json`` (its rows,
rate, start soles, footholds, IK limits and success criteria) every row must hold:

* **the file**: as many rows as the walk wrote, at its control rate from t = 0; a unit quaternion;
  the support column as the footsteps' timing says;
* **the pose**: joints within the URDF limits; each sole (forward kinematics) where the CSV says it
  is and, when it bears weight, on its foothold within the walk's tolerance and flat; the swing sole
  above the ground; each knee bent at least the walk's margin from straight (the angle between thigh
  and shank) and as written; the CoM as written and on the LIPM's within the walk's tolerance;
* **motion, from the rows alone**: each row's velocity and acceleration by second central
  differences of the rows around it (the trunk's by the logarithm of its relative pose on SE(3), from
  the relative quaternion),
  every joint's acceleration within the walk's limit;
* **balance**: the ground's wrench from the inverse dynamics of that motion: the multibody ZMP as
  written and inside the support polygon with the walk's margin, the friction ratio within the
  soles' μ (the first and last rows excepted: their stencil reaches beyond the walk);
* **torques and commands**: the written joint torques those of the inverse dynamics and within the
  servo limits; the servo commands the rows plus the sag those torques cause (``verify.commands``);
* **the walk's own verdict**: ``summary.json`` says ok;
* **CSV and MCAP together**: the MCAP's ``/joint_states`` are the CSV's rows.

The footsteps in time, the support polygons, the motion and the commands are restated here and in
:mod:`.motion`, :mod:`.balance` and :mod:`.commands` from docs/walking.md, never imported from the walk's
generator (``walking/``) or the planner's physics (``tools/check_imports.py``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_mcap import MAX_MCAP_BYTES
from jethr1_plan.geometry import SIDES, other_side, pose_from_quaternion
from jethr1_plan.io.csv_table import MAX_CSV_BYTES
from jethr1_plan.io.input_file import read_input, read_input_text
from jethr1_plan.records import topics as tp
from jethr1_plan.records.plan_columns import PELVIS, ZMP
from jethr1_plan.records.walk_columns import COM_REF
from jethr1_plan.robot.load import load_robot
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.verify.balance import hull_edges, sole_edges, support_margin
from jethr1_plan.verify.commands import WALK_SAG_FILTER_S, servo_commands
from jethr1_plan.verify.common import TOL_M, TOL_T, Failure, Failures, is_walk
from jethr1_plan.verify.motion import base_wrench, row_motion

__all__ = ["CRITERIA", "EDGE_ROWS", "is_walk", "verify_walk"]

TOL_ZMP_M = 1e-5  # the recomputed ZMP differentiates written numbers twice [m]
TOL_TAU_NM = 1e-6  # and so do the recomputed torques [N·m]
EDGE_ROWS = 1  # rows at each end whose stencil reaches beyond the walk: not judged (docs/walking.md)
ACCELERATION_TOL = 1e-3  # a joint's row acceleration may exceed its limit by this (the IK's round-off) [rad/s²]
#: a walk's success criteria (``spec.success`` in summary.json) where its summary leaves one out, as
#: docs/walking.md states them [m, rad]
CRITERIA = {"foot_tolerance_m": 1e-3, "foot_tolerance_rad": 0.01, "knee_margin_rad": 0.1, "com_tolerance_m": 1e-4,
            "zmp_margin_m": 0.0, "landing_tolerance_m": 0.02}
#: every joint's acceleration limit where ``spec.ik`` leaves it out [rad/s²]
MAX_JOINT_ACCELERATION = 100.0


def _number(summary: dict, key: str, src: str) -> float:
    v = summary.get(key)
    if not isinstance(v, int | float) or isinstance(v, bool) or not np.isfinite(v):
        raise InputError(src, key, "missing or not a number")
    return float(v)


@dataclass(frozen=True)
class Footsteps:
    """A walk's footsteps in time as its ``summary.json`` states them (docs/walking.md): both soles at
    ``start`` (sole centres (3,) [m]), then each step's ``sides[k]`` sole lifts at ``lift_s[k]`` and lands
    on ``landings[k]`` at ``land_s[k]``; between those instants that sole is in the air."""

    start: dict[str, np.ndarray]
    sides: list[str]
    landings: np.ndarray  # (S, 3) [m]
    lift_s: np.ndarray  # (S,) [s]
    land_s: np.ndarray  # (S,) [s]

    def support(self, t: np.ndarray) -> np.ndarray:
        """(N,) 'left', 'right' or 'both' at times ``t`` [s]."""
        out = np.full(len(t), "both", dtype=object)
        for side, lift, land in zip(self.sides, self.lift_s, self.land_s, strict=True):
            out[(t > lift) & (t < land)] = other_side(side)
        return out

    def feet(self, t: np.ndarray) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """Per side, the foothold [m] (N, 3) it stands on at times ``t`` (the last one it landed on by then,
        else its start) and where it is in the air (N,)."""
        pos = {s: np.broadcast_to(self.start[s], (len(t), 3)).copy() for s in SIDES}
        air = {s: np.zeros(len(t), dtype=bool) for s in SIDES}
        for side, p, lift, land in zip(self.sides, self.landings, self.lift_s, self.land_s, strict=True):
            pos[side][t >= land] = p
            air[side] |= (t > lift) & (t < land)
        return pos, air


def _footsteps(summary: dict, src: str) -> Footsteps:
    """The footsteps from ``summary.json``'s start soles and steps; each step's lift and landing must be
    where its timing puts them: the first lift at ``start_s``, each landing ``single_support_s`` after its
    lift, each next lift ``double_support_s`` after that landing."""
    try:
        timing = summary["spec"]["timing"]
        start = {s: np.asarray(summary["start_m"][s], dtype=float).reshape(3) for s in SIDES}
        steps = summary["steps"]
        sides = [str(st["side"]) for st in steps]
        landings = np.array([np.asarray(st["position_m"], dtype=float).reshape(3) for st in steps]).reshape(-1, 3)
        lift = np.array([float(st["lift_s"]) for st in steps])
        land = np.array([float(st["land_s"]) for st in steps])
        t0, single, double, _, _ = (float(timing[k]) for k in ("start_s", "single_support_s", "double_support_s",
                                                                "end_s", "swing_height_m"))
    except (KeyError, TypeError, ValueError, IndexError):
        raise InputError(src, "steps", "missing or malformed start_m, steps or spec.timing") from None
    if any(s not in SIDES for s in sides):
        raise InputError(src, "steps", "a step's side is neither left nor right")
    for k in range(len(sides)):
        due = t0 + k * (single + double)
        if abs(due - lift[k]) > TOL_T or abs(due + single - land[k]) > TOL_T:
            raise InputError(src, f"steps[{k}]", f"lifts at {lift[k]:g} s and lands at {land[k]:g} s; its timing says "
                             f"{due:g} s and {due + single:g} s")
    return Footsteps(start, sides, landings, lift, land)


def verify_walk(folder: Path, summary: dict, files: list[Path], max_failures: int = 50) -> tuple[int, Failures, str]:
    """Verify a walk's files; (rows, failures (the first ``max_failures`` listed, every failing row counted), what
    was checked).

    Raises:
        InputError: an unreadable or malformed file or summary.
    """
    from jethr1_plan.files.walk_folder import read_walk_csv
    from jethr1_plan.records.walk_columns import walk_columns

    src = str(folder / "summary.json")
    robot_ref = summary.get("robot_yaml") if isinstance(summary.get("robot_yaml"), str) and Path(
        summary["robot_yaml"]).is_file() else summary.get("robot")
    if not isinstance(robot_ref, str):
        raise InputError(src, "robot", "missing")
    robot = load_robot(robot_ref)
    csv_path = folder / "trajectory.csv"
    if not os.path.lexists(csv_path):
        raise InputError(str(folder), "", "a walk is verified from its trajectory.csv, which is missing")
    text = read_input_text(csv_path, MAX_CSV_BYTES, "a walk's CSV")
    c = read_walk_csv(text, str(csv_path))
    missing = [k for k in walk_columns(robot) if k not in c]
    if missing:
        raise InputError(str(csv_path), "header", f"missing column {missing[0]!r}")
    found: list[Failure] = []
    failing: set[int] = set()  # every failing row, listed or not
    n = len(c["time_s"])
    t = c["time_s"]

    def fail(rows, check: str, detail) -> None:
        failing.update(int(i) for i in np.atleast_1d(rows))
        for i in np.atleast_1d(rows)[:max_failures]:
            i = int(i)
            found.append(Failure(i, float(t[i]) if i < n else float("nan"), check,
                                 detail(i) if callable(detail) else detail))

    rate = _number(summary.get("spec", {}).get("timing", {}), "control_hz", src + " spec.timing")
    expected_rows = int(_number(summary, "rows", src))
    if n != expected_rows:
        fail([min(n, expected_rows) - 1 if min(n, expected_rows) else 0], "file",
             f"{n} rows, summary.json says {expected_rows}")
    if summary.get("ok") is not True:
        fail([0], "verdict", "summary.json says the walk failed its own criteria")
    if n == 0:
        return 0, Failures(found, failing), str(folder)
    bad_t = np.flatnonzero(np.abs(t - np.arange(n) / rate) > TOL_T)
    fail(bad_t, "time", lambda i: f"t = {t[i]!r} s, expected {i / rate:.9f} s at {rate:g} Hz")
    quat = np.column_stack([c[f"pelvis_q{a}"] for a in "xyzw"])
    bad_q = np.flatnonzero(np.abs(np.linalg.norm(quat, axis=1) - 1.0) > 1e-6)
    fail(bad_q, "pose", "the trunk's quaternion is not a unit one")
    q = np.column_stack([c[f"{j}_rad"] for j in robot.joint_names])
    over = np.flatnonzero(np.any((q < robot.lower_rad - 1e-6) | (q > robot.upper_rad + 1e-6), axis=1))
    fail(over, "joints", "a joint beyond its URDF limits")
    tau = np.column_stack([c[f"{j}_tau_nm"] for j in robot.joint_names])
    q_cmd = np.column_stack([c[f"{j}_cmd_rad"] for j in robot.joint_names])
    expected = servo_commands(q, tau, robot.servo_stiffness_nm_per_rad, rate, WALK_SAG_FILTER_S)
    fail(np.flatnonzero(np.any(np.abs(q_cmd - expected) > 1e-9, axis=1)), "commands",
         "the servo commands are not the rows plus the sag under their torques")
    if np.isnan(np.concatenate([quat.ravel(), q.ravel()])).any():
        fail([int(np.flatnonzero(np.isnan(np.column_stack([quat, q])).any(axis=1))[0])], "file", "an empty pose cell")
        return n, Failures(found[:max_failures], failing), str(folder)
    given = summary.get("spec", {}).get("success", {})
    if not isinstance(given, dict):
        raise InputError(src, "spec.success", "not a mapping")
    criteria = {k: (_number(given, k, src + " spec.success") if k in given else v) for k, v in CRITERIA.items()}
    ik_doc = summary.get("spec", {}).get("ik", {})
    acc_limit = (_number(ik_doc, "max_joint_acceleration_rad_s2", src + " spec.ik") if isinstance(ik_doc, dict)
                 and "max_joint_acceleration_rad_s2" in ik_doc else MAX_JOINT_ACCELERATION)
    _check_rows(c, robot, q, quat, _footsteps(summary, src), rate, criteria, acc_limit, fail)
    mcap_path = folder / "trajectory.mcap"
    if mcap_path in files and mcap_path.is_file():
        _check_mcap(mcap_path, robot, q, t, fail)
    found.sort(key=lambda f: f.row)
    return n, Failures(found[:max_failures], failing), str(folder)


def _knee_bend(w, robot: RobotModel, side: str) -> float:
    """The angle [rad] between the thigh and the shank (0: straight), by forward kinematics."""
    hip, knee, ankle = (w.get_T_world_frame(robot.legs[side].joints[k])[:3, 3] for k in (2, 3, 4))
    a, b = knee - hip, ankle - knee
    return float(np.arccos(np.clip(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)), -1.0, 1.0)))


@dataclass
class _Dynamics:
    """What one inverse-dynamics pass over the written rows gives (SI units): the CoM, the ZMP, the ground force's
    sideways ratio, the joints' torques, the knees' bends, the soles' poses, the generalised accelerations."""

    com: np.ndarray  # (n, 3) [m]
    zmp: np.ndarray  # (n, 2) [m]
    friction: np.ndarray  # (n,)
    tau: np.ndarray  # (n, J) [N·m]
    bend: np.ndarray  # (n, 2) [rad]
    sole: dict[str, np.ndarray]  # side -> (n, 4, 4)
    acc: np.ndarray  # (n, 6 + J)


def _inverse_dynamics(c, robot: RobotModel, q, quat, rate: float) -> _Dynamics:
    """Forward kinematics and inverse dynamics of every written row (the motion by central differences,
    ``row_motion``): the ground's wrench about its origin gives the ZMP; the torques split the generalised forces
    over the soles down (as the written support says)."""
    n = len(q)
    unit = quat / np.linalg.norm(quat, axis=1)[:, None]
    T = np.array([pose_from_quaternion([c[k][i] for k in PELVIS], unit[i])
                  for i in range(n)])
    pos = np.column_stack([c[k] for k in PELVIS])
    v, acc = row_motion(pos, unit, q, 1.0 / rate)
    w = robot.wrapper()
    d = _Dynamics(np.zeros((n, 3)), np.zeros((n, 2)), np.zeros(n), np.zeros_like(q), np.zeros((n, 2)),
                  {s: np.zeros((n, 4, 4)) for s in SIDES}, acc)
    for i in range(n):
        w.state.q[:3] = T[i][:3, 3]
        w.state.q[3:7] = unit[i]
        w.state.q[7:] = q[i]
        w.state.qd = v[i]
        w.state.qdd = acc[i]
        w.update_kinematics()
        d.com[i] = w.com_world()
        for k, s in enumerate(SIDES):
            d.sole[s][i] = w.get_T_world_frame(robot.legs[s].sole)
            d.bend[i, k] = _knee_bend(w, robot, s)
        gen = w.mass_matrix() @ acc[i] + w.non_linear_effects()  # the generalised forces the motion needs
        force, moment = base_wrench(T[i], gen)  # what the ground supplies, in the world, about its origin
        d.zmp[i] = (-moment[1] / force[2], moment[0] / force[2])
        d.friction[i] = float(np.linalg.norm(force[:2]) / force[2])
        written_support = str(c["support"][i])  # as the footsteps say (checked below), either one at a boundary
        feet_down = SIDES if written_support not in SIDES else (written_support,)
        Jc = np.vstack([w.frame_jacobian(robot.legs[s].sole, "local") for s in feet_down])
        split = np.linalg.lstsq(Jc[:, :6].T, gen[:6], rcond=None)[0]
        d.tau[i] = gen[6:] - Jc[:, 6:].T @ split
    return d


def _check_rows(c, robot: RobotModel, q, quat, tl: Footsteps, rate: float, criteria: dict[str, float],
                acc_limit: float, fail) -> None:
    """The pose, motion and balance checks, from one inverse-dynamics pass over the written rows."""
    d = _inverse_dynamics(c, robot, q, quat, rate)
    com, bend = d.com, d.bend
    written_com = np.column_stack([c[f"com_{a}_m"] for a in "xyz"])
    fail(np.flatnonzero(np.linalg.norm(com - written_com, axis=1) > TOL_M), "CoM",
         lambda i: f"written {np.round(written_com[i], 6).tolist()} m, forward kinematics "
                   f"{np.round(com[i], 6).tolist()} m")
    lipm = np.column_stack([c[k] for k in COM_REF])
    fail(np.flatnonzero(np.linalg.norm(com[:, :2] - lipm, axis=1) > criteria["com_tolerance_m"] + TOL_M), "CoM",
         lambda i: f"{1000 * np.linalg.norm(com[i, :2] - lipm[i]):.3f} mm from the LIPM's (tolerance "
                   f"{1000 * criteria['com_tolerance_m']:g} mm)")
    fail(np.flatnonzero(np.min(bend, axis=1) < criteria["knee_margin_rad"] - 1e-9), "knee",
         lambda i: f"a knee bent {np.min(bend[i]):.4f} rad from straight, less than the margin "
                   f"{criteria['knee_margin_rad']:g} rad")
    written_bend = np.column_stack([c[f"knee_bend_{s}_rad"] for s in SIDES])
    fail(np.flatnonzero(np.max(np.abs(bend - written_bend), axis=1) > 1e-6), "knee",
         lambda i: f"knee bends written {np.round(written_bend[i], 6).tolist()} rad, forward kinematics "
                   f"{np.round(bend[i], 6).tolist()} rad")
    _check_feet(c, tl, d.sole, criteria, fail)
    _check_dynamics(c, robot, d, tl, criteria, acc_limit, fail)


def _check_feet(c, tl: Footsteps, sole: dict[str, np.ndarray], criteria: dict[str, float], fail) -> None:
    """Every row's support as the footsteps say (either phase on a boundary), each sole where it is written, a sole
    bearing weight on its foothold and flat, a swinging one above the ground."""
    t = c["time_s"]
    support = tl.support(t)
    feet, air = tl.feet(t)
    edge = np.zeros(len(t), dtype=bool)  # rows on a phase boundary (times written to 1e-9 s): either phase holds
    for lift, land in zip(tl.lift_s, tl.land_s, strict=True):
        edge |= (np.abs(t - lift) < 1e-6) | (np.abs(t - land) < 1e-6)
    for i in range(len(t)):
        written_support = str(c["support"][i])
        if written_support != support[i] and not (edge[i] and written_support in (*SIDES, "both")):
            fail([i], "support", f"written {written_support!r}, the footsteps say {support[i]!r}")
        for s in SIDES:
            p = sole[s][i][:3, 3]
            written = np.array([c[f"{s}_foot_{a}_m"][i] for a in "xyz"])
            if np.linalg.norm(p - written) > TOL_M:
                fail([i], "feet", f"the {s} sole written at {np.round(written, 6).tolist()} m, forward kinematics "
                     f"puts it at {np.round(p, 6).tolist()} m")
            if not air[s][i]:  # bearing weight: on its foothold and flat
                err = float(np.linalg.norm(p - feet[s][i]))
                tilt = float(np.linalg.norm(sole[s][i][:3, :3] - np.eye(3)) / np.sqrt(2))
                if err > criteria["foot_tolerance_m"] + 1e-12:
                    fail([i], "feet", f"the {s} sole bears weight {1000 * err:.2f} mm from its foothold "
                         f"{np.round(feet[s][i], 4).tolist()} m")
                if tilt > criteria["foot_tolerance_rad"]:
                    fail([i], "feet", f"the {s} sole bears weight {tilt:.3f} rad off flat")
            elif p[2] < -TOL_M - criteria["foot_tolerance_m"]:
                fail([i], "feet", f"the swinging {s} sole is {1000 * -p[2]:.1f} mm below the ground")


def _check_dynamics(c, robot: RobotModel, d: _Dynamics, tl: Footsteps, criteria: dict[str, float], acc_limit: float,
                    fail) -> None:
    """Away from the ends (``EDGE_ROWS``, where the differences are one-sided): the written ZMP and torques the
    inverse dynamics', torques within the servos' limits, the joints' accelerations, the ground's force within the
    soles' friction, the ZMP inside the support by the walk's margin."""
    n = len(d.zmp)
    zmp, tau, friction = d.zmp, d.tau, d.friction
    feet, air = tl.feet(c["time_s"])
    inner = np.arange(EDGE_ROWS, n - EDGE_ROWS)
    written_zmp = np.column_stack([c[k] for k in ZMP])
    fail(inner[np.linalg.norm(zmp - written_zmp, axis=1)[inner] > TOL_ZMP_M], "ZMP",
         lambda i: f"written {np.round(written_zmp[i], 5).tolist()} m, recomputed {np.round(zmp[i], 5).tolist()} m")
    written_tau = np.column_stack([c[f"{j}_tau_nm"] for j in robot.joint_names])
    fail(inner[np.max(np.abs(tau - written_tau), axis=1)[inner] > TOL_TAU_NM], "torque",
         lambda i: f"written torques differ from the inverse dynamics of the rows by "
                   f"{np.max(np.abs(tau[i] - written_tau[i])):.2e} N·m")
    over = inner[np.any(np.abs(tau[inner]) > robot.servo_limit_nm, axis=1)]
    fail(over, "torque", lambda i: f"the rows need {_worst(robot, tau[i])}")
    joint_acc = np.abs(d.acc[:, 6:])
    fail(inner[np.max(joint_acc, axis=1)[inner] > acc_limit + ACCELERATION_TOL], "acceleration",
         lambda i: f"{robot.joint_names[int(np.argmax(joint_acc[i]))]} accelerates at {np.max(joint_acc[i]):.0f} "
                   f"rad/s² between its rows (limit {acc_limit:g} rad/s²)")
    mu = robot.sole_friction
    fail(inner[friction[inner] > mu], "friction",
         lambda i: f"the ground's force is {friction[i]:.2f} of its normal force sideways (soles' μ {mu:g})")
    for row in inner.tolist():
        down = [s for s in SIDES if not air[s][row]]
        if len(down) == 1:
            normals, offsets = (e[0] for e in sole_edges(feet[down[0]][row, :2], robot.sole_length_m,
                                                         robot.sole_width_m))
        else:
            normals, offsets = hull_edges([feet[s][row, :2] for s in down], robot.sole_length_m, robot.sole_width_m)
        inside = float(support_margin(zmp[row:row + 1], normals[None], offsets[None])[0])
        if inside < criteria["zmp_margin_m"] - 1e-9:
            fail([row], "ZMP", f"the recomputed ZMP is {1000 * inside:.1f} mm inside the support, less than "
                 f"the walk's margin {1000 * criteria['zmp_margin_m']:g} mm")


def _worst(robot: RobotModel, tau: np.ndarray) -> str:
    k = int(np.argmax(np.abs(tau) / robot.servo_limit_nm))
    return f"{abs(tau[k]):.2f} N·m at {robot.joint_names[k]}, beyond its servo's {robot.servo_limit_nm[k]:g} N·m"


def _check_mcap(path: Path, robot: RobotModel, q: np.ndarray, t: np.ndarray, fail) -> None:
    """The MCAP's ``/joint_states`` (decoded from the definitions it carries) against the CSV's rows."""
    from jethr1_plan.files.mcap import read_mcap
    from jethr1_plan.files.messages import log_times

    data = read_input(path, MAX_MCAP_BYTES, "a walk's MCAP")
    try:
        messages = read_mcap(data, [tp.JOINT_STATES])
    except Exception as exc:  # any corrupt MCAP is bad input, not a bug
        raise InputError(str(path), "", f"not a readable MCAP file ({type(exc).__name__}: {str(exc)[:80]})") from None
    states = [(m, ns) for _, _, m, ns in messages]
    if len(states) != len(q):
        fail([min(len(states), len(q)) - 1 if min(len(states), len(q)) else 0], "MCAP",
             f"{len(states)} /joint_states messages, trajectory.csv has {len(q)} rows")
    expected_ns = log_times(np.asarray(t, dtype=float))
    for i, (m, ns) in enumerate(states[:len(q)]):
        try:
            pos = np.asarray(m.position, dtype=float)
            names = list(m.name)
        except (AttributeError, TypeError, ValueError):
            raise InputError(str(path), tp.JOINT_STATES, "a message without name / position") from None
        if names != list(robot.joint_names) or pos.shape != q[i].shape or np.any(pos != q[i]) \
                or ns != expected_ns[i]:
            fail([i], "MCAP", "/joint_states differs from trajectory.csv's row")
