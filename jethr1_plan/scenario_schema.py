"""The scenario file's schema: every key known, every number bounded (a typo such as ``samples: 1e8`` is a
one-line error, not an hour of work or a full memory), and the names its choices take. :mod:`.scenario` reads a
scenario against it and then checks what a schema cannot (the geometry, the robot).
"""

from __future__ import annotations

from jethr1_plan.optimisers import METHODS

__all__ = ["DEFAULT_CARTON_M", "F3_UNITS", "MAX_FILE_BYTES", "MAX_ROWS", "MAX_SAMPLES", "MAX_VALUES", "MIN_PHASE_ROWS",
           "MIN_RATE_HZ", "POLICIES", "SCHEMA", "TIMING_MODES", "TOLERANCE_KEYS", "YAW_MODES"]

DEFAULT_CARTON_M = (0.21, 0.11, 0.14)
F3_UNITS = {"mm": 0.001, "m": 1.0}
YAW_MODES = ("eq4", "mpc", "forward_axis", "fixed")
POLICIES = ("robust", "minimal")
TIMING_MODES = ("fixed", "fastest")

# Bounds say what the machine can hold and what a scenario means.
MAX_FILE_BYTES = 1_000_000  # a scenario is a few kilobytes
MAX_VALUES = 100_000  # values in the document, aliases expanded (a scenario has a few hundred)
MAX_ROWS = 200_000  # output rows of a plan (rate × duration): ~200 MB of CSV and MCAP
MAX_SAMPLES = 1000  # swing samples per step (each one is optimised)
MIN_RATE_HZ = 10.0  # the servos and fans are commanded at least this often: a fan's lag is ~50 ms (0.1 s a row at most)
MIN_PHASE_ROWS = 5  # rows in every swing and every transfer: a phase of fewer is not a motion the rows describe
_num = {"type": "number", "minimum": -1e9, "maximum": 1e9}
_pos = {"type": "number", "exclusiveMinimum": 0, "maximum": 1e9}
_prob = {"type": "number", "minimum": 0, "maximum": 1}
_coord = {"type": "number", "minimum": -100, "maximum": 100}  # [m]
_vec3 = {"type": "array", "items": _coord, "minItems": 3, "maxItems": 3}
_size3 = {"type": "array", "items": {"type": "number", "exclusiveMinimum": 0, "maximum": 10}, "minItems": 3,
          "maxItems": 3}
_duration = {"type": "number", "exclusiveMinimum": 0, "maximum": 300}  # [s]


def _obj(props: dict, required: tuple = ()) -> dict:
    return {"type": "object", "properties": props, "required": list(required), "additionalProperties": False}


_phase = _obj({"population": {"type": "integer", "minimum": 2, "maximum": 10000},
               "generations": {"type": "integer", "minimum": 1, "maximum": 10000},
               "half_range_m": {"type": "number", "exclusiveMinimum": 0, "maximum": 1}, "crossover": _prob,
               "mutation": _prob})

SCHEMA = _obj({
    "name": {"type": "string", "minLength": 1, "maxLength": 100, "pattern": r"^(?!\.\.?$)[^/\\\x00-\x1f]+$",
             "description": "a plain name: it names folders (replan-steps' OUTDIR/<name>/), so no '/', not '.' or "
                            "'..', no control characters"},
    "description": {"type": "string", "maxLength": 5000},
    "robot": {"type": "string", "minLength": 1, "maxLength": 1000},
    "seed": {"type": "integer", "minimum": 0, "maximum": 2**63 - 1},
    "start": _obj({"left": _vec3, "right": _vec3}, ("left", "right")),
    "terrain": _obj({
        "carton_size_m": _size3,
        "cartons": {"type": "array", "maxItems": 200, "items": _obj({"top_centre_m": _vec3, "size_m": _size3},
                                                                    ("top_centre_m",))},
    }),
    "steps": {"type": "array", "minItems": 1, "maxItems": 50, "items": _obj({
        "swing": {"enum": ["left", "right"]},
        "landing_m": _vec3,
        "path": {"oneOf": [
            _obj({"kind": {"const": "arc"}, "clearance_m": {"type": "number", "minimum": 0, "maximum": 2},
                  "samples": {"type": "integer", "minimum": 2, "maximum": MAX_SAMPLES},
                  "lift_m": {"type": "number", "minimum": 0, "maximum": 0.2},
                  "descent_m": {"type": "number", "minimum": 0, "maximum": 0.2}}, ("kind",)),
            _obj({"kind": {"const": "points"},
                  "points_m": {"type": "array", "items": _vec3, "minItems": 2, "maxItems": MAX_SAMPLES}},
                 ("kind", "points_m")),
        ]},
    }, ("swing",))},
    "optimiser": _obj({
        "method": {"enum": list(METHODS)},
        "initial": _phase,
        "intermediate": _phase,
        "bits": {"type": "integer", "minimum": 2, "maximum": 20},
        "fitness": _obj({"c1": _num, "c2": _num, "c4_1": _num, "c4_2": _num,
                         "omega": {"type": "number", "minimum": 0, "maximum": 1e9},
                         "f3_unit": {"enum": list(F3_UNITS)}, "graded": {"type": "boolean"}}),
        "gaex": _obj({"half_m": {"type": "number", "exclusiveMinimum": 0, "maximum": 0.05},
                      "step_m": {"type": "number", "minimum": 0.0005, "maximum": 0.05}}),
        "sqp": _obj({"smoothness_n_per_m2": {"type": "number", "minimum": 0, "maximum": 1e9}}),
        "nominal_height_m": {"type": "number", "exclusiveMinimum": 0, "maximum": 10},
    }),
    "balance": _obj({"thrust_max_n": {"type": "number", "minimum": 0, "maximum": 1e4},
                     "rho_rad": {"type": "number", "minimum": 0, "maximum": 1.5707963267948966},
                     "sole_margin_m": {"type": "number", "minimum": 0, "maximum": 0.1},
                     "policy": {"enum": list(POLICIES)},
                     "robust": _obj({"thrust_error": {"type": "number", "minimum": 0, "maximum": 0.9},
                                     "mass_error": {"type": "number", "minimum": 0, "maximum": 0.9},
                                     "com_error_m": {"type": "number", "minimum": 0, "maximum": 0.1},
                                     "min_share": _prob})}),
    "body_yaw": _obj({"mode": {"enum": list(YAW_MODES)}, "fixed_rad": {"type": "number", "minimum": -7, "maximum": 7},
                      "horizon_s": {"type": "number", "exclusiveMinimum": 0, "maximum": 10},
                      "alpha": {"type": "number", "minimum": 0, "maximum": 1e9},
                      "beta": {"type": "number", "minimum": 0, "maximum": 1e9}}),
    "timing": _obj({"swing_s": _duration, "transfer_s": _duration,
                    "rate_hz": {"type": "number", "minimum": MIN_RATE_HZ, "maximum": 1000},
                    "mode": {"enum": list(TIMING_MODES)},
                    "dynamic_share": {"type": "number", "minimum": 0, "maximum": 0.99},
                    "safety_factor": {"type": "number", "minimum": 0.1, "maximum": 1},
                    "spin_down_n": {"type": "number", "minimum": 0.01, "maximum": 100},
                    "min_swing_s": {"type": "number", "minimum": 0, "maximum": 300},
                    "min_transfer_s": {"type": "number", "minimum": 0, "maximum": 300},
                    "max_swing_s": _duration, "max_transfer_s": _duration}),
    "expect": _obj({"feasible": {"type": "boolean"},
                    "peak_thrust_n": {"type": "number", "minimum": 0, "maximum": 1e4}}),
}, ("steps",))

#: the YAML's names of a Tolerance's fields (``balance.robust``)
TOLERANCE_KEYS = {"thrust_error": "thrust", "mass_error": "mass", "com_error_m": "com_m"}
