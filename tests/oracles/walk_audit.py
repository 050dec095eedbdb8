"""An independent audit of a walk folder with pinocchio, reading only what was written: trajectory.csv,
summary.json (its step times, rate, limits and margins) and the robot's files (URDF and YAML).

None of jethr1_plan's code: the URDF loaded by pinocchio itself, each row's configuration built from
the CSV's cells, the velocity and acceleration at row i from pinocchio's own difference on the
configuration space (d± = difference(q_i, q_i±1): v = (d⁺ − d⁻)/2Δt, a = (d⁺ + d⁻)/Δt²), the
ground's wrench from RNEA's floating-base rows, the ZMP and friction ratio from it, joint torques
(the support wrench split by least norm over the soles that bear weight), each leg's κ and knee bend.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

SIDES = ("left", "right")
ROLES = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")


@dataclass
class Audit:
    """Per row (N,) unless stated; rows 0 and N − 1 (their stencil reaches beyond the walk) are NaN."""

    t: np.ndarray
    qdd: np.ndarray  # (N, J) the joints' second central differences [rad/s²]
    zmp: np.ndarray  # (N, 2) [m]
    zmp_margin: np.ndarray  # inside the support's rectangles' hull [m]
    friction_ratio: np.ndarray
    torque_ratio: np.ndarray  # (N, J) |τ| over the URDF's effort
    kappa_leg: np.ndarray  # (N, 2)
    knee_bend: np.ndarray  # (N, 2) [rad]
    mu: float
    acc_limit: float  # [rad/s²]
    knee_margin: float  # [rad]
    joint_names: list[str]

    def inner(self, x: np.ndarray) -> np.ndarray:
        return x[1:-1]

    @property
    def worst(self) -> dict:
        """The worst of each check over the judged rows."""
        return {"zmp_margin_m": float(np.min(self.inner(self.zmp_margin))),
                "friction_ratio": float(np.max(self.inner(self.friction_ratio))),
                "torque_ratio": float(np.max(self.inner(self.torque_ratio))),
                "joint_acceleration_rad_s2": float(np.max(np.abs(self.inner(self.qdd)))),
                "knee_bend_rad": float(np.min(self.knee_bend))}

    @property
    def clean(self) -> bool:
        """ZMP inside the support, friction under μ, torques within effort, accelerations within the
        limit and knees bent at least the margin, on every judged row."""
        w = self.worst
        return (w["zmp_margin_m"] >= 0 and w["friction_ratio"] <= self.mu and w["torque_ratio"] <= 1
                and w["joint_acceleration_rad_s2"] <= self.acc_limit + 1e-3 and w["knee_bend_rad"] >= self.knee_margin)


def _hull_margin(p: np.ndarray, pts: np.ndarray) -> float:
    from scipy.spatial import ConvexHull

    h = pts[ConvexHull(pts).vertices]
    e = np.roll(h, -1, axis=0) - h
    n = np.column_stack([e[:, 1], -e[:, 0]]) / np.linalg.norm(e, axis=1)[:, None]
    return float(np.min(np.einsum("kd,kd->k", n, h) - n @ p))


def read_folder(folder: Path) -> tuple[dict, list[list[str]], dict[str, int]]:
    """(summary.json, the CSV's rows as text, each column's index) of a written folder."""
    folder = Path(folder)
    summary = json.loads((folder / "summary.json").read_text())
    with open(folder / "trajectory.csv", newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = list(reader)
    return summary, rows, {h: k for k, h in enumerate(header)}


def audit_walk(folder: Path) -> Audit:
    """Audit the walk written in ``folder``."""
    summary, rows, col = read_folder(folder)
    model, _ = _model(Path(summary["robot_yaml"]))
    names = [str(x) for x in model.names[2:]]
    t = np.array([float(r[col["time_s"]]) for r in rows])
    pos = np.array([[float(r[col[f"pelvis_{a}_m"]]) for a in "xyz"] for r in rows])
    quat = np.array([[float(r[col[f"pelvis_q{a}"]]) for a in "xyzw"] for r in rows])
    joints = {name: np.array([float(r[col[f"{name}_rad"]]) for r in rows]) for name in names}
    spec = summary["spec"]
    return audit_rows(Path(summary["robot_yaml"]), t, [r[col["support"]] for r in rows], pos, quat, joints,
                      1.0 / float(spec["timing"]["control_hz"]), float(spec["ik"]["max_joint_acceleration_rad_s2"]),
                      float(spec["success"]["knee_margin_rad"]))


_MODELS: dict = {}


def _model(robot_yaml: Path):
    import pinocchio as pin

    if robot_yaml not in _MODELS:
        rdoc = yaml.safe_load(robot_yaml.read_text())
        _MODELS[robot_yaml] = (pin.buildModelFromUrdf(str(robot_yaml.parent / rdoc["urdf"]),
                                                      pin.JointModelFreeFlyer()), rdoc)
    return _MODELS[robot_yaml]


def audit_rows(robot_yaml: Path, t: np.ndarray, support: list[str], pelvis_m: np.ndarray, pelvis_quat: np.ndarray,
               joints: dict[str, np.ndarray], dt: float, acc_limit: float, knee_margin: float) -> Audit:
    """Audit rows given as arrays: times, supports, the trunk's positions (N, 3) and quaternions (N, 4;
    x, y, z, w), each joint's angles by name; the control period [s], the joints' acceleration limit
    [rad/s²] and the knee margin [rad]."""
    import pinocchio as pin

    model, rdoc = _model(Path(robot_yaml))
    data = model.createData()
    n = len(t)
    names = [str(x) for x in model.names[2:]]
    Q = np.zeros((n, model.nq))
    Q[:, :3] = pelvis_m
    Q[:, 3:7] = pelvis_quat / np.linalg.norm(pelvis_quat, axis=1)[:, None]
    for name in names:
        Q[:, model.joints[model.getJointId(name)].idx_q] = joints[name]
    sole_length, sole_width = float(rdoc["sole"]["length_m"]), float(rdoc["sole"]["width_m"])
    mu = float(rdoc.get("twin", {}).get("sole_friction", 0.8))
    sole = {s: model.getFrameId(rdoc["legs"][s]["sole"]) for s in SIDES}
    leg_v = {s: [model.joints[model.getJointId(rdoc["legs"][s]["joints"][r])].idx_v for r in ROLES] for s in SIDES}
    leg_frames = {s: [model.getFrameId(rdoc["legs"][s]["joints"][r]) for r in ("hip_pitch", "knee", "ankle_pitch")]
                  for s in SIDES}
    effort = np.array(model.effortLimit[6:], dtype=float)
    nan = np.full(n, np.nan)
    zmp, margin, friction = np.full((n, 2), np.nan), nan.copy(), nan.copy()
    torque = np.full((n, model.nv - 6), np.nan)
    qdd = np.full((n, model.nv - 6), np.nan)
    kappa_leg, bend = np.zeros((n, 2)), np.zeros((n, 2))
    for i in range(n):
        pin.forwardKinematics(model, data, Q[i])
        pin.computeJointJacobians(model, data, Q[i])
        pin.updateFramePlacements(model, data)
        for k, s in enumerate(SIDES):
            J = pin.getFrameJacobian(model, data, sole[s], pin.LOCAL)[:, leg_v[s]]
            sv = np.linalg.svd(J, compute_uv=False)
            kappa_leg[i, k] = sv[0] / sv[-1]
            hip, knee, ankle = (data.oMf[f].translation for f in leg_frames[s])
            a, b = knee - hip, ankle - knee
            bend[i, k] = np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b)
        if i == 0 or i == n - 1:
            continue
        d_plus = pin.difference(model, Q[i], Q[i + 1])
        d_minus = pin.difference(model, Q[i], Q[i - 1])
        v, acc = (d_plus - d_minus) / (2 * dt), (d_plus + d_minus) / dt**2
        qdd[i] = acc[6:]
        gen = pin.rnea(model, data, Q[i], v, acc).copy()
        pin.computeJointJacobians(model, data, Q[i])
        pin.updateFramePlacements(model, data)
        base = data.oMi[1]
        force = base.rotation @ gen[:3]
        moment = base.rotation @ gen[3:6] + np.cross(base.translation, force)
        zmp[i] = (-moment[1] / force[2], moment[0] / force[2])
        friction[i] = np.hypot(force[0], force[1]) / force[2]
        down = SIDES if support[i] == "both" else (support[i],)
        corners = []
        for s in down:
            M = data.oMf[sole[s]]
            for cx, cy in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
                corners.append((M.rotation @ np.array([cx * sole_length / 2, cy * sole_width / 2, 0.0])
                                + M.translation)[:2])
        margin[i] = _hull_margin(zmp[i], np.array(corners))
        Jc = np.vstack([pin.getFrameJacobian(model, data, sole[s], pin.LOCAL) for s in down])
        split = np.linalg.lstsq(Jc[:, :6].T, gen[:6], rcond=None)[0]
        torque[i] = gen[6:] - Jc[:, 6:].T @ split
    return Audit(t, qdd, zmp, margin, friction, np.abs(torque) / effort, kappa_leg, bend, mu, acc_limit, knee_margin,
                 names)
