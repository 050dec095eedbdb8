"""ROS 2 messages as the value trees :class:`~.cdr.CdrEncoder` encodes (columns for many messages at once):
stamps and headers on the fixed epoch of :mod:`.mcap`, poses, the robot's transforms and URDF, joint
states and trajectories, markers and point clouds."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from jethr1_plan.geometry import quat_rpy
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.robot.urdf import urdf_joints

__all__ = [
    "EPOCH_NS",
    "carton_markers",
    "cube_marker",
    "header",
    "joint_rotations",
    "joint_state",
    "joint_trajectory",
    "log_times",
    "point_cloud2",
    "pose_stamped",
    "prefixed_urdf",
    "robot_transforms",
    "seconds",
    "stamps",
    "step_markers",
    "swing_path_markers",
    "urdf_message",
    "yaw_quaternions",
]


EPOCH_NS = 946_684_800 * 1_000_000_000  # 2000-01-01T00:00:00Z [ns since 1970]


def log_times(t_s: np.ndarray) -> np.ndarray:
    """Log times [ns since 1970] of times ``t_s`` [s] from the start."""
    return EPOCH_NS + np.round(np.asarray(t_s, dtype=float) * 1e9).astype(np.int64)


def seconds(log_time_ns: int | np.ndarray) -> np.ndarray:
    """Times [s] from the start of log times [ns], to 1e-9 s (as trajectory.csv writes them)."""
    return np.round((np.asarray(log_time_ns, dtype=np.int64) - EPOCH_NS) / 1e9, 9)


def stamps(t_s: np.ndarray | float) -> dict:
    """``builtin_interfaces/Time`` of times ``t_s`` [s] from the start (the log times)."""
    ns = log_times(np.atleast_1d(t_s))
    sec, nanosec = ns // 1_000_000_000, ns % 1_000_000_000
    if np.ndim(t_s) == 0:
        return {"sec": int(sec[0]), "nanosec": int(nanosec[0])}
    return {"sec": sec.astype(np.int32), "nanosec": nanosec.astype(np.uint32)}


def header(t_s: np.ndarray | float, frame_id: str = "") -> dict:
    """``std_msgs/Header`` of times ``t_s`` [s] from the start."""
    return {"stamp": stamps(t_s), "frame_id": frame_id}


def _xyz(v) -> dict:
    """``geometry_msgs/Point`` or ``Vector3``: one (3,), or columns of an (N, 3) array."""
    v = np.asarray(v, dtype=float)
    if v.ndim == 2:
        return {"x": v[:, 0], "y": v[:, 1], "z": v[:, 2]}
    return dict(zip("xyz", map(float, v), strict=True))


def _xyzw(q) -> dict:
    """``geometry_msgs/Quaternion``: one (4,) x, y, z, w, or columns of an (N, 4) array."""
    q = np.asarray(q, dtype=float)
    if q.ndim == 2:
        return {"x": q[:, 0], "y": q[:, 1], "z": q[:, 2], "w": q[:, 3]}
    return dict(zip("xyzw", map(float, q), strict=True))


def yaw_quaternions(yaw_rad: np.ndarray) -> np.ndarray:
    """(N, 4) x, y, z, w quaternions of rotations by ``yaw_rad`` about z."""
    half = 0.5 * np.asarray(yaw_rad, dtype=float)
    z = np.zeros_like(half)
    return np.stack([z, z, np.sin(half), np.cos(half)], axis=1)


def pose_stamped(t_s: np.ndarray, frame_id: str, position, orientation_xyzw=(0.0, 0.0, 0.0, 1.0)) -> dict:
    """``geometry_msgs/PoseStamped`` per time: ``position`` (N, 3) [m], orientation (N, 4) or one quaternion."""
    return {"header": header(t_s, frame_id),
            "pose": {"position": _xyz(position), "orientation": _xyzw(orientation_xyzw)}}


def _transform(stamp_t, parent: str, child: str, translation, rotation) -> dict:
    return {"header": header(stamp_t, parent), "child_frame_id": child,
            "transform": {"translation": _xyz(translation), "rotation": _xyzw(rotation)}}


def joint_rotations(robot: RobotModel, q: np.ndarray) -> list[np.ndarray]:
    """Per URDF joint, the parent→child rotation quaternions (N, 4) x, y, z, w for joint angles ``q`` (N, J)."""
    q = np.atleast_2d(q)
    index = {name: k for k, name in enumerate(robot.joint_names)}
    out = []
    for j in urdf_joints(robot.urdf_path):
        base = quat_rpy(j.rpy)
        if j.kind in ("revolute", "continuous"):
            axis = np.asarray(j.axis, dtype=float) / np.linalg.norm(j.axis)
            half = 0.5 * q[:, index[j.name]]
            rot = np.concatenate([np.sin(half)[:, None] * axis, np.cos(half)[:, None]], axis=1)
            bx, by, bz, bw = base
            x, y, z, w = rot.T
            out.append(np.stack([bw * x + bx * w + by * z - bz * y, bw * y - bx * z + by * w + bz * x,
                                 bw * z + bx * y - by * x + bz * w, bw * w - bx * x - by * y - bz * z], axis=1))
        else:
            out.append(np.repeat(base[None], len(q), axis=0))
    return out


def robot_transforms(robot: RobotModel, t_s: np.ndarray, p_body: np.ndarray, trunk_xyzw: np.ndarray, q: np.ndarray,
                     prefix: str = "") -> tuple[dict, dict]:
    """(``/tf``, ``/tf_static``) of the robot: per time, world→trunk (``p_body`` (N, 3) [m],
    ``trunk_xyzw`` (N, 4)) and every moving joint's parent→child link for joint angles ``q`` (N, J)
    [rad]; once (at time 0), every fixed joint's. ``prefix`` goes before every robot frame."""
    t = np.asarray(t_s, dtype=float)
    moving = [_transform(t, "world", prefix + robot.trunk, p_body, trunk_xyzw)]
    static = []
    for j, rot in zip(urdf_joints(robot.urdf_path), joint_rotations(robot, np.asarray(q, dtype=float)), strict=True):
        if j.kind == "fixed":
            static.append(_transform(0.0, prefix + j.parent, prefix + j.child, j.xyz, quat_rpy(j.rpy)))
        else:
            moving.append(_transform(t, prefix + j.parent, prefix + j.child, j.xyz, rot))
    return {"transforms": moving}, {"transforms": static}


def urdf_message(robot: RobotModel, prefix: str = "") -> dict:
    """``std_msgs/String`` of the robot's URDF (every link prefixed ``prefix``)."""
    return {"data": prefixed_urdf(robot, prefix) if prefix else robot.urdf_path.read_text(encoding="utf-8")}


def prefixed_urdf(robot: RobotModel, prefix: str) -> str:
    """The robot's URDF with every link name (and every joint's parent and child) prefixed."""
    import xml.etree.ElementTree as ET

    root = ET.parse(robot.urdf_path).getroot()
    for link in root.iter("link"):
        link.set("name", prefix + link.get("name", ""))
    for joint in root.iter("joint"):
        for tag in ("parent", "child"):
            el = joint.find(tag)
            if el is not None:
                el.set("link", prefix + el.get("link", ""))
    return ET.tostring(root, encoding="unicode")


def joint_state(t_s: np.ndarray, names: Sequence[str], position_rad: np.ndarray, effort_nm: np.ndarray) -> dict:
    """``sensor_msgs/JointState`` per time: positions (N, J) [rad] and efforts (N, J) [N·m]."""
    return {"header": header(t_s), "name": list(names), "position": np.asarray(position_rad, dtype=float),
            "effort": np.asarray(effort_nm, dtype=float)}


def joint_trajectory(names: Sequence[str], t_s: np.ndarray, positions_rad: np.ndarray) -> dict:
    """One ``trajectory_msgs/JointTrajectory`` as a JointTrajectoryController executes it: a point
    per row, ``time_from_start`` its time [s], ``positions`` its servo commands (N, J) [rad]. The
    header's stamp is zero: the controller starts it when it arrives."""
    ns = np.round(np.asarray(t_s, dtype=float) * 1e9).astype(np.int64)
    points = {"positions": np.asarray(positions_rad, dtype=float).reshape(len(ns), -1),
              "time_from_start": {"sec": (ns // 1_000_000_000).astype(np.int32),
                                  "nanosec": (ns % 1_000_000_000).astype(np.uint32)}}
    return {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""}, "joint_names": list(names),
            "points": points}


def _color(rgba) -> dict:
    return dict(zip("rgba", map(float, rgba), strict=True))


def cube_marker(ns: str, ident: int, centre, size, rgba, frame_id: str = "world") -> dict:
    """A ``visualization_msgs/Marker`` CUBE (axis-aligned) of ``size`` [m] at ``centre`` [m]."""
    return {"header": header(0.0, frame_id), "ns": ns, "id": ident, "type": 1, "action": 0,
            "pose": {"position": _xyz(centre), "orientation": _xyzw((0.0, 0.0, 0.0, 1.0))},
            "scale": _xyz(size), "color": _color(rgba)}


def step_markers(steps: Iterable[dict], frame_id: str = "world") -> dict:
    """``/sim/steps``: per landing (``foothold_m``, ``landed_m`` [m], ``error_m``, ``slip_m`` [m], ``turn_rad``
    [rad], ``step``): a green SPHERE at the foothold, an orange one where the sole landed, a LINE_STRIP between
    them and a TEXT_VIEW_FACING label above: the step, its landing error, the support sole's slip and turn."""
    markers = []
    for k, st in enumerate(steps):
        foot, landed = np.asarray(st["foothold_m"], dtype=float), np.asarray(st["landed_m"], dtype=float)
        base = {"header": header(0.0, frame_id), "ns": f"step_{st['step']}", "action": 0}
        ident = 4 * k
        for j, (where, rgba) in enumerate(((foot, (0.2, 0.8, 0.2, 0.9)), (landed, (1.0, 0.55, 0.1, 0.9)))):
            markers.append({**base, "id": ident + j, "type": 2, "scale": _xyz((0.012, 0.012, 0.012)),
                            "pose": {"position": _xyz(where), "orientation": _xyzw((0.0, 0.0, 0.0, 1.0))},
                            "color": _color(rgba)})
        markers.append({**base, "id": ident + 2, "type": 4, "scale": {"x": 0.002},
                        "pose": {"orientation": _xyzw((0.0, 0.0, 0.0, 1.0))}, "color": _color((1.0, 1.0, 1.0, 1.0)),
                        "points": _xyz(np.vstack([foot, landed]))})
        text = (f"step {st['step']}: {1000 * st['error_m']:.1f} mm off; support slip {1000 * st['slip_m']:.1f} mm, "
                f"turn {np.degrees(st['turn_rad']):+.2f} deg")
        markers.append({**base, "id": ident + 3, "type": 9, "scale": {"z": 0.02}, "text": text,
                        "pose": {"position": _xyz(landed + np.array([0.0, 0.0, 0.06])),
                                 "orientation": _xyzw((0.0, 0.0, 0.0, 1.0))}, "color": _color((1.0, 1.0, 1.0, 1.0))})
    return {"markers": markers}


def carton_markers(cartons: Iterable) -> dict:
    """``/terrain``: a brown CUBE per carton, its top face where the carton's is."""
    markers = []
    for k, c in enumerate(cartons):
        x, y, ztop = c.top_centre_m
        markers.append(cube_marker("cartons", k, (x, y, ztop - c.size_m[2] / 2), c.size_m, (0.72, 0.53, 0.32, 0.9)))
    return {"markers": markers}


def swing_path_markers(paths: Iterable[np.ndarray]) -> dict:
    """``/swing_path``: a LINE_STRIP (5 mm wide) per step through its swing samples [m]."""
    return {"markers": [{"header": header(0.0, "world"), "ns": "swing_paths", "id": k, "type": 4, "action": 0,
                         "pose": {"orientation": _xyzw((0.0, 0.0, 0.0, 1.0))}, "scale": {"x": 0.005},
                         "color": _color((0.1, 0.6, 1.0, 1.0)),
                         "points": _xyz(np.asarray(path, dtype=float).reshape(-1, 3))}
                        for k, path in enumerate(paths)]}


def point_cloud2(points_m: np.ndarray, values: Mapping[str, np.ndarray], frame_id: str = "world") -> dict:
    """A ``sensor_msgs/PointCloud2`` of float32 x, y, z [m] and the named ``values`` per point."""
    cols = [np.asarray(points_m, dtype=float).reshape(-1, 3), *(np.asarray(v, dtype=float)[:, None]
                                                                 for v in values.values())]
    data = np.concatenate(cols, axis=1).astype("<f4")
    names = ["x", "y", "z", *values]
    return {"header": header(0.0, frame_id), "height": 1, "width": len(data),
            "fields": [{"name": n, "offset": 4 * k, "datatype": 7, "count": 1} for k, n in enumerate(names)],
            "is_bigendian": False, "point_step": 4 * len(names), "row_step": 4 * len(names) * len(data),
            "data": data.tobytes(), "is_dense": True}
