"""Closed-form leg IK and batched forward kinematics in numpy, geometry read from the URDF.

A fast path beside PlaCo (``posture.py``) for exhaustive sweeps: for a leg whose hip axes (yaw,
roll, pitch) meet at the hip joint centre and whose ankle axes (pitch, roll) meet at the ankle
centre, with the knee and ankle on the leg's axis, the six joint angles follow in closed form
(Kajita et al., *Introduction to Humanoid Robotics*, §2.5). Joint placements, axes, link masses and
centres of mass all come from the URDF file; :func:`check_structure` refuses a robot whose URDF does
not have this structure. Agreement with PlaCo to 1e-9 m is tested on thousands of random
candidates (``tests/test_leg_kinematics.py``).

All functions take a leading batch dimension N.
"""

from __future__ import annotations

import functools
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from .errors import RobotModelError
from .posture import JOINT_LIMIT, OK, UNREACHABLE
from .robot_model import SIDES, RobotModel, urdf_joints

AXES = {"hip_yaw": (0, 0, 1), "hip_roll": (1, 0, 0), "hip_pitch": (0, 1, 0), "knee": (0, 1, 0),
        "ankle_pitch": (0, 1, 0), "ankle_roll": (1, 0, 0)}

# Rotations are stored batch-last, (3, 3, N): numpy's einsum over that layout is several times
# faster than matmul over (N, 3, 3) stacks of small matrices.


def rot_axis(axis, a: np.ndarray) -> np.ndarray:
    """(3, 3, N) rotations about ``axis`` by angles ``a`` (N,) [rad] (direct for x, y, z; else Rodrigues)."""
    k = np.asarray(axis, dtype=float)
    k = k / np.linalg.norm(k)
    a = np.atleast_1d(np.asarray(a, dtype=float))
    c, s = np.cos(a), np.sin(a)
    principal = np.flatnonzero(np.abs(k) == 1.0)
    if len(principal) == 1:
        i = int(principal[0])
        j, m = (i + 1) % 3, (i + 2) % 3
        R = np.zeros((3, 3, len(a)))
        R[i, i] = 1.0
        R[j, j] = c
        R[m, m] = c
        R[j, m] = -s * k[i]
        R[m, j] = s * k[i]
        return R
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3)[:, :, None] + K[:, :, None] * s + (K @ K)[:, :, None] * (1 - c)


def _mm(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Batch-last matrix product (3, 3, N) × (3, 3, N)."""
    return np.einsum("ijn,jkn->ikn", A, B)


def _mv(A: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Batch-last (3, 3, N) × a constant vector (3,) → (3, N)."""
    return np.einsum("ijn,j->in", A, v)


@dataclass(frozen=True)
class LegGeometry:
    """What the closed form needs, read from the URDF [m]."""

    hip_offset_m: float  # trunk origin → hip centre along trunk y (left +, right −)
    thigh_m: float
    shank_m: float
    ankle_height_m: float  # ankle centre → sole


@functools.lru_cache(maxsize=8)
def check_structure(robot: RobotModel) -> LegGeometry:
    """Check that the URDF's legs have the closed-form structure; return their geometry.

    Raises:
        RobotModelError: the URDF does not fit (the PlaCo path still works).
    """
    joints = {j.name: j for j in urdf_joints(robot.urdf_path)}
    src = str(robot.urdf_path)
    for side, sgn in (("left", 1.0), ("right", -1.0)):
        chain = [joints[f"{side}_{t}"] for t in AXES]
        for j, axis in zip(chain, AXES.values(), strict=True):
            if j.kind != "revolute" or not np.allclose(j.axis, axis) or not np.allclose(j.rpy, 0):
                raise RobotModelError(src, j.name, f"analytic IK needs a revolute joint about {axis} with rpy 0")
        x = [np.asarray(j.xyz) for j in chain]
        ok = (np.allclose(x[0][[0, 2]], 0) and np.isclose(x[0][1], sgn * robot.hip_offset_m)
              and all(np.allclose(v, 0) for v in (x[1], x[2], x[5]))
              and np.allclose(x[3][:2], 0) and np.allclose(x[4][:2], 0))
        if not ok:
            raise RobotModelError(src, f"{side} leg", "analytic IK needs intersecting hip and ankle axes")
    return LegGeometry(robot.hip_offset_m, robot.thigh_m, robot.shank_m, robot.ankle_height_m)


def leg_ik(geom: LegGeometry, side: str, trunk_xyz: np.ndarray, trunk_yaw: np.ndarray, foot_xyz: np.ndarray,
           foot_yaw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint angles (N, 6) [rad] of one leg for level trunk and flat foot poses; and reach (N,) bool.

    Args:
        trunk_xyz, foot_xyz: (N, 3) [m]; trunk_yaw, foot_yaw: (N,) [rad] or scalars.
    """
    sgn = 1.0 if side == "left" else -1.0
    trunk_xyz, foot_xyz = np.atleast_2d(trunk_xyz), np.atleast_2d(foot_xyz)
    n = max(len(trunk_xyz), len(foot_xyz))
    ty = np.broadcast_to(np.asarray(trunk_yaw, dtype=float), (n,))
    fy = np.broadcast_to(np.asarray(foot_yaw, dtype=float), (n,))
    hip = trunk_xyz + np.stack([-np.sin(ty), np.cos(ty), np.zeros(n)], axis=1) * (sgn * geom.hip_offset_m)
    ankle = foot_xyz + np.array([0.0, 0.0, geom.ankle_height_m])  # flat feet: the sole normal is z
    d = hip - ankle
    cf, sf = np.cos(fy), np.sin(fy)
    r = np.stack([cf * d[:, 0] + sf * d[:, 1], -sf * d[:, 0] + cf * d[:, 1], d[:, 2]], axis=1)  # foot frame
    a, b = geom.thigh_m, geom.shank_m
    c = np.sqrt(np.einsum("ni,ni->n", r, r))
    cos_k = (a * a + b * b - c * c) / (2 * a * b)
    reach = (cos_k >= -1.0) & (cos_k <= 1.0) & (c > 0)
    cos_k = np.clip(cos_k, -1.0, 1.0)
    knee = np.pi - np.arccos(cos_k)
    ankle_roll = np.arctan2(r[:, 1], r[:, 2])
    alpha = np.arcsin(np.clip(a * np.sin(np.pi - knee) / np.where(c > 0, c, 1.0), -1.0, 1.0))
    ankle_pitch = -np.arctan2(r[:, 0], np.sign(r[:, 2]) * np.hypot(r[:, 1], r[:, 2])) - alpha
    # hip: Rz(δ) Rx(A) Ry(B) = Rz(q1) Rx(q2) Ry(q3) with δ = fy − ty, A = −q6, B = −(q4 + q5);
    # the five entries used, written out elementwise
    sd, cd = np.sin(fy - ty), np.cos(fy - ty)
    sa, ca = np.sin(-ankle_roll), np.cos(-ankle_roll)
    sb, cb = np.sin(-(knee + ankle_pitch)), np.cos(-(knee + ankle_pitch))
    r01, r11, r21, r20, r22 = -sd * ca, cd * ca, sa, -ca * sb, ca * cb
    hip_yaw = np.arctan2(-r01, r11)
    hip_roll = np.arctan2(r21, -r01 * np.sin(hip_yaw) + r11 * np.cos(hip_yaw))
    hip_pitch = np.arctan2(-r20, r22)
    q = np.stack([hip_yaw, hip_roll, hip_pitch, knee, ankle_pitch, ankle_roll], axis=1)
    return q, reach


@functools.lru_cache(maxsize=8)
def _mass_model(robot: RobotModel):
    """Per URDF link: (mass [kg], CoM in the link frame [m]); the joint chain in file order."""
    root = ET.parse(robot.urdf_path).getroot()
    links = {}
    for link in root.iter("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        org = inertial.find("origin")
        com = np.array([float(v) for v in (org.get("xyz") if org is not None else "0 0 0").split()])
        links[link.get("name")] = (float(inertial.find("mass").get("value")), com)
    index = {name: k for k, name in enumerate(robot.joint_names)}
    chain = []
    for j in urdf_joints(robot.urdf_path):
        R0 = None
        if not np.allclose(j.rpy, 0):
            R0 = _mm(_mm(rot_axis((0, 0, 1), j.rpy[2]), rot_axis((0, 1, 0), j.rpy[1])), rot_axis((1, 0, 0), j.rpy[0]))
        chain.append((j, index.get(j.name), R0, np.asarray(j.xyz, dtype=float)))
    return links, chain


def link_poses(robot: RobotModel, trunk_xyz: np.ndarray, trunk_yaw: np.ndarray, q: np.ndarray
               ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """World (R (3, 3, N), p (3, N)) of every URDF link for trunk poses and joints ``q`` (N, 12)."""
    _, chain = _mass_model(robot)
    q = np.atleast_2d(q)
    n = len(q)
    poses = {"trunk": (rot_axis((0, 0, 1), np.broadcast_to(np.asarray(trunk_yaw, dtype=float), (n,))),
                       np.broadcast_to(np.asarray(trunk_xyz, dtype=float), (n, 3)).T)}
    for j, k, R0, xyz in chain:
        R_parent, p_parent = poses[j.parent]
        p = p_parent + _mv(R_parent, xyz) if xyz.any() else p_parent
        R = R_parent if R0 is None else _mm(R_parent, np.broadcast_to(R0, (3, 3, n)))
        if k is not None:
            R = _mm(R, rot_axis(j.axis, q[:, k]))
        poses[j.child] = (R, p)
    return poses


def com_batch(robot: RobotModel, trunk_xyz: np.ndarray, trunk_yaw: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Whole-body CoM (N, 3) [m]: Σ m_i (R_i c_i + p_i) / M over the URDF's links."""
    links, _ = _mass_model(robot)
    poses = link_poses(robot, trunk_xyz, trunk_yaw, q)
    total = 0.0
    moment = np.zeros((3, len(np.atleast_2d(q))))
    for name, (m, c) in links.items():
        R, p = poses[name]
        moment += m * p
        if c.any():
            moment += _mv(R, m * c)
        total += m
    return (moment / total).T


def _merged(robot: RobotModel, link: str, fixed_children: dict) -> tuple[float, np.ndarray]:
    """Mass [kg] and CoM [m] (in ``link``'s frame) of ``link`` with everything fixed to it."""
    links, _ = _mass_model(robot)
    m, c = links.get(link, (0.0, np.zeros(3)))
    total, moment = m, m * c
    for j, R0 in fixed_children.get(link, []):
        mc, cc = _merged(robot, j.child, fixed_children)
        total += mc
        moment = moment + mc * (np.asarray(j.xyz) + (R0 @ cc if R0 is not None else cc))
    return total, (moment / total if total > 0 else np.zeros(3))


@functools.lru_cache(maxsize=8)
def _leg_mass_model(robot: RobotModel):
    """Masses and CoMs of the rigid groups the closed-form CoM needs: the trunk with everything
    fixed to it, and per leg the six moving links with everything fixed to each."""
    _, chain = _mass_model(robot)
    fixed_children: dict[str, list] = {}
    for j, _k, R0, _xyz in chain:
        if j.kind == "fixed":
            fixed_children.setdefault(j.parent, []).append((j, None if R0 is None else R0[:, :, 0]))
    joints = {j.name: j for j, *_ in chain}
    trunk = _merged(robot, "trunk", fixed_children)
    legs = {}
    for side in SIDES:
        names = [f"{side}_{t}" for t in AXES]
        legs[side] = {
            "hip_xyz": np.asarray(joints[names[0]].xyz),
            "knee_xyz": np.asarray(joints[names[3]].xyz),
            "ankle_xyz": np.asarray(joints[names[4]].xyz),
            "links": [_merged(robot, joints[n].child, fixed_children) for n in names],
        }
    return trunk, legs


def _mul(a, b):
    """a·b where either may be the exact scalar 0.0 or 1.0 (then no array work is done)."""
    if isinstance(a, float):
        return 0.0 if a == 0.0 else (b if a == 1.0 else a * b)
    if isinstance(b, float):
        return 0.0 if b == 0.0 else (a if b == 1.0 else a * b)
    return a * b


def _add(a, b):
    if isinstance(a, float) and a == 0.0:
        return b
    if isinstance(b, float) and b == 0.0:
        return a
    return a + b


def _rot(c, s, u, w):
    """(c·u − s·w, s·u + c·w): a plane rotation, skipping the work on exact zeros."""
    return _add(_mul(c, u), -_mul(s, w)), _add(_mul(s, u), _mul(c, w))


def _rot_zxyx(cz, sz, cx, sx, cy, sy, v, cx2=None, sx2=None):
    """Rz·Rx·Ry (·Rx2) applied to a constant vector ``v`` (3,), elementwise over the angle arrays.

    Angles may be given as the floats 1.0/0.0 (cos/sin of zero): the zero terms of the usually
    sparse link vectors then cost nothing.
    """
    x, y, z = float(v[0]), float(v[1]), float(v[2])
    if cx2 is not None:  # innermost Rx2
        y, z = _rot(cx2, sx2, y, z)
    z, x = _rot(cy, sy, z, x)  # Ry: x' = c x + s z, z' = −s x + c z
    y, z = _rot(cx, sx, y, z)  # Rx
    x, y = _rot(cz, sz, x, y)  # Rz
    return x, y, z


def fast_com(robot: RobotModel, trunk_xyz: np.ndarray, trunk_yaw: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Whole-body CoM (N, 3) [m] for the closed-form leg structure, written out elementwise.

    Equal to :func:`com_batch` (tested to 1e-12 m) and several times faster: each link frame of a
    leg is Rz(yaw + q1)·Rx(q2)·Ry(q3 + …) applied to constant vectors read from the URDF.
    """
    (m_t, c_t), legs = _leg_mass_model(robot)
    q = np.atleast_2d(q)
    n = len(q)
    yaw = np.broadcast_to(np.asarray(trunk_yaw, dtype=float), (n,))
    p = np.broadcast_to(np.asarray(trunk_xyz, dtype=float), (n, 3))
    cyaw, syaw = np.cos(yaw), np.sin(yaw)
    one, zero = 1.0, 0.0
    x, y, z = _rot_zxyx(cyaw, syaw, one, zero, one, zero, c_t)
    mx, my, mz = m_t * (p[:, 0] + x), m_t * (p[:, 1] + y), m_t * (p[:, 2] + z)
    total = m_t
    for k0, side in ((0, "left"), (6, "right")):
        leg = legs[side]
        q1, q2, q3, q4, q5, q6 = (q[:, k0 + i] for i in range(6))
        hx, hy, hz = _rot_zxyx(cyaw, syaw, one, zero, one, zero, leg["hip_xyz"])
        hip = (p[:, 0] + hx, p[:, 1] + hy, p[:, 2] + hz)
        psi = yaw + q1
        cz, sz = np.cos(psi), np.sin(psi)
        cx, sx = np.cos(q2), np.sin(q2)
        angles = [(one, zero), (one, zero), (np.cos(q3), np.sin(q3)), (np.cos(q3 + q4), np.sin(q3 + q4)),
                  (np.cos(q3 + q4 + q5), np.sin(q3 + q4 + q5))]
        rolls = [(one, zero), (cx, sx), (cx, sx), (cx, sx), (cx, sx)]
        kx, ky, kz = _rot_zxyx(cz, sz, cx, sx, *angles[2], leg["knee_xyz"])
        knee = (hip[0] + kx, hip[1] + ky, hip[2] + kz)
        ax_, ay_, az_ = _rot_zxyx(cz, sz, cx, sx, *angles[3], leg["ankle_xyz"])
        ankle = (knee[0] + ax_, knee[1] + ay_, knee[2] + az_)
        origins = [hip, hip, hip, knee, ankle]
        for (m, c), origin, (cr, sr), (cp, sp) in zip(leg["links"][:5], origins, rolls, angles, strict=True):
            vx, vy, vz = _rot_zxyx(cz, sz, cr, sr, cp, sp, c)
            mx, my, mz = mx + m * (origin[0] + vx), my + m * (origin[1] + vy), mz + m * (origin[2] + vz)
            total += m
        m, c = leg["links"][5]  # the foot link, turned by the ankle roll too
        vx, vy, vz = _rot_zxyx(cz, sz, cx, sx, *angles[4], c, np.cos(q6), np.sin(q6))
        mx, my, mz = mx + m * (ankle[0] + vx), my + m * (ankle[1] + vy), mz + m * (ankle[2] + vz)
        total += m
    return np.stack([mx, my, mz], axis=1) / total


def solve_postures(robot: RobotModel, trunk_xyz: np.ndarray, trunk_yaw: np.ndarray, feet: dict[str, tuple]
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Both legs in closed form: joints (N, 12) [rad], CoM (N, 3) [m] and status (N,) as in posture.py.

    ``feet[side] = (xyz (N, 3) or (3,), yaw (N,) or scalar)``. Status: OK, UNREACHABLE (the
    hip–ankle distance exceeds the leg) or JOINT_LIMIT (the solution leaves the URDF limits).
    """
    geom = check_structure(robot)
    trunk_xyz = np.atleast_2d(np.asarray(trunk_xyz, dtype=float))
    n = len(trunk_xyz)
    qs, reach = [], np.ones(n, dtype=bool)
    for side in SIDES:
        xyz, yaw = feet[side]
        q, ok = leg_ik(geom, side, trunk_xyz, trunk_yaw, np.broadcast_to(np.asarray(xyz, dtype=float), (n, 3)),
                       yaw)
        qs.append(q)
        reach &= ok
    q = np.concatenate(qs, axis=1)
    within = np.all((q >= robot.lower_rad) & (q <= robot.upper_rad), axis=1)
    status = np.where(~reach, UNREACHABLE, np.where(within, OK, JOINT_LIMIT)).astype(np.int8)
    com = fast_com(robot, trunk_xyz, trunk_yaw, q)
    return q, com, status


class AnalyticPostureSolver:
    """Drop-in for :class:`~jethr1_plan.posture.PostureSolver` using the closed form (no PlaCo).

    ``solve_batch`` returns the same :class:`~jethr1_plan.posture.PostureBatch`; the residual is 0
    (the closed form is exact to rounding) and no IK iterations are spent.
    """

    def __init__(self, model: RobotModel):
        check_structure(model)
        self.model = model
        self.evaluations = 0
        self.replay_log = None

    def solve_batch(self, stance, p_body: np.ndarray, warm: np.ndarray | None = None):
        from .posture import PostureBatch

        p_body = np.atleast_2d(np.asarray(p_body, dtype=float))
        feet = {}
        for side in SIDES:
            T = stance.foot_pose(side)
            feet[side] = (T[:3, 3], np.arctan2(T[1, 0], T[0, 0]))
        q, com, status = solve_postures(self.model, p_body, stance.body_yaw, feet)
        com[status == UNREACHABLE] = np.nan
        self.evaluations += len(p_body)
        return PostureBatch(q=q, com=com, status=status, residual_m=np.where(status == OK, 0.0, np.inf),
                            iterations=np.zeros(len(p_body), dtype=np.int32))


def make_posture_solver(model: RobotModel, kinematics: str = "placo"):
    """A posture solver: ``placo`` (PlaCo's KinematicsSolver) or ``analytic`` (closed form)."""
    if kinematics == "analytic":
        return AnalyticPostureSolver(model)
    if kinematics == "placo":
        from .posture import PostureSolver

        return PostureSolver(model)
    raise ValueError(f"unknown kinematics {kinematics!r}")
