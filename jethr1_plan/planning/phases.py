"""The plan's phases at the output rate, one step at a time: stand → (transfer → swing)* → transfer →
stand (:class:`Sequence`), each phase written by :class:`~.sequence.SequenceBuilder`, timed fastest
(:mod:`.fast_timing`) or paced (:mod:`.pacing`) where the scenario asks."""

from __future__ import annotations

import numpy as np

from jethr1_plan.geometry import SIDES
from jethr1_plan.kinematics import PostureSolver
from jethr1_plan.planning.fast_timing import FastTiming, time_phase
from jethr1_plan.planning.pacing import pace_swing
from jethr1_plan.planning.problems import yaw_function
from jethr1_plan.planning.results import StepResult
from jethr1_plan.planning.sequence import FanThrust, SequenceBuilder
from jethr1_plan.records.infeasible import Infeasible
from jethr1_plan.records.plan_rows import Rows
from jethr1_plan.robot.model import RobotModel, reach_centre
from jethr1_plan.scenario import Scenario

__all__ = ["STANDING_HEIGHT_FRACTION", "Sequence", "build_sequence", "standing_pose"]

STANDING_HEIGHT_FRACTION = 0.9  # standing pelvis height over the soles, as a fraction of the leg length


def standing_pose(robot: RobotModel, feet: dict[str, np.ndarray], yaw_rad: float) -> np.ndarray:
    """P_body [m] over the midpoint of both soles, knees bent.

    The height is the highest of 0.9, 0.89, ... leg lengths over the higher sole at which both
    hip–ankle distances are at most 95 % of the leg's stretch (so wide stances crouch).
    """
    mid = 0.5 * (feet["left"] + feet["right"])
    base = max(feet["left"][2], feet["right"][2])
    reach = 0.95 * (robot.thigh_m + robot.shank_m)
    for frac in np.arange(STANDING_HEIGHT_FRACTION, 0.3, -0.01):
        p = np.array([mid[0], mid[1], base + frac * robot.leg_length_m])
        ok = True
        for side in SIDES:
            ok &= bool(np.linalg.norm(p - reach_centre(robot, side, feet[side], yaw_rad)) <= reach)
        if ok:
            return p
    return p


class Sequence:
    """Stand → (transfer → swing)* → transfer → stand, at the scenario's output rate, one step at a time
    (:meth:`add`, then :meth:`finish`); with ``stop_at_infeasible``, :meth:`add` stops at the end of the
    phase holding the first infeasible row and returns it (the plan is refused then). Under the robust
    policy a swing whose multibody ZMP comes within ``sole_margin_m`` of the sole's edge is paced
    (:func:`~.pacing.pace_swing`); with ``strict_dynamics`` its rows still that near are infeasible."""

    def __init__(self, scenario: Scenario, robot: RobotModel, solver: PostureSolver, schedule=None,
                 stop_at_infeasible: bool = False, strict_dynamics: bool = False):
        tm, b = scenario.timing, scenario.balance
        self.scenario, self.robot, self.stop, self.strict = scenario, robot, stop_at_infeasible, strict_dynamics
        self.seq = SequenceBuilder(robot, solver, tm.rate_hz, b.thrust_max_n, b.rho_rad, b.sole_margin_m, b.tolerance)
        self.fast = FastTiming.of(tm) if tm.fastest else None
        # a yaw schedule laid its rows out by the default law; a fastest timing replaces pacing
        self.paced = b.policy == "robust" and schedule is None and self.fast is None
        if schedule is not None:
            self.seq.yaw_of_row = schedule.at_row
        self.seq.smooth_trunk = self.fast is not None
        # a swing refused at a row need not be built past it (a fastest timing's search reads whole swings)
        self.seq.stop_at_infeasible = stop_at_infeasible and self.fast is None
        self.feet = {k: v.copy() for k, v in scenario.start.items()}
        self.p_prev, self.yaw_prev = standing_pose(robot, self.feet, 0.0), 0.0
        self.thrust_out: FanThrust | None = None
        self.share_out = 1.0  # the share of the tolerance at the end of the previous swing
        self.steps = 0

    def add(self, st: StepResult) -> Infeasible | None:
        """The transfer into step ``st`` and its swing; the first infeasible row where that stops the plan."""
        seq, tm, b, feet = self.seq, self.scenario.timing, self.scenario.balance, self.feet
        nf = len(self.robot.fans)
        yaw_of = yaw_function(self.scenario, self.robot, st.support, feet[st.support])
        p_first, yaw_first = st.p_body[0], yaw_of(st.path_m[0])
        shares = st.shares
        p_prev, yaw_prev, thrust_out, thrust_in = self.p_prev, self.yaw_prev, self.thrust_out, FanThrust(
            st.fan_thrust(0, nf), st.fan_index)
        share_in = min(self.share_out, float(shares[0]))

        def transfer(positions=None, include_end=False):
            seq.transfer(st.index, feet, p_prev, yaw_prev, p_first, yaw_first, tm.transfer_s, thrust_out, thrust_in,
                         include_end=include_end, share=share_in, positions=positions)

        if self.fast is None:
            transfer()
        else:
            seq.rows.timed.append(time_phase(seq, seq.snapshot(), transfer, "transfer", feet, SIDES, 1.0, self.fast,
                                             tm.transfer_s))
        if self.stop and seq.first_infeasible is not None:
            return seq.first_infeasible
        snap = seq.snapshot()

        def build(positions):
            seq.swing(st.index, st.support, feet, st.path_m, st.p_body, yaw_of, tm.swing_s, shares, positions)

        if self.fast is None:
            build(None)
        else:
            record = time_phase(seq, snap, lambda pos, end: build(pos), "swing", feet, (st.support,),
                                float(len(st.path_m) - 1), self.fast, tm.swing_s)
            if seq.first_infeasible is not snap[3] and seq.smooth_trunk:  # the smooth trunk left the feasible set:
                seq.smooth_trunk = False  # the optimiser's own path, linear between its samples
                seq.restore(snap)
                record = time_phase(seq, snap, lambda pos, end: build(pos), "swing", feet, (st.support,),
                                    float(len(st.path_m) - 1), self.fast, tm.swing_s)
                seq.smooth_trunk = True
            seq.rows.timed.append(record)
        if self.paced:
            pace_swing(seq, snap, build, st.p_body, tm.swing_s, b.sole_margin_m, self.strict)
        if self.stop and seq.first_infeasible is not None:
            return seq.first_infeasible
        feet[st.swing] = st.path_m[-1].copy()
        self.p_prev, self.yaw_prev = st.p_body[-1], yaw_of(st.path_m[-1])
        self.thrust_out = FanThrust(st.fan_thrust(len(st.samples) - 1, nf), st.fan_index)
        self.share_out = float(shares[-1])
        self.steps += 1
        return None

    def state(self) -> tuple:
        """Everything :meth:`add` has built so far (the rows' columns copied), for :meth:`resume`."""
        seq = self.seq
        return ({k: list(v) for k, v in seq.rows.columns.items()}, seq.t,
                None if seq.q_prev is None else seq.q_prev.copy(), seq.first_infeasible,
                {k: v.copy() for k, v in self.feet.items()}, self.p_prev.copy(), self.yaw_prev, self.thrust_out,
                self.share_out, self.steps, [dict(p) for p in seq.rows.paced], [dict(p) for p in seq.rows.timed])

    def resume(self, state: tuple) -> None:
        """Back to a :meth:`state` (of a sequence of the same scenario's settings and the same first steps)."""
        columns, seq = state[0], self.seq
        seq.rows.columns = {k: list(v) for k, v in columns.items()}
        seq.t, q_prev, seq.first_infeasible = state[1], state[2], state[3]
        seq.q_prev = None if q_prev is None else q_prev.copy()
        self.feet = {k: v.copy() for k, v in state[4].items()}
        self.p_prev, self.yaw_prev, self.thrust_out, self.share_out, self.steps = (state[5].copy(), *state[6:10])
        seq.rows.paced = [dict(p) for p in state[10]]
        seq.rows.timed = [dict(p) for p in state[11]]

    def finish(self) -> tuple[Rows, Infeasible | None]:
        """The final transfer to standing; (the rows, the first infeasible row or None)."""
        seq = self.seq
        end = standing_pose(self.robot, self.feet, self.yaw_prev)

        def transfer(positions=None, include_end=True):
            seq.transfer(self.steps, self.feet, self.p_prev, self.yaw_prev, end, self.yaw_prev,
                         self.scenario.timing.transfer_s, self.thrust_out, None, include_end=include_end,
                         share=self.share_out, positions=positions)

        if self.fast is None:
            transfer()
        else:
            seq.rows.timed.append(time_phase(seq, seq.snapshot(), transfer, "transfer", self.feet, SIDES, 1.0,
                                             self.fast, self.scenario.timing.transfer_s, include_end=True))
        return seq.rows, seq.first_infeasible


def build_sequence(scenario: Scenario, robot: RobotModel, solver: PostureSolver, steps: list[StepResult],
                   schedule=None, stop_at_infeasible: bool = False, strict_dynamics: bool = False
                   ) -> tuple[Rows, Infeasible | None]:
    """Every step's rows (:class:`Sequence`); with ``stop_at_infeasible``, only up to the end of the phase
    holding the first infeasible row (the plan is refused then: the rows after it would be discarded)."""
    sequence = Sequence(scenario, robot, solver, schedule, stop_at_infeasible, strict_dynamics)
    for st in steps:
        bad = sequence.add(st)
        if bad is not None:
            return sequence.seq.rows, bad
    return sequence.finish()


