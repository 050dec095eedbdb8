"""The robot's sensors in the twin: what its declared sensors (the robot YAML's ``sensors:``) read from the
MuJoCo state, with their noise, bias and delay; and the robot's own kinematic model, which turns those
readings into sole and fan poses. The twin's controllers see the robot only through these
(:class:`~jethr1_plan.control.feedback.Controller` takes a :class:`Measurement`, never the MuJoCo data).

What each sensor reads (its truth, then its errors):

* **IMU** on the trunk: the trunk's orientation and its angular rate in its own frame. The attitude is
  read off by a small rotation (world frame) of roll and pitch errors (a bias constant over the run,
  within ``attitude_bias_rad``, plus white noise of ``attitude_noise_rad``) and a heading error that
  grows at the drift rate (the gyro's z bias integrated, within ``yaw_drift_rad_s``); the rate with a
  bias within ``rate_bias_rad_s`` per axis plus white noise ``rate_noise_rad_s``.
* **Encoders**: each joint's angle plus a zero offset (calibration, within ``offset_rad``) and white
  noise ``noise_rad``, rounded to ``resolution_rad``.
* **Sole force sensors** (where declared): each sole's normal force and its centre of pressure in the
  sole's frame, with white noise ``force_noise_n``, ``cop_noise_m``.

Each reading is ``delay_s`` old: the sensor model keeps the truth of the last ticks and reads the one
that many ticks back. The biases, offsets and delays of a run are a :class:`SensorDraw`: nominal (no
bias, the declared delays) or drawn by a randomised trial (biases uniform within their bounds, the CoM
of a tilt bias uniform over its disc, each delay uniform between the declared one and twice it). The
noise comes from the draw's own generator, ``default_rng([noise_seed, 0])``: the same draw reads the
same numbers. SI units.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from jethr1_plan.control.measurement import Measurement, SoleReading
from jethr1_plan.geometry import SIDES
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.robot.sensors import Sensors
from jethr1_plan.sim.twin import Twin, build_twin

__all__ = ["OwnKinematics", "SensorDraw", "SensorModel", "rotation_vector"]

NOISE_BLOCK = 4096  # standard normals drawn ahead at a time, whole readings' worth (:meth:`SensorModel._noise`)


def rotation_vector(v: np.ndarray) -> np.ndarray:
    """The rotation (3, 3) of the rotation vector ``v`` (3,) [rad] (Rodrigues)."""
    x, y, z = (float(a) for a in v)
    a = math.sqrt(x * x + y * y + z * z)
    if a < 1e-12:
        return np.eye(3)
    kx, ky, kz = x / a, y / a, z / a
    s, c = math.sin(a), 1.0 - math.cos(a)
    return np.array([[1.0 - c * (ky * ky + kz * kz), -s * kz + c * kx * ky, s * ky + c * kx * kz],
                     [s * kz + c * kx * ky, 1.0 - c * (kx * kx + kz * kz), -s * kx + c * ky * kz],
                     [-s * ky + c * kx * kz, s * kx + c * ky * kz, 1.0 - c * (kx * kx + ky * ky)]])


@dataclass(frozen=True)
class SensorDraw:
    """A run's sensor errors that hold over the whole run (the module docstring). Delays None: as declared."""

    imu_tilt_bias_rad: tuple[float, float] = (0.0, 0.0)  # roll and pitch errors of the attitude [rad]
    gyro_bias_rad_s: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [rad/s]
    yaw_drift_rad_s: float = 0.0  # the heading error's rate [rad/s]
    encoder_offset_rad: tuple[float, ...] = ()  # per joint (empty: none) [rad]
    imu_delay_s: float | None = None
    encoder_delay_s: float | None = None
    sole_delay_s: float | None = None
    noise_seed: int = 0  # the white noise's generator: default_rng([noise_seed, 0])

    @classmethod
    def draw(cls, sensors: Sensors, rng: np.random.Generator, n_joints: int) -> SensorDraw:
        """A randomised trial's sensor errors within the declaration, drawn from ``rng`` (always the same
        number of draws, whatever is declared, so later draws of the trial do not shift)."""
        imu, enc, sole = sensors.imu, sensors.encoders, sensors.soles
        r, a = math.sqrt(float(rng.uniform())), float(rng.uniform(0.0, 2 * math.pi))
        gyro = rng.uniform(-1.0, 1.0, 3)
        drift = float(rng.uniform(-1.0, 1.0))
        offsets = rng.uniform(-1.0, 1.0, n_joints)
        delays = rng.uniform(1.0, 2.0, 3)
        seed = int(rng.integers(0, 2**62))
        tilt = (imu.attitude_bias_rad if imu else 0.0) * r
        gx, gy, gz = (float(v) for v in gyro * (imu.rate_bias_rad_s if imu else 0.0))
        return cls((tilt * math.cos(a), tilt * math.sin(a)), (gx, gy, gz),
                   drift * (imu.yaw_drift_rad_s if imu else 0.0),
                   tuple(float(v) for v in offsets * (enc.offset_rad if enc else 0.0)),
                   float(delays[0] * imu.delay_s) if imu else None,
                   float(delays[1] * enc.delay_s) if enc else None,
                   float(delays[2] * sole.delay_s) if sole else None, seed)


class SensorModel:
    """The robot's declared sensors reading the twin (the module docstring), one :meth:`read` per control
    tick of ``period_s``."""

    def __init__(self, twin: Twin, sensors: Sensors, draw: SensorDraw, period_s: float) -> None:
        self.twin, self.sensors, self.draw, self.period = twin, sensors, draw, period_s
        self.rng = np.random.default_rng([draw.noise_seed, 0])
        n = len(twin.robot.joint_names)
        # a reading's white noise, in the order it is drawn: (σ, count) per noisy signal (:meth:`_noise`)
        imu, enc, sole = sensors.imu, sensors.encoders, sensors.soles
        parts = [(imu.attitude_noise_rad, 3) if imu is not None else (0.0, 0),
                 (imu.rate_noise_rad_s, 3) if imu is not None else (0.0, 0),
                 (enc.noise_rad, len(twin.qpos_adr)) if enc is not None else (0.0, 0)]
        parts += [(sole.force_noise_n, 1), (sole.cop_noise_m, 2)] * len(SIDES) if sole is not None else []
        sigma = [np.full(k if sd > 0 else 0, sd) for sd, k in parts]
        self._sigma = np.concatenate(sigma)  # [rad, rad/s, rad, N, m] per draw of a reading
        self._at = np.cumsum([0] + [len(x) for x in sigma])  # where each signal's draws start in a reading's row
        self._rows = np.zeros((0, len(self._sigma)))  # readings' noise drawn ahead (:meth:`_noise`)
        self._row = 0
        self.offset = np.asarray(draw.encoder_offset_rad, dtype=float) if draw.encoder_offset_rad else np.zeros(n)
        self.gyro_bias = np.asarray(draw.gyro_bias_rad_s)  # [rad/s]

        def ticks(given: float | None, declared) -> int:
            delay = given if given is not None else (declared.delay_s if declared is not None else 0.0)
            return max(0, round(delay / period_s))

        self.lag = {"imu": ticks(draw.imu_delay_s, sensors.imu), "encoders": ticks(draw.encoder_delay_s,
                    sensors.encoders), "soles": ticks(draw.sole_delay_s, sensors.soles)}
        self.history: deque[tuple] = deque(maxlen=max(self.lag.values()) + 1)  # (rotation, rate, joints, soles)
        self.vel = np.zeros(6)
        self.buf = np.zeros(6)

    def _sole_truth(self, d) -> dict[str, tuple[float, np.ndarray]]:
        """Per sole: the normal force [N] and its centre of pressure in the sole's frame (x, y) [m]."""
        import mujoco

        twin = self.twin
        force = {s: 0.0 for s in SIDES}
        moment = {s: np.zeros(3) for s in SIDES}
        by_geom = {g: s for s, g in twin.sole_geoms.items()}
        for ci in range(d.ncon):
            con = d.contact[ci]
            side = by_geom.get(con.geom1, by_geom.get(con.geom2))
            if side is not None:
                mujoco.mj_contactForce(twin.model, d, ci, self.buf)
                z = abs(float(con.frame[2::3] @ self.buf[:3]))
                force[side] += z
                moment[side] = moment[side] + z * con.pos
        out = {}
        for s in SIDES:
            b = twin.foot_bodies[s]
            if force[s] > 1e-9:
                local = d.xmat[b].reshape(3, 3).T @ (moment[s] / force[s] - d.xpos[b])
                out[s] = (force[s], local[:2].copy())
            else:
                out[s] = (0.0, np.zeros(2))
        return out

    def _noise(self) -> np.ndarray:
        """This reading's white noise, one draw per entry of ``_sigma``: the numbers of ``rng.normal(0, σ, n)`` called
        signal by signal in reading order (each is ``0 + σ·z`` of the generator's next standard normal z), taken
        from the rows of readings drawn ahead, so that a reading costs no call into the generator."""
        if self._row == len(self._rows):
            k = len(self._sigma)
            rows = max(1, NOISE_BLOCK // max(k, 1))
            self._rows, self._row = 0.0 + self._sigma * self.rng.standard_normal(rows * k).reshape(rows, k), 0
        self._row += 1
        return self._rows[self._row - 1]

    def _keep(self, d) -> np.ndarray:
        """This tick's truth of the twin's state ``d`` kept for the delayed readings; this tick's white noise."""
        import mujoco

        twin, sensors = self.twin, self.sensors
        imu, enc, sole = sensors.imu, sensors.encoders, sensors.soles
        if imu is not None:
            mujoco.mj_objectVelocity(twin.model, d, mujoco.mjtObj.mjOBJ_XBODY, twin.trunk, self.vel, 1)  # body frame
        self.history.append((d.xmat[twin.trunk].reshape(3, 3).copy() if imu else None,
                             self.vel[:3].copy() if imu else None,
                             d.qpos[twin.qpos_adr] if enc else None,
                             self._sole_truth(d) if sole is not None else None))
        return self._noise()

    @property
    def depth(self) -> int:
        """How many ticks back a reading reaches (the longest delay's, and its own)."""
        return int(self.history.maxlen or 1)

    def tick(self, d, time_s: float, keep: bool = True) -> None:
        """A control tick (at ``time_s`` [s]) at which the robot does not look at its sensors: their truth is kept and
        their noise drawn as :meth:`read` does, so that a later reading reads the same numbers as had every tick been
        read. ``keep`` False: no later reading reaches back to this tick (it comes at least :attr:`depth` ticks
        later): only its noise is drawn."""
        if keep:
            self._keep(d)
        else:
            self._noise()

    def read(self, d, time_s: float) -> Measurement:
        """The reading at this tick of the twin's state ``d`` (a ``mujoco.MjData``)."""
        sensors = self.sensors
        imu, enc, sole = sensors.imu, sensors.encoders, sensors.soles
        noise, at = self._keep(d), self._at
        last = len(self.history) - 1
        draw = self.draw
        rotation = rate = joints = None
        soles = None
        if imu is not None:
            truth = self.history[max(0, last - self.lag["imu"])]
            err = np.array([draw.imu_tilt_bias_rad[0], draw.imu_tilt_bias_rad[1], draw.yaw_drift_rad_s * time_s])
            if imu.attitude_noise_rad > 0:
                err += noise[at[0]:at[1]]
            rotation = rotation_vector(err) @ truth[0]
            rate = truth[1] + self.gyro_bias
            if imu.rate_noise_rad_s > 0:
                rate += noise[at[1]:at[2]]
        if enc is not None:
            joints = self.history[max(0, last - self.lag["encoders"])][2] + self.offset
            if enc.noise_rad > 0:
                joints += noise[at[2]:at[3]]
            if enc.resolution_rad > 0:
                joints = np.round(joints / enc.resolution_rad) * enc.resolution_rad
        if sole is not None:
            truth_soles = self.history[max(0, last - self.lag["soles"])][3]
            soles = {}
            for k, s in enumerate(SIDES):
                f, cop = truth_soles[s]
                if sole.force_noise_n > 0:
                    f = max(0.0, f + float(noise[at[3 + 2 * k]]))
                if sole.cop_noise_m > 0:
                    cop = cop + noise[at[4 + 2 * k]:at[5 + 2 * k]]
                soles[s] = SoleReading(f, cop)
        return Measurement(time_s, rotation, rate, joints, soles)


class OwnKinematics:
    """The robot's own kinematic model (its URDF compiled by MuJoCo, nominal masses: not the twin's
    perturbed physics), posed from a measurement: the trunk at the origin, oriented as the IMU reads it,
    the joints at the encoders' angles. Implements :class:`~jethr1_plan.control.measurement.Kinematics`."""

    def __init__(self, robot: RobotModel) -> None:
        import mujoco

        self.twin = build_twin(robot, ())
        self.data = mujoco.MjData(self.twin.model)
        self.jacp = np.zeros((3, self.twin.model.nv))
        self.jacr = np.zeros((3, self.twin.model.nv))
        self.fan_ids = [self.twin.fan_bodies[f.frame] for f in robot.fans]

    def update(self, joints_rad: np.ndarray, trunk_rotation: np.ndarray) -> None:
        import mujoco

        d = self.data
        d.qpos[:3] = 0.0
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(trunk_rotation, dtype=float).reshape(9))
        d.qpos[3:7] = quat
        d.qpos[self.twin.qpos_adr] = joints_rad
        mujoco.mj_kinematics(self.twin.model, d)
        mujoco.mj_comPos(self.twin.model, d)

    def sole(self, side: str) -> tuple[np.ndarray, np.ndarray]:
        b = self.twin.foot_bodies[side]
        return self.data.xpos[b].copy(), self.data.xmat[b].reshape(3, 3).copy()

    def fan(self, index: int) -> np.ndarray:
        return self.data.xpos[self.fan_ids[index]].copy()

    def sole_jacobian(self, side: str, joints: np.ndarray) -> np.ndarray:
        import mujoco

        mujoco.mj_jacBody(self.twin.model, self.data, self.jacp, self.jacr, self.twin.foot_bodies[side])
        cols = self.twin.dof_adr[np.asarray(joints)]
        return np.vstack([self.jacp[:, cols], self.jacr[:, cols]])

    def fan_lift_jacobian(self, index: int) -> np.ndarray:
        import mujoco

        body = self.fan_ids[index]
        mujoco.mj_jac(self.twin.model, self.data, self.jacp, None, self.data.xpos[body], body)
        return self.jacp[2, self.twin.dof_adr].copy()
