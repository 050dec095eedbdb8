"""The robot's sensors in the twin: readings equal to the truth without errors, the declared delay, noise,
bias and resolution; the same draw reads the same numbers; and the controller acts on what the sensors
read, not on the twin's state."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from jethr1_plan.cli import run
from jethr1_plan.control.measurement import Measurement
from jethr1_plan.robot.load import load_robot
from jethr1_plan.robot.sensors import EncoderSpec, ImuSpec, Sensors, SoleSensorSpec
from jethr1_plan.sim.rehearsal import Perturbation, load_plan, rehearse
from jethr1_plan.sim.sensors import OwnKinematics, SensorDraw, SensorModel, rotation_vector
from jethr1_plan.sim.twin import build_twin
from tests.conftest import ROOT


@pytest.fixture(scope="module")
def side_step(tmp_path_factory):
    out = tmp_path_factory.mktemp("sensors")
    assert run(["plan", str(ROOT / "configs" / "side_step.yaml"), "-o", str(out), "--no-progress"]) == 0
    return out / "side_step"


def _posed(robot, q_offset: float = 0.0):
    import mujoco

    twin = build_twin(robot, ())
    d = mujoco.MjData(twin.model)
    d.qpos[:3] = (0.1, -0.2, 0.4)
    d.qpos[3:7] = (math.cos(0.15), 0.0, math.sin(0.15) * 0.6, math.sin(0.15) * 0.8)  # a tilted, turned trunk
    d.qpos[twin.qpos_adr] = np.linspace(-0.3, 0.3, len(twin.qpos_adr)) + q_offset
    d.qvel[3:6] = (0.2, -0.1, 0.3)
    mujoco.mj_forward(twin.model, d)
    return twin, d


def test_without_errors_the_sensors_read_the_truth():
    robot = load_robot("jethr1")
    twin, d = _posed(robot)
    ideal = Sensors(ImuSpec("trunk"), EncoderSpec(), SoleSensorSpec())
    m = SensorModel(twin, ideal, SensorDraw(), 0.002).read(d, 0.0)
    np.testing.assert_allclose(m.trunk_rotation, d.xmat[twin.trunk].reshape(3, 3), atol=1e-15)
    np.testing.assert_allclose(m.joints_rad, d.qpos[twin.qpos_adr], atol=0)
    # the free joint's angular velocity is the body frame's: the gyro reads it
    np.testing.assert_allclose(m.trunk_rate_rad_s, d.qvel[3:6], atol=1e-12)
    # the soles: each one's normal force and its centre of pressure in the sole's frame (the floor under the
    # lower sole pushes it)
    from jethr1_plan.sim.judge import sole_loads as _sole_loads

    loads = _sole_loads(twin, d, np.zeros(6))
    assert max(f for f, _ in loads.values()) > 1.0
    for side, (f, cop) in loads.items():
        b = twin.foot_bodies[side]
        assert m.soles[side].force_n == pytest.approx(f, rel=1e-12)
        if f > 0:
            local = d.xmat[b].reshape(3, 3).T @ (cop - d.xpos[b])
            np.testing.assert_allclose(m.soles[side].cop_m, local[:2], atol=1e-12)


def test_the_declared_delay_noise_bias_and_resolution():
    robot = load_robot("jethr1")
    twin, d = _posed(robot)
    period = 0.002
    spec = Sensors(ImuSpec("trunk", attitude_noise_rad=0.002, rate_noise_rad_s=0.01, delay_s=0.006),
                   EncoderSpec(noise_rad=0.0, resolution_rad=0.01, delay_s=0.0))
    draw = SensorDraw(imu_tilt_bias_rad=(0.003, -0.004), gyro_bias_rad_s=(0.01, 0.0, -0.02), noise_seed=7)
    model = SensorModel(twin, spec, draw, period)
    truth = d.xmat[twin.trunk].reshape(3, 3).copy()
    reads = [model.read(d, 0.0) for _ in range(4000)]
    # the attitude: the truth turned by the bias, with white noise of the declared σ about it
    err = np.array([_rotvec(r.trunk_rotation @ truth.T) for r in reads])
    np.testing.assert_allclose(err.mean(axis=0)[:2], (0.003, -0.004), atol=2e-4)
    assert err.std(axis=0) == pytest.approx([0.002] * 3, rel=0.06)
    rate = np.array([r.trunk_rate_rad_s for r in reads])
    np.testing.assert_allclose(rate.mean(axis=0) - d.qvel[3:6], (0.01, 0.0, -0.02), atol=1e-3)
    # encoders: multiples of the resolution, within half of it of the truth
    q = reads[0].joints_rad
    np.testing.assert_allclose(q / 0.01, np.round(q / 0.01), atol=1e-9)
    assert np.max(np.abs(q - d.qpos[twin.qpos_adr])) <= 0.005 + 1e-12
    # the same draw reads the same numbers
    again = SensorModel(twin, spec, draw, period)
    assert all(np.array_equal(a.trunk_rotation, again.read(d, 0.0).trunk_rotation) for a in reads[:50])
    # the delay: the IMU reads the state of 3 ticks before, the encoders the present one
    import mujoco

    model = SensorModel(twin, spec, replace(draw, imu_tilt_bias_rad=(0.0, 0.0)), period)
    spec0 = replace(spec, imu=replace(spec.imu, attitude_noise_rad=0.0))
    model = SensorModel(twin, spec0, SensorDraw(), period)
    seen = []
    for k in range(6):
        d.qpos[3:7] = (math.cos(0.05 * k), math.sin(0.05 * k), 0.0, 0.0)  # rolling, one step per tick
        d.qpos[twin.qpos_adr[0]] = 0.1 * k
        mujoco.mj_forward(twin.model, d)
        m = model.read(d, k * period)
        seen.append((math.atan2(m.trunk_rotation[2, 1], m.trunk_rotation[2, 2]), m.joints_rad[0]))
    assert [round(a / 0.1, 6) for a, _ in seen] == [0, 0, 0, 0, 1, 2]  # roll 0.1 k, three ticks late
    assert [round(q0 / 0.1, 6) for _, q0 in seen] == [0, 1, 2, 3, 4, 5]


def _rotvec(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(R).as_rotvec()


def test_the_noise_is_the_declared_generators_draws_in_reading_order():
    """Every reading's white noise is ``default_rng([noise_seed, 0]).normal(0, σ, n)`` drawn in the order the module
    docstring states (the attitude, the gyro, the encoders, then each sole's force and centre of pressure), to the
    bit, over more readings than one block of draws holds."""
    import mujoco

    from jethr1_plan.sim.sensors import NOISE_BLOCK

    robot = load_robot("jethr1")
    twin, d = _posed(robot)
    spec = Sensors(ImuSpec("trunk", attitude_noise_rad=0.002, rate_noise_rad_s=0.01, delay_s=0.0),
                   EncoderSpec(noise_rad=0.001, resolution_rad=0.0, delay_s=0.0),
                   SoleSensorSpec(force_noise_n=0.5, cop_noise_m=0.002, delay_s=0.0))
    draw = SensorDraw(gyro_bias_rad_s=(0.01, 0.0, -0.02), noise_seed=11)
    model = SensorModel(twin, spec, draw, 0.002)
    n_joints = len(twin.qpos_adr)
    ticks = 3 * NOISE_BLOCK // (6 + n_joints + 6) + 7  # past three blocks, ending inside one
    reads = [model.read(d, 0.0) for _ in range(ticks)]
    rng = np.random.default_rng([11, 0])
    rotation, vel = d.xmat[twin.trunk].reshape(3, 3), np.zeros(6)
    mujoco.mj_objectVelocity(twin.model, d, mujoco.mjtObj.mjOBJ_XBODY, twin.trunk, vel, 1)
    soles = model._sole_truth(d)
    for m in reads:
        np.testing.assert_array_equal(m.trunk_rotation, rotation_vector(np.zeros(3) + rng.normal(0.0, 0.002, 3))
                                      @ rotation)
        np.testing.assert_array_equal(m.trunk_rate_rad_s, vel[:3] + np.asarray(draw.gyro_bias_rad_s)
                                      + rng.normal(0.0, 0.01, 3))
        np.testing.assert_array_equal(m.joints_rad, d.qpos[twin.qpos_adr] + np.zeros(n_joints)
                                      + rng.normal(0.0, 0.001, n_joints))
        for side in ("left", "right"):
            force, cop = soles[side]
            assert m.soles[side].force_n == max(0.0, force + float(rng.normal(0.0, 0.5)))
            np.testing.assert_array_equal(m.soles[side].cop_m, cop + rng.normal(0.0, 0.002, 2))


def test_a_reading_after_ticks_unread_is_the_reading_of_a_robot_that_read_every_tick():
    """A robot that does not look at its sensors at a tick (``tick``: a feed-forward robot between its estimates)
    still has their truth kept and their noise drawn: its next reading, delayed and noisy, is to the bit the one a
    robot reading at every tick gets, with the state of the tick the delay names; a tick further back than any
    reading reaches (``depth``) need not be kept."""
    import mujoco

    robot = load_robot("jethr1")
    twin, d = _posed(robot)
    spec = Sensors(ImuSpec("trunk", attitude_noise_rad=0.002, rate_noise_rad_s=0.01, delay_s=0.006),
                   EncoderSpec(noise_rad=0.001, resolution_rad=0.0005, delay_s=0.004))
    draw = SensorDraw(imu_tilt_bias_rad=(0.003, -0.004), yaw_drift_rad_s=0.001, noise_seed=5)
    every, some = SensorModel(twin, spec, draw, 0.002), SensorModel(twin, spec, draw, 0.002)
    for k in range(700):  # past one block of noise drawn ahead
        d.qpos[3:7] = (math.cos(0.001 * k), math.sin(0.001 * k), 0.0, 0.0)
        d.qpos[twin.qpos_adr[0]] = 0.01 * k
        mujoco.mj_forward(twin.model, d)
        a = every.read(d, 0.002 * k)
        if k % 300 == 299:
            b = some.read(d, 0.002 * k)
            assert np.array_equal(a.trunk_rotation, b.trunk_rotation) and np.array_equal(a.joints_rad, b.joints_rad)
            assert np.array_equal(a.trunk_rate_rad_s, b.trunk_rate_rad_s)
            # and the reading is a delayed one: the encoders' joint 0 two ticks back, within the noise
            assert abs(b.joints_rad[0] - 0.01 * (k - 2)) < 0.01
        else:
            some.tick(d, 0.002 * k, keep=k % 300 >= 299 - some.depth)
    assert some.depth == 4  # the IMU's 6 ms at 2 ms a tick, and the reading's own


def test_rotation_vector_is_rodrigues():
    from scipy.spatial.transform import Rotation

    for v in ([0.0, 0.0, 0.0], [0.01, -0.02, 0.3], [1.0, 2.0, -0.5]):
        np.testing.assert_allclose(rotation_vector(np.array(v)), Rotation.from_rotvec(v).as_matrix(), atol=1e-14)


def test_trials_draw_sensor_errors_within_the_declaration():
    robot = load_robot("jethr1")
    s = robot.sensors
    for k in range(50):
        p = Perturbation.draw(np.random.default_rng([3, k]), s, len(robot.joint_names))
        q = p.sensors
        assert math.hypot(*q.imu_tilt_bias_rad) <= s.imu.attitude_bias_rad + 1e-15
        assert max(abs(v) for v in q.gyro_bias_rad_s) <= s.imu.rate_bias_rad_s
        assert abs(q.yaw_drift_rad_s) <= s.imu.yaw_drift_rad_s
        assert len(q.encoder_offset_rad) == 12 and max(map(abs, q.encoder_offset_rad)) <= s.encoders.offset_rad
        assert s.imu.delay_s <= q.imu_delay_s <= 2 * s.imu.delay_s and q.sole_delay_s is None
        # the model errors are the same whether or not the sensors are drawn
        bare = Perturbation.draw(np.random.default_rng([3, k]))
        assert replace(p, sensors=None) == bare


def test_the_robots_own_kinematics_put_the_soles_where_the_twin_has_them():
    """Posed from true readings (no errors), the robot's model puts each sole where the twin does,
    relative to the trunk; its swing-sole Jacobian moves the sole as a finite difference does."""
    robot = load_robot("jethr1")
    twin, d = _posed(robot)
    kin = OwnKinematics(robot)
    R = d.xmat[twin.trunk].reshape(3, 3)
    kin.update(d.qpos[twin.qpos_adr], R)
    for side in ("left", "right"):
        p, Rs = kin.sole(side)
        np.testing.assert_allclose(p, d.xpos[twin.foot_bodies[side]] - d.qpos[:3], atol=1e-12)
        np.testing.assert_allclose(Rs, d.xmat[twin.foot_bodies[side]].reshape(3, 3), atol=1e-12)
    leg = np.array(robot.legs["left"].index)
    J = kin.sole_jacobian("left", leg)
    q = d.qpos[twin.qpos_adr].copy()
    p0, _ = kin.sole("left")
    h = 1e-7
    for n, j in enumerate(leg):
        dq = q.copy()
        dq[j] += h
        kin.update(dq, R)
        np.testing.assert_allclose((kin.sole("left")[0] - p0) / h, J[:3, n], atol=1e-5)


def test_the_controller_acts_on_what_the_imu_reads_not_on_the_twin(side_step, monkeypatch):
    """An IMU that reads the trunk 1.5° towards the swing fan beyond the truth: the IMU law adds thrust for
    the tilt it reads (it never sees the twin's level trunk), so the plan's thrust is exceeded where the
    robot, truly level, needed none more; with the truth read, it does not."""
    import jethr1_plan.sim.run as run_mod

    track = load_plan(side_step)
    honest = rehearse(track, "feedback", record=True)
    real_read = run_mod.SensorModel.read

    def leaning(self, d, t):
        m = real_read(self, d, t)
        # a 1.5° roll towards +y (the side step's left fan lies at +y of its right support sole)
        return Measurement(m.time_s, rotation_vector(np.array([-math.radians(1.5), 0.0, 0.0])) @ m.trunk_rotation,
                           m.trunk_rate_rad_s, m.joints_rad, m.soles)

    monkeypatch.setattr(run_mod.SensorModel, "read", leaning)
    fooled = rehearse(track, "feedback", record=True)
    swing = (track.phase == "swing")
    rows = np.clip(np.round(np.asarray(fooled.record["t"]) * track.rate_hz).astype(int), 0, len(track) - 1)
    in_swing = swing[rows]
    extra_fooled = (np.asarray(fooled.record["thrust"]).sum(axis=1) - track.thrust_cmd[rows].sum(axis=1))[in_swing]
    rows_h = np.clip(np.round(np.asarray(honest.record["t"]) * track.rate_hz).astype(int), 0, len(track) - 1)
    extra_honest = (np.asarray(honest.record["thrust"]).sum(axis=1)
                    - track.thrust_cmd[rows_h].sum(axis=1))[swing[rows_h]]
    assert np.median(extra_fooled) > np.median(extra_honest) + 2.0
