"""One walk from its file to its verdict: generate it (Paper B's pipeline), analyse it (κ, torques,
the multibody ZMP, E_con), judge it against the walk's success criteria and rehearse it in the
MuJoCo twin."""

from __future__ import annotations

import numpy as np

from jethr1_plan.control.commands import servo_commands
from jethr1_plan.sim.walk_rehearsal import rehearse_walk
from jethr1_plan.walking.analysis import analyse, judge
from jethr1_plan.walking.result import WALK_SAG_FILTER_S, WalkResult, generate_walk
from jethr1_plan.walking.spec import WalkSpec

__all__ = ["run_walk"]


def run_walk(spec: WalkSpec, rehearse: bool | None = None) -> WalkResult:
    """Generate, analyse, judge and (``rehearse``, default the spec's ``success.rehearse``) rehearse a walk."""
    walk = generate_walk(spec)
    a = analyse(walk)
    s = spec.success
    verdict = judge(walk, a, s)
    commands = servo_commands(walk.q, a.tau, spec.robot.servo_stiffness_nm_per_rad, spec.timing.control_hz,
                              WALK_SAG_FILTER_S)
    run = rehearse_walk(walk, commands) if (s.rehearse if rehearse is None else rehearse) else None
    armless = None
    if spec.arms.enabled and spec.robot.walking.arm_swing:
        held = generate_walk(spec.varied(arms=False))
        armless = float(np.max(np.abs(held.h_low + held.h_up)))
    return WalkResult(spec, walk, a, verdict, run, armless, commands)
