"""``jethr1 replan-steps``: a multi-step scenario executed as a robot does it, one step at a time, each
planned from where the previous one really landed.

What the robot does between steps: after each swing the plan ends with a double-support transfer and
the robot stands still. There it measures where both soles are (in the twin: the soles' poses at the
end of the rehearsal's hold), and the next step is planned afresh from those measured soles to the
scenario's landing of that step, which stays where the scenario puts it on its carton (a world
target, not a displacement). An arc path is drawn again from the measured sole; a path of points
keeps its shape and is re-anchored (:func:`reanchor`). So a step's landing error is that step's
own, and errors do not add up from step to step, as they do when every step is planned from where
the previous one was supposed to land (the whole scenario planned at once and replayed feed-forward).

Each one-step scenario is a scenario file of its own (the original with ``start`` and ``steps``
replaced), validated like any other, planned and checked by :func:`pipeline.plan.plan_to_folder`
into ``OUT/<name>/<name>_step<k>/``, and rehearsed in the MuJoCo twin (``sim.rehearsal``). The
rehearsal of a step starts from that plan's first row (the robot standing on the measured soles)
after the twin's settling time: what carries over from step to step is where the soles are, not the
twin's internal state (servo sag, contact forces); the robot is standing still there.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from jethr1_plan.geometry import SIDES
from jethr1_plan.scenario import Scenario, load_scenario_text

__all__ = ["measured_soles", "reanchor", "replan_steps", "step_scenario"]


def reanchor(points_m: np.ndarray, start_m: np.ndarray) -> np.ndarray:
    """A swing path (N, 3) [m] moved to begin at ``start_m``: the offset of its first point fades out
    along the path's length (a smoothstep), so its last point, the landing, stays where it was."""
    pts = np.asarray(points_m, dtype=float)
    length = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    s = length / length[-1] if length[-1] > 0 else np.linspace(0.0, 1.0, len(pts))
    fade = 1.0 - s * s * (3.0 - 2.0 * s)
    out = pts + fade[:, None] * (np.asarray(start_m, dtype=float) - pts[0])
    out[0], out[-1] = start_m, pts[-1]
    return out


def step_scenario(scenario: Scenario, k: int, feet_m: dict[str, np.ndarray]) -> Scenario:
    """Step ``k`` of ``scenario`` alone, from soles at ``feet_m`` [m] (side -> (3,)) to the scenario's
    landing of that step, as a scenario file of its own (named ``<name>_step<k>``).

    Raises:
        InputError: the measured soles or the step from them break the scenario's rules (a sole off
            its carton, a path into a carton).
    """
    doc = yaml.safe_load(scenario.text)
    step = dict(doc["steps"][k])
    path = dict(step.get("path", {"kind": "arc"}))
    if path["kind"] == "points":
        path["points_m"] = reanchor(np.array(path["points_m"], dtype=float), feet_m[step["swing"]]).tolist()
        step["path"] = path
    doc.update(name=f"{scenario.name}_step{k}", start={str(s): [float(v) for v in feet_m[s]] for s in SIDES},
               steps=[step])
    doc.pop("expect", None)
    return load_scenario_text(yaml.safe_dump(doc, sort_keys=False), f"{scenario.name}_step{k}.yaml")


def measured_soles(track, qpos: np.ndarray) -> dict[str, tuple[np.ndarray, float]]:
    """Each sole's centre (3,) [m] and yaw [rad] in the twin for the state ``qpos`` (free joint
    position, quaternion w, x, y, z, then the joints in the robot's order), by forward kinematics."""
    import mujoco

    from jethr1_plan.sim.twin import build_twin

    twin = build_twin(track.robot, track.cartons)
    d = mujoco.MjData(twin.model)
    d.qpos[:7] = qpos[:7]
    d.qpos[twin.qpos_adr] = qpos[7:]
    mujoco.mj_forward(twin.model, d)
    out = {}
    for s in SIDES:
        b = twin.foot_bodies[s]
        out[s] = (d.xpos[b].copy(), math.atan2(d.xmat[b][3], d.xmat[b][0]))
    return out


def replan_steps(scenario: Scenario, outdir: Path, controller: str = "feedforward", progress=None) -> dict[str, Any]:
    """Plan, rehearse and measure each step of ``scenario`` in turn, each planned from the soles the
    previous rehearsal measured (the module docstring); the plans go to ``outdir/<name>_step<k>/``.

    Returns the report: per step, where the swing sole landed against the scenario's landing
    (``landing_error_m``, xy), the support sole's drift from where it stood, the rehearsal's verdict,
    tilt and slip; and the largest landing error.
    """
    from jethr1_plan.pipeline.plan import plan_to_folder
    from jethr1_plan.sim.rehearsal import Perturbation, load_plan, simulate

    feet = {s: np.asarray(scenario.start[s], dtype=float).copy() for s in SIDES}
    targets = [st.landing_m for st in scenario.steps]
    steps: list[dict[str, Any]] = []
    for k, st in enumerate(scenario.steps):
        one = step_scenario(scenario, k, feet)
        result, summary, folder, _ = plan_to_folder(one, outdir)
        run = simulate(folder, controller, [Perturbation()])[0]
        assert run.record is not None  # the first run is recorded
        soles = measured_soles(load_plan(folder), np.asarray(run.record["qpos"][-1], dtype=float))
        landed, yaw = soles[st.swing]
        err = landed[:2] - targets[k][:2]
        support = soles[st.support][0]
        drift = support[:2] - feet[st.support][:2]
        steps.append({"step": k, "swing": st.swing, "folder": folder.name, "feasible": result.feasible,
                      "max_thrust_n": summary["trajectory"]["max_thrust_n"],
                      "start_m": {str(s): [float(v) for v in feet[s]] for s in SIDES},
                      "landing_target_m": [float(v) for v in targets[k]],
                      "landed_m": [float(v) for v in landed], "landed_yaw_rad": float(yaw),
                      "landing_error_m": float(np.hypot(*err)), "landing_error_xy_m": [float(v) for v in err],
                      "support_drift_m": float(np.hypot(*drift)), "survived": run.survived, "fell": run.fell,
                      "max_trunk_tilt_deg": run.max_trunk_tilt_deg, "support_max_slip_m": run.support_max_slip_m,
                      "least_cop_margin_m": run.least_cop_margin_m})
        if progress:
            progress(f"step {k}", k + 1, len(scenario.steps))
        if not run.survived:
            break
        # the next step starts from the soles where they are (on their carton tops: z as planned)
        feet = {s: np.array([soles[s][0][0], soles[s][0][1], (targets[k] if s == st.swing else feet[s])[2]])
                for s in SIDES}
    errors = [s["landing_error_m"] for s in steps]
    return {"scenario": scenario.name, "controller": controller, "steps": steps,
            "all_survived": len(steps) == len(scenario.steps) and all(s["survived"] for s in steps),
            "max_landing_error_m": max(errors) if errors else None}
