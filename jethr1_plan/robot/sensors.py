"""What a robot measures, as its YAML declares it (``sensors:``): the IMU, the joints' encoders, the soles'
force sensors and the perception error, with the noise, bias and delay bounds of each (SI units), and the
sensors each thrust feedback law reads. The twin's sensors (``sim.sensors``) read these declarations.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from jethr1_plan.errors import RobotModelError

__all__ = ["LAW_SENSORS", "EncoderSpec", "ImuSpec", "Sensors", "SoleSensorSpec", "declared_sensors", "sensor_names"]


@dataclass(frozen=True)
class ImuSpec:
    """An IMU on the trunk (the robot YAML's ``sensors.imu``): what it measures is the trunk's attitude
    (roll, pitch from gravity; yaw integrated from the gyro) and angular rate; SI units. Noise is white
    (1 σ per sample); a bias is constant over a run, drawn within ± the bound by randomised trials."""

    frame: str  # the frame it is fixed to (the trunk)
    attitude_noise_rad: float = 0.0  # [rad] 1 σ on roll and pitch (and yaw)
    attitude_bias_rad: float = 0.0  # [rad] bound of the roll and pitch bias
    rate_noise_rad_s: float = 0.0  # [rad/s] 1 σ per axis
    rate_bias_rad_s: float = 0.0  # [rad/s] bound of the gyro's bias per axis
    yaw_drift_rad_s: float = 0.0  # [rad/s] bound of the heading's drift (the gyro's z bias, integrated)
    delay_s: float = 0.0  # [s] from the motion to the reading


@dataclass(frozen=True)
class EncoderSpec:
    """The joints' encoders (``sensors.encoders``): each servo's output angle; SI units."""

    noise_rad: float = 0.0  # [rad] 1 σ per sample
    resolution_rad: float = 0.0  # [rad] the reading is a multiple of this (0: continuous)
    offset_rad: float = 0.0  # [rad] bound of each joint's zero offset (calibration), drawn by randomised trials
    delay_s: float = 0.0  # [s]


@dataclass(frozen=True)
class SoleSensorSpec:
    """Force sensors under each sole (``sensors.soles``): the normal force and its centre of pressure in the
    sole's frame; SI units."""

    force_noise_n: float = 0.0  # [N] 1 σ
    cop_noise_m: float = 0.0  # [m] 1 σ per axis
    delay_s: float = 0.0  # [s]


@dataclass(frozen=True)
class Sensors:
    """What the robot measures (the robot YAML's ``sensors:``): the twin's controllers see the robot only
    through these (``sim.sensors``). ``perception_error_m``: how well the robot knows where the next
    foothold lies relative to its support sole when it plans a step from where it stands (a person or a
    camera measuring the cartons) [m], a bound."""

    imu: ImuSpec | None = None
    encoders: EncoderSpec | None = None
    soles: SoleSensorSpec | None = None
    perception_error_m: float = 0.0

    @property
    def names(self) -> tuple[str, ...]:
        """The sensors present, by name: ``imu``, ``encoders``, ``soles``."""
        return tuple(n for n in ("imu", "encoders", "soles") if getattr(self, n) is not None)

    def describe(self) -> dict:
        """The declaration as ``summary.json`` and ``simulation.json`` state it (SI units)."""
        return {"imu": None if self.imu is None else asdict(self.imu),
                "encoders": None if self.encoders is None else asdict(self.encoders),
                "soles": None if self.soles is None else asdict(self.soles),
                "perception": {"landing_error_m": self.perception_error_m}}


#: what each thrust law reads (``controller.law``): the sensors it needs
LAW_SENSORS = {"imu_tilt_pid": ("imu", "encoders"), "cop_edge_pi": ("soles", "encoders")}



def sensor_names(doc: dict) -> list[str]:
    """The sensors a robot YAML's ``sensors:`` declares, by name."""
    block = doc.get("sensors", {})
    return [n for n in ("imu", "encoders", "soles") if block.get(n) is not None]


def declared_sensors(doc: dict, trunk: str, frames: set[str], src: str) -> Sensors:
    """``sensors:``: the IMU (on the trunk), the encoders, the soles' force sensors, the perception error."""
    block = doc.get("sensors", {})
    imu = block.get("imu")
    if imu is not None:
        imu = dict(imu)
        frame = imu.pop("frame", trunk)
        if frame != trunk:
            raise RobotModelError(src, "sensors.imu.frame", f"{frame!r}: the IMU is modelled on the trunk ({trunk!r})"
                                  if frame in frames else f"frame {frame!r} not in the URDF")
        imu = ImuSpec(frame, **{k: float(v) for k, v in imu.items()})
    enc = block.get("encoders")
    soles = block.get("soles")
    return Sensors(imu=imu,
                   encoders=None if enc is None else EncoderSpec(**{k: float(v) for k, v in enc.items()}),
                   soles=None if soles is None else SoleSensorSpec(**{k: float(v) for k, v in soles.items()}),
                   perception_error_m=float(block.get("perception", {}).get("landing_error_m", 0.0)))
