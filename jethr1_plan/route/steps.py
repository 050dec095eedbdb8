"""One step of a route as the balance space judges it: feasible or why not, and its cost.

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
closed-form IK holds, within the joint limits, at the interior points (:data:`TRANSFER_POINTS`) of the line
between the map's best postures at its two ends (the first from, and the last to, the planner's standing
pose); where the same foot swings again, both ends are the posture of one cell and the transfer is taken as
feasible. docs/route.md measures how often this agrees with the planner.

**Cost** (:class:`~.terrain.CostWeights`): per step ``step`` + ``peak_thrust`` · F_peak/F_max +
``mean_thrust`` · F_mean/F_max + ``margin`` · max(0, 1 − d/``margin_m``) + ``edge`` · max(0, 1 − e/``edge_m``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from jethr1_plan.geometry import other_side, wrap_angle
from jethr1_plan.kinematics.closed_form import solve_postures
from jethr1_plan.physics.balance import body_yaw_eq4
from jethr1_plan.planning.plan import standing_pose
from jethr1_plan.reasons import Reason
from jethr1_plan.route.balance_map import OUTSIDE, BalanceMap
from jethr1_plan.route.footholds import Footholds
from jethr1_plan.route.terrain import Terrain
from jethr1_plan.swing_path import arc_paths, collides

__all__ = ["TRANSFER_POINTS", "WHY", "Edge", "StepModel", "better"]

#: where a transfer's line is checked: its interior (the ends are the planner's own, balanced postures)
TRANSFER_POINTS = np.linspace(0.15, 0.85, 15)

#: why a step is not feasible, from the nearest miss to the farthest (the frontier names the nearest)
WHY = ("planner", "transfer", "margin", "thrust", "balance", "joint limits", "overlap", "collision", "reach", "goal")
_REACH = [int(Reason.UNREACHABLE), OUTSIDE]
_JOINTS = [int(Reason.JOINT_LIMIT), int(Reason.NOT_CONVERGED)]
_BALANCE = [int(Reason.NO_BALANCE), int(Reason.EDGE_ANGLE)]


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
            with np.errstate(invalid="ignore"):  # rows beyond the map hold inf: judged by ``all_ok`` first
                means, leasts = thrust.mean(axis=1), margin.min(axis=1)
            for i in range(len(targets)):
                if tall[i] or best[i].ok:  # a lower arc of the list the map accepts stands
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
                    mean, least = float(means[i]), float(leasts[i])
                    cost = (w.step + w.peak_thrust * peak[i] / self.fmax + w.mean_thrust * mean / self.fmax
                            + w.margin * max(0.0, 1.0 - least / w.margin_m)
                            + w.edge * max(0.0, 1.0 - float(self.holds.edge_m[targets[i]]) / w.edge_m))
                    e = Edge(True, float(cost), clearance, float(peak[i]), mean, least)
                if not best[i].ok and better(e, best[i]):  # the first arc of the list the map accepts
                    best[i] = e
        return best


def better(a: Edge, b: Edge) -> bool:
    """Whether ``a`` is the better judgement of a step: feasible over not, then the cheaper, or the nearer miss
    (:data:`WHY`) and the smaller thrust needed."""
    if a.ok != b.ok:
        return a.ok
    if a.ok:
        return a.cost < b.cost
    if WHY.index(a.why) != WHY.index(b.why):
        return WHY.index(a.why) < WHY.index(b.why)
    return a.need_n < b.need_n
