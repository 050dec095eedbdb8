"""``jethr1 verify``: an independent re-check of a written trajectory before it goes on the robot.

Reads only the written file (``trajectory.csv`` or ``trajectory.mcap``) and the robot model, never
the planner's state: puts each row's pelvis pose and joints into a fresh PlaCo robot and checks,
row by row,

* joints within the URDF limits;
* both soles flat (level, facing +x), the support sole where it was at the start of its phase and
  (with the scenario) where the scenario puts it;
* the swing sole on its written sample (CSV) or on a swing path of the file (MCAP);
* each fan's thrust within [0, F_max];
* the ZMP from the written thrust (A-1, A-2) inside the support sole, or in double support inside
  the hull of both soles;
* the written CoM and ZMP (CSV) match the recomputed ones.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .balance import inside_polygon, sole_polygon
from .errors import InputError
from .posture import pose_from_quaternion
from .robot_model import GRAVITY, JOINT_NAMES, SIDES, load_robot
from .sequence import convex_hull

TOL_M = 1e-6  # position tolerance [m] (the IK tolerance)
TOL_RAD = 1e-6


@dataclass
class Failure:
    row: int
    time_s: float
    check: str
    detail: str

    def __str__(self) -> str:
        return f"row {self.row} (t = {self.time_s:.3f} s): {self.check}: {self.detail}"


def _rows_from_csv(text: str) -> dict[str, np.ndarray]:
    from .csv_writer import columns, read_trajectory_csv

    header = text.split("\n", 1)[0].split(",")
    missing = [c for c in columns() if c not in header and c != "reason"]
    if missing:
        raise InputError("trajectory.csv", "header", f"missing columns {missing[:4]}")
    return read_trajectory_csv(text)


def _rows_from_mcap(data: bytes) -> tuple[dict[str, np.ndarray], list[np.ndarray]]:
    from .mcap_writer import read_mcap

    by_time: dict[int, dict] = {}
    paths: list[np.ndarray] = []
    for topic, _schema, msg, t in read_mcap(data):
        if topic == "/swing_path":
            for ent in msg["entities"]:
                for line in ent["lines"]:
                    paths.append(np.array([[p["x"], p["y"], p["z"]] for p in line["points"]]))
        elif topic in ("/joint_states", "/thrust", "/p_body"):
            by_time.setdefault(t, {})[topic] = msg
    rows = [by_time[t] for t in sorted(by_time)]
    if not rows or any(len(r) != 3 for r in rows):
        raise InputError("trajectory.mcap", "/joint_states, /thrust, /p_body", "missing or unpaired messages")
    cols: dict[str, list] = {}
    for t, r in zip(sorted(by_time), rows, strict=True):
        pose = r["/p_body"]["pose"]
        names = r["/joint_states"]["name"]
        pos = dict(zip(names, r["/joint_states"]["position_rad"], strict=True))
        th = r["/thrust"]
        vals = {"time_s": t / 1e9, "pelvis_x_m": pose["position"]["x"], "pelvis_y_m": pose["position"]["y"],
                "pelvis_z_m": pose["position"]["z"], **{f"pelvis_q{k}": pose["orientation"][k] for k in "xyzw"},
                **{f"{j}_rad": pos[j] for j in JOINT_NAMES}, "thrust_left_n": th["left_n"],
                "thrust_right_n": th["right_n"], "phase": th["phase"], "support": th["support"], "step": th["step"]}
        for k, v in vals.items():
            cols.setdefault(k, []).append(v)
    return {k: np.array(v, dtype=object if k in ("phase", "support") else float) for k, v in cols.items()}, paths


def _forward_kinematics(c: dict[str, np.ndarray], robot, q: np.ndarray) -> dict:
    """Per row, from the written pelvis pose and joints (fresh PlaCo robot): both sole poses (n, 4, 4),
    the CoM (n, 3) and both fans' ground points (n, 2)."""
    wrapper = robot.wrapper()
    n = len(q)
    out = {"feet": {s: np.zeros((n, 4, 4)) for s in SIDES}, "fans": {s: np.zeros((n, 2)) for s in SIDES},
           "com": np.zeros((n, 3))}
    for i in range(n):
        quat = [float(c[f"pelvis_q{k}"][i]) for k in "xyzw"]
        p = [c["pelvis_x_m"][i], c["pelvis_y_m"][i], c["pelvis_z_m"][i]]
        wrapper.set_T_world_fbase(pose_from_quaternion(p, quat))
        wrapper.state.q[7:] = q[i]
        wrapper.update_kinematics()
        for s in SIDES:
            out["feet"][s][i] = wrapper.get_T_world_frame(f"{s}_foot")
            out["fans"][s][i] = wrapper.get_T_world_frame(f"{s}_fan")[:2, 3]
        out["com"][i] = wrapper.com_world()
    return out


def verify_rows(c: dict[str, np.ndarray], robot_name: str = "jethr1", swing_paths: list[np.ndarray] | None = None,
                start_feet: dict[str, np.ndarray] | None = None, max_failures: int = 50,
                balance: dict | None = None) -> tuple[int, list[Failure]]:
    """Check every row (vectorised over rows); return (rows checked, failures sorted by row).

    ``balance``: the plan's ``summary.json`` balance block (policy, sole margin, tolerance); with it
    every row's written thrust must keep the ZMP in the support (shrunk by the sole margin) under every
    error within the tolerance (``balance.balance_slack``).
    """
    robot = load_robot(robot_name)
    w = robot.mass_kg * GRAVITY
    fmax = {f.foot.split("_")[0]: f.max_thrust_n for f in robot.fans}
    n = len(c["time_s"])
    q = np.stack([c[f"{j}_rad"] for j in JOINT_NAMES], axis=1).astype(float)
    fk = _forward_kinematics(c, robot, q)
    reference = _ground_references(c, fk["feet"])
    found: list[tuple[int, int, str, str]] = []  # (row, order, check, detail)

    def fail(rows, order, check, detail):
        for i in np.flatnonzero(rows):
            found.append((int(i), order, check, detail(int(i))))

    out = (q < robot.lower_rad - 1e-9) | (q > robot.upper_rad + 1e-9)
    first = np.argmax(out, axis=1)
    fail(out.any(axis=1), 0, "joint limit", lambda i: f"{JOINT_NAMES[first[i]]} = {q[i, first[i]]:.4f} rad outside "
         f"[{robot.lower_rad[first[i]]:.3f}, {robot.upper_rad[first[i]]:.3f}]")
    support = c["support"]
    pos = {s: fk["feet"][s][:, :3, 3] for s in SIDES}
    for s in SIDES:
        tilt = np.linalg.norm(fk["feet"][s][:, :3, :3] - np.eye(3), axis=(1, 2)) / np.sqrt(2)
        fail(tilt > TOL_RAD, 1, "sole not flat", lambda i, s=s, t=tilt: f"{s} sole turned by {t[i]:.2e}")
        grounded = (support == s) | (support == "both")
        dev = np.linalg.norm(pos[s] - reference[s], axis=1)
        fail(grounded & (dev > TOL_M), 2, "support foot moved",
             lambda i, s=s, d=dev: f"{s} sole {d[i]:.2e} m from where it stands over the rows it supports "
             f"({np.round(reference[s][i], 6).tolist()} m)")
        if start_feet is not None and n and grounded[0] and np.linalg.norm(pos[s][0] - start_feet[s]) > TOL_M:
            fail(np.arange(n) == 0, 2, "support foot moved", lambda i, s=s: f"{s} sole at "
                 f"{np.round(pos[s][0], 6).tolist()} m, scenario says {np.round(start_feet[s], 6).tolist()} m")
    single = support != "both"
    swing_pos = np.where((support == "right")[:, None], pos["left"], pos["right"])
    if "swing_x_m" in c:
        sample = np.stack([c["swing_x_m"], c["swing_y_m"], c["swing_z_m"]], axis=1).astype(float)
        off = single & ~(np.isfinite(sample).all(axis=1) & (np.linalg.norm(swing_pos - sample, axis=1) <= TOL_M))
        fail(off, 3, "swing sole off its sample", lambda i: f"swing sole at {np.round(swing_pos[i], 6).tolist()} m, "
             f"sample {np.round(sample[i], 6).tolist()} m")
    elif swing_paths:
        for i in np.flatnonzero(single):
            d = min(_distance_to_polyline(swing_pos[i], path) for path in swing_paths)
            if d > TOL_M:
                found.append((int(i), 3, "swing sole off its path", f"{d:.2e} m from every swing path"))
    thrust = {"left": c["thrust_left_n"].astype(float), "right": c["thrust_right_n"].astype(float)}
    for s in SIDES:
        bad = ~((thrust[s] >= 0.0) & (thrust[s] <= fmax[s] + 1e-9))
        fail(bad, 4, "thrust out of range", lambda i, s=s: f"{s} fan {thrust[s][i]:.3f} N outside [0, {fmax[s]}] N")
    com = fk["com"]
    total = thrust["left"] + thrust["right"]
    zmp = (w * com[:, :2] - sum(thrust[s][:, None] * fk["fans"][s] for s in SIDES)) / (w - total)[:, None]
    # the minimal thrust puts the ZMP on the sole's edge; the fan's FK position may differ from the
    # planned one by the IK tolerance, so the edge is given that much
    half = np.array([robot.sole_length_m, robot.sole_width_m]) / 2
    sup_xy = np.where((support == "left")[:, None], pos["left"][:, :2], pos["right"][:, :2])
    outside = single & np.any(np.abs(zmp - sup_xy) > half + TOL_M, axis=1)
    hulls: dict[bytes, np.ndarray] = {}
    for i in np.flatnonzero(~single):
        key = np.round(np.concatenate([pos["left"][i, :2], pos["right"][i, :2]]), 7).tobytes()
        if key not in hulls:
            hulls[key] = convex_hull(np.vstack([sole_polygon(pos[s][i, :2], 0.0, robot.sole_length_m,
                                                             robot.sole_width_m) for s in SIDES]))
        outside[i] = not inside_polygon(zmp[i], hulls[key], tol_m=TOL_M)
    where = np.where(single, "the support sole", "the hull of both soles")
    fail(outside, 5, "ZMP outside support", lambda i: f"ZMP {np.round(zmp[i], 4).tolist()} m with the written "
         f"thrust ({total[i]:.3f} N) is outside {where[i]}")
    if "thrust_window_lo_n" in c:
        _check_windows(c, robot, fk, pos, single, thrust, zmp, balance, found)
    if "left_hip_yaw_cmd_rad" in c and "left_hip_yaw_tau_nm" in c and n > 1:
        _check_commands(c, robot, q, thrust, found)
    if "com_x_m" in c:
        written = np.stack([c["com_x_m"], c["com_y_m"], c["com_z_m"]], axis=1).astype(float)
        bad = ~(np.linalg.norm(written - com, axis=1) <= 1e-9)
        fail(bad, 6, "CoM column wrong", lambda i: f"written {np.round(written[i], 6).tolist()}, recomputed "
             f"{np.round(com[i], 6).tolist()}")
        wz = np.stack([c["zmp_x_m"], c["zmp_y_m"]], axis=1).astype(float)
        bad = ~(np.linalg.norm(wz - zmp, axis=1) <= TOL_M)
        fail(bad, 7, "ZMP column wrong", lambda i: f"written {np.round(wz[i], 6).tolist()}, recomputed "
             f"{np.round(zmp[i], 6).tolist()}")
    found.sort(key=lambda f: (f[0], f[1]))
    return n, [Failure(i, float(c["time_s"][i]), check, detail) for i, _, check, detail in found[:max_failures]]


# The fans' positions from forward kinematics differ from the planned ones by up to the IK tolerance
# (1e-6 m); about the sole's edge that moves the thrust window by ~M·g·1e-6 m / 0.1 m ≈ 1e-3 N and a
# balance moment by ~1e-4 N·m.
WINDOW_TOL_N = 1e-3
SLACK_TOL_NM = 1e-4


def _supports(c, robot, pos, single) -> list[np.ndarray]:
    """Per row, the real support polygon: the support sole, or the hull of both soles."""
    out = []
    for i in range(len(single)):
        soles = [SIDES.index(c["support"][i])] if single[i] else [0, 1]
        polys = [sole_polygon(pos[SIDES[k]][i, :2], 0.0, robot.sole_length_m, robot.sole_width_m) for k in soles]
        out.append(polys[0] if single[i] else convex_hull(np.vstack(polys)))
    return out


def _check_windows(c, robot, fk, pos, single, thrust, zmp, balance, found) -> None:
    """The written thrust window, ZMP margin and (with the plan's balance settings) the tolerance."""
    from .balance import Tolerance, balance_slack, polygon_margin, thrust_window

    polys = _supports(c, robot, pos, single)
    lo_w, hi_w = c["thrust_window_lo_n"].astype(float), c["thrust_window_hi_n"].astype(float)
    margin_w = c["zmp_margin_m"].astype(float)
    fmax = {f.foot.split("_")[0]: f.max_thrust_n for f in robot.fans}
    tol = Tolerance(**{k: float(v) for k, v in zip(("thrust", "mass", "com_m"), (
        (balance or {}).get("tolerance", {}).get(key, 0.0) for key in ("thrust_error", "mass_error", "com_error_m")),
        strict=True)})
    shrink = float((balance or {}).get("sole_margin_m", 0.0))
    com = fk["com"][:, :2]
    for i, poly in enumerate(polys):
        margin = float(polygon_margin(zmp[i], poly))
        if not abs(margin - margin_w[i]) <= TOL_M:
            found.append((i, 8, "ZMP margin column wrong", f"written {margin_w[i]:.6f} m, recomputed {margin:.6f} m"))
        # the window of the fan that carries thrust (in a swing row: the swing foot's fan)
        loaded = [s for s in SIDES if thrust[s][i] > 0]
        side = loaded[0] if loaded else (("left" if c["support"][i] == "right" else "right") if single[i] else None)
        if side is not None and np.isfinite(lo_w[i]):
            lo, hi = thrust_window(com[i], fk["fans"][side][i], poly, robot.mass_kg)
            lo, hi = float(lo), float(min(hi, fmax[side]))
            if not (abs(lo - lo_w[i]) <= WINDOW_TOL_N and abs(hi - hi_w[i]) <= WINDOW_TOL_N):
                found.append((i, 8, "thrust window column wrong", f"written [{lo_w[i]:.4f}, {hi_w[i]:.4f}] N, "
                              f"recomputed [{lo:.4f}, {hi:.4f}] N"))
            if not (lo - WINDOW_TOL_N <= thrust[side][i] <= hi + WINDOW_TOL_N):
                found.append((i, 8, "thrust outside its window", f"{side} fan {thrust[side][i]:.3f} N outside "
                              f"[{lo:.3f}, {hi:.3f}] N"))
        if balance is not None:
            shrunk = poly if shrink == 0 else (sole_polygon(np.mean(poly, axis=0), 0.0, robot.sole_length_m,
                                                            robot.sole_width_m, shrink) if single[i] else None)
            if shrunk is None:  # the hull of both soles shrunk by the margin
                soles = [sole_polygon(pos[s][i, :2], 0.0, robot.sole_length_m, robot.sole_width_m, shrink)
                         for s in SIDES]
                shrunk = convex_hull(np.vstack(soles))
            slack = float(balance_slack(com[i], np.stack([fk["fans"][s][i] for s in SIDES]),
                                        np.array([thrust[s][i] for s in SIDES]), shrunk, robot.mass_kg, tol))
            if slack < -SLACK_TOL_NM:
                found.append((i, 8, "below the tolerance", f"the written thrust keeps the ZMP in the support only "
                              f"without ±{100 * tol.thrust:g} % thrust, ±{100 * tol.mass:g} % mass and "
                              f"{1000 * tol.com_m:g} mm CoM error ({-slack:.4f} N·m short)"))


def _check_commands(c, robot, q, thrust, found) -> None:
    """The command columns against the commands recomputed from the written rows (``commands``)."""
    from .commands import fan_commands, servo_commands

    rate = 1.0 / float(np.median(np.diff(c["time_s"].astype(float))))
    tau = np.stack([c[f"{j}_tau_nm"] for j in JOINT_NAMES], axis=1).astype(float)
    q_cmd = servo_commands(q, tau, robot.servo_stiffness_nm_per_rad, rate)
    written = np.stack([c[f"{j}_cmd_rad"] for j in JOINT_NAMES], axis=1).astype(float)
    bad = np.flatnonzero(~np.all(np.abs(written - q_cmd) <= 1e-9, axis=1))
    for i in bad:
        j = int(np.argmax(np.abs(written[i] - q_cmd[i])))
        found.append((int(i), 9, "servo command column wrong", f"{JOINT_NAMES[j]}_cmd_rad {written[i, j]:.6f}, "
                      f"recomputed {q_cmd[i, j]:.6f}"))
    fans = [robot.fan_for(s) for s in SIDES]
    f_cmd = fan_commands(np.column_stack([thrust[s] for s in SIDES]), rate, np.array([f.lag_s for f in fans]),
                         np.array([f.max_thrust_n for f in fans]))
    written = np.column_stack([c[f"thrust_cmd_{s}_n"] for s in SIDES]).astype(float)
    for i in np.flatnonzero(~np.all(np.abs(written - f_cmd) <= 1e-9, axis=1)):
        found.append((int(i), 9, "fan command column wrong", f"written {np.round(written[i], 4).tolist()} N, "
                      f"recomputed {np.round(f_cmd[i], 4).tolist()} N"))


def _ground_references(c: dict[str, np.ndarray], feet: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Per foot and row, where that foot stands: the median of its position over each stretch of
    consecutive rows in which it is on the ground (so a single tampered row stands out)."""
    n = len(c["support"])
    ref = {}
    for s in SIDES:
        grounded = np.array([sup in (s, "both") for sup in c["support"]])
        pos = feet[s][:, :3, 3]
        ref[s] = np.full((n, 3), np.nan)
        start = 0
        while start < n:
            if not grounded[start]:
                start += 1
                continue
            end = start
            while end < n and grounded[end]:
                end += 1
            ref[s][start:end] = np.median(pos[start:end], axis=0)
            start = end
    return ref


def _distance_to_polyline(p: np.ndarray, pts: np.ndarray) -> float:
    a, b = pts[:-1], pts[1:]
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-30), 0, 1)
    return float(np.min(np.linalg.norm(a + t[:, None] * ab - p, axis=1)))


def verify_path(path: Path, scenario: Path | None = None) -> tuple[int, list[Failure], str]:
    """Verify a trajectory.csv, trajectory.mcap or an output folder; returns (rows, failures, what)."""
    path = Path(path)
    if path.is_dir():
        csv = path / "trajectory.csv"
        path = csv if csv.exists() else path / "trajectory.mcap"
    if not path.exists():
        raise InputError(str(path), "", "no such file (expected trajectory.csv, trajectory.mcap or their folder)")
    robot_name, start, balance = "jethr1", None, None
    summary = path.parent / "summary.json"
    if summary.exists():
        try:
            doc = json.loads(summary.read_text())
            robot_name = doc.get("robot_yaml") or doc.get("robot", robot_name)
            scenario = scenario or (Path(doc["scenario_file"]) if doc.get("scenario_file") else None)
            balance = doc.get("balance")
        except (ValueError, KeyError):
            pass
    if scenario is not None and Path(scenario).exists():
        from .scenario import load_scenario

        start = load_scenario(scenario).start
    if path.suffix == ".mcap":
        rows, paths = _rows_from_mcap(path.read_bytes())
        n, failures = verify_rows(rows, robot_name, swing_paths=paths, start_feet=start)
    elif path.suffix == ".csv":
        n, failures = verify_rows(_rows_from_csv(path.read_text()), robot_name, start_feet=start, balance=balance)
    else:
        raise InputError(str(path), "", "expected a .csv or .mcap trajectory")
    return n, failures, str(path)
