"""Where a route's landing errors come from, step by step, in the robot's frame: the independent replay
(tests/oracles/replay.py, unchanged) is run on a written plan folder while every physics step's body poses
are recorded; each landing error e_n = L_act - L_plan (world, horizontal) is split into

* the support sole's error inherited: P_act - P_plan (its own landing error and its slip since);
* the support's turn: [R(psi_act) - R(psi_plan)] r_plan, r_plan the planned landing relative to the
  planned support sole in the support's frame;
* the relative error: R(psi_act) (r_act - r_plan), r_act the actual landing relative to the actual
  support sole in its frame, reported in the support sole's frame (x forward, y left) so that a
  systematic cause (short/long, inwards/outwards) shows as a sign that repeats.

The relative error is split further by the time it builds up: at lift-off (the end of the transfer before
the swing: the trunk and swing sole already off the plan), at touchdown (the last swing row) and after
(the transfer that follows, where the judge reads the landing).

    .venv/bin/python bench/diag_drift.py FOLDER [--runs feedforward:1,pid:0.8,pid:1,pid:1.25] [--follow cmd]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import jethr1_plan.arithmetic  # noqa: F401  (first: NumPy's and OpenBLAS's kernels pinned before they load)

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.oracles import replay as oracle  # noqa: E402


def _rot(psi: float) -> np.ndarray:
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, -s], [s, c]])


def record(folder: Path, controller: str, scale: float, follow: str = "cmd"):
    """Replay ``folder`` and return (result, per physics step: soles' xy (K, 2, 2), yaw (K, 2), trunk xy,
    trunk yaw and tilt components)."""
    import mujoco

    summary, _, _ = oracle._read(folder)
    rdoc = yaml.safe_load(Path(summary["robot_yaml"]).read_text())
    names = [rdoc["legs"][s]["sole"] for s in oracle.SIDES]
    log: list[tuple] = []
    real_step = mujoco.mj_step
    ids: list[int] = []

    def step(m, d):
        real_step(m, d)
        if not ids:
            ids.extend(m.body(n).id for n in names)
            ids.append(m.body(rdoc["trunk"]).id)
        xy = np.array([d.xpos[b][:2] for b in ids])
        yaw = np.array([math.atan2(d.xmat[b][3], d.xmat[b][0]) for b in ids])
        log.append((xy, yaw, d.xmat[ids[2]][[2, 5]].copy()))

    mujoco.mj_step = step
    try:
        res = oracle.replay(folder, controller, scale, follow=follow)
    finally:
        mujoco.mj_step = real_step
    xy = np.array([e[0] for e in log])
    yaw = np.array([e[1] for e in log])
    tilt = np.array([e[2] for e in log])
    return res, xy, yaw, tilt


def plan_poses(folder: Path):
    """The plan's soles and trunk by forward kinematics of each CSV row (the oracle's model, nominal)."""
    import mujoco

    summary, rows, col = oracle._read(folder)
    robot_yaml = Path(summary["robot_yaml"])
    rdoc = yaml.safe_load(robot_yaml.read_text())
    m = oracle._model(rdoc, robot_yaml.parent / rdoc["urdf"], summary["terrain"]["cartons"], 1.0, 0.8)
    d = mujoco.MjData(m)
    names = [m.actuator(i).name for i in range(m.nu)]
    qadr = np.array([m.jnt_qposadr[m.joint(n).id] for n in names])
    ids = [m.body(rdoc["legs"][s]["sole"]).id for s in oracle.SIDES] + [m.body(rdoc["trunk"]).id]
    n = len(rows)
    xy, yaw = np.zeros((n, 3, 2)), np.zeros((n, 3))
    for i, r in enumerate(rows):
        d.qpos[:3] = [float(r[col[f"pelvis_{a}_m"]]) for a in "xyz"]
        d.qpos[3:7] = [float(r[col[f"pelvis_q{a}"]]) for a in "wxyz"]
        d.qpos[qadr] = [float(r[col[f"{nm}_rad"]]) for nm in names]
        mujoco.mj_kinematics(m, d)
        for k, b in enumerate(ids):
            xy[i, k] = d.xpos[b][:2]
            yaw[i, k] = math.atan2(d.xmat[b][3], d.xmat[b][0])
    t = np.array([float(r[col["time_s"]]) for r in rows])
    phase = [r[col["phase"]] for r in rows]
    support = [r[col["support"]] for r in rows]
    step = np.array([int(float(r[col["step"]])) for r in rows])
    return t, phase, support, step, xy, yaw


def swings(phase, support, step):
    """Per swing: (step, support side index, first swing row, last swing row, last row of the transfer
    after it, last row of the transfer before it)."""
    out = []
    n = len(phase)
    for s in sorted({int(x) for x in step}):
        rows = [i for i in range(n) if phase[i] == "swing" and step[i] == s]
        if not rows:
            continue
        a, b = rows[0], rows[-1]
        j = b + 1
        while j + 1 < n and phase[j + 1] == "transfer":
            j += 1
        i0 = a - 1
        out.append((s, oracle.SIDES.index(support[a]), a, b, j, i0))
    return out


def decompose(folder: Path, controller: str, scale: float, follow: str = "cmd") -> list[dict]:
    t, phase, support, step, pxy, pyaw = plan_poses(folder)
    res, axy, ayaw, tilt = record(folder, controller, scale, follow)
    dt = 0.001
    n_settle = round(oracle.SETTLE_S / dt)

    def k_of(row: int) -> int:
        return min(n_settle + round(t[row] / dt) - 1, len(axy) - 1)

    out = []
    for s, p, _, b, j, i0 in swings(phase, support, step):
        w = 1 - p
        rec = {"step": s, "support": oracle.SIDES[p], "fell": res.fell}
        r_plan = _rot(-pyaw[j, p]) @ (pxy[j, w] - pxy[j, p])
        for tag, row in (("lift", i0), ("touch", b), ("land", j)):
            k = k_of(row)
            if k >= len(axy) or k < 0:
                continue
            r_act = _rot(-ayaw[k, p]) @ (axy[k, w] - axy[k, p])
            r_pl = _rot(-pyaw[row, p]) @ (pxy[row, w] - pxy[row, p])
            rec[f"rel_{tag}"] = r_act - r_pl
            rec[f"trunk_yaw_{tag}"] = math.degrees(ayaw[k, 2] - ayaw[k, p] - (pyaw[row, 2] - pyaw[row, p]))
        for tag, row in (("lift", i0), ("touch", b), ("land", j)):
            k = k_of(row)
            rec[f"w_{tag}"] = axy[k, w] - pxy[row, w]
            rec[f"p_{tag}"] = axy[k, p] - pxy[row, p]
            rec[f"pyaw_{tag}"] = math.degrees(ayaw[k, p] - pyaw[row, p])
            rec[f"wyaw_{tag}"] = math.degrees(ayaw[k, w] - pyaw[row, w])
        k = k_of(j)
        rec["err"] = axy[k, w] - pxy[j, w]
        rec["sup_err"] = axy[k, p] - pxy[j, p]
        rec["sup_turn_deg"] = math.degrees(ayaw[k, p] - pyaw[j, p])
        rec["turn_part"] = (_rot(ayaw[k, p]) - _rot(pyaw[j, p])) @ r_plan
        rec["rel_part"] = _rot(ayaw[k, p]) @ rec.get("rel_land", np.zeros(2))
        rec["slip"] = axy[k, p] - axy[k_of(i0), p]
        rec["rel_plan"] = r_plan
        rec["tilt_land"] = tilt[k]
        out.append(rec)
    return out


def show(folder: Path, controller: str, scale: float, follow: str) -> None:
    rows = decompose(folder, controller, scale, follow)
    f = lambda v: f"{1000 * v[0]:+6.1f},{1000 * v[1]:+6.1f}"  # noqa: E731
    print(f"\n{folder.name} {controller} x{scale:g} follow={follow}")
    print(f"{'st':>2} {'sup':>5} {'|err|':>5} {'err xy':>13} {'support err':>13} {'turn part':>13} "
          f"{'rel part':>13} | rel(sup frame) lift / touch / land {'':8} trunk yaw rel sup [deg] lift/touch/land")
    for r in rows:
        print(f"{r['step']:>2} {r['support']:>5} {1000 * np.hypot(*r['err']):5.1f} {f(r['err'])} {f(r['sup_err'])} "
              f"{f(r['turn_part'])} {f(r['rel_part'])} | {f(r.get('rel_lift', (0, 0)))} / "
              f"{f(r.get('rel_touch', (0, 0)))} / {f(r.get('rel_land', (0, 0)))} | "
              f"{r.get('trunk_yaw_lift', 0):+5.2f}/{r.get('trunk_yaw_touch', 0):+5.2f}/"
              f"{r.get('trunk_yaw_land', 0):+5.2f}"
              f"  sup turn {r['sup_turn_deg']:+5.2f}")
    print("world errors [mm] of the swing sole / the support sole at lift-off, touchdown, judge; yaw errors [deg]")
    for r in rows:
        print(f"{r['step']:>2} {r['support']:>5} swing {f(r['w_lift'])} {f(r['w_touch'])} {f(r['w_land'])}  "
              f"support {f(r['p_lift'])} {f(r['p_touch'])} {f(r['p_land'])}  yaw sw {r['wyaw_touch']:+5.2f} "
              f"{r['wyaw_land']:+5.2f} sup {r['pyaw_lift']:+5.2f} {r['pyaw_touch']:+5.2f} {r['pyaw_land']:+5.2f}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("folder")
    ap.add_argument("--runs", default="feedforward:1,pid:0.8,pid:1,pid:1.25")
    ap.add_argument("--follow", default="cmd")
    args = ap.parse_args()
    for spec in args.runs.split(","):
        c, s = spec.split(":")
        show(Path(args.folder), c, float(s), args.follow)
    return 0


if __name__ == "__main__":
    sys.exit(main())
