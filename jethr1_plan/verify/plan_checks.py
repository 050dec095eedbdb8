"""The checks of a plan's rows, one small function each with its name (what a failure is called) and
what it holds the rows to; :func:`jethr1_plan.verify.plan.verify_rows` runs :data:`CHECKS` in order.

Every check reads a :class:`~.plan_rows.RowData` (the written columns and what is recomputed from them)
and returns its findings: ``(row, detail)`` pairs. A check whose columns the file does not have is
skipped; on a file without rows only the file's own checks run.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from jethr1_plan.geometry import SIDES, other_side
from jethr1_plan.records.plan_columns import COM, KAPPA, SWING, TOLERANCE_SHARE, WINDOW, ZMP, ZMP_MARGIN
from jethr1_plan.verify.balance import Tolerance, balance_slack, largest_share, support_margin
from jethr1_plan.verify.commands import PLAN_SAG_FILTER_S, fan_commands, servo_commands
from jethr1_plan.verify.common import TOL_M, TOL_RAD, TOL_T
from jethr1_plan.verify.plan_rows import (
    RowData,
    distance_to_polyline,
    expected_sequence,
    ground_references,
    scenario_feet,
)

__all__ = ["CHECKS", "RowCheck", "check"]

TOL_TAU = 1e-6  # torque tolerance [N·m] (forward kinematics from the written joints, exact to rounding)
# The fans' positions from forward kinematics differ from the planned ones by up to the IK tolerance
# (1e-6 m); about the sole's edge that moves the thrust window by ~M·g·1e-6 m / 0.1 m ≈ 1e-3 N and a
# balance moment by ~1e-4 N·m.
WINDOW_TOL_N = 1e-3
SLACK_TOL_NM = 1e-4
# the share of a row moves with its slack at about 0.7..3 N·m per unit of share: the FK's 1e-4 N·m
# moves it by less than 2e-4
SHARE_TOL = 1e-3

Finding = tuple[int, str]  # (row, detail)


@dataclass(frozen=True)
class RowCheck:
    """One check: ``name`` is what its failures are called; ``test`` gives the findings."""

    name: str
    what: str  # one line: what it holds the rows to
    test: Callable[[RowData], Iterable[Finding]]
    needs: tuple[str, ...] = ()  # columns it reads beyond every plan's (skipped without them)
    on_empty: bool = False  # runs on a file without rows (the file's own checks)


CHECKS: list[RowCheck] = []


def check(name: str, what: str, needs: tuple[str, ...] = (), on_empty: bool = False):
    """Register a check (in the order they run; a row's failures are listed in this order)."""
    def register(fn: Callable[[RowData], Iterable[Finding]]):
        CHECKS.append(RowCheck(name, what, fn, needs, on_empty))
        return fn
    return register


def rows(mask: Any, detail: Callable[..., str]) -> list[Finding]:
    """A finding for every row where ``mask`` holds."""
    return [(int(i), detail(int(i))) for i in np.flatnonzero(mask)]


# --- the file ----------------------------------------------------------------------------------


@check("row count", "as many rows as summary.json says (or, without it, as the scenario's plan has)", on_empty=True)
def _row_count(x: RowData) -> list[Finding]:
    traj = (x.summary or {}).get("trajectory")
    if isinstance(traj, dict):
        expected = traj.get("rows")
        if isinstance(expected, int) and expected != x.n:
            return [(min(expected, x.n), f"the file has {x.n} rows, summary.json says {expected}"
                     + (" (cut short?)" if x.n < expected else ""))]
        return []
    if x.scenario is not None and x.rate_hz is not None and x.n:
        sequence = expected_sequence(x.scenario, x.rate_hz, x.summary)
        expected = len(sequence) if sequence is not None else x.n
        if expected != x.n:
            return [(min(x.n, expected), f"the file has {x.n} rows, the scenario's plan {expected}")]
    return []


@check("infeasible plan", "summary.json does not say the plan is infeasible", on_empty=True)
def _summary_verdict(x: RowData) -> list[Finding]:
    s = x.summary
    if s is not None and not isinstance(s.get("trajectory"), dict) and s.get("feasible") is False:
        return [(0, "summary.json says the plan is infeasible")]
    return []


@check("no rows", "the file has rows", on_empty=True)
def _no_rows(x: RowData) -> list[Finding]:
    return [(0, "the file has a header and no rows")] if x.n == 0 else []


@check("time", "time from 0 at the plan's rate (without one: strictly increasing)")
def _time(x: RowData) -> list[Finding]:
    t = x.c["time_s"].astype(float)
    out = []
    if not abs(t[0]) <= TOL_T:
        out.append((0, f"the plan starts at t = 0 s, this row says {t[0]:.9g} s"))
    dt = np.diff(t)
    rate = x.rate_hz
    if rate is not None:
        out += [(int(i) + 1, f"{dt[i]:+.9g} s after the previous row; the plan's rate is {rate:g} Hz "
                 f"({1 / rate:.9g} s)") for i in np.flatnonzero(~(np.abs(dt - 1.0 / rate) <= TOL_T))]
    else:
        out += [(int(i) + 1, f"not after the previous row ({dt[i]:+.9g} s)") for i in np.flatnonzero(~(dt > 0))]
    return out


@check("phase out of order", "phases, steps, samples and supports in the scenario's order (without it: "
       "consistent with each other)")
def _phases(x: RowData) -> list[Finding]:
    c = x.c
    expected = (expected_sequence(x.scenario, x.rate_hz, x.summary) if x.scenario is not None and x.rate_hz is not None
                else None)
    if expected is not None:
        out = []
        for i in range(min(x.n, len(expected))):
            got = (str(c["phase"][i]), int(c["step"][i]), int(c["sample"][i]), str(c["support"][i]))
            if got != expected[i]:
                out.append((i, f"{got[0]} step {got[1]} sample {got[2]} support {got[3]}; the scenario's plan has "
                            f"{expected[i][0]} step {expected[i][1]} sample {expected[i][2]} support "
                            f"{expected[i][3]} here"))
        return out
    phase, support, sample = c["phase"], c["support"], c["sample"].astype(float)
    bad = ~(((phase == "transfer") & (support == "both")) | ((phase == "swing") & np.isin(support, SIDES)))
    out = [(int(i), f"{phase[i]} with support {support[i]}") for i in np.flatnonzero(bad)]
    cont = phase[1:] == phase[:-1]
    out += [(int(i) + 1, f"sample {sample[i + 1]:g} after {sample[i]:g}")
            for i in np.flatnonzero(cont & (np.diff(sample) != 1))]
    return out


@check("not a number", "every number of the row finite (the swing sample, the window and the share may be empty)")
def _numbers(x: RowData) -> list[Finding]:
    return rows(~x.finite, lambda i: "a value of the row is empty or not finite")


# --- the pose ----------------------------------------------------------------------------------


@check("not a unit quaternion", "the trunk's quaternion of unit length")
def _unit_quaternion(x: RowData) -> list[Finding]:
    norm = np.linalg.norm(x.quat, axis=1)
    return rows(~(np.abs(norm - 1.0) <= 1e-9), lambda i: f"|q| = {norm[i]:.6g}")


@check("trunk not level", "the trunk level (a yaw only)")
def _level(x: RowData) -> list[Finding]:
    quat = x.quat
    return rows(~((np.abs(quat[:, 0]) <= 1e-9) & (np.abs(quat[:, 1]) <= 1e-9)),
                lambda i: f"qx = {quat[i, 0]:.3g}, qy = {quat[i, 1]:.3g}")


@check("marked infeasible", "the planner's own verdict: every row feasible")
def _marked(x: RowData) -> list[Finding]:
    reason = x.c["reason"]
    return rows(~x.c["feasible"].astype(bool), lambda i: f"the planner says: {str(reason[i])[:100] or 'no reason'}")


@check("reason on a feasible row", "no reason on a feasible row")
def _reason(x: RowData) -> list[Finding]:
    reason = x.c["reason"]
    return rows(x.c["feasible"].astype(bool) & (reason != ""), lambda i: str(reason[i])[:100])


@check("joint limit", "every joint within its URDF limits")
def _joint_limits(x: RowData) -> list[Finding]:
    r, q = x.robot, x.q
    out = (q < r.lower_rad - 1e-9) | (q > r.upper_rad + 1e-9)
    first = np.argmax(out, axis=1)
    return rows(out.any(axis=1), lambda i: f"{r.joint_names[first[i]]} = {q[i, first[i]]:.4f} rad outside "
                f"[{r.lower_rad[first[i]]:.3f}, {r.upper_rad[first[i]]:.3f}]")


@check("sole not flat", "both soles flat")
def _flat(x: RowData) -> list[Finding]:
    out = []
    for s in SIDES:
        tilt = np.linalg.norm(x.fk["feet"][s][:, :3, :3] - np.eye(3), axis=(1, 2)) / np.sqrt(2)
        out += rows(tilt > TOL_RAD, lambda i, s=s, t=tilt: f"{s} sole turned by {t[i]:.2e}")
    return out


@check("support foot moved", "a sole on the ground stays where it stands (without a scenario: the start feet "
       "given)")
def _support_still(x: RowData) -> list[Finding]:
    reference = ground_references(x.support, x.pos)
    out = []
    for s in SIDES:
        grounded = (x.support == s) | (x.support == "both")
        dev = np.linalg.norm(x.pos[s] - reference[s], axis=1)
        out += rows(grounded & (dev > TOL_M), lambda i, s=s, d=dev, ref=reference: f"{s} sole {d[i]:.2e} m from "
                    f"where it stands over the rows it supports ({np.round(ref[s][i], 6).tolist()} m)")
        if x.scenario is None and x.start_feet is not None and grounded[0] and \
                np.linalg.norm(x.pos[s][0] - x.start_feet[s]) > TOL_M:
            out.append((0, f"{s} sole at {np.round(x.pos[s][0], 6).tolist()} m, the scenario says "
                        f"{np.round(x.start_feet[s], 6).tolist()} m"))
    return out


@check("sole not where the scenario puts it", "each sole on the ground where the scenario puts it in that phase")
def _placed(x: RowData) -> list[Finding]:
    if x.scenario is None:
        return []
    placed = scenario_feet(x.scenario, x.c["step"], x.c["phase"])
    out = []
    for s in SIDES:
        off = np.linalg.norm(x.pos[s] - placed[s], axis=1)
        out += rows(np.isfinite(off) & (off > TOL_M), lambda i, s=s, o=off: f"{s} sole at "
                    f"{np.round(x.pos[s][i], 4).tolist()} m, the scenario puts it at "
                    f"{np.round(placed[s][i], 4).tolist()} m ({o[i]:.2e} m away)")
    return out


@check("swing sole off its sample", "the swing sole on the row's written sample", needs=(SWING[0],))
def _on_sample(x: RowData) -> list[Finding]:
    c = x.c
    sample = np.stack([c[k] for k in SWING], axis=1).astype(float)
    off = x.single & ~(np.isfinite(sample).all(axis=1) & (np.linalg.norm(x.swing_pos - sample, axis=1) <= TOL_M))
    return rows(off, lambda i: f"swing sole at {np.round(x.swing_pos[i], 6).tolist()} m, sample "
                f"{np.round(sample[i], 6).tolist()} m")


@check("swing sole off its path", "the swing sole on the scenario's swing path (without it: on one of the file's)")
def _on_path(x: RowData) -> list[Finding]:
    sc = x.scenario
    paths = [st.path_m for st in sc.steps] if sc is not None else (x.swing_paths or [])
    out = []
    for i in np.flatnonzero(x.single) if paths else ():
        step = int(x.c["step"][i])
        candidates = [paths[step]] if sc is not None and 0 <= step < len(paths) else paths
        d = min(distance_to_polyline(x.swing_pos[i], p) for p in candidates)
        if d > TOL_M:
            out.append((int(i), f"{d:.2e} m from the scenario's swing path" if sc is not None else
                        f"{d:.2e} m from every swing path of the file"))
    return out


# --- balance -----------------------------------------------------------------------------------


@check("thrust out of range", "each fan's thrust within [0, F_max] of the fan and of the scenario")
def _thrust_range(x: RowData) -> list[Finding]:
    out = []
    for k, fan in enumerate(x.fans):
        f = x.thrust[:, k]
        out += rows(~((f >= 0.0) & (f <= x.fmax[k] + 1e-9)), lambda i, k=k, fan=fan: f"{fan.name} fan "
                    f"{x.thrust[i, k]:.3f} N outside [0, {x.fmax[k]:g}] N (the fan's rating and the scenario's limit)")
    return out


@check("thrust on the support foot", "a fan on a sole never pushes while its foot alone supports the robot")
def _support_fan(x: RowData) -> list[Finding]:
    out = []
    for k, fan in enumerate(x.fans):
        if fan.leg is not None:
            out += rows((x.support == fan.leg) & (x.thrust[:, k] != 0.0), lambda i, k=k, fan=fan: f"{fan.name} fan "
                        f"{x.thrust[i, k]:.3f} N while its foot supports the robot")
    return out


@check("ZMP outside support", "the ZMP of the written thrust (A-1, A-2) in the support sole (double support: the "
       "hull of both)")
def _zmp_inside(x: RowData) -> list[Finding]:
    # the minimal thrust puts the ZMP on the sole's edge; the fan's FK position may differ from the
    # planned one by the IK tolerance, so the edge is given that much
    margin = support_margin(x.zmp, *x.support_edges)
    outside = ~(margin >= -TOL_M)
    where = np.where(x.on_one_sole, "the support sole", "the hull of both soles")
    total = x.thrust.sum(axis=1)
    return rows(outside, lambda i: f"ZMP {np.round(x.zmp[i], 4).tolist()} m with the written thrust ({total[i]:.3f} N) "
                f"is outside {where[i]}")


@check("ground would have to pull", "the rows' own motion (second central differences of the written poses, "
       "the fans' written thrust) needs the ground to push, not pull, on every inner row")
def _ground_pushes(x: RowData) -> list[Finding]:
    fz = x.vertical_force
    if fz is None:
        return []
    pull = np.zeros(x.n, dtype=bool)
    pull[1:-1] = fz[1:-1] <= 0.0
    return rows(pull, lambda i: f"the motion needs {fz[i]:.2f} N of vertical ground force: the trunk falls faster "
                "than gravity between the rows around it")


@check("CoM column wrong", "the written CoM is the posture's", needs=(COM[0],))
def _com_column(x: RowData) -> list[Finding]:
    c, com = x.c, x.fk["com"]
    written = np.stack([c[k] for k in COM], axis=1).astype(float)
    return rows(~(np.linalg.norm(written - com, axis=1) <= 1e-9), lambda i: f"written "
                f"{np.round(written[i], 6).tolist()}, recomputed {np.round(com[i], 6).tolist()}")


@check("ZMP column wrong", "the written ZMP is the written thrust's", needs=(ZMP[0],))
def _zmp_column(x: RowData) -> list[Finding]:
    wz = np.stack([x.c[k] for k in ZMP], axis=1).astype(float)
    return rows(~(np.linalg.norm(wz - x.zmp, axis=1) <= TOL_M), lambda i: f"written {np.round(wz[i], 6).tolist()}, "
                f"recomputed {np.round(x.zmp[i], 6).tolist()}")


@check("ZMP margin column wrong", "the written ZMP margin is the ZMP's distance inside the support",
       needs=(WINDOW[0], ZMP_MARGIN))
def _margin_column(x: RowData) -> list[Finding]:
    margin_w = x.c[ZMP_MARGIN].astype(float)
    margin = support_margin(x.zmp, *x.support_edges)
    check = np.isfinite(x.zmp).all(axis=1)
    return rows(check & ~(np.abs(margin - margin_w) <= TOL_M), lambda i: f"written {margin_w[i]:.6f} m, recomputed "
                f"{margin[i]:.6f} m")


@check("thrust window column wrong", "the written thrust window is the posture's", needs=(WINDOW[0],))
def _window_column(x: RowData) -> list[Finding]:
    lo, hi, computed = x.windows
    lo_w, hi_w = x.c[WINDOW[0]].astype(float), x.c[WINDOW[1]].astype(float)
    bad = computed & ~((np.abs(lo - lo_w) <= WINDOW_TOL_N) & (np.abs(hi - hi_w) <= WINDOW_TOL_N))
    return rows(bad, lambda i: f"written [{lo_w[i]:.4f}, {hi_w[i]:.4f}] N, recomputed [{lo[i]:.4f}, {hi[i]:.4f}] N")


@check("thrust outside its window", "the written thrust within the posture's window", needs=(WINDOW[0],))
def _in_window(x: RowData) -> list[Finding]:
    lo, hi, computed = x.windows
    total = x.thrust.sum(axis=1)
    bad = computed & ~((lo - WINDOW_TOL_N <= total) & (total <= hi + WINDOW_TOL_N))

    def detail(i: int) -> str:
        share = x.thrust[i] / total[i] if total[i] > 0 else np.zeros(len(x.fans))
        carry = np.flatnonzero(share > 0) if total[i] > 0 else np.array(x.robot.swing_fans(
            other_side(x.support[i]))[:1], dtype=int)
        names = "+".join(x.robot.fans[k].name for k in carry)
        return f"{names} fan {total[i]:.3f} N outside [{lo[i]:.3f}, {hi[i]:.3f}] N"
    return rows(bad, detail)


def _plan_tolerance(x: RowData) -> Tolerance:
    """The plan's tolerance, from its ``balance`` block."""
    tol_doc = (x.balance or {}).get("tolerance", {})
    return Tolerance(*(float(tol_doc.get(key, 0.0)) for key in ("thrust_error", "mass_error", "com_error_m")))


@check("below the tolerance", "under the plan's tolerance, the ZMP in the support for every error within the "
       "row's share of it (the whole of it where the plan has no shares)", needs=(WINDOW[0],))
def _tolerance(x: RowData) -> list[Finding]:
    if x.balance is None:
        return []
    tol = _plan_tolerance(x)
    shares = x.c[TOLERANCE_SHARE].astype(float) if TOLERANCE_SHARE in x.c else np.full(x.n, np.nan)
    share = np.where(np.isfinite(shares) & (not tol.nominal), shares, 1.0)
    at = np.flatnonzero(np.isfinite(x.zmp).all(axis=1))
    normals, offsets = x.tolerance_edges
    slack = np.full(x.n, np.inf)
    slack[at] = balance_slack(x.fk["com"][at, :2], x.fk["fans"][at], x.thrust[at], normals[at], offsets[at],
                              x.robot.mass_kg, tol, share[at])

    def detail(i: int) -> str:
        held = tol.times(float(share[i]))
        return (f"the written thrust keeps the ZMP in the support only without ±{100 * held.thrust:g} % thrust, "
                f"±{100 * held.mass:g} % mass and {1000 * held.com_m:g} mm CoM error ({-slack[i]:.4f} N·m short)"
                + (f" ({share[i]:.4f} of the plan's tolerance)" if share[i] < 1.0 else ""))
    return rows(slack < -SLACK_TOL_NM, detail)


@check("tolerance share column wrong", "under a tolerance, the written share is the largest share of it the row's "
       "thrust holds (recomputed, ``verify.balance.largest_share``)", needs=(TOLERANCE_SHARE,))
def _share_column(x: RowData) -> list[Finding]:
    if x.balance is None:
        return []
    tol = _plan_tolerance(x)
    if tol.nominal:
        return []
    written = x.c[TOLERANCE_SHARE].astype(float)
    at = np.flatnonzero(np.isfinite(x.zmp).all(axis=1))
    normals, offsets = x.tolerance_edges
    again = np.full(x.n, np.nan)
    again[at] = largest_share(x.fk["com"][at, :2], x.fk["fans"][at], x.thrust[at], normals[at], offsets[at],
                              x.robot.mass_kg, tol)
    out = []
    for i in at.tolist():
        if not np.isfinite(written[i]):
            out.append((i, "empty under a tolerance"))
        elif abs(again[i] - written[i]) > SHARE_TOL:
            out.append((i, f"written {written[i]:.6f}, recomputed {again[i]:.6f}"))
    return out


@check("below the least share", "every row's tolerance share at least the plan's ``min_share``",
       needs=(TOLERANCE_SHARE,))
def _least_share(x: RowData) -> list[Finding]:
    least = float((x.balance or {}).get("min_share") or 0.0)
    written = x.c[TOLERANCE_SHARE].astype(float)
    return rows(np.isfinite(written) & (written < least - SHARE_TOL),
                lambda i: f"tolerance share {written[i]:.4f} below the plan's min_share {least:g}")


# --- the analysis ------------------------------------------------------------------------------


@check("torque column wrong", "the written static torques are the posture's under the written thrust",
       needs=(KAPPA[0],))
def _torque_column(x: RowData) -> list[Finding]:
    if not x.statics:
        return []
    tau_w = np.stack([x.c[f"{j}_tau_nm"] for j in x.robot.joint_names], axis=1).astype(float)
    tau = x.fk["tau"]
    ok = np.isfinite(tau).all(axis=1)
    err = np.abs(tau_w - tau)
    out = []
    for i in np.flatnonzero(ok & ~np.all(err <= TOL_TAU * np.maximum(1.0, np.abs(tau)), axis=1)):
        j = int(np.argmax(err[i]))
        out.append((int(i), f"{x.robot.joint_names[j]}_tau_nm {tau_w[i, j]:.4f}, recomputed {tau[i, j]:.4f} N·m"))
    return out


@check("torque over its servo limit", "every static torque within its servos' limit (unless told not to)",
       needs=(KAPPA[0],))
def _torque_limit(x: RowData) -> list[Finding]:
    if not (x.statics and x.torque_limits):
        return []
    tau_w = np.stack([x.c[f"{j}_tau_nm"] for j in x.robot.joint_names], axis=1).astype(float)
    tau = x.fk["tau"]
    ok = np.isfinite(tau).all(axis=1)
    used = np.where(ok[:, None], tau, tau_w)
    ratio = np.abs(used) / x.robot.servo_limit_nm
    out = []
    for i in np.flatnonzero(ratio.max(axis=1) > 1.0):
        j = int(np.argmax(ratio[i]))
        out.append((int(i), f"{x.robot.joint_names[j]} needs {abs(used[i, j]):.2f} N·m, its servos give "
                    f"{x.robot.servo_limit_nm[j]:.2f} N·m"))
    return out


@check("kappa column wrong", "the written κ of each leg is the posture's", needs=(KAPPA[0],))
def _kappa_column(x: RowData) -> list[Finding]:
    if not x.statics:
        return []
    kappa_w = np.stack([x.c[k] for k in KAPPA], axis=1).astype(float)
    kappa = x.fk["kappa"]
    bad = np.isfinite(kappa).all(axis=1) & ~np.all(np.abs(kappa_w - kappa) <= 1e-6 * np.maximum(1.0, kappa), axis=1)
    return rows(bad, lambda i: f"written {np.round(kappa_w[i], 4).tolist()}, recomputed "
                f"{np.round(kappa[i], 4).tolist()}")


def _command_rate(x: RowData) -> float | None:
    """The rows' rate from their times (None where the time check has said why it is not one)."""
    dt = np.diff(x.c["time_s"].astype(float))
    if x.n < 2 or not (np.all(dt > 0) and np.all(np.isfinite(dt))) or not x.statics:
        return None
    return 1.0 / float(np.median(dt))


@check("servo command column wrong", "the servo commands are the rows plus the sag under their torques "
       "(``verify.commands``)", needs=(KAPPA[0],))
def _servo_commands(x: RowData) -> list[Finding]:
    rate = _command_rate(x)
    if rate is None or f"{x.robot.joint_names[0]}_cmd_rad" not in x.c:
        return []
    r = x.robot
    tau = np.stack([x.c[f"{j}_tau_nm"] for j in r.joint_names], axis=1).astype(float)
    q_cmd = servo_commands(x.q, tau, r.servo_stiffness_nm_per_rad, rate, PLAN_SAG_FILTER_S)
    written = np.stack([x.c[f"{j}_cmd_rad"] for j in r.joint_names], axis=1).astype(float)
    out = []
    for i in np.flatnonzero(~np.all(np.abs(written - q_cmd) <= 1e-9, axis=1)):
        j = int(np.argmax(np.abs(written[i] - q_cmd[i])))
        out.append((int(i), f"{r.joint_names[j]}_cmd_rad {written[i, j]:.6f}, recomputed {q_cmd[i, j]:.6f}"))
    return out


@check("fan command column wrong", "the fan commands are the thrust led by the fans' lag (``verify.commands``)",
       needs=(KAPPA[0],))
def _fan_commands(x: RowData) -> list[Finding]:
    rate = _command_rate(x)
    if rate is None or f"{x.robot.joint_names[0]}_cmd_rad" not in x.c:
        return []
    fans = x.fans
    f_cmd = fan_commands(x.thrust, rate, np.array([f.lag_s for f in fans]), np.array([f.max_thrust_n for f in fans]))
    written = np.column_stack([x.c[f"thrust_cmd_{f.name}_n"] for f in fans]).astype(float)
    return rows(~np.all(np.abs(written - f_cmd) <= 1e-9, axis=1), lambda i: f"written "
                f"{np.round(written[i], 4).tolist()} N, recomputed {np.round(f_cmd[i], 4).tolist()} N")
