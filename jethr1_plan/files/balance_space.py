"""Files of ``jethr1 balance-space``: CSV, MCAP (point clouds and cells), the Fig. 5 style PNG, summary."""

from __future__ import annotations

import io
import math
from typing import Protocol, TextIO

import numpy as np

from jethr1_plan.files.mcap import MARKERS, Ros2Mcap, Topic
from jethr1_plan.files.messages import cube_marker, point_cloud2
from jethr1_plan.io.csv_table import number_text as num
from jethr1_plan.reasons import Reason, message
from jethr1_plan.records.plan_columns import PELVIS, REASON

__all__ = ["BALANCE_SPACE_COLUMNS", "BALANCE_SPACE_TOPICS", "Sweep", "SweepGrid", "balance_space_csv",
           "balance_space_mcap", "balance_space_png", "least_thrust_columns", "write_balance_space_csv"]


class SweepGrid(Protocol):
    """What these files read of a sweep's grid (``balance_space.spec.SweepSpec``)."""

    @property
    def support_side(self) -> str: ...
    @property
    def swing_side(self) -> str: ...
    @property
    def support_xyz(self) -> tuple[float, float, float] | None: ...
    @property
    def support(self) -> tuple[float, float, float]: ...  # the support sole's centre [m]
    @property
    def resolution_m(self) -> float: ...
    @property
    def fan_limit_n(self) -> float: ...  # the limit on every fan [N]
    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...  # grid coordinates along x, y, z [m]


class Sweep(Protocol):
    """What these files read of a sweep (``balance_space.sweep.SweepResult``): every cell, x-major."""

    @property
    def spec(self) -> SweepGrid: ...
    @property
    def thrust(self) -> np.ndarray: ...  # (N,) the least thrust [N] (inf where nothing balances)
    @property
    def p_body(self) -> np.ndarray: ...  # (N, 3) the best posture [m]
    @property
    def reason(self) -> np.ndarray: ...  # (N,) reason codes
    @property
    def with_thrust(self) -> np.ndarray: ...  # (N,) the cells in balance with thrust
    @property
    def without_thrust(self) -> np.ndarray: ...  # (N,) the cells in balance without
    def swing_at(self, mask: np.ndarray) -> np.ndarray: ...  # the swing sole centres [m] of the cells ``mask`` picks
    def cell_yaw(self, swing: np.ndarray) -> np.ndarray: ...  # (k,) the body yaw (A-4) [rad] of swing soles (k, 3)

#: the topics of ``balance_space.mcap`` (ROS 2 profile, :mod:`.mcap`), in the order the file registers them
BALANCE_SPACE_TOPICS: dict[str, Topic] = {
    "/support_sole": Topic(MARKERS, True, "the support sole, a CUBE"),
    "/balance_space/with_thrust": Topic("sensor_msgs/msg/PointCloud2", True,
                                        "the cells the swing sole reaches in balance with thrust: float32 x, y, z "
                                        "[m] and `min_thrust_n` [N]"),
    "/balance_space/without_thrust": Topic("sensor_msgs/msg/PointCloud2", True,
                                           "the cells it reaches without thrust (same fields)"),
    "/balance_space/cells": Topic(MARKERS, True, "both spaces as CUBE_LISTs of the grid's cells, coloured by the "
                                                 "least thrust (viridis, 0 to the fan limit)"),
}
#: least-thrust colours of the cells: viridis at 0, 1/4, 1/2, 3/4 and 1 of the fan limit
_VIRIDIS = np.array([(0.267, 0.005, 0.329), (0.229, 0.322, 0.546), (0.128, 0.567, 0.551), (0.369, 0.789, 0.383),
                     (0.993, 0.906, 0.144)])


#: the columns of balance_space.csv
BALANCE_SPACE_COLUMNS = ("x_m", "y_m", "z_m", "min_thrust_n", *PELVIS, "pelvis_yaw_rad", REASON)


def balance_space_csv(r: Sweep) -> str:
    """balance_space.csv as text (:func:`write_balance_space_csv`)."""
    out = io.StringIO()
    write_balance_space_csv(r, out)
    return out.getvalue()


def write_balance_space_csv(r: Sweep, out: TextIO) -> None:
    """Write balance_space.csv to ``out``: x_m, y_m, z_m, min_thrust_n (empty outside the space with thrust),
    best pelvis, reason.

    Written one x slice at a time, column-wise within it (each axis value's text once): 906,471 cells in ~1.5 s
    where a row at a time took 15 s, with one slice's text (~0.3 MB at 1 cm) held at a time, not the file's
    (49 MB); the same bytes (``tests/files/test_balance_space.py``)."""
    words = {int(k): ",,,,," + message(k) for k in np.unique(r.reason)}
    axes = r.spec.axes()
    ax, ay, az = ([num(v) for v in a.tolist()] for a in axes)
    heads = [f"{y},{z}," for y in ay for z in az]
    n = len(heads)
    nz = len(axes[2])
    out.write(",".join(BALANCE_SPACE_COLUMNS) + "\n")
    for i, x in enumerate(ax):
        sl = slice(i * n, (i + 1) * n)
        m = r.reason[sl] == Reason.OK
        tails: list[str] = [""] * n
        inside = np.flatnonzero(m)
        if len(inside):
            # the body yaw depends on the cell's x and y alone: its text once per column of cells
            ys, column = np.unique(inside // nz, return_inverse=True)
            yaw = r.cell_yaw(np.column_stack([np.full(len(ys), axes[0][i]), axes[1][ys], np.zeros(len(ys))]))
            yaw_text = [num(v) for v in yaw.tolist()]
            cols = [r.thrust[sl][inside], *r.p_body[sl][inside].T]
            texts = [[num(v) for v in c.tolist()] for c in cols]
            for k, a, b, c, d, j in zip(inside.tolist(), *texts, column.tolist(), strict=True):
                tails[k] = f"{a},{b},{c},{d},{yaw_text[j]},"
        outside = np.flatnonzero(~m)
        for k, code, t in zip(outside.tolist(), r.reason[sl][outside].tolist(), r.thrust[sl][outside].tolist(),
                              strict=True):
            tails[k] = words[code] + (f" ({t:.2f} N needed)" if math.isfinite(t) else "")
        x_ = x + ","
        out.write("".join([x_ + h + t + "\n" for h, t in zip(heads, tails, strict=True)]))


def _thrust_colors(thrust_n: np.ndarray, fmax_n: float) -> dict:
    """``std_msgs/ColorRGBA`` per cell (as columns, float32 as the message holds them): viridis of ``thrust_n`` /
    ``fmax_n``."""
    s = np.clip(np.asarray(thrust_n, dtype=float) / fmax_n if fmax_n > 0 else 0.0, 0.0, 1.0)
    grid = np.linspace(0.0, 1.0, len(_VIRIDIS))
    return {**{c: np.interp(s, grid, _VIRIDIS[:, k]).astype(np.float32) for k, c in enumerate("rgb")},
            "a": np.ones(len(s), np.float32)}


def balance_space_mcap(r: Sweep, sole_length_m: float, sole_width_m: float) -> bytes:
    """The MCAP bytes of a balance-space sweep (topics :data:`BALANCE_SPACE_TOPICS`): the support
    sole; the cells of each space as a point cloud and as cubes coloured by the least thrust."""
    out = Ros2Mcap(BALANCE_SPACE_TOPICS)
    x, y, z = r.spec.support
    out.write("/support_sole", 0.0, {"markers": [cube_marker("support_sole", 0, (x, y, z - 0.005),
                                                              (sole_length_m, sole_width_m, 0.01),
                                                              (0.2, 0.2, 0.9, 1.0))]})
    cells, res = [], float(r.spec.resolution_m)
    for k, (topic, mask) in enumerate((("/balance_space/with_thrust", r.with_thrust),
                                       ("/balance_space/without_thrust", r.without_thrust))):
        pts, thrust = r.swing_at(mask), np.asarray(r.thrust, dtype=float)[mask]
        out.write(topic, 0.0, point_cloud2(pts, {"min_thrust_n": thrust}))
        cells.append({**cube_marker(topic.rsplit("/", 1)[1], k, (0.0, 0.0, 0.0), (res, res, res), (1, 1, 1, 1)),
                      "type": 6, "points": {"x": pts[:, 0], "y": pts[:, 1], "z": pts[:, 2]},
                      "colors": _thrust_colors(thrust, float(r.spec.fan_limit_n))})
    out.write("/balance_space/cells", 0.0, {"markers": cells})
    del cells, pts, thrust  # (encoded: let go before the chunks are written)
    return out.finish()


def least_thrust_columns(r: Sweep, mask: np.ndarray, hidden: int) -> np.ndarray:
    """The least thrust [N] of the cells ``mask`` selects in each column of the grid along axis ``hidden``
    (0 x, 1 y, 2 z): an (n_a, n_b) image over the two other axes in their order, NaN where the column holds
    none of them (what a top or side view of the space shows)."""
    shape = tuple(len(a) for a in r.spec.axes())
    idx = np.unravel_index(np.flatnonzero(mask), shape)
    kept = [k for k in range(3) if k != hidden]
    image = np.full((shape[kept[0]], shape[kept[1]]), np.inf)
    np.minimum.at(image, (idx[kept[0]], idx[kept[1]]), np.asarray(r.thrust, dtype=float)[mask])
    image[np.isinf(image)] = np.nan
    return image


def _view_box(r: Sweep) -> tuple[np.ndarray, np.ndarray]:
    """The corners [m] of the box the views show: the space with thrust (the larger) and the support sole, two
    cells beyond; the whole grid if the space is empty."""
    grid = r.spec.axes()
    pts = r.swing_at(r.with_thrust)
    if not len(pts):
        return np.array([a[0] for a in grid]), np.array([a[-1] for a in grid])
    pad = 2 * r.spec.resolution_m
    sup = np.asarray(r.spec.support_xyz)
    return np.minimum(pts.min(axis=0), sup) - pad, np.maximum(pts.max(axis=0), sup) + pad


def balance_space_png(r: Sweep, sole_length_m: float, sole_width_m: float) -> bytes:
    """Fig. 5 as a picture: without and with thrust, top (x–y) and side (x–z) views, each pixel block a column of
    cells coloured by its least thrust (:func:`least_thrust_columns`), the support sole drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    fig, axes = plt.subplots(2, 2, figsize=(11, 9), constrained_layout=True)
    sup = np.asarray(r.spec.support_xyz)
    fmax = r.spec.fan_limit_n
    grid = r.spec.axes()
    half = r.spec.resolution_m / 2
    lo, hi = _view_box(r)
    for row, (title, mask) in enumerate((("without thrust (F = 0)", r.without_thrust),
                                         (f"with thrust (F ≤ {fmax:g} N)", r.with_thrust))):
        for col, (b, hidden, lb) in enumerate(((1, 2, "y [m]"), (2, 1, "z [m]"))):
            ax = axes[row, col]
            image = least_thrust_columns(r, mask, hidden)
            extent = (grid[0][0] - half, grid[0][-1] + half, grid[b][0] - half, grid[b][-1] + half)
            im = ax.imshow(image.T, origin="lower", extent=extent, cmap="viridis", vmin=0, vmax=fmax,
                           interpolation="nearest", aspect="equal" if b == 1 else "auto")
            fig.colorbar(im, ax=ax, label="least thrust [N]")
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[b], hi[b])
            if b == 1:
                ax.add_patch(Rectangle((sup[0] - sole_length_m / 2, sup[1] - sole_width_m / 2), sole_length_m,
                                       sole_width_m, fill=True, color="tab:red", alpha=0.8, label="support sole"))
            else:
                ax.plot([sup[0] - sole_length_m / 2, sup[0] + sole_length_m / 2], [sup[2], sup[2]], color="tab:red",
                        lw=4, label="support sole")
            ax.set_xlabel("x [m]")
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
