"""The messages of jethr1's MCAP files logged into a Rerun recording, one handler per message type
(:data:`HANDLERS`): the robot from its URDF moved by ``/tf``, markers as boxes, lines and labelled points, point
clouds coloured by their first value, poses as moving points, thrust, its window, the ZMP margin and a walk's
figures as plots; one timeline, :data:`TIMELINE`, in seconds from the start. Rerun is imported only here, and
only when a view is asked for (:func:`rerun`).
"""

from __future__ import annotations

import tempfile
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from jethr1_plan.files.messages import EPOCH_NS
from jethr1_plan.records import topics as tp
from jethr1_plan.records.plan_columns import ZMP_MARGIN

__all__ = ["HANDLERS", "TIMELINE", "VIEW_EXTRA", "Scene", "ViewerMissing", "cloud_fields", "rerun", "since_start"]


VIEW_EXTRA = "jethr1 view needs the optional extra: pip install 'jethr1-plan[view]'"


TIMELINE = "time"  # seconds from the start of the scenario


class ViewerMissing(RuntimeError):
    """Rerun is not installed."""


@dataclass
class Scene:
    """What the files gave: the plots drawn (their groups) and every point logged in the world [m]."""

    plots: set[str] = field(default_factory=set)
    points: list[np.ndarray] = field(default_factory=list)


def rerun() -> Any:
    """The ``rerun`` module (the optional extra).

    Raises:
        ViewerMissing: it is not installed.
    """
    try:
        import rerun
    except ImportError:
        raise ViewerMissing(VIEW_EXTRA) from None
    return rerun


def since_start(log_ns: list[int]) -> np.ndarray:
    """Times from the start of log times [ns], exactly (as numpy durations)."""
    return (np.asarray(log_ns, dtype=np.int64) - EPOCH_NS).astype("timedelta64[ns]")


def _world(rr: Any) -> Any:
    return rr.CoordinateFrame("world")


_TINT = {"rehearsal": 0xF4A261FF}  # the rehearsal's robot in orange (RGBA), the plan's in the URDF's colours


def _robot(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: Scene) -> None:
    """The URDF of ``std_msgs/String``: its links' visual geometry on frames named as its links (no
    joint transforms: the file's /tf and /tf_static place them)."""
    rr = rerun()
    import pyarrow as pa
    from rerun.chunk import Chunk
    from rerun.urdf import UrdfTree

    with tempfile.TemporaryDirectory() as tmp:
        urdf = Path(tmp) / "robot.urdf"
        urdf.write_text(msgs[0].data, encoding="utf-8")
        tree = UrdfTree.from_file_path(urdf, prefix, static_transform_entity_path=f"/{prefix}/urdf_tf")
        chunks = [c for c in tree.stream(include_joint_transforms=False)
                  if "/collision_geometries/" not in c.entity_path]
    tint = _TINT.get(prefix)
    if tint is not None:
        tinted = []
        for c in chunks:
            batch = c.to_record_batch()
            for k, name in enumerate(batch.schema.names):
                if name.endswith(":colors"):
                    f = batch.schema.field(k)
                    batch = batch.set_column(k, f, pa.array([[tint]] * batch.num_rows, type=f.type))
            tinted += Chunk.from_record_batch(batch, index=None, entity_path=c.entity_path)
        chunks = tinted
    rr.send_chunks(chunks, recording=rec)


def _transforms(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: Scene) -> None:
    """``tf2_msgs/TFMessage``: per child frame, its parent → child transform over time (static for
    /tf_static)."""
    rr = rerun()
    static = path.endswith(tp.TF_STATIC)
    series: dict[str, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    for t, msg in zip(times, msgs, strict=True):
        for ts in msg.transforms:
            s = series[ts.child_frame_id]
            tr, ro = ts.transform.translation, ts.transform.rotation
            s["t"].append(t)
            s["parent"].append(ts.header.frame_id)
            s["translation"].append((tr.x, tr.y, tr.z))
            s["quaternion"].append((ro.x, ro.y, ro.z, ro.w))
    for child, s in series.items():
        entity = f"{path}/{child.replace('/', '_')}"
        if static:
            rec.log(entity, rr.Transform3D(translation=s["translation"][-1], quaternion=s["quaternion"][-1],
                                           parent_frame=s["parent"][-1], child_frame=child), static=True)
            continue
        rec.send_columns(entity, indexes=[rr.TimeColumn(TIMELINE, duration=since_start(s["t"]))],
                         columns=rr.Transform3D.columns(translation=s["translation"], quaternion=s["quaternion"],
                                                        parent_frame=s["parent"], child_frame=[child] * len(s["t"])))


_POINT_COLORS = {tp.COM: (230, 57, 70), tp.ZMP: (42, 157, 143), tp.P_BODY: (120, 120, 120),
                 tp.SWING_SOLE: (25, 150, 255), "/com_ref": (244, 162, 97), "/zmp_ref": (38, 70, 83),
                 "/sim/com": (230, 57, 70), "/sim/cop": (233, 196, 106)}


def _poses(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: Scene) -> None:
    """``geometry_msgs/PoseStamped``: a moving point, and its path as a faint line."""
    rr = rerun()
    xyz = np.array([(m.pose.position.x, m.pose.position.y, m.pose.position.z) for m in msgs], dtype=float)
    topic = path[len(prefix) + 1:]
    color = _POINT_COLORS.get(topic, (200, 200, 200))
    scene.points.append(xyz)
    rec.log(path, _world(rr), rr.Points3D.from_fields(radii=0.012, colors=[color]), static=True)
    rec.send_columns(path, indexes=[rr.TimeColumn(TIMELINE, duration=since_start(times))],
                     columns=rr.Points3D.columns(positions=xyz))
    if len(xyz) > 1:
        rec.log(f"{path}_path", _world(rr), rr.LineStrips3D([xyz], radii=0.002, colors=[(*color, 110)]), static=True)


def _color(c: Any) -> tuple[int, int, int, int]:
    r, g, b, a = (round(255 * max(0.0, min(1.0, v))) for v in (c.r, c.g, c.b, c.a))
    return r, g, b, a


def _markers(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: Scene) -> None:
    """``visualization_msgs/MarkerArray`` (the last message): CUBEs and CUBE_LISTs as boxes,
    LINE_STRIPs as lines, SPHEREs as points and TEXT_VIEW_FACINGs as labelled points."""
    rr = rerun()
    boxes: dict[str, list] = defaultdict(list)
    texts: dict[str, list] = defaultdict(list)
    for m in msgs[-1].markers:
        entity = f"{path}/{m.ns or 'marker'}_{m.id}"
        scale = np.array([m.scale.x, m.scale.y, m.scale.z])
        if m.type == 1:  # CUBE
            p, q = m.pose.position, m.pose.orientation
            boxes[f"{path}/{m.ns or 'marker'}"].append(((p.x, p.y, p.z), scale / 2, (q.x, q.y, q.z, q.w),
                                                        _color(m.color)))
            scene.points.append(np.array([[p.x, p.y, p.z + m.scale.z / 2]]))
        elif m.type == 6 and m.points:  # CUBE_LIST
            centres = np.array([(p.x, p.y, p.z) for p in m.points], dtype=float)
            scene.points.append(centres)
            colors = [_color(c) for c in m.colors] if m.colors else [_color(m.color)]
            rec.log(entity, _world(rr), rr.Boxes3D(centers=centres, half_sizes=[scale / 2], colors=colors,
                                                   fill_mode="solid"), static=True)
        elif m.type == 4 and m.points:  # LINE_STRIP
            pts = np.array([(p.x, p.y, p.z) for p in m.points], dtype=float)
            rec.log(entity, _world(rr), rr.LineStrips3D([pts], radii=m.scale.x / 2, colors=[_color(m.color)]),
                    static=True)
        elif m.type == 2:  # SPHERE
            p = m.pose.position
            rec.log(entity, _world(rr), rr.Points3D([(p.x, p.y, p.z)], radii=m.scale.x / 2, colors=[_color(m.color)]),
                    static=True)
        elif m.type == 9:  # TEXT_VIEW_FACING
            p = m.pose.position
            texts[f"{path}/{m.ns or 'marker'}"].append(((p.x, p.y, p.z), m.text, _color(m.color)))
    for entity, labels in texts.items():
        rec.log(entity, _world(rr), rr.Points3D([x[0] for x in labels], labels=[x[1] for x in labels],
                                                colors=[x[2] for x in labels], radii=0.004, show_labels=True),
                static=True)
    for entity, cubes in boxes.items():
        rec.log(entity, _world(rr), rr.Boxes3D(centers=[c[0] for c in cubes], half_sizes=[c[1] for c in cubes],
                                               quaternions=[c[2] for c in cubes], colors=[c[3] for c in cubes],
                                               fill_mode="solid"), static=True)


_PCL_TYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}  # PointField datatypes


def cloud_fields(msg: Any) -> dict[str, np.ndarray]:
    """The fields of a ``sensor_msgs/PointCloud2`` (one value each) as arrays (points,), decoded from its bytes
    by the offsets, datatypes and byte order it declares."""
    order = ">" if msg.is_bigendian else "<"
    n = int(msg.width) * int(msg.height)
    dtype = np.dtype({"names": [f.name for f in msg.fields],
                      "formats": [order + _PCL_TYPES[int(f.datatype)] for f in msg.fields],
                      "offsets": [int(f.offset) for f in msg.fields], "itemsize": int(msg.point_step)})
    data = np.frombuffer(bytes(msg.data), dtype=dtype, count=n)
    return {f.name: data[f.name].astype(float) for f in msg.fields}


def _cloud(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: Scene) -> None:
    """``sensor_msgs/PointCloud2``: its points at each message's time (one message at the start: for good),
    coloured by the first field after x, y, z (viridis from 0 to its largest value)."""
    rr = rerun()
    from matplotlib import colormaps

    clouds = [cloud_fields(m) for m in msgs]
    extra = [k for k in clouds[0] if k not in ("x", "y", "z")] if clouds else []
    top = max((float(np.nanmax(c[extra[0]])) for c in clouds if extra and len(c[extra[0]])), default=0.0)
    once = len(msgs) == 1 and times[0] == EPOCH_NS
    for t, c in zip(times, clouds, strict=True):
        xyz = np.column_stack([c["x"], c["y"], c["z"]])
        scene.points.append(xyz)
        colors = None
        if extra:
            shade = np.nan_to_num(c[extra[0]] / top, nan=0.0) if top > 0 else np.zeros(len(xyz))
            colors = (255 * colormaps["viridis"](np.clip(shade, 0.0, 1.0))).astype(np.uint8)
        if not once:
            rec.set_time(TIMELINE, duration=since_start([t])[0])
        rec.log(path, _world(rr), rr.Points3D(xyz, colors=colors, radii=0.004), static=once)
    if not once:
        rec.reset_time()


def _plot(rec: Any, entity: str, times: list[int], values: np.ndarray, name: str, color: tuple[int, int, int],
          scene: Scene, width: float = 1.5) -> None:
    rr = rerun()
    rec.log(entity, rr.SeriesLines(names=name, colors=[color], widths=width), static=True)
    rec.send_columns(entity, indexes=[rr.TimeColumn(TIMELINE, duration=since_start(times))],
                     columns=rr.Scalars.columns(scalars=np.asarray(values, dtype=float)))
    scene.plots.add(entity.split("/")[2])


_FAN_COLORS = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (148, 103, 189)]


def _thrust(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: Scene) -> None:
    """``jethr1_msgs/Thrust``: thrust per fan, its window, the ZMP margin."""
    fans = list(msgs[0].fan)
    thrust = np.array([m.thrust_n for m in msgs], dtype=float).reshape(len(msgs), len(fans))
    for k, fan in enumerate(fans):
        _plot(rec, f"/plots/thrust/plan_{fan}", times, thrust[:, k], f"{fan} fan (plan) [N]",
              _FAN_COLORS[k % len(_FAN_COLORS)], scene, 2.0)
    for side in ("lo", "hi"):
        _plot(rec, f"/plots/thrust/window_{side}", times, np.array([getattr(m, f"window_{side}_n") for m in msgs]),
              f"window {'low' if side == 'lo' else 'high'} [N]", (150, 150, 150), scene, 1.0)
    _plot(rec, "/plots/zmp_margin/plan", times, np.array([m.zmp_margin_m for m in msgs]), "ZMP margin (plan) [m]",
          (42, 157, 143), scene)


def _fan_thrust(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: Scene) -> None:
    """``jethr1_msgs/FanThrust``: the thrust each fan applied (a rehearsal)."""
    frames = list(msgs[0].frame)
    thrust = np.array([m.thrust_n for m in msgs], dtype=float).reshape(len(msgs), len(frames))
    for k, frame in enumerate(frames):
        name = frame.rsplit("/", 1)[-1].removesuffix("_fan")
        _plot(rec, f"/plots/thrust/{prefix}_{name}", times, thrust[:, k], f"{name} fan ({prefix}) [N]",
              tuple(int(0.55 * c + 0.45 * 255) for c in _FAN_COLORS[k % len(_FAN_COLORS)]),  # type: ignore[arg-type]
              scene, 1.5)


def _walk_analysis(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: Scene) -> None:
    """``jethr1_msgs/WalkAnalysis``: pelvic yaw and its reference, yaw momentum, κ, ZMP margin."""
    def col(name: str) -> np.ndarray:
        return np.array([getattr(m, name) for m in msgs], dtype=float)

    _plot(rec, "/plots/yaw/yaw", times, np.degrees(col("yaw_rad")), "pelvic yaw [deg]", (214, 39, 40), scene)
    _plot(rec, "/plots/yaw/yaw_ref", times, np.degrees(col("yaw_ref_rad")), "reference (B-30) [deg]",
          (127, 127, 127), scene, 1.0)
    _plot(rec, "/plots/momentum/lower", times, col("h_lower_nms"), "lower body [N·m·s]", (31, 119, 180), scene)
    _plot(rec, "/plots/momentum/upper", times, col("h_upper_nms"), "arms [N·m·s]", (44, 160, 44), scene)
    _plot(rec, "/plots/kappa/kappa", times, col("kappa"), "κ(J_low)", (148, 103, 189), scene)
    _plot(rec, "/plots/zmp_margin/walk", times, col(ZMP_MARGIN), "ZMP margin [m]", (42, 157, 143), scene)


HANDLERS: dict[str, Callable[..., None]] = {
    "std_msgs/msg/String": _robot,
    "tf2_msgs/msg/TFMessage": _transforms,
    "geometry_msgs/msg/PoseStamped": _poses,
    "visualization_msgs/msg/MarkerArray": _markers,
    "jethr1_msgs/msg/Thrust": _thrust,
    "jethr1_msgs/msg/FanThrust": _fan_thrust,
    "jethr1_msgs/msg/WalkAnalysis": _walk_analysis,
    "sensor_msgs/msg/PointCloud2": _cloud,
}
