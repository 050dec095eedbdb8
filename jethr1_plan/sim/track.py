"""A written plan as the twin follows it (:class:`PlanTrack`, read by :func:`load_plan` from a plan folder or
made by :func:`track_of` from a plan's table in memory), and the model errors of one run
(:class:`Perturbation`): what the twin differs from the planner's model by.

Randomised trials (:meth:`Perturbation.draw`, or :meth:`Perturbation.draw_within` the plan's
tolerance) scale every link's mass and inertia, shift the CoM, scale the fans' thrust, change their
lag and the servos' stiffness, and draw the sensors' biases, offsets and delays
(:class:`~.sensors.SensorDraw`); :mod:`.certificate` turns their verdicts into a certificate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_table import fan_matrix, joint_matrix, stack
from jethr1_plan.folders.plan import read_plan
from jethr1_plan.geometry import SIDES
from jethr1_plan.io.input_file import input_folder
from jethr1_plan.records.plan_columns import PELVIS, PELVIS_QUAT, TOLERANCE_SHARE, WINDOW, ZMP
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.robot.sensors import Sensors
from jethr1_plan.sim.sensors import SensorDraw
from jethr1_plan.sim.twin import Twin
from jethr1_plan.swing_path import Carton

__all__ = ["Frame", "Perturbation", "PlanTrack", "held_tolerance", "load_plan", "moved", "plan_kinematics", "track_of"]


@dataclass(frozen=True)
class Perturbation:
    """Model errors of one run: what the twin differs from the planner's model by."""

    mass_scale: float = 1.0  # every link's mass and inertia × this
    com_offset_m: tuple[float, float] = (0.0, 0.0)  # the whole robot's CoM moved by this (x, y) [m]
    thrust_gain: float = 1.0  # every fan gives this × its command
    fan_lag_s: float = 0.05  # time constant of the fans' first-order lag [s]
    servo_stiffness_scale: float = 1.0  # every servo's stiffness and damping × this
    sensors: SensorDraw | None = None  # the run's sensor biases, offsets, delays and noise seed (None: nominal)

    @classmethod
    def draw(cls, rng: np.random.Generator, sensors: Sensors | None = None, n_joints: int = 0) -> Perturbation:
        """A randomised trial, the default (wider) randomisation: mass ±5 %, CoM within 5 mm, thrust
        gain 0.8..1.1, lag 30..80 ms, and servo stiffness 0.8..1.25 (log-uniform: the sag
        compensation then under- or overshoots). Uniform; the CoM offset uniform over the disc. With the
        robot's ``sensors``, then its sensors' errors (:meth:`SensorDraw.draw`)."""
        return cls._draw(rng, 0.05, 0.005, (0.8, 1.1), sensors, n_joints)

    @classmethod
    def draw_within(cls, rng: np.random.Generator, tolerance: dict, sensors: Sensors | None = None,
                    n_joints: int = 0) -> Perturbation:
        """A randomised trial inside a plan's ``tolerance`` (:func:`held_tolerance`): thrust gain
        uniform in 1 ± thrust_error, mass scale in 1 ± mass_error, the CoM offset uniform over the
        disc of radius com_error_m; lag, servo stiffness and the sensors as :meth:`draw` (the plan's
        tolerance does not cover them: the twin's own spread)."""
        x = float(tolerance["thrust_error"])
        return cls._draw(rng, float(tolerance["mass_error"]), float(tolerance["com_error_m"]), (1.0 - x, 1.0 + x),
                         sensors, n_joints)

    @classmethod
    def _draw(cls, rng: np.random.Generator, mass_error: float, com_m: float, gain: tuple[float, float],
              sensors: Sensors | None, n_joints: int) -> Perturbation:
        mass = float(rng.uniform(1.0 - mass_error, 1.0 + mass_error))
        r, a = com_m * math.sqrt(float(rng.uniform())), float(rng.uniform(0.0, 2 * math.pi))
        thrust = float(rng.uniform(*gain))
        lag = float(rng.uniform(0.03, 0.08))
        stiffness = float(math.exp(rng.uniform(math.log(0.8), math.log(1.25))))
        drawn = SensorDraw.draw(sensors, rng, n_joints) if sensors is not None else None
        return cls(mass, (r * math.cos(a), r * math.sin(a)), thrust, lag, stiffness, drawn)

    def inside(self, tolerance: dict) -> dict[str, bool]:
        """Whether this draw lies inside a plan's ``tolerance``, per model error and in all
        (``thrust``: |gain − 1| ≤ thrust_error, ``mass``: |scale − 1| ≤ mass_error, ``com``: offset ≤
        com_error_m; lag and stiffness are not part of a plan's tolerance)."""
        eps = 1e-12
        out = {"thrust": abs(self.thrust_gain - 1.0) <= float(tolerance["thrust_error"]) + eps,
               "mass": abs(self.mass_scale - 1.0) <= float(tolerance["mass_error"]) + eps,
               "com": math.hypot(*self.com_offset_m) <= float(tolerance["com_error_m"]) + eps}
        return {**out, "all": all(out.values())}


@dataclass
class PlanTrack:
    """A written plan as the rehearsal reads it (rows at ``rate_hz``; fans in the robot's order)."""

    folder: Path
    robot: RobotModel
    cartons: tuple[Carton, ...]
    rate_hz: float
    thrust_max_n: float
    thrust_error: float
    mass_error: float
    time_s: np.ndarray  # (N,)
    q: np.ndarray  # (N, 12) joint targets [rad]
    pelvis: np.ndarray  # (N, 7) position [m] and quaternion w, x, y, z
    thrust: np.ndarray  # (N, F) planned thrust per fan [N]
    window: np.ndarray  # (N, 2) thrust window of the row [N] (NaN: none)
    zmp: np.ndarray  # (N, 2) planned ZMP [m]
    support: np.ndarray  # (N,) 'left', 'right' or 'both'
    phase: np.ndarray  # (N,)
    step: np.ndarray  # (N,)
    sample: np.ndarray  # (N,)
    q_cmd: np.ndarray  # (N, 12) servo commands [rad] (the plan's <joint>_cmd_rad: sag compensated)
    thrust_cmd: np.ndarray  # (N, F) fan commands [N] (the plan's thrust_cmd_*: lag compensated)
    feet: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (N, 2, 3) planned sole centres [m]
    feet_yaw: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (N, 2) [rad]
    feet_rot: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (N, 2, 3, 3) planned sole orientations
    fans_m: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (N, F, 3) planned fan positions [m]
    trunk_rot: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (N, 3, 3) planned trunk orientations
    #: the tolerance the plan holds at every row: thrust_error, mass_error (fractions), com_error_m [m],
    #: and ``source`` (see :func:`held_tolerance`)
    tolerance: dict = field(default_factory=dict)
    #: the plan's files as summary.json records them (name → sha256, bytes), and summary.json's own SHA-256: what
    #: a rehearsal is of (``simulate`` writes them into simulation.json and commits only while they are the folder's)
    plan_files: dict = field(default_factory=dict)
    summary_sha256: str = ""

    def __len__(self) -> int:
        return len(self.time_s)

    def where(self, i: int) -> dict:
        return {"row": int(i), "time_s": float(self.time_s[i]), "step": int(self.step[i]),
                "phase": str(self.phase[i]), "sample": int(self.sample[i])}


def load_plan(folder: Path) -> PlanTrack:
    """Read a plan folder (``trajectory.csv`` + ``summary.json``, through
    :func:`~jethr1_plan.folders.plan.read_plan`) as the rehearsal follows it.

    Raises:
        InputError: a missing or unreadable file, a plan written infeasible, a robot that cannot load.
    """
    folder = Path(folder)
    input_folder(folder, "a plan folder (trajectory.csv, trajectory.mcap and summary.json)")
    plan = read_plan(folder, suffixes=(".csv",), strict=True, purpose="simulate rehearses a plan's folder")
    summary_path, csv_path = folder / "summary.json", folder / "trajectory.csv"
    summary = plan.summary or {}
    if summary.get("feasible") is not True:
        raise InputError(str(summary_path), "feasible", "the plan is not feasible: nothing to rehearse")
    try:
        rate = float(summary["trajectory"]["rate_hz"])
        thrust_max = float(summary["thrust_max_n"])
        tolerance = held_tolerance(summary)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(str(summary_path), "", f"malformed: {exc}".splitlines()[0]) from None
    track = track_of(plan.table, plan.robot, plan.cartons, rate, thrust_max, tolerance, folder)
    if len(track) < 2 or not np.all(np.isfinite(track.q)) or not np.all(np.isfinite(track.pelvis)):
        raise InputError(str(csv_path), "", "malformed trajectory: fewer than 2 rows or non-finite poses")
    track.plan_files, track.summary_sha256 = dict(summary.get("files") or {}), plan.summary_sha256
    return track


def track_of(c: dict[str, np.ndarray], robot: RobotModel, cartons: tuple[Carton, ...], rate_hz: float,
             thrust_max_n: float, tolerance: dict, folder: Path = Path(".")) -> PlanTrack:
    """A plan's table (the columns of ``trajectory.csv``, :func:`~jethr1_plan.files.plan_table.plan_table`) as
    the twin follows it; ``tolerance`` as :func:`held_tolerance` gives it."""
    q = joint_matrix(c, robot)
    pelvis = stack(c, (*PELVIS, PELVIS_QUAT[3], *PELVIS_QUAT[:3]))  # x, y, z, then the quaternion w, x, y, z
    track = PlanTrack(folder, robot, cartons, rate_hz, thrust_max_n, float(tolerance["thrust_error"]),
                      float(tolerance["mass_error"]), np.asarray(c["time_s"], dtype=float), q, pelvis,
                      fan_matrix(c, robot), stack(c, WINDOW),
                      stack(c, ZMP), np.asarray(c["support"]), np.asarray(c["phase"]),
                      np.asarray(c["step"]).astype(int), np.asarray(c["sample"]).astype(int),
                      joint_matrix(c, robot, "_cmd_rad"), fan_matrix(c, robot, "thrust_cmd_"))
    track.tolerance = dict(tolerance)
    return track


def held_tolerance(summary: dict) -> dict:
    """The model errors a plan's ``summary.json`` says it holds at every row: where its rows hold only a
    share of the scenario's tolerance, the tolerance at the least share
    (``robustness.tolerance_share.tolerance``); else ``balance.tolerance``; a plan with neither (or the
    minimal policy) holds none. Fractions of thrust and mass, the CoM error in metres."""
    shared = (summary.get("robustness") or {}).get(TOLERANCE_SHARE) or {}
    if shared.get("tolerance"):
        tol, source = shared["tolerance"], f"robustness.tolerance_share (least share {float(shared['least']):g})"
    else:
        tol, source = (summary.get("balance") or {}).get("tolerance") or {}, "balance.tolerance"
    out = {key: float(tol.get(key, 0.0)) for key in ("thrust_error", "mass_error", "com_error_m")}
    if not all(math.isfinite(v) and v >= 0 for v in out.values()):
        raise ValueError(f"tolerance {out} is not finite and non-negative")
    return {**out, "source": source}


def plan_kinematics(twin: Twin, track: PlanTrack) -> None:
    """The planned sole centres, yaws and orientations of every row (forward kinematics in the twin's model)."""
    import mujoco

    m = twin.model
    d = mujoco.MjData(m)
    n = len(track)
    feet = np.zeros((n, 2, 3))
    yaw = np.zeros((n, 2))
    rot = np.zeros((n, 2, 3, 3))
    fan_ids = [twin.fan_bodies[f.frame] for f in twin.robot.fans]
    fans = np.zeros((n, len(fan_ids), 3))
    trunk = np.zeros((n, 3, 3))
    for i in range(n):
        d.qpos[:7] = track.pelvis[i]
        d.qpos[twin.qpos_adr] = track.q[i]
        mujoco.mj_kinematics(m, d)
        for k, s in enumerate(SIDES):
            b = twin.foot_bodies[s]
            feet[i, k] = d.xpos[b]
            R = d.xmat[b].reshape(3, 3)
            rot[i, k] = R
            yaw[i, k] = math.atan2(R[1, 0], R[0, 0])
        for k, b in enumerate(fan_ids):
            fans[i, k] = d.xpos[b]
        trunk[i] = d.xmat[twin.trunk].reshape(3, 3)
    track.feet, track.feet_yaw, track.feet_rot, track.fans_m, track.trunk_rot = feet, yaw, rot, fans, trunk




@dataclass(frozen=True)
class Frame:
    """A rigid motion of the plane carried to 3-D: a turn by ``yaw_rad`` about the vertical through the
    origin, then a shift by ``shift_m``: p ↦ R_z(yaw)·p + shift."""

    yaw_rad: float = 0.0
    shift_m: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def rotation(self) -> np.ndarray:
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def point(self, p: np.ndarray) -> np.ndarray:
        """Points (..., 3) [m] moved."""
        return np.asarray(p, dtype=float) @ self.rotation.T + np.asarray(self.shift_m)

    @classmethod
    def mapping(cls, a_xyz: np.ndarray, a_yaw: float, b_xyz: np.ndarray, b_yaw: float) -> Frame:
        """The motion that takes a pose (position, yaw) ``a`` to ``b``."""
        yaw = b_yaw - a_yaw
        c, s = math.cos(yaw), math.sin(yaw)
        a = np.asarray(a_xyz, dtype=float)
        turned = np.array([c * a[0] - s * a[1], s * a[0] + c * a[1], a[2]])
        x, y, z = (float(v) for v in np.asarray(b_xyz, dtype=float) - turned)
        return cls(float(yaw), (x, y, z))


def moved(track: PlanTrack, frame: Frame) -> PlanTrack:
    """``track`` with its world poses (the trunk, the soles, the fans, the ZMP) moved by ``frame``; its
    joints, thrusts and commands unchanged (they do not depend on where the robot stands)."""
    if frame == Frame():
        return track
    R = frame.rotation
    half = frame.yaw_rad / 2
    qz = np.array([math.cos(half), 0.0, 0.0, math.sin(half)])  # w, x, y, z
    quat = track.pelvis[:, 3:7]
    w1, z1 = qz[0], qz[3]
    w2, x2, y2, z2 = quat.T
    turned = np.column_stack([w1 * w2 - z1 * z2, w1 * x2 - z1 * y2, w1 * y2 + z1 * x2, w1 * z2 + z1 * w2])
    pelvis = np.column_stack([frame.point(track.pelvis[:, :3]), turned])
    zmp = track.zmp @ R[:2, :2].T + np.asarray(frame.shift_m[:2])
    return replace(track, pelvis=pelvis, zmp=zmp, feet=frame.point(track.feet),
                   feet_yaw=track.feet_yaw + frame.yaw_rad, feet_rot=np.einsum("ij,nkjl->nkil", R, track.feet_rot),
                   fans_m=frame.point(track.fans_m), trunk_rot=np.einsum("ij,njl->nil", R, track.trunk_rot))
