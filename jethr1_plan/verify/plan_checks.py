"""The checks of a plan's file and of its poses, one small function each with its name (what a failure is
called) and what it holds the rows to (:mod:`.checks`); the balance's are in :mod:`.balance_checks`, the
torques' and the commands' in :mod:`.analysis_checks`.
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.geometry import SIDES
from jethr1_plan.records.plan_columns import SWING
from jethr1_plan.verify.checks import Finding, RowCheck, registrar, rows
from jethr1_plan.verify.common import TOL_M, TOL_RAD, TOL_T
from jethr1_plan.verify.plan_geometry import distances_to_polyline
from jethr1_plan.verify.plan_rows import (
    RowData,
    expected_sequence,
    ground_references,
    scenario_feet,
)

__all__ = ["CHECKS"]

CHECKS: list[RowCheck] = []  # in the order they run
check = registrar(CHECKS)

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
    rows_single = np.flatnonzero(x.single) if paths else np.zeros(0, dtype=int)
    step = x.c["step"][rows_single].astype(int)
    d = np.full(len(rows_single), np.inf)
    for k, path in enumerate(paths):  # each row against its step's path (any path where the step is not one)
        mine = (step == k) | (sc is None) | (step < 0) | (step >= len(paths))
        if mine.any():
            d[mine] = np.minimum(d[mine], distances_to_polyline(x.swing_pos[rows_single[mine]], path))
    what = "from the scenario's swing path" if sc is not None else "from every swing path of the file"
    return [(int(i), f"{di:.2e} m {what}") for i, di in zip(rows_single, d, strict=True) if di > TOL_M]
