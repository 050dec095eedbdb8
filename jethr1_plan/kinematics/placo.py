"""Posture kinematics through PlaCo (Paper A, III-B): from P_body and the body yaw to the leg joints.

PlaCo's KinematicsSolver solves the leg IK with the trunk pose imposed (``mask_fbase``) and two
soft sole tasks; the residual is checked against the tolerance on both feet, so a candidate is
either converged or carries the reason it is not (:class:`~jethr1_plan.reasons.Reason`).

A :class:`PlacoPostureSolver` owns one PlaCo robot and solver; it cannot be pickled: each worker
process builds its own.
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.geometry import SIDES, pose_matrix
from jethr1_plan.kinematics.base import PostureBatch, Stance
from jethr1_plan.reasons import Reason
from jethr1_plan.robot.model import RobotModel, reach_centre

__all__ = ["BENT_SEED", "PlacoPostureSolver", "leg_reach_ok"]

OK, UNREACHABLE, JOINT_LIMIT, NOT_CONVERGED = Reason.OK, Reason.UNREACHABLE, Reason.JOINT_LIMIT, Reason.NOT_CONVERGED

#: bent-knee seed per leg (hip yaw, hip roll, hip pitch, knee, ankle pitch, ankle roll) [rad]
BENT_SEED = np.array([0.0, 0.0, -0.5, 1.0, -0.5, 0.0])


def leg_reach_ok(model: RobotModel, stance: Stance, p_body: np.ndarray) -> np.ndarray:
    """(N,) True where both hip–ankle distances are within the leg's geometric range."""
    longest_sq = (model.thigh_m + model.shank_m) ** 2
    shortest_sq = (abs(model.thigh_m - model.shank_m) + 0.05) ** 2  # the knee limit keeps it well above
    ok = np.ones(len(p_body), dtype=bool)
    for side in SIDES:  # flat feet: the ankle is straight above the sole
        d = p_body - reach_centre(model, side, stance.foot_pose(side)[:3, 3], stance.body_yaw)
        dist_sq = np.einsum("ij,ij->i", d, d)
        ok &= (dist_sq <= longest_sq) & (dist_sq >= shortest_sq)
    return ok


class PlacoPostureSolver:
    """Leg IK through PlaCo for batches of P_body candidates.

    Args:
        model: the robot.
        tol_m: position residual accepted on each sole [m].
        tol_rad: orientation residual accepted on each sole [rad].
        max_iter: Gauss–Newton iterations before a candidate is declared not converged.
    """

    def __init__(self, model: RobotModel, tol_m: float = 1e-6, tol_rad: float = 1e-6, max_iter: int = 15):
        import placo

        self.model = model
        self.tol_m, self.tol_rad, self.max_iter = tol_m, tol_rad, max_iter
        self.robot = model.wrapper()
        self.solver = placo.KinematicsSolver(self.robot)
        self.solver.mask_fbase(True)
        self.tasks = {}
        for side in SIDES:
            sole = model.legs[side].sole
            task = self.solver.add_frame_task(sole, np.eye(4))
            task.configure(sole, "soft", 1.0, 1.0)
            self.tasks[side] = task
        self._task_errors = [sub for t in self.tasks.values() for sub in (t.position(), t.orientation())]
        self._legs = model.leg_index
        self.seed = self._bent_seed()
        self._tol = min(tol_m, tol_rad)
        self._lo = model.lower_rad + 1e-9
        self._hi = model.upper_rad - 1e-9
        self.evaluations = 0
        #: when a list, every IK run appends (trunk pose, P_body, start q, left/right targets, iterations):
        #: the benchmark replays them in a bare PlaCo loop
        self.replay_log: list | None = None

    def _bent_seed(self) -> np.ndarray:
        """Every joint at 0 (within its limits), the legs' at :data:`BENT_SEED`."""
        seed = np.clip(np.zeros(len(self.model.joint_names)), self.model.lower_rad, self.model.upper_rad)
        seed[self._legs] = np.concatenate([BENT_SEED, BENT_SEED])
        return seed

    def set_stance(self, stance: Stance) -> None:
        """Point the sole tasks at the stance's feet and cache the trunk orientation."""
        if stance is getattr(self, "_stance", None):
            return
        self._targets = {side: stance.foot_pose(side) for side in SIDES}
        for side, task in self.tasks.items():
            task.T_world_frame = self._targets[side]
        self._T_trunk = pose_matrix(np.zeros(3), stance.body_yaw)
        self._stance = stance
        # bent-knee seed with the hip yaws that keep each foot at its yaw under the turned trunk
        self.seed = self._bent_seed()
        for side in SIDES:
            k = self.model.legs[side].index[0]
            foot_yaw = stance.support_yaw if side == stance.support_side else stance.swing_yaw
            yaw = (foot_yaw - stance.body_yaw + np.pi) % (2 * np.pi) - np.pi
            self.seed[k] = np.clip(yaw, self.model.lower_rad[k], self.model.upper_rad[k])

    def solve_one(self, p_body: np.ndarray, q_start: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool, float, int]:
        """Solve one candidate from ``q_start``: (q, com, converged, residual, iterations).

        Gauss–Newton steps (``update_kinematics`` + ``solve``) until the sole tasks' errors are
        within tolerance. PlaCo reports each task's error for the state *before* the step just
        taken, so convergence is declared when the state before the last step was already within
        tolerance (the last step only refines it): the reported residual is exact and an upper
        bound. The loop stops early when the error no longer halves (a joint limit or the
        stretched-leg singularity).
        """
        robot = self.robot
        update, solve = robot.update_kinematics, self.solver.solve
        pos_l, ori_l, pos_r, ori_r = (e.error_norm for e in self._task_errors)
        T = self._T_trunk.copy()
        T[:3, 3] = p_body
        robot.set_T_world_fbase(T)
        robot.state.q[7:] = q_start
        tol, max_iter = self._tol, self.max_iter
        update()
        solve(True)
        update()
        solve(True)
        it = 2
        prev = lagged = np.inf
        while it < max_iter:
            update()
            solve(True)
            it += 1
            lagged = max(pos_l(), pos_r())  # positions first, orientations once they are in
            if lagged <= tol:
                lagged = max(lagged, ori_l(), ori_r())
                if lagged <= tol:
                    break
            if it >= 4 and lagged > 0.8 * prev:
                break
            prev = lagged
        update()
        return robot.state.q[7:].copy(), robot.com_world(), lagged <= tol, lagged, it

    def solve_batch(self, stance: Stance, p_body: np.ndarray, warm: np.ndarray | None = None) -> PostureBatch:
        """Postures for candidates ``p_body`` (N, 3) [m] under ``stance``.

        Candidates that are geometrically out of reach are marked without running IK. The others
        are visited in a deterministic order (sorted by position), each warm-started from the last
        converged neighbour (or ``warm``, or the bent-knee seed).
        """
        p_body = np.atleast_2d(np.asarray(p_body, dtype=float))
        n = len(p_body)
        self.set_stance(stance)
        q = np.zeros((n, len(self.model.joint_names)))
        com = np.full((n, 3), np.nan)
        status = np.full(n, UNREACHABLE, dtype=np.int8)
        residual = np.full(n, np.inf)
        reach = leg_reach_ok(self.model, stance, p_body)
        idx = np.flatnonzero(reach)
        order = idx[np.lexsort((p_body[idx, 0], p_body[idx, 1], np.round(p_body[idx, 2], 2)))]
        start = self.seed if warm is None else warm
        iters = np.zeros(n, dtype=np.int32)
        log = self.replay_log
        solve_one = self.solve_one
        results = []
        legs = self._legs  # the joints the sole tasks move (any other stays at its seed)
        lo, hi = self._lo[legs] + 1e-6, self._hi[legs] - 1e-6
        for i in order.tolist():
            p = p_body[i]
            qi, ci, ok, ri, it = solve_one(p, start)
            if log is not None:
                log.append((self._T_trunk, p, start, self._targets["left"], self._targets["right"], it))
            if not ok and start is not self.seed and not ((qi[legs] <= lo).any() or (qi[legs] >= hi).any()):
                # not converged and no joint at a limit: a far neighbour can mislead, retry from the seed
                qi, ci, ok, ri, it2 = solve_one(p, self.seed)
                if log is not None:
                    log.append((self._T_trunk, p, self.seed, self._targets["left"], self._targets["right"], it2))
                it += it2
            results.append((qi, ci, ok, ri, it))
            if ok:
                start = qi
        if results:
            qs, coms, oks, res, its = zip(*results, strict=True)
            qs, oks = np.array(qs), np.array(oks)
            at_limit = np.any((qs[:, legs] <= lo) | (qs[:, legs] >= hi), axis=1)
            q[order], com[order] = qs, np.array(coms)
            status[order] = np.where(oks, OK, np.where(at_limit, JOINT_LIMIT, NOT_CONVERGED))
            residual[order], iters[order] = np.array(res), np.array(its)
        self.evaluations += n
        return PostureBatch(q=q, com=com, status=status, residual_m=residual, iterations=iters)
