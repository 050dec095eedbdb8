"""An independent dynamic audit of a plan folder with pinocchio, reading only what was written:
trajectory.csv, summary.json (the robot's YAML path) and the robot's files (URDF and YAML).

None of jethr1_plan's code. Each row's configuration is built from the CSV's cells; the velocity and
acceleration at row i come from pinocchio's own difference on the configuration space
(d± = difference(q_i, q_i±1): v = (d⁺ − d⁻)/2Δt, a = (d⁺ + d⁻)/Δt², the strictest central stencil of the
written rows); RNEA's floating-base rows give the wrench the world must supply; the fans' written thrusts
(``thrust_<fan>_n`` along the fan's axis at the URDF frame the YAML names) supply part of it and the
ground the rest. The ground's share gives the dynamic ZMP; with v = a = 0 the same sum gives the
quasistatic ZMP that Paper A's model (and the CSV's ``zmp_*`` columns) state.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tests.oracles.walk_audit import _hull_margin, _model, read_folder

SIDES = ("left", "right")


@dataclass
class PlanAudit:
    """Per row (N,); rows 0 and N − 1 of the dynamic figures (their stencil reaches beyond the plan) are NaN."""

    t: np.ndarray
    support: list[str]
    zmp_static: np.ndarray  # (N, 2) quasistatic ZMP with the written thrust [m]
    zmp_dynamic: np.ndarray  # (N, 2) ZMP from the rows' central differences [m]
    margin_static: np.ndarray  # inside the support soles' hull [m]
    margin_dynamic: np.ndarray  # [m]
    friction_ratio: np.ndarray  # |horizontal ground force| / vertical ground force (dynamic)


def audit_plan(folder: Path) -> PlanAudit:
    """Audit the plan written in ``folder``."""
    import pinocchio as pin

    summary, rows, col = read_folder(folder)
    robot_yaml = Path(summary["robot_yaml"])
    model, rdoc = _model(robot_yaml)
    data = model.createData()
    n = len(rows)

    def column(name: str) -> np.ndarray:
        return np.array([float(r[col[name]]) for r in rows])

    t = column("time_s")
    support = [r[col["support"]] for r in rows]
    Q = np.zeros((n, model.nq))
    Q[:, :3] = np.column_stack([column(f"pelvis_{a}_m") for a in "xyz"])
    quat = np.column_stack([column(f"pelvis_q{a}") for a in "xyzw"])
    Q[:, 3:7] = quat / np.linalg.norm(quat, axis=1)[:, None]
    for name in (str(x) for x in model.names[2:]):
        Q[:, model.joints[model.getJointId(name)].idx_q] = column(f"{name}_rad")
    fans = [(model.getFrameId(fan["frame"]), np.asarray(fan["axis"], dtype=float), column(f"thrust_{fan['name']}_n"))
            for fan in rdoc["fans"]]
    sole = {s: model.getFrameId(rdoc["legs"][s]["sole"]) for s in SIDES}
    half = (float(rdoc["sole"]["length_m"]) / 2, float(rdoc["sole"]["width_m"]) / 2)
    dt = float(np.median(np.diff(t)))

    zs, zd = np.full((n, 2), np.nan), np.full((n, 2), np.nan)
    ms, md, fr = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    zero = np.zeros(model.nv)
    for i in range(n):
        pin.framesForwardKinematics(model, data, Q[i])
        down = SIDES if support[i] == "both" else (support[i],)
        corners = np.array([(data.oMf[sole[s]].rotation @ np.array([cx * half[0], cy * half[1], 0.0])
                             + data.oMf[sole[s]].translation)[:2]
                            for s in down for cx, cy in ((1, 1), (-1, 1), (-1, -1), (1, -1))])
        fan_force = np.zeros(3)
        fan_moment = np.zeros(3)
        for frame, axis, thrust in fans:
            M = data.oMf[frame]
            f = thrust[i] * (M.rotation @ axis)
            fan_force += f
            fan_moment += np.cross(M.translation, f)
        stencils = [(zero, zero, zs, ms, None)]
        if 0 < i < n - 1:
            d_plus = pin.difference(model, Q[i], Q[i + 1])
            d_minus = pin.difference(model, Q[i], Q[i - 1])
            stencils.append(((d_plus - d_minus) / (2 * dt), (d_plus + d_minus) / dt**2, zd, md, fr))
        for v, a, zmp, margin, friction in stencils:
            gen = pin.rnea(model, data, Q[i], v, a)
            base = data.oMi[1]
            force = base.rotation @ gen[:3]
            moment = base.rotation @ gen[3:6] + np.cross(base.translation, force)
            force, moment = force - fan_force, moment - fan_moment  # the ground's share
            zmp[i] = (-moment[1] / force[2], moment[0] / force[2])
            margin[i] = _hull_margin(zmp[i], corners)
            if friction is not None:
                friction[i] = np.hypot(force[0], force[1]) / force[2]
    return PlanAudit(t, support, zs, zd, ms, md, fr)
