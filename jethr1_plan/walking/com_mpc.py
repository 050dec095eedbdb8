"""The CoM by model predictive control on the LIPM (Paper B, IV-A, eqs. B-10..B-18), with PlaCo's
``LIPM`` and ``Problem``.

The CoM moves at a constant height z_c; its horizontal state (position, velocity, acceleration) is
integrated from a piecewise-constant jerk (B-10..B-13), and the ZMP is z = x − (z_c/g)·ẍ (B-14,
B-15). At every update an N-step horizon is optimised (B-18):

    min  α/2·‖Z − Z_ref‖² + β/2·‖ΔV‖² + γ/2·‖U‖²    s.t.  Z in the support polygon at every step

with ΔV the CoM velocity's change from one step to the next (the "velocity fluctuation" of [12],
here read as v_k − v_(k−1)) and U the jerks; the first interval is applied and the problem is solved
again from the new state (receding horizon). The predicted CoM over the horizon (B-25, B-26) is
what the pelvic-rotation reference looks ahead at.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jethr1_plan.geometry import GRAVITY, halfplanes
from jethr1_plan.walking.timeline import Timeline, polygon_of

__all__ = ["CoMPlan", "CoMSettings", "plan_com"]

@dataclass(frozen=True)
class CoMSettings:
    """(B-18)'s settings (SI units)."""

    height_m: float  # z_c
    dt_s: float = 0.1  # the MPC's step: the jerk is constant over it; the problem is solved again after it
    horizon_s: float = 1.6
    zmp_weight: float = 1.0  # α
    velocity_weight: float = 1e-2  # β
    jerk_weight: float = 1e-6  # γ
    zmp_margin_m: float = 0.02  # the support polygon is shrunk by this [m]


@dataclass
class CoMPlan:
    """The CoM at every control step, and what each MPC update predicted over its horizon."""

    t: np.ndarray  # (N,) [s]
    pos: np.ndarray  # (N, 2) [m]
    vel: np.ndarray  # (N, 2) [m/s]
    acc: np.ndarray  # (N, 2) [m/s²]
    zmp: np.ndarray  # (N, 2) the LIPM's ZMP [m]
    zmp_ref: np.ndarray  # (N, 2) [m]
    update_t: np.ndarray  # (U,) the times of the MPC updates [s]
    predicted: np.ndarray  # (U, H, 2) the CoM each update predicts at its horizon's steps [m]


def _affine(A: np.ndarray, b: np.ndarray):
    """The PlaCo expression A·x + b."""
    import placo

    e = placo.Expression()
    e.A, e.b = A, b
    return e


def _stack(exprs: list):
    """PlaCo expressions stacked into one."""
    return _affine(np.vstack([e.A for e in exprs]), np.concatenate([e.b for e in exprs]))


class _Condensed:
    """(B-12..B-17) condensed: every step's position, velocity and ZMP as A·U + b(x_0), U the 2N jerks
    (x's N, then y's N), A from ``placo.LIPM`` (built once: it depends on the step and the horizon
    only), b the free motion from the initial state x_0 = (position, velocity, acceleration)."""

    def __init__(self, dt: float, horizon: int, omega2: float):
        import placo

        problem = placo.Problem()  # held while the LIPM's expressions are read (PlaCo keeps a reference)
        lipm = placo.LIPM(problem, dt, horizon, 0.0, np.zeros(2), np.zeros(2), np.zeros(2))
        self.dt, self.n, self.omega2 = dt, horizon, omega2
        self.zmp_A = _stack([lipm.zmp(k, omega2) for k in range(1, horizon + 1)]).A
        self.pos_A = _stack([lipm.pos(k) for k in range(1, horizon + 1)]).A
        vel = [lipm.vel(k) for k in range(horizon + 1)]
        self.dvel_A = np.vstack([vel[k].A - vel[k - 1].A for k in range(1, horizon + 1)])
        self.jerk_A = _stack([lipm.jerk(k) for k in range(horizon)]).A

    def free(self, state: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """b of the ZMP (2N,), the velocity (2N + 2,: steps 0..N) and the position (2N,) from ``state``
        (2, 3): rows x, y; columns position, velocity, acceleration."""
        tk = self.dt * np.arange(self.n + 1)[:, None]
        p0, v0, a0 = state[:, 0], state[:, 1], state[:, 2]
        pos = p0 + v0 * tk + a0 * tk ** 2 / 2
        vel = v0 + a0 * tk
        zmp = pos - np.broadcast_to(a0, pos.shape) / self.omega2
        return zmp[1:].ravel(), vel.ravel(), pos[1:].ravel()


def plan_com(timeline: Timeline, settings: CoMSettings, control_dt_s: float) -> CoMPlan:
    """Run the MPC over the whole walk, starting at rest over the stance's midpoint; sample the CoM
    every ``control_dt_s`` [s]."""
    import placo

    omega2 = GRAVITY / settings.height_m
    dt = settings.dt_s
    horizon = max(2, round(settings.horizon_s / dt))
    duration = timeline.duration_s
    updates = int(np.ceil(duration / dt - 1e-9))
    sub = round(dt / control_dt_s)
    if abs(sub * control_dt_s - dt) > 1e-9:
        raise ValueError("the MPC step must be a multiple of the control period")
    start = timeline.zmp_reference(np.array([0.0]))[0]
    state = np.column_stack([start, np.zeros(2), np.zeros(2)])  # rows x, y; columns pos, vel, acc
    polygons: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
    rows: dict[str, list] = {"t": [], "pos": [], "vel": [], "acc": []}
    predicted = np.zeros((updates, horizon, 2))
    model = _Condensed(dt, horizon, omega2)
    for u in range(updates):
        t0 = u * dt
        times = np.minimum(t0 + dt * np.arange(1, horizon + 1), duration)
        refs = timeline.zmp_reference(times)
        keys = timeline.support_keys(times)
        zmp_b, vel_b, pos_b = model.free(state)
        problem = placo.Problem()
        problem.add_variable(2 * horizon)
        problem.add_constraint(_affine(model.zmp_A, zmp_b) == refs.ravel()).configure("soft", settings.zmp_weight)
        rows_a, rows_b = [], []
        for k, key in enumerate(keys):  # the ZMP in its support polygon: n·z ≤ offset for every edge
            if key not in polygons:
                polygons[key] = halfplanes(polygon_of(key, timeline.sole_length_m, timeline.sole_width_m,
                                                       settings.zmp_margin_m))
            normals, offsets = polygons[key]
            rows_a.append(normals @ model.zmp_A[2 * k:2 * k + 2])
            rows_b.append(normals @ zmp_b[2 * k:2 * k + 2] - offsets)
        problem.add_constraint(_affine(np.vstack(rows_a), np.concatenate(rows_b)) <= 0.0)
        fluctuation = _affine(model.dvel_A, vel_b[2:] - vel_b[:-2])
        problem.add_constraint(fluctuation == np.zeros(2 * horizon)).configure("soft", settings.velocity_weight)
        problem.add_constraint(_affine(model.jerk_A, np.zeros(2 * horizon)) == np.zeros(2 * horizon)).configure(
            "soft", settings.jerk_weight)
        problem.solve()
        x = np.asarray(problem.x, dtype=float)  # the jerks: x's N, then y's N
        predicted[u] = (model.pos_A @ x + pos_b).reshape(horizon, 2)
        # the first interval, integrated exactly (its jerk is constant: B-12, B-13)
        tau = control_dt_s * np.arange(sub + 1)[:, None]
        j0 = np.array([x[0], x[horizon]])
        p0, v0, a0 = state[:, 0], state[:, 1], state[:, 2]
        pos = p0 + v0 * tau + a0 * tau ** 2 / 2 + j0 * tau ** 3 / 6
        vel = v0 + a0 * tau + j0 * tau ** 2 / 2
        acc = a0 + j0 * tau
        rows["t"].extend((t0 + tau[:sub, 0]).tolist())
        rows["pos"].extend(pos[:sub])
        rows["vel"].extend(vel[:sub])
        rows["acc"].extend(acc[:sub])
        state = np.column_stack([pos[sub], vel[sub], acc[sub]])
    t_out = np.asarray(rows["t"])
    keep = t_out <= duration + 1e-9
    pos, vel, acc = (np.asarray(rows[k])[keep] for k in ("pos", "vel", "acc"))
    t_out = t_out[keep]
    return CoMPlan(t_out, pos, vel, acc, pos - acc / omega2, timeline.zmp_reference(t_out),
                   dt * np.arange(updates), predicted)
