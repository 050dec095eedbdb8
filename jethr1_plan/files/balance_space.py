"""Files of ``jethr1 balance-space``: CSV, MCAP point clouds, the Fig. 5 style PNG, summary."""

from __future__ import annotations

import base64
import io
import json

import numpy as np

from jethr1_plan.balance_space.sweep import SweepResult
from jethr1_plan.files.mcap import SCHEMAS, pose_message, scene_entity, stamp, vector3
from jethr1_plan.io.csv_table import csv_text
from jethr1_plan.io.csv_table import number_text as num
from jethr1_plan.reasons import message

__all__ = [
    "BALANCE_SPACE_COLUMNS",
    "FLOAT32",
    "POINT_CLOUD_SCHEMA",
    "balance_space_csv",
    "balance_space_mcap",
    "balance_space_png",
    "point_cloud",
]

POINT_CLOUD_SCHEMA = {
    "title": "foxglove.PointCloud", "type": "object",
    "properties": {
        "timestamp": SCHEMAS["foxglove.PoseInFrame"]["properties"]["timestamp"],
        "frame_id": {"type": "string"},
        "pose": SCHEMAS["foxglove.PoseInFrame"]["properties"]["pose"],
        "point_stride": {"type": "integer", "minimum": 0},
        "fields": {"type": "array", "items": {
            "title": "foxglove.PackedElementField", "type": "object",
            "properties": {"name": {"type": "string"}, "offset": {"type": "integer", "minimum": 0},
                           "type": {"type": "integer", "minimum": 0, "maximum": 8}},
            "required": ["name", "offset", "type"]}},
        "data": {"type": "string", "contentEncoding": "base64"},
    },
    "required": ["timestamp", "frame_id", "pose", "point_stride", "fields", "data"],
}
FLOAT32 = 7


#: the columns of balance_space.csv
BALANCE_SPACE_COLUMNS = ("x_m", "y_m", "z_m", "min_thrust_n", "pelvis_x_m", "pelvis_y_m", "pelvis_z_m",
                         "pelvis_yaw_rad", "reason")


def balance_space_csv(r: SweepResult) -> str:
    """x_m, y_m, z_m, min_thrust_n (empty outside the space with thrust), best pelvis, reason."""
    member = r.with_thrust

    def row(i: int) -> list[str]:
        x, y, z = r.swing[i]
        if member[i]:
            p = r.p_body[i]
            return [num(x), num(y), num(z), num(r.thrust[i]), num(p[0]), num(p[1]), num(p[2]), num(r.yaw[i]), ""]
        reason = message(r.reason[i])
        if np.isfinite(r.thrust[i]):
            reason += f" ({r.thrust[i]:.2f} N needed)"
        return [num(x), num(y), num(z), "", "", "", "", "", reason]

    return csv_text(BALANCE_SPACE_COLUMNS, (row(i) for i in range(len(r.swing))))


def point_cloud(points: np.ndarray, thrust: np.ndarray) -> dict:
    """A foxglove.PointCloud of float32 x, y, z, min_thrust_n."""
    data = np.concatenate([points, thrust[:, None]], axis=1).astype("<f4").tobytes()
    return {"timestamp": stamp(0.0), "frame_id": "world", "pose": pose_message((0, 0, 0)), "point_stride": 16,
            "fields": [{"name": n, "offset": 4 * k, "type": FLOAT32}
                       for k, n in enumerate(("x", "y", "z", "min_thrust_n"))],
            "data": base64.b64encode(data).decode()}


def balance_space_mcap(r: SweepResult, sole_length_m: float, sole_width_m: float) -> bytes:
    """/balance_space/with_thrust and /without_thrust point clouds, and /support_sole."""
    from mcap.writer import CompressionType, Writer

    buf = io.BytesIO()
    w = Writer(buf, compression=CompressionType.ZSTD)
    w.start(profile="", library="jethr1-plan")
    pc = w.register_schema(name="foxglove.PointCloud", encoding="jsonschema",
                           data=json.dumps(POINT_CLOUD_SCHEMA, sort_keys=True).encode())
    su = w.register_schema(name="foxglove.SceneUpdate", encoding="jsonschema",
                           data=json.dumps(SCHEMAS["foxglove.SceneUpdate"], sort_keys=True).encode())
    chans = {t: w.register_channel(topic=t, message_encoding="json", schema_id=pc)
             for t in ("/balance_space/with_thrust", "/balance_space/without_thrust")}
    sole = w.register_channel(topic="/support_sole", message_encoding="json", schema_id=su)
    for seq, (topic, mask) in enumerate((("/balance_space/with_thrust", r.with_thrust),
                                         ("/balance_space/without_thrust", r.without_thrust))):
        msg = point_cloud(r.swing[mask], r.thrust[mask])
        w.add_message(channel_id=chans[topic], log_time=0, publish_time=0, sequence=seq,
                      data=json.dumps(msg, separators=(",", ":")).encode())
    x, y, z = r.spec.support
    cube = {"pose": pose_message((x, y, z - 0.005)), "size": vector3((sole_length_m, sole_width_m, 0.01)),
            "color": {"r": 0.2, "g": 0.2, "b": 0.9, "a": 1.0}}
    w.add_message(channel_id=sole, log_time=0, publish_time=0, sequence=2,
                  data=json.dumps({"deletions": [],
                                   "entities": [scene_entity(0.0, "support_sole", cubes=[cube])]}).encode())
    w.finish()
    return buf.getvalue()


def balance_space_png(r: SweepResult, sole_length_m: float, sole_width_m: float) -> bytes:
    """Fig. 5 as a picture: without and with thrust, top (x–y) and side (x–z) views, support sole drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    fig, axes = plt.subplots(2, 2, figsize=(11, 9), constrained_layout=True)
    sup = np.asarray(r.spec.support_xyz)
    fmax = r.spec.fan_limit_n
    for row, (title, mask) in enumerate((("without thrust (F = 0)", r.without_thrust),
                                         (f"with thrust (F ≤ {fmax:g} N)", r.with_thrust))):
        pts, thr = r.swing[mask], r.thrust[mask]
        for col, (a, b, la, lb) in enumerate(((0, 1, "x [m]", "y [m]"), (0, 2, "x [m]", "z [m]"))):
            ax = axes[row, col]
            if len(pts):
                # one marker per column of cells: the least thrust over the hidden axis
                key = np.round(pts[:, [a, b]], 6)
                uniq, inv = np.unique(key, axis=0, return_inverse=True)
                best = np.full(len(uniq), np.inf)
                np.minimum.at(best, inv.ravel(), thr)
                sc = ax.scatter(uniq[:, 0], uniq[:, 1], c=best, s=4, marker="s", cmap="viridis", vmin=0, vmax=fmax)
                fig.colorbar(sc, ax=ax, label="least thrust [N]")
            if b == 1:
                ax.add_patch(Rectangle((sup[0] - sole_length_m / 2, sup[1] - sole_width_m / 2), sole_length_m,
                                       sole_width_m, fill=True, color="tab:red", alpha=0.8, label="support sole"))
                ax.set_aspect("equal")
            else:
                ax.plot([sup[0] - sole_length_m / 2, sup[0] + sole_length_m / 2], [sup[2], sup[2]], color="tab:red",
                        lw=4, label="support sole")
            ax.set_xlabel(la)
            ax.set_ylabel(lb)
            ax.set_title(f"{title}: {'top' if b == 1 else 'side'} view, {int(mask.sum())} cells")
            ax.legend(loc="lower left", fontsize=8)
            ax.grid(alpha=0.3)
    fig.suptitle(f"Balance space of the {r.spec.swing_side} sole, {r.spec.support_side} sole supporting "
                 f"(resolution {r.spec.resolution_m * 1000:g} mm)")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()
