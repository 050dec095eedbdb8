"""Searches over P_body for one support sole: the compiled objective, its projection and the seeds.

The balance-space sweep (:mod:`~jethr1_plan.balance_space.sweep`), ``compare``'s reference thrust and the
sqp optimiser's last resort all search the same objective: the least thrust over P_body under all of
Paper A's constraints, for a swing sole at a given cell, with the body yaw of (A-4).

* :class:`Evaluator` — the objective of candidates of many cells at once (``physics.compiled.
  balance_objective``: closed-form IK, CoM, thrust window, edge angle, reach), with the projection into
  the legs' reach balls and joint limits (:meth:`Evaluator.into_reach`, :func:`leg_shapes`).
* :func:`generic_seeds`, :func:`lens_seeds` — starting points; :func:`pelvis_box` — the grid of every pelvis
  position from which both legs may reach.
* ``optimisers.compass`` — the compass search; ``optimisers.exhaustive`` — Paper A's grid search.

Mirror-exact: Jet-HR1 is left-right symmetric, so a left support's search must be the mirror image (y → −y)
of a right support's, to the bit. Every choice a search makes in order (the directions it polls first, the
seeds, the grids and their tie order) is written for a right support and multiplied by the evaluator's
:attr:`Evaluator.flip` (1, −1, 1) for a left one; the kinematics and the yaw are odd to the bit
(``physics.compiled.legs.body_com``, ``geometry.wrap_angle``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jethr1_plan.geometry import GRAVITY, other_side, sole_polygon
from jethr1_plan.kinematics.closed_form import check_structure, kernel_params
from jethr1_plan.physics.balance import NOMINAL, Tolerance, body_yaw_eq4
from jethr1_plan.physics.compiled.legs import yaw_cos_sin
from jethr1_plan.physics.compiled.objective import balance_objective
from jethr1_plan.physics.compiled.reach import into_reach, pitch_bounds
from jethr1_plan.robot.model import RobotModel, reach_centre

__all__ = [
    "AXIS_DIRECTIONS",
    "DIRECTIONS",
    "EDGE_PENALTY_N_PER_DEG",
    "FINE_DIRECTIONS",
    "INTO_JOINT_LIMITS",
    "INTO_REACH",
    "INTO_ROLL_KNEE",
    "REACH_MARGIN_M",
    "SEARCH_LEVEL",
    "Cells",
    "Evaluator",
    "SupportStance",
    "cube_offsets",
    "generic_seeds",
    "leg_shapes",
    "lens_seeds",
    "pelvis_box",
]

EDGE_PENALTY_N_PER_DEG = 50.0  # far above dF/dθ (about 1 N per degree), so the penalty is exact
# what the searches' projection (Evaluator.into_reach) moves a pelvis position into: the legs' reach balls only; also
# each leg's roll and knee limits; also its pitch limits (dearer: trigonometry where the pitch is near a limit)
INTO_REACH, INTO_ROLL_KNEE, INTO_JOINT_LIMITS = 0, 1, 2
SEARCH_LEVEL = INTO_ROLL_KNEE  # the searches' default (Evaluator.level)
REACH_MARGIN_M = 1e-4  # searches stay this far [m] inside a leg's full stretch (optimisers.sqp keeps ~0.13 mm)

AXIS_DIRECTIONS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
DIRECTIONS = np.array([d for d in np.ndindex(3, 3, 3) if d != (1, 1, 1)], dtype=float) - 1.0  # 26 neighbours
# the compass's fine polls: the 6 axes and the 8 cube corners (the 12 edge directions as well cost 1.5x
# the evaluations for no measured gain in agreement with the exhaustive search)
FINE_DIRECTIONS = DIRECTIONS[np.abs(DIRECTIONS).sum(axis=1) != 2]


@dataclass(frozen=True)
class SupportStance:
    """What a search holds fixed: the support sole and the balance settings (SI units)."""

    support_side: str
    support_xyz: tuple[float, float, float]
    rho_rad: float
    thrust_max_n: float  # the limit on every fan [N]
    sole_margin_m: float = 0.0
    tolerance: Tolerance = NOMINAL

    @property
    def swing_side(self) -> str:
        return other_side(self.support_side)


@dataclass
class Cells:
    """Per-candidate data of the cells being searched."""

    swing: np.ndarray  # (C, 3) swing sole centres [m]
    yaw: np.ndarray  # (C,) body yaw (A-4) [rad]
    fan: np.ndarray  # (C, 2) thrust point [m]
    centre_s: np.ndarray  # (C, 3) centre of the support leg's reach ball (robot.model.reach_centre) [m]
    centre_w: np.ndarray  # (C, 3) centre of the swing leg's reach ball [m]
    yaw_cs: np.ndarray  # (C, 2) cos and sin of the yaw (as the kernels compute them)


class Evaluator:
    """Vectorised objective over candidates of many cells at once.

    ``level``: what :meth:`into_reach` and the compass move a pelvis position into by default (INTO_REACH,
    INTO_ROLL_KNEE, INTO_JOINT_LIMITS). ``flip`` (3,): (1, 1, 1) for a right support, (1, −1, 1) for a left one,
    the mirror applied to every ordered choice of the searches (poll directions, seeds, grids)."""

    def __init__(self, robot: RobotModel, stance: SupportStance, level: int = SEARCH_LEVEL):
        self.robot, self.stance, self.level = robot, stance, level
        self.geom = check_structure(robot)
        self.support = np.asarray(stance.support_xyz, dtype=float)
        self.poly = sole_polygon(self.support[:2], 0.0, robot.sole_length_m, robot.sole_width_m, stance.sole_margin_m)
        fan = robot.fan_for(stance.swing_side)  # turns the trunk to it (its sole without one)
        self.fan_offset = np.asarray(fan.offset_m[:2]) if fan is not None else np.zeros(2)
        self.evaluations = 0
        self.params = kernel_params(robot, stance.support_side, self.support, self.poly, stance.rho_rad,
                                    stance.thrust_max_n, robot.mass_kg * GRAVITY, EDGE_PENALTY_N_PER_DEG,
                                    stance.tolerance)
        self.mirror = -1.0 if stance.support_side == "left" else 1.0
        self.flip = np.array([1.0, self.mirror, 1.0])
        self.axis_dirs = np.ascontiguousarray(AXIS_DIRECTIONS * self.flip)
        self.fine_dirs = np.ascontiguousarray(FINE_DIRECTIONS * self.flip)
        self.all_dirs = np.ascontiguousarray(DIRECTIONS * self.flip)
        # per level (INTO_REACH, INTO_ROLL_KNEE, INTO_JOINT_LIMITS) the legs' sets of into_reach: the first two
        # leave the pitch free (their fast-path pitch range infinite)
        limited = leg_shapes(self.geom.thigh_m, self.geom.shank_m, self.search_radius, self.params.limits,
                             stance.swing_side)
        free = limited.copy()
        free[:, 12:] = (-np.inf, np.inf)
        self.shapes = np.stack([free, free, limited])

    def cells(self, swing: np.ndarray) -> Cells:
        swing = np.ascontiguousarray(swing, dtype=float)
        fan = np.ascontiguousarray(swing[:, :2] + self.fan_offset)
        yaw = body_yaw_eq4(self.support[:2], fan, self.stance.support_side)
        centre_s = reach_centre(self.geom, self.stance.support_side, np.broadcast_to(self.support, swing.shape), yaw)
        centre_w = reach_centre(self.geom, self.stance.swing_side, swing, yaw)
        return Cells(swing, yaw, fan, np.ascontiguousarray(centre_s), np.ascontiguousarray(centre_w),
                     np.ascontiguousarray(np.column_stack(yaw_cos_sin(np.ascontiguousarray(yaw)))))

    @property
    def search_radius(self) -> float:
        """The reach balls' radius the searches use [m]: thigh + shank, REACH_MARGIN_M short."""
        return self.geom.thigh_m + self.geom.shank_m - REACH_MARGIN_M

    def into_reach(self, c: Cells, idx: np.ndarray, P: np.ndarray, level: int | None = None) -> np.ndarray:
        """P (M, 3) [m] moved onto the nearest point of both legs' reach balls where it lies beyond them,
        and (``level``, default :attr:`level`) into each leg's roll and knee limits (INTO_ROLL_KNEE), and its
        pitch limits too (INTO_JOINT_LIMITS).

        The optimum of most cells has a leg at full stretch, where the CoM moves like the square root
        of the distance to the ball's surface: a pattern search stalls against it. Searching over the
        projection instead lets it slide along the surface (and along the circle where both legs
        are straight). High cells' optima sit where that sphere meets a joint limit (an ankle and hip
        roll, a fully bent knee, a hip or ankle pitch): the same holds there. See
        ``physics.compiled.reach``. The balls' radius is REACH_MARGIN_M short
        of thigh + shank: a leg exactly straight is singular (PlaCo's IK cannot place its CoM to
        better than ~1e-4 rad of edge angle there), and 0.1 mm leaves the knee bent about 2.6°.
        """
        return into_reach(np.ascontiguousarray(P, dtype=float), np.ascontiguousarray(idx, dtype=np.int64),
                          c.centre_w, c.centre_s, self.search_radius, self.shapes,
                          self.level if level is None else level)

    def reach_possible(self, c: Cells) -> np.ndarray:
        """Exact test that some P_body reaches both ankles: two spheres of radius thigh + shank
        around the ankles, shifted by the hip offsets at the cell's yaw, must intersect."""
        g = self.geom
        return np.linalg.norm(c.centre_w - c.centre_s, axis=1) <= 2 * (g.thigh_m + g.shank_m)

    def hip_yaw_allowed(self, c: Cells) -> np.ndarray | None:
        """Per cell whether the trunk's yaw leaves both hip yaws within their limits; None where that does not
        decide. With both soles flat and facing +x, every posture with the hips above the ankles has both hip
        yaws equal to −yaw (``physics.compiled.legs``): when the ankle roll's limits keep the hips above the
        ankles (|roll| < π/2), a cell whose −yaw lies beyond a hip yaw's limits has no valid posture at all."""
        lim = self.params.limits
        if np.any(np.abs(lim[:, [5, 11]]) >= np.pi / 2):
            return None
        hip = -c.yaw
        return (hip >= lim[0, 0]) & (hip <= lim[1, 0]) & (hip >= lim[0, 6]) & (hip <= lim[1, 6])

    def __call__(self, c: Cells, idx: np.ndarray, P: np.ndarray):
        """Objective, thrust [N] and reason code of candidates P (M, 3) [m] for cells ``idx`` (M,).

        The objective is F* plus an exact penalty for (A-10) (continuous, so the search can slide
        along the cone's edge), and graded penalties above 2000 for postures that do not reach, leave
        the joint limits or cannot be balanced (see ``physics.compiled.balance_objective``).
        """
        self.evaluations += len(P)
        P = np.ascontiguousarray(P, dtype=float)
        idx = np.ascontiguousarray(idx, dtype=np.int64)
        return balance_objective(P, idx, c.swing, c.yaw_cs, c.fan, *self.params)

    def offsets(self, step: float, half: int) -> np.ndarray:
        """:func:`cube_offsets` mirrored for a left support (the same points in the mirrored order) [m]."""
        return cube_offsets(step, half) * self.flip


def leg_shapes(thigh_m: float, shank_m: float, radius_m: float, limits: np.ndarray, swing_side: str) -> np.ndarray:
    """Per leg (swing, support), the box in (c, φ, β) that ``physics.compiled.into_leg`` keeps the hip
    in: (2, 14), see there. ``limits`` (2, 12) [rad]: the legs' joints by role, left then right (hip
    yaw, roll, pitch, knee, ankle pitch, roll); ``radius_m``: the searches' reach radius.

    The knee's limits bound c, c² = a² + b² + 2ab·cos(knee); the ankle roll's and the hip roll's
    (−φ) bound φ; the ankle and hip pitch bound β (``physics.compiled.pitch_bounds``).
    """
    a, b = thigh_m, shank_m
    out = np.empty((2, 14))
    for row, side in enumerate((swing_side, other_side(swing_side))):
        k = 0 if side == "left" else 6
        lo, hi = limits[0, k:k + 6] + 1e-9, limits[1, k:k + 6] - 1e-9
        roll_lo, roll_hi = max(lo[5], -hi[1]), min(hi[5], -lo[1])
        c_min = math.sqrt(max(a * a + b * b + 2 * a * b * math.cos(min(hi[3], math.pi)), 0.0)) * (1 + 1e-9)
        c_max = min(radius_m, math.sqrt(a * a + b * b + 2 * a * b * math.cos(max(lo[3], 0.0))))
        out[row, :12] = (math.sin(roll_lo), math.cos(roll_lo), math.sin(roll_hi), math.cos(roll_hi), c_min, c_max,
                         a, b, lo[4], hi[4], lo[2], hi[2])
        bounds = np.array([pitch_bounds(c, out[None], 0, row) for c in np.linspace(c_min, c_max, 4001)])
        b_lo, b_hi = bounds[:, 0].max() + 1e-3, bounds[:, 1].min() - 1e-3  # inside every c's range
        out[row, 12:] = (math.tan(b_lo), math.tan(b_hi)) if b_lo < b_hi else (np.inf, -np.inf)
    return out


def generic_seeds(ev: Evaluator, c: Cells, idx: np.ndarray) -> np.ndarray:
    """Pelvis positions per cell: over the support foot, a quarter and half way to the swing foot,
    each from a deep crouch to nearly straight legs: (len(idx), 12, 3)."""
    g = ev.geom
    sup = ev.support
    sw = c.swing[idx]
    leg = g.thigh_m + g.shank_m + g.ankle_height_m
    seeds = []
    for t in (0.0, 0.25, 0.5):
        base = sup + t * (sw - sup)
        for hz in (0.42, 0.57, 0.72, 0.87):
            p = base.copy()
            p[:, 2] = np.minimum(sup[2], sw[:, 2]) + hz * leg
            seeds.append(p)
    return np.stack(seeds, axis=1)


def lens_seeds(ev: Evaluator, c: Cells, idx: np.ndarray) -> np.ndarray:
    """Pelvis positions spread over the lens where both legs reach (the two reach balls of radius
    thigh + shank): three cuts across the line of centres, two radii, five directions from straight
    up to level on either side: (len(idx), 30, 3) [m]."""
    L = ev.geom.thigh_m + ev.geom.shank_m
    a, b = c.centre_w[idx], c.centre_s[idx]
    axis = b - a
    h = np.linalg.norm(axis, axis=1)
    e = axis / np.maximum(h, 1e-12)[:, None]
    up = np.array([0.0, 0.0, 1.0]) - e[:, 2:3] * e
    up /= np.maximum(np.linalg.norm(up, axis=1), 1e-12)[:, None]
    side = np.cross(e, up) * ev.mirror  # a left support: the mirror of a right's seeds, in the same order
    half = np.maximum(L - h / 2, 0.0)  # the lens's half thickness along the line of centres
    seeds = []
    for t in (-0.5, 0.0, 0.5):
        rt = np.sqrt(np.maximum(L ** 2 - (h / 2 + abs(t) * half) ** 2, 0.0))
        centre = (a + b) / 2 + (t * half)[:, None] * e
        for frac in (0.45, 0.9):
            for phi in (0.0, np.pi / 4, -np.pi / 4, np.pi / 2, -np.pi / 2):
                seeds.append(centre + (frac * rt)[:, None] * (np.cos(phi) * up + np.sin(phi) * side))
    return np.stack(seeds, axis=1)


def cube_offsets(step: float, half: int) -> np.ndarray:
    """The (2·half + 1)³ offsets [m] of a cubic grid of spacing ``step`` [m] centred on zero: (N, 3)."""
    g = np.arange(-half, half + 1) * step
    return np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)


def pelvis_box(ev: Evaluator, c: Cells, i: int, res: float) -> np.ndarray:
    """Grid points [m] of every P_body from which both ankles may be reached (bounding box of the
    intersection of the two reach spheres) at spacing ``res``."""
    g = ev.geom
    L = g.thigh_m + g.shank_m
    cs = reach_centre(g, ev.stance.support_side, ev.support, c.yaw[i])
    cw = reach_centre(g, ev.stance.swing_side, c.swing[i], c.yaw[i])
    lo = np.maximum(cs - L, cw - L)
    hi = np.minimum(cs + L, cw + L)
    lo[2] = max(lo[2], max(cs[2], cw[2]))  # the pelvis stays above the ankles
    if ev.mirror < 0:  # a left support: the right's grid mirrored (from the far side of y, then negated)
        lo[1], hi[1] = -hi[1], -lo[1]
    axes = [np.arange(lo[k], hi[k] + 1e-12, res) for k in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3) * ev.flip


