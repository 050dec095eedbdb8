"""Scenario files: a typed, validating loader.

A scenario is YAML (see README, "Scenario files"). Structure is checked against a JSON Schema
(unknown keys, wrong types, bounds), then numbers are checked to be finite, then the geometry is
checked (soles fully on cartons, swing paths that clear carton edges). Every problem is an
:class:`~jethr1_plan.errors.InputError` naming the file, the key path and what is wrong.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.geometry import GRAVITY, other_side
from jethr1_plan.io.yaml_input import fill_dataclass, read_text
from jethr1_plan.optimisers import OptimiserConfig
from jethr1_plan.optimisers.problem import FitnessConstants
from jethr1_plan.physics.balance import NOMINAL, Tolerance
from jethr1_plan.robot.load import build_with_robot
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.scenario_schema import (
    DEFAULT_CARTON_M,
    F3_UNITS,
    MAX_FILE_BYTES,
    MAX_ROWS,
    MAX_VALUES,
    MIN_PHASE_ROWS,
    SCHEMA,
    TOLERANCE_KEYS,
)
from jethr1_plan.swing_path import Carton, arc_path, first_collision, sole_on_carton

__all__ = ["MAX_ESTIMATED_S", "REFERENCE_SAMPLE_S", "ROBUST_DEFAULT", "BalanceConfig", "BodyYaw", "Scenario", "Step",
           "Timing", "check_fastest", "check_plan_time", "load_scenario", "load_scenario_text", "plan_seconds"]

MAX_ESTIMATED_S = 3600.0  # a request estimated to take longer on this machine is refused before it starts [s]
# the least times (below what docs/benchmarks.md measures, so that no request that would finish is refused) [s]
GA_EVALUATION_S = 50e-6  # one GA candidate: a posture and its balance
SQP_SAMPLE_S = 0.01  # sqp, one swing sample
REFERENCE_SAMPLE_S = 0.3  # the exhaustive reference (compare --reference), one swing sample


@dataclass(frozen=True)
class Step:
    """One swing: which foot, its sampled path (N, 3) [m] (first = current sole, last = landing)."""

    swing: str
    path_m: np.ndarray

    @property
    def support(self) -> str:
        return other_side(self.swing)

    @property
    def landing_m(self) -> np.ndarray:
        return self.path_m[-1]


@dataclass(frozen=True)
class Timing:
    """``timing:`` of a scenario. ``mode`` ``fixed``: every swing lasts ``swing_s`` and every transfer
    ``transfer_s``; ``fastest``: each as fast as the rows' own dynamics allow (``planning.fast_timing``),
    with ``dynamic_share`` of each row's tolerance share held under the motion, ``safety_factor`` on the
    joint velocity, torque and friction limits (the fans' lag ÷ it), ``spin_down_n`` [N] how far a fan
    may stay above a falling plan, and floors and caps on each phase [s] (a phase slower than its cap
    is infeasible); ``swing_s`` and ``transfer_s`` are then the fixed timing it is compared with."""

    swing_s: float = 8.0  # each swing [s]
    transfer_s: float = 3.0  # each double-support transfer [s]
    rate_hz: float = 50.0  # output rows per second [Hz]
    mode: str = "fixed"
    dynamic_share: float = 0.8
    safety_factor: float = 0.8
    spin_down_n: float = 0.5
    min_swing_s: float = 0.0
    min_transfer_s: float = 0.0
    max_swing_s: float = 300.0
    max_transfer_s: float = 300.0

    @property
    def fastest(self) -> bool:
        return self.mode == "fastest"


@dataclass(frozen=True)
class BodyYaw:
    """``body_yaw:`` of a scenario: how the trunk turns (Paper A's (A-4), Paper B's MPC) [rad, s]."""

    mode: str = "eq4"  # eq4 | mpc | forward_axis | fixed
    fixed_rad: float = 0.0  # the yaw of mode ``fixed`` [rad]
    horizon_s: float = 1.6  # mpc: look-ahead [s]
    alpha: float = 1.0  # mpc: weight of tracking (A-4)'s reference
    beta: float = 1e-10  # mpc: weight of the yaw acceleration

    @property
    def mpc(self) -> dict:
        """The MPC's settings (``yaw_mpc.build_schedule``)."""
        return {"horizon_s": self.horizon_s, "alpha": self.alpha, "beta": self.beta}


#: the robust policy's default: ±10 % thrust, ±5 % total mass, 10 mm of CoM error (model and servo sag)
ROBUST_DEFAULT = Tolerance(thrust=0.10, mass=0.05, com_m=0.01)


@dataclass(frozen=True)
class BalanceConfig:
    """``balance:`` of a scenario (SI units).

    ``policy`` chooses the thrust of every posture: ``minimal`` is Paper A's least thrust H(P_body)
    (the ZMP on the sole's edge); ``robust`` the least thrust whose ZMP stays in the sole under
    every model error within ``robust`` (``balance.thrust_window``), and the optimisers choose
    P_body for it; where no posture of a sample reaches that tolerance, the sample takes the largest
    share of it one does (``tolerance_share``), and a share below ``min_share`` makes the plan
    infeasible.
    """

    thrust_max_n: float = math.inf  # the limit on every fan [N]; a scenario's defaults to its robot's largest fan
    rho_rad: float = math.radians(5.0)
    sole_margin_m: float = 0.0
    policy: str = "robust"
    robust: Tolerance = ROBUST_DEFAULT
    min_share: float = 0.0  # the least share of ``robust`` a plan may take at any sample (0: any margin beats none)

    @property
    def tolerance(self) -> Tolerance:
        """The model errors every planned posture must survive (zero under ``minimal``)."""
        return self.robust if self.policy == "robust" else NOMINAL


@dataclass(frozen=True)
class Scenario:
    """A validated scenario (SI units)."""

    source: str
    name: str
    robot: RobotModel
    seed: int
    start: dict[str, np.ndarray]
    cartons: tuple[Carton, ...]
    steps: tuple[Step, ...]
    optimiser: OptimiserConfig
    balance: BalanceConfig
    body_yaw: BodyYaw
    timing: Timing
    nominal_height_m: float | None
    expect: dict = field(default_factory=dict)
    text: str = ""  # the scenario file as read (kept in summary.json, so a plan folder names its scenario)

    @property
    def yaw_mode(self) -> str:
        return self.body_yaw.mode


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file (the robot it names is loaded for its sole size).

    Raises:
        InputError: the first problem found (exit 2).
    """
    return load_scenario_text(read_text(path, MAX_FILE_BYTES, "a scenario"), str(path))


def load_scenario_text(text: str, src: str) -> Scenario:
    """A scenario from its YAML ``text``; ``src`` names it in messages (see :func:`load_scenario`)."""
    return replace(build_with_robot(text, src, SCHEMA, MAX_VALUES, "a scenario", _build), text=text)


def _build(doc: dict, src: str, robot) -> Scenario:
    if not robot.fans:
        raise InputError(src, "robot", f"{robot.name} has no fans: a plan steps with thrust (Paper A); walks without "
                         "fans are jethr1 walk's")
    terrain = doc.get("terrain", {})
    size = tuple(terrain.get("carton_size_m", DEFAULT_CARTON_M))
    cartons = tuple(Carton(tuple(c["top_centre_m"]), tuple(c.get("size_m", size))) for c in terrain.get("cartons", []))
    _check_overlaps(cartons, src)
    ground = _Ground(cartons, robot.sole_length_m, robot.sole_width_m)
    start = ({side: np.array(doc["start"][side], dtype=float) for side in ("left", "right")} if "start" in doc
             else robot.start_feet())
    for side in ("left", "right"):
        if not ground.holds(start[side]):
            raise InputError(src, f"start.{side}", "the sole does not lie fully on a carton top")
    if np.linalg.norm(start["left"][:2] - start["right"][:2]) < robot.sole_width_m:
        raise InputError(src, "start", "the two soles overlap")
    feet = dict(start)
    steps = []
    for i, sd in enumerate(doc["steps"]):
        step = _step(sd, f"steps[{i}]", feet, robot, ground, src)
        steps.append(step)
        feet[step.swing] = step.landing_m
    opt = doc.get("optimiser", {})
    optimiser = _optimiser(opt, robot, src)
    balance = _balance(dict(doc.get("balance", {})), robot, src)
    timing = fill_dataclass(Timing(), doc.get("timing", {}))
    _check_timing(timing, len(steps), doc.get("body_yaw", {}).get("mode", "eq4"), balance, src)
    scenario = Scenario(
        source=src, name=doc.get("name", Path(src).stem), robot=robot, seed=doc.get("seed", 0),
        start=start, cartons=cartons, steps=tuple(steps), optimiser=optimiser, balance=balance,
        body_yaw=fill_dataclass(BodyYaw(), doc.get("body_yaw", {})), timing=timing,
        nominal_height_m=opt.get("nominal_height_m"), expect=dict(doc.get("expect", {})))
    check_plan_time(scenario, (optimiser.method,))
    return scenario


@dataclass(frozen=True)
class _Ground:
    """Where a sole may stand: fully on a carton top, or on the ground (z = 0) where there are no cartons."""

    cartons: tuple[Carton, ...]
    sole_l: float  # [m]
    sole_w: float  # [m]

    def holds(self, p: np.ndarray) -> bool:
        if not self.cartons:
            return abs(p[2]) < 1e-9
        return any(sole_on_carton(p, 0.0, self.sole_l, self.sole_w, c) for c in self.cartons)


def _step(sd: dict, key: str, feet: dict[str, np.ndarray], robot, ground: _Ground, src: str) -> Step:
    """``steps[i]``: the swing path (explicit points or an arc to ``landing_m``) from where the soles stand
    (``feet``), its landing on the terrain and off the support sole, every sample within the legs' span, and the
    path clear of every carton."""
    swing = sd["swing"]
    path_doc = sd.get("path", {"kind": "arc"})
    if path_doc["kind"] == "points":
        pts = np.array(path_doc["points_m"], dtype=float)
        if np.linalg.norm(pts[0] - feet[swing]) > 1e-6:
            raise InputError(src, f"{key}.path.points_m[0]",
                             f"must be the {swing} sole's current position {feet[swing].tolist()}")
        if "landing_m" in sd and np.linalg.norm(pts[-1] - np.array(sd["landing_m"])) > 1e-6:
            raise InputError(src, f"{key}.path.points_m", "last point differs from landing_m")
    else:
        if "landing_m" not in sd:
            raise InputError(src, f"{key}.landing_m", "missing")
        try:
            pts = arc_path(feet[swing], np.array(sd["landing_m"], dtype=float),
                           **{k: path_doc[k] for k in ("clearance_m", "samples", "lift_m", "descent_m")
                              if k in path_doc})
        except ValueError as exc:
            raise InputError(src, f"{key}.path.samples", str(exc)) from None
    landing = pts[-1]
    if not ground.holds(landing):
        raise InputError(src, f"{key}.landing_m", f"the landing sole at {np.round(landing, 4).tolist()} m does "
                         "not lie fully on a carton top")
    other = feet[other_side(swing)]
    if np.linalg.norm(landing[:2] - other[:2]) < ground.sole_w:
        raise InputError(src, f"{key}.landing_m", "the landing sole overlaps the support sole")
    span = 2 * (robot.leg_length_m + robot.hip_offset_m)  # both legs straight, hips side by side
    far = np.flatnonzero(np.linalg.norm(pts - other, axis=1) > span)
    if len(far):
        k = len(pts) - 1 if far[-1] == len(pts) - 1 else int(far[0])  # the landing first: that is what was typed
        raise InputError(src, f"{key}.{'landing_m' if k == len(pts) - 1 else 'path'}", "out of reach: the swing "
                         f"sole at {np.round(pts[k], 4).tolist()} m is {np.linalg.norm(pts[k] - other):.3f} m from "
                         f"the support sole; {robot.name}'s legs span at most {span:.3f} m (2 x (leg "
                         f"{robot.leg_length_m:g} m + hip offset {robot.hip_offset_m:g} m))")
    cartons = ground.cartons
    hit = first_collision(pts, 0.0, ground.sole_l, ground.sole_w, list(cartons)) if cartons else None
    if hit is not None:
        seg, pos, k = hit
        raise InputError(src, f"{key}.path", f"the swing sole enters carton {k} near {np.round(pos, 3).tolist()} m "
                         f"(between samples {seg} and {seg + 1}): the path cannot clear its edge; "
                         "raise clearance_m")
    return Step(swing, pts)


def _optimiser(opt: dict, robot, src: str) -> OptimiserConfig:
    """``optimiser:``: the method and its settings over the defaults; the fitness's constants (Paper A's)."""
    fit = dict(opt.get("fitness", {}))
    if "f3_unit" in fit:
        fit["f3_unit_m"] = F3_UNITS[fit.pop("f3_unit")]
    constants = fill_dataclass(FitnessConstants(weight_n=robot.mass_kg * GRAVITY), fit)
    base = OptimiserConfig()
    optimiser = fill_dataclass(base, {k: v for k, v in opt.items() if k in ("method", "bits")},
                      initial=fill_dataclass(base.initial, opt.get("initial", {})),
                      intermediate=fill_dataclass(base.intermediate, opt.get("intermediate", {})), constants=constants,
                      **{f"gaex_{k}": v for k, v in opt.get("gaex", {}).items()},
                      **{f"sqp_{k}": v for k, v in opt.get("sqp", {}).items()})
    if optimiser.gaex_step_m > optimiser.gaex_half_m:
        raise InputError(src, "optimiser.gaex.step_m", "larger than half_m")
    if optimiser.gaex_half_m / optimiser.gaex_step_m > 50:
        raise InputError(src, "optimiser.gaex", "more than 50 steps per half width (a cube of over 1 million postures "
                         "per sample)")
    return optimiser


def _balance(bal: dict, robot, src: str) -> BalanceConfig:
    """``balance:``: the thrust limit (by default the robot's largest fan, never above it), the policy and its
    tolerance, the sole margin (leaving a support polygon)."""
    fan_max = max((f.thrust_max_n for f in robot.fans), default=0.0)  # the limit caps every fan; by default none
    if bal.get("thrust_max_n", fan_max) > fan_max:
        raise InputError(src, "balance.thrust_max_n", f"{bal['thrust_max_n']:g} N is more than the robot's fans give "
                         f"({fan_max:g} N)")
    robust_doc = dict(bal.pop("robust", {}))
    min_share = robust_doc.pop("min_share", 0.0)
    robust = {TOLERANCE_KEYS[k]: v for k, v in robust_doc.items()}
    balance = fill_dataclass(BalanceConfig(thrust_max_n=fan_max), bal,
                             robust=fill_dataclass(BalanceConfig().robust, robust), min_share=min_share)
    sole_l, sole_w = robot.sole_length_m, robot.sole_width_m
    if balance.sole_margin_m >= min(sole_l, sole_w) / 2:
        raise InputError(src, "balance.sole_margin_m", f"leaves no support polygon (sole {sole_l} x {sole_w} m)")
    return balance


def _check_timing(timing: Timing, n_steps: int, yaw_mode: str, balance: BalanceConfig, src: str) -> None:
    """``timing:``: every phase at least :data:`MIN_PHASE_ROWS` rows, a fastest timing the planner can give, at
    most :data:`MAX_ROWS` rows in all."""
    for key, seconds in (("swing_s", timing.swing_s), ("transfer_s", timing.transfer_s)):
        if seconds * timing.rate_hz < MIN_PHASE_ROWS - 1e-9:
            raise InputError(src, f"timing.{key}", f"{seconds:g} s at rate_hz {timing.rate_hz:g} is "
                             f"{seconds * timing.rate_hz:.3g} rows: every phase needs at least {MIN_PHASE_ROWS} rows "
                             "(raise rate_hz or the duration)")
    if timing.fastest:
        check_fastest(timing, yaw_mode, balance, src)
    rows = (n_steps * (timing.swing_s + timing.transfer_s) + timing.transfer_s) * timing.rate_hz
    if rows > MAX_ROWS:
        raise InputError(src, "timing", f"the trajectory would have {rows:,.0f} rows; at most {MAX_ROWS:,} "
                         "(lower rate_hz or the durations)")


def plan_seconds(scenario: Scenario, method: str) -> float:
    """A low estimate of the time one plan of ``scenario`` takes with ``method`` on one core [s]: the GA family
    evaluates about population x generations candidates at a step's first sample (the initial phase) and at
    every other (the intermediate phase); sqp takes a near fixed time a sample."""
    samples = sum(len(st.path_m) for st in scenario.steps)
    if method not in ("gas", "ga", "gaex"):
        return samples * SQP_SAMPLE_S
    o = scenario.optimiser
    first = o.initial.population * o.initial.generations
    other = o.intermediate.population * o.intermediate.generations if method != "gaex" else \
        (2 * round(o.gaex_half_m / o.gaex_step_m) + 1) ** 3
    return (len(scenario.steps) * first + (samples - len(scenario.steps)) * other) * GA_EVALUATION_S


def check_plan_time(scenario: Scenario, methods: tuple[str, ...], plans: int = 1, workers: int = 1,
                    key: str = "optimiser", what: str = "", extra_s: float = 0.0) -> None:
    """Refuse, before it starts, a request of ``plans`` plans of ``scenario`` with each of ``methods`` on
    ``workers`` cores estimated (:func:`plan_seconds`, plus ``extra_s`` of other work) to take longer than
    :data:`MAX_ESTIMATED_S`.

    Raises:
        InputError: naming the scenario, ``key`` and the estimate.
    """
    seconds = (plans * sum(plan_seconds(scenario, m) for m in methods) + extra_s) / max(1, workers)
    if seconds > MAX_ESTIMATED_S:
        raise InputError(scenario.source, key, f"{what or 'the plan'} would take at least {_time_text(seconds)} on "
                         f"this machine ({'; '.join(methods)}); at most {_time_text(MAX_ESTIMATED_S)} is started: "
                         "fewer samples, a smaller population or fewer generations")


def _time_text(seconds: float) -> str:
    if seconds >= 86400:
        return f"{seconds / 86400:.3g} days"
    if seconds >= 3600:
        return f"{seconds / 3600:.3g} h"
    return f"{seconds / 60:.3g} min" if seconds >= 60 else f"{seconds:.3g} s"


def check_fastest(timing: Timing, yaw_mode: str, balance: BalanceConfig, src: str) -> None:
    """Refuse a fastest timing the planner cannot give: a yaw MPC (its schedule lays the rows out by the fixed
    law), a plan with no margin to spend (the minimal policy without ``balance.sole_margin_m``), floors above
    caps."""
    if yaw_mode == "mpc":
        raise InputError(src, "timing.mode", "fastest cannot be combined with body_yaw.mode mpc (its schedule is laid "
                         "out on the fixed timing's rows)")
    if balance.tolerance == NOMINAL and balance.sole_margin_m == 0:
        raise InputError(src, "timing.mode", "fastest needs a margin for the rows' motion to spend: the robust policy "
                         "or balance.sole_margin_m > 0 (a minimal plan's ZMP lies on the sole's edge)")
    for kind in ("swing", "transfer"):
        lo, hi = getattr(timing, f"min_{kind}_s"), getattr(timing, f"max_{kind}_s")
        if lo > hi:
            raise InputError(src, f"timing.min_{kind}_s", f"{lo:g} s is above timing.max_{kind}_s {hi:g} s")


def _check_overlaps(cartons: tuple[Carton, ...], src: str) -> None:
    """Refuse two cartons that share space (touching faces are fine: a stack, a row)."""
    lo = np.array([[c.top_centre_m[0] - c.size_m[0] / 2, c.top_centre_m[1] - c.size_m[1] / 2,
                    c.top_centre_m[2] - c.size_m[2]] for c in cartons]).reshape(-1, 3)
    hi = np.array([[c.top_centre_m[0] + c.size_m[0] / 2, c.top_centre_m[1] + c.size_m[1] / 2, c.top_centre_m[2]]
                   for c in cartons]).reshape(-1, 3)
    for k in range(1, len(cartons)):
        depth = np.minimum(hi[k], hi[:k]) - np.maximum(lo[k], lo[:k])  # (k, 3) overlap along each axis
        clash = np.flatnonzero(np.all(depth > 1e-9, axis=1))
        if len(clash):
            raise InputError(src, f"terrain.cartons[{k}]", f"overlaps carton {clash[0]} "
                             f"({1000 * float(np.min(depth[clash[0]])):.1f} mm deep): two cartons cannot share space")
