"""A written plan rehearsed in the twin (``jethr1 simulate``).

The plan is read from its folder only (``trajectory.csv`` and ``summary.json``): the servos follow
the joint columns (linear between rows), the fans get the thrust columns as feed-forward, through a
first-order lag, optionally corrected by the robot's feedback law (:mod:`jethr1_plan.control.feedback`:
the IMU law of :mod:`~jethr1_plan.control.imu_thrust` or the CoP law of
:mod:`~jethr1_plan.control.thrust_feedback`, whichever the robot's sensors allow), which reads only the
robot's declared sensors (:mod:`.sensors`). The robot starts in the first row's posture and settles for
``SETTLE_S`` before the plan's clock starts; it holds the last row for ``HOLD_S`` after it ends. The
run itself, its verdict and its measurements: :mod:`.run`; the plan as the twin follows it and the
model errors of a run: :mod:`.track`.
"""

from __future__ import annotations

from pathlib import Path

from jethr1_plan.control import thrust_feedback as ctl
from jethr1_plan.control.imu_thrust import ImuGains
from jethr1_plan.control.swing_placement import PlacementGains
from jethr1_plan.sim.judge import FALL_DROP_M, FALL_TILT_DEG, RunResult
from jethr1_plan.sim.run import HOLD_S, SETTLE_S, TwinRun, law_of
from jethr1_plan.sim.track import Perturbation, PlanTrack, held_tolerance, load_plan, plan_kinematics
from jethr1_plan.sim.twin import TwinParams

__all__ = ["FALL_DROP_M", "FALL_TILT_DEG", "Perturbation", "PlanTrack", "RunResult", "held_tolerance", "load_plan",
           "rehearse", "simulate"]

_plan_kinematics = plan_kinematics


def rehearse(track: PlanTrack, controller: str = "feedforward", perturbation: Perturbation | None = None,
             gains: ctl.Gains | None = None, record: bool = False, params: TwinParams | None = None,
             compensate: bool = True, placement: PlacementGains | None = None, imu_gains: ImuGains | None = None,
             seed: int = 0) -> RunResult:
    """Run ``track`` in a fresh twin with ``controller``: ``feedforward`` (the plan's commands), ``feedback``
    (the robot's own thrust law, ``RobotModel.feedback_law``) or a law by name (``imu_tilt_pid``,
    ``cop_edge_pi``); :class:`~.run.TwinRun` following the whole plan.

    With ``compensate`` the servos follow the plan's command columns (``<joint>_cmd_rad``: the
    posture plus the sag of the servos under the row's static torque) and the fans its
    ``thrust_cmd_*`` columns (the thrust led by the fans' lag) (:mod:`jethr1_plan.control.commands`), and
    the feedback's extra thrust moves the swing leg's commands by J_fanᵀ·ΔF/k as the robot would;
    without it the servos follow the joint columns and the fans the thrust columns.

    A feedback controller also places the swing sole (:mod:`jethr1_plan.control.swing_placement`, gains
    ``placement``) where the robot has an IMU: in single support the yaw the support sole has slipped by
    (the IMU's attitude through the encoders' kinematics) turns the swing leg's commands back about the
    support sole, so that the landing stays where the plan puts it in the world; the offset is held
    after the landing, until that leg supports the next swing.

    Raises:
        InputError: a feedback controller on a robot without the sensors of a law.
    """
    run = TwinRun(track.robot, track.cartons, track.thrust_max_n, controller, perturbation, gains, imu_gains,
                  placement, compensate, seed, params, record)
    run.follow(track, settle_s=SETTLE_S, hold_s=HOLD_S)
    return run.result()


def _run_one(folder: str, controller: str, perturbation: Perturbation, record: bool, compensate: bool, seed: int
             ) -> RunResult:
    return rehearse(load_plan(Path(folder)), controller, perturbation, record=record, compensate=compensate,
                    seed=seed)


def simulate(folder: Path, controller: str, perturbations: list[Perturbation], jobs: int = 1,
             progress=None, compensate: bool = True, track: PlanTrack | None = None, seed: int = 0
             ) -> list[RunResult]:
    """Every perturbation's run of the plan in ``folder`` (the first one recorded), in order; the
    results do not depend on ``jobs``. ``track``: the folder's plan if the caller has read it already;
    ``seed``: the sensors' noise of a run whose perturbation draws none.

    Raises:
        InputError: a feedback controller on a robot without the sensors of its law.
    """
    if track is None:
        track = load_plan(folder)  # bad input fails here, before any worker starts
    law_of(track.robot, controller)
    if jobs <= 1 or len(perturbations) == 1:
        out = []
        for k, p in enumerate(perturbations):
            out.append(rehearse(track, controller, p, record=k == 0, compensate=compensate, seed=seed))
            if progress:
                progress(f"run {k + 1}", k + 1, len(perturbations))
        return out
    from joblib import delayed

    from jethr1_plan.io.pool import parallel

    out = []
    tasks = [delayed(_run_one)(str(folder), controller, p, k == 0, compensate, seed)
             for k, p in enumerate(perturbations)]
    for k, r in enumerate(parallel(jobs, return_as="generator")(tasks)):
        out.append(r)
        if progress:
            progress(f"run {k + 1}", k + 1, len(perturbations))
    return out
