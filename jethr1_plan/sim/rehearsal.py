"""A written plan rehearsed in the twin (``jethr1 simulate``).

The plan is read from its folder only (``trajectory.csv`` and ``summary.json``): the servos follow
the joint columns (linear between rows), the fans get the thrust columns as feed-forward, through a
first-order lag, optionally corrected by the plan's feedback law
(:mod:`jethr1_plan.control.thrust_feedback`). The robot
starts in the first row's posture and settles for ``SETTLE_S`` before the plan's clock starts; it
holds the last row for ``HOLD_S`` after it ends.

A run **falls** when the trunk tilts more than ``FALL_TILT_DEG`` from level or the pelvis drops more
than ``FALL_DROP_M`` below the plan; it **succeeds** when it does not fall and both soles end on
carton tops (on the ground where the scenario has no cartons). Measured along the way: the largest
trunk tilt, the support soles' largest tilt and slip (against where the plan puts them), the least
margin of the measured centre of pressure inside the support sole, each landing's error (the swing
sole at the end of the transfer that follows it, against the plan), the largest thrust.

Randomised trials (:meth:`Perturbation.draw`, or :meth:`Perturbation.draw_within` the plan's
tolerance) scale every link's mass and inertia, shift the CoM, scale the fans' thrust, change their
lag and the servos' stiffness; :mod:`.certificate` turns their verdicts into a certificate.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from jethr1_plan.control import thrust_feedback as ctl
from jethr1_plan.control.feedback import UNLOADED, Controller
from jethr1_plan.control.imu_thrust import ImuGains
from jethr1_plan.control.measurement import Measurement, Reference
from jethr1_plan.control.swing_placement import PlacementGains, yaw_of
from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_folder import read_plan
from jethr1_plan.files.plan_table import fan_matrix, joint_matrix, stack
from jethr1_plan.geometry import GRAVITY, SIDES, other_side, polygon_margin, sole_polygon
from jethr1_plan.robot.model import LAW_SENSORS, RobotModel, Sensors
from jethr1_plan.sim.sensors import OwnKinematics, SensorDraw, SensorModel
from jethr1_plan.sim.twin import Twin, TwinParams, build_twin
from jethr1_plan.swing_path import Carton, sole_on_carton

__all__ = ["FALL_DROP_M", "FALL_TILT_DEG", "Perturbation", "PlanTrack", "RunResult", "held_tolerance", "load_plan",
           "rehearse"]

SETTLE_S = 0.5  # the first posture is held this long before the plan's clock starts [s]
HOLD_S = 1.0  # the last posture is held this long after the plan ends [s]
FALL_TILT_DEG = 10.0  # a trunk tilted more than this from level has fallen [deg]
FALL_DROP_M = 0.10  # a pelvis this far below the plan has fallen [m]
ON_TOP_TOL_M = 0.005  # a sole within this of a carton's top (height) stands on it [m]
RECORD_HZ = 50.0  # rate of the recorded states (simulation.mcap) [Hz]


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

    def __len__(self) -> int:
        return len(self.time_s)

    def where(self, i: int) -> dict:
        return {"row": int(i), "time_s": float(self.time_s[i]), "step": int(self.step[i]),
                "phase": str(self.phase[i]), "sample": int(self.sample[i])}


def load_plan(folder: Path) -> PlanTrack:
    """Read a plan folder (``trajectory.csv`` + ``summary.json``, through
    :func:`~jethr1_plan.files.plan_folder.read_plan`) as the rehearsal follows it.

    Raises:
        InputError: a missing or unreadable file, a plan written infeasible, a robot that cannot load.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(str(folder), "", "not a plan folder (expected trajectory.csv and summary.json in it)")
    plan = read_plan(folder, suffixes=(".csv",), strict=True, purpose="simulate rehearses a plan's folder")
    summary_path, csv_path = folder / "summary.json", folder / "trajectory.csv"
    summary = plan.summary or {}
    if summary.get("feasible") is not True:
        raise InputError(str(summary_path), "feasible", "the plan is not feasible: nothing to rehearse")
    robot, c = plan.robot, plan.table
    try:
        tol = summary.get("balance", {}).get("tolerance", {})
        rate = float(summary["trajectory"]["rate_hz"])
        thrust_max = float(summary["thrust_max_n"])
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(str(summary_path), "", f"malformed: {exc}".splitlines()[0]) from None
    q = joint_matrix(c, robot)
    pelvis = stack(c, ("pelvis_x_m", "pelvis_y_m", "pelvis_z_m", "pelvis_qw", "pelvis_qx", "pelvis_qy", "pelvis_qz"))
    track = PlanTrack(folder, robot, plan.cartons, rate, thrust_max, float(tol.get("thrust_error", 0.0)),
                      float(tol.get("mass_error", 0.0)), c["time_s"], q, pelvis, fan_matrix(c, robot),
                      stack(c, ("thrust_window_lo_n", "thrust_window_hi_n")), stack(c, ("zmp_x_m", "zmp_y_m")),
                      c["support"], c["phase"], c["step"].astype(int), c["sample"].astype(int),
                      joint_matrix(c, robot, "_cmd_rad"), fan_matrix(c, robot, "thrust_cmd_"))
    if len(track) < 2 or not np.all(np.isfinite(q)) or not np.all(np.isfinite(pelvis)):
        raise InputError(str(csv_path), "", "malformed trajectory: fewer than 2 rows or non-finite poses")
    try:
        track.tolerance = held_tolerance(summary)
    except (TypeError, ValueError, AttributeError) as exc:
        raise InputError(str(summary_path), "balance.tolerance", f"malformed: {exc}".splitlines()[0]) from None
    return track


def held_tolerance(summary: dict) -> dict:
    """The model errors a plan's ``summary.json`` says it holds at every row: where its rows hold only a
    share of the scenario's tolerance, the tolerance at the least share
    (``robustness.tolerance_share.tolerance``); else ``balance.tolerance``; a plan with neither (or the
    minimal policy) holds none. Fractions of thrust and mass, the CoM error in metres."""
    shared = (summary.get("robustness") or {}).get("tolerance_share") or {}
    if shared.get("tolerance"):
        tol, source = shared["tolerance"], f"robustness.tolerance_share (least share {float(shared['least']):g})"
    else:
        tol, source = (summary.get("balance") or {}).get("tolerance") or {}, "balance.tolerance"
    out = {key: float(tol.get(key, 0.0)) for key in ("thrust_error", "mass_error", "com_error_m")}
    if not all(math.isfinite(v) and v >= 0 for v in out.values()):
        raise ValueError(f"tolerance {out} is not finite and non-negative")
    return {**out, "source": source}


def _plan_kinematics(twin: Twin, track: PlanTrack) -> None:
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


@dataclass
class RunResult:
    """One run's verdict and measurements (SI units, angles in degrees where named so)."""

    controller: str
    compensated: bool  # the plan's sag and lag compensation in the feed-forward
    perturbation: dict
    survived: bool
    fell: dict | None
    max_trunk_tilt_deg: float
    support_max_tilt_deg: float
    support_max_slip_m: float
    least_cop_margin_m: float | None
    least_cop_margin_at: dict | None
    landing_errors_m: list[dict]
    soles_on_cartons_at_end: dict[str, bool]
    max_thrust_n: float
    simulated_s: float
    wall_s: float
    record: dict | None = None
    law: str | None = None  # the thrust law the controller ran (None: feed-forward)
    steps: list[dict] = field(default_factory=list)  # per swing: support slip and turn, the landing error's parts

    def as_dict(self) -> dict:
        out = asdict(self)
        out.pop("record")
        return out


def _apply(twin: Twin, p: Perturbation) -> None:
    m = twin.model
    if p.servo_stiffness_scale != 1.0:  # position actuators: gain kp, bias (0, −kp, −kv)
        m.actuator_gainprm[:, 0] *= p.servo_stiffness_scale
        m.actuator_biasprm[:, 1:3] *= p.servo_stiffness_scale
    if p.mass_scale != 1.0:
        m.body_mass[:] *= p.mass_scale
        m.body_inertia[:] *= p.mass_scale
    if any(p.com_offset_m):
        total = float(m.body_mass.sum())
        m.body_ipos[twin.trunk, :2] += np.asarray(p.com_offset_m) * total / m.body_mass[twin.trunk]


def _sole_loads(twin: Twin, d, buf: np.ndarray) -> dict[str, tuple[float, np.ndarray]]:
    """Per sole: the normal force [N] of its contacts and their centre of pressure (x, y, z) [m]
    (the sole's centre where it carries nothing)."""
    import mujoco

    force = {s: 0.0 for s in twin.sole_geoms}  # [N]
    moment = {s: np.zeros(3) for s in twin.sole_geoms}  # Σ force · contact point [N·m]
    by_geom = {g: s for s, g in twin.sole_geoms.items()}
    for ci in range(d.ncon):
        con = d.contact[ci]
        side = by_geom.get(con.geom1, by_geom.get(con.geom2))
        if side is not None:
            mujoco.mj_contactForce(twin.model, d, ci, buf)
            z = abs(float(con.frame[2::3] @ buf[:3]))  # the world z component of the contact force
            force[side] += z
            moment[side] = moment[side] + z * con.pos
    return {s: (f, moment[s] / f if f > 1e-9 else d.xpos[twin.foot_bodies[s]].copy()) for s, f in force.items()}


def _law_of(robot: RobotModel, controller: str) -> str | None:
    """The thrust law a ``controller`` runs: None (feed-forward), the robot's own (``feedback``), or a named
    law (``imu_tilt_pid``, ``cop_edge_pi``).

    Raises:
        InputError: the robot declares no sensors a feedback law could read, or not those the named law needs.
    """
    if controller == "feedforward":
        return None
    law = robot.feedback_law if controller == "feedback" else controller
    if law is None:
        raise InputError(str(robot.yaml_path), "sensors", "the robot declares no sensors a feedback law reads "
                         "(an IMU and encoders, or sole force sensors and encoders): only feed-forward runs")
    missing = [n for n in LAW_SENSORS[law] if n not in robot.sensors.names]
    if missing:
        raise InputError(str(robot.yaml_path), "sensors", f"{law} reads the {' and '.join(missing)}, which the "
                         f"robot does not declare (it has: {', '.join(robot.sensors.names) or 'none'})")
    return law


class _StepJudge:
    """Per swing, from the twin's truth (the judge's, never a controller's): the support sole's slip and
    turn over the swing, and the landing error (the swing sole at the end of the transfer after it, against
    the plan) in parts that add up to it:

    * ``inherited``: where the landing would be had the support sole not moved during the swing and the
      legs held the planned relative pose: the support sole's error at the swing's start, carried over;
    * ``support_slip``: the support sole's slip and turn during the swing, carried to the landing;
    * ``servo_sag``: the legs' joints off the plan at touchdown (the servos' sag beyond the plan's
      compensation, their tracking lag), less the thrust part;
    * ``thrust``: the swing leg's deflection under the thrust's deviation from the plan at touchdown
      (J_solẹ·k⁻¹·J_fanᵀ·ΔF, the nominal stiffness scaled by the run's);
    * ``touchdown``: the plan's own swing sole not yet at (or past) its landing when the sole touched;
    * ``slide``: the landed sole's motion from touchdown to the end of the transfer.

    Touchdown: the first tick after the swing's middle with the swing sole carrying over 2 N (in the
    transfer, where it never did during the swing)."""

    TOUCH_N = 2.0  # a sole carrying this has touched down [N]

    def __init__(self, twin: Twin, track: PlanTrack, stiffness_scale: float) -> None:
        self.twin, self.track = twin, track
        self.k = twin.robot.servo_stiffness_nm_per_rad * stiffness_scale
        self.swings: dict[int, dict] = {}
        for st in np.unique(track.step[track.phase == "swing"]):
            rows = np.flatnonzero((track.phase == "swing") & (track.step == st))
            sup = str(track.support[rows[0]])
            self.swings[int(st)] = {"first": int(rows[0]), "last": int(rows[-1]), "support": sup,
                                    "swing": other_side(sup)}
        self.judge = {step: row for row, step, _ in _landing_rows(track)}
        self.current: dict | None = None
        self.done: list[dict] = []
        self.jacp = np.zeros((3, twin.model.nv))
        self.jacr = np.zeros((3, twin.model.nv))

    def _pose(self, d, side: str) -> tuple[np.ndarray, np.ndarray]:
        b = self.twin.foot_bodies[side]
        return d.xpos[b].copy(), d.xmat[b].reshape(3, 3).copy()

    def tick(self, d, i: int, t: float, loads: dict, applied: np.ndarray) -> None:
        """After a physics step at plan row ``i`` (time ``t`` [s]): ``loads`` the soles' true normal forces,
        ``applied`` the fans' true thrust."""
        track = self.track
        step = int(track.step[i])
        cur = self.current
        if cur is None and track.phase[i] == "swing" and step in self.swings:
            info = self.swings[step]
            sup = info["support"]
            si, wi = SIDES.index(sup), SIDES.index(info["swing"])
            landing = track.feet[info["last"], wi]
            r_plan = _yaw_rotation(float(track.feet_yaw[info["first"], si]))
            p0, r0 = self._pose(d, sup)
            cur = self.current = {**info, "step": step, "landing": landing,
                                  "land_rel": r_plan.T @ (landing - track.feet[info["first"], si]),
                                  "p0": p0, "r0": r0, "touch": None, "swing_end": None}
            return
        if cur is None:
            return
        sup, sw = cur["support"], cur["swing"]
        if cur["swing_end"] is None and (track.phase[i] != "swing" or int(track.step[i]) != cur["step"]):
            p, r = self._pose(d, sup)
            cur["swing_end"] = (p, r)
        if cur["touch"] is None and i > (cur["first"] + cur["last"]) / 2 and loads[sw] > self.TOUCH_N:
            cur["touch"] = self._touchdown(d, i, applied)
        judge = self.judge.get(cur["step"])
        if judge is not None and t >= track.time_s[judge] - 1e-9:
            self._finish(d)

    def _touchdown(self, d, i: int, applied: np.ndarray) -> dict:
        import mujoco

        track, cur, twin = self.track, self.current, self.twin
        assert cur is not None
        sup, sw = cur["support"], cur["swing"]
        si, wi = SIDES.index(sup), SIDES.index(sw)
        p, r = self._pose(d, sup)
        pw, _ = self._pose(d, sw)
        land_rel, landing = cur["land_rel"], cur["landing"]
        r_plan = _yaw_rotation(float(track.feet_yaw[i, si]))
        rel_plan = r_plan.T @ (track.feet[i, wi] - track.feet[i, si])
        rel = r.T @ (pw - p)
        # the swing leg's deflection under the thrust's deviation from the plan (the swing sole's fans)
        fans = [k for k, f in enumerate(twin.robot.fans) if f.leg == sw]
        leg = np.array(twin.robot.legs[sw].index)
        dq = np.zeros(len(self.k))
        for k in fans:
            body = twin.fan_bodies[twin.robot.fans[k].frame]
            mujoco.mj_jac(twin.model, d, self.jacp, None, d.xpos[body], body)
            dq += self.jacp[2, twin.dof_adr] * (float(applied[k]) - float(track.thrust[i, k])) / self.k
        mujoco.mj_jacBody(twin.model, d, self.jacp, self.jacr, twin.foot_bodies[sw])
        thrust_part = self.jacp[:, twin.dof_adr[leg]] @ dq[leg]
        servo = r @ (rel - rel_plan)
        return {"row": i, "time_s": float(track.time_s[i]), "world": (pw - landing)[:2],
                "inherited": (cur["p0"] + cur["r0"] @ land_rel - landing)[:2],
                "support_slip": (p + r @ land_rel - cur["p0"] - cur["r0"] @ land_rel)[:2],
                "servo_sag": (servo - thrust_part)[:2], "thrust": thrust_part[:2],
                "touchdown": (r @ (rel_plan - land_rel))[:2]}

    def _finish(self, d) -> None:
        cur = self.current
        assert cur is not None
        sup, sw = cur["support"], cur["swing"]
        pw, _ = self._pose(d, sw)
        end, r_end = cur["swing_end"] or self._pose(d, sup)
        slip = (end - cur["p0"])[:2]
        err = (pw - cur["landing"])[:2]
        rec = {"step": cur["step"], "swing": sw, "support": sup,
               "support_slip_m": float(np.hypot(*slip)), "support_slip_xy_m": [float(v) for v in slip],
               "support_turn_rad": float(yaw_of(r_end) - yaw_of(cur["r0"])),
               "landing_error_m": float(np.hypot(*err)), "landing_error_xy_m": [float(v) for v in err],
               "touchdown": None, "parts_xy_m": None}
        touch = cur["touch"]
        if touch is not None:
            rec["touchdown"] = {"row": touch["row"], "time_s": touch["time_s"]}
            parts = {k: touch[k] for k in ("inherited", "support_slip", "servo_sag", "thrust", "touchdown")}
            parts["slide"] = err - touch["world"]
            rec["parts_xy_m"] = {k: [float(v[0]), float(v[1])] for k, v in parts.items()}
        self.done.append(rec)
        self.current = None


def _yaw_rotation(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rehearse(track: PlanTrack, controller: str = "feedforward", perturbation: Perturbation | None = None,
             gains: ctl.Gains | None = None, record: bool = False, params: TwinParams | None = None,
             compensate: bool = True, placement: PlacementGains | None = None, imu_gains: ImuGains | None = None,
             seed: int = 0) -> RunResult:
    """Run ``track`` in a fresh twin with ``controller``: ``feedforward`` (the plan's commands), ``feedback``
    (the robot's own thrust law, ``RobotModel.feedback_law``) or a law by name (``imu_tilt_pid``,
    ``cop_edge_pi``).

    The controller (:class:`~jethr1_plan.control.feedback.Controller`) sees the robot only through its
    declared sensors (:class:`~.sensors.SensorModel`: noise, bias and delay, the run's
    :class:`~.sensors.SensorDraw` from ``perturbation.sensors``, else nominal with the noise seeded by
    ``seed``) and its own kinematic model (:class:`~.sensors.OwnKinematics`); the verdict and the
    measurements are the twin's truth.

    With ``compensate`` the servos follow the plan's command columns (``<joint>_cmd_rad``: the
    posture plus the sag of the servos under the row's static torque) and the fans its
    ``thrust_cmd_*`` columns (the thrust led by the fans' lag) (:mod:`jethr1_plan.control.commands`), and
    the feedback's extra thrust moves the swing leg's commands by J_fanᵀ·ΔF/k as the robot would;
    without it the servos follow the joint columns and the fans the thrust columns.

    A feedback controller also places the swing sole (:mod:`jethr1_plan.control.swing_placement`, gains
    ``placement``) where the robot has an IMU: in single support the yaw the support sole has slipped by
    (the IMU's attitude through the encoders' kinematics) turns the swing leg's commands back about the
    support sole, so that the landing stays where the plan puts it in the world; the offset is held
    after the landing.

    Raises:
        InputError: ``feedback`` on a robot without the sensors of a law.
    """
    import mujoco

    p = perturbation or Perturbation()
    robot = track.robot
    law = _law_of(robot, controller)
    gains = gains or ctl.Gains.of(robot)
    imu_gains = imu_gains or ImuGains.of(robot)
    twin = build_twin(robot, track.cartons, params)
    if not len(track.feet) or not len(track.feet_rot) or not len(track.fans_m):
        _plan_kinematics(twin, track)
    _apply(twin, p)
    m = twin.model
    d = mujoco.MjData(m)
    d.qpos[:7] = track.pelvis[0]
    d.qpos[twin.qpos_adr] = track.q[0]
    mujoco.mj_forward(m, d)
    target = track.q_cmd if compensate else track.q
    thrust_ff = track.thrust_cmd if compensate else track.thrust
    rate = imu_gains.rate_hz if law == "imu_tilt_pid" else gains.rate_hz
    dt_c = 1.0 / rate
    nsub = max(1, round(dt_c / m.opt.timestep))
    dt_c = nsub * m.opt.timestep
    fans = robot.fans
    fan_ids = [twin.fan_bodies[f.frame] for f in fans]
    side_index = {s: k for k, s in enumerate(SIDES)}
    applied = np.zeros(len(fans))
    sensors = SensorModel(twin, robot.sensors, p.sensors or SensorDraw(noise_seed=seed), dt_c)
    loop = Controller(robot, OwnKinematics(robot) if law is not None else None, law, track.thrust_max_n, gains,
                      imu_gains, placement, compensate)
    judge_steps = _StepJudge(twin, track, p.servo_stiffness_scale)
    buf = np.zeros(6)
    n_rows = len(track)
    duration = float(track.time_s[-1])
    n_settle, n_plan, n_hold = round(SETTLE_S / dt_c), round(duration / dt_c) + 1, round(HOLD_S / dt_c)
    record_every = max(1, round(1.0 / (RECORD_HZ * dt_c)))
    rec: dict[str, list] | None = {"t": [], "qpos": [], "thrust": [], "cop": [], "com": []} if record else None
    max_tilt = sup_tilt = sup_slip = max_thrust = 0.0
    least_margin, least_at = math.inf, None
    fell = None
    landing: list[dict] = []
    judge = _landing_rows(track)
    weight = GRAVITY * float(m.body_mass.sum())
    nothing = Measurement(0.0, None, None, None, None)
    wall0 = time.perf_counter()
    k_end = n_settle + n_plan + n_hold
    t = 0.0
    for k in range(k_end):
        t = (k - n_settle) * dt_c
        if k < n_settle:
            i, a = 0, 0.0
        else:
            x = min(max(t * track.rate_hz, 0.0), n_rows - 1.0)
            i = min(int(x), n_rows - 2)
            a = x - i
        j = i + 1
        active = k >= n_settle
        sup = track.support[i]
        ref = Reference(t, sup, (1 - a) * target[i] + a * target[j],
                        ((1 - a) * thrust_ff[i] + a * thrust_ff[j]) if active else np.zeros(len(fans)),
                        track.trunk_rot[i], track.feet[i], track.feet_yaw[i], track.fans_m[i], active)
        cmd = loop.step(sensors.read(d, t) if law is not None else nothing, ref)
        d.ctrl[:] = cmd.q
        loads = _sole_loads(twin, d, buf)
        total = sum(f for f, _ in loads.values())
        cop = np.asarray(sum(f * c for f, c in loads.values()) / total) if total > 1e-9 else None
        # single support as the twin measures it: the swing sole carries (next to) nothing
        alone = sup != "both" and loads[sup][0] > 0.2 * weight and loads[other_side(sup)][0] < UNLOADED * weight
        if alone:
            poly = sole_polygon(track.feet[i, side_index[sup], :2], track.feet_yaw[i, side_index[sup]],
                                robot.sole_length_m, robot.sole_width_m)
            margin = float(polygon_margin(loads[sup][1][:2], poly))
            if margin < least_margin:
                least_margin, least_at = margin, track.where(i)
        applied += (p.thrust_gain * cmd.thrust - applied) * (dt_c / p.fan_lag_s)
        max_thrust = max(max_thrust, float(cmd.thrust.max(initial=0.0)))
        d.xfrc_applied[:] = 0.0
        for f_idx, body in enumerate(fan_ids):
            fz = float(applied[f_idx])
            d.xfrc_applied[body, :3] = (0.0, 0.0, fz)
            # the moment about the body's CoM of the vertical force at its origin: r × (0, 0, fz), written out as
            # np.cross computes it (the same floats, without its per-call cost)
            rx, ry, rz = (d.xpos[body] - d.xipos[body]).tolist()
            d.xfrc_applied[body, 3:] = (ry * fz - rz * 0.0, rz * 0.0 - rx * fz, rx * 0.0 - ry * 0.0)
        mujoco.mj_step(m, d, nsub)
        # measurements
        R = d.xmat[twin.trunk]
        tilt = math.degrees(math.acos(min(1.0, max(-1.0, R[8]))))
        max_tilt = max(max_tilt, tilt)
        for s in (SIDES if sup == "both" else (sup,)):
            b = twin.foot_bodies[s]
            sup_tilt = max(sup_tilt, math.degrees(math.acos(min(1.0, max(-1.0, d.xmat[b][8])))))
            sup_slip = max(sup_slip, float(np.hypot(*(d.xpos[b][:2] - track.feet[i, side_index[s], :2]))))
        z_plan = (1 - a) * track.pelvis[i, 2] + a * track.pelvis[j, 2]
        if fell is None and (tilt > FALL_TILT_DEG or d.qpos[2] < z_plan - FALL_DROP_M):
            reason = (f"trunk tilted {tilt:.1f} deg" if tilt > FALL_TILT_DEG
                      else f"pelvis {z_plan - d.qpos[2]:.3f} m below the plan")
            fell = {**track.where(i), "reason": reason}
            break
        if active:
            judge_steps.tick(d, i, t, {s: f for s, (f, _) in loads.items()}, applied)
        while judge and active and t >= track.time_s[judge[0][0]] - 1e-9:
            row, step, sole = judge.pop(0)
            err = d.xpos[twin.foot_bodies[sole]] - track.feet[row, side_index[sole]]
            landing.append({"step": step, "sole": sole, "xy_m": float(np.hypot(err[0], err[1])),
                            "z_m": float(err[2])})
        if rec is not None and active and (k - n_settle) % record_every == 0:
            rec["t"].append(t)
            rec["qpos"].append(d.qpos[:7].tolist() + d.qpos[twin.qpos_adr].tolist())
            rec["thrust"].append(applied.tolist())
            rec["cop"].append(None if cop is None else cop.tolist())
            rec["com"].append(d.subtree_com[twin.trunk].tolist())
    wall = time.perf_counter() - wall0
    on_top = {s: _on_cartons(track, d.xpos[twin.foot_bodies[s]], d.xmat[twin.foot_bodies[s]]) for s in SIDES}
    if rec is not None:
        rec["steps"] = judge_steps.done
    return RunResult(
        controller=controller, compensated=compensate, perturbation=asdict(p),
        survived=fell is None and all(on_top.values()), fell=fell,
        max_trunk_tilt_deg=max_tilt, support_max_tilt_deg=sup_tilt, support_max_slip_m=sup_slip,
        least_cop_margin_m=None if math.isinf(least_margin) else least_margin, least_cop_margin_at=least_at,
        landing_errors_m=landing,
        soles_on_cartons_at_end=on_top, max_thrust_n=max_thrust, simulated_s=max(t, 0.0) + SETTLE_S,
        wall_s=wall, record=rec, law=law, steps=judge_steps.done)


def _landing_rows(track: PlanTrack) -> list[tuple[int, int, str]]:
    """(row, step, sole) at which each landing is judged: the last row of the transfer that follows
    the swing of ``step`` (transfers carry the index of the step they lead into), in time order."""
    out = []
    n = len(track)
    for i in range(n):
        last_of_transfer = track.phase[i] == "transfer" and (i + 1 == n or track.phase[i + 1] != "transfer")
        if last_of_transfer and track.step[i] >= 1:
            step = int(track.step[i]) - 1
            swing_rows = np.flatnonzero((track.phase == "swing") & (track.step == step))
            if len(swing_rows):
                sup = track.support[swing_rows[0]]
                out.append((i, step, other_side(sup)))
    return out


def _on_cartons(track: PlanTrack, xyz: np.ndarray, xmat: np.ndarray) -> bool:
    """Whether a sole, at its simulated pose, lies on a carton top (the ground without cartons)."""
    yaw = math.atan2(xmat[3], xmat[0])
    level = xmat[8] > math.cos(math.radians(5.0))
    if not track.cartons:
        return bool(level and abs(xyz[2]) < ON_TOP_TOL_M)
    return bool(level and any(abs(xyz[2] - c.top_z) < ON_TOP_TOL_M
                              and sole_on_carton(np.array([xyz[0], xyz[1], c.top_z]), yaw, track.robot.sole_length_m,
                                                 track.robot.sole_width_m, c, tol_m=ON_TOP_TOL_M)
                              for c in track.cartons))


def _run_one(folder: str, controller: str, perturbation: Perturbation, record: bool, compensate: bool
             ) -> RunResult:
    return rehearse(load_plan(Path(folder)), controller, perturbation, record=record, compensate=compensate)


def simulate(folder: Path, controller: str, perturbations: list[Perturbation], jobs: int = 1,
             progress=None, compensate: bool = True, track: PlanTrack | None = None) -> list[RunResult]:
    """Every perturbation's run of the plan in ``folder`` (the first one recorded), in order; the
    results do not depend on ``jobs``. ``track``: the folder's plan if the caller has read it already."""
    if track is None:
        track = load_plan(folder)  # bad input fails here, before any worker starts
    if jobs <= 1 or len(perturbations) == 1:
        out = []
        for k, p in enumerate(perturbations):
            out.append(rehearse(track, controller, p, record=k == 0, compensate=compensate))
            if progress:
                progress(f"run {k + 1}", k + 1, len(perturbations))
        return out
    from joblib import Parallel, delayed

    out = []
    tasks = [delayed(_run_one)(str(folder), controller, p, k == 0, compensate) for k, p in enumerate(perturbations)]
    for k, r in enumerate(Parallel(n_jobs=jobs, return_as="generator")(tasks)):
        out.append(r)
        if progress:
            progress(f"run {k + 1}", k + 1, len(perturbations))
    return out
