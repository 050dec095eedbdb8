"""Closed-form leg IK and batched forward kinematics in numpy, geometry read from the URDF.

A fast path beside PlaCo (``kinematics.placo``) for exhaustive sweeps: for a leg whose hip axes (yaw,
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
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from jethr1_plan.errors import RobotModelError
from jethr1_plan.geometry import SIDES, halfplanes, other_side
from jethr1_plan.kinematics.base import PostureBatch, Stance
from jethr1_plan.physics.balance import NOMINAL, Tolerance
from jethr1_plan.reasons import Reason
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.robot.urdf import urdf_joints

__all__ = [
    "AXES",
    "ClosedFormPostureSolver",
    "KernelParams",
    "LegGeometry",
    "check_structure",
    "closed_form_arrays",
    "kernel_params",
    "leg_mass_model",
    "limit_arcs",
    "mass_model",
    "mm_batch",
    "rot_axis",
    "solve_postures",
]

AXES = {"hip_yaw": (0, 0, 1), "hip_roll": (1, 0, 0), "hip_pitch": (0, 1, 0), "knee": (0, 1, 0),
        "ankle_pitch": (0, 1, 0), "ankle_roll": (1, 0, 0)}

# Rotations are stored batch-last, (3, 3, N): numpy's einsum over that layout is several times
# faster than matmul over (N, 3, 3) stacks of small matrices.


def rot_axis(axis, a: ArrayLike) -> np.ndarray:
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


def mm_batch(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Batch-last matrix product (3, 3, N) × (3, 3, N)."""
    return np.einsum("ijn,jkn->ikn", A, B)


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
    wrapper = robot.wrapper()
    wrapper.state.q[7:] = 0.0
    wrapper.update_kinematics()
    for side, sgn in (("left", 1.0), ("right", -1.0)):
        leg = robot.legs[side]
        chain = [joints[n] for n in leg.joints]
        parents = [robot.trunk] + [j.child for j in chain[:-1]]
        for j, axis, parent in zip(chain, AXES.values(), parents, strict=True):
            if j.kind != "revolute" or not np.allclose(j.axis, axis) or not np.allclose(j.rpy, 0):
                raise RobotModelError(src, j.name, f"analytic IK needs a revolute joint about {axis} with rpy 0")
            if j.parent != parent:
                raise RobotModelError(src, j.name, f"analytic IK needs the leg as one chain from {robot.trunk} "
                                      f"(parent {parent!r}, got {j.parent!r})")
        sole, ankle = wrapper.get_T_world_frame(leg.sole), wrapper.get_T_world_frame(leg.joints[4])
        if not (np.allclose(sole[:3, :3], np.eye(3)) and np.allclose(sole[:2, 3], ankle[:2, 3])):
            raise RobotModelError(src, leg.sole, "analytic IK needs the sole frame level and straight below the "
                                  "ankle at the zero posture")
        x = [np.asarray(j.xyz) for j in chain]
        ok = (np.allclose(x[0][[0, 2]], 0) and np.isclose(x[0][1], sgn * robot.hip_offset_m)
              and all(np.allclose(v, 0) for v in (x[1], x[2], x[5]))
              and np.allclose(x[3][:2], 0) and np.allclose(x[4][:2], 0))
        if not ok:
            raise RobotModelError(src, f"{side} leg", "analytic IK needs intersecting hip and ankle axes")
    return LegGeometry(robot.hip_offset_m, robot.thigh_m, robot.shank_m, robot.ankle_height_m)


@functools.lru_cache(maxsize=8)
def mass_model(robot: RobotModel):
    """Per URDF link: (mass [kg], CoM in the link frame [m]); the joint chain in file order."""
    root = ET.parse(robot.urdf_path).getroot()
    links = {}
    for link in root.iter("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        org = inertial.find("origin")
        com = np.array([float(v) for v in (org.get("xyz", "0 0 0") if org is not None else "0 0 0").split()])
        mass = inertial.find("mass")
        links[str(link.get("name"))] = (float(mass.get("value", "0") if mass is not None else 0.0), com)
    index = {name: k for k, name in enumerate(robot.joint_names)}
    chain = []
    for j in urdf_joints(robot.urdf_path):
        R0 = None
        if not np.allclose(j.rpy, 0):
            R0 = mm_batch(mm_batch(rot_axis((0, 0, 1), j.rpy[2]), rot_axis((0, 1, 0), j.rpy[1])),
                          rot_axis((1, 0, 0), j.rpy[0]))
        chain.append((j, index.get(j.name), R0, np.asarray(j.xyz, dtype=float)))
    return links, chain


def _merged(robot: RobotModel, link: str, fixed_children: dict) -> tuple[float, np.ndarray]:
    """Mass [kg] and CoM [m] (in ``link``'s frame) of ``link`` with everything fixed to it."""
    links, _ = mass_model(robot)
    m, c = links.get(link, (0.0, np.zeros(3)))
    total, moment = m, m * c
    for j, R0 in fixed_children.get(link, []):
        mc, cc = _merged(robot, j.child, fixed_children)
        total += mc
        moment = moment + mc * (np.asarray(j.xyz) + (R0 @ cc if R0 is not None else cc))
    return total, (moment / total if total > 0 else np.zeros(3))


@functools.lru_cache(maxsize=8)
def leg_mass_model(robot: RobotModel):
    """Masses and CoMs of the rigid groups the closed-form CoM needs: the trunk with everything
    fixed to it, and per leg the six moving links with everything fixed to each. Joints outside the
    legs (a waist, arms) are held at 0 by the planner, so they count as fixed."""
    _, chain = mass_model(robot)
    fixed_children: dict[str, list] = {}
    moving = {n for leg in robot.legs.values() for n in leg.joints}
    for j, _k, R0, _xyz in chain:
        if j.kind == "fixed" or j.name not in moving:  # any joint but the legs' is held at 0: rigid
            fixed_children.setdefault(j.parent, []).append((j, None if R0 is None else R0[:, :, 0]))
    joints = {j.name: j for j, *_ in chain}
    trunk = _merged(robot, robot.trunk, fixed_children)
    legs = {}
    for side in SIDES:
        names = list(robot.legs[side].joints)
        legs[side] = {
            "hip_xyz": np.asarray(joints[names[0]].xyz),
            "knee_xyz": np.asarray(joints[names[3]].xyz),
            "ankle_xyz": np.asarray(joints[names[4]].xyz),
            "links": [_merged(robot, joints[n].child, fixed_children) for n in names],
        }
    return trunk, legs


@functools.lru_cache(maxsize=8)
def closed_form_arrays(robot: RobotModel) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The robot's constants as ``physics.compiled`` takes them: geom (4,) hip offset, thigh, shank,
    ankle height [m]; trunk (4,) mass [kg] and CoM [m]; joints (2, 3, 3) per leg (left, right) the
    hip, knee and ankle placements [m]; links (2, 6, 4) per leg and moving link mass and CoM; limits
    (2, 12) [rad], the legs' joints by role (left then right)."""
    g = check_structure(robot)
    (m_t, c_t), legs = leg_mass_model(robot)
    return (np.array([g.hip_offset_m, g.thigh_m, g.shank_m, g.ankle_height_m]), np.array([m_t, *c_t]),
            np.array([[legs[s]["hip_xyz"], legs[s]["knee_xyz"], legs[s]["ankle_xyz"]] for s in SIDES], dtype=float),
            np.array([[[m, *c] for m, c in legs[s]["links"]] for s in SIDES], dtype=float),
            np.stack([robot.lower_rad, robot.upper_rad])[:, robot.leg_index].astype(float))


def solve_postures(robot: RobotModel, trunk_xyz: ArrayLike, trunk_yaw: ArrayLike, feet: dict[str, tuple]
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Both legs in closed form: joints (N, J) [rad] in the robot's order (any joint outside the legs at
    0), CoM (N, 3) [m] and status (N,) (a Reason), by ``physics.compiled.postures`` (the one
    implementation).

    ``feet[side] = (xyz (N, 3) or (3,), yaw (N,) or scalar)``. Status: OK, UNREACHABLE (the
    hip–ankle distance exceeds the leg) or JOINT_LIMIT (the solution leaves the URDF limits).
    """
    from jethr1_plan.physics.compiled.legs import postures

    P = np.ascontiguousarray(np.atleast_2d(np.asarray(trunk_xyz, dtype=float)))
    n = len(P)
    yaw = np.ascontiguousarray(np.broadcast_to(np.asarray(trunk_yaw, dtype=float), (n,)))
    foot_xyz = np.ascontiguousarray(np.stack([np.broadcast_to(np.asarray(feet[s][0], dtype=float), (n, 3))
                                              for s in SIDES], axis=1))
    foot_yaw = np.ascontiguousarray(np.stack([np.broadcast_to(np.asarray(feet[s][1], dtype=float), (n,))
                                              for s in SIDES], axis=1))
    q_legs, com, status = postures(P, yaw, foot_xyz, foot_yaw, *closed_form_arrays(robot))
    legs = robot.leg_index
    if len(robot.joint_names) == 12 and np.array_equal(legs, np.arange(12)):
        return q_legs, com, status
    q = np.zeros((n, len(robot.joint_names)))
    q[:, legs] = q_legs
    return q, com, status


class ClosedFormPostureSolver:
    """The :class:`~jethr1_plan.kinematics.base.PostureSolver` of the closed form (no PlaCo).

    ``solve_batch`` returns the same :class:`~jethr1_plan.kinematics.base.PostureBatch` as PlaCo's; the residual is 0
    (the closed form is exact to rounding) and no IK iterations are spent.
    """

    def __init__(self, model: RobotModel):
        check_structure(model)
        self.model = model
        self.evaluations = 0
        self.replay_log: list | None = None  # PlaCo's only

    def solve_batch(self, stance: Stance, p_body: np.ndarray, warm: np.ndarray | None = None) -> PostureBatch:
        p_body = np.atleast_2d(np.asarray(p_body, dtype=float))
        feet = {}
        for side in SIDES:
            T = stance.foot_pose(side)
            feet[side] = (T[:3, 3], np.arctan2(T[1, 0], T[0, 0]))
        q, com, status = solve_postures(self.model, p_body, stance.body_yaw, feet)
        com[status == Reason.UNREACHABLE] = np.nan
        self.evaluations += len(p_body)
        return PostureBatch(q=q, com=com, status=status, residual_m=np.where(status == Reason.OK, 0.0, np.inf),
                            iterations=np.zeros(len(p_body), dtype=np.int32))


class KernelParams(NamedTuple):
    """Robot and support constants of the compiled objective (SI units)."""

    geom: np.ndarray  # (4,) hip offset, thigh, shank, ankle height [m]
    trunk: np.ndarray  # (4,) mass [kg], CoM in the trunk frame [m]
    joints: np.ndarray  # (2, 3, 3) per leg (left, right): hip, knee, ankle joint placements [m]
    links: np.ndarray  # (2, 6, 4) per leg and moving link: mass [kg], CoM in the link frame [m]
    limits: np.ndarray  # (2, 12) lower, upper joint limits [rad]
    normals: np.ndarray  # (K, 2) outward normals of the support polygon
    offsets: np.ndarray  # (K,) n·x ≤ b inside
    support: np.ndarray  # (3,) support sole centre [m]
    scalars: np.ndarray  # (9,) support sign (+1 left, −1 right), ρ [rad], F_max [N], M·g [N], edge penalty
    # [N/deg], the tolerance of balance.thrust_window: thrust error, mass error, CoM error [m]; tan ρ
    fans: np.ndarray  # (F, 4) per fan the swing may use: on the trunk (1) or the swing sole (0), offset x, y [m],
    # maximum [N]
    arcs: np.ndarray  # (12, 5) the joint limits as cosines and sines (limit_arcs)


def kernel_params(robot: RobotModel, support_side: str, support_xyz: np.ndarray, polygon: np.ndarray,
                  rho_rad: float, thrust_max_n: float, weight_n: float, edge_penalty_n_per_deg: float,
                  tolerance: Tolerance = NOMINAL) -> KernelParams:
    """Constants of ``physics.compiled.balance_objective`` from the robot model (URDF masses and placements)."""
    geom, trunk, joints, links, limits = closed_form_arrays(robot)
    swing = other_side(support_side)
    fans = [robot.fans[i] for i in robot.swing_fans(swing)]
    normals, offsets = halfplanes(polygon)
    return KernelParams(
        geom=geom, trunk=trunk, joints=joints, links=links, limits=limits,
        normals=np.ascontiguousarray(normals, dtype=float), offsets=np.ascontiguousarray(offsets, dtype=float),
        support=np.asarray(support_xyz, dtype=float),
        scalars=np.array([1.0 if support_side == "left" else -1.0, rho_rad, thrust_max_n, weight_n,
                          edge_penalty_n_per_deg, tolerance.thrust, tolerance.mass, tolerance.com_m,
                          math.tan(rho_rad) if rho_rad < math.pi / 2 else -1.0]),
        fans=np.array([[float(f.on_trunk), f.offset_m[0], f.offset_m[1], f.thrust_max_n] for f in fans],
                      dtype=float).reshape(len(fans), 4),
        arcs=limit_arcs(limits),
    )


def limit_arcs(limits: np.ndarray) -> np.ndarray:
    """The joint limits (2, 12) [rad] as ``physics.compiled.objective.surely_within`` reads them: per joint
    cos lo, sin lo, cos hi, sin hi, and 1 where the range is wider than π (12, 5)."""
    lo, hi = limits
    return np.ascontiguousarray(np.column_stack([np.cos(lo), np.sin(lo), np.cos(hi), np.sin(hi),
                                                 (hi - lo > np.pi).astype(float)]))
