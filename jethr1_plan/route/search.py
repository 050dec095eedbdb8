"""The footstep search over carton tops, on the balance space: the least-cost sequence of steps
(:mod:`.steps` judges each, over the footholds of :mod:`.footholds`) from the start soles to the goal.

**Search.** A* over the states, successors evaluated in one batch per expansion, with the
admissible heuristic ``step`` × (a lower bound on the steps left): each step puts the swing sole
within the maps' reach R of the support sole, so the foot nearest the goal gets at most R closer
per step; reaching a region with both feet takes one step more than reaching it with the first.
:func:`exhaustive` is Dijkstra over every reachable state (no heuristic, no early stop): the
benchmark's reference. Both skip ``blacklist``ed steps and transfers (those the planner failed)
and stop a route at ``limits.max_steps``.

Where no route exists, the :class:`Frontier` names the cartons reached, the nearest one not reached and why
no step gets there.
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass

import numpy as np

from jethr1_plan.geometry import other_side
from jethr1_plan.route.steps import Edge, StepModel, better

__all__ = ["Frontier", "RouteStep", "SearchResult", "astar", "exhaustive"]

_SIDES = ("left", "right")  # plain strings: they go into YAML and JSON


@dataclass(frozen=True)
class RouteStep:
    """One chosen step: the swing foot, the footholds (support, from, to) and the map's judgement."""

    swing: str
    support: int
    frm: int
    to: int
    edge: Edge

    @property
    def key(self) -> tuple[str, int, int, int]:
        return (self.swing, self.support, self.frm, self.to)


@dataclass
class Frontier:
    """Where a search that found no route got to."""

    reached: list[int]  # cartons some sole stood on, in the terrain's order
    states: int  # stances explored
    nearest: int | None = None  # the nearest carton no sole reached
    why: str = ""
    detail: str = ""


@dataclass
class SearchResult:
    steps: list[RouteStep] | None  # None: no route
    cost: float
    expanded: int
    evaluated: int
    wall_s: float
    frontier: Frontier | None = None


State = tuple[int, int, str | None]  # (left foothold, right foothold, the foot that swung last)


def _goal_test(model: StepModel) -> tuple:
    """(reached(left, right) -> bool, steps_left_lower_bound(left, right) -> int)."""
    t = model.terrain
    holds = model.holds
    xy = holds.xyz[:, :2]
    L, W = model.L, model.W
    R = max(model.reach.values()) or math.inf
    goal = t.goal
    if goal.carton is not None:
        on = holds.carton == goal.carton
        pts = xy[on]
        lo, hi = (pts.min(axis=0), pts.max(axis=0)) if len(pts) else (np.full(2, np.inf), np.full(2, np.inf))
        inside = on
    else:
        assert goal.region is not None
        (x0, x1), (y0, y1) = goal.region
        lo, hi = np.array([x0 + L / 2, y0 + W / 2]), np.array([x1 - L / 2, y1 - W / 2])
        inside = np.all((xy >= lo - 1e-9) & (xy <= hi + 1e-9), axis=1)
    dist = np.linalg.norm(np.maximum(0.0, np.maximum(lo - xy, xy - hi)), axis=1)
    steps_to = np.where(inside, 0, np.ceil(dist / R - 1e-12).clip(min=1))

    if goal.carton is not None:
        def reached(a: int, b: int) -> bool:
            return bool(inside[a] or inside[b])

        def h(a: int, b: int) -> int:
            return int(min(steps_to[a], steps_to[b]))
    else:
        def reached(a: int, b: int) -> bool:
            return bool(inside[a] and inside[b])

        def h(a: int, b: int) -> int:
            sa, sb = steps_to[a], steps_to[b]
            if sa == 0 or sb == 0:
                return int(max(sa, sb))
            return int(min(sa, sb) + 1)
    return reached, h


def _search(model: StepModel, heuristic: bool, stop_at_goal: bool) -> SearchResult:
    t0 = time.perf_counter()
    ev0 = model.evaluated
    reached, h = _goal_test(model)
    w = model.terrain.options.cost.step if heuristic else 0.0
    max_steps = model.terrain.limits.max_steps
    start: State = (model.holds.start["left"], model.holds.start["right"], None)
    g = {start: 0.0}
    depth = {start: 0}
    parent: dict[State, tuple[State, RouteStep] | None] = {start: None}
    heap: list = [(w * h(start[0], start[1]), 0, start)]
    closed: set[State] = set()
    seq = 1
    best_goal: State | None = None
    while heap:
        _, _, s = heapq.heappop(heap)
        if s in closed:
            continue
        closed.add(s)
        if s != start and reached(s[0], s[1]) and model.transfer(s[0], s[1], s[2], None):
            if best_goal is None or g[s] < g[best_goal]:
                best_goal = s
            if stop_at_goal:
                break
            continue
        if depth[s] >= max_steps:
            continue
        feet = (s[0], s[1])
        for k, swing in enumerate(_SIDES):
            frm, sup = feet[k], feet[1 - k]
            if not model.transfer(s[0], s[1], s[2], swing):
                continue
            targets = model.candidates(swing, sup, frm)
            if not len(targets):
                continue
            for to, e in zip(targets, model.edges(swing, sup, frm, targets), strict=True):
                if not e.ok:
                    continue
                nxt: State = (int(to), sup, swing) if k == 0 else (sup, int(to), swing)
                cost = g[s] + e.cost
                if nxt in closed or cost >= g.get(nxt, math.inf) - 1e-12:
                    continue
                g[nxt], depth[nxt] = cost, depth[s] + 1
                parent[nxt] = (s, RouteStep(swing, sup, frm, int(to), e))
                heapq.heappush(heap, (cost + w * h(nxt[0], nxt[1]), seq, nxt))
                seq += 1
    wall = time.perf_counter() - t0
    if best_goal is None:
        return SearchResult(None, math.inf, len(closed), model.evaluated - ev0, wall, _frontier(model, closed))
    steps = []
    s = best_goal
    while parent[s] is not None:
        prev, step = parent[s]  # type: ignore[misc]
        steps.append(step)
        s = prev
    return SearchResult(steps[::-1], g[best_goal], len(closed), model.evaluated - ev0, wall)


def astar(model: StepModel) -> SearchResult:
    """The least-cost route (A*, admissible heuristic): the same cost as :func:`exhaustive`."""
    return _search(model, heuristic=True, stop_at_goal=True)


def exhaustive(model: StepModel) -> SearchResult:
    """Dijkstra over every state reachable within the step limit: the reference the benchmark compares with."""
    return _search(model, heuristic=False, stop_at_goal=False)


def _rect_distance(a, b) -> float:
    ax0, ax1, ay0, ay1 = a.top_rectangle()
    bx0, bx1, by0, by1 = b.top_rectangle()
    return math.hypot(max(0.0, bx0 - ax1, ax0 - bx1), max(0.0, by0 - ay1, ay0 - by1))


def _frontier(model: StepModel, closed: set[State]) -> Frontier:
    """The cartons reached, the nearest one not reached, and why no step gets there."""
    holds = model.holds
    reached = sorted({int(holds.carton[i]) for s in closed for i in s[:2]})
    cartons = model.terrain.cartons
    out = Frontier(reached, len(closed))
    others = [k for k in range(len(cartons)) if k not in reached and np.any(holds.carton == k)]
    if not others:
        out.why = "goal"
        out.detail = ("a sole reached every carton, but no stance ends the route at the goal (its soles there, and "
                      "the last transfer to standing within the joint limits)")
        return out
    goal = model.terrain.goal
    goal_xy = (np.array(cartons[goal.carton].top_centre_m[:2]) if goal.carton is not None
               else np.array([np.mean(goal.region[0]), np.mean(goal.region[1])]))  # type: ignore[index]

    def key(k: int) -> tuple[float, float]:
        return (min(_rect_distance(cartons[k], cartons[r]) for r in reached),
                float(np.linalg.norm(np.array(cartons[k].top_centre_m[:2]) - goal_xy)))

    nearest = min(others, key=key)
    out.nearest = nearest
    targets = np.flatnonzero(holds.carton == nearest)
    best = Edge(False, why="reach")
    closest, where = math.inf, None
    for s in sorted(closed, key=lambda st: (st[0], st[1], st[2] or "")):
        feet = (s[0], s[1])
        for k, swing in enumerate(_SIDES):
            frm, sup = feet[k], feet[1 - k]
            d = np.linalg.norm(holds.xyz[targets, :2] - holds.xyz[sup, :2], axis=1)
            j = int(np.argmin(d))
            if d[j] < closest:
                closest, where = float(d[j]), (swing, sup)
            near = targets[d <= model.reach[other_side(swing)]]
            moving = model.transfer(s[0], s[1], s[2], swing)
            for e in model.edges(swing, sup, frm, near) if len(near) else []:
                if e.ok and not moving:
                    e = Edge(False, why="transfer")
                if better(e, best):
                    best = e
    out.why = best.why
    names = model.terrain.names
    if best.why == "reach" and where is not None:
        swing, sup = where
        m = model.maps[other_side(swing)]
        d = holds.xyz[targets, :2] - holds.xyz[sup, :2]
        along = m.reach_along(d[int(np.argmin(np.linalg.norm(d, axis=1)))])
        out.detail = (f"its nearest foothold is {closest:.3f} m from a support sole; the balance space ({swing} foot "
                      f"swinging) reaches {along:.3f} m that way")
    elif best.why == "thrust":
        out.detail = (f"the best swing path there needs {best.need_n:.2f} N by the map; the limit is "
                      f"{min(model.terrain.limits.peak_thrust_n, model.fmax):g} N")
    elif best.why == "balance":
        out.detail = "no thrust balances some point of every swing path there (or the edge angle exceeds rho)"
    elif best.why == "joint limits":
        out.detail = "every swing path there needs a posture beyond the joint limits"
    elif best.why == "overlap":
        out.detail = "every swing path there passes over the support sole"
    elif best.why == "margin":
        out.detail = ("every swing path there leaves the balance space between its grid nodes (the map's "
                      "conservative lookup)")
    elif best.why == "collision":
        out.detail = f"every arc there (sagitta {', '.join(f'{c:g}' for c in model.terrain.options.clearances_m)} m) " \
                     "enters a carton"
    elif best.why == "planner":
        out.detail = "the planner found no balanced posture on the steps the map allows"
    elif best.why == "transfer":
        out.detail = ("the steps there are feasible, but the double-support transfer before each leaves the joint "
                      "limits")
    out.detail = f"carton {names[nearest]}: {out.detail}"
    return out
