"""``timing: {mode: fastest}``: each swing and transfer run as fast as the rows' own dynamics allow.

The path of a phase is fixed by the plan (a swing: the swing sole and P_body linear between the
optimised samples, u ∈ [0, N − 1] the fractional sample index; a transfer: P_body and yaw blended
linearly, s ∈ [0, 1], the thrust ramped along s); only when each row passes changes. The builder
writes the phase's rows on a fine grid of the path (thrust, tolerance share and legs exactly as the
rows will have them), ``physics.path_dynamics`` turns them into constraints linear in s̈ and ṡ², and
TOPP-RA (``control.time_optimal``) gives the fastest law. The rows are then written on the output clock
(the law's duration rounded up to whole rows, the law slowed uniformly to fill them) and checked
again from the rows themselves, by second central differences as ``verify`` does; where a row breaks
a constraint (the rows see the sample corners the smooth grid averages), the law is slowed around it
and solved again.

The dynamic constraints are held at ``dynamic_share`` of each row's tolerance share (the rest is
what the motion may spend) and of ``balance.sole_margin_m``; the solver sees the motion's terms
``DYNAMIC_MARGIN`` larger than they are and the velocity bounds that much tighter, so that the rows
between grid points keep to them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from jethr1_plan.control.time_optimal import TimeLaw, binding_constraints, fastest_law
from jethr1_plan.geometry import SIDES, convex_hull, pose_difference, sole_polygon
from jethr1_plan.physics.path_dynamics import Limits, path_constraints
from jethr1_plan.physics.row_dynamics import row_derivatives
from jethr1_plan.records.plan_rows import RowField

__all__ = ["DYNAMIC_MARGIN", "FastTiming", "time_phase"]

DYNAMIC_MARGIN = 1.15  # the solver's motion terms × this, its velocity bounds ÷ this²
GRID_PER_SAMPLE = 4  # swing grid points per optimised sample
TRANSFER_GRID = 101  # transfer grid points over s ∈ [0, 1]
SWING_STENCIL = 1.0  # the swing's derivatives over ± one sample (they average its corners) [samples]
TRANSFER_STENCIL = 0.02  # [s units]
ROUNDS = 16  # slow-downs around rows that break a constraint
SLOW = 0.7  # ṡ² × this around such a row, per round
CORNER_PASSES = 3  # solves with the corners' spikes linearised at the previous law's speed
CORNER_X_FLOOR = 1e-2  # the least ṡ² [samples²/s²] a corner's tangent is taken at


@dataclass(frozen=True)
class FastTiming:
    """The fastest timing's settings (``scenario.Timing``): ``dynamic_share`` of each row's tolerance share
    (and sole margin) held under the rows' motion, ``safety`` on the joint velocity, torque and friction
    limits (the fans' lag ÷ it), the fans' spin-down allowance [N], the phases' floors and caps [s]; the
    defaults are the scenario's."""

    dynamic_share: float
    safety: float
    spin_down_n: float
    min_swing_s: float
    min_transfer_s: float
    max_swing_s: float
    max_transfer_s: float

    @classmethod
    def of(cls, timing) -> FastTiming:
        """The settings of a scenario's ``timing`` (``scenario.Timing``)."""
        return cls(timing.dynamic_share, timing.safety_factor, timing.spin_down_n, timing.min_swing_s,
                   timing.min_transfer_s, timing.max_swing_s, timing.max_transfer_s)


def _grid_table(seq, start: int) -> dict[str, np.ndarray]:
    """The rows written from ``start`` on, as arrays: base (G, 4, 4), q, thrust (G, F), share (G,)."""
    c = seq.rows.columns
    p = np.asarray(c[RowField.P_BODY_M][start:], dtype=float)
    yaw = np.asarray(c[RowField.YAW_RAD][start:], dtype=float)
    base = np.zeros((len(p), 4, 4))
    base[:, 0, 0], base[:, 0, 1], base[:, 1, 0], base[:, 1, 1] = np.cos(yaw), -np.sin(yaw), np.sin(yaw), np.cos(yaw)
    base[:, 2, 2] = base[:, 3, 3] = 1.0
    base[:, :3, 3] = p
    thrust = seq.rows.fan_array()[start:]
    share = np.asarray(c[RowField.TOLERANCE_SHARE][start:], dtype=float)
    return {"base": base, "q": np.asarray(c[RowField.Q_RAD][start:], dtype=float), "thrust": thrust,
            "share": np.where(np.isfinite(share), share, 1.0),
            "time": np.asarray(c[RowField.TIME_S][start:], dtype=float)}


def _path_derivatives(base: np.ndarray, q: np.ndarray, thrust: np.ndarray, grid: np.ndarray, stencil: float
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q', q'' (G, 6 + J), F' (G, F)) along a uniform ``grid`` by differences over ± ``stencil`` (one-sided
    at the ends; q'' there that of the nearest point with both sides)."""
    G = len(grid)
    k = max(1, round(stencil / (grid[1] - grid[0])))
    i = np.arange(G)
    ip, im = np.minimum(i + k, G - 1), np.maximum(i - k, 0)
    hp, hm = grid[ip] - grid, grid - grid[im]
    dp = np.concatenate([pose_difference(base, base[ip]), q[ip] - q], axis=1)
    dm = np.concatenate([pose_difference(base, base[im]), q[im] - q], axis=1)
    both = (hp > 0) & (hm > 0)
    d1, d2 = np.zeros_like(dp), np.zeros_like(dp)
    den = np.where(both, hp * hm * (hp + hm), 1.0)[:, None]
    d1[both] = ((hm**2)[:, None] * dp - (hp**2)[:, None] * dm)[both] / den[both]
    d2[both] = (2 * (hm[:, None] * dp + hp[:, None] * dm))[both] / den[both]
    d1[~both] = np.where((hp > 0)[:, None], dp / np.maximum(hp, 1e-12)[:, None], -dm / np.maximum(hm, 1e-12)[:, None])[
        ~both]
    inner = np.flatnonzero(both)
    for j in np.flatnonzero(~both):
        d2[j] = d2[inner[np.argmin(np.abs(inner - j))]] if len(inner) else 0.0
    dF = (thrust[ip] - thrust[im]) / np.maximum(hp + hm, 1e-12)[:, None]
    return d1, d2, dF


def _polygon(seq, feet: dict[str, np.ndarray], supports: tuple[str, ...], margin: float) -> np.ndarray:
    r = seq.robot
    polys = [sole_polygon(feet[s][:2], 0.0, r.sole_length_m, r.sole_width_m, margin) for s in supports]
    return polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys))


def _short(name: str) -> str:
    """The binding constraint's name as summary.json reports it (an edge's mass sign dropped)."""
    if name.startswith("ZMP edge"):
        return "dynamic ZMP, support edge " + name.split()[2]
    if name.startswith("friction"):
        return "friction"
    if name.startswith("torsion"):
        return "support sole's torsion (yaw friction)"
    if name.startswith("torque"):
        return "torque " + name.split()[1]
    return name


def _corner_terms(seq, tab: dict, grid: np.ndarray, supports: tuple[str, ...], polygon: np.ndarray,
                  limits: Limits) -> np.ndarray:
    """(G, m) α ≥ 0: at each optimised sample (a corner of the piecewise linear path), how much a row passing
    it at ṡ adds to each constraint, α·ṡ: the path's velocity q' turns by Δq' there within one row, an
    acceleration Δq'·ṡ/Δt; α is the constraints' s̈ coefficient of that turn (0 where it helps)."""
    G = len(grid)
    out = np.zeros((G, 0))
    step = grid[1] - grid[0]
    at = [i for i in range(1, G - 1) if abs(grid[i] - round(grid[i])) < 1e-9]
    base, q = tab["base"], tab["q"]
    turn = np.zeros((G, base.shape[0] and 6 + q.shape[1]))
    for i in at:
        dp = np.concatenate([pose_difference(base[i], base[i + 1]), q[i + 1] - q[i]])
        dm = np.concatenate([pose_difference(base[i], base[i - 1]), q[i - 1] - q[i]])
        turn[i] = (dp + dm) / step / seq.dt
    idx = np.array(at, dtype=int)
    con = path_constraints(seq.robot, base[idx], q[idx], turn[idx], np.zeros_like(turn[idx]), tab["thrust"][idx],
                           np.zeros_like(tab["thrust"][idx]), supports, polygon,
                           Limits(limits.tolerance, limits.share[idx], limits.safety, limits.friction,
                                  limits.spin_down_n))
    out = np.zeros((G, con.a.shape[1]))
    out[idx] = np.maximum(con.a, 0.0) * DYNAMIC_MARGIN
    return out


def _spread(corner: np.ndarray, grid: np.ndarray, per_row: np.ndarray) -> np.ndarray:
    """(G, m) the corners' spikes as the rows around them feel them: a row φ samples from a corner, the rows
    ``per_row`` (G,) samples apart, sees the turn reduced by (1 − φ/per_row)₊ (its stencil straddles the corner
    for a shorter time); the corners on both sides add."""
    at = np.flatnonzero(np.any(corner > 0, axis=1))
    out = np.zeros_like(corner)
    if not len(at):
        return out
    span = np.maximum(per_row, 1e-9)
    for i in at:
        w = np.clip(1.0 - np.abs(grid - grid[i]) / span, 0.0, 1.0)
        out += w[:, None] * corner[i][None, :]
    return out


def _row_values(seq, start: int, stop: int, supports: tuple[str, ...], polygon: np.ndarray, fast: FastTiming,
                tolerance: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row of ``start:stop``: the largest constraint value (> 0 broken) and ṡ² bound (< 1 broken) of its own
    motion (second central differences over the row before and the one after; the last row held), and that
    constraint's value at rest."""
    lo = max(start - 1, 0)
    tab = _grid_table(seq, lo)
    n = stop - lo
    base, q, thrust, share = tab["base"][:n], tab["q"][:n], tab["thrust"][:n], tab["share"][:n]
    v, a = row_derivatives(base, q, seq.dt)
    dF = np.gradient(thrust, seq.dt, axis=0) if n > 1 else np.zeros_like(thrust)
    limits = Limits(tolerance, fast.dynamic_share * share, fast.safety, seq.robot.sole_friction, fast.spin_down_n)
    con = path_constraints(seq.robot, base, q, v, a, thrust, dF, supports, polygon, limits)
    value = con.b + con.c
    k = np.argmax(value, axis=1)
    rows = np.arange(len(k))
    worst, rest = value[rows, k], con.c[rows, k]
    return worst[start - lo:], con.x_max[start - lo:], rest[start - lo:]


def time_phase(seq, snap: tuple, build: Callable[[np.ndarray, bool], None], kind: str, feet: dict[str, np.ndarray],
               supports: tuple[str, ...], span: float, fast: FastTiming, fixed_s: float, include_end: bool = False
               ) -> dict:
    """Write one phase (after ``snap``) timed fastest. ``build(positions, include_end)`` writes its rows at the
    path places ``positions`` (a swing: fractional samples in [0, ``span``]; a transfer: s in [0, 1]); ``kind``
    'swing' or 'transfer'. Rows still breaking a constraint after :data:`ROUNDS` slow-downs are marked
    infeasible. Returns the phase's record for summary.json's ``timing.phases``."""
    tol = seq.tolerance
    tolerance = (tol.thrust, tol.mass, tol.com_m)
    swing = kind == "swing"
    grid = (np.linspace(0.0, span, GRID_PER_SAMPLE * round(span) + 1) if swing
            else np.linspace(0.0, 1.0, TRANSFER_GRID))
    start = snap[0]
    tab = _phase_table(seq, snap, build, grid, swing)
    dq, ddq, dF = _path_derivatives(tab["base"], tab["q"], tab["thrust"], grid,
                                    SWING_STENCIL if swing else TRANSFER_STENCIL)
    polygon = _polygon(seq, feet, supports, fast.dynamic_share * seq.margin)
    limits = Limits(tolerance, fast.dynamic_share * tab["share"], fast.safety, seq.robot.sole_friction,
                    fast.spin_down_n)
    con = path_constraints(seq.robot, tab["base"], tab["q"], dq, ddq, tab["thrust"], dF, supports, polygon, limits)
    a, b = con.a * DYNAMIC_MARGIN, con.b * DYNAMIC_MARGIN
    c = np.minimum(con.c, 0.0)  # a point that breaks a limit at rest is no faster at rest: the rows say so
    x_max = con.x_max / DYNAMIC_MARGIN**2
    corner = _corner_terms(seq, tab, grid, supports, polygon, limits) if swing else None
    floor = fast.min_swing_s if swing else fast.min_transfer_s
    cap = fast.max_swing_s if swing else fast.max_transfer_s
    law: TimeLaw | None = None
    rounds = 0
    worst = xb = np.zeros(0)
    for rounds in range(ROUNDS + 1):
        law = _fastest_with_corners(grid, a, b, c, x_max, corner, seq.dt)
        if law is None:
            break
        duration = max(law.duration_s, floor)
        if duration > cap:  # no faster within its limits than its cap allows: refused below
            break
        n = max(1, math.ceil(duration / seq.dt - 1e-9))
        stretch = law.duration_s / (n * seq.dt)
        positions = law.positions(np.arange(n + 1 if include_end else n) * seq.dt * stretch)
        seq.restore(snap)
        build(positions, include_end)
        if seq.first_infeasible is not snap[3]:  # a row that does not hold at rest: no timing helps it
            break
        worst, xb, rest = _row_values(seq, start, len(seq.rows), supports, polygon, fast, tolerance)
        bad = np.flatnonzero((worst > 0.0) | (xb < 1.0))
        if not len(bad) or rounds == ROUNDS or np.all((rest[bad] >= 0.0) & (worst[bad] > 0.0)):
            break
        x_max = _slowed(x_max, law, grid, positions, bad, worst, xb, rest, swing)
    phase = {"step": int(seq.rows.columns[RowField.STEP][start]) if len(seq.rows) > start else None, "phase": kind,
             "rows": len(seq.rows) - start, "fixed_duration_s": fixed_s, "rounds": rounds}
    if swing:
        phase["trunk"] = ("linear between samples" if not seq.smooth_trunk else "monotone cubic through the samples"
                          + (f", linear on segments {sorted(seq.linear_segments)}" if seq.linear_segments else ""))
    if law is None or law.duration_s > cap:
        seq.restore(snap)
        build(np.linspace(0.0, span if swing else 1.0, max(1, round(fixed_s / seq.dt)) + int(include_end)),
              include_end)
        if law is None:
            _mark_all(seq, start, f"no timing of this {kind} keeps its rows' dynamics within the limits, even at rest")
            return {**phase, "rows": len(seq.rows) - start, "duration_s": None, "binding": []}
        _mark_all(seq, start, f"the fastest {kind} its limits allow takes {law.duration_s:.2f} s, above "
                  f"timing.max_{kind}_s {cap:g} s")
        return {**phase, "rows": len(seq.rows) - start, "duration_s": None, "fastest_s": law.duration_s,
                "binding": []}
    return {**phase, **_timed(seq, start, kind, law, (a, b, c, x_max), con, worst, xb, include_end, floor, cap,
                              fixed_s)}


def _phase_table(seq, snap: tuple, build: Callable[[np.ndarray, bool], None], grid: np.ndarray, swing: bool) -> dict:
    """The phase's rows written at the grid's places (the smooth trunk kept off the segments where its postures
    fail: reach, limits), read back as a table; the sequence restored to ``snap``."""
    start = snap[0]
    seq.linear_segments = set()
    for _ in range(4):
        seq.restore(snap)
        build(grid, True)
        failed = np.flatnonzero(~np.asarray(seq.rows.columns[RowField.FEASIBLE][start:], dtype=bool))
        if not (swing and seq.smooth_trunk and len(failed)):
            break
        seg = np.floor(grid[failed]).astype(int)
        seq.linear_segments |= {int(k) for k in np.concatenate([seg - 1, seg, seg + 1])}
    tab = _grid_table(seq, start)
    seq.restore(snap)
    return tab


def _fastest_with_corners(grid: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray, x_max: np.ndarray,
                          corner: np.ndarray | None, dt: float) -> TimeLaw | None:
    """The fastest law within the constraints a·s̈ + b·ṡ² + c ≤ 0, ṡ² ≤ x_max; at a swing's corners (``corner``)
    their one-row spike α·ṡ bounded above by its tangent at the last law's ṡ (√x is concave), at most where it
    leaves half the row's slack at rest (so that rest stays feasible), over ``CORNER_PASSES``."""
    law = fastest_law(grid, a, b, c, x_max)
    for _ in range(CORNER_PASSES if corner is not None else 0):
        if law is None:
            break
        assert corner is not None
        spread = _spread(corner, grid, law.sd * dt)
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(spread > 0, -c / spread, np.inf)
        root = np.clip(np.minimum(np.sqrt(np.maximum(law.sd**2, CORNER_X_FLOOR))[:, None], room), 1e-9, None)
        alpha = np.where(c < 0, spread, 0.0)
        law = fastest_law(grid, a, b + alpha / (2 * root), c + alpha * root / 2, x_max)
    return law


def _slowed(x_max: np.ndarray, law: TimeLaw, grid: np.ndarray, positions: np.ndarray, bad: np.ndarray,
            worst: np.ndarray, xb: np.ndarray, rest: np.ndarray, swing: bool) -> np.ndarray:
    """``x_max`` (ṡ² bounds) lowered around each row that broke a constraint by what it needs: its motion's part
    scales with ṡ² (ṡ at a corner)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(worst > 0, (-rest / (worst - rest)) ** 2, xb)
    need = np.clip(np.nan_to_num(need, nan=SLOW), 0.05, SLOW)
    rows_at = positions[np.minimum(bad, len(positions) - 1)]
    reach = np.abs(np.gradient(positions))[np.minimum(bad, len(positions) - 1)] + (
        0.5 if swing else TRANSFER_STENCIL)
    factor = np.ones(len(grid))
    for u, r, f in zip(rows_at, reach, need[bad], strict=True):
        factor = np.where(np.abs(grid - u) <= r, np.minimum(factor, f), factor)
    return np.where(factor < 1.0, np.minimum(x_max, law.sd**2) * factor, x_max)


def _timed(seq, start: int, kind: str, law: TimeLaw, terms: tuple, con, worst: np.ndarray, xb: np.ndarray,
           include_end: bool, floor: float, cap: float, fixed_s: float) -> dict:
    """A phase timed fastest: its duration, the constraints that bind it and for how much of the time; rows still
    breaking a constraint, or a phase over its cap in whole rows, marked infeasible."""
    a, b, c, x_max = terms
    duration = (len(seq.rows) - start - int(include_end)) * seq.dt
    names = binding_constraints(law, a, b, c, x_max, con.names, con.x_name)
    dt = np.diff(law.times)
    shares: dict[str, float] = {}
    for name, t in zip(names, dt, strict=True):
        shares[_short(name)] = shares.get(_short(name), 0.0) + float(t)
    total = float(dt.sum()) or 1.0
    binding = [{"constraint": k, "time_fraction": v / total}
               for k, v in sorted(shares.items(), key=lambda kv: -kv[1])]
    broken = np.flatnonzero((worst > 0.0) | (xb < 1.0))
    if len(broken):
        _mark_rows(seq, start, broken, worst, kind)
    if duration > cap + 1e-9:
        _mark_all(seq, start, f"the fastest {kind} its limits allow takes {duration:.2f} s (whole rows), above "
                  f"timing.max_{kind}_s {cap:g} s")
    return {"duration_s": duration, "fastest_s": law.duration_s,
            "speed_up": fixed_s / duration if duration > 0 else None, "floor_applied": bool(law.duration_s < floor),
            "binding": binding,
            "least_dynamic_slack": float(-np.max(worst)) if len(worst) else None}


def _mark_all(seq, start: int, reason: str) -> None:
    c = seq.rows.columns
    r = start
    c[RowField.FEASIBLE][r] = False
    c[RowField.REASON][r] = c[RowField.REASON][r] or reason
    seq.mark(int(c[RowField.STEP][r]), str(c[RowField.PHASE][r]), int(c[RowField.SAMPLE][r]), reason)


def _mark_rows(seq, start: int, broken: np.ndarray, worst: np.ndarray, kind: str) -> None:
    c = seq.rows.columns
    for i in broken.tolist():
        r = start + i
        reason = (f"the rows' motion breaks a dynamic limit of the fastest {kind} by {worst[i]:.4f} "
                  "(dynamic ZMP, friction, torque, joint velocity or fan lag) after every slow-down")
        c[RowField.FEASIBLE][r] = False
        c[RowField.REASON][r] = c[RowField.REASON][r] or reason
        seq.mark(int(c[RowField.STEP][r]), kind, int(c[RowField.SAMPLE][r]), reason, list(c[RowField.P_BODY_M][r]))


def sides_down(kind: str, support: str) -> tuple[str, ...]:
    """The soles on the ground in a phase."""
    return SIDES if kind == "transfer" else (support,)
