"""The footstep search over carton tops, on the balance space.

**Footholds.** Candidate sole centres on every carton top: a grid ``foothold_spacing_m`` apart,
symmetric about the top's centre, and the sole as far to each side as the margin lets it where the grid
stops short of that, every sole (flat, yaw 0) inside the top by ``edge_margin_m`` (by default the
robot's measured landing error); the start soles are footholds too.

**States and steps.** A state is where both soles stand (two footholds) and which foot swung last;
either foot may swing next, so a route may step twice with the same foot (Paper A's trial does). A step
(swing foot, from, to) is
feasible when the landing does not overlap the support sole, every point of its swing path (the
planner's arc, :func:`~jethr1_plan.swing_path.arc_path`, for a sagitta of ``clearances_m``) lies
within the legs' span and in the support side's balance space translated to the support sole
(:meth:`BalanceMap.lookup`, conservative), the map's peak thrust along it is within
``limits.peak_thrust_n``, and the sole clears every carton on the way. The sagittas are tried in the
order given and the first that passes is taken (a sagitta above half the step's length only where it is
the lowest of the list: the sole never moves back): the default tries the highest first, whose steeper
final descent lands nearer the planned foothold in the twin (docs/route.md).

**Transfers.** Between two swings both soles stand and the planner moves the trunk in a straight line
from the posture that ended one swing to the one that starts the next (``planning.sequence``); where the
support changes over a long stance that line can leave the joint limits. A transfer is feasible when the
closed-form IK holds, within the joint limits, at the interior points of the line between the map's
best postures at its two ends (the first from, and the last to, the planner's standing pose); where the
same foot swings again, both ends are the posture of one cell and the transfer is taken as feasible. Measured
on 61 transfers of 11 random routes: all 24 that the planner refused were caught, 4 of the 37 it
accepted refused too (docs/route.md).

**Cost** (:class:`~.terrain.CostWeights`): per step ``step`` + ``peak_thrust`` · F_peak/F_max +
``mean_thrust`` · F_mean/F_max + ``margin`` · max(0, 1 − d/``margin_m``) + ``edge`` · max(0, 1 − e/``edge_m``).

**Search.** A* over the states, successors evaluated in one batch per expansion, with the
admissible heuristic ``step`` × (a lower bound on the steps left): each step puts the swing sole
within the maps' reach R of the support sole, so the foot nearest the goal gets at most R closer
per step; reaching a region with both feet takes one step more than reaching it with the first.
:func:`exhaustive` is Dijkstra over every reachable state (no heuristic, no early stop): the
benchmark's reference. Both skip ``blacklist``ed steps and transfers (those the planner failed)
and stop a route at ``limits.max_steps``.
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass, field

import numpy as np

from jethr1_plan.geometry import SIDES, other_side, wrap_angle
from jethr1_plan.kinematics.closed_form import solve_postures
from jethr1_plan.physics.balance import body_yaw_eq4
from jethr1_plan.planning.plan import standing_pose
from jethr1_plan.reasons import Reason
from jethr1_plan.route.balance_map import OUTSIDE, BalanceMap
from jethr1_plan.route.terrain import Terrain
from jethr1_plan.swing_path import arc_paths, collides, sole_on_carton

__all__ = ["TRANSFER_POINTS", "WHY", "Edge", "Footholds", "Frontier", "RouteStep", "SearchResult", "StepModel", "astar",
           "exhaustive", "footholds"]

#: where a transfer's line is checked: its interior (the ends are the planner's own, balanced postures)
TRANSFER_POINTS = np.linspace(0.15, 0.85, 15)

#: why a step is not feasible, from the nearest miss to the farthest (the frontier names the nearest)
WHY = ("planner", "transfer", "margin", "thrust", "balance", "joint limits", "overlap", "collision", "reach", "goal")
_REACH = [int(Reason.UNREACHABLE), OUTSIDE]
_JOINTS = [int(Reason.JOINT_LIMIT), int(Reason.NOT_CONVERGED)]
_BALANCE = [int(Reason.NO_BALANCE), int(Reason.EDGE_ANGLE)]
_SIDES = ("left", "right")  # plain strings: they go into YAML and JSON


@dataclass
class Footholds:
    """Candidate sole centres (F, 3) [m], the carton under each, and the start soles' indices."""

    xyz: np.ndarray
    carton: np.ndarray
    start: dict[str, int]
    edge_m: np.ndarray  # (F,) the sole's least distance to the edge of its carton's top [m]

    def __len__(self) -> int:
        return len(self.xyz)


def footholds(terrain: Terrain) -> Footholds:
    """The footholds of every carton top (rounded to 1 µm, each checked to lie on its top), then the start soles."""
    robot = terrain.robot
    L, W = robot.sole_length_m, robot.sole_width_m
    opt = terrain.options
    s = opt.foothold_spacing_m
    pts, owner = [], []
    for k, c in enumerate(terrain.cartons):
        cx, cy, cz = c.top_centre_m
        axes = []
        for size, sole in ((c.size_m[0], L), (c.size_m[1], W)):
            half = (size - sole) / 2 - opt.edge_margin_m
            n = math.floor(half / s + 1e-9) if half >= 0 else -1
            axis = np.arange(-n, n + 1) * s if n >= 0 else np.zeros(0)
            if n >= 0 and half - n * s > 1e-6:  # the sole as far to each side as the margin lets it
                axis = np.concatenate([[-half], axis, [half]])
            axes.append(axis)
        for dx in axes[0]:
            for dy in axes[1]:
                p = np.array([round(cx + dx, 6), round(cy + dy, 6), cz])
                if sole_on_carton(p, 0.0, L, W, c):
                    pts.append(p)
                    owner.append(k)
    start = {}
    for side in SIDES:
        p = np.asarray(terrain.base.start[side], dtype=float)
        same = [i for i, q in enumerate(pts) if np.allclose(q, p, atol=1e-9)]
        if same:
            start[side] = same[0]
            continue
        k = next(k for k, c in enumerate(terrain.cartons) if sole_on_carton(p, 0.0, L, W, c))
        start[side] = len(pts)
        pts.append(p.copy())
        owner.append(k)
    xyz = np.array(pts, dtype=float).reshape(-1, 3)
    owner_a = np.array(owner, dtype=np.int64)
    rect = np.array([terrain.cartons[k].top_rectangle() for k in owner_a]).reshape(-1, 4)
    edge = np.min(np.column_stack([xyz[:, 0] - L / 2 - rect[:, 0], rect[:, 1] - xyz[:, 0] - L / 2,
                                   xyz[:, 1] - W / 2 - rect[:, 2], rect[:, 3] - xyz[:, 1] - W / 2]), axis=1)
    return Footholds(xyz, owner_a, start, np.maximum(edge, 0.0))


@dataclass(frozen=True)
class Edge:
    """One step as the map judges it: feasible or why not, its cost and figures (from the map)."""

    ok: bool
    cost: float = math.inf
    clearance_m: float = 0.0
    peak_n: float = math.inf  # the map's least thrust at the path's worst point [N]
    mean_n: float = math.inf
    margin_m: float = 0.0  # the path's least distance to the edge of the balance space [m]
    why: str = ""  # one of WHY where not ok
    need_n: float = math.inf  # where ``why`` is thrust: the peak thrust the path needs, by the map [N]


@dataclass
class StepModel:
    """Judges steps on the maps; results cached by (swing side, support, from, to)."""

    terrain: Terrain
    holds: Footholds
    maps: dict[str, BalanceMap]  # by support side
    blacklist: set[tuple[str, int, int, int]] = field(default_factory=set)
    cache: dict[tuple[str, int, int, int], Edge] = field(default_factory=dict)
    evaluated: int = 0
    transfer_blacklist: set[tuple] = field(default_factory=set)  # (left, right, last swing, next swing or None)
    transfers: dict[tuple, bool] = field(default_factory=dict)

    def __post_init__(self) -> None:
        robot = self.terrain.robot
        self.L, self.W = robot.sole_length_m, robot.sole_width_m
        self.span = 2 * (robot.leg_length_m + robot.hip_offset_m)  # the scenario loader's limit
        self.reach = {side: min(m.reach_m, self.span) for side, m in self.maps.items()}
        self.fmax = self.terrain.base.balance.thrust_max_n
        self.cartons = list(self.terrain.cartons)

    def posture(self, support_side: str, feet: dict[str, np.ndarray]) -> tuple[np.ndarray, float]:
        """The map's best trunk position [m] and the body yaw of (A-4) [rad] with both soles at ``feet`` and
        the other sole swinging (at the start or the end of its swing)."""
        swing = other_side(support_side)
        sup = feet[support_side]
        p = self.maps[support_side].posture(feet[swing] - sup) + sup
        fan = self.terrain.robot.fan_for(swing)
        off = np.asarray(fan.offset_m[:2]) if fan is not None else np.zeros(2)
        return p, float(body_yaw_eq4(sup[:2], feet[swing][:2] + off, support_side))

    def transfer(self, left: int, right: int, last: str | None, nxt: str | None) -> bool:
        """Whether the double-support transfer on footholds (left, right) from the end of the ``last`` foot's
        swing (None: the standing pose) to the start of the ``nxt`` foot's (None: the standing pose) holds."""
        key = (left, right, last, nxt)
        if key in self.transfer_blacklist:
            return False
        if last is not None and last == nxt:
            return True  # the same support before and after: both ends are the map's posture of one cell
        if key not in self.transfers:
            robot = self.terrain.robot
            feet = {"left": self.holds.xyz[left], "right": self.holds.xyz[right]}
            if last is None:
                p0, y0 = standing_pose(robot, feet, 0.0), 0.0
            else:
                p0, y0 = self.posture(other_side(last), feet)
            if nxt is None:
                p1, y1 = standing_pose(robot, feet, y0), y0
            else:
                p1, y1 = self.posture(other_side(nxt), feet)
            s = TRANSFER_POINTS
            P = p0 + s[:, None] * (p1 - p0)
            yaw = wrap_angle(y0 + s * float(wrap_angle(y1 - y0)))
            ok = bool(np.all(np.isfinite(P)))
            if ok:
                _, _, status = solve_postures(robot, P, yaw, {k: (v, 0.0) for k, v in feet.items()})
                ok = bool(np.all(status == Reason.OK))
            self.transfers[key] = ok
        return self.transfers[key]

    def candidates(self, swing: str, support: int, frm: int) -> np.ndarray:
        """Footholds the swing sole may land on: within the map's reach of the support sole, not on it."""
        sup = self.holds.xyz[support]
        d = np.linalg.norm(self.holds.xyz[:, :2] - sup[:2], axis=1)
        ok = (d <= self.reach[other_side(swing)]) & (d >= self.W)
        ok[frm] = False
        return np.flatnonzero(ok)

    def edges(self, swing: str, support: int, frm: int, targets: np.ndarray) -> list[Edge]:
        """The steps of the ``swing`` foot from foothold ``frm`` to each of ``targets``, the other foot on
        ``support``."""
        keys = [(swing, support, frm, int(t)) for t in targets]
        todo = [k for k in keys if k not in self.cache]
        if todo:
            for k, e in zip(todo, self._evaluate(swing, support, frm, np.array([k[3] for k in todo])), strict=True):
                self.cache[k] = e
        return [Edge(False, why="planner") if k in self.blacklist else self.cache[k] for k in keys]

    def _evaluate(self, swing: str, support: int, frm: int, targets: np.ndarray) -> list[Edge]:
        opt = self.terrain.options
        w = opt.cost
        sup = self.holds.xyz[support]
        m = self.maps[other_side(swing)]
        limit = min(self.terrain.limits.peak_thrust_n, self.fmax)
        ends = self.holds.xyz[targets]
        self.evaluated += len(targets)
        best: list[Edge] = [Edge(False, why="reach") for _ in targets]
        chord = np.linalg.norm(ends - self.holds.xyz[frm], axis=1)
        lowest = min(opt.clearances_m)
        for clearance in opt.clearances_m:
            # an arc at most a half circle (the sole never moves back), but for the lowest of the list
            tall = (clearance > chord / 2) & (clearance > lowest)
            paths = arc_paths(self.holds.xyz[frm], ends, clearance, opt.samples, opt.lift_m, opt.descent_m)  # (K, N, 3)
            rel = paths - sup
            ok, thrust, margin, reason, need = m.lookup(rel)
            far = np.any(np.linalg.norm(rel, axis=2) > self.span, axis=1)
            reach = far | np.any(np.isin(reason, _REACH), axis=1)
            joints = np.any(np.isin(reason, _JOINTS), axis=1)
            over = np.any(reason == Reason.OVERLAP, axis=1)
            balance = np.any(np.isin(reason, _BALANCE), axis=1)
            too_much = np.any(reason == Reason.THRUST_MAX, axis=1)
            peak_need = np.max(np.where(np.isfinite(need), need, 0.0), axis=1)
            all_ok = np.all(ok, axis=1)
            peak = np.where(all_ok, np.max(thrust, axis=1), np.inf)
            hit = collides(paths, self.L, self.W, self.cartons)
            for i in range(len(targets)):
                if tall[i]:
                    continue
                if reach[i]:
                    e = Edge(False, why="reach")
                elif hit[i]:
                    e = Edge(False, clearance_m=clearance, why="collision")
                elif over[i]:
                    e = Edge(False, clearance_m=clearance, why="overlap")
                elif joints[i]:
                    e = Edge(False, clearance_m=clearance, why="joint limits")
                elif balance[i]:
                    e = Edge(False, clearance_m=clearance, why="balance")
                elif too_much[i] or peak_need[i] > limit or (all_ok[i] and peak[i] > limit):
                    e = Edge(False, clearance_m=clearance, why="thrust",
                             need_n=float(max(peak_need[i], peak[i]) if all_ok[i] else peak_need[i]))
                elif not all_ok[i]:
                    e = Edge(False, clearance_m=clearance, why="margin")
                else:
                    mean = float(np.mean(thrust[i]))
                    least = float(np.min(margin[i]))
                    cost = (w.step + w.peak_thrust * peak[i] / self.fmax + w.mean_thrust * mean / self.fmax
                            + w.margin * max(0.0, 1.0 - least / w.margin_m)
                            + w.edge * max(0.0, 1.0 - float(self.holds.edge_m[targets[i]]) / w.edge_m))
                    e = Edge(True, float(cost), clearance, float(peak[i]), mean, least)
                if not best[i].ok and _better(e, best[i]):  # the first arc of the list the map accepts
                    best[i] = e
        return best


def _better(a: Edge, b: Edge) -> bool:
    if a.ok != b.ok:
        return a.ok
    if a.ok:
        return a.cost < b.cost
    if WHY.index(a.why) != WHY.index(b.why):
        return WHY.index(a.why) < WHY.index(b.why)
    return a.need_n < b.need_n


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
                if _better(e, best):
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
