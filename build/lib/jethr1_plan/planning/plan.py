"""``jethr1 plan``: a scenario in, optimised swing samples and a resampled trajectory out."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from jethr1_plan import __version__
from jethr1_plan.errors import InfeasiblePlan
from jethr1_plan.kinematics.closed_form import make_posture_solver
from jethr1_plan.kinematics.placo import PostureSolver, Stance
from jethr1_plan.optimisers.gas import SampleResult, optimise_sample
from jethr1_plan.optimisers.problem import VIOLATIONS, SampleProblem
from jethr1_plan.physics.balance import NOMINAL, body_yaw_eq4, body_yaw_forward_axis, sole_polygon
from jethr1_plan.physics.statics import KAPPA_WARNING, analyse_rows
from jethr1_plan.planning.commands import fan_commands, servo_commands
from jethr1_plan.planning.sequence import Rows, SequenceBuilder, swing_row_positions
from jethr1_plan.robot.model import SIDES, RobotModel, load_robot, reach_centre
from jethr1_plan.scenario import Scenario

STANDING_HEIGHT_FRACTION = 0.9  # standing pelvis height over the soles, as a fraction of the leg length
NOMINAL_HEIGHT_FRACTION = 0.8  # centre of the initial phase's box, same unit


@dataclass
class StepResult:
    """The optimised samples of one step."""

    index: int
    swing: str
    support: str
    path_m: np.ndarray  # (N, 3)
    samples: list[SampleResult]

    @property
    def p_body(self) -> np.ndarray:
        return np.array([s.p_body for s in self.samples])

    @property
    def thrust_n(self) -> np.ndarray:
        return np.array([float(s.best.thrust_n[0]) for s in self.samples])


@dataclass
class PlanResult:
    scenario: Scenario
    robot: RobotModel
    method: str
    seed: int
    steps: list[StepResult]
    rows: Rows | None
    first_infeasible: dict | None
    evaluations: int
    wall_s: float
    optimise_s: float = 0.0  # the optimisation alone (no output-rate sequence) [s]

    @property
    def feasible(self) -> bool:
        return self.first_infeasible is None


def smoothness(p_body: np.ndarray, thrust_n: np.ndarray) -> dict:
    """Σ‖ΔP_body‖² [m²], the largest ‖ΔP_body‖ [m] and the largest thrust jump [N] over consecutive samples
    (pairs of samples that both balance)."""
    d = np.diff(p_body, axis=0)
    step = np.linalg.norm(d, axis=1) if len(d) else np.zeros(1)
    thrust = np.asarray(thrust_n, dtype=float)
    pairs = np.isfinite(thrust[1:]) & np.isfinite(thrust[:-1])  # infeasible samples have no thrust
    jumps = np.abs(thrust[1:][pairs] - thrust[:-1][pairs])
    return {"smoothness_m2": float(np.sum(d * d)), "max_step_m": float(step.max()),
            "max_thrust_jump_n": float(jumps.max()) if len(jumps) else 0.0}


def yaw_function(scenario: Scenario, robot: RobotModel, support: str, support_xyz: np.ndarray):
    """Body yaw [rad] as a function of the swing sole position, per the scenario's mode."""
    swing = "left" if support == "right" else "right"
    off = np.asarray(robot.fan_for(swing).offset_in_foot_m[:2])
    if scenario.yaw_mode in ("eq4", "mpc"):  # mpc smooths this reference (yaw_mpc.build_schedule)
        return lambda sw: float(body_yaw_eq4(support_xyz[:2], sw[:2] + off, support))
    if scenario.yaw_mode == "forward_axis":
        return lambda sw: float(body_yaw_forward_axis(support_xyz[:2], sw[:2] + off))
    return lambda sw: scenario.yaw_fixed_rad


def sample_problem(scenario: Scenario, robot: RobotModel, support: str, support_xyz: np.ndarray,
                   swing_xyz: np.ndarray, yaw: float) -> SampleProblem:
    """The optimisation problem at one swing sample."""
    swing = "left" if support == "right" else "right"
    fan_xy = swing_xyz[:2] + np.asarray(robot.fan_for(swing).offset_in_foot_m[:2])
    stance = Stance(support, support_xyz, 0.0, swing_xyz, 0.0, yaw)
    poly = sole_polygon(support_xyz[:2], 0.0, robot.sole_length_m, robot.sole_width_m, scenario.balance.sole_margin_m)
    return SampleProblem(stance=stance, fan_xy=fan_xy, ankle_xy=swing_xyz[:2].copy(), edge_origin_xy=support_xyz[:2],
                         support_polygon=poly, mass_kg=robot.mass_kg, thrust_max_n=scenario.balance.thrust_max_n,
                         rho_rad=scenario.balance.rho_rad, tolerance=scenario.balance.tolerance)


def path_problems(scenario: Scenario, robot: RobotModel, si: int, feet: dict[str, np.ndarray],
                  sample_yaw: np.ndarray | None = None) -> Callable[[float], SampleProblem]:
    """``problem_at(u)``: the problem with the swing sole at path parameter ``u`` of step ``si``
    (sample index, fractional between samples, interpolated as the sequence's rows are); the body
    yaw from the scenario's mode, or interpolated in ``sample_yaw`` (the MPC schedule's samples)."""
    step = scenario.steps[si]
    support = step.support
    yaw_of = yaw_function(scenario, robot, support, feet[support])
    idx = np.arange(len(step.path_m))

    def problem_at(u: float) -> SampleProblem:
        swing = np.array([np.interp(u, idx, step.path_m[:, j]) for j in range(3)])
        yaw = yaw_of(swing) if sample_yaw is None else float(np.interp(u, idx, sample_yaw))
        return sample_problem(scenario, robot, support, feet[support], swing, yaw)

    return problem_at


def feet_before_each_step(scenario: Scenario) -> list[dict[str, np.ndarray]]:
    """Both sole positions [m] at the start of every step."""
    feet = {k: v.copy() for k, v in scenario.start.items()}
    out = []
    for step in scenario.steps:
        out.append({k: v.copy() for k, v in feet.items()})
        feet[step.swing] = step.landing_m.copy()
    return out


def optimise_step(scenario: Scenario, si: int, feet: dict[str, np.ndarray], cfg, seed: int,
                  keep_going: bool, solver: PostureSolver | None = None, kinematics: str = "placo",
                  sample_yaw: np.ndarray | None = None,
                  progress: Callable[[str, int, int], None] | None = None, done0: int = 0, total: int = 0
                  ) -> tuple[StepResult, dict | None]:
    """Optimise every sample of step ``si``; stops at its first infeasible sample unless ``keep_going``.

    Steps are independent of each other (each starts with the initial phase and every sample has
    its own random stream ``default_rng([seed, step, sample])``), so they may run in any process.
    """
    robot = load_robot(scenario.robot)
    solver = solver or make_posture_solver(robot, kinematics)
    step = scenario.steps[si]
    support = step.support
    problem_at = path_problems(scenario, robot, si, feet, sample_yaw)
    z_nom = scenario.nominal_height_m or NOMINAL_HEIGHT_FRACTION * robot.leg_length_m
    results: list[SampleResult] = []
    previous = None
    first_bad = None
    problems = [problem_at(i) for i in range(len(step.path_m))]
    nominals = [np.array([*(0.5 * (feet[support][:2] + swing_xyz[:2])), feet[support][2] + z_nom])
                for swing_xyz in step.path_m]
    path_results = None
    if cfg.method == "sqp":  # optimises the whole path at once (forward and backward passes)
        from jethr1_plan.optimisers.sqp import optimise_path_sqp

        path_results = optimise_path_sqp(solver, robot, problems, nominals, cfg,
                                         [np.random.default_rng([seed, si, i]) for i in range(len(problems))],
                                         lambda i, lam: problem_at(i + lam),
                                         swing_row_positions(len(problems), scenario.timing.swing_s,
                                                             scenario.timing.rate_hz))
    for i, swing_xyz in enumerate(step.path_m):
        problem, nominal = problems[i], nominals[i]
        if path_results is not None:
            res = path_results[i]
        else:
            res = optimise_sample(solver, problem, cfg, np.random.default_rng([seed, si, i]), previous, nominal)
        results.append(res)
        previous = res.p_body
        if progress:
            progress(f"step {si} sample {i}", done0 + i + 1, total)
        if not res.feasible and first_bad is None:
            first_bad = {"step": si, "phase": "swing", "sample": i, "swing_m": swing_xyz.tolist(),
                         "p_body_m": res.p_body.tolist(), "thrust_n": _finite(res.best.thrust_n[0]),
                         "reason": VIOLATIONS[int(res.best.violation[0])]}
            if problem.tolerance != NOMINAL:
                first_bad["reachable_tolerance"] = reachable_tolerance(robot, problem, res.p_body,
                                                                       cfg.initial.half_range_m)
            if not keep_going:
                return StepResult(si, step.swing, support, step.path_m[:i + 1], results), first_bad
    return StepResult(si, step.swing, support, step.path_m, results), first_bad


def _optimise_step_job(scenario, si, feet, cfg, seed, keep_going, kinematics, sample_yaw):
    return optimise_step(scenario, si, feet, cfg, seed, keep_going, kinematics=kinematics, sample_yaw=sample_yaw)


def plan(*args, **kwargs) -> PlanResult:
    """:func:`_plan` with BLAS on one thread, as in joblib's worker processes: a multi-threaded BLAS
    sums in another order (measured: sqp's P_body moved by 4.6 mm at one sample of the robust trial
    between -j 1 and -j 2), so the output would depend on -j. See :func:`_plan` for the arguments."""
    import scipy.optimize  # noqa: F401  (its own BLAS must be loaded to be limited)
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        return _plan(*args, **kwargs)


def _plan(scenario: Scenario, method: str | None = None, seed: int | None = None,
         progress: Callable[[str, int, int], None] | None = None, keep_going: bool = False,
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
        InfeasiblePlan: at the first infeasible sample unless ``keep_going``.
    """
    t0 = time.perf_counter()
    robot = load_robot(scenario.robot)
    cfg = scenario.optimiser if method is None else replace(scenario.optimiser, method=method)
    seed = scenario.seed if seed is None else seed
    # every step, and the sequence, get a solver of their own (as worker processes do), so that the
    # result does not depend on -j: a PlaCo solver carries state from one solve to the next
    given = solver
    feet_at = feet_before_each_step(scenario)
    schedule = yaw_schedule(scenario, robot) if scenario.yaw_mode == "mpc" else None
    sample_yaws = schedule.sample_yaw if schedule else [None] * len(scenario.steps)
    total = sum(len(s.path_m) for s in scenario.steps)
    n = len(scenario.steps)
    if jobs > 1 and n > 1:
        from joblib import Parallel, delayed

        outcomes = []
        for k, out in enumerate(Parallel(n_jobs=min(jobs, n), return_as="generator")(
                delayed(_optimise_step_job)(scenario, si, feet_at[si], cfg, seed, keep_going, kinematics,
                                            sample_yaws[si]) for si in range(n))):
            outcomes.append(out)
            if progress:
                progress(f"step {k}", sum(len(o[0].samples) for o in outcomes), total)
    else:
        outcomes, done = [], 0
        for si in range(n):
            out = optimise_step(scenario, si, feet_at[si], cfg, seed, keep_going, given, kinematics, sample_yaws[si],
                                progress, done, total)
            outcomes.append(out)
            done += len(out[0].samples)
            if out[1] is not None and not keep_going:
                break
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
        raise InfeasiblePlan(_describe(first_bad), plan_summary(result))

    rows = None
    if build_rows:
        rows, bad_row = build_sequence(scenario, robot, given or make_posture_solver(robot, kinematics), steps,
                                       schedule)
        bad_torque = add_analysis(rows, robot, 1.0 / scenario.timing.rate_hz, strict_torque)
        bad_row = bad_row or bad_torque
        if first_bad is None and bad_row is not None:
            first_bad = bad_row
            if not keep_going:
                result = PlanResult(scenario, robot, cfg.method, seed, steps, None, first_bad, evaluations,
                                    time.perf_counter() - t0)
                raise InfeasiblePlan(_describe(first_bad), plan_summary(result))
    return PlanResult(scenario, robot, cfg.method, seed, steps, rows, first_bad, evaluations, time.perf_counter() - t0,
                      optimise_s)


def add_analysis(rows: Rows, robot: RobotModel, dt: float, strict_torque: bool) -> dict | None:
    """Add Paper B's per-row figures (static torques, κ, yaw momentum) to ``rows``; flag torques
    above the servo limits (infeasible rows under ``strict_torque``). Returns the first such row."""
    a = analyse_rows(robot, rows, dt)
    c = rows.columns
    c["tau"], c["kappa"], c["yaw_momentum"] = list(a["tau"]), list(a["kappa"]), list(a["yaw_momentum"])
    c["q_cmd"] = list(servo_commands(np.asarray(c["q"], dtype=float), a["tau"], robot.servo_stiffness_nm_per_rad,
                                     1.0 / dt))
    fans = [robot.fan_for(side) for side in SIDES]
    cmd = fan_commands(np.column_stack([rows.array(f"thrust_{side}") for side in SIDES]), 1.0 / dt,
                       np.array([f.lag_s for f in fans]), np.array([f.max_thrust_n for f in fans]))
    for k, side in enumerate(SIDES):
        c[f"thrust_cmd_{side}"] = list(cmd[:, k])
    ratio = np.abs(a["tau"]) / robot.servo_limit_nm
    over = np.flatnonzero(ratio.max(axis=1) > 1.0)
    rows.analysis = {"energy_j": a["energy_j"], "ratio": ratio}
    if not strict_torque or not len(over):
        return None
    first = None
    for i in over:
        j = int(np.argmax(ratio[i]))
        reason = f"{robot.joint_names[j]} torque {a['tau'][i, j]:.2f} N·m above its servo limit"
        c["feasible"][i] = False
        c["reason"][i] = c["reason"][i] or reason
        if first is None:
            first = {"time_s": float(c["time_s"][i]), "step": int(c["step"][i]), "phase": c["phase"][i],
                     "sample": int(c["sample"][i]), "reason": reason}
    return first


def reachable_tolerance(robot: RobotModel, problem: SampleProblem, centre: np.ndarray, half: float) -> dict:
    """The largest share of the tolerance a sample reaches (``sqp_optimiser.largest_tolerance``)."""
    from jethr1_plan.optimisers.sqp import largest_tolerance

    k, p = largest_tolerance(robot, problem, centre, half)
    t = problem.tolerance.scaled(k)
    return {"scale": k, "thrust_error": t.thrust, "mass_error": t.mass, "com_error_m": t.com_m,
            "p_body_m": None if p is None else p.tolist()}


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _describe(bad: dict) -> str:
    where = f"step {bad['step']} {bad['phase']} sample {bad['sample']}"
    pos = f" (swing sole at {np.round(bad['swing_m'], 4).tolist()} m)" if "swing_m" in bad else ""
    thrust = f", minimal thrust {bad['thrust_n']:.2f} N" if bad.get("thrust_n") is not None else ""
    reach = bad.get("reachable_tolerance")
    if reach is not None:
        thrust += (f"; the most found to hold there: ±{100 * reach['thrust_error']:.1f} % thrust, "
                   f"±{100 * reach['mass_error']:.1f} % mass, {1000 * reach['com_error_m']:.1f} mm of CoM error "
                   f"({100 * reach['scale']:.0f} % of the tolerance)" if reach["scale"] > 0 else
                   "; no posture balances this sample even without tolerance")
    return f"infeasible at {where}{pos}: {bad['reason']}{thrust}"


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
    from jethr1_plan.planning.yaw_mpc import build_schedule

    feet_at = feet_before_each_step(scenario)
    eq4 = [yaw_function(scenario, robot, st.support, f[st.support]) for st, f in zip(scenario.steps, feet_at,
                                                                                       strict=True)]
    return build_schedule(scenario, robot, eq4, [st.path_m for st in scenario.steps], **scenario.yaw_mpc)


def build_sequence(scenario: Scenario, robot: RobotModel, solver: PostureSolver, steps: list[StepResult],
                   schedule=None) -> tuple[Rows, dict | None]:
    """Stand → (transfer → swing)* → transfer → stand, at the scenario's output rate."""
    tm = scenario.timing
    b = scenario.balance
    seq = SequenceBuilder(robot, solver, tm.rate_hz, b.thrust_max_n, b.rho_rad, b.sole_margin_m, b.tolerance)
    if schedule is not None:
        seq.yaw_of_row = schedule.at_row
    feet = {k: v.copy() for k, v in scenario.start.items()}
    p_prev, yaw_prev = standing_pose(robot, feet, 0.0), 0.0
    thrust_out = None
    for st in steps:
        yaw_of = yaw_function(scenario, robot, st.support, feet[st.support])
        p_first, yaw_first = st.p_body[0], yaw_of(st.path_m[0])
        seq.transfer(st.index, feet, p_prev, yaw_prev, p_first, yaw_first, tm.transfer_s, thrust_out,
                     (st.swing, float(st.thrust_n[0])))
        seq.swing(st.index, st.support, feet, st.path_m, st.p_body, yaw_of, tm.swing_s)
        feet[st.swing] = st.path_m[-1].copy()
        p_prev, yaw_prev = st.p_body[-1], yaw_of(st.path_m[-1])
        thrust_out = (st.swing, float(st.thrust_n[-1]))
    seq.transfer(len(steps), feet, p_prev, yaw_prev, standing_pose(robot, feet, yaw_prev), yaw_prev, tm.transfer_s,
                 thrust_out, None, include_end=True)
    return seq.rows, seq.first_infeasible


def _where(rows: Rows, i: int) -> dict:
    c = rows.columns
    return {"row": int(i), "time_s": round(float(c["time_s"][i]), 9), "step": int(c["step"][i]),
            "phase": c["phase"][i], "sample": int(c["sample"][i])}


def robustness_summary(rows: Rows) -> dict:
    """The least ZMP margin [m] and the narrowest thrust window [N] over the rows, and where they occur.

    The narrowest window is taken over the rows whose fan carries thrust (elsewhere the window is
    that of a fan not in use)."""
    margin = rows.array("zmp_margin").astype(float)
    window = np.array(rows.columns["window"], dtype=float)
    loaded = (rows.array("thrust_left") + rows.array("thrust_right")) > 0
    if not np.isfinite(margin).any():  # no row has a posture (an unreachable step written anyway)
        return {"least_zmp_margin_m": None}
    i = int(np.nanargmin(margin))
    out = {"least_zmp_margin_m": float(margin[i]), "least_zmp_margin_at": _where(rows, i)}
    width = np.where(loaded & np.isfinite(window[:, 0]), window[:, 1] - window[:, 0], np.inf)
    if np.isfinite(width).any():
        j = int(np.argmin(width))
        out |= {"narrowest_window_n": [float(window[j, 0]), float(window[j, 1])],
                "narrowest_window_width_n": float(width[j]), "narrowest_window_at": _where(rows, j)}
    return out


def plan_summary(result: PlanResult) -> dict:
    """summary.json (CONTRACT.md): figures over the optimised swing samples, per step and in total."""
    sc = result.scenario
    per_step = []
    all_thrust, all_p = [], []
    for st in result.steps:
        thrust = st.thrust_n
        fin = thrust[np.isfinite(thrust)]
        per_step.append({
            "index": st.index, "swing": st.swing, "support": st.support, "samples": len(st.samples),
            "max_thrust_n": float(fin.max()) if len(fin) else None,
            "mean_thrust_n": float(fin.mean()) if len(fin) else None,
            **smoothness(st.p_body, thrust),
            "evaluations": int(sum(s.evaluations for s in st.samples)),
            "restarts": sum(s.phase == "restart" for s in st.samples),
            "feasible": all(s.feasible for s in st.samples),
        })
        all_thrust.append(fin)
        all_p.append(st.p_body)
    thr = np.concatenate(all_thrust) if all_thrust else np.zeros(0)
    out = {
        "scenario": sc.name,
        "scenario_file": str(Path(sc.source).resolve()) if sc.text else sc.source,
        "scenario_yaml": sc.text,  # the scenario as read: verify finds it even where the file has moved
        "robot": result.robot.name,
        "robot_yaml": str(result.robot.yaml_path),
        "optimiser": result.method,
        "seed": result.seed,
        "version": __version__,
        "feasible": result.feasible,
        "first_infeasible": result.first_infeasible,
        "sample_count": int(sum(len(st.samples) for st in result.steps)),
        "row_count": len(result.rows) if result.rows is not None else 0,
        "max_thrust_n": float(thr.max()) if len(thr) else None,
        "mean_thrust_n": float(thr.mean()) if len(thr) else None,
        "thrust_max_n": sc.balance.thrust_max_n,
        "balance": {"policy": sc.balance.policy, "sole_margin_m": sc.balance.sole_margin_m,
                    "tolerance": {"thrust_error": sc.balance.tolerance.thrust, "mass_error": sc.balance.tolerance.mass,
                                  "com_error_m": sc.balance.tolerance.com_m}},
        "smoothness_m2": float(sum(s["smoothness_m2"] for s in per_step)),
        "max_step_m": max((s["max_step_m"] for s in per_step), default=0.0),
        "max_thrust_jump_n": max((s["max_thrust_jump_n"] for s in per_step), default=0.0),
        "evaluations": int(result.evaluations),
        "wall_s": float(result.wall_s),
        "steps": per_step,
        "terrain": {"cartons": [{"top_centre_m": list(c.top_centre_m), "size_m": list(c.size_m)}
                                for c in sc.cartons]},
    }
    if result.rows is not None and len(result.rows):
        rows = result.rows
        tl, tr = rows.array("thrust_left"), rows.array("thrust_right")
        out["trajectory"] = {"rows": len(rows), "rate_hz": sc.timing.rate_hz,
                             "duration_s": len(rows) / sc.timing.rate_hz,
                             "max_thrust_n": float(max(tl.max(), tr.max()))}
        out["robustness"] = robustness_summary(rows)
        from jethr1_plan.sim.controller import Gains, law

        tol = sc.balance.tolerance
        out["controller"] = law(Gains.of(result.robot), tol.thrust, tol.mass, sc.balance.thrust_max_n)
        if "tau" in rows.columns:
            tau, kappa = np.abs(rows.array("tau")), rows.array("kappa")
            ratio = rows.analysis["ratio"]
            out["torques"] = {
                "max_abs_nm": dict(zip(result.robot.joint_names, tau.max(axis=0).tolist(), strict=True)),
                "max_ratio_to_servo_limit": float(ratio.max()),
                "rows_over_servo_limit": int(np.sum(ratio.max(axis=1) > 1.0)),
            }
            out["energy_j"] = float(rows.analysis["energy_j"])
            kappa = np.where(np.isfinite(kappa), kappa, np.nan)  # rows without a posture have none
            out["kappa"] = {"max_left": _finite(np.nanmax(kappa[:, 0], initial=0.0)),
                            "max_right": _finite(np.nanmax(kappa[:, 1], initial=0.0)),
                            "warning_threshold": KAPPA_WARNING,
                            "rows_above_threshold": int(np.sum(kappa.max(axis=1) > KAPPA_WARNING))}
            out["yaw_momentum_peak_nms"] = float(np.abs(rows.array("yaw_momentum")).max())
        dt = 1.0 / sc.timing.rate_hz
        yaw = np.unwrap(rows.array("yaw").astype(float))
        rate = np.gradient(yaw, dt)
        out["yaw"] = {"mode": sc.yaw_mode, "peak_rate_rad_s": float(np.abs(rate).max()),
                      "peak_accel_rad_s2": float(np.abs(np.gradient(rate, dt)).max())}
    return out
