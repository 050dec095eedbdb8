"""``jethr1 plan``: a scenario in, optimised swing samples and a resampled trajectory out.

:func:`plan` optimises every step (:func:`optimise_step`, one :class:`StepJob` each, in any
process), then builds the output-rate sequence (:func:`build_sequence`) and adds Paper B's per-row
analysis (:func:`add_analysis`). The problems come from :mod:`.problems`, the optimiser from the
registry (:func:`jethr1_plan.optimisers.optimise_path`), the summary from :mod:`.report`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from jethr1_plan.control.commands import fan_commands, servo_commands
from jethr1_plan.control.time_laws import swing_row_positions
from jethr1_plan.errors import InfeasiblePlan
from jethr1_plan.geometry import SIDES
from jethr1_plan.kinematics import PostureSolver, make_posture_solver
from jethr1_plan.optimisers import OptimiserConfig, PathRequest, optimise_path
from jethr1_plan.physics.balance import NOMINAL
from jethr1_plan.physics.row_dynamics import RowDynamics
from jethr1_plan.physics.statics import analyse_rows
from jethr1_plan.planning.fast_timing import FastTiming, time_phase
from jethr1_plan.planning.problems import feet_before_each_step, nominal_p_body, path_problems, yaw_function
from jethr1_plan.planning.report import describe_infeasible, finite_or_none, plan_summary
from jethr1_plan.planning.results import PlanResult, StepResult
from jethr1_plan.planning.sequence import GRIP_SAFETY, FanThrust, Rows, SequenceBuilder, pace_swing, rows_dynamics
from jethr1_plan.reasons import message
from jethr1_plan.robot.model import RobotModel, reach_centre
from jethr1_plan.scenario import Scenario

__all__ = [
    "STANDING_HEIGHT_FRACTION",
    "StepJob",
    "add_analysis",
    "build_sequence",
    "optimise_step",
    "plan",
    "row_solver",
    "standing_pose",
    "step_key",
    "yaw_schedule",
]

STANDING_HEIGHT_FRACTION = 0.9  # standing pelvis height over the soles, as a fraction of the leg length

Progress = Callable[[str, int, int], None]  # progress(label, done, total)


@dataclass(frozen=True)
class StepJob:
    """One step to optimise: all it needs, so that it may run in any process.

    Steps are independent of each other (each starts with the initial phase and every sample has
    its own random stream ``default_rng([seed, step, sample])``).
    """

    scenario: Scenario
    index: int
    feet: dict[str, np.ndarray]  # both soles at the start of the step [m]
    config: OptimiserConfig
    seed: int
    keep_going: bool = False  # go on past the first infeasible sample
    kinematics: str = "placo"
    sample_yaw: np.ndarray | None = None  # the MPC schedule's body yaw per sample [rad] (yaw mode mpc)


def optimise_step(job: StepJob, solver: PostureSolver | None = None, progress: Progress | None = None,
                  done0: int = 0, total: int = 0) -> tuple[StepResult, dict | None]:
    """Optimise every sample of one step; stops at its first infeasible sample unless ``job.keep_going``.

    Returns the step's result and its first infeasible sample (a summary.json record) or None.
    """
    scenario, si = job.scenario, job.index
    robot = scenario.robot
    solver = solver or make_posture_solver(robot, job.kinematics)
    step = scenario.steps[si]
    support = step.support
    problem_at = path_problems(scenario, robot, si, job.feet, job.sample_yaw)
    problems = [problem_at(i) for i in range(len(step.path_m))]
    request = PathRequest(
        robot=robot, solver=solver, problems=problems,
        nominals=nominal_p_body(scenario, robot, job.feet[support], step.path_m), config=job.config,
        rngs=[np.random.default_rng([job.seed, si, i]) for i in range(len(problems))],
        between=lambda i, lam: problem_at(i + lam),
        row_positions=swing_row_positions(len(problems), scenario.timing.swing_s, scenario.timing.rate_hz),
        stop_at_infeasible=not job.keep_going,
        progress=(lambda k: progress(f"step {si} sample {k - 1}", done0 + k, total)) if progress else None)
    samples = optimise_path(request).samples
    fans = tuple(int(k) for k in problems[0].fan_index)
    first_bad = None
    min_share = scenario.balance.min_share if scenario.balance.tolerance != NOMINAL else 0.0
    for i, res in enumerate(samples):
        if res.feasible and res.share >= min_share:
            continue
        first_bad = {"step": si, "phase": "swing", "sample": i, "swing_m": step.path_m[i].tolist(),
                     "p_body_m": res.p_body.tolist(), "thrust_n": finite_or_none(res.best.thrust_n[0]),
                     "reason": message(res.best.violation[0])}
        if problems[i].tolerance != NOMINAL:
            t = problems[i].tolerance.scaled(res.share if res.feasible else 0.0)
            first_bad["tolerance_share"] = {"share": res.share if res.feasible else 0.0, "thrust_error": t.thrust,
                                            "mass_error": t.mass, "com_error_m": t.com_m, "min_share": min_share}
            if res.feasible:
                first_bad["reason"] = (f"tolerance share {res.share:.3f} below balance.robust.min_share "
                                       f"{min_share:g}")
        if not job.keep_going:
            return StepResult(si, step.swing, support, step.path_m[:i + 1], samples[:i + 1], fans), first_bad
        break
    return StepResult(si, step.swing, support, step.path_m, samples, fans), first_bad


def step_key(job: StepJob) -> tuple:
    """What a step's optimisation depends on beyond the scenario's other parts: its index, the swing foot,
    its path, both soles at its start, the seed, the optimiser, the kinematics and the MPC's yaws."""
    yaw = None if job.sample_yaw is None else np.asarray(job.sample_yaw, dtype=float).tobytes()
    return (job.index, job.scenario.steps[job.index].swing, np.asarray(job.scenario.steps[job.index].path_m,
            dtype=float).tobytes(), *(np.asarray(job.feet[k], dtype=float).tobytes() for k in sorted(job.feet)),
            job.seed, repr(job.config), job.kinematics, job.keep_going, yaw)


def plan(*args, **kwargs) -> PlanResult:
    """:func:`_plan` with BLAS on one thread, as in joblib's worker processes: a multi-threaded BLAS
    sums in another order (measured: sqp's P_body moved by 4.6 mm at one sample of the robust trial
    between -j 1 and -j 2), so the output would depend on -j. See :func:`_plan` for the arguments."""
    import scipy.optimize  # noqa: F401  (its own BLAS must be loaded to be limited)
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        return _plan(*args, **kwargs)


def _plan(scenario: Scenario, method: str | None = None, seed: int | None = None,
          progress: Progress | None = None, keep_going: bool = False,
          build_rows: bool = True, jobs: int = 1, solver: PostureSolver | None = None,
          kinematics: str = "placo", strict_torque: bool = False, step_memo: dict | None = None,
          early_rows: bool = False, row_memo: dict | None = None, strict_dynamics: bool = False) -> PlanResult:
    """Optimise every swing sample of ``scenario`` and resample the whole sequence.

    Args:
        method: override of ``optimiser.method``.
        seed: override of the scenario's seed.
        progress: called as ``progress(label, done, total)`` as samples (or, with jobs, steps) finish.
        keep_going: continue past infeasible samples (their rows are marked infeasible).
        build_rows: also build the output-rate trajectory.
        jobs: processes optimising steps in parallel; the result does not depend on it.
        solver: the posture solver to use in this process (one is made if None).
        kinematics: ``placo`` (PlaCo's IK, the default) or ``analytic`` (closed form, same results
            to 1e-9 m, several times faster).
        strict_torque: rows whose static torque exceeds a servo limit are infeasible (else flagged).
        step_memo: steps optimised by earlier calls, filled by this one (:func:`step_key`); only for
            scenarios that differ in their steps alone (the route re-plans a route whose steps changed
            after the first k: those k are not optimised again). Each step has a solver of its own, so
            a remembered step is the one this call would compute, bit for bit.
        early_rows: (one process, ``build_rows``, not ``keep_going``) build each step's rows as soon as it
            is optimised, and stop at the first infeasible row without optimising the steps after it (the
            route: a refused step costs no more optimisation); the same rows, the same first infeasible
            row, but a refused plan's ``steps`` end at the refused one.
        strict_dynamics: (the robust policy) a swing row whose multibody ZMP stays nearer the sole's edge
            than ``balance.sole_margin_m`` even paced is infeasible (the route); without it the plan keeps
            the best pace and ``summary.json``'s ``dynamics`` (and ``jethr1 plan``'s warning) report it.
        row_memo: with ``early_rows`` and ``step_memo``, the rows built after each run of first steps
            (by their memo keys), filled by this call: a re-planned route does not build the rows of its
            unchanged first steps again (the same rows, bit for bit: they depend on those steps alone).

    Raises:
        InfeasiblePlan: at the first infeasible sample unless ``keep_going``.
    """
    t0 = time.perf_counter()
    robot = scenario.robot
    cfg = scenario.optimiser if method is None else replace(scenario.optimiser, method=method)
    seed = scenario.seed if seed is None else seed
    # every step, and the sequence, get a solver of their own (as worker processes do), so that the
    # result does not depend on -j: a PlaCo solver carries state from one solve to the next
    given = solver
    feet_at = feet_before_each_step(scenario)
    schedule = yaw_schedule(scenario, robot) if scenario.yaw_mode == "mpc" else None
    sample_yaws = schedule.sample_yaw if schedule else [None] * len(scenario.steps)
    jobs_of = [StepJob(scenario, si, feet_at[si], cfg, seed, keep_going, kinematics, sample_yaws[si])
               for si in range(len(scenario.steps))]
    total = sum(len(s.path_m) for s in scenario.steps)
    n = len(scenario.steps)
    memo = step_memo if step_memo is not None and given is None else None
    early: Sequence | None = None
    early_bad: dict | None = None
    keys = [step_key(job) for job in jobs_of] if memo is not None else []
    if jobs > 1 and n > 1:
        from joblib import delayed

        from jethr1_plan.io.pool import parallel

        todo = [k for k in range(n) if memo is None or keys[k] not in memo]
        fresh = iter(parallel(min(jobs, len(todo)), return_as="generator")(
            delayed(optimise_step)(jobs_of[k]) for k in todo)) if todo else iter(())
        outcomes = []
        for k in range(n):
            if memo is not None and keys[k] in memo:
                out = memo[keys[k]]
            else:
                out = next(fresh)
                if memo is not None:
                    memo[keys[k]] = out
            outcomes.append(out)
            if progress:
                progress(f"step {k}", sum(len(o[0].samples) for o in outcomes), total)
    else:
        early = (Sequence(scenario, robot, row_solver(robot, given, kinematics), schedule, True, strict_dynamics)
                 if early_rows and build_rows and not keep_going else None)
        outcomes, done = [], 0
        for k, job in enumerate(jobs_of):
            if memo is not None and keys[k] in memo:
                out = memo[keys[k]]
            else:
                out = optimise_step(job, given, progress, done, total)
                if memo is not None:
                    memo[keys[k]] = out
            outcomes.append(out)
            done += len(out[0].samples)
            if out[1] is not None and not keep_going:
                break
            if early is not None:
                prefix = tuple(keys[:k + 1]) if memo is not None and row_memo is not None else None
                if prefix is not None and prefix in row_memo:  # type: ignore[operator]
                    early.resume(row_memo[prefix])  # type: ignore[index]
                    continue
                early_bad = early.add(out[0])
                if early_bad is not None:
                    break
                if prefix is not None:
                    row_memo[prefix] = early.state()  # type: ignore[index]
    steps: list[StepResult] = []
    first_bad = None
    for st, bad in outcomes:
        steps.append(st)
        if bad is not None and first_bad is None:
            first_bad = bad
            if not keep_going:
                break
    evaluations = sum(s.evaluations for st in steps for s in st.samples)
    optimise_s = time.perf_counter() - t0
    if first_bad is not None and not keep_going:
        result = PlanResult(scenario, robot, cfg.method, seed, steps, None, first_bad, evaluations,
                            time.perf_counter() - t0)
        raise InfeasiblePlan(describe_infeasible(first_bad), plan_summary(result))

    rows = None
    if build_rows:
        if early is not None:
            rows, bad_row = (early.seq.rows, early_bad) if early_bad is not None else early.finish()
        else:
            rows, bad_row = build_sequence(scenario, robot, row_solver(robot, given, kinematics), steps, schedule,
                                           stop_at_infeasible=not keep_going, strict_dynamics=strict_dynamics)
        bad_torque = add_analysis(rows, robot, 1.0 / scenario.timing.rate_hz, strict_torque)
        bad_row = bad_row or bad_torque
        if first_bad is None and bad_row is not None:
            first_bad = bad_row
            if not keep_going:
                result = PlanResult(scenario, robot, cfg.method, seed, steps, None, first_bad, evaluations,
                                    time.perf_counter() - t0)
                raise InfeasiblePlan(describe_infeasible(first_bad), plan_summary(result))
    return PlanResult(scenario, robot, cfg.method, seed, steps, rows, first_bad, evaluations, time.perf_counter() - t0,
                      optimise_s)


def row_solver(robot: RobotModel, given: PostureSolver | None = None, kinematics: str = "placo") -> PostureSolver:
    """The solver of the output-rate rows: the closed form wherever the legs have its structure (the same
    postures as PlaCo's IK to 1e-9 m, without an iterative solve per row; PlaCo confirms every written
    row, its forward kinematics in the self-check putting the soles where they belong), else ``given``
    or a new solver of ``kinematics``."""
    from jethr1_plan.errors import RobotModelError
    from jethr1_plan.kinematics.closed_form import ClosedFormPostureSolver

    try:
        return ClosedFormPostureSolver(robot)
    except RobotModelError:
        return given or make_posture_solver(robot, kinematics)


def add_analysis(rows: Rows, robot: RobotModel, dt: float, strict_torque: bool) -> dict | None:
    """Add Paper B's per-row figures (static torques, κ, yaw momentum) and the rows' dynamics
    (:func:`plan_row_dynamics`) to ``rows``; mark infeasible the rows whose motion needs the ground to
    pull (a vertical ground force ≤ 0) or more friction than μ / ``GRIP_SAFETY`` (``physics.row_dynamics``),
    and, under ``strict_torque``, torques above the servo limits.
    Returns the first such row."""
    a = analyse_rows(robot, rows, dt)
    c = rows.columns
    c["tau"], c["kappa"], c["yaw_momentum"] = list(a["tau"]), list(a["kappa"]), list(a["yaw_momentum"])
    c["q_cmd"] = list(servo_commands(np.asarray(c["q"], dtype=float), a["tau"], robot.servo_stiffness_nm_per_rad,
                                     1.0 / dt))
    fans = robot.fans
    cmd = fan_commands(np.column_stack([rows.array(f"thrust_{f.name}") for f in fans]), 1.0 / dt,
                       np.array([f.lag_s for f in fans]), np.array([f.max_thrust_n for f in fans]))
    for k, f in enumerate(fans):
        c[f"thrust_cmd_{f.name}"] = list(cmd[:, k])
    ratio = np.abs(a["tau"]) / robot.servo_limit_nm
    dyn = plan_row_dynamics(rows, robot, dt)
    rows.analysis = {"energy_j": a["energy_j"], "ratio": ratio, "dynamics": dyn}
    bad: dict[int, str] = {}
    if strict_torque:
        for i in np.flatnonzero(ratio.max(axis=1) > 1.0).tolist():
            j = int(np.argmax(ratio[i]))
            bad[i] = f"{robot.joint_names[j]} torque {a['tau'][i, j]:.2f} N·m above its servo limit"
    for i in (np.flatnonzero(dyn.vertical_force_n[1:-1] <= 0.0) + 1).tolist():  # the stencil's inner rows
        bad.setdefault(i, f"the rows' motion needs the ground to pull ({dyn.vertical_force_n[i]:.1f} N vertical): "
                          "the trunk falls faster than gravity")
    # the soles' grip, with a margin: the friction the rows' motion needs within μ / GRIP_SAFETY (the twist
    # about the ZMP is the swings' pacing's, ``sequence.pace_swing``)
    mu = robot.sole_friction
    inner = np.arange(1, len(rows) - 1)
    for i in inner[dyn.friction_ratio[inner] > mu / GRIP_SAFETY].tolist():
        bad.setdefault(i, f"the rows' motion needs a friction ratio of {dyn.friction_ratio[i]:.2f}, more than the "
                          f"soles' μ {mu:g} / {GRIP_SAFETY:g}")
    first = None
    for i in sorted(bad):
        c["feasible"][i] = False
        c["reason"][i] = c["reason"][i] or bad[i]
        if first is None:
            first = {"time_s": float(c["time_s"][i]), "step": int(c["step"][i]), "phase": c["phase"][i],
                     "sample": int(c["sample"][i]), "reason": bad[i]}
    return first


def plan_row_dynamics(rows: Rows, robot: RobotModel, dt: float) -> RowDynamics:
    """The multibody ZMP the output rows need (:func:`~.sequence.rows_dynamics` of every row)."""
    return rows_dynamics(rows, robot, dt)


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


def yaw_schedule(scenario: Scenario, robot: RobotModel):
    """The MPC-smoothed body yaw (yaw mode ``mpc``) at every row and swing sample."""
    from jethr1_plan.control.yaw_mpc import build_schedule

    feet_at = feet_before_each_step(scenario)
    eq4 = [yaw_function(scenario, robot, st.support, f[st.support]) for st, f in zip(scenario.steps, feet_at,
                                                                                       strict=True)]
    return build_schedule(scenario, robot, eq4, [st.path_m for st in scenario.steps], **scenario.body_yaw.mpc)


class Sequence:
    """Stand → (transfer → swing)* → transfer → stand, at the scenario's output rate, one step at a time
    (:meth:`add`, then :meth:`finish`); with ``stop_at_infeasible``, :meth:`add` stops at the end of the
    phase holding the first infeasible row and returns it (the plan is refused then). Under the robust
    policy a swing whose multibody ZMP comes within ``sole_margin_m`` of the sole's edge is paced
    (:func:`~.sequence.pace_swing`); with ``strict_dynamics`` its rows still that near are infeasible."""

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
        self.feet = {k: v.copy() for k, v in scenario.start.items()}
        self.p_prev, self.yaw_prev = standing_pose(robot, self.feet, 0.0), 0.0
        self.thrust_out: FanThrust | None = None
        self.share_out = 1.0  # the share of the tolerance at the end of the previous swing
        self.steps = 0

    def add(self, st: StepResult) -> dict | None:
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

    def finish(self) -> tuple[Rows, dict | None]:
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
                   ) -> tuple[Rows, dict | None]:
    """Every step's rows (:class:`Sequence`); with ``stop_at_infeasible``, only up to the end of the phase
    holding the first infeasible row (the plan is refused then: the rows after it would be discarded)."""
    sequence = Sequence(scenario, robot, solver, schedule, stop_at_infeasible, strict_dynamics)
    for st in steps:
        bad = sequence.add(st)
        if bad is not None:
            return sequence.seq.rows, bad
    return sequence.finish()


