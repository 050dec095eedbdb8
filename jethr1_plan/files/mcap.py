"""MCAP files in the ROS 2 profile, written and read: what Foxglove/Lichtblick, Rerun, ``rosbags``,
``mcap_ros2`` and ``ros2 bag play`` all read.

Profile ``ros2``; messages CDR-encoded (:mod:`.cdr`); each channel's schema the ``ros2msg``
definition of its type with its dependencies appended (:mod:`.ros2_msgs`); each channel's metadata
the ``offered_qos_profiles`` ``ros2 bag play`` publishes it with (reliable, keep last; transient
local for what is published once: the URDF, ``/tf_static``, the scenery).

Every kind of file declares its topics once, as data (a :class:`Topic` per topic name):
``plan_mcap.PLAN_TOPICS``, ``simulation.SIMULATION_TOPICS``, ``walk_folder.WALK_TOPICS``,
``balance_space.BALANCE_SPACE_TOPICS``; the writer registers exactly these channels, in that order.

Times: every message is logged at :data:`EPOCH_NS` + its time from the start of the scenario, the
epoch being 2000-01-01T00:00:00Z (a fixed date: the same input gives the same bytes; viewers show
the plan starting at midnight on 1 January 2000), and its header stamp is the same time. Messages
are written in log-time order (at equal times in the order of the file's topics). The header
records no library version.
"""

from __future__ import annotations

import io
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from jethr1_plan.files.cdr import CdrEncoder, parse_schema
from jethr1_plan.files.ros2_msgs import MSGDEFS, schema_text
from jethr1_plan.geometry import quat_rpy
from jethr1_plan.records.topics import MARKERS, POSE, STRING, TF, Topic
from jethr1_plan.robot.model import RobotModel, urdf_joints

__all__ = [
    "EPOCH_NS",
    "MARKERS",
    "MCAP_MAGIC",
    "POSE",
    "STRING",
    "TF",
    "McapTooLarge",
    "Ros2Mcap",
    "Topic",
    "carton_markers",
    "cube_marker",
    "header",
    "joint_rotations",
    "joint_state",
    "joint_trajectory",
    "log_times",
    "mcap_expanded_bytes",
    "point_cloud2",
    "pose_stamped",
    "prefixed_urdf",
    "qos_profile",
    "read_mcap",
    "robot_transforms",
    "seconds",
    "stamps",
    "step_markers",
    "swing_path_markers",
    "topics_markdown",
    "urdf_message",
    "yaw_quaternions",
]

EPOCH_NS = 946_684_800 * 1_000_000_000  # 2000-01-01T00:00:00Z [ns since 1970]

def qos_profile(transient_local: bool) -> str:
    """``offered_qos_profiles`` as rosbag2 stores it (its integer form, which Humble and later read):
    reliable, keep last (depth 1 when transient local, else 10), durations left at the default."""
    zero = "\n    sec: 0\n    nsec: 0"
    return (f"- history: 1\n  depth: {1 if transient_local else 10}\n  reliability: 1\n"
            f"  durability: {1 if transient_local else 2}\n  deadline:{zero}\n  lifespan:{zero}\n  liveliness: 1\n"
            f"  liveliness_lease_duration:{zero}\n  avoid_ros_namespace_conventions: false\n")


def topics_markdown(topics: Mapping[str, Topic]) -> str:
    """A Markdown table of a file's topics (the docs print it; a test holds it to the declaration)."""
    lines = ["| topic | type | QoS durability | carries |", "| --- | --- | --- | --- |"]
    lines += [f"| `{name}` | `{t.type}` | {'transient local' if t.latched else 'volatile'} | {t.what} |"
              for name, t in topics.items()]
    return "\n".join(lines) + "\n"


class Ros2Mcap:
    """An MCAP in the ROS 2 profile being written: one channel per declared topic, registered in
    order; messages kept until :meth:`finish` writes them in log-time order (zstd-compressed
    chunks, one sequence number per message)."""

    def __init__(self, topics: Mapping[str, Topic], msgdefs: Mapping[str, str] = MSGDEFS):
        from mcap.writer import CompressionType, Writer

        self._buf = io.BytesIO()
        self._w = Writer(self._buf, compression=CompressionType.ZSTD)
        self._w.start(profile="ros2", library="jethr1-plan")
        self.types = {name: t.type for name, t in topics.items()}
        schemas: dict[str, int] = {}
        types: dict = {}
        for name in dict.fromkeys(self.types.values()):
            text = schema_text(name, msgdefs)
            types.update(parse_schema(name, text))
            schemas[name] = self._w.register_schema(name=name, encoding="ros2msg", data=text.encode())
        self._encoder = CdrEncoder(types)
        self._channels = {name: self._w.register_channel(
            topic=name, message_encoding="cdr", schema_id=schemas[t.type],
            metadata={"offered_qos_profiles": qos_profile(t.latched)}) for name, t in topics.items()}
        self._rank = {name: k for k, name in enumerate(topics)}
        self._pending: list[tuple[np.ndarray, str, list[bytes]]] = []  # log times [ns], topic, messages

    def write(self, topic: str, t_s: float, msg: Mapping) -> None:
        """Log one message on ``topic`` at ``t_s`` [s] from the start."""
        self.write_rows(topic, np.array([t_s]), msg)

    def write_rows(self, topic: str, t_s: Sequence[float] | np.ndarray, msg: Mapping) -> None:
        """Log ``len(t_s)`` messages on ``topic``, message i at ``t_s[i]`` [s], given as one value tree
        whose per-message fields have one value per message (:mod:`.cdr`)."""
        t = np.asarray(t_s, dtype=float)
        if len(t) == 0:
            return
        data = self._encoder.encode(self.types[topic], msg, len(t))
        self._pending.append((log_times(t), topic, data))

    def finish(self) -> bytes:
        """Write every message, in log-time order, and return the file's bytes."""
        if self._pending:
            times = np.concatenate([t for t, _, _ in self._pending])
            ranks = np.concatenate([np.full(len(t), self._rank[topic]) for t, topic, _ in self._pending])
            channels = [self._channels[topic] for t, topic, _ in self._pending for _ in range(len(t))]
            data: list[bytes | None] = [d for _, _, messages in self._pending for d in messages]
            self._pending = []
            add = self._w.add_message
            # by log time, then topic order; np.lexsort is stable, so a topic's messages keep their order
            for seq, k in enumerate(np.lexsort((ranks, times)).tolist()):
                ns = int(times[k])
                message, data[k] = data[k], None  # (each message's bytes let go once in its chunk)
                add(channel_id=channels[k], log_time=ns, publish_time=ns, sequence=seq, data=message)
        self._w.finish()
        return self._buf.getvalue()


MCAP_MAGIC = b"\x89MCAP0\r\n"
MAX_MCAP_EXPANSION = 50  # the chunks of jethr1's files expand 3 to 12 times; no more than this many
MCAP_SLACK_BYTES = 20_000_000  # ... plus this (a small file's URDF, schemas)


class McapTooLarge(ValueError):
    """An MCAP whose chunks would expand beyond the bound its reader gives (a bomb, or not jethr1's)."""


def mcap_expanded_bytes(data: bytes, max_bytes: int | None = None) -> int:
    """The bytes the chunks of MCAP ``data`` decompress to, read from the chunk records and their zstd frame
    headers before anything is decompressed; at most ``max_bytes`` (default: :data:`MAX_MCAP_EXPANSION` times
    the file plus :data:`MCAP_SLACK_BYTES`).

    Raises:
        McapTooLarge: more than ``max_bytes``; a chunk whose compression jethr1 does not read (not zstd, not
            none), or whose zstd frame says it holds more than its chunk record says.
        ValueError: not an MCAP file (its records do not parse).
    """
    import struct

    import zstandard

    limit = len(data) * MAX_MCAP_EXPANSION + MCAP_SLACK_BYTES if max_bytes is None else max_bytes
    if not data.startswith(MCAP_MAGIC):
        raise ValueError("not an MCAP file (no MCAP magic at its start)")
    pos, total = len(MCAP_MAGIC), 0
    while pos + 9 <= len(data):
        op = data[pos]
        (length,) = struct.unpack_from("<Q", data, pos + 1)
        body = pos + 9
        if body + length > len(data):
            raise ValueError(f"a record at byte {pos} runs past the end of the file (cut?)")
        if op == 0x06:  # Chunk: start, end, uncompressed size, CRC, compression, records
            if length < 32:
                raise ValueError(f"a chunk record at byte {pos} is too short")
            size = struct.unpack_from("<Q", data, body + 16)[0]
            (n,) = struct.unpack_from("<I", data, body + 28)
            compression = data[body + 32:body + 32 + n].decode("utf-8", "replace")
            records = body + 32 + n + 8
            if compression not in ("", "zstd"):
                raise McapTooLarge(f"a chunk compressed with {compression[:20]!r}: jethr1 reads zstd chunks (what "
                                   "it writes)")
            if compression == "zstd" and records < body + length:
                frame = zstandard.get_frame_parameters(data[records:body + length]).content_size
                if frame not in (0, zstandard.CONTENTSIZE_UNKNOWN) and frame > size:
                    raise McapTooLarge(f"a chunk at byte {pos} expands to {frame:,} bytes, though it says {size:,}")
            total += size
            if total > limit:
                raise McapTooLarge(f"its chunks expand to more than {limit:,} bytes: more than this kind of file "
                                   "holds")
        elif op == 0x02:  # Footer: the end
            break
        pos = body + length
    return total


def read_mcap(data: bytes, topics: Iterable[str] | None = None,
              ordered: bool = True, max_expanded_bytes: int | None = None) -> list[tuple[str, str, Any, int]]:
    """The messages of a ROS 2 MCAP (of ``topics``, else all), in log-time order (``ordered``; else in
    the file's order, which the writer makes the same, and a third faster): (topic, type name,
    the message decoded by ``mcap_ros2`` from the definitions stored in the file, log time [ns]);
    the chunks' CRCs checked. Fields are attributes (``msg.header.stamp.sec``), sequences lists. The
    chunks' sizes are checked before any is decompressed (:func:`mcap_expanded_bytes`, with
    ``max_expanded_bytes``).

    Raises:
        Exception: of many kinds on a corrupt file or one not in the ROS 2 profile (the callers turn
            them into bad input); :class:`McapTooLarge` for chunks that would expand beyond the bound.
    """
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    mcap_expanded_bytes(data, max_expanded_bytes)

    reader = make_reader(io.BytesIO(data), validate_crcs=True, decoder_factories=[DecoderFactory()])
    profile = reader.get_header().profile
    if profile != "ros2":
        raise ValueError(f"profile {profile!r}, not 'ros2' (written by an older jethr1? write it again)")
    wanted = None if topics is None else list(topics)
    return [(channel.topic, schema.name if schema is not None else "", msg, message.log_time)
            for schema, channel, message, msg in reader.iter_decoded_messages(topics=wanted, log_time_order=ordered)]


# --- message builders (value trees, one value per message where they vary) -----------------------------


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
