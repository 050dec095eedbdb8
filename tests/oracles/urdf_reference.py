"""An independent forward-kinematics reference written straight from the URDF file (no PlaCo).

Used by the tests to check PlaCo's IK, CoM and the planner's outputs.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np


def _rot(axis, angle) -> np.ndarray:
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _rpy(r, p, y) -> np.ndarray:
    return _rot((0, 0, 1), y) @ _rot((0, 1, 0), p) @ _rot((1, 0, 0), r)


class UrdfReference:
    def __init__(self, urdf: Path):
        root = ET.parse(urdf).getroot()
        self.links = {}
        for link in root.iter("link"):
            inertial = link.find("inertial")
            if inertial is None:
                self.links[link.get("name")] = (0.0, np.zeros(3))
                continue
            org = inertial.find("origin")
            com = np.array([float(v) for v in org.get("xyz").split()]) if org is not None else np.zeros(3)
            self.links[link.get("name")] = (float(inertial.find("mass").get("value")), com)
        self.joints = []
        for j in root.iter("joint"):
            org = j.find("origin")
            xyz = np.array([float(v) for v in org.get("xyz", "0 0 0").split()])
            rpy = [float(v) for v in org.get("rpy", "0 0 0").split()]
            ax = j.find("axis")
            axis = [float(v) for v in ax.get("xyz").split()] if ax is not None else [1, 0, 0]
            self.joints.append((j.get("name"), j.get("type"), j.find("parent").get("link"),
                                j.find("child").get("link"), xyz, _rpy(*rpy), axis))

    def link_poses(self, trunk_xyz, trunk_yaw, q: dict[str, float]) -> dict[str, np.ndarray]:
        T0 = np.eye(4)
        T0[:3, :3] = _rot((0, 0, 1), trunk_yaw)
        T0[:3, 3] = trunk_xyz
        poses = {"trunk": T0}
        pending = list(self.joints)
        while pending:
            rest = []
            for name, kind, parent, child, xyz, R0, axis in pending:
                if parent not in poses:
                    rest.append((name, kind, parent, child, xyz, R0, axis))
                    continue
                T = np.eye(4)
                T[:3, :3] = R0 @ (_rot(axis, q[name]) if kind == "revolute" else np.eye(3))
                T[:3, 3] = xyz
                poses[child] = poses[parent] @ T
            pending = rest
        return poses

    def com(self, trunk_xyz, trunk_yaw, q: dict[str, float]) -> tuple[float, np.ndarray]:
        poses = self.link_poses(trunk_xyz, trunk_yaw, q)
        total, moment = 0.0, np.zeros(3)
        for name, (m, c) in self.links.items():
            T = poses[name]
            moment += m * (T[:3, :3] @ c + T[:3, 3])
            total += m
        return total, moment / total
