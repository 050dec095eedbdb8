"""``jethr1 verify``: an independent re-check of a written plan before it goes on the robot.

Reads only what was written (``trajectory.csv``, ``trajectory.mcap``, ``summary.json``), the
scenario and the robot model, never the planner's state. Each row's pelvis pose and joints go into
a fresh PlaCo robot, and every row must hold against everything that can be known:

* **the file** (``summary.json``): as many rows as the plan wrote, at its rate from t = 0, strictly
  increasing; **the scenario**: transfers and swings in its order and lengths, each with its step,
  its samples counted from 0 and its support;
* **the pose**: a unit quaternion of a level trunk; joints within the URDF limits; both soles flat;
  every sole on the ground where the scenario puts it in that phase (the start, then each landing),
  the swing sole on the scenario's swing path and on its written sample;
* **the plan's own verdict**: every row marked feasible with no reason;
* **balance**: each fan's thrust within [0, F_max] of the fan and of the scenario; the ZMP from the
  written thrust (A-1, A-2) in the support sole (double support: the hull of both); the written
  thrust window and ZMP margin recomputed; under the plan's tolerance, the ZMP in the support for
  every error within it (``balance.balance_slack``);
* **the analysis**: the written CoM and ZMP; the static torques recomputed (``statics``) and within
  the servo limits; κ of each leg; the command columns recomputed (``commands``);
* **CSV and MCAP together** (a folder with both): the same rows, the same numbers.

A failing row gives one line; a file that cannot be read as this format is bad input (exit 2).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from jethr1_plan.files.plan_folder import PlanFolder
from jethr1_plan.geometry import (
    GRAVITY,
    SIDES,
    convex_hull,
    inside_polygon,
    other_side,
    pose_from_quaternion,
    sole_polygon,
)
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.verify.common import TOL_M, TOL_RAD, TOL_T, Failure

__all__ = ["verify_plan", "verify_rows"]

TOL_TAU = 1e-6  # torque tolerance [N·m] (forward kinematics from the written joints, exact to rounding)
# The fans' positions from forward kinematics differ from the planned ones by up to the IK tolerance
# (1e-6 m); about the sole's edge that moves the thrust window by ~M·g·1e-6 m / 0.1 m ≈ 1e-3 N and a
# balance moment by ~1e-4 N·m.
WINDOW_TOL_N = 1e-3
SLACK_TOL_NM = 1e-4


def verify_plan(plan: PlanFolder) -> tuple[int, list[Failure]]:
    """Every row of every trajectory file of ``plan`` (and, with both, the CSV against the MCAP);
    (rows, failures sorted by row)."""
    n, failures = 0, []
    for f, table in plan.tables.items():
        k, fails = verify_rows(table, plan.robot, swing_paths=plan.swing_paths.get(f), summary=plan.summary,
                               scenario=plan.scenario)
        n = max(n, k)
        failures += [Failure(x.row, x.time_s, x.check, f"{f.name}: {x.detail}" if len(plan.tables) > 1 else x.detail)
                     for x in fails]
    if len(plan.tables) == 2:
        (_, csv_rows), (_, mcap_rows) = sorted(plan.tables.items(), key=lambda kv: kv[0].suffix)
        failures += _compare_files(csv_rows, mcap_rows)
    failures.sort(key=lambda x: x.row)
    return n, failures



def _compare_files(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> list[Failure]:
    """Rows of the CSV (a) and the MCAP (b) that differ (the numbers written are the same floats)."""
    out = []
    n = min(len(a["time_s"]), len(b["time_s"]))
    if len(a["time_s"]) != len(b["time_s"]):
        out.append(Failure(n, float(a["time_s"][n - 1]) if n else 0.0, "CSV and MCAP differ",
                           f"{len(a['time_s'])} rows in the CSV, {len(b['time_s'])} in the MCAP"))
    for i in range(n):
        for k in a:
            if k not in b:
                continue
            x, y = a[k][i], b[k][i]
            if isinstance(x, float | np.floating):
                x, y = float(x), float(y)
                same = x == y or (math.isnan(x) and math.isnan(y)) or abs(x - y) <= 1e-12 * max(1.0, abs(x))
            else:
                same = x == y
            if not same:
                out.append(Failure(i, float(a["time_s"][i]), "CSV and MCAP differ", f"{k}: {x!r} against {y!r}"))
                break
    return out


# --- checks ----------------------------------------------------------------------------------


def _forward_kinematics(c: dict[str, np.ndarray], robot: RobotModel, q: np.ndarray, thrust: np.ndarray,
                        statics: bool) -> dict:
    """Per row, from the written pelvis pose and joints (fresh PlaCo robot): both sole poses (n, 4, 4),
    the CoM (n, 3), every fan's ground point (n, F, 2); with ``statics`` also the static torques under
    the written thrust (n, F) (n, J) and each leg's κ (n, 2)."""
    from jethr1_plan.physics.statics import leg_condition_numbers, static_torques

    wrapper = robot.wrapper()
    n = len(q)
    out: dict[str, Any] = {"feet": {s: np.zeros((n, 4, 4)) for s in SIDES}, "fans": np.zeros((n, len(robot.fans), 2)),
           "com": np.zeros((n, 3)), "tau": np.full((n, len(robot.joint_names)), np.nan),
           "kappa": np.full((n, 2), np.nan)}
    for i in range(n):
        quat = [float(c[f"pelvis_q{k}"][i]) for k in "xyzw"]
        norm = math.sqrt(sum(v * v for v in quat))
        if not math.isfinite(norm) or norm < 1e-9:
            continue
        p = [c["pelvis_x_m"][i], c["pelvis_y_m"][i], c["pelvis_z_m"][i]]
        wrapper.set_T_world_fbase(pose_from_quaternion(p, [v / norm for v in quat]))
        wrapper.state.q[7:] = q[i]
        wrapper.update_kinematics()
        for s in SIDES:
            out["feet"][s][i] = wrapper.get_T_world_frame(robot.legs[s].sole)
        for k, fan in enumerate(robot.fans):
            out["fans"][i, k] = wrapper.get_T_world_frame(fan.frame)[:2, 3]
        out["com"][i] = wrapper.com_world()
        if statics:
            sup = c["support"][i]
            supports = SIDES if sup == "both" else ((sup,) if sup in SIDES else ())
            if supports:
                out["tau"][i], _ = static_torques(robot, wrapper, np.where(np.isfinite(thrust[i]), thrust[i], 0.0),
                                                  supports)
            kappa = leg_condition_numbers(robot, wrapper)
            out["kappa"][i] = kappa["left"], kappa["right"]
    return out


def _expected_sequence(sc, rate_hz: float) -> list[tuple[str, int, int, str]]:
    """(phase, step, sample, support) of every row the scenario's plan has, in order (``sequence``)."""
    from jethr1_plan.control.time_laws import swing_row_positions

    n_tr = max(1, round(sc.timing.transfer_s * rate_hz))
    rows = []
    for k, st in enumerate(sc.steps):
        rows += [("transfer", k, i, "both") for i in range(n_tr)]
        rows += [("swing", k, i, st.support) for i in range(len(swing_row_positions(len(st.path_m), sc.timing.swing_s,
                                                                                    rate_hz)))]
    rows += [("transfer", len(sc.steps), i, "both") for i in range(n_tr + 1)]
    return rows


def _scenario_feet(sc, row_step: np.ndarray, phase: np.ndarray) -> dict[str, np.ndarray]:
    """Per row, where the scenario puts each sole on the ground: before step k (transfers leading into
    step k, and the support sole of swing k); NaN for the swing sole of a swing row."""
    from jethr1_plan.planning.problems import feet_before_each_step

    before = feet_before_each_step(sc)
    final = {k: v.copy() for k, v in before[-1].items()}
    final[sc.steps[-1].swing] = sc.steps[-1].landing_m.copy()
    before.append(final)
    out = {s: np.full((len(phase), 3), np.nan) for s in SIDES}
    for i, (ph, k) in enumerate(zip(phase, row_step, strict=True)):
        k = int(k)
        if not 0 <= k < len(before):
            continue
        for s in SIDES:
            if ph == "transfer" or (ph == "swing" and k < len(sc.steps) and sc.steps[k].support == s):
                out[s][i] = before[k][s]
    return out


def verify_rows(c: dict[str, np.ndarray], robot: RobotModel, swing_paths: list[np.ndarray] | None = None,
                start_feet: dict[str, np.ndarray] | None = None, max_failures: int = 50,
                balance: dict | None = None, summary: dict | None = None, scenario=None,
                torque_limits: bool = True) -> tuple[int, list[Failure]]:
    """Check every row (vectorised where it can); return (rows checked, failures sorted by row).

    Args:
        summary: the plan's ``summary.json``: row count, rate, thrust limit, balance (policy,
            tolerance). ``balance`` alone may be given instead (the planner's self-check).
        scenario: the plan's scenario: the phases, the soles on the ground, the swing paths.
        start_feet: where the soles stand at the start (without a scenario).
        torque_limits: rows whose static torque exceeds a servo limit fail.
    """
    balance = balance if balance is not None else (summary or {}).get("balance")
    w = robot.mass_kg * GRAVITY
    fans = robot.fans
    fmax = np.array([f.max_thrust_n for f in fans])
    limit = (summary or {}).get("thrust_max_n")
    if isinstance(limit, int | float):
        fmax = np.minimum(fmax, float(limit))
    n = len(c["time_s"])
    found: list[tuple[int, int, str, str]] = []  # (row, order, check, detail)

    def fail(rows, order, check, detail):
        for i in np.flatnonzero(rows):
            found.append((int(i), order, check, detail(int(i))))

    _check_file(c, n, summary, scenario, found)
    if n == 0:
        return 0, _failures(found, c, max_failures)
    finite = np.ones(n, dtype=bool)
    for k, v in c.items():
        if k in ("phase", "support", "reason", "feasible"):
            continue
        if k.startswith(("swing_", "thrust_window_")):
            continue  # empty (NaN) where there is no swing sole, or no window
        finite &= np.isfinite(v.astype(float))
    fail(~finite, 0, "not a number", lambda i: "a value of the row is empty or not finite")
    joints = robot.joint_names
    q = np.stack([c[f"{j}_rad"] for j in joints], axis=1).astype(float)
    q = np.where(np.isfinite(q), q, 0.0)
    statics = f"{joints[0]}_tau_nm" in c
    thrust = np.stack([c[f"thrust_{f.name}_n"] for f in fans], axis=1).astype(float).reshape(n, len(fans))
    fk = _forward_kinematics(c, robot, q, thrust, statics)
    quat = np.stack([c[f"pelvis_q{k}"] for k in "xyzw"], axis=1).astype(float)
    norm = np.linalg.norm(quat, axis=1)
    fail(~(np.abs(norm - 1.0) <= 1e-9), 1, "not a unit quaternion", lambda i: f"|q| = {norm[i]:.6g}")
    fail(~((np.abs(quat[:, 0]) <= 1e-9) & (np.abs(quat[:, 1]) <= 1e-9)), 1, "trunk not level",
         lambda i: f"qx = {quat[i, 0]:.3g}, qy = {quat[i, 1]:.3g}")
    feasible = c["feasible"].astype(bool)
    reason = c["reason"]
    fail(~feasible, 1, "marked infeasible", lambda i: f"the planner says: {str(reason[i])[:100] or 'no reason'}")
    fail(feasible & (reason != ""), 1, "reason on a feasible row", lambda i: str(reason[i])[:100])

    out = (q < robot.lower_rad - 1e-9) | (q > robot.upper_rad + 1e-9)
    first = np.argmax(out, axis=1)
    fail(out.any(axis=1), 2, "joint limit", lambda i: f"{joints[first[i]]} = {q[i, first[i]]:.4f} rad outside "
         f"[{robot.lower_rad[first[i]]:.3f}, {robot.upper_rad[first[i]]:.3f}]")
    support = c["support"]
    pos = {s: fk["feet"][s][:, :3, 3] for s in SIDES}
    reference = _ground_references(c, fk["feet"])
    placed = _scenario_feet(scenario, c["step"], c["phase"]) if scenario is not None else None
    for s in SIDES:
        tilt = np.linalg.norm(fk["feet"][s][:, :3, :3] - np.eye(3), axis=(1, 2)) / np.sqrt(2)
        fail(tilt > TOL_RAD, 3, "sole not flat", lambda i, s=s, t=tilt: f"{s} sole turned by {t[i]:.2e}")
        grounded = (support == s) | (support == "both")
        dev = np.linalg.norm(pos[s] - reference[s], axis=1)
        fail(grounded & (dev > TOL_M), 4, "support foot moved",
             lambda i, s=s, d=dev: f"{s} sole {d[i]:.2e} m from where it stands over the rows it supports "
             f"({np.round(reference[s][i], 6).tolist()} m)")
        if placed is not None:
            off = np.linalg.norm(pos[s] - placed[s], axis=1)
            fail(np.isfinite(off) & (off > TOL_M), 4, "sole not where the scenario puts it",
                 lambda i, s=s, o=off: f"{s} sole at {np.round(pos[s][i], 4).tolist()} m, the scenario puts it at "
                 f"{np.round(placed[s][i], 4).tolist()} m ({o[i]:.2e} m away)")
        elif start_feet is not None and grounded[0] and np.linalg.norm(pos[s][0] - start_feet[s]) > TOL_M:
            fail(np.arange(n) == 0, 4, "support foot moved", lambda i, s=s: f"{s} sole at "
                 f"{np.round(pos[s][0], 6).tolist()} m, the scenario says {np.round(start_feet[s], 6).tolist()} m")
    single = support != "both"
    swing_pos = np.where((support == "right")[:, None], pos["left"], pos["right"])
    if "swing_x_m" in c:
        sample = np.stack([c["swing_x_m"], c["swing_y_m"], c["swing_z_m"]], axis=1).astype(float)
        off = single & ~(np.isfinite(sample).all(axis=1) & (np.linalg.norm(swing_pos - sample, axis=1) <= TOL_M))
        fail(off, 5, "swing sole off its sample", lambda i: f"swing sole at {np.round(swing_pos[i], 6).tolist()} m, "
             f"sample {np.round(sample[i], 6).tolist()} m")
    paths = [st.path_m for st in scenario.steps] if scenario is not None else (swing_paths or [])
    if paths:
        for i in np.flatnonzero(single):
            step = int(c["step"][i])
            candidates = [paths[step]] if scenario is not None and 0 <= step < len(paths) else paths
            d = min(_distance_to_polyline(swing_pos[i], p) for p in candidates)
            if d > TOL_M:
                found.append((int(i), 5, "swing sole off its path", f"{d:.2e} m from the scenario's swing path"
                              if scenario is not None else f"{d:.2e} m from every swing path of the file"))
    for f_idx, fan in enumerate(fans):
        bad = ~((thrust[:, f_idx] >= 0.0) & (thrust[:, f_idx] <= fmax[f_idx] + 1e-9))
        fail(bad, 6, "thrust out of range", lambda i, f_idx=f_idx, fan=fan: f"{fan.name} fan "
             f"{thrust[i, f_idx]:.3f} N outside [0, {fmax[f_idx]:g}] N (the fan's rating and the scenario's limit)")
        if fan.leg is not None:  # a fan on a sole never pushes while its foot alone supports the robot
            fail((support == fan.leg) & (thrust[:, f_idx] != 0.0), 6, "thrust on the support foot",
                 lambda i, f_idx=f_idx, fan=fan: f"{fan.name} fan {thrust[i, f_idx]:.3f} N while its foot supports "
                 "the robot")
    com = fk["com"]
    total = thrust.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        moment = sum(thrust[:, f_idx, None] * fk["fans"][:, f_idx] for f_idx in range(len(fans)))
        zmp = (w * com[:, :2] - moment) / (w - total)[:, None]
    # the minimal thrust puts the ZMP on the sole's edge; the fan's FK position may differ from the
    # planned one by the IK tolerance, so the edge is given that much
    half = np.array([robot.sole_length_m, robot.sole_width_m]) / 2
    sup_xy = np.where((support == "left")[:, None], pos["left"][:, :2], pos["right"][:, :2])
    outside = single & ~np.all(np.abs(zmp - sup_xy) <= half + TOL_M, axis=1)
    hulls: dict[bytes, np.ndarray] = {}
    for i in np.flatnonzero(~single):
        key = np.round(np.concatenate([pos["left"][i, :2], pos["right"][i, :2]]), 7).tobytes()
        if key not in hulls:
            hulls[key] = convex_hull(np.vstack([sole_polygon(pos[s][i, :2], 0.0, robot.sole_length_m,
                                                             robot.sole_width_m) for s in SIDES]))
        outside[i] = not inside_polygon(zmp[i], hulls[key], tol_m=TOL_M)
    where = np.where(single, "the support sole", "the hull of both soles")
    fail(outside, 7, "ZMP outside support", lambda i: f"ZMP {np.round(zmp[i], 4).tolist()} m with the written "
         f"thrust ({total[i]:.3f} N) is outside {where[i]}")
    if "com_x_m" in c:
        written = np.stack([c["com_x_m"], c["com_y_m"], c["com_z_m"]], axis=1).astype(float)
        bad = ~(np.linalg.norm(written - com, axis=1) <= 1e-9)
        fail(bad, 8, "CoM column wrong", lambda i: f"written {np.round(written[i], 6).tolist()}, recomputed "
             f"{np.round(com[i], 6).tolist()}")
        wz = np.stack([c["zmp_x_m"], c["zmp_y_m"]], axis=1).astype(float)
        bad = ~(np.linalg.norm(wz - zmp, axis=1) <= TOL_M)
        fail(bad, 8, "ZMP column wrong", lambda i: f"written {np.round(wz[i], 6).tolist()}, recomputed "
             f"{np.round(zmp[i], 6).tolist()}")
    if "thrust_window_lo_n" in c:
        _check_windows(c, robot, fk, pos, single, thrust, zmp, balance, found)
    if statics:
        _check_statics(c, robot, fk, torque_limits, found)
    if f"{joints[0]}_cmd_rad" in c and statics and n > 1:
        _check_commands(c, robot, q, thrust, found)
    return n, _failures(found, c, max_failures)


def _failures(found: list, c: dict, max_failures: int) -> list[Failure]:
    """The first ``max_failures`` failures in row order, and the first of every other kind of check."""
    found.sort(key=lambda f: (f[0], f[1]))
    chosen = found[:max_failures]
    shown = {f[2] for f in chosen}
    for f in found[max_failures:]:
        if f[2] not in shown:
            chosen.append(f)
            shown.add(f[2])
    times = c["time_s"]
    out = []
    for i, _, check, detail in chosen:
        t = float(times[i]) if 0 <= i < len(times) and np.isfinite(times[i]) else float(len(times))
        out.append(Failure(i, t, check, detail))
    return out


def _check_file(c: dict, n: int, summary: dict | None, scenario, found: list) -> None:
    """Row count, time and the order of phases against summary.json and the scenario."""
    rate = None
    traj = (summary or {}).get("trajectory")
    if isinstance(traj, dict):
        rows = traj.get("rows")
        if isinstance(rows, int) and rows != n:
            at = min(rows, n)
            found.append((at, 0, "row count", f"the file has {n} rows, summary.json says {rows}"
                          + (" (cut short?)" if n < rows else "")))
        if isinstance(traj.get("rate_hz"), int | float) and traj["rate_hz"] > 0:
            rate = float(traj["rate_hz"])
    elif summary is not None and summary.get("feasible") is False:
        found.append((0, 0, "infeasible plan", "summary.json says the plan is infeasible"))
    if scenario is not None and rate is None:
        rate = scenario.timing.rate_hz
    if n == 0:
        found.append((0, 0, "no rows", "the file has a header and no rows"))
        return
    t = c["time_s"].astype(float)
    if not abs(t[0]) <= TOL_T:
        found.append((0, 0, "time", f"the plan starts at t = 0 s, this row says {t[0]:.9g} s"))
    dt = np.diff(t)
    if rate is not None:
        bad = np.flatnonzero(~(np.abs(dt - 1.0 / rate) <= TOL_T))
        for i in bad:
            found.append((int(i) + 1, 0, "time", f"{dt[i]:+.9g} s after the previous row; the plan's rate is "
                          f"{rate:g} Hz ({1 / rate:.9g} s)"))
    else:
        for i in np.flatnonzero(~(dt > 0)):
            found.append((int(i) + 1, 0, "time", f"not after the previous row ({dt[i]:+.9g} s)"))
    if scenario is not None and rate is not None:
        expected = _expected_sequence(scenario, rate)
        if len(expected) != n and not isinstance(traj, dict):
            found.append((min(n, len(expected)), 0, "row count", f"the file has {n} rows, the scenario's plan "
                          f"{len(expected)}"))
        for i in range(min(n, len(expected))):
            got = (str(c["phase"][i]), int(c["step"][i]), int(c["sample"][i]), str(c["support"][i]))
            if got != expected[i]:
                found.append((i, 0, "phase out of order", f"{got[0]} step {got[1]} sample {got[2]} support {got[3]}; "
                              f"the scenario's plan has {expected[i][0]} step {expected[i][1]} sample "
                              f"{expected[i][2]} support {expected[i][3]} here"))
    else:
        phase, support, sample = c["phase"], c["support"], c["sample"].astype(float)
        bad = ~(((phase == "transfer") & (support == "both")) | ((phase == "swing") & np.isin(support, SIDES)))
        for i in np.flatnonzero(bad):
            found.append((int(i), 0, "phase out of order", f"{phase[i]} with support {support[i]}"))
        cont = phase[1:] == phase[:-1]
        for i in np.flatnonzero(cont & (np.diff(sample) != 1)):
            found.append((int(i) + 1, 0, "phase out of order", f"sample {sample[i + 1]:g} after {sample[i]:g}"))


def _supports(c, robot, pos, single) -> list[np.ndarray]:
    """Per row, the real support polygon: the support sole, or the hull of both soles."""
    out = []
    for i in range(len(single)):
        soles = [SIDES.index(c["support"][i])] if single[i] and c["support"][i] in SIDES else [0, 1]
        polys = [sole_polygon(pos[SIDES[k]][i, :2], 0.0, robot.sole_length_m, robot.sole_width_m) for k in soles]
        out.append(polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys)))
    return out


def _check_windows(c, robot, fk, pos, single, thrust, zmp, balance, found) -> None:
    """The written thrust window, ZMP margin and (with the plan's balance settings) the tolerance."""
    from jethr1_plan.geometry import polygon_margin
    from jethr1_plan.physics.balance import Tolerance, balance_slack, shared_window, thrust_window

    polys = _supports(c, robot, pos, single)
    lo_w, hi_w = c["thrust_window_lo_n"].astype(float), c["thrust_window_hi_n"].astype(float)
    margin_w = c["zmp_margin_m"].astype(float)
    fmax = np.array([f.max_thrust_n for f in robot.fans])
    tol_doc = (balance or {}).get("tolerance", {})
    tol = Tolerance(*(float(tol_doc.get(key, 0.0)) for key in ("thrust_error", "mass_error", "com_error_m")))
    shrink = float((balance or {}).get("sole_margin_m", 0.0))
    com = fk["com"][:, :2]
    for i, poly in enumerate(polys):
        if not np.all(np.isfinite(zmp[i])):
            continue
        margin = float(polygon_margin(zmp[i], poly))
        if not abs(margin - margin_w[i]) <= TOL_M:
            found.append((i, 9, "ZMP margin column wrong", f"written {margin_w[i]:.6f} m, recomputed {margin:.6f} m"))
        # the window of the fans that carry thrust, in their shares (in a swing row without thrust: the
        # first fan the swing may use, its sole's)
        total = float(np.sum(thrust[i]))
        share = None
        if total > 0:
            share = thrust[i] / total
        elif single[i] and c["support"][i] in SIDES:
            usable = robot.swing_fans(other_side(c["support"][i]))
            if usable:
                share = np.isin(np.arange(len(fmax)), usable[:1]).astype(float)
        if share is not None and np.isfinite(lo_w[i]):
            carry = np.flatnonzero(share > 0)
            if len(carry) == 1:
                w_lo, w_hi = thrust_window(com[i], fk["fans"][i, carry[0]], poly, robot.mass_kg)
                lo, hi = float(w_lo), min(float(w_hi), float(fmax[carry[0]]))
            else:
                w_lo, w_hi = shared_window(com[i], fk["fans"][i, carry], share[carry], poly, robot.mass_kg)
                lo, hi = float(w_lo), min(float(w_hi), float(np.min(fmax[carry] / share[carry])))
            if not (abs(lo - lo_w[i]) <= WINDOW_TOL_N and abs(hi - hi_w[i]) <= WINDOW_TOL_N):
                found.append((i, 9, "thrust window column wrong", f"written [{lo_w[i]:.4f}, {hi_w[i]:.4f}] N, "
                              f"recomputed [{lo:.4f}, {hi:.4f}] N"))
            if not (lo - WINDOW_TOL_N <= total <= hi + WINDOW_TOL_N):
                names = "+".join(robot.fans[k].name for k in carry)
                found.append((i, 9, "thrust outside its window", f"{names} fan {total:.3f} N outside "
                              f"[{lo:.3f}, {hi:.3f}] N"))
        if balance is not None:
            soles = [c["support"][i]] if single[i] and c["support"][i] in SIDES else list(SIDES)
            shrunk = [sole_polygon(pos[s][i, :2], 0.0, robot.sole_length_m, robot.sole_width_m, shrink) for s in soles]
            region = shrunk[0] if len(shrunk) == 1 else convex_hull(np.vstack(shrunk))
            slack = float(balance_slack(com[i], fk["fans"][i], thrust[i], region, robot.mass_kg, tol))
            if slack < -SLACK_TOL_NM:
                found.append((i, 9, "below the tolerance", f"the written thrust keeps the ZMP in the support only "
                              f"without ±{100 * tol.thrust:g} % thrust, ±{100 * tol.mass:g} % mass and "
                              f"{1000 * tol.com_m:g} mm CoM error ({-slack:.4f} N·m short)"))


def _check_statics(c, robot, fk, torque_limits: bool, found) -> None:
    """The torque and κ columns against their recomputation; torques within the servo limits."""
    tau_w = np.stack([c[f"{j}_tau_nm"] for j in robot.joint_names], axis=1).astype(float)
    tau = fk["tau"]
    ok = np.isfinite(tau).all(axis=1)
    err = np.abs(tau_w - tau)
    for i in np.flatnonzero(ok & ~np.all(err <= TOL_TAU * np.maximum(1.0, np.abs(tau)), axis=1)):
        j = int(np.argmax(err[i]))
        found.append((int(i), 10, "torque column wrong", f"{robot.joint_names[j]}_tau_nm {tau_w[i, j]:.4f}, recomputed "
                      f"{tau[i, j]:.4f} N·m"))
    if torque_limits:
        ratio = np.abs(np.where(ok[:, None], tau, tau_w)) / robot.servo_limit_nm
        for i in np.flatnonzero(ratio.max(axis=1) > 1.0):
            j = int(np.argmax(ratio[i]))
            found.append((int(i), 10, "torque over its servo limit", f"{robot.joint_names[j]} needs "
                          f"{abs(tau[i, j] if ok[i] else tau_w[i, j]):.2f} N·m, its servos give "
                          f"{robot.servo_limit_nm[j]:.2f} N·m"))
    kappa_w = np.stack([c["kappa_left"], c["kappa_right"]], axis=1).astype(float)
    kappa = fk["kappa"]
    bad = np.isfinite(kappa).all(axis=1) & ~np.all(np.abs(kappa_w - kappa) <= 1e-6 * np.maximum(1.0, kappa), axis=1)
    for i in np.flatnonzero(bad):
        found.append((int(i), 10, "kappa column wrong", f"written {np.round(kappa_w[i], 4).tolist()}, recomputed "
                      f"{np.round(kappa[i], 4).tolist()}"))


def _check_commands(c, robot, q, thrust, found) -> None:
    """The command columns against the commands recomputed from the written rows (``commands``)."""
    from jethr1_plan.control.commands import fan_commands, servo_commands

    dt = np.diff(c["time_s"].astype(float))
    if not (np.all(dt > 0) and np.all(np.isfinite(dt))):
        return  # the time check has said why
    rate = 1.0 / float(np.median(dt))
    tau = np.stack([c[f"{j}_tau_nm"] for j in robot.joint_names], axis=1).astype(float)
    q_cmd = servo_commands(q, tau, robot.servo_stiffness_nm_per_rad, rate)
    written = np.stack([c[f"{j}_cmd_rad"] for j in robot.joint_names], axis=1).astype(float)
    for i in np.flatnonzero(~np.all(np.abs(written - q_cmd) <= 1e-9, axis=1)):
        j = int(np.argmax(np.abs(written[i] - q_cmd[i])))
        found.append((int(i), 11, "servo command column wrong", f"{robot.joint_names[j]}_cmd_rad {written[i, j]:.6f}, "
                      f"recomputed {q_cmd[i, j]:.6f}"))
    fans = robot.fans
    f_cmd = fan_commands(thrust, rate, np.array([f.lag_s for f in fans]),
                         np.array([f.max_thrust_n for f in fans]))
    written = np.column_stack([c[f"thrust_cmd_{f.name}_n"] for f in fans]).astype(float)
    for i in np.flatnonzero(~np.all(np.abs(written - f_cmd) <= 1e-9, axis=1)):
        found.append((int(i), 11, "fan command column wrong", f"written {np.round(written[i], 4).tolist()} N, "
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
