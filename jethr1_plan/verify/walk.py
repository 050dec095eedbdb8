"""``jethr1 verify`` of a walk folder (``jethr1 walk``'s output): an independent re-check of what was
written, never the generator's state.

Each row's trunk pose and joints go into a fresh PlaCo robot; against ``summary.json`` (its rows,
rate, start soles, footholds and success criteria) every row must hold:

* **the file**: as many rows as the walk wrote, at its control rate from t = 0; a unit quaternion;
  the support column as the footsteps' timing says;
* **the pose**: joints within the URDF limits; each sole (forward kinematics) where the CSV says it
  is and, when it bears weight, on its foothold within the walk's tolerance and flat; the swing sole
  above the ground; the knees at least the walk's margin from straight; the CoM as written;
* **balance**: the multibody ZMP recomputed from the written rows (the centroidal momentum of each
  row's posture and motion, differentiated) as written, and inside the support polygon with the
  walk's margin (the first and last two rows excepted: one-sided differences);
* **torques and commands**: the written joint torques within the servo limits; the servo commands
  the rows plus the sag those torques cause (``planning.commands``);
* **the walk's own verdict**: ``summary.json`` says ok;
* **CSV and MCAP together**: the MCAP's ``/joint_states`` are the CSV's rows.
"""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.geometry import SIDES, polygon_margin, pose_from_quaternion
from jethr1_plan.robot.model import RobotModel, load_robot
from jethr1_plan.verify.common import TOL_M, TOL_T, Failure
from jethr1_plan.walking.analysis import EDGE_ROWS, SuccessCriteria, zmp_from_momentum
from jethr1_plan.walking.generator import generalized_velocity
from jethr1_plan.walking.timeline import Timeline, polygon_of

__all__ = ["is_walk", "verify_walk"]

TOL_ZMP_M = 1e-5  # the recomputed ZMP differentiates written numbers twice [m]


def is_walk(summary: dict | None, header: list[str] | None = None) -> bool:
    """Whether a folder's files are a walk's (summary kind, or a walk's CSV header)."""
    if summary is not None:
        return summary.get("kind") == "walk"
    return header is not None and "yaw_ref_rad" in header


def _number(summary: dict, key: str, src: str) -> float:
    v = summary.get(key)
    if not isinstance(v, int | float) or isinstance(v, bool) or not np.isfinite(v):
        raise InputError(src, key, "missing or not a number")
    return float(v)


def _timeline(summary: dict, robot: RobotModel, src: str) -> Timeline:
    """The walk's footsteps in time, rebuilt from ``summary.json``'s start soles, footholds and timing;
    its lift and landing times must be the ones the summary states."""
    try:
        timing = summary["spec"]["timing"]
        start = {s: np.asarray(summary["start_m"][s], dtype=float) for s in SIDES}
        footholds = [(st["side"], np.asarray(st["position_m"], dtype=float)) for st in summary["steps"]]
        tl = Timeline.build(start, footholds, float(timing["start_s"]), float(timing["single_support_s"]),
                            float(timing["double_support_s"]), float(timing["end_s"]),
                            float(timing["swing_height_m"]), robot.sole_length_m, robot.sole_width_m)
        stated = [(float(st["lift_s"]), float(st["land_s"])) for st in summary["steps"]]
    except (KeyError, TypeError, ValueError, IndexError):
        raise InputError(src, "steps", "missing or malformed start_m, steps or spec.timing") from None
    for k, (st, (lift, land)) in enumerate(zip(tl.steps, stated, strict=True)):
        if abs(st.t_lift - lift) > TOL_T or abs(st.t_land - land) > TOL_T:
            raise InputError(src, f"steps[{k}]", f"lifts at {lift:g} s and lands at {land:g} s; its timing says "
                             f"{st.t_lift:g} s and {st.t_land:g} s")
    return tl


def verify_walk(folder: Path, summary: dict, files: list[Path], max_failures: int = 50):
    """Verify a walk's files; (rows, failures, what was checked).

    Raises:
        InputError: an unreadable or malformed file or summary.
    """
    from jethr1_plan.files.walk_folder import read_walk_csv, walk_columns

    src = str(folder / "summary.json")
    robot_ref = summary.get("robot_yaml") if isinstance(summary.get("robot_yaml"), str) and Path(
        summary["robot_yaml"]).is_file() else summary.get("robot")
    if not isinstance(robot_ref, str):
        raise InputError(src, "robot", "missing")
    robot = load_robot(robot_ref)
    csv_path = folder / "trajectory.csv"
    if not csv_path.is_file():
        raise InputError(str(folder), "", "a walk is verified from its trajectory.csv, which is missing")
    try:
        text = csv_path.read_bytes().decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(str(csv_path), "", f"cannot read as UTF-8 text: {exc}") from None
    c = read_walk_csv(text, str(csv_path))
    missing = [k for k in walk_columns(robot) if k not in c]
    if missing:
        raise InputError(str(csv_path), "header", f"missing column {missing[0]!r}")
    found: list[Failure] = []
    n = len(c["time_s"])
    t = c["time_s"]

    def fail(rows, check: str, detail) -> None:
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
        return 0, found, str(folder)
    bad_t = np.flatnonzero(np.abs(t - np.arange(n) / rate) > TOL_T)
    fail(bad_t, "time", lambda i: f"t = {t[i]!r} s, expected {i / rate:.9f} s at {rate:g} Hz")
    quat = np.column_stack([c[f"pelvis_q{a}"] for a in "xyzw"])
    bad_q = np.flatnonzero(np.abs(np.linalg.norm(quat, axis=1) - 1.0) > 1e-6)
    fail(bad_q, "pose", "the trunk's quaternion is not a unit one")
    q = np.column_stack([c[f"{j}_rad"] for j in robot.joint_names])
    over = np.flatnonzero(np.any((q < robot.lower_rad - 1e-6) | (q > robot.upper_rad + 1e-6), axis=1))
    fail(over, "joints", "a joint beyond its URDF limits")
    tau = np.column_stack([c[f"{j}_tau_nm"] for j in robot.joint_names])
    fail(np.flatnonzero(np.any(np.abs(tau) > robot.servo_limit_nm + 1e-9, axis=1)), "torque",
         "a joint torque beyond its servo limit")
    from jethr1_plan.control.commands import servo_commands
    from jethr1_plan.walking.result import WALK_SAG_FILTER_S

    q_cmd = np.column_stack([c[f"{j}_cmd_rad"] for j in robot.joint_names])
    expected = servo_commands(q, tau, robot.servo_stiffness_nm_per_rad, rate, WALK_SAG_FILTER_S)
    fail(np.flatnonzero(np.any(np.abs(q_cmd - expected) > 1e-9, axis=1)), "commands",
         "the servo commands are not the rows plus the sag under their torques")
    if np.isnan(np.concatenate([quat.ravel(), q.ravel()])).any():
        fail([int(np.flatnonzero(np.isnan(np.column_stack([quat, q])).any(axis=1))[0])], "file", "an empty pose cell")
        return n, found[:max_failures], str(folder)
    given = summary.get("spec", {}).get("success", {})
    for f in fields(SuccessCriteria):
        if f.name in given and f.name != "rehearse":
            _number(given, f.name, src + " spec.success")
    criteria = SuccessCriteria(**{f.name: given[f.name] for f in fields(SuccessCriteria) if f.name in given})
    _check_rows(c, robot, q, quat, _timeline(summary, robot, src), rate, criteria, fail)
    mcap_path = folder / "trajectory.mcap"
    if mcap_path in files and mcap_path.is_file():
        _check_mcap(mcap_path, robot, q, t, fail)
    found.sort(key=lambda f: f.row)
    return n, found[:max_failures], str(folder)


def _check_rows(c, robot: RobotModel, q, quat, tl: Timeline, rate: float, criteria: SuccessCriteria, fail) -> None:
    """The pose and balance checks, from one forward-kinematics pass over the written rows."""
    n = len(q)
    t = c["time_s"]
    dt = 1.0 / rate
    unit = quat / np.linalg.norm(quat, axis=1)[:, None]
    T = np.array([pose_from_quaternion([c["pelvis_x_m"][i], c["pelvis_y_m"][i], c["pelvis_z_m"][i]], unit[i])
                  for i in range(n)])
    # the generalised velocity at each row: the mean of the motions over the periods before and after it
    v_period = np.zeros((n, 6 + len(robot.joint_names)))
    for i in range(1, n):
        v_period[i] = generalized_velocity(T[i - 1], T[i], q[i - 1], q[i], dt)
    v = v_period.copy()
    v[:-1] = 0.5 * (v_period[:-1] + v_period[1:])
    w = robot.wrapper()
    com, h = np.zeros((n, 3)), np.zeros((n, 6))
    sole = {s: np.zeros((n, 4, 4)) for s in SIDES}
    for i in range(n):
        w.state.q[:3] = T[i][:3, 3]
        w.state.q[3:7] = unit[i]
        w.state.q[7:] = q[i]
        w.update_kinematics()
        com[i] = w.com_world()
        h[i] = w.centroidal_map() @ v[i]
        for s in SIDES:
            sole[s][i] = w.get_T_world_frame(robot.legs[s].sole)
    written_com = np.column_stack([c[f"com_{a}_m"] for a in "xyz"])
    fail(np.flatnonzero(np.linalg.norm(com - written_com, axis=1) > TOL_M), "CoM",
         lambda i: f"written {np.round(written_com[i], 6).tolist()} m, forward kinematics "
                   f"{np.round(com[i], 6).tolist()} m")
    knees = [robot.legs[s].index[3] for s in SIDES]
    knee_short = np.flatnonzero(np.min(q[:, knees] - robot.lower_rad[knees], axis=1) < criteria.knee_margin_rad - 1e-9)
    fail(knee_short, "knee", f"closer than {criteria.knee_margin_rad:g} rad to straight")
    support, _ = tl.phase(t)
    feet, air = tl.feet(t)
    edge = np.zeros(n, dtype=bool)  # rows on a phase boundary (times written to 1e-9 s): either phase holds
    for st in tl.steps:
        edge |= (np.abs(t - st.t_lift) < 1e-6) | (np.abs(t - st.t_land) < 1e-6)
    for i in range(n):
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
                if err > criteria.foot_tolerance_m + 1e-12:
                    fail([i], "feet", f"the {s} sole bears weight {1000 * err:.2f} mm from its foothold "
                         f"{np.round(feet[s][i], 4).tolist()} m")
                if tilt > criteria.foot_tolerance_rad:
                    fail([i], "feet", f"the {s} sole bears weight {tilt:.3f} rad off flat")
            elif p[2] < -TOL_M - criteria.foot_tolerance_m:
                fail([i], "feet", f"the swinging {s} sole is {1000 * -p[2]:.1f} mm below the ground")
    zmp = zmp_from_momentum(com, h, dt, robot.mass_kg)
    written_zmp = np.column_stack([c["zmp_x_m"], c["zmp_y_m"]])
    fail(np.flatnonzero(np.linalg.norm(zmp - written_zmp, axis=1) > TOL_ZMP_M), "ZMP",
         lambda i: f"written {np.round(written_zmp[i], 5).tolist()} m, recomputed {np.round(zmp[i], 5).tolist()} m")
    keys = tl.support_keys(t)
    for i in range(EDGE_ROWS, n - EDGE_ROWS):
        inside = polygon_margin(zmp[i], polygon_of(keys[i], robot.sole_length_m, robot.sole_width_m, 0.0))
        if inside < criteria.zmp_margin_m - 1e-9:
            fail([i], "ZMP", f"the recomputed ZMP is {1000 * inside:.1f} mm inside the support, less than "
                 f"the walk's margin {1000 * criteria.zmp_margin_m:g} mm")


def _check_mcap(path: Path, robot: RobotModel, q: np.ndarray, t: np.ndarray, fail) -> None:
    """The MCAP's ``/joint_states`` (decoded from the definitions it carries) against the CSV's rows."""
    from jethr1_plan.files.mcap import log_times, read_mcap

    try:
        data = path.read_bytes()
        messages = read_mcap(data, ["/joint_states"])
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
            raise InputError(str(path), "/joint_states", "a message without name / position") from None
        if names != list(robot.joint_names) or pos.shape != q[i].shape or np.any(pos != q[i]) \
                or ns != expected_ns[i]:
            fail([i], "MCAP", "/joint_states differs from trajectory.csv's row")
