"""An independent replay of a written plan in MuJoCo, reading only what was written: ``trajectory.csv``
(the servo and fan commands, the planned postures and phases), ``summary.json`` (the robot YAML's path
and the cartons) and the robot's files (URDF and YAML).

None of jethr1_plan's code, and not the twin's model: its own MuJoCo model built here from the URDF,
its own contact (soft cartons, the sole boxes), its own servos (a PD position loop whose torque is
limited by the robot YAML's servo table, stall torque × servos × gear ratio, with the servo's
stiffness scaled by ``stiffness_scale``: what the plan's sag compensation does not know), its own
fans (a first-order lag), and no re-planning: the CSV is executed whole, row after row.

Two ways to run the fans:

* ``feedforward``: each fan follows its ``thrust_cmd_<fan>_n`` column;
* ``pid``: a trunk-tilt PID, Paper A's law on a pelvis IMU: in single support the swing fan's command
  is its column plus k_p·e + k_i·∫e + k_d·ė, with e [rad] the trunk's tilt (its z axis against the
  planned one, from the CSV's pelvis quaternion) along the horizontal direction from the planned
  support sole to the planned fan (more thrust where the trunk leans towards the fan).

Verdicts: a fall (the trunk tilted more than 10°, or the pelvis 0.1 m below the plan), each landing's
error (the swing sole's horizontal distance from its planned position, at the last row of the transfer
after its swing), each swing's support slip and turn, and both soles on carton tops at the end.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

SIDES = ("left", "right")
ROLES = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
SETTLE_S, HOLD_S = 0.5, 1.0
FALL_TILT_DEG, FALL_DROP_M = 10.0, 0.10
ON_TOP_M = 0.005


@dataclass(frozen=True)
class PidGains:
    """The trunk-tilt PID (Paper A: the thrust by a PID on the pelvis IMU)."""

    kp_n_per_rad: float = 300.0
    ki_n_per_rad_s: float = 300.0
    kd_n_s_per_rad: float = 15.0


@dataclass
class ReplayResult:
    fell: dict | None
    landings_m: list[dict] = field(default_factory=list)  # step, sole, xy error [m], error vector
    swings: list[dict] = field(default_factory=list)  # step, support slip [m] and turn [rad] over the swing
    on_cartons: dict[str, bool] = field(default_factory=dict)
    max_tilt_deg: float = 0.0

    @property
    def survived(self) -> bool:
        return self.fell is None and all(self.on_cartons.values())

    @property
    def worst_landing_m(self) -> float:
        return max((e["xy_m"] for e in self.landings_m), default=0.0)


def _read(folder: Path):
    summary = json.loads((folder / "summary.json").read_text())
    with open(folder / "trajectory.csv", newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = list(reader)
    col = {h: k for k, h in enumerate(header)}
    return summary, rows, col


def _servo_table(rdoc: dict) -> dict[str, tuple[float, float]]:
    """Per joint name: (stiffness [N·m/rad], torque limit [N·m]) from the robot YAML's servo table."""
    servos = rdoc["servos"]
    k0, stall = float(servos.get("stiffness_nm_per_rad", 78.0)), float(servos["stall_torque_nm"])
    out = {}
    for side in SIDES:
        for role in ROLES:
            j = servos["joints"][role]
            n, g = int(j["servos"]), float(j["gear_ratio"])
            out[rdoc["legs"][side]["joints"][role]] = (k0 * n * g * g, stall * n * g)
    return out


def _model(rdoc: dict, urdf: Path, cartons: list[dict], stiffness_scale: float, friction: float):
    import mujoco

    text = urdf.read_text()
    end = text.index(">", text.index("<robot")) + 1
    text = text[:end] + '<mujoco><compiler fusestatic="false" discardvisual="true"/></mujoco>' + text[end:]
    spec = mujoco.MjSpec.from_string(text)
    spec.option.timestep = 0.001
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL
    spec.bodies[1].add_freejoint()
    for g in spec.geoms:
        g.contype = g.conaffinity = 0
    length, width = float(rdoc["sole"]["length_m"]), float(rdoc["sole"]["width_m"])
    for side in SIDES:
        g = spec.body(rdoc["legs"][side]["sole"]).add_geom()
        g.name = f"sole_{side}"
        g.type = mujoco.mjtGeom.mjGEOM_BOX
        g.size = [length / 2, width / 2, 0.004]
        g.pos = [0.0, 0.0, 0.004]
        g.contype, g.conaffinity = 1, 0
        g.friction = [friction, 0.0, 0.0]
        g.condim = 3
        g.density = 0.0
        g.solref = [0.008, 1.0]  # cardboard under rubber: a little softer than MuJoCo's default
    low = 0.0
    for k, c in enumerate(cartons):
        (x, y, top), (sx, sy, sz) = c["top_centre_m"], c["size_m"]
        b = spec.worldbody.add_geom()
        b.name = f"box{k}"
        b.type = mujoco.mjtGeom.mjGEOM_BOX
        b.size = [sx / 2, sy / 2, sz / 2]
        b.pos = [x, y, top - sz / 2]
        b.contype, b.conaffinity = 0, 1
        b.friction = [friction, 0.0, 0.0]
        low = min(low, top - sz)
    fl = spec.worldbody.add_geom()
    fl.type = mujoco.mjtGeom.mjGEOM_PLANE
    fl.size = [20.0, 20.0, 0.1]
    fl.pos = [0.0, 0.0, low]
    fl.contype, fl.conaffinity = 0, 1
    table = _servo_table(rdoc)
    derivative = float(rdoc["servos"].get("derivative_time_s", 0.03))
    armature = float(rdoc["servos"].get("armature_kgm2", 0.003))
    for name, (k, limit) in table.items():
        spec.joint(name).armature = armature
        a = spec.add_actuator()
        a.name = name
        a.target = name
        a.trntype = mujoco.mjtTrn.mjTRN_JOINT
        a.set_to_position(kp=k * stiffness_scale, kv=k * stiffness_scale * derivative)
        a.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        a.forcerange = [-limit, limit]
    return spec.compile()


def replay(folder: Path, controller: str = "feedforward", stiffness_scale: float = 1.0, follow: str = "cmd",
           gains: PidGains | None = None, fan_lag_s: float = 0.05, friction: float = 0.8) -> ReplayResult:
    """Execute the plan in ``folder`` whole (see the module docstring). ``follow``: the servos get the
    ``<joint>_cmd_rad`` columns (``cmd``) or the posture columns ``<joint>_rad`` (``raw``)."""
    import mujoco

    folder = Path(folder)
    summary, rows, col = _read(folder)
    robot_yaml = Path(summary["robot_yaml"])
    rdoc = yaml.safe_load(robot_yaml.read_text())
    cartons = summary["terrain"]["cartons"]
    m = _model(rdoc, robot_yaml.parent / rdoc["urdf"], cartons, stiffness_scale, friction)
    d = mujoco.MjData(m)
    names = [m.actuator(i).name for i in range(m.nu)]
    qadr = np.array([m.jnt_qposadr[m.joint(n).id] for n in names])
    n_rows = len(rows)

    def column(name: str) -> np.ndarray:
        return np.array([float(r[col[name]]) for r in rows])

    t_rows = column("time_s")
    rate = 1.0 / float(t_rows[1] - t_rows[0])
    phase = [r[col["phase"]] for r in rows]
    support = [r[col["support"]] for r in rows]
    step = column("step").astype(int)
    pelvis = np.column_stack([column(f"pelvis_{a}_m") for a in "xyz"])
    quat_wxyz = np.column_stack([column(f"pelvis_q{a}") for a in "wxyz"])
    q_plan = np.column_stack([column(f"{n}_rad") for n in names])
    q_cmd = np.column_stack([column(f"{n}_{'cmd_rad' if follow == 'cmd' else 'rad'}") for n in names])
    fans = [(f["name"], f["frame"], f.get("mount", f.get("foot")), float(f["thrust_max_n"])) for f in rdoc["fans"]]
    f_cmd = np.column_stack([column(f"thrust_{'cmd_' if follow == 'cmd' else ''}{name}_n") for name, *_ in fans])
    fan_body = [m.body(frame).id for _, frame, _, _ in fans]
    fan_side = [next((s for s in SIDES if rdoc["legs"][s]["sole"] == mount), None) for _, _, mount, _ in fans]
    caps = np.array([cap for *_, cap in fans])
    sole_body = {s: m.body(rdoc["legs"][s]["sole"]).id for s in SIDES}
    trunk = m.body(rdoc["trunk"]).id
    length, width = float(rdoc["sole"]["length_m"]), float(rdoc["sole"]["width_m"])

    # the plan's soles, fans and trunk axes by forward kinematics of each row (this model, nominal posture)
    plan_sole = np.zeros((n_rows, 2, 3))
    plan_yaw = np.zeros((n_rows, 2))
    plan_fan = np.zeros((n_rows, len(fans), 3))
    plan_z = np.zeros((n_rows, 3))
    for i in range(n_rows):
        d.qpos[:3], d.qpos[3:7] = pelvis[i], quat_wxyz[i]
        d.qpos[qadr] = q_plan[i]
        mujoco.mj_kinematics(m, d)
        for k, s in enumerate(SIDES):
            plan_sole[i, k] = d.xpos[sole_body[s]]
            plan_yaw[i, k] = math.atan2(d.xmat[sole_body[s]][3], d.xmat[sole_body[s]][0])
        for k, b in enumerate(fan_body):
            plan_fan[i, k] = d.xpos[b]
        plan_z[i] = d.xmat[trunk].reshape(3, 3)[:, 2]

    d.qpos[:] = 0.0
    d.qpos[:3], d.qpos[3:7] = pelvis[0], quat_wxyz[0]
    d.qpos[qadr] = q_plan[0]
    mujoco.mj_forward(m, d)
    # stand the robot on its soles: lift or drop it so that the lower sole touches its carton
    gains = gains or PidGains()
    dt = m.opt.timestep
    n_settle, n_hold = round(SETTLE_S / dt), round(HOLD_S / dt)
    n_plan = round(float(t_rows[-1]) / dt) + 1
    applied = np.zeros(len(fans))
    integral, last_e = 0.0, None
    res = ReplayResult(fell=None)
    judge = []
    for i in range(n_rows):
        if phase[i] == "transfer" and (i + 1 == n_rows or phase[i + 1] != "transfer") and step[i] >= 1:
            swing_rows = [r for r in range(i) if phase[r] == "swing" and step[r] == step[i] - 1]
            if swing_rows:
                judge.append((i, int(step[i]) - 1, "left" if support[swing_rows[0]] == "right" else "right"))
    swing_start: dict | None = None
    ctrl_every = 1  # the servos' and the fans' loop at 1 kHz
    cmd_now = np.zeros(len(fans))
    for k in range(n_settle + n_plan + n_hold):
        t = (k - n_settle) * dt
        x = min(max(t * rate, 0.0), n_rows - 1.0)
        i = min(int(x), n_rows - 2)
        a = x - i
        if k % ctrl_every == 0:
            d.ctrl[:] = (1 - a) * q_cmd[i] + a * q_cmd[i + 1]
            ff = (1 - a) * f_cmd[i] + a * f_cmd[i + 1] if k >= n_settle else np.zeros(len(fans))
            cmd_now = ff.copy()
            sup = support[i]
            if controller == "pid" and k >= n_settle and sup in SIDES:
                swing = "left" if sup == "right" else "right"
                carry = [f for f in range(len(fans)) if fan_side[f] == swing]
                if carry:
                    fan_xy = plan_fan[i, carry[0], :2]
                    u = fan_xy - plan_sole[i, SIDES.index(sup), :2]
                    u = u / max(np.linalg.norm(u), 1e-9)
                    z_meas = d.xmat[trunk].reshape(3, 3)[:, 2]
                    e = float((z_meas[:2] - plan_z[i, :2]) @ u)
                    de = 0.0 if last_e is None else (e - last_e) / (ctrl_every * dt)
                    last_e = e
                    integral += e * ctrl_every * dt
                    for f in carry:
                        cmd_now[f] = float(np.clip(ff[f] + gains.kp_n_per_rad * e + gains.ki_n_per_rad_s * integral
                                                   + gains.kd_n_s_per_rad * de, 0.0, caps[f]))
            else:
                integral, last_e = 0.0, None
        applied += (cmd_now - applied) * (dt / fan_lag_s)
        d.xfrc_applied[:] = 0.0
        for f, b in enumerate(fan_body):
            force = np.array([0.0, 0.0, applied[f]])
            d.xfrc_applied[b, :3] = force
            d.xfrc_applied[b, 3:] = np.cross(d.xpos[b] - d.xipos[b], force)
        mujoco.mj_step(m, d)
        R = d.xmat[trunk]
        tilt = math.degrees(math.acos(min(1.0, max(-1.0, float(R[8])))))
        res.max_tilt_deg = max(res.max_tilt_deg, tilt)
        z_plan = (1 - a) * pelvis[i, 2] + a * pelvis[i + 1, 2]
        if tilt > FALL_TILT_DEG or d.qpos[2] < z_plan - FALL_DROP_M:
            res.fell = {"row": i, "phase": phase[i], "step": int(step[i]), "tilt_deg": tilt}
            break
        if k >= n_settle:
            sup = support[i]
            if phase[i] == "swing" and swing_start is None:
                b = sole_body[sup]
                swing_start = {"support": sup, "step": int(step[i]), "xy": d.xpos[b][:2].copy(),
                               "yaw": math.atan2(d.xmat[b][3], d.xmat[b][0])}
            if phase[i] != "swing" and swing_start is not None:
                b = sole_body[swing_start["support"]]
                slip = d.xpos[b][:2] - swing_start["xy"]
                turn = math.atan2(d.xmat[b][3], d.xmat[b][0]) - swing_start["yaw"]
                res.swings.append({"step": swing_start["step"], "support": swing_start["support"],
                                   "slip_m": float(np.hypot(*slip)), "turn_rad": float(turn)})
                swing_start = None
            while judge and t >= t_rows[judge[0][0]] - 1e-9:
                row, st, sole = judge.pop(0)
                err = d.xpos[sole_body[sole]][:2] - plan_sole[row, SIDES.index(sole), :2]
                res.landings_m.append({"step": st, "sole": sole, "xy_m": float(np.hypot(*err)),
                                       "error_m": [float(err[0]), float(err[1])]})
    if res.fell is None:
        for s in SIDES:
            b = sole_body[s]
            res.on_cartons[s] = _on_carton(d.xpos[b], d.xmat[b], cartons, length, width)
    return res


def _on_carton(xyz: np.ndarray, xmat: np.ndarray, cartons: list[dict], length: float, width: float) -> bool:
    """The whole sole (its rectangle at its yaw) within a carton's top, ``ON_TOP_M`` of tolerance, and level."""
    if xmat[8] < math.cos(math.radians(5.0)):
        return False
    yaw = math.atan2(xmat[3], xmat[0])
    c, s = math.cos(yaw), math.sin(yaw)
    corners = [(xyz[0] + c * dx - s * dy, xyz[1] + s * dx + c * dy)
               for dx in (-length / 2, length / 2) for dy in (-width / 2, width / 2)]
    for box in cartons:
        (x, y, top), (sx, sy, _) = box["top_centre_m"], box["size_m"]
        if abs(xyz[2] - top) > ON_TOP_M:
            continue
        if all(abs(px - x) <= sx / 2 + ON_TOP_M and abs(py - y) <= sy / 2 + ON_TOP_M for px, py in corners):
            return True
    return False
