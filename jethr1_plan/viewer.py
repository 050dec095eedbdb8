"""``jethr1 view``: a plan folder (with its rehearsal, if simulated), a route folder (its plan and
``route.mcap``), a walk folder or a balance space in Rerun, from the MCAP files written there (what the
files say, not what a planner remembers).

The robot is built from the URDF each file carries and moved by its ``/tf`` (the rehearsal's frames
prefixed ``sim/``, so both robots play in one scene); the markers (cartons, swing paths,
footsteps, the support sole, the balance-space cells, the route's footholds) become boxes, lines and
labelled points; point clouds (the balance space's, the slices a route judged each step on) become
points coloured by their first value (the least thrust); CoM, ZMP and the other poses become moving
points; the thrust of each fan (planned and applied), its window, the ZMP margin and a walk's figures
become plots. One timeline, ``time``: seconds from the start.

Rerun is an optional extra (``pip install 'jethr1-plan[view]'``); nothing here imports it until a
view is asked for.
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.mcap import EPOCH_NS, read_mcap
from jethr1_plan.files.plan_folder import check_belongs, rehearsal_of
from jethr1_plan.files.plan_mcap import MAX_MCAP_BYTES
from jethr1_plan.io.input_file import check_input_path, read_input
from jethr1_plan.records import topics as tp
from jethr1_plan.records.plan_columns import ZMP_MARGIN

__all__ = ["VIEW_EXTRA", "ViewFiles", "ViewerMissing", "cloud_fields", "has_display", "record", "view", "view_files"]

VIEW_EXTRA = "jethr1 view needs the optional extra: pip install 'jethr1-plan[view]'"
TIMELINE = "time"  # seconds from the start of the scenario


class ViewerMissing(RuntimeError):
    """Rerun is not installed."""


@dataclass
class _Scene:
    """What the files gave: the plots drawn (their groups) and every point logged in the world [m]."""

    plots: set[str] = field(default_factory=set)
    points: list[np.ndarray] = field(default_factory=list)


@dataclass
class ViewFiles:
    """What a path holds: its kind (``plan``, ``route``, ``walk``, ``balance space``, ``rehearsal``) and the
    MCAP files to show, each with the entity path its content goes under."""

    kind: str
    files: list[tuple[Path, str]] = field(default_factory=list)


def _topics(path: Path) -> set[str]:
    from mcap.reader import make_reader

    try:
        with path.open("rb") as f:
            summary = make_reader(f).get_summary()
    except Exception as exc:  # the mcap reader raises many kinds on a corrupt file
        raise InputError(str(path), "", f"not a valid MCAP file ({type(exc).__name__})") from None
    return set() if summary is None else {c.topic for c in summary.channels.values()}


def _kind(path: Path) -> str:
    topics = _topics(path)
    for topic, kind in ((tp.THRUST, "plan"), ("/walk_analysis", "walk"), ("/sim/thrust", "rehearsal"),
                        ("/balance_space/cells", "balance space"), ("/route/footsteps", "route")):
        if topic in topics:
            return kind
    raise InputError(str(path), "", "not an MCAP file jethr1 writes (no /thrust, /walk_analysis, /sim/thrust, "
                     "/balance_space/cells or /route/footsteps)")


def view_files(path: Path) -> ViewFiles:
    """The MCAP files of a plan folder (``trajectory.mcap`` and ``simulation.mcap`` if present), a route
    folder (its plan's and ``route.mcap``), a walk folder, a balance-space folder, or one of those files.

    Raises:
        InputError: no such path, or nothing jethr1 writes there.
    """
    path = Path(path)
    check_input_path(path, "a plan, route, walk or balance-space folder, or one of their MCAP files")
    if path.is_file():
        kind = _kind(path)
        return ViewFiles(kind, [(path, "rehearsal" if kind == "rehearsal" else kind.replace(" ", "_"))])
    if not path.is_dir():
        raise InputError(str(path), "", "no such file or folder")
    if (path / "balance_space.mcap").is_file():
        return ViewFiles("balance space", [(path / "balance_space.mcap", "balance_space")])
    trajectory, route = path / "trajectory.mcap", path / "route.mcap"
    if not trajectory.is_file():
        if route.is_file():
            return ViewFiles(_kind(route), [(route, "route")])
        raise InputError(str(path), "", "no trajectory.mcap, route.mcap or balance_space.mcap in this folder")
    kind = _kind(trajectory)
    summary = check_belongs(path) if kind == "plan" else {}  # a plan folder is one thing: its MCAP is the one
    out = ViewFiles(kind, [(trajectory, kind)])                 # its summary.json records
    if kind == "plan" and (path / "simulation.mcap").is_file() and rehearsal_of(path, summary):
        out.files.append((path / "simulation.mcap", "rehearsal"))
    if kind == "plan" and route.is_file():
        if _kind(route) != "route":
            raise InputError(str(route), "", "not a route.mcap jethr1 writes (no /route/footsteps)")
        out.kind = "route"
        out.files.append((route, "route"))
    return out


def has_display() -> bool:
    """A screen a native Rerun viewer can open on (macOS and Windows always have one)."""
    return sys.platform in ("darwin", "win32") or bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _rerun() -> Any:
    try:
        import rerun
    except ImportError:
        raise ViewerMissing(VIEW_EXTRA) from None
    return rerun


def view(path: Path, save: Path | None = None) -> str:
    """Show ``path`` in a Rerun viewer, or with ``save`` write the recording to that ``.rrd`` file;
    a sentence saying what was done.

    Raises:
        ViewerMissing: Rerun is not installed.
        InputError: see :func:`view_files`; no display and no ``save``.
    """
    rr = _rerun()
    found = view_files(path)
    messages = [_read(f) for f, _ in found.files]  # every file decoded before anything is written
    if save is None and not has_display():
        raise InputError(str(path), "", "no display to open a viewer on: save the recording with --save FILE.rrd "
                         "and open it with `rerun FILE.rrd` where there is one")
    rec = rr.RecordingStream("jethr1", recording_id=f"jethr1 {found.kind} {Path(path).resolve()}")
    if save is not None:
        rec.save(str(save))
    else:
        rec.spawn()
    record(rec, found, messages)
    rec.flush()
    if save is not None:
        rec.disconnect()
        return f"wrote {save} ({found.kind}: {', '.join(f.name for f, _ in found.files)}); open it with `rerun {save}`"
    return f"sent {found.kind} ({', '.join(f.name for f, _ in found.files)}) to the Rerun viewer"


# --- the recording --------------------------------------------------------------------------------


def _read(path: Path) -> list:
    """Every message of one file (:func:`~jethr1_plan.files.mcap.read_mcap`).

    Raises:
        InputError: not a ROS 2 MCAP file.
    """
    data = read_input(path, MAX_MCAP_BYTES, "an MCAP file")
    try:
        return read_mcap(data)
    except Exception as exc:  # the mcap readers raise many kinds on a corrupt or foreign file
        raise InputError(str(path), "", f"not a readable MCAP file ({type(exc).__name__}: {str(exc)[:80]})") from None


def record(rec: Any, found: ViewFiles, messages: list[list] | None = None) -> None:
    """Log every file of ``found`` (its ``messages`` if already read) into the recording ``rec``, with a
    blueprint for its kind."""
    rr = _rerun()
    rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    scene = _Scene()
    if messages is None:
        messages = [_read(f) for f, _ in found.files]
    for (_, prefix), file_messages in zip(found.files, messages, strict=True):
        _log_file(rec, file_messages, prefix, scene)
    rec.send_blueprint(_blueprint(found.kind, scene))


def _since_start(log_ns: list[int]) -> np.ndarray:
    """Times from the start of log times [ns], exactly (as numpy durations)."""
    return (np.asarray(log_ns, dtype=np.int64) - EPOCH_NS).astype("timedelta64[ns]")


def _log_file(rec: Any, messages: list, prefix: str, scene: _Scene) -> None:
    """Log one file's messages under ``/<prefix>`` (plots under ``/plots``)."""
    by_topic: dict[str, list] = defaultdict(list)
    types: dict[str, str] = {}
    for topic, type_name, msg, t in messages:
        by_topic[topic].append((t, msg))
        types[topic] = type_name
    for topic, got in by_topic.items():
        handler = _HANDLERS.get(types[topic])
        if handler is not None:
            handler(rec, f"/{prefix}{topic}", [t for t, _ in got], [m for _, m in got], prefix, scene)


def _world(rr: Any) -> Any:
    return rr.CoordinateFrame("world")


_TINT = {"rehearsal": 0xF4A261FF}  # the rehearsal's robot in orange (RGBA), the plan's in the URDF's colours


def _robot(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: _Scene) -> None:
    """The URDF of ``std_msgs/String``: its links' visual geometry on frames named as its links (no
    joint transforms: the file's /tf and /tf_static place them)."""
    rr = _rerun()
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


def _transforms(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: _Scene) -> None:
    """``tf2_msgs/TFMessage``: per child frame, its parent → child transform over time (static for
    /tf_static)."""
    rr = _rerun()
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
        rec.send_columns(entity, indexes=[rr.TimeColumn(TIMELINE, duration=_since_start(s["t"]))],
                         columns=rr.Transform3D.columns(translation=s["translation"], quaternion=s["quaternion"],
                                                        parent_frame=s["parent"], child_frame=[child] * len(s["t"])))


_POINT_COLORS = {tp.COM: (230, 57, 70), tp.ZMP: (42, 157, 143), tp.P_BODY: (120, 120, 120),
                 tp.SWING_SOLE: (25, 150, 255), "/com_ref": (244, 162, 97), "/zmp_ref": (38, 70, 83),
                 "/sim/com": (230, 57, 70), "/sim/cop": (233, 196, 106)}


def _poses(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: _Scene) -> None:
    """``geometry_msgs/PoseStamped``: a moving point, and its path as a faint line."""
    rr = _rerun()
    xyz = np.array([(m.pose.position.x, m.pose.position.y, m.pose.position.z) for m in msgs], dtype=float)
    topic = path[len(prefix) + 1:]
    color = _POINT_COLORS.get(topic, (200, 200, 200))
    scene.points.append(xyz)
    rec.log(path, _world(rr), rr.Points3D.from_fields(radii=0.012, colors=[color]), static=True)
    rec.send_columns(path, indexes=[rr.TimeColumn(TIMELINE, duration=_since_start(times))],
                     columns=rr.Points3D.columns(positions=xyz))
    if len(xyz) > 1:
        rec.log(f"{path}_path", _world(rr), rr.LineStrips3D([xyz], radii=0.002, colors=[(*color, 110)]), static=True)


def _color(c: Any) -> tuple[int, int, int, int]:
    r, g, b, a = (round(255 * max(0.0, min(1.0, v))) for v in (c.r, c.g, c.b, c.a))
    return r, g, b, a


def _markers(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: _Scene) -> None:
    """``visualization_msgs/MarkerArray`` (the last message): CUBEs and CUBE_LISTs as boxes,
    LINE_STRIPs as lines, SPHEREs as points and TEXT_VIEW_FACINGs as labelled points."""
    rr = _rerun()
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


def _cloud(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: _Scene) -> None:
    """``sensor_msgs/PointCloud2``: its points at each message's time (one message at the start: for good),
    coloured by the first field after x, y, z (viridis from 0 to its largest value)."""
    rr = _rerun()
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
            rec.set_time(TIMELINE, duration=_since_start([t])[0])
        rec.log(path, _world(rr), rr.Points3D(xyz, colors=colors, radii=0.004), static=once)
    if not once:
        rec.reset_time()


def _plot(rec: Any, entity: str, times: list[int], values: np.ndarray, name: str, color: tuple[int, int, int],
          scene: _Scene, width: float = 1.5) -> None:
    rr = _rerun()
    rec.log(entity, rr.SeriesLines(names=name, colors=[color], widths=width), static=True)
    rec.send_columns(entity, indexes=[rr.TimeColumn(TIMELINE, duration=_since_start(times))],
                     columns=rr.Scalars.columns(scalars=np.asarray(values, dtype=float)))
    scene.plots.add(entity.split("/")[2])


_FAN_COLORS = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (148, 103, 189)]


def _thrust(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: _Scene) -> None:
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


def _fan_thrust(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: _Scene) -> None:
    """``jethr1_msgs/FanThrust``: the thrust each fan applied (a rehearsal)."""
    frames = list(msgs[0].frame)
    thrust = np.array([m.thrust_n for m in msgs], dtype=float).reshape(len(msgs), len(frames))
    for k, frame in enumerate(frames):
        name = frame.rsplit("/", 1)[-1].removesuffix("_fan")
        _plot(rec, f"/plots/thrust/{prefix}_{name}", times, thrust[:, k], f"{name} fan ({prefix}) [N]",
              tuple(int(0.55 * c + 0.45 * 255) for c in _FAN_COLORS[k % len(_FAN_COLORS)]),  # type: ignore[arg-type]
              scene, 1.5)


def _walk_analysis(rec: Any, path: str, times: list[int], msgs: list, prefix: str, scene: _Scene) -> None:
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


_HANDLERS: dict[str, Callable[..., None]] = {
    "std_msgs/msg/String": _robot,
    "tf2_msgs/msg/TFMessage": _transforms,
    "geometry_msgs/msg/PoseStamped": _poses,
    "visualization_msgs/msg/MarkerArray": _markers,
    "jethr1_msgs/msg/Thrust": _thrust,
    "jethr1_msgs/msg/FanThrust": _fan_thrust,
    "jethr1_msgs/msg/WalkAnalysis": _walk_analysis,
    "sensor_msgs/msg/PointCloud2": _cloud,
}


def _eye(scene: _Scene) -> Any:
    """A camera looking at the middle of what was logged, from the front left and above, far enough
    to see all of it."""
    import rerun.blueprint as rrb

    if not scene.points:
        return None
    pts = np.concatenate([np.asarray(p, dtype=float).reshape(-1, 3) for p in scene.points])
    pts = pts[np.isfinite(pts).all(axis=1)]
    if not len(pts):
        return None
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    target = (lo + hi) / 2
    size = max(float(np.max(hi - lo)), 0.8)
    position = target + size * np.array([0.8, -1.2, 0.6])
    return rrb.archetypes.EyeControls3D(kind=rrb.components.Eye3DKind.Orbital, position=position, look_target=target,
                                        eye_up=(0.0, 0.0, 1.0))


def _blueprint(kind: str, scene: _Scene) -> Any:
    """A 3D view in the world frame beside the plots the files gave."""
    import rerun.blueprint as rrb

    view3d = rrb.Spatial3DView(origin="/", name=f"jethr1 {kind}", contents=["/**", "- /plots/**"],
                               spatial_information=rrb.archetypes.SpatialInformation(target_frame="world"),
                               eye_controls=_eye(scene))
    titles = {"thrust": "thrust [N]: per fan, planned and applied, with its window", "zmp_margin": "ZMP margin [m]",
              "yaw": "pelvic yaw [deg]", "momentum": "yaw momentum [N·m·s]", "kappa": "κ"}
    order = [p for p in ("thrust", "zmp_margin", "yaw", "momentum", "kappa") if p in scene.plots]
    if not order:
        return rrb.Blueprint(view3d, collapse_panels=True)
    graphs = [rrb.TimeSeriesView(origin=f"/plots/{p}", name=titles[p]) for p in order]
    return rrb.Blueprint(rrb.Horizontal(view3d, rrb.Vertical(*graphs), column_shares=[3, 2]), collapse_panels=True)
