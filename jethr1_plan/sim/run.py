"""The twin's run: one MuJoCo twin, the robot's loop and its sensors, following one plan or, step after
step, the plans the robot makes as it goes (:class:`TwinRun`); the judge of every run.

A run **falls** when the trunk tilts more than ``FALL_TILT_DEG`` from level or the pelvis drops more
than ``FALL_DROP_M`` below the plan; it **succeeds** when it does not fall and both soles end on
carton tops (on the ground where the scenario has no cartons). Measured along the way (the twin's
truth: the judge's, never the controller's): the largest trunk tilt, the support soles' largest tilt
and slip (against where the plan puts them), the least margin of the true centre of pressure inside
the support sole, each landing's error (the swing sole at the end of the transfer that follows it,
against the plan), per swing the support sole's slip and turn and the landing error's parts
(:class:`StepJudge`), the largest thrust.

The controller (:class:`~jethr1_plan.control.feedback.Controller`) sees the robot only through its
declared sensors (:class:`~.sensors.SensorModel`) and its own kinematics (:class:`~.sensors.OwnKinematics`),
and the plan through a reference in its IMU's world (:meth:`TwinRun.follow`'s ``reference`` track).
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from jethr1_plan.control import thrust_feedback as ctl
from jethr1_plan.control.feedback import UNLOADED, Controller
from jethr1_plan.control.imu_thrust import ImuGains
from jethr1_plan.control.measurement import Measurement, Reference
from jethr1_plan.control.swing_placement import PlacementGains, yaw_of
from jethr1_plan.errors import InputError
from jethr1_plan.geometry import GRAVITY, SIDES, other_side, polygon_margin, sole_polygon
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.robot.sensors import LAW_SENSORS
from jethr1_plan.sim.sensors import OwnKinematics, SensorDraw, SensorModel
from jethr1_plan.sim.track import Perturbation, PlanTrack, plan_kinematics
from jethr1_plan.sim.twin import Twin, TwinParams, build_twin
from jethr1_plan.swing_path import Carton, sole_on_carton

__all__ = ["FALL_DROP_M", "FALL_TILT_DEG", "HOLD_S", "SETTLE_S", "RunResult", "Segment", "StepJudge", "TwinRun",
           "landing_rows", "law_of", "on_cartons"]

SETTLE_S = 0.5  # the first posture is held this long before the plan's clock starts [s]
HOLD_S = 1.0  # the last posture is held this long after the plan ends [s]
FALL_TILT_DEG = 10.0  # a trunk tilted more than this from level has fallen [deg]
FALL_DROP_M = 0.10  # a pelvis this far below the plan has fallen [m]
ON_TOP_TOL_M = 0.005  # a sole within this of a carton's top (height) stands on it [m]
RECORD_HZ = 50.0  # rate of the recorded states (simulation.mcap) [Hz]
BLEND_S = 0.3  # a new plan's first commands are blended in from the last ones over this [s]


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
    stopped: str | None = None  # why the robot stopped before the plan's end without falling (step by step)

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
    (the sole's centre where it carries nothing). The contact forces are the constraint solver's: the
    twin's elliptic cones keep each contact's force in its frame (normal, then tangential) at its
    ``efc_address`` (what ``mj_contactForce`` reads)."""
    force = {s: 0.0 for s in twin.sole_geoms}  # [N]
    moment = {s: np.zeros(3) for s in twin.sole_geoms}  # Σ force · contact point [N·m]
    n = d.ncon
    if n:
        contact = d.contact
        geoms = contact.geom[:n]
        adr = contact.efc_address[:n]
        for side, g in twin.sole_geoms.items():
            idx = np.flatnonzero(((geoms[:, 0] == g) | (geoms[:, 1] == g)) & (adr >= 0))
            if not len(idx):
                continue
            a = adr[idx]
            frames = contact.frame[idx]
            f = d.efc_force
            # the world z component of each contact's force (its frame's rows are the normal and tangents)
            z = np.abs(frames[:, 2] * f[a] + frames[:, 5] * f[a + 1] + frames[:, 8] * f[a + 2])
            force[side] = float(z.sum())
            moment[side] = z @ contact.pos[idx]
    return {s: (f, moment[s] / f if f > 1e-9 else d.xpos[twin.foot_bodies[s]].copy()) for s, f in force.items()}


def law_of(robot: RobotModel, controller: str) -> str | None:
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


class StepJudge:
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
        self.judge = {step: row for row, step, _ in landing_rows(track)}
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
        rec = {"step": cur["step"], "swing": sw, "support": sup, "landed_m": [float(v) for v in pw],
               "target_m": [float(v) for v in cur["landing"]],
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




@dataclass
class Segment:
    """What one :meth:`TwinRun.follow` saw: the plan's rows it reached, whether the robot fell there."""

    fell: dict | None
    landings: list[dict]
    steps: list[dict]
    end_s: float  # the run's clock when the segment ended [s]


class TwinRun:
    """One twin and one robot loop, run on; :meth:`follow` a plan's track, then another from where the
    robot stands (the twin's state, the servos', the fans' and the controller's carry over), then
    :meth:`result`.

    ``controller``: ``feedforward``, ``feedback`` (the robot's own law) or a law's name. The sensors' errors:
    ``perturbation.sensors``, else nominal with the noise seeded by ``seed``."""

    def __init__(self, robot: RobotModel, cartons: tuple[Carton, ...], thrust_max_n: float,
                 controller: str = "feedforward", perturbation: Perturbation | None = None,
                 gains: ctl.Gains | None = None, imu_gains: ImuGains | None = None,
                 placement: PlacementGains | None = None, compensate: bool = True, seed: int = 0,
                 params: TwinParams | None = None, record: bool = False) -> None:
        import mujoco

        self.p = perturbation or Perturbation()
        self.robot, self.cartons, self.controller, self.compensate = robot, cartons, controller, compensate
        self.law = law_of(robot, controller)
        gains = gains or ctl.Gains.of(robot)
        imu_gains = imu_gains or ImuGains.of(robot)
        self.twin = build_twin(robot, cartons, params)
        _apply(self.twin, self.p)
        self.model = self.twin.model
        self.data = mujoco.MjData(self.model)
        rate = imu_gains.rate_hz if self.law == "imu_tilt_pid" else gains.rate_hz
        self.nsub = max(1, round(1.0 / rate / self.model.opt.timestep))
        self.dt = self.nsub * self.model.opt.timestep
        self.fan_ids = [self.twin.fan_bodies[f.frame] for f in robot.fans]
        self.applied = np.zeros(len(robot.fans))
        self.sensors = SensorModel(self.twin, robot.sensors, self.p.sensors or SensorDraw(noise_seed=seed), self.dt)
        self.loop = Controller(robot, OwnKinematics(robot) if self.law is not None else None, self.law, thrust_max_n,
                               gains, imu_gains, placement, compensate)
        self.weight = GRAVITY * float(self.model.body_mass.sum())
        self.buf = np.zeros(6)
        self.t = -SETTLE_S  # the run's clock: 0 where the first plan starts [s]
        self.rec: dict[str, list] | None = ({"t": [], "qpos": [], "thrust": [], "cop": [], "com": []} if record
                                            else None)
        self.max_tilt = self.sup_tilt = self.sup_slip = self.max_thrust = 0.0
        self.least_margin: float = math.inf
        self.least_at: dict | None = None
        self.fell: dict | None = None
        self.landings: list[dict] = []
        self.steps: list[dict] = []
        self.last_q: np.ndarray | None = None
        self.wall = 0.0
        self.started = False

    def start(self, pelvis: np.ndarray, q: np.ndarray) -> None:
        """Put the robot in a posture: the trunk's pose (position, quaternion w, x, y, z) and the joints."""
        import mujoco

        d = self.data
        d.qpos[:7] = pelvis
        d.qpos[self.twin.qpos_adr] = q
        mujoco.mj_forward(self.model, d)
        self.started = True

    def pose(self, side: str) -> tuple[np.ndarray, float]:
        """A sole's true centre (3,) [m] and yaw [rad] (the judge's, or an experimenter's: not the robot's)."""
        b = self.twin.foot_bodies[side]
        return self.data.xpos[b].copy(), yaw_of(self.data.xmat[b])

    def measure(self) -> Measurement:
        """The robot's sensors read now (the robot's view, for its own estimates between plans)."""
        return self.sensors.read(self.data, self.t)

    def follow(self, track: PlanTrack, reference: PlanTrack | None = None, settle_s: float = 0.0,
               hold_s: float = 0.0) -> Segment:
        """Run the twin along ``track`` (its poses in the twin's world: what the judge compares with), the
        controller following ``reference`` (the same rows in the robot's IMU world; default ``track``): hold
        the first row for ``settle_s``, run the rows, hold the last for ``hold_s``. The run's clock goes on."""
        import mujoco

        if not self.started:
            self.start(track.pelvis[0], track.q[0])
        ref_track = reference if reference is not None else track
        for tr in (track, ref_track):
            if not len(tr.feet) or not len(tr.feet_rot) or not len(tr.fans_m):
                plan_kinematics(self.twin, tr)
        m, d, twin, robot, loop, p = self.model, self.data, self.twin, self.robot, self.loop, self.p
        target = ref_track.q_cmd if self.compensate else ref_track.q
        thrust_ff = ref_track.thrust_cmd if self.compensate else ref_track.thrust
        nf = len(robot.fans)
        side_index = {s: k for k, s in enumerate(SIDES)}
        judge_steps = StepJudge(twin, track, p.servo_stiffness_scale)
        judge = landing_rows(track)
        n_rows = len(track)
        dt = self.dt
        n_settle, n_plan, n_hold = round(settle_s / dt), round(float(track.time_s[-1]) / dt) + 1, round(hold_s / dt)
        record_every = max(1, round(1.0 / (RECORD_HZ * dt)))
        blend_from = self.last_q
        nothing = Measurement(0.0, None, None, None, None)
        t0 = self.t + settle_s  # the run's clock at the track's first row
        wall0 = time.perf_counter()
        landings: list[dict] = []
        for k in range(n_settle + n_plan + n_hold):
            t = (k - n_settle) * dt  # the track's clock
            if k < n_settle:
                i, a = 0, 0.0
            else:
                x = min(max(t * track.rate_hz, 0.0), n_rows - 1.0)
                i = min(int(x), n_rows - 2)
                a = x - i
            j = i + 1
            active = k >= n_settle
            sup = track.support[i]
            q_ref = (1 - a) * target[i] + a * target[j]
            if blend_from is not None and t < BLEND_S:
                w = max(0.0, t) / BLEND_S
                q_ref = (1 - w) * blend_from + w * q_ref
            ref = Reference(t, sup, q_ref, ((1 - a) * thrust_ff[i] + a * thrust_ff[j]) if active else np.zeros(nf),
                            ref_track.trunk_rot[i], ref_track.feet[i], ref_track.feet_yaw[i], ref_track.fans_m[i],
                            active)
            self.t = t0 + t
            cmd = loop.step(self.sensors.read(d, self.t) if self.law is not None else nothing, ref)
            d.ctrl[:] = cmd.q
            self.last_q = q_ref
            loads = _sole_loads(twin, d, self.buf)
            total = sum(f for f, _ in loads.values())
            cop = np.asarray(sum(f * c for f, c in loads.values()) / total) if total > 1e-9 else None
            # single support as the twin measures it: the swing sole carries (next to) nothing
            alone = (sup != "both" and loads[sup][0] > 0.2 * self.weight
                     and loads[other_side(sup)][0] < UNLOADED * self.weight)
            if alone:
                poly = sole_polygon(track.feet[i, side_index[sup], :2], track.feet_yaw[i, side_index[sup]],
                                    robot.sole_length_m, robot.sole_width_m)
                margin = float(polygon_margin(loads[sup][1][:2], poly))
                if margin < self.least_margin:
                    self.least_margin, self.least_at = margin, {**track.where(i), "run_time_s": self.t}
            self.applied += (p.thrust_gain * cmd.thrust - self.applied) * (dt / p.fan_lag_s)
            self.max_thrust = max(self.max_thrust, float(cmd.thrust.max(initial=0.0)))
            d.xfrc_applied[:] = 0.0
            for f_idx, body in enumerate(self.fan_ids):
                fz = float(self.applied[f_idx])
                d.xfrc_applied[body, :3] = (0.0, 0.0, fz)
                # the moment about the body's CoM of the vertical force at its origin: r × (0, 0, fz), written out as
                # np.cross computes it (the same floats, without its per-call cost)
                rx, ry, rz = (d.xpos[body] - d.xipos[body]).tolist()
                d.xfrc_applied[body, 3:] = (ry * fz - rz * 0.0, rz * 0.0 - rx * fz, rx * 0.0 - ry * 0.0)
            mujoco.mj_step(m, d, self.nsub)
            # measurements
            R = d.xmat[twin.trunk]
            tilt = math.degrees(math.acos(min(1.0, max(-1.0, R[8]))))
            self.max_tilt = max(self.max_tilt, tilt)
            for s in (SIDES if sup == "both" else (sup,)):
                b = twin.foot_bodies[s]
                self.sup_tilt = max(self.sup_tilt, math.degrees(math.acos(min(1.0, max(-1.0, d.xmat[b][8])))))
                self.sup_slip = max(self.sup_slip,
                                    float(np.hypot(*(d.xpos[b][:2] - track.feet[i, side_index[s], :2]))))
            z_plan = (1 - a) * track.pelvis[i, 2] + a * track.pelvis[j, 2]
            if tilt > FALL_TILT_DEG or d.qpos[2] < z_plan - FALL_DROP_M:
                reason = (f"trunk tilted {tilt:.1f} deg" if tilt > FALL_TILT_DEG
                          else f"pelvis {z_plan - d.qpos[2]:.3f} m below the plan")
                self.fell = {**track.where(i), "run_time_s": self.t, "reason": reason}
                break
            if active:
                judge_steps.tick(d, i, t, {s: f for s, (f, _) in loads.items()}, self.applied)
            while judge and active and t >= track.time_s[judge[0][0]] - 1e-9:
                row, step, sole = judge.pop(0)
                err = d.xpos[twin.foot_bodies[sole]] - track.feet[row, side_index[sole]]
                landings.append({"step": step, "sole": sole, "xy_m": float(np.hypot(err[0], err[1])),
                                 "z_m": float(err[2])})
            if self.rec is not None and active and (k - n_settle) % record_every == 0:
                self.rec["t"].append(self.t)
                self.rec["qpos"].append(d.qpos[:7].tolist() + d.qpos[twin.qpos_adr].tolist())
                self.rec["thrust"].append(self.applied.tolist())
                self.rec["cop"].append(None if cop is None else cop.tolist())
                self.rec["com"].append(d.subtree_com[twin.trunk].tolist())
        self.wall += time.perf_counter() - wall0
        self.landings += landings
        self.steps += judge_steps.done
        return Segment(self.fell, landings, judge_steps.done, self.t)

    def soles_on_cartons(self) -> dict[str, bool]:
        d, twin = self.data, self.twin
        return {s: on_cartons(self.robot, self.cartons, d.xpos[twin.foot_bodies[s]], d.xmat[twin.foot_bodies[s]])
                for s in SIDES}

    def result(self, on_top: dict[str, bool] | None = None) -> RunResult:
        """The run's verdict: no fall and both soles on carton tops (``on_top``: where the caller judged it)."""
        on_top = on_top if on_top is not None else self.soles_on_cartons()
        if self.rec is not None:
            self.rec["steps"] = self.steps
        return RunResult(
            controller=self.controller, compensated=self.compensate, perturbation=asdict(self.p),
            survived=self.fell is None and all(on_top.values()), fell=self.fell,
            max_trunk_tilt_deg=self.max_tilt, support_max_tilt_deg=self.sup_tilt, support_max_slip_m=self.sup_slip,
            least_cop_margin_m=None if math.isinf(self.least_margin) else self.least_margin,
            least_cop_margin_at=self.least_at, landing_errors_m=self.landings, soles_on_cartons_at_end=on_top,
            max_thrust_n=self.max_thrust, simulated_s=self.t + SETTLE_S, wall_s=self.wall, record=self.rec,
            law=self.law, steps=self.steps)


def landing_rows(track: PlanTrack) -> list[tuple[int, int, str]]:
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


def on_cartons(robot: RobotModel, cartons: tuple[Carton, ...], xyz: np.ndarray, xmat: np.ndarray) -> bool:
    """Whether a sole, at its simulated pose, lies on a carton top (the ground without cartons)."""
    yaw = math.atan2(xmat[3], xmat[0])
    level = xmat[8] > math.cos(math.radians(5.0))
    if not cartons:
        return bool(level and abs(xyz[2]) < ON_TOP_TOL_M)
    return bool(level and any(abs(xyz[2] - c.top_z) < ON_TOP_TOL_M
                              and sole_on_carton(np.array([xyz[0], xyz[1], c.top_z]), yaw, robot.sole_length_m,
                                                 robot.sole_width_m, c, tol_m=ON_TOP_TOL_M)
                              for c in cartons))


