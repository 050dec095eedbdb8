"""An independent replay of a plan: its own MuJoCo model of the URDF, its own servos, reading only
``trajectory.csv``'s command columns (and the scenario's cartons and landings to judge the run).

Nothing of ``jethr1_plan`` is imported: the robot comes from its URDF and YAML (pyyaml), the plan from the
CSV (the ``csv`` module). What differs from the project's twin on purpose:

* servos are torques computed here, τ = k·(q_cmd − q) − d·q̇ within the URDF's effort (``motor``
  actuators, 0.5 ms steps; the damping d·q̇ as the joint's own damping, which Euler integrates implicitly),
  k and d the YAML's servo table × a stiffness scale (×0.8, ×1, ×1.25: what a real robot does not know to
  better than ±25 %);
* contact: the soles are boxes of the YAML's size with a pyramidal friction cone and MuJoCo's default
  contact softness; Euler integration;
* fans: a first-order lag of the YAML's ``lag_s`` on the CSV's ``thrust_cmd_*`` columns;
* optional **trunk-tilt PID** (Paper A's robot: the thrust from the IMU): in single support, the trunk's
  tilt towards the swing fan e = ẑ_trunk · u (u the horizontal unit vector from the support sole to the
  fan) adds k_p·e + k_i·∫e + k_d·ė to the fan's command, within [0, F_max].

The run **falls** when the trunk tilts more than 10° or the pelvis drops 0.1 m below the CSV's; it
**passes** when it does not fall, every landing (the swing sole at the end of the transfer after its
swing) lies within 10 mm of the scenario's landing in the ground plane, and both soles end on carton tops.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

FALL_TILT_DEG = 10.0
FALL_DROP_M = 0.10
LANDING_TOL_M = 0.010
ON_TOP_TOL_M = 0.005
STEP_S = 0.0005
SETTLE_S = 0.5
HOLD_S = 1.0
CARTON = (0.21, 0.11, 0.14)


@dataclass
class Replay:
    fell: str | None
    landings_m: list[float]
    on_cartons: bool
    max_tilt_deg: float

    @property
    def passed(self) -> bool:
        return self.fell is None and self.on_cartons and all(e <= LANDING_TOL_M for e in self.landings_m)


def read_csv(path: Path) -> dict[str, np.ndarray]:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    head, body = rows[0], rows[1:]
    out = {}
    for k, name in enumerate(head):
        col = [r[k] for r in body]
        try:
            out[name] = np.array([float(v) if v != "" else np.nan for v in col])
        except ValueError:
            out[name] = np.array(col, dtype=object)
    return out


def _robot(yaml_path: Path) -> dict:
    doc = yaml.safe_load(yaml_path.read_text())
    doc["urdf_path"] = yaml_path.parent / doc["urdf"]
    return doc


def _model(robot: dict, scenario: dict, stiffness_scale: float):
    import mujoco

    text = robot["urdf_path"].read_text()
    i = text.index(">", text.index("<robot")) + 1
    text = text[:i] + '<mujoco><compiler fusestatic="false" discardvisual="true"/></mujoco>' + text[i:]
    spec = mujoco.MjSpec.from_string(text)
    spec.option.timestep = STEP_S
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    spec.bodies[1].add_freejoint()
    for g in spec.geoms:
        g.contype = g.conaffinity = 0
    mu = float((robot.get("twin") or {}).get("sole_friction", 0.8))
    for side in ("left", "right"):
        g = spec.body(robot["legs"][side]["sole"]).add_geom()
        g.name = f"{side}_sole"
        g.type = mujoco.mjtGeom.mjGEOM_BOX
        g.size = [robot["sole"]["length_m"] / 2, robot["sole"]["width_m"] / 2, 0.005]
        g.pos = [0, 0, 0.005]
        g.contype, g.conaffinity, g.density = 1, 0, 0.0
        g.friction = [mu, 0.005, 0.0001]
    size = (scenario.get("terrain") or {}).get("carton_size_m", CARTON)
    boxes = [(c["top_centre_m"], c.get("size_m", size)) for c in (scenario.get("terrain") or {}).get("cartons", [])]
    for top, sz in boxes:
        g = spec.worldbody.add_geom()
        g.type = mujoco.mjtGeom.mjGEOM_BOX
        g.size = [sz[0] / 2, sz[1] / 2, sz[2] / 2]
        g.pos = [top[0], top[1], top[2] - sz[2] / 2]
        g.contype, g.conaffinity = 0, 1
        g.friction = [mu, 0.005, 0.0001]
    floor = spec.worldbody.add_geom()
    floor.type = mujoco.mjtGeom.mjGEOM_PLANE
    floor.size = [10, 10, 0.1]
    floor.pos = [0, 0, min((t[2] - s[2] for t, s in boxes), default=0.0)]
    floor.contype, floor.conaffinity = 0, 1
    servo = robot["servos"]
    role = {name: r for leg in robot["legs"].values() for r, name in leg["joints"].items()}
    joints = [j.name for j in spec.joints if j.type != mujoco.mjtJoint.mjJNT_FREE]
    kp, kd = [], []
    for name in joints:
        t = servo["joints"][role[name]]
        k = servo["stiffness_nm_per_rad"] * t["servos"] * t["gear_ratio"] ** 2 * stiffness_scale
        kp.append(k)
        kd.append(k * servo["derivative_time_s"])
        spec.joint(name).armature = servo.get("armature_kgm2", 0.0)
        spec.joint(name).damping = [k * servo["derivative_time_s"], 0.0, 0.0]  # Euler: joint damping implicit
        a = spec.add_actuator()
        a.name, a.target, a.trntype = name, name, mujoco.mjtTrn.mjTRN_JOINT
    return spec.compile(), joints, np.array(kp), np.array(kd)


def _urdf_efforts(urdf: Path) -> dict[str, float]:
    import xml.etree.ElementTree as ET

    out = {}
    for j in ET.parse(urdf).getroot().iter("joint"):
        lim = j.find("limit")
        if lim is not None and lim.get("effort"):
            out[j.get("name")] = float(lim.get("effort"))
    return out


def replay(folder: Path, scenario_path: Path, robot_yaml: Path, stiffness_scale: float = 1.0, pid: bool = False,
           gains: tuple[float, float, float] = (300.0, 600.0, 12.0)) -> Replay:
    """Replay ``folder``/trajectory.csv; ``gains`` (k_p [N/rad], k_i [N/(rad·s)], k_d [N·s/rad]) of the PID."""
    import mujoco

    robot, scenario = _robot(robot_yaml), yaml.safe_load(scenario_path.read_text())
    model, joints, kp, kd = _model(robot, scenario, stiffness_scale)
    efforts = _urdf_efforts(robot["urdf_path"])
    tau_max = np.array([efforts[n] for n in joints])
    c = read_csv(folder / "trajectory.csv")
    t_rows = c["time_s"]
    q_cmd = np.column_stack([c[f"{n}_cmd_rad"] for n in joints])
    q0 = np.column_stack([c[f"{n}_rad"] for n in joints])[0]
    fans = robot["fans"]
    f_cmd = np.column_stack([c[f"thrust_cmd_{f['name']}_n"] for f in fans])
    fmax = np.array([min(f["thrust_max_n"], float((scenario.get("balance") or {}).get("thrust_max_n", 1e9)))
                     for f in fans])
    lag = np.array([f.get("lag_s", 0.05) for f in fans])
    fan_body = [model.body(f["frame"]).id for f in fans]
    mount_side = {robot["legs"][s]["sole"]: s for s in ("left", "right")}
    fan_side = [mount_side.get(f.get("mount", f.get("foot"))) for f in fans]
    sole_body = {s: model.body(robot["legs"][s]["sole"]).id for s in ("left", "right")}
    trunk = 1
    support, phase, step = c["support"], c["phase"], c["step"]
    pelvis_z = c["pelvis_z_m"]
    d = mujoco.MjData(model)
    d.qpos[:3] = [c["pelvis_x_m"][0], c["pelvis_y_m"][0], c["pelvis_z_m"][0]]
    d.qpos[3:7] = [c["pelvis_qw"][0], c["pelvis_qx"][0], c["pelvis_qy"][0], c["pelvis_qz"][0]]
    qadr = np.array([model.jnt_qposadr[model.joint(n).id] for n in joints])
    vadr = np.array([model.jnt_dofadr[model.joint(n).id] for n in joints])
    d.qpos[qadr] = q0
    mujoco.mj_forward(model, d)
    landings_at = []  # (row, side, landing xy)
    for k, st in enumerate(scenario["steps"]):
        rows = np.flatnonzero((phase == "transfer") & (step == k + 1))
        landing = st.get("landing_m") or st["path"]["points_m"][-1]
        if len(rows):
            landings_at.append((int(rows[-1]), st["swing"], np.array(landing[:2], dtype=float)))
    thrust = np.zeros(len(fans))
    integral, prev_e = 0.0, 0.0
    max_tilt, fell, landings = 0.0, None, []
    n_settle, n_hold = round(SETTLE_S / STEP_S), round(HOLD_S / STEP_S)
    n_plan = round(float(t_rows[-1]) / STEP_S) + 1
    for k in range(n_settle + n_plan + n_hold):
        t = (k - n_settle) * STEP_S
        x = min(max(t, 0.0), float(t_rows[-1]))
        i = min(int(np.searchsorted(t_rows, x, side="right") - 1), len(t_rows) - 2)
        a = (x - t_rows[i]) / (t_rows[i + 1] - t_rows[i])
        target = (1 - a) * q_cmd[i] + a * q_cmd[i + 1] if k >= n_settle else q_cmd[0]
        cmd = (1 - a) * f_cmd[i] + a * f_cmd[i + 1] if k >= n_settle else np.zeros(len(fans))
        R = d.xmat[trunk].reshape(3, 3)
        sup = str(support[i])
        if pid and k >= n_settle and sup in ("left", "right"):
            swing_fans = [j for j, s in enumerate(fan_side) if s not in (sup, None)]
            if swing_fans:
                j = swing_fans[0]
                u = d.xpos[fan_body[j]][:2] - d.xpos[sole_body[sup]][:2]
                u = u / max(np.linalg.norm(u), 1e-9)
                e = float(R[0, 2] * u[0] + R[1, 2] * u[1])  # the trunk's up axis leaning towards the fan
                integral += e * STEP_S
                de = (e - prev_e) / STEP_S
                prev_e = e
                cmd = cmd.copy()
                cmd[j] = cmd[j] + gains[0] * e + gains[1] * integral + gains[2] * de
        else:
            integral *= math.exp(-STEP_S / 0.3)
            prev_e = 0.0
        cmd = np.clip(cmd, 0.0, fmax)
        thrust += (cmd - thrust) * (STEP_S / lag)
        q, qd = d.qpos[qadr], d.qvel[vadr]
        d.ctrl[:] = np.clip(kp * (target - q), -tau_max - kd * np.abs(qd), tau_max + kd * np.abs(qd))
        d.xfrc_applied[:] = 0.0
        for j, b in enumerate(fan_body):
            r = d.xpos[b] - d.xipos[b]
            d.xfrc_applied[b, 2] = thrust[j]
            d.xfrc_applied[b, 3:] = np.cross(r, [0.0, 0.0, thrust[j]])
        mujoco.mj_step(model, d)
        tilt = math.degrees(math.acos(min(1.0, max(-1.0, d.xmat[trunk][8]))))
        max_tilt = max(max_tilt, tilt)
        z_plan = (1 - a) * pelvis_z[i] + a * pelvis_z[i + 1]
        if tilt > FALL_TILT_DEG or d.qpos[2] < z_plan - FALL_DROP_M:
            fell = f"row {i} (t = {t:.2f} s): tilt {tilt:.1f} deg, pelvis {z_plan - d.qpos[2]:.3f} m low"
            break
        while landings_at and k >= n_settle and t >= t_rows[landings_at[0][0]]:
            _, side, xy = landings_at.pop(0)
            landings.append(float(np.linalg.norm(d.xpos[sole_body[side]][:2] - xy)))
    size = (scenario.get("terrain") or {}).get("carton_size_m", CARTON)
    boxes = [(c_["top_centre_m"], c_.get("size_m", size)) for c_ in (scenario.get("terrain") or {}).get("cartons", [])]
    on = True
    for s in ("left", "right"):
        p, m = d.xpos[sole_body[s]], d.xmat[sole_body[s]]
        yaw = math.atan2(m[3], m[0])
        L, W = robot["sole"]["length_m"], robot["sole"]["width_m"]
        corners = [p[:2] + np.array([math.cos(yaw) * dx - math.sin(yaw) * dy, math.sin(yaw) * dx + math.cos(yaw) * dy])
                   for dx in (-L / 2, L / 2) for dy in (-W / 2, W / 2)]
        on &= any(abs(p[2] - top[2]) < ON_TOP_TOL_M and all(abs(cc[0] - top[0]) <= sz[0] / 2 + ON_TOP_TOL_M and
                                                            abs(cc[1] - top[1]) <= sz[1] / 2 + ON_TOP_TOL_M
                                                            for cc in corners) for top, sz in boxes)
    return Replay(fell, landings, bool(on) and fell is None, max_tilt)


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path)
    ap.add_argument("scenario", type=Path)
    ap.add_argument("--robot", type=Path, default=Path(__file__).resolve().parents[2] / "robots/jethr1/jethr1.yaml")
    args = ap.parse_args()
    for pid in (False, True):
        for k in (0.8, 1.0, 1.25):
            r = replay(args.folder, args.scenario, args.robot, k, pid)
            print(f"{'PID' if pid else 'feed-forward'} stiffness x{k}: {'pass' if r.passed else 'FAIL'}; "
                  f"fell {r.fell}; landings {[round(1000 * e, 1) for e in r.landings_m]} mm; "
                  f"on cartons {r.on_cartons}; "
                  f"max tilt {r.max_tilt_deg:.2f} deg", flush=True)
