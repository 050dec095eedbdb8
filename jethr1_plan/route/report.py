"""What ``jethr1 route`` reports of a route found and planned: summary.json's ``route`` section
(:func:`route_summary`) and the drawing of ``route.png`` and ``route.mcap`` (:func:`drawing`)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from jethr1_plan.files.route import RouteDrawing, SliceCloud
from jethr1_plan.geometry import other_side
from jethr1_plan.planning.results import PlanResult
from jethr1_plan.records.plan_rows import RowField
from jethr1_plan.route.balance_map import BalanceMap
from jethr1_plan.route.footholds import Footholds
from jethr1_plan.route.search import RouteStep, SearchResult
from jethr1_plan.route.terrain import Terrain
from jethr1_plan.scenario import Scenario

__all__ = ["RouteOutcome", "drawing", "plan_summary_lite", "route_summary", "steps_text"]


@dataclass
class RouteOutcome:
    """A route found and planned."""

    terrain: Terrain
    holds: Footholds
    steps: list[RouteStep]
    scenario: Scenario
    text: str  # route.yaml
    result: PlanResult
    searches: list[SearchResult]
    blacklisted: list[dict] = field(default_factory=list)
    plan_s: float = 0.0


def steps_text(n: int) -> str:
    return f"{n} step{'' if n == 1 else 's'}"


def _per_step(result: PlanResult) -> list[dict]:
    """Per step, from the plan's rows (the transfer before the swing and the swing): the largest total
    thrust [N], the least ZMP margin [m] and, where the plan has it, the least tolerance share."""
    rows = result.rows
    out: list[dict] = []
    if rows is None:
        return out
    step = rows.array(RowField.STEP)
    total = _total_thrust(result)
    margin = rows.array(RowField.ZMP_MARGIN_M).astype(float)
    share = rows.array(RowField.TOLERANCE_SHARE).astype(float)
    for st in result.steps:
        at = step == st.index
        m = margin[at]
        rec = {"peak_thrust_n": float(np.max(total[at])) if at.any() else None,
               "mean_thrust_n": float(np.mean(total[at])) if at.any() else None,
               "least_zmp_margin_m": float(np.nanmin(m)) if np.isfinite(m).any() else None}
        if np.isfinite(share[at]).any():
            rec["least_tolerance_share"] = float(np.nanmin(share[at]))
        out.append(rec)
    return out


def route_summary(o: RouteOutcome, maps: dict[str, BalanceMap], wall: dict[str, float]) -> dict:
    """The ``route`` section of summary.json."""
    t = o.terrain
    names = t.names
    plan_steps = _per_step(o.result)
    tol = t.base.balance.tolerance
    steps = []
    for k, st in enumerate(o.steps):
        e = st.edge
        rec = {"index": k, "swing": st.swing, "support": other_side(st.swing),
               "from_m": o.holds.xyz[st.frm].tolist(), "landing_m": o.holds.xyz[st.to].tolist(),
               "carton": names[o.holds.carton[st.to]], "clearance_m": e.clearance_m,
               "map": {"peak_thrust_n": e.peak_n, "mean_thrust_n": e.mean_n, "least_margin_m": e.margin_m,
                       "cost": e.cost},
               "plan": plan_steps[k] if k < len(plan_steps) else None}
        steps.append(rec)
    searched = o.searches
    return {
        "terrain": t.name, "terrain_file": str(Path(t.source).resolve()), "terrain_yaml": t.text,
        "goal": t.goal.describe(names), "footholds": len(o.holds),
        "balance": {"policy": t.base.balance.policy, "tolerance": {"thrust_error": tol.thrust, "mass_error": tol.mass,
                                                                   "com_error_m": tol.com_m}},
        "cost_weights": asdict(t.options.cost), "cost": float(sum(s.edge.cost for s in o.steps)),
        "steps": steps,
        "search": {"runs": len(searched), "stances_expanded": sum(s.expanded for s in searched),
                   "steps_judged": sum(s.evaluated for s in searched), "wall_s": sum(s.wall_s for s in searched)},
        "blacklisted": o.blacklisted,
        "maps": [{"support": side, "resolution_m": m.settings.resolution_m, "cells": int(m.member.size),
                  "members": int(m.member.sum()), "reach_m": m.reach_m, "key": m.key,
                  "file": None if m.path is None else str(m.path), "reused": m.reused, "wall_s": m.wall_s}
                 for side, m in maps.items()],
        "wall_s": wall,
    }


def _slices(o: RouteOutcome, maps: dict[str, BalanceMap]) -> list[SliceCloud]:
    """Per step, the support's balance space around the swing: the cells in the path's vertical plane
    (within half a cell) and the layer at the landing's height, in the world frame."""
    rows = o.result.rows
    times = rows.array(RowField.TIME_S).astype(float) if rows is not None else np.zeros(0)
    step_col = rows.array(RowField.STEP) if rows is not None else np.zeros(0)
    phase = rows.array(RowField.PHASE) if rows is not None else np.zeros(0)
    out = []
    for k, st in enumerate(o.steps):
        m = maps[other_side(st.swing)]
        sup = o.holds.xyz[st.support]
        a, b = o.holds.xyz[st.frm] - sup, o.holds.xyz[st.to] - sup
        res = m.settings.resolution_m
        X, Y, Z = np.meshgrid(*m.axes, indexing="ij")
        rel = np.stack([X, Y, Z], axis=-1)[m.member]
        d = b[:2] - a[:2]
        n = np.linalg.norm(d)
        if n > 0:
            u = d / n
            along = (rel[:, :2] - a[:2]) @ u
            off = np.abs((rel[:, 0] - a[0]) * u[1] - (rel[:, 1] - a[1]) * u[0])
            plane = (off <= res / 2 + 1e-9) & (along >= -0.1) & (along <= n + 0.1)
        else:
            plane = np.zeros(len(rel), dtype=bool)
        layer = np.abs(rel[:, 2] - m.axes[2][np.argmin(np.abs(m.axes[2] - b[2]))]) < 1e-9
        pick = plane | layer
        sel = np.flatnonzero(m.member.ravel())[pick]
        at = np.flatnonzero((step_col == k) & (phase == "swing"))
        out.append(SliceCloud(float(times[at[0]]) if len(at) else 0.0, rel[pick] + sup, m.thrust.ravel()[sel],
                              m.margin.ravel()[sel]))
    return out


def drawing(o: RouteOutcome, maps: dict[str, BalanceMap]) -> RouteDrawing:
    t = o.terrain
    robot = t.robot
    names = t.names
    per = _per_step(o.result)
    if t.goal.carton is not None:
        goal_rect = t.cartons[t.goal.carton].top_rectangle()
    else:
        (x0, x1), (y0, y1) = t.goal.region  # type: ignore[misc]
        goal_rect = (x0, x1, y0, y1)
    labels = [f"{st.swing:5s} -> {names[o.holds.carton[st.to]]}: plan {p['peak_thrust_n']:5.2f} N, map "
              f"{st.edge.peak_n:5.2f} N, margin {1000 * st.edge.margin_m:3.0f} mm" for st, p in zip(o.steps, per,
                                                                                                  strict=True)]
    s = plan_summary_lite(o.result)
    title = (f"{t.name}: {steps_text(len(o.steps))} to {t.goal.describe(names)}; {t.base.balance.policy} policy, "
             f"plan's peak thrust {s:.2f} N")
    return RouteDrawing(title=title, cartons=t.cartons, names=names, footholds_m=o.holds.xyz,
                        start={k: np.asarray(v, dtype=float) for k, v in t.base.start.items()},
                        swings=[st.swing for st in o.steps], landings_m=o.holds.xyz[[st.to for st in o.steps]],
                        paths_m=[st.path_m for st in o.scenario.steps],
                        sole_m=(robot.sole_length_m, robot.sole_width_m),
                        goal_rect=(float(goal_rect[0]), float(goal_rect[1]), float(goal_rect[2]), float(goal_rect[3])),
                        step_labels=labels, slices=_slices(o, maps),
                        thrust_max_n=t.base.balance.thrust_max_n)


def plan_summary_lite(result: PlanResult) -> float:
    """The plan's largest total thrust over its rows [N]."""
    rows = result.rows
    if rows is None or not len(rows):
        return float("nan")
    return float(np.max(_total_thrust(result)))


def _total_thrust(result: PlanResult) -> np.ndarray:
    """(rows,) the thrust of all fans together at each row [N]."""
    assert result.rows is not None
    return np.sum([result.rows.fan(f.name) for f in result.robot.fans], axis=0)


