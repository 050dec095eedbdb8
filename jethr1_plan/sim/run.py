"""The twin's run: one MuJoCo twin, the robot's loop and its sensors, following one plan or, step after
step, the plans the robot makes as it goes (:class:`TwinRun`).

Measured along the way by the judge (:mod:`.judge`: the twin's truth, never the controller's): the largest
trunk tilt, the support soles' largest tilt and slip (against where the plan puts them), the least margin of
the true centre of pressure inside the support sole, each landing's error (the swing sole at the end of the
transfer that follows it, against the plan), per swing the support sole's slip and turn and the landing
error's parts (:class:`~.judge.StepJudge`), the largest thrust; a fall ends the run.

The controller (:class:`~jethr1_plan.control.feedback.Controller`) sees the robot only through its
declared sensors (:class:`~.sensors.SensorModel`) and its own kinematics (:class:`~.sensors.OwnKinematics`),
and the plan through a reference in its IMU's world (:meth:`TwinRun.follow`'s ``reference`` track).
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from jethr1_plan.control import thrust_feedback as ctl
from jethr1_plan.control.feedback import UNLOADED, Controller
from jethr1_plan.control.imu_thrust import ImuGains
from jethr1_plan.control.measurement import Measurement, Reference
from jethr1_plan.control.swing_placement import PlacementGains, yaw_of
from jethr1_plan.errors import InputError
from jethr1_plan.geometry import GRAVITY, SIDES, halfplanes, other_side, sole_polygon
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.robot.sensors import LAW_SENSORS
from jethr1_plan.sim.judge import FALL_DROP_M, FALL_TILT_DEG, RunResult, StepJudge, landing_rows, on_cartons, sole_loads
from jethr1_plan.sim.sensors import OwnKinematics, SensorDraw, SensorModel
from jethr1_plan.sim.track import Perturbation, PlanTrack, plan_kinematics
from jethr1_plan.sim.twin import Twin, TwinParams, build_twin
from jethr1_plan.swing_path import Carton

__all__ = ["BLEND_S", "HOLD_S", "RECORD_HZ", "SETTLE_S", "Segment", "TwinRun", "law_of"]

SETTLE_S = 0.5  # the first posture is held this long before the plan's clock starts [s]
HOLD_S = 1.0  # the last posture is held this long after the plan ends [s]
RECORD_HZ = 50.0  # rate of the recorded states (simulation.mcap) [Hz]
BLEND_S = 0.3  # a new plan's first commands are blended in from the last ones over this [s]


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


@dataclass
class Segment:
    """What one :meth:`TwinRun.follow` saw: the plan's rows it reached, whether the robot fell there."""

    fell: dict | None
    landings: list[dict]
    steps: list[dict]
    end_s: float  # the run's clock when the segment ended [s]


class _Following:
    """What the robot's loop is given at a tick of :meth:`TwinRun.follow`: the reference track's row ``i`` and the
    next interpolated by ``a``, the joints' targets blended in over ``BLEND_S`` from the last ones sent (a new
    plan's first commands), the thrust feed-forward only while the plan runs."""

    def __init__(self, ref_track: PlanTrack, compensate: bool, blend_from: np.ndarray | None, n_fans: int) -> None:
        self.track, self.blend_from, self.n_fans = ref_track, blend_from, n_fans
        self.target = ref_track.q_cmd if compensate else ref_track.q
        self.thrust_ff = ref_track.thrust_cmd if compensate else ref_track.thrust

    def commands(self, t: float, i: int, a: float, active: bool) -> tuple[np.ndarray, np.ndarray]:
        """(the joints' target [rad], the fans' feed-forward [N]) at the track's time ``t`` [s]."""
        j = i + 1
        q_ref = (1 - a) * self.target[i] + a * self.target[j]
        if self.blend_from is not None and t < BLEND_S:
            w = max(0.0, t) / BLEND_S
            q_ref = (1 - w) * self.blend_from + w * q_ref
        thrust = ((1 - a) * self.thrust_ff[i] + a * self.thrust_ff[j]) if active else np.zeros(self.n_fans)
        return q_ref, thrust

    def reference(self, t: float, i: int, a: float, sup: str, active: bool) -> tuple[np.ndarray, Reference]:
        """(the joints' target [rad], the loop's reference) at the track's time ``t`` [s]."""
        r = self.track
        q_ref, thrust = self.commands(t, i, a, active)
        return q_ref, Reference(t, sup, q_ref, thrust, r.trunk_rot[i], r.feet[i], r.feet_yaw[i], r.fans_m[i], active)


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
                 params: TwinParams | None = None, record: bool = False, estimating: bool = False) -> None:
        import mujoco

        self.p = perturbation or Perturbation()
        self.robot, self.cartons, self.controller, self.compensate = robot, cartons, controller, compensate
        self.law = law_of(robot, controller)
        # the sensors are read at every control tick where a law reads them or where the robot estimates between
        # plans where it stands (``measure``): a delayed reading is the state that many ticks before, never an
        # older reading taken at the previous estimate
        self.sensing = self.law is not None or estimating
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
        self._margin_edges: tuple | None = None  # ((row, sole), normals, offsets) of the last support sole asked
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
        """The robot's sensors read now (the robot's view, for its own estimates between plans, after a
        :meth:`follow` that ended without a fall)."""
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
        m, d, twin, loop = self.model, self.data, self.twin, self.loop
        judge_steps = StepJudge(twin, track, self.p.servo_stiffness_scale)
        judge = landing_rows(track)
        n_rows = len(track)
        dt = self.dt
        n_settle, n_plan, n_hold = round(settle_s / dt), round(float(track.time_s[-1]) / dt) + 1, round(hold_s / dt)
        record_every = max(1, round(1.0 / (RECORD_HZ * dt)))
        follow = _Following(ref_track, self.compensate, self.last_q, len(self.robot.fans))
        t0 = self.t + settle_s  # the run's clock at the track's first row
        wall0 = time.perf_counter()
        landings: list[dict] = []
        feed_forward = self.law is None  # the plan's commands alone: no measurement, no loop state to keep
        time_s, rate_hz, support = track.time_s, track.rate_hz, track.support
        ticks = n_settle + n_plan + n_hold
        kept_from = ticks - self.sensors.depth  # a feed-forward robot reads its sensors after the run (``measure``)
        for k in range(ticks):
            t = (k - n_settle) * dt  # the track's clock
            if k < n_settle:
                i, a = 0, 0.0
            else:
                x = min(max(t * rate_hz, 0.0), n_rows - 1.0)
                i = min(int(x), n_rows - 2)
                a = x - i
            active = k >= n_settle
            sup = support[i]
            self.t = t0 + t
            if feed_forward:  # what Controller.step returns without a law: the reference's commands
                q_ref, thrust = follow.commands(t, i, a, active)
                if self.sensing:  # the robot estimates where it stands between plans (``measure``), not now
                    self.sensors.tick(d, self.t, keep=k >= kept_from)
            else:
                q_ref, ref = follow.reference(t, i, a, sup, active)
                cmd = loop.step(self.sensors.read(d, self.t), ref)
                thrust = cmd.thrust
            d.ctrl[:] = q_ref if feed_forward else cmd.q
            self.last_q = q_ref
            loads = sole_loads(twin, d, self.buf)
            self._cop_margin(track, i, sup, loads)
            self._thrust(thrust, dt)
            mujoco.mj_step(m, d, self.nsub)
            if self._fallen(track, i, a, sup):
                break
            if active:
                judge_steps.tick(d, i, t, {s: f for s, (f, _) in loads.items()}, self.applied)
            while judge and active and t >= time_s[judge[0][0]] - 1e-9:
                row, step, sole = judge.pop(0)
                err = d.xpos[twin.foot_bodies[sole]] - track.feet[row, SIDES.index(sole)]
                landings.append({"step": step, "sole": sole, "xy_m": float(np.hypot(err[0], err[1])),
                                 "z_m": float(err[2])})
            if self.rec is not None and active and (k - n_settle) % record_every == 0:
                total = sum(f for f, _ in loads.values())
                self._record(np.asarray(sum(f * c for f, c in loads.values()) / total) if total > 1e-9 else None)
        self.wall += time.perf_counter() - wall0
        self.landings += landings
        self.steps += judge_steps.done
        return Segment(self.fell, landings, judge_steps.done, self.t)

    def _cop_margin(self, track: PlanTrack, i: int, sup: str, loads: dict[str, tuple[float, np.ndarray]]) -> None:
        """The least margin of the true centre of pressure inside the support sole, in single support as the twin
        measures it (the swing sole carrying next to nothing)."""
        alone = (sup != "both" and loads[sup][0] > 0.2 * self.weight
                 and loads[other_side(sup)][0] < UNLOADED * self.weight)
        if alone:
            k = SIDES.index(sup)
            if self._margin_edges is None or self._margin_edges[0] != (i, k):
                poly = sole_polygon(track.feet[i, k, :2], track.feet_yaw[i, k], self.robot.sole_length_m,
                                    self.robot.sole_width_m)
                self._margin_edges = ((i, k), *halfplanes(poly))
            _, normals, offsets = self._margin_edges
            # polygon_margin's signed distance, the sole's edges kept over the ticks of one row
            margin = float((offsets - np.asarray(loads[sup][1][:2], dtype=float) @ normals.T).min(axis=-1))
            if margin < self.least_margin:
                self.least_margin, self.least_at = margin, {**track.where(i), "run_time_s": self.t}

    def _thrust(self, command: np.ndarray, dt: float) -> None:
        """The fans' true thrust after ``dt`` [s] of their first-order lag towards ``command`` × the thrust gain,
        applied to their bodies as vertical forces."""
        d, p = self.data, self.p
        self.applied += (p.thrust_gain * command - self.applied) * (dt / p.fan_lag_s)
        self.max_thrust = max(self.max_thrust, float(command.max(initial=0.0)))
        xfrc, xpos, xipos = d.xfrc_applied, d.xpos, d.xipos
        for fz, body in zip(self.applied.tolist(), self.fan_ids, strict=True):
            # the moment about the body's CoM of the vertical force at its origin: r × (0, 0, fz), written out as
            # np.cross computes it (the same floats, without its per-call cost)
            (px, py, pz), (cx, cy, cz) = xpos[body].tolist(), xipos[body].tolist()
            rx, ry, rz = px - cx, py - cy, pz - cz
            xfrc[body] = (0.0, 0.0, fz, ry * fz - rz * 0.0, rz * 0.0 - rx * fz, rx * 0.0 - ry * 0.0)

    def _fallen(self, track: PlanTrack, i: int, a: float, sup: str) -> bool:
        """After a physics step: the trunk's and the support soles' tilt and slip measured; whether the robot fell
        (the trunk tilted over ``FALL_TILT_DEG``, the pelvis ``FALL_DROP_M`` below the plan), noted in ``fell``."""
        d, twin = self.data, self.twin
        xmat, xpos = d.xmat, d.xpos
        tilt = math.degrees(math.acos(min(1.0, max(-1.0, float(xmat[twin.trunk, 8])))))
        self.max_tilt = max(self.max_tilt, tilt)
        for s in (SIDES if sup == "both" else (sup,)):
            b, k = twin.foot_bodies[s], SIDES.index(s)
            self.sup_tilt = max(self.sup_tilt, math.degrees(math.acos(min(1.0, max(-1.0, float(xmat[b, 8]))))))
            (x, y), (fx, fy) = xpos[b, :2].tolist(), track.feet[i, k, :2].tolist()
            self.sup_slip = max(self.sup_slip, float(np.hypot(x - fx, y - fy)))
        z_plan = (1 - a) * float(track.pelvis[i, 2]) + a * float(track.pelvis[i + 1, 2])
        z = float(d.qpos[2])
        if tilt > FALL_TILT_DEG or z < z_plan - FALL_DROP_M:
            reason = (f"trunk tilted {tilt:.1f} deg" if tilt > FALL_TILT_DEG
                      else f"pelvis {z_plan - z:.3f} m below the plan")
            self.fell = {**track.where(i), "run_time_s": self.t, "reason": reason}
            return True
        return False

    def _record(self, cop: np.ndarray | None) -> None:
        """The state at the run's clock, once per instant: the first tick of a plan followed after another carries
        the clock where the last one left it, and that instant is recorded already."""
        d, twin = self.data, self.twin
        assert self.rec is not None
        if self.rec["t"] and self.t <= self.rec["t"][-1]:
            return
        self.rec["t"].append(self.t)
        self.rec["qpos"].append(d.qpos[:7].tolist() + d.qpos[twin.qpos_adr].tolist())
        self.rec["thrust"].append(self.applied.tolist())
        self.rec["cop"].append(None if cop is None else cop.tolist())
        self.rec["com"].append(d.subtree_com[twin.trunk].tolist())

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
            peak_thrust_n=self.max_thrust, simulated_s=self.t + SETTLE_S, wall_s=self.wall, record=self.rec,
            law=self.law, steps=self.steps)
