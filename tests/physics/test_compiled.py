"""The compiled balance-space objective against the numpy functions it fuses.

The reference composes the numpy statements of the same formulas (the oracles in ``tests/``):
closed-form IK + CoM (``leg_oracle``, itself checked against PlaCo), the least balancing thrust
(``oracle.window_bounds``, nominal and robust), the edge angle (``balance.edge_angle_excess``) and the reach balls
(``robot_model.reach_centre``). Candidates are random pelvis positions around random swing cells, so
every reason code occurs.
"""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.balance_space.sweep import SweepSpec
from jethr1_plan.kinematics.closed_form import check_structure
from jethr1_plan.optimisers.compass import compass_search
from jethr1_plan.optimisers.exhaustive import exhaustive_cell
from jethr1_plan.optimisers.search import (
    EDGE_PENALTY_N_PER_DEG,
    FINE_DIRECTIONS,
    INTO_JOINT_LIMITS,
    INTO_REACH,
    INTO_ROLL_KNEE,
    Evaluator,
    generic_seeds,
    lens_seeds,
)
from jethr1_plan.physics.balance import NOMINAL, Tolerance, least_thrust
from jethr1_plan.physics.compiled.objective import balance_objective
from jethr1_plan.physics.compiled.reach import into_reach
from jethr1_plan.reasons import Reason, balances
from jethr1_plan.robot.load import load_robot
from jethr1_plan.robot.model import fan_ground_xy, reach_centre
from tests.oracles.balance import edge_angle_error, window_bounds
from tests.oracles.leg import fast_com, leg_ik


def numpy_objective(ev: Evaluator, cells, idx: np.ndarray, P: np.ndarray):
    spec, robot = ev.stance, ev.robot
    swing, yaw, fan = cells.swing[idx], cells.yaw[idx], cells.fan[idx]
    feet = {spec.support_side: (ev.support, 0.0), spec.swing_side: (swing, 0.0)}
    geom = check_structure(robot)
    qs, reach = [], np.ones(len(P), dtype=bool)
    for side in ("left", "right"):
        xyz, fyaw = feet[side]
        q_side, ok = leg_ik(geom, side, P, yaw, np.broadcast_to(xyz, (len(P), 3)), fyaw)
        qs.append(q_side)
        reach &= ok
    q = np.concatenate(qs, axis=1)
    within = np.all((q >= robot.lower_rad) & (q <= robot.upper_rad), axis=1)
    status = np.where(~reach, Reason.UNREACHABLE, np.where(within, Reason.OK, Reason.JOINT_LIMIT))
    com = fast_com(robot, P, yaw, q)
    usable = [robot.fans[i] for i in robot.swing_fans(spec.swing_side)]
    if len(usable) == 1 and not usable[0].on_trunk:
        lo, hi, blocked = window_bounds(com[:, :2], fan, ev.poly, robot.mass_kg, spec.tolerance)
        thrust = np.where((lo <= hi) & ~blocked, lo, np.inf)
        above = thrust > spec.thrust_max_n
    else:  # several fans: the least total (its own test holds it to HiGHS), within the maxima where it can be
        soles = {spec.support_side: ev.support, spec.swing_side: swing}
        fans = np.stack([fan_ground_xy(f, soles, P, yaw) for f in usable], axis=1)
        caps = np.array([min(f.thrust_max_n, spec.thrust_max_n) for f in usable])
        bounded, _ = least_thrust(com[:, :2], fans, ev.poly, robot.mass_kg, caps, spec.tolerance)
        free, _ = least_thrust(com[:, :2], fans, ev.poly, robot.mass_kg, None, spec.tolerance)
        above = np.isfinite(free) & ~np.isfinite(bounded)
        thrust = np.where(above, free, bounded)
    edge = np.maximum(edge_angle_error(ev.support[:2], com[:, :2], swing[:, :2]) - spec.rho_rad, 0.0)
    limit_excess = np.sum(np.maximum(robot.lower_rad - q, 0) + np.maximum(q - robot.upper_rad, 0), axis=1)
    g = ev.geom
    d_s = np.linalg.norm(P - reach_centre(g, spec.support_side, ev.support, yaw), axis=1)
    d_w = np.linalg.norm(P - reach_centre(g, spec.swing_side, swing, yaw), axis=1)
    reach_excess = np.maximum(np.maximum(d_s, d_w) - (g.thigh_m + g.shank_m), 0.0)
    dist = np.linalg.norm(com[:, :2] - ev.support[:2], axis=1)
    balanced = np.isfinite(thrust)
    obj = np.select([status == Reason.UNREACHABLE, status == Reason.JOINT_LIMIT, ~balanced],
                    [4000 + 1e4 * reach_excess, 3000 + 1e3 * limit_excess, 2000 + 1e3 * dist],
                    thrust + EDGE_PENALTY_N_PER_DEG * np.degrees(edge))
    reason = np.select([status == Reason.UNREACHABLE, status == Reason.JOINT_LIMIT, ~balanced, edge > 0, above],
                       [Reason.UNREACHABLE, Reason.JOINT_LIMIT, Reason.NO_BALANCE, Reason.EDGE_ANGLE,
                        Reason.THRUST_MAX],
                       Reason.OK)
    return obj, np.where((reason == Reason.OK) | (reason == Reason.THRUST_MAX), thrust, np.inf), reason


@pytest.mark.parametrize("robot_name, side, support, tol", [
    ("jethr1", "right", (0.0, -0.1125, 0.0), NOMINAL),
    ("jethr1", "left", (0.05, 0.1, 0.04), NOMINAL),
    ("jethr1", "right", (0.0, -0.1125, 0.0), Tolerance(0.1, 0.05, 0.01)),
    ("jethr1_trunk_fan", "right", (0.0, -0.1125, 0.0), Tolerance(0.1, 0.05, 0.01)),  # two fans, one on the trunk
])
def test_compiled_objective_equals_the_numpy_functions(robot_name, side, support, tol):
    spec = SweepSpec(robot=robot_name, support_side=side, support_xyz=support, thrust_max_n=18.0, tolerance=tol)
    ev = Evaluator(load_robot(spec.robot), spec.support_stance())
    rng = np.random.default_rng(3)
    n_cells, m = 400, 40_000
    swing = np.column_stack([rng.uniform(-0.6, 0.7, n_cells), rng.uniform(-0.7, 0.7, n_cells),
                             rng.uniform(0.0, 0.3, n_cells)])
    cells = ev.cells(swing)
    idx = rng.integers(0, n_cells, m)
    mid = (np.asarray(support) + swing[idx]) / 2
    P = mid + np.column_stack([rng.normal(0, 0.08, m), rng.normal(0, 0.08, m), rng.uniform(0.15, 0.45, m)])
    obj, thrust, reason = ev(cells, idx, P)
    obj_ref, thrust_ref, reason_ref = numpy_objective(ev, cells, idx, P)
    # every reason occurs, so every branch is compared
    assert set(np.unique(reason_ref)) == {Reason.OK, Reason.UNREACHABLE, Reason.JOINT_LIMIT, Reason.NO_BALANCE,
                                          Reason.EDGE_ANGLE, Reason.THRUST_MAX}
    np.testing.assert_array_equal(reason, reason_ref)
    np.testing.assert_allclose(obj, obj_ref, rtol=0, atol=1e-8)
    finite = np.isfinite(thrust_ref)
    np.testing.assert_array_equal(np.isfinite(thrust), finite)
    np.testing.assert_allclose(thrust[finite], thrust_ref[finite], rtol=0, atol=1e-10)
    assert ev.evaluations == m


def test_into_reach_is_the_nearest_point_of_both_reach_balls():
    """The projection onto the intersection of two balls: inside points stay, every result lies in
    both balls, and none of 4,000 random points of the intersection is nearer to the original."""
    rng = np.random.default_rng(7)
    radius = 0.38
    centre_w = np.array([[0.30, 0.10, 0.30], [0.0, 0.0, 0.0], [0.50, -0.2, 0.10]])
    centre_s = np.array([[0.0, -0.10, 0.08], [0.10, 0.05, 0.0], [0.0, 0.0, 0.08]])
    idx = np.repeat(np.arange(3), 200)
    P = (centre_w[idx] + centre_s[idx]) / 2 + rng.normal(0, 0.3, (len(idx), 3))
    out = into_reach(P, idx, centre_w, centre_s, radius, np.zeros((1, 2, 14)), INTO_REACH)
    dw = np.linalg.norm(out - centre_w[idx], axis=1)
    ds = np.linalg.norm(out - centre_s[idx], axis=1)
    assert np.all(dw <= radius + 1e-12) and np.all(ds <= radius + 1e-12)
    inside = ((np.linalg.norm(P - centre_w[idx], axis=1) <= radius)
              & (np.linalg.norm(P - centre_s[idx], axis=1) <= radius))
    assert inside.any() and (~inside).any()
    np.testing.assert_array_equal(out[inside], P[inside])
    for c in range(3):
        cloud = centre_w[c] + rng.uniform(-radius, radius, (20000, 3))
        lens = cloud[(np.linalg.norm(cloud - centre_w[c], axis=1) <= radius)
                     & (np.linalg.norm(cloud - centre_s[c], axis=1) <= radius)][:4000]
        rows = np.flatnonzero(idx == c)
        nearest = np.min(np.linalg.norm(P[rows, None, :] - lens[None], axis=2), axis=1)
        assert np.all(np.linalg.norm(out[rows] - P[rows], axis=1) <= nearest + 1e-9)


def _leg_joints(ev: Evaluator, cells, idx: np.ndarray, P: np.ndarray) -> dict[str, np.ndarray]:
    """Per leg (swing, support) the oracle's joints (N, 6) [rad] by role (``tests/leg_oracle``) and reach."""
    geom = check_structure(ev.robot)
    feet = {ev.stance.support_side: np.broadcast_to(ev.support, (len(idx), 3)), ev.stance.swing_side: cells.swing[idx]}
    return {role: leg_ik(geom, side, P, cells.yaw[idx], feet[side], 0.0)
            for role, side in (("swing", ev.stance.swing_side), ("support", ev.stance.support_side))}


@pytest.mark.parametrize("level", [INTO_ROLL_KNEE, INTO_JOINT_LIMITS])
def test_into_reach_moves_the_hip_into_the_joint_limits(level):
    """The searches' projection into the legs' joint limits, judged by the oracle's IK (``leg_oracle``):
    points 4 mm (σ) off valid postures are left alone when their joints are within the limits it keeps
    (roll and knee; with INTO_JOINT_LIMITS the hip and ankle pitch too) and within the reach balls;
    otherwise at least 99 % land within them (98 % with the pitch; measured 99.2 % and 98.8 %: the rest
    are left in the balls), none leaves the reach balls, and the move stays near the distance to the
    valid posture they came from (a feasible point that far away exists; measured: median 0.49 of it). The identity
    it rests on holds: with the trunk level, the sole flat and the hip above the ankle, the hip roll is
    minus the ankle roll."""
    spec = SweepSpec()
    ev = Evaluator(load_robot(spec.robot), spec.support_stance())
    rng = np.random.default_rng(5)
    swing = np.column_stack([rng.uniform(-0.5, 0.6, 400), rng.uniform(-0.6, 0.4, 400), rng.uniform(0.0, 0.3, 400)])
    cells = ev.cells(swing)
    idx = rng.choice(np.flatnonzero(ev.reach_possible(cells)), 200_000)
    P = ev.into_reach(cells, idx, (ev.support + swing[idx]) / 2 + np.column_stack(
        [rng.normal(0, 0.08, len(idx)), rng.normal(0, 0.08, len(idx)), rng.uniform(0.2, 0.45, len(idx))]), INTO_REACH)
    roles = [1, 3, 5] if level == INTO_ROLL_KNEE else [1, 2, 3, 4, 5]  # hip roll, (hip pitch,) knee, (ankle pitch,) ...
    lim = ev.params.limits

    def within(points):
        ok = np.ones(len(points), dtype=bool)
        for name, (q, reach) in _leg_joints(ev, cells, idx, points).items():
            k = 0 if (ev.stance.swing_side if name == "swing" else ev.stance.support_side) == "left" else 6
            ok &= reach & np.all((q[:, roles] >= lim[0, k:k + 6][roles]) & (q[:, roles] <= lim[1, k:k + 6][roles]),
                                 axis=1)
            above = reach & (np.abs(q[:, 5]) < np.pi / 2)  # the hip above the ankle
            np.testing.assert_allclose(q[above, 1], -q[above, 5], rtol=0, atol=1e-12)
        balls = ((np.linalg.norm(points - cells.centre_w[idx], axis=1) <= ev.search_radius)
                 & (np.linalg.norm(points - cells.centre_s[idx], axis=1) <= ev.search_radius))
        return ok, balls

    valid = np.logical_and(*within(P))
    P, idx = P[valid], idx[valid]
    noise = rng.normal(0, 0.004, P.shape)
    X = P + noise
    Q = ev.into_reach(cells, idx, X, level)
    ok_x, balls_x = within(X)
    ok_q, _ = within(Q)
    inside = ok_x & balls_x
    assert inside.mean() > 0.3 and (~inside).sum() > 10_000
    np.testing.assert_array_equal(Q[inside], X[inside])
    moved = ~inside
    assert ok_q[moved].mean() >= (0.99 if level == INTO_ROLL_KNEE else 0.98), ok_q[moved].mean()
    radius = ev.search_radius * (1 + 1e-12)
    assert np.all(np.linalg.norm(Q - cells.centre_w[idx], axis=1) <= radius)
    assert np.all(np.linalg.norm(Q - cells.centre_s[idx], axis=1) <= radius)
    ratio = np.linalg.norm(Q - X, axis=1)[moved & ok_q] / np.linalg.norm(noise, axis=1)[moved & ok_q]
    assert np.median(ratio) <= 1.0 and np.quantile(ratio, 0.99) <= 2.0


@pytest.mark.parametrize("chunk", [1, 3, 14])
def test_compass_ends_where_no_poll_direction_improves(chunk):
    """The compiled compass search, polling ``chunk`` directions at a time (14: every one), stops only
    where none of the 14 fine directions at the last step (0.5 mm, each moved onto the reach balls)
    scores lower, or at zero thrust; never above its start; and it counts every evaluation."""
    spec = SweepSpec(resolution_m=0.01)
    ev = Evaluator(load_robot(spec.robot), spec.support_stance())
    rng = np.random.default_rng(11)
    swing = np.column_stack([rng.uniform(0.1, 0.6, 60), rng.uniform(-0.5, 0.3, 60), rng.uniform(0.0, 0.25, 60)])
    cells = ev.cells(swing)
    idx = np.flatnonzero(ev.reach_possible(cells))
    P0 = ev.into_reach(cells, idx, (ev.support + swing[idx]) / 2 + np.array([0.0, 0.0, 0.38]))
    f0 = ev(cells, idx, P0)[0]
    before = ev.evaluations
    # no cap on the polls (the default stops a stage after 60), so every row ends by its step
    P, f = compass_search(ev, cells, idx, P0, f0, np.full(len(idx), 0.004), 0.0005, max_iter=100_000, chunk=chunk)
    spent = ev.evaluations - before
    assert np.all(f <= f0)
    obj, _, reason = ev(cells, idx, P)
    searched = (f > 0) & balances(reason)  # rows that fell back on their best valid posture are left out
    assert searched.sum() >= 10
    np.testing.assert_array_equal(obj[searched], f[searched])
    for d in FINE_DIRECTIONS:
        polled = ev.into_reach(cells, idx[searched], P[searched] + 0.0005 * d)
        assert np.all(ev(cells, idx[searched], polled)[0] >= f[searched] - 1e-12)
    assert spent >= searched.sum() * (6 + 6 + 14 + 14 + 1)  # a failed poll at each of 4, 2, 1, 0.5 mm; the last check


def test_the_search_slides_along_the_knee_limit_to_the_exhaustive_optimum():
    """Two high swing soles whose optimum has the swing knee fully bent against its limit while the support
    leg is straight: from the same best seed, the compass moving candidates onto the reach balls only
    stops 0.37 and 0.46 N above the exhaustive search's optimum (measured), against the knee's limit;
    moving them into the knee and roll limits too (the default) it slides along that ridge to within
    0.1 N, and its posture there has the swing knee at the limit (the oracle's IK)."""
    spec = SweepSpec()
    ev = Evaluator(load_robot(spec.robot), spec.support_stance())
    swing = np.array([[-0.02, -0.02, 0.26], [-0.16, -0.11, 0.26]])
    cells = ev.cells(swing)
    idx = np.arange(len(swing))
    seeds = np.concatenate([generic_seeds(ev, cells, idx), lens_seeds(ev, cells, idx)], axis=1)
    b, k = seeds.shape[:2]
    rows = np.repeat(idx, k)
    ends = {}
    for level in (INTO_REACH, INTO_ROLL_KNEE):
        S = ev.into_reach(cells, rows, seeds.reshape(-1, 3), level)
        obj = ev(cells, rows, S)[0].reshape(b, k)
        j = np.argmin(obj, axis=1)
        ends[level] = compass_search(ev, cells, idx, S.reshape(b, k, 3)[idx, j], obj[idx, j], np.full(b, 0.032),
                                     0.0005, levels=(level, level))
    best = np.array([exhaustive_cell(ev, cells, i, 0.005)[1] for i in idx])
    assert np.all(ends[INTO_REACH][1] > best + 0.1)
    assert np.all(np.abs(ends[INTO_ROLL_KNEE][1] - best) <= 0.1)
    q, reach = _leg_joints(ev, cells, idx, ends[INTO_ROLL_KNEE][0])["swing"]
    k0 = 0 if ev.stance.swing_side == "left" else 6
    assert np.all(reach) and np.all(ev.params.limits[1, k0 + 3] - q[:, 3] < 1e-3)  # knee within 1 mrad of its limit


def test_the_fast_paths_give_the_same_bits_as_the_angles():
    """The objective decides joint limits on the joints' cosines and sines and the edge angle on a tangent
    where those settle it; forced to compute every angle instead (limit arcs no joint can satisfy by the
    margin test, no tangent), it gives the same objective, thrust and reason to the bit, on candidates near the
    optima (where the shortcuts apply) and far from them (where they do not)."""
    spec = SweepSpec(thrust_max_n=18.0)
    ev = Evaluator(load_robot(spec.robot), spec.support_stance())
    rng = np.random.default_rng(8)
    swing = np.column_stack([rng.uniform(-0.6, 0.7, 300), rng.uniform(-0.2, 0.7, 300), rng.uniform(0.0, 0.3, 300)])
    cells = ev.cells(swing)
    idx = np.flatnonzero(ev.reach_possible(cells))
    seeds = np.concatenate([generic_seeds(ev, cells, idx), lens_seeds(ev, cells, idx)], axis=1)
    rows = np.repeat(idx, seeds.shape[1])
    S = ev.into_reach(cells, rows, seeds.reshape(-1, 3))
    P = np.concatenate([S, S + rng.normal(0, 0.01, S.shape), S + rng.normal(0, 0.1, S.shape)])
    rows = np.tile(rows, 3)
    fast = ev(cells, rows, P)
    slow_params = ev.params._replace(arcs=np.tile([1.0, 0.0, 1.0, 0.0, 0.0], (12, 1)),
                                     scalars=np.concatenate([ev.params.scalars[:8], [-1.0]]))
    slow = balance_objective(np.ascontiguousarray(P), rows, cells.swing, cells.yaw_cs, cells.fan, *slow_params)
    assert set(np.unique(fast[2])) >= {Reason.OK, Reason.JOINT_LIMIT, Reason.EDGE_ANGLE, Reason.THRUST_MAX}
    for a, b in zip(fast, slow, strict=True):
        np.testing.assert_array_equal(a, b)


def _mirrored(side_spec: SweepSpec):
    """Evaluators of a right support and of its mirror image (a left support at y → −y)."""
    right = SweepSpec(support_side="right", support_xyz=side_spec.support, thrust_max_n=side_spec.thrust_max_n)
    x, y, z = side_spec.support
    left = SweepSpec(support_side="left", support_xyz=(x, -y, z), thrust_max_n=side_spec.thrust_max_n)
    robot = load_robot(right.robot)
    return Evaluator(robot, right.support_stance()), Evaluator(robot, left.support_stance())


FLIP = np.array([1.0, -1.0, 1.0])


def test_the_objective_and_the_compass_of_a_left_support_mirror_a_right_ones_to_the_bit():
    """Jet-HR1 is symmetric: the objective at the mirror image (y → −y) of a right support's candidate, with the
    left sole supporting, is the same to the bit; so is a compass search from mirrored starts (its poll
    directions mirrored) and where it ends, mirrored."""
    ev_r, ev_l = _mirrored(SweepSpec(support_xyz=(0.0, -0.1125, 0.0), thrust_max_n=23.0))
    rng = np.random.default_rng(9)
    swing = np.column_stack([rng.uniform(-0.5, 0.7, 200), rng.uniform(-0.1, 0.6, 200), rng.uniform(0.0, 0.3, 200)])
    c_r, c_l = ev_r.cells(swing), ev_l.cells(swing * FLIP)
    np.testing.assert_array_equal(c_l.yaw, -c_r.yaw)
    idx = np.repeat(np.flatnonzero(ev_r.reach_possible(c_r)), 50)
    P = (ev_r.support + swing[idx]) / 2 + np.column_stack([rng.normal(0, 0.06, len(idx)), rng.normal(0, 0.06, len(idx)),
                                                           rng.uniform(0.2, 0.45, len(idx))])
    for a, b in zip(ev_r(c_r, idx, P), ev_l(c_l, idx, P * FLIP), strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(ev_l.into_reach(c_l, idx, P * FLIP), ev_r.into_reach(c_r, idx, P) * FLIP)
    rows = np.unique(idx)[:60]
    P0 = ev_r.into_reach(c_r, rows, (ev_r.support + swing[rows]) / 2 + np.array([0.0, 0.0, 0.35]))
    f0 = ev_r(c_r, rows, P0)[0]
    P_r, f_r = compass_search(ev_r, c_r, rows, P0, f0, np.full(len(rows), 0.032), 0.0005)
    P_l, f_l = compass_search(ev_l, c_l, rows, P0 * FLIP, f0, np.full(len(rows), 0.032), 0.0005)
    assert np.any(f_r < f0 - 1.0)
    np.testing.assert_array_equal(f_l, f_r)
    np.testing.assert_array_equal(P_l, P_r * FLIP)


def test_the_exhaustive_search_of_a_left_support_mirrors_a_right_ones_to_the_bit():
    """The exhaustive search's grids are mirrored for a left support: its answer at a mirrored cell is the mirror
    of the right support's, to the bit."""
    ev_r, ev_l = _mirrored(SweepSpec(support_xyz=(0.0, -0.1125, 0.0), thrust_max_n=23.0))
    swing = np.array([[0.35, 0.05, 0.12], [0.1, 0.25, 0.22]])
    c_r, c_l = ev_r.cells(swing), ev_l.cells(swing * FLIP)
    for i in range(len(swing)):
        p_r, f_r, r_r = exhaustive_cell(ev_r, c_r, i, 0.01)
        p_l, f_l, r_l = exhaustive_cell(ev_l, c_l, i, 0.01)
        assert (f_l, r_l) == (f_r, r_r) and r_r == Reason.OK
        np.testing.assert_array_equal(p_l, p_r * FLIP)
