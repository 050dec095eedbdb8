"""A multi-step plan executed as the robot would: one step at a time, each step planned again from where
the robot estimates its soles stand, to where it perceives the next foothold (``jethr1 simulate`` of a
multi-step plan or a route).

Why: a plan made in one go places every step relative to where the previous one was supposed to land;
the robot lands a few millimetres off, and every step after it carries that error on, so the errors add
up over a route (docs/rehearsal.md, "Step by step"). A robot that plans each step from where it stands,
to where it sees the next carton, keeps each step's error its own.

What the robot does (in one continuous twin run: the servos', fans' and contacts' state carry over):

1. It stands still on both soles (``STAND_S`` after each step). It reads its sensors once
   (:meth:`~.run.TwinRun.measure`) and its own kinematics (:class:`~.sensors.OwnKinematics`: the encoders
   and the IMU's attitude) give where its swing sole stands relative to its support sole, and the
   support sole's heading in the IMU's world.
2. It plans in the *step frame*: its support sole where the plan put it (the scenario's own position of
   that sole before the step), heading +x (the planner's soles face +x). The swing sole starts where
   the kinematics put it relative to the support sole; it lands where the robot perceives the plan's
   foothold relative to its support sole: the foothold's true position relative to the true support
   sole, off by the perception error (uniform over a disc of the robot's ``perception.landing_error_m``,
   the run's generator ``default_rng([noise_seed, 1])``). The cartons are where they truly are relative to
   the support sole.
3. The step's plan: the plan's own optimised trunk postures of that step (relative to the support sole,
   unchanged) along the plan's swing path moved to the new ends (the offset of each end fades out along
   the path, a smoothstep in arc length), its rows built by the planner's row builder (IK, the robust
   thrust, pacing, the commands): *re-anchored* (a share of the trunk's shift whose first or last
   posture the legs cannot reach is not built: :func:`~.reoptimise.ends_reached`). Where a row of that is
   not feasible, the plan's own samples are optimised again from there (:func:`~.reoptimise.reoptimised`:
   each kept where it holds the planner's sample program, else solved by it from where it stands, giving
   up the share of the tolerance the new ends cost), its rows under the scenario's own limits:
   *re-optimised*. Where that is refused too, the step is optimised anew (``planning.plan``): *optimised*.
   Where that is refused too, it is optimised anew over the same swing sampled more finely
   (:func:`refined_path`; *optimised-fine*, :func:`plan_anew`): every one of them a plan the planner
   accepts whole (every row feasible under the scenario's own limits).
   Where none plans, the robot stops: the run fails.
4. It follows that plan (stand → transfer → swing → transfer → stand), its controller's reference the
   plan turned into its IMU's world (the support sole's measured heading).

The judge compares with the truth: each step's plan carried into the twin's world by the true pose of
its support sole; each landing against the plan's foothold (the scenario's landing: the carton
position the robot aims for).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from jethr1_plan.control.swing_placement import yaw_of
from jethr1_plan.errors import InfeasiblePlan, InputError
from jethr1_plan.files.plan_table import plan_table
from jethr1_plan.geometry import SIDES
from jethr1_plan.planning.plan import Sequence, add_analysis, one_blas_thread, plan, row_solver
from jethr1_plan.planning.problems import feet_before_each_step
from jethr1_plan.planning.results import PlanResult, StepResult
from jethr1_plan.records.infeasible import Infeasible
from jethr1_plan.records.plan_rows import RowField
from jethr1_plan.scenario import Scenario, Step, load_scenario_text
from jethr1_plan.sim.judge import RunResult
from jethr1_plan.sim.reoptimise import ends_reached, reoptimised, step_plan
from jethr1_plan.sim.run import HOLD_S, SETTLE_S, TwinRun
from jethr1_plan.sim.sensors import OwnKinematics
from jethr1_plan.sim.track import Frame, Perturbation, moved, plan_kinematics, track_of
from jethr1_plan.swing_path import Carton, path_length

__all__ = ["MODES", "STAND_S", "Execution", "StepPlan", "execute", "executed_plan", "plan_anew", "reanchor_ends",
           "refined_path", "replan_step"]

STAND_S = 0.5  # after each step the robot stands this long before it measures and plans the next [s]
#: a re-anchored step's trunk moves by these shares of its swing sole's shift, tried in turn
TRUNK_SHARES = (0.5, 0.0, 1.0)
#: where a step optimised anew is refused, it is optimised again over its swing path with each segment split
#: into this many (the same sole positions at every row), in turn
REFINEMENTS = (2, 3, 4)
#: every way a step is planned, in the order tried (:func:`replan_step`)
MODES = ("re-anchored", "re-optimised", "optimised", "optimised-fine")


def refined_path(path_m: np.ndarray, factor: int) -> np.ndarray:
    """A swing path (N, 3) [m] with every segment split into ``factor`` equal parts: ((N − 1)·factor + 1, 3),
    the same points on the same straight segments. The rows interpolate the swing sole linearly between
    samples at min_jerk(k / n)·(N − 1) (``time_laws.swing_row_positions``), which the refined path's
    (N − 1)·factor scales with it: every row's swing sole stands where it stood; the optimiser places the
    trunk at ``factor`` times as many samples, so that the rows interpolating P_body between two of them
    span a ``factor``-th of the swing's progress."""
    pts = np.asarray(path_m, dtype=float)
    lam = np.arange(factor)[:, None] / factor
    inner = (pts[:-1, None, :] * (1.0 - lam) + pts[1:, None, :] * lam).reshape(-1, 3)
    return np.vstack([inner, pts[-1:]])


def reanchor_ends(path_m: np.ndarray, start_m: np.ndarray, end_m: np.ndarray) -> np.ndarray:
    """A swing path (N, 3) [m] moved to run from ``start_m`` to ``end_m``: the offset of its first point
    fades out along its length and that of its last fades in (smoothsteps in arc length), so a vertical
    lift or descent stays vertical to within the offsets' change over it."""
    pts = np.asarray(path_m, dtype=float)
    length = path_length(pts)
    s = length / length[-1] if length[-1] > 0 else np.linspace(0.0, 1.0, len(pts))
    smooth = s * s * (3.0 - 2.0 * s)
    out = (pts + (1.0 - smooth)[:, None] * (np.asarray(start_m, dtype=float) - pts[0])
           + smooth[:, None] * (np.asarray(end_m, dtype=float) - pts[-1]))
    out[0], out[-1] = start_m, end_m
    return out


@dataclass
class StepPlan:
    """One step as the robot planned it, in its step frame."""

    index: int
    scenario: Scenario  # the one-step scenario (step frame)
    result: PlanResult  # its plan
    mode: str  # how it was planned: one of MODES (:func:`replan_step`)
    to_world: Frame  # step frame → the twin's world (the truth: the judge's)
    start_m: dict[str, np.ndarray]  # the soles the robot planned from (its estimate), step frame [m]
    target_m: np.ndarray  # the landing it aimed for (perceived), step frame [m]


@dataclass
class Execution:
    """A run step by step: the twin's verdict, a record per step, the robot's plans."""

    run: RunResult
    steps: list[dict] = field(default_factory=list)
    plans: list[StepPlan] = field(default_factory=list)
    refused: dict | None = None  # the step the robot could not plan, and why


def replan_step(scenario: Scenario, k: int, nominal: StepResult, start: dict[str, np.ndarray], target: np.ndarray,
                cartons: tuple[Carton, ...]) -> tuple[PlanResult, str]:
    """Step ``k`` of ``scenario`` planned from soles at ``start`` [m] to the landing ``target`` [m] among
    ``cartons`` (all in the step frame: the support sole where ``scenario`` has it before the step):
    re-anchored where its rows are feasible under the scenario's own limits (ρ too), else re-optimised from the
    plan's samples (:func:`~jethr1_plan.sim.reoptimise.reoptimised`), else optimised anew (:func:`plan_anew`);
    (the plan, its mode).

    Raises:
        InfeasiblePlan: none plans.
    """
    with one_blas_thread():  # as every plan: the answer must not depend on the BLAS's threads (-j)
        return _replan_step(scenario, k, nominal, start, target, cartons)


def _replan_step(scenario: Scenario, k: int, nominal: StepResult, start: dict[str, np.ndarray], target: np.ndarray,
                 cartons: tuple[Carton, ...]) -> tuple[PlanResult, str]:
    st = scenario.steps[k]
    path = reanchor_ends(st.path_m, start[st.swing], target)
    one = replace(scenario, name=f"{scenario.name}_step{k}",
                  start={s: np.asarray(start[s], dtype=float) for s in SIDES}, steps=(Step(st.swing, path),),
                  cartons=cartons, expect={})
    if scenario.yaw_mode != "mpc":
        for share in TRUNK_SHARES:
            # the trunk follows the swing sole's shift by ``share``, sample by sample: both legs then bend by
            # part of the shift, away from the joint limits the plan's postures may sit on
            shift = share * (path - st.path_m)
            if not ends_reached(one, path, nominal.p_body + shift):
                continue  # its first swing row or the first row after its landing is out of reach: refused
            samples = [replace(x, best=replace(x.best, p_body=x.best.p_body + shift[i]))
                       for i, x in enumerate(nominal.samples)]
            planned = step_plan(one, StepResult(0, st.swing, st.support, path, samples, nominal.fan_index),
                                "re-anchored")
            if planned is not None:
                return planned, "re-anchored"
        again = reoptimised(one, nominal, TRUNK_SHARES[0] * (path - st.path_m))
        if again is not None:
            return again, "re-optimised"
    return plan_anew(one)


def plan_anew(one: Scenario) -> tuple[PlanResult, str]:
    """The one-step scenario ``one`` optimised anew (``planning.plan``): as it is (*optimised*), else over its
    swing path refined by each factor of :data:`REFINEMENTS` (:func:`refined_path`; *optimised-fine*), with
    the scenario's own timing (a slower swing would run longer than the executed plan, written with the
    scenario's timing, says). Of the refinements the planner accepts, the first whose swing keeps the
    multibody ZMP ``balance.sole_margin_m`` inside the sole with the friction within its bound (its pacing
    held, ``planning.pacing``), else the first. Nothing of the scenario's limits changes: each is a plan
    whose every row is feasible.

    Raises:
        InfeasiblePlan: none plans (the message: the plain optimisation's first infeasible row, then each
            refinement's).
    """
    try:
        return plan(one), "optimised"
    except InfeasiblePlan as exc:
        refusals = [str(exc)]
    st = one.steps[0]
    first: tuple[PlanResult, str] | None = None
    for factor in REFINEMENTS:
        fine = replace(one, steps=(Step(st.swing, refined_path(st.path_m, factor)),))
        try:
            got = plan(fine), "optimised-fine"
        except InfeasiblePlan as exc:
            refusals.append(f"×{factor} samples: {exc}")
            continue
        assert got[0].rows is not None  # planned whole
        if all(p["margin_held"] for p in got[0].rows.paced):
            return got
        first = first or got
    if first is not None:
        return first
    raise InfeasiblePlan("; ".join(refusals))


def _perceived(target_world: np.ndarray, sup_true: np.ndarray, yaw_true: float, sup_frame: np.ndarray,
               error_m: np.ndarray) -> np.ndarray:
    """The foothold ``target_world`` as the robot perceives it in its step frame: its true position
    relative to the true support sole (turned by the sole's heading), put at ``sup_frame``, off by
    ``error_m`` (x, y)."""
    c, s = math.cos(-yaw_true), math.sin(-yaw_true)
    d = np.asarray(target_world, dtype=float) - sup_true
    rel = np.array([c * d[0] - s * d[1], s * d[0] + c * d[1], d[2]])
    out = sup_frame + rel
    out[:2] += error_m
    return out


def execute(scenario: Scenario, nominal: list[StepResult], controller: str = "feedback",
            perturbation: Perturbation | None = None, seed: int = 0, record: bool = False,
            thrust_max_n: float | None = None, placed_m: tuple[float, float] = (0.0, 0.0)) -> Execution:
    """Execute ``scenario`` step by step in the twin (the module docstring); ``nominal`` its steps as its plan
    optimised them (``plan(scenario).steps``); ``controller`` as :class:`~.run.TwinRun` takes it;
    ``placed_m``: the robot put down this far (x, y) [m] off its plan's start (it does not know).

    Raises:
        InputError: the robot has no IMU and encoders to estimate where it stands.
    """
    robot = scenario.robot
    if robot.sensors.imu is None or robot.sensors.encoders is None:
        raise InputError(str(robot.yaml_path), "sensors", "step-by-step execution estimates where the soles stand "
                         "from the IMU and the encoders; the robot declares "
                         f"{', '.join(robot.sensors.names) or 'no sensors'}")
    p = perturbation or Perturbation()
    b = scenario.balance
    thrust_max = thrust_max_n if thrust_max_n is not None else b.thrust_max_n
    tolerance = {"thrust_error": b.tolerance.thrust, "mass_error": b.tolerance.mass, "com_error_m": b.tolerance.com_m}
    run = TwinRun(robot, scenario.cartons, thrust_max, controller, p, seed=seed, record=record, estimating=True)
    kin = OwnKinematics(robot)
    noise_seed = p.sensors.noise_seed if p.sensors is not None else seed
    perception = np.random.default_rng([noise_seed, 1])
    feet_nominal = feet_before_each_step(scenario)
    out = Execution(run=None)  # type: ignore[arg-type]
    n = len(scenario.steps)
    for k, st in enumerate(scenario.steps):
        sup, sw = st.support, st.swing
        s_frame = feet_nominal[k][sup]
        if k == 0:
            start = {s: np.asarray(scenario.start[s], dtype=float) for s in SIDES}
            sup_true, yaw_true = start[sup] + np.array([placed_m[0], placed_m[1], 0.0]), 0.0
            yaw_est = 0.0
        else:
            start, yaw_est = _estimated_start(run, kin, sup, sw, s_frame)
            sup_true, yaw_true = run.pose(sup)
        radius = robot.sensors.perception_error_m * math.sqrt(float(perception.uniform()))
        angle = float(perception.uniform(0.0, 2 * math.pi))
        error = np.array([radius * math.cos(angle), radius * math.sin(angle)])
        target = _perceived(st.landing_m, sup_true, yaw_true, s_frame, error)
        shift = s_frame - sup_true
        cartons = tuple(Carton((float(c.top_centre_m[0] + shift[0]), float(c.top_centre_m[1] + shift[1]),
                                float(c.top_centre_m[2] + shift[2])), c.size_m) for c in scenario.cartons)
        try:
            result, mode = replan_step(scenario, k, nominal[k], start, target, cartons)
        except InfeasiblePlan as exc:
            out.refused = {"step": k, "reason": str(exc)}
            break
        to_world = Frame.mapping(s_frame, 0.0, sup_true, yaw_true)
        to_imu = Frame.mapping(s_frame, 0.0, np.zeros(3), yaw_est)
        assert result.rows is not None  # a plan's rows (planned whole, not samples only)
        table = plan_table(robot, result.rows)
        track = track_of(table, robot, scenario.cartons, scenario.timing.rate_hz, thrust_max, tolerance)
        plan_kinematics(run.twin, track)
        if k == 0:
            first = moved(track, to_world)
            run.start(first.pelvis[0], first.q[0])
        seg = run.follow(moved(track, to_world), moved(track, to_imu), settle_s=SETTLE_S if k == 0 else 0.0,
                         hold_s=HOLD_S if k == n - 1 else STAND_S)
        for landing in seg.landings:  # the scenario's step (the run's landings are the segment's, step 0 each)
            landing["step"] = k
        out.plans.append(StepPlan(k, result.scenario, result, mode, to_world, start, target))
        out.steps.append(_step_record(k, st, mode, to_world, target, error, start, (sup_true, yaw_true), seg))
        out.steps[-1].update(path_samples=len(result.steps[0].path_m), swing_s=float(result.scenario.timing.swing_s))
        if seg.fell is not None:
            break
    out.run = run.result()
    for rec_k, judged in zip(out.steps, out.run.steps, strict=False):  # the footholds the robot aimed for
        judged["step"] = rec_k["step"]  # the scenario's step (the judge counts within each executed segment)
        judged["foothold_m"] = rec_k["landing_m"]
        if "landing_error_m" in rec_k:
            judged["foothold_error_m"] = rec_k["landing_error_m"]
    if out.refused is not None:
        out.run.survived = False
        out.run.stopped = f"step {out.refused['step']} could not be planned from where the robot stood"
    return out


def _estimated_start(run: TwinRun, kin: OwnKinematics, sup: str, sw: str, s_frame: np.ndarray
                     ) -> tuple[dict[str, np.ndarray], float]:
    """Where the robot believes its soles stand before a step, in the step's frame (the support sole at
    ``s_frame``): the swing sole relative to the support by its own kinematics from the IMU and the encoders,
    turned by the support sole's estimated heading; and that heading [rad]."""
    m = run.measure()
    assert m.joints_rad is not None and m.trunk_rotation is not None  # the IMU and encoders (checked by execute)
    kin.update(m.joints_rad, m.trunk_rotation)
    p_sup, r_sup = kin.sole(sup)
    p_sw, _ = kin.sole(sw)
    yaw_est = yaw_of(r_sup)
    c, s = math.cos(-yaw_est), math.sin(-yaw_est)
    d = p_sw - p_sup
    return {sup: s_frame.copy(), sw: s_frame + np.array([c * d[0] - s * d[1], s * d[0] + c * d[1], d[2]])}, yaw_est


def _step_record(k: int, st, mode: str, to_world: Frame, target: np.ndarray, error: np.ndarray,
                 start: dict[str, np.ndarray], support: tuple[np.ndarray, float], seg) -> dict:
    """One executed step as simulation.json records it (SI units, in the twin's world): the foothold, as
    perceived, where the robot believed it stood, the true support sole, and the judge's landing."""
    sup_true, yaw_true = support
    judged = seg.steps[0] if seg.steps else None
    rec = {"step": k, "swing": st.swing, "support": st.support, "mode": mode,
           "landing_m": [float(v) for v in st.landing_m],
           "perceived_m": [float(v) for v in to_world.point(target)],
           "perception_error_m": [float(v) for v in error],
           "estimated_start_m": {s: [float(v) for v in to_world.point(start[s])] for s in SIDES},
           "support_m": [float(v) for v in sup_true], "support_yaw_rad": float(yaw_true),
           "survived_step": seg.fell is None}
    if judged is not None:
        landed = np.asarray(judged["landed_m"])
        err = landed[:2] - np.asarray(st.landing_m)[:2]
        rec.update(landed_m=judged["landed_m"], landing_error_m=float(np.hypot(*err)),
                   landing_error_xy_m=[float(v) for v in err], judge=judged)
    return rec


def executed_plan(scenario: Scenario, execution: Execution, folder: Path) -> tuple[PlanResult, str]:
    """The steps the robot executed, as a plan of the twin's world, for ``folder`` (where it will be written
    with its scenario, ``executed.yaml``); the plan and that scenario's text ("" where the executed landings
    break a scenario's rules: then the plan names no scenario and ``verify`` checks its rows against its own
    swing paths).

    Each step's trunk postures as the robot planned them (carried into the world by its support sole's
    true pose), its swing path from where the sole stood to where it truly landed (the path moved to those
    ends, :func:`reanchor_ends`; the height of the carton it landed on), the rows built by the planner's
    row builder under the scenario's own limits with the scenario's timing: no pauses
    between the steps, every swing lasting the scenario's ``swing_s``, as it ran. A
    sole stands where it landed until it swings again (its slip while it supports is in the run's record).
    Rows that break the planner's rules are kept, marked infeasible."""
    import yaml

    robot = scenario.robot
    feet = {s: np.asarray(scenario.start[s], dtype=float).copy() for s in SIDES}
    steps: list[Step] = []
    results: list[StepResult] = []
    docs: list[dict] = []
    for plan_k, rec in zip(execution.plans, execution.steps, strict=False):
        if "landed_m" not in rec:
            break
        st = plan_k.result.steps[0]
        frame = plan_k.to_world
        landed = np.array([rec["landed_m"][0], rec["landed_m"][1], rec["landing_m"][2]])
        path = reanchor_ends(frame.point(st.path_m), feet[st.swing], landed)
        samples = [replace(x, best=replace(x.best, p_body=frame.point(x.best.p_body))) for x in st.samples]
        steps.append(Step(st.swing, path))
        results.append(StepResult(len(results), st.swing, st.support, path, samples, st.fan_index))
        docs.append({"swing": str(st.swing), "path": {"kind": "points", "points_m": path.tolist()}})
        feet[st.swing] = landed
    doc = yaml.safe_load(scenario.text) if scenario.text else {}
    doc.pop("expect", None)
    doc.update(name=f"{scenario.name}_executed", steps=docs,
               start={str(s): [float(v) for v in scenario.start[s]] for s in SIDES})
    text = ("# The steps `jethr1 simulate` executed step by step (the twin's world): each swing from where its\n"
            "# sole stood to where it landed. Written beside the plan it makes (docs/rehearsal.md).\n"
            + yaml.safe_dump(doc, sort_keys=False))
    source = str(Path(folder) / "executed.yaml")
    try:
        load_scenario_text(text, source)
    except InputError:
        text = ""
    done = replace(scenario, name=f"{scenario.name}_executed", steps=tuple(steps), expect={}, source=source,
                   text=text, start={s: np.asarray(scenario.start[s], dtype=float) for s in SIDES})
    seq = Sequence(done, robot, row_solver(robot), None)
    for st in results:
        seq.add(st)
    rows, bad = seq.finish()
    bad = add_analysis(rows, robot, 1.0 / done.timing.rate_hz, False) or bad
    first = bad if bad is not None else next((Infeasible.at_row(i, r)
                                              for i, r in enumerate(rows.columns[RowField.REASON]) if r), None)
    return PlanResult(done, robot, "executed", done.seed, results, rows, first, 0, 0.0), text
