"""Files of ``jethr1 route`` beside its plan: ``route.mcap`` (the terrain, the footholds, the route and
the balance-space slices it used) and ``route.png`` (a top view).

The plan itself (``trajectory.csv``, ``trajectory.mcap``, ``summary.json``) is an ordinary plan's
(:mod:`.plan_folder`); ``route.mcap`` plays beside ``trajectory.mcap`` in Foxglove/Lichtblick (same
clock, same ``world`` frame).
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from jethr1_plan.files.mcap import MARKERS, Ros2Mcap, Topic
from jethr1_plan.files.messages import carton_markers, cube_marker, header, point_cloud2, swing_path_markers
from jethr1_plan.records import topics as tp
from jethr1_plan.swing_path import Carton

__all__ = ["ROUTE_FILES", "ROUTE_TOPICS", "RouteDrawing", "SliceCloud", "route_mcap", "route_png"]

#: the files a route adds to its plan folder
ROUTE_FILES = frozenset({"route.yaml", "route.mcap", "route.png"})

#: the topics of ``route.mcap`` (ROS 2 profile, :mod:`.mcap`), in the order the file registers them
ROUTE_TOPICS: dict[str, Topic] = {
    tp.TERRAIN: Topic(MARKERS, True, "a CUBE per carton"),
    "/route/footholds": Topic(MARKERS, True, "the candidate sole centres the search chose from (a CUBE_LIST of 1 cm "
                                             "squares) and the goal (a flat CUBE: its carton or region)"),
    "/route/footsteps": Topic(MARKERS, True, "the start soles and each landing sole (flat CUBEs, left blue, right "
                                             "red) with the step's number (TEXT_VIEW_FACING)"),
    "/route/swing_paths": Topic(MARKERS, True, "a LINE_STRIP per step through its swing samples"),
    "/route/balance_space": Topic("sensor_msgs/msg/PointCloud2", False,
                                  "at each swing's start: the support sole's balance space the step was judged on, "
                                  "in the world frame: the cells in the swing path's vertical plane and at the "
                                  "landing's height; float32 x, y, z [m], `min_thrust_n` [N], `margin_m` [m]"),
}
_LEFT, _RIGHT = (0.15, 0.35, 0.95, 0.9), (0.9, 0.2, 0.2, 0.9)


@dataclass
class SliceCloud:
    """The balance-space cells shown for one step, in the world frame."""

    time_s: float  # the step's swing start in the plan [s]
    points_m: np.ndarray  # (P, 3)
    thrust_n: np.ndarray  # (P,)
    margin_m: np.ndarray  # (P,)


@dataclass
class RouteDrawing:
    """What the route's files show (world frame, SI units)."""

    title: str
    cartons: Sequence[Carton]
    names: Sequence[str]
    footholds_m: np.ndarray  # (F, 3) candidates
    start: dict[str, np.ndarray]
    swings: list[str]  # per step: the foot that swings
    landings_m: np.ndarray  # (S, 3)
    paths_m: list[np.ndarray]  # per step (N, 3)
    sole_m: tuple[float, float]  # length, width
    goal_rect: tuple[float, float, float, float]  # x0, x1, y0, y1
    step_labels: list[str]  # per step: a short line for the figure
    slices: list[SliceCloud]
    thrust_max_n: float


def _footstep(ns: str, ident: int, xyz, sole, rgba) -> dict:
    return cube_marker(ns, ident, (xyz[0], xyz[1], xyz[2] + 0.003), (sole[0], sole[1], 0.006), rgba)


def route_mcap(d: RouteDrawing) -> bytes:
    """The bytes of ``route.mcap`` (topics :data:`ROUTE_TOPICS`)."""
    out = Ros2Mcap(ROUTE_TOPICS)
    out.write(tp.TERRAIN, 0.0, carton_markers(d.cartons))
    holds = np.asarray(d.footholds_m, dtype=float).reshape(-1, 3)
    x0, x1, y0, y1 = d.goal_rect
    top = max((c.top_z for c in d.cartons), default=0.0)
    out.write("/route/footholds", 0.0, {"markers": [
        {**cube_marker("footholds", 0, (0.0, 0.0, 0.0), (0.01, 0.01, 0.002), (0.3, 0.3, 0.3, 1.0)), "type": 6,
         "points": {"x": holds[:, 0], "y": holds[:, 1], "z": holds[:, 2] + 0.002}},
        cube_marker("goal", 0, ((x0 + x1) / 2, (y0 + y1) / 2, top + 0.001), (x1 - x0, y1 - y0, 0.002),
                    (0.1, 0.8, 0.2, 0.35))]})
    steps = [_footstep("start", k, d.start[side], d.sole_m, _LEFT if side == "left" else _RIGHT)
             for k, side in enumerate(("left", "right"))]
    for k, (side, p) in enumerate(zip(d.swings, d.landings_m, strict=True)):
        steps.append(_footstep("landings", k, p, d.sole_m, _LEFT if side == "left" else _RIGHT))
        steps.append({**cube_marker("step_numbers", k, (p[0], p[1], p[2] + 0.04), (0.0, 0.0, 0.04), (1, 1, 1, 1)),
                      "type": 9, "text": str(k + 1)})
    out.write("/route/footsteps", 0.0, {"markers": steps})
    out.write("/route/swing_paths", 0.0, {**swing_path_markers(d.paths_m)})
    for s in d.slices:
        msg = point_cloud2(s.points_m, {"min_thrust_n": s.thrust_n, "margin_m": s.margin_m})
        msg["header"] = header(s.time_s, "world")
        out.write("/route/balance_space", s.time_s, msg)
    return out.finish()


def route_png(d: RouteDrawing) -> bytes:
    """A top view: cartons shaded by height and named, the candidate footholds, the goal, the start soles,
    each landing sole numbered, the swing paths, and the balance-space slice at each landing's height."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    xs = [v for c in d.cartons for v in c.top_rectangle()[:2]]
    ys = [v for c in d.cartons for v in c.top_rectangle()[2:]]
    span_x, span_y = max(xs) - min(xs) + 0.1, max(ys) - min(ys) + 0.1
    width = 12.0
    plot_h = min(9.0, max(3.0, width * span_y / span_x))
    text_h = 0.16 * (len(d.step_labels) + 1)
    fig, (ax, notes) = plt.subplots(2, 1, figsize=(width, plot_h + text_h + 0.6), constrained_layout=True,
                                    gridspec_kw={"height_ratios": [plot_h, text_h]})
    notes.axis("off")
    zs = [c.top_z for c in d.cartons]
    lo, hi = min(zs), max(zs)
    cmap = plt.get_cmap("copper")
    for c, name in zip(d.cartons, d.names, strict=True):
        x0, x1, y0, y1 = c.top_rectangle()
        shade = 0.35 + 0.5 * ((c.top_z - lo) / (hi - lo) if hi > lo else 0.5)
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, color=cmap(shade), alpha=0.55, lw=0))
        ax.text(x0 + 0.005, y1 - 0.005, f"{name}\nz {c.top_z:+.2f}", fontsize=6, va="top", color="0.15")
    if d.slices:  # the last step's layer at its landing's height: where the swing sole may be, by the map
        sl = d.slices[-1]
        z = d.landings_m[-1][2]
        flat = np.abs(sl.points_m[:, 2] - sl.points_m[np.argmin(np.abs(sl.points_m[:, 2] - z)), 2]) < 1e-6
        sc = ax.scatter(sl.points_m[flat, 0], sl.points_m[flat, 1], s=6, c=sl.thrust_n[flat], cmap="viridis", vmin=0,
                        vmax=d.thrust_max_n, alpha=0.25, marker="s", lw=0, zorder=0)
        fig.colorbar(sc, ax=ax, shrink=0.9, label="least thrust [N]\n(last step's map)")
    holds = np.asarray(d.footholds_m).reshape(-1, 3)
    ax.scatter(holds[:, 0], holds[:, 1], s=3, c="0.3", marker=".", label="candidate footholds")
    gx0, gx1, gy0, gy1 = d.goal_rect
    ax.add_patch(Rectangle((gx0, gy0), gx1 - gx0, gy1 - gy0, fill=False, ls="--", lw=1.5, ec="tab:green",
                           label="goal"))
    L, W = d.sole_m
    for side in ("left", "right"):
        p = d.start[side]
        ax.add_patch(Rectangle((p[0] - L / 2, p[1] - W / 2), L, W, fill=False, lw=1.5, ls=":",
                               ec="tab:blue" if side == "left" else "tab:red"))
    for k, (side, p, path) in enumerate(zip(d.swings, d.landings_m, d.paths_m, strict=True)):
        col = "tab:blue" if side == "left" else "tab:red"
        ax.plot(path[:, 0], path[:, 1], color=col, lw=1, alpha=0.8)
        ax.add_patch(Rectangle((p[0] - L / 2, p[1] - W / 2), L, W, fill=True, alpha=0.35, color=col))
        ax.text(p[0], p[1], str(k + 1), ha="center", va="center", fontsize=9, weight="bold")
    ax.plot([], [], color="tab:blue", label="left sole (dotted: start)")
    ax.plot([], [], color="tab:red", label="right sole (dotted: start)")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(alpha=0.3)
    ax.set_xlim(min(xs) - 0.05, max(xs) + 0.05)
    ax.set_ylim(min(ys) - 0.05, max(ys) + 0.05)
    handles, labels = ax.get_legend_handles_labels()
    notes.legend(handles, labels, loc="upper right", fontsize=7, frameon=False)
    ax.set_title(d.title, fontsize=10)
    notes.text(0.0, 1.0, "\n".join(f"{k + 1:2d}. {s}" for k, s in enumerate(d.step_labels)), transform=notes.transAxes,
               va="top", fontsize=8, family="monospace")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()
