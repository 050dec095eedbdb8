"""``jethr1 view``: the files of a path (:mod:`.files`) logged into one Rerun recording (:mod:`.topics`), shown in
a viewer or saved to an ``.rrd`` file, with a blueprint for their kind: a 3D view in the world frame beside the
plots the files gave.
"""

from __future__ import annotations

import os
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.mcap import read_mcap
from jethr1_plan.files.plan_mcap import MAX_MCAP_BYTES
from jethr1_plan.io.input_file import read_input
from jethr1_plan.viewer.files import ViewFiles, view_files
from jethr1_plan.viewer.topics import HANDLERS, Scene, rerun

__all__ = ["has_display", "record", "view"]


def has_display() -> bool:
    """A screen a native Rerun viewer can open on (macOS and Windows always have one)."""
    return sys.platform in ("darwin", "win32") or bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def view(path: Path, save: Path | None = None) -> str:
    """Show ``path`` in a Rerun viewer, or with ``save`` write the recording to that ``.rrd`` file;
    a sentence saying what was done.

    Raises:
        ViewerMissing: Rerun is not installed.
        InputError: see :func:`view_files`; no display and no ``save``.
    """
    rr = rerun()
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
    rr = rerun()
    rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    scene = Scene()
    if messages is None:
        messages = [_read(f) for f, _ in found.files]
    for (_, prefix), file_messages in zip(found.files, messages, strict=True):
        _log_file(rec, file_messages, prefix, scene)
    rec.send_blueprint(_blueprint(found.kind, scene))


def _log_file(rec: Any, messages: list, prefix: str, scene: Scene) -> None:
    """Log one file's messages under ``/<prefix>`` (plots under ``/plots``)."""
    by_topic: dict[str, list] = defaultdict(list)
    types: dict[str, str] = {}
    for topic, type_name, msg, t in messages:
        by_topic[topic].append((t, msg))
        types[topic] = type_name
    for topic, got in by_topic.items():
        handler = HANDLERS.get(types[topic])
        if handler is not None:
            handler(rec, f"/{prefix}{topic}", [t for t, _ in got], [m for _, m in got], prefix, scene)


def _eye(scene: Scene) -> Any:
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


def _blueprint(kind: str, scene: Scene) -> Any:
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
