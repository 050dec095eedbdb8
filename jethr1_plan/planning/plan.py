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
from jethr1_plan.kinematics import PostureSolver, make_posture_solver
from jethr1_plan.optimisers import OptimiserConfig, PathRequest, optimise_path
from jethr1_plan.physics.balance import NOMINAL
from jethr1_plan.physics.row_dynamics import RowDynamics
from jethr1_plan.physics.statics import analyse_rows
from jethr1_plan.planning.pacing import GRIP_SAFETY, rows_dynamics
from jethr1_plan.planning.phases import STANDING_HEIGHT_FRACTION, Sequence, build_sequence, standing_pose
from jethr1_plan.planning.problems import feet_before_each_step, nominal_p_body, path_problems, yaw_function
from jethr1_plan.planning.report import finite_or_none, plan_summary
from jethr1_plan.planning.results import PlanResult, StepResult
from jethr1_plan.reasons import message
from jethr1_plan.records.infeasible import Infeasible, InfeasibleAt, ShareAt
from jethr1_plan.records.plan_rows import RowField, Rows
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.scenario import Scenario

__all__ = [
    "SAG_STIFFNESS_SCALE",
    "STANDING_HEIGHT_FRACTION",
    "Sequence",
    "StepJob",
    "add_analysis",
    "build_sequence",
    "finish_plan",
    "optimise_step",
    "parallel_steps",
    "plan",
    "plan_parts",
    "row_solver",
    "standing_pose",
    "step_jobs",
    "step_key",
    "yaw_schedule",
]


Progress = Callable[[str, int, int], None]  # progress(label, done, total)

#: The servo commands undo the sag of the stiffest servo the robot may have, s_max = 1.25 times the robot
#: YAML's stiffness k (a real robot knows its stiffness within ±25 %): q_cmd = q + τ_f/(s_max·k). A servo of
#: stiffness s·k then holds q_cmd − τ/(s·k) = q + (τ/k)(1/s_max − 1/s): for every s ≤ s_max each joint yields
#: along its load, never against it, so the legs never stand taller than planned and a swing sole reaches its
#: carton by the planned touchdown (early, in the final vertical descent, where the servos are softer). Undoing
#: the nominal sag instead leaves the legs (τ/k)(1 − 1/s) too long at s > 1: the sole then hangs above its
#: carton while the transfer already moves the trunk over it, and lands where the trunk drags it.
SAG_STIFFNESS_SCALE = 1.25


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
                  done0: int = 0, total: int = 0) -> tuple[StepResult, Infeasible | None]:
    """Optimise every sample of one step; stops at its first infeasible sample unless ``job.keep_going``.

    Returns the step's result and its first infeasible sample or None.
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
    min_share = scenario.balance.min_share if scenario.balance.tolerance != NOMINAL else 0.0
    for i, res in enumerate(samples):
        if res.feasible and res.share >= min_share:
            continue
        reason, share = message(res.best.violation[0]), None
        if problems[i].tolerance != NOMINAL:
            held = res.share if res.feasible else 0.0
            t = problems[i].tolerance.scaled(held)
            share = ShareAt(held, t.thrust, t.mass, t.com_m, min_share)
            if res.feasible:
                reason = f"tolerance share {res.share:.3f} below balance.robust.min_share {min_share:g}"
        first_bad = Infeasible(si, "swing", i, reason, p_body_m=tuple(res.p_body.tolist()),
                               swing_m=tuple(step.path_m[i].tolist()),
                               thrust_n=finite_or_none(res.best.thrust_n[0]), share=share)
        if not job.keep_going:
            return StepResult(si, step.swing, support, step.path_m[:i + 1], samples[:i + 1], fans), first_bad
        return StepResult(si, step.swing, support, step.path_m, samples, fans), first_bad
    return StepResult(si, step.swing, support, step.path_m, samples, fans), None


def step_key(job: StepJob) -> tuple:
    """What a step's optimisation depends on beyond the scenario's other parts: its index, the swing foot,
    its path, both soles at its start, the seed, the optimiser, the kinematics and the MPC's yaws."""
    yaw = None if job.sample_yaw is None else np.asarray(job.sample_yaw, dtype=float).tobytes()
    return (job.index, job.scenario.steps[job.index].swing, np.asarray(job.scenario.steps[job.index].path_m,
            dtype=float).tobytes(), *(np.asarray(job.feet[k], dtype=float).tobytes() for k in sorted(job.feet)),
            job.seed, repr(job.config), job.kinematics, job.keep_going, yaw)


def plan(scenario: Scenario, method: str | None = None, seed: int | None = None, progress: Progress | None = None,
         keep_going: bool = False, build_rows: bool = True, jobs: int = 1, solver: PostureSolver | None = None,
         kinematics: str = "placo", strict_torque: bool = False) -> PlanResult:
    """:func:`_plan` with BLAS on one thread, as in joblib's worker processes: a multi-threaded BLAS
    sums in another order (measured: sqp's P_body moved by 4.6 mm at one sample of the robust trial
    between -j 1 and -j 2), so the output would depend on -j. See :func:`_plan` for the arguments."""
    with one_blas_thread():
        return _plan(scenario, method, seed, progress, keep_going, build_rows, jobs, solver, kinematics,
                     strict_torque)


def one_blas_thread():
    """A context in which BLAS runs on one thread (scipy's own BLAS loaded first, by the SLSQP step that the
    optimisers call, so that it is limited too)."""
    from threadpoolctl import threadpool_limits

    import jethr1_plan.optimisers.slsqp  # noqa: F401  (loads SciPy's BLAS, which must be loaded to be limited)

    return threadpool_limits(limits=1)


def _plan(scenario: Scenario, method: str | None = None, seed: int | None = None,
          progress: Progress | None = None, keep_going: bool = False,
          build_rows: bool = True, jobs: int = 1, solver: PostureSolver | None = None,
          kinematics: str = "placo", strict_torque: bool = False) -> PlanResult:
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

    Raises:
        InfeasibleAt: at the first infeasible sample unless ``keep_going``.
    """
    t0 = time.perf_counter()
    cfg = scenario.optimiser if method is None else replace(scenario.optimiser, method=method)
    seed = scenario.seed if seed is None else seed
    todo, schedule = step_jobs(scenario, cfg, seed, keep_going, kinematics)
    total = sum(len(s.path_m) for s in scenario.steps)
    outcomes: list[tuple[StepResult, Infeasible | None]] = []
    if jobs > 1 and len(todo) > 1:
        for k, out in enumerate(parallel_steps(todo, jobs)):
            outcomes.append(out)
            if progress:
                progress(f"step {k}", sum(len(o[0].samples) for o in outcomes), total)
    else:
        done = 0
        for job in todo:
            # every step, and the sequence, get a solver of their own (as worker processes do), so that the
            # result does not depend on -j: a PlaCo solver carries state from one solve to the next
            outcomes.append(optimise_step(job, solver, progress, done, total))
            done += len(outcomes[-1][0].samples)
            if outcomes[-1][1] is not None and not keep_going:
                break
    steps, first_bad = _first_refusal(outcomes, keep_going)
    parts = plan_parts(scenario, cfg.method, seed, steps, first_bad, t0, keep_going, strict_torque)
    if (first_bad is not None and not keep_going) or not build_rows:
        return finish_plan(parts, None, None)
    rows, bad_row = build_sequence(scenario, scenario.robot, row_solver(scenario.robot, solver, kinematics), steps,
                                   schedule, stop_at_infeasible=not keep_going)
    return finish_plan(parts, rows, bad_row)


def step_jobs(scenario: Scenario, cfg: OptimiserConfig, seed: int, keep_going: bool = False,
              kinematics: str = "placo"):
    """Every step of ``scenario`` as a :class:`StepJob`, and the MPC's yaw schedule (yaw mode ``mpc``; else None)."""
    feet_at = feet_before_each_step(scenario)
    schedule = yaw_schedule(scenario, scenario.robot) if scenario.yaw_mode == "mpc" else None
    sample_yaws = schedule.sample_yaw if schedule else [None] * len(scenario.steps)
    return [StepJob(scenario, si, feet_at[si], cfg, seed, keep_going, kinematics, sample_yaws[si])
            for si in range(len(scenario.steps))], schedule


def parallel_steps(todo: list[StepJob], jobs: int):
    """The outcomes of :func:`optimise_step` of each job, in order, optimised in up to ``jobs`` processes."""
    if not todo:
        return iter(())
    from joblib import delayed

    from jethr1_plan.io.pool import parallel

    return iter(parallel(min(jobs, len(todo)), return_as="generator")(delayed(optimise_step)(job) for job in todo))


def _first_refusal(outcomes: list[tuple[StepResult, Infeasible | None]], keep_going: bool
                   ) -> tuple[list[StepResult], Infeasible | None]:
    """The steps optimised (up to the first refused one, unless ``keep_going``) and the first refusal."""
    steps: list[StepResult] = []
    first_bad = None
    for st, bad in outcomes:
        steps.append(st)
        if bad is not None and first_bad is None:
            first_bad = bad
            if not keep_going:
                break
    return steps, first_bad


@dataclass(frozen=True)
class _Parts:
    """What :func:`finish_plan` makes a plan of, beside its rows."""

    scenario: Scenario
    method: str
    seed: int
    steps: list[StepResult]
    first_bad: Infeasible | None
    t0: float  # the plan's start (``time.perf_counter``) [s]
    optimise_s: float
    keep_going: bool
    strict_torque: bool


def plan_parts(scenario: Scenario, method: str, seed: int, steps: list[StepResult], first_bad: Infeasible | None,
               t0: float, keep_going: bool = False, strict_torque: bool = False) -> _Parts:
    """The optimised ``steps`` of a plan begun at ``t0`` (``time.perf_counter``) and their first refusal, for
    :func:`finish_plan` (the optimisation's time counted to now)."""
    return _Parts(scenario, method, seed, steps, first_bad, t0, time.perf_counter() - t0, keep_going, strict_torque)


def finish_plan(parts: _Parts, rows: Rows | None, bad_row: Infeasible | None) -> PlanResult:
    """The plan of the optimised steps and their rows (None: not built), analysed (:func:`add_analysis`).

    Raises:
        InfeasibleAt: at the first refused sample or row, unless ``keep_going``.
    """
    sc, robot, first_bad = parts.scenario, parts.scenario.robot, parts.first_bad
    evaluations = sum(s.evaluations for st in parts.steps for s in st.samples)

    def result(built: Rows | None, optimise_s: float = 0.0) -> PlanResult:
        return PlanResult(sc, robot, parts.method, parts.seed, parts.steps, built, first_bad, evaluations,
                          time.perf_counter() - parts.t0, optimise_s)

    if first_bad is not None and not parts.keep_going:
        raise InfeasibleAt(first_bad, plan_summary(result(None)))
    if rows is not None:
        bad_torque = add_analysis(rows, robot, 1.0 / sc.timing.rate_hz, parts.strict_torque)
        bad_row = bad_row or bad_torque
        if first_bad is None and bad_row is not None:
            first_bad = bad_row
            if not parts.keep_going:
                raise InfeasibleAt(first_bad, plan_summary(result(None)))
    return result(rows, parts.optimise_s)


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


def add_analysis(rows: Rows, robot: RobotModel, dt: float, strict_torque: bool) -> Infeasible | None:
    """Add Paper B's per-row figures (static torques, κ, yaw momentum) and the rows' dynamics
    (:func:`plan_row_dynamics`) to ``rows``; mark infeasible the rows whose motion needs the ground to
    pull (a vertical ground force ≤ 0) or more friction than μ / ``GRIP_SAFETY`` (``physics.row_dynamics``),
    and, under ``strict_torque``, torques above the servo limits.
    Returns the first such row."""
    c = rows.columns
    q = np.asarray(c[RowField.Q_RAD], dtype=float)
    thrust = rows.fan_array()
    a = analyse_rows(robot, np.asarray(c[RowField.P_BODY_M], dtype=float), np.asarray(c[RowField.YAW_RAD],
                     dtype=float), q, thrust, np.asarray(c[RowField.SUPPORT]), dt)
    fans = robot.fans
    rows.set_analysis(a["tau"], a["kappa"], a["yaw_momentum"],
                      servo_commands(q, a["tau"], SAG_STIFFNESS_SCALE * robot.servo_stiffness_nm_per_rad, 1.0 / dt),
                      fan_commands(thrust, 1.0 / dt, np.array([f.lag_s for f in fans]),
                                   np.array([f.thrust_max_n for f in fans])))
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
    # about the ZMP is the swings' pacing's, ``pacing.pace_swing``)
    mu = robot.sole_friction
    inner = np.arange(1, len(rows) - 1)
    for i in inner[dyn.friction_ratio[inner] > mu / GRIP_SAFETY].tolist():
        bad.setdefault(i, f"the rows' motion needs a friction ratio of {dyn.friction_ratio[i]:.2f}, more than the "
                          f"soles' μ {mu:g} / {GRIP_SAFETY:g}")
    first = None
    for i in sorted(bad):
        c[RowField.FEASIBLE][i] = False
        c[RowField.REASON][i] = c[RowField.REASON][i] or bad[i]
        if first is None:
            first = Infeasible(int(c[RowField.STEP][i]), c[RowField.PHASE][i], int(c[RowField.SAMPLE][i]), bad[i],
                               float(c[RowField.TIME_S][i]))
    return first


def plan_row_dynamics(rows: Rows, robot: RobotModel, dt: float) -> RowDynamics:
    """The multibody ZMP the output rows need (:func:`~.pacing.rows_dynamics` of every row)."""
    return rows_dynamics(rows, robot, dt)


def yaw_schedule(scenario: Scenario, robot: RobotModel):
    """The MPC-smoothed body yaw (yaw mode ``mpc``) at every row and swing sample."""
    from jethr1_plan.control.yaw_mpc import build_schedule

    feet_at = feet_before_each_step(scenario)
    eq4 = [yaw_function(scenario, robot, st.support, f[st.support]) for st, f in zip(scenario.steps, feet_at,
                                                                                       strict=True)]
    return build_schedule(scenario, robot, eq4, [st.path_m for st in scenario.steps], **scenario.body_yaw.mpc)
