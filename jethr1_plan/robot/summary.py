"""What ``jethr1 robot show`` reports of a loaded robot (every figure computed from the model)."""

from __future__ import annotations

from jethr1_plan.geometry import GRAVITY
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.robot.schema import LEG_ROLES

__all__ = ["robot_summary"]


def robot_summary(model: RobotModel) -> dict:
    """The figures of ``jethr1 robot show --json`` (SI units)."""
    return {
        "name": model.name,
        "urdf": str(model.urdf_path),
        "mass_kg": model.mass_kg,
        "height_m": model.height_m,
        "leg_length_m": model.leg_length_m,
        "hip_width_m": 2 * model.hip_offset_m,
        "joints": [
            {
                "name": n,
                "lower_rad": float(lo),
                "upper_rad": float(hi),
                "effort_nm": float(e),
                "servo_limit_nm": float(s),
            }
            for n, lo, hi, e, s in zip(
                model.joint_names, model.lower_rad, model.upper_rad, model.effort_nm, model.servo_limit_nm, strict=True
            )
        ],
        "fans": [
            {"name": f.name, "frame": f.frame, "mount": f.mount, "thrust_max_n": f.thrust_max_n,
             "offset_m": list(f.offset_m), "lag_s": f.lag_s}
            for f in model.fans
        ],
        "trunk": model.trunk,
        "legs": {s: {"sole": leg.sole, "joints": dict(zip(LEG_ROLES, leg.joints, strict=True))}
                 for s, leg in model.legs.items()},
        "stance_width_m": model.stance_width_m,
        "sole": {"length_m": model.sole_length_m, "width_m": model.sole_width_m},
        "weight_n": model.mass_kg * GRAVITY,
        "sensors": model.sensors.describe(),
        "feedback_law": model.feedback_law,
        "landing_error_m": model.landing_error_m,
    }
