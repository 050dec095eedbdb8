"""A plan's rows as the checks of :mod:`.plan_checks` read them: the written columns and what is
recomputed from them, each once: forward kinematics of each row's pelvis pose and joints in a fresh
PlaCo robot (soles, CoM, fans, static torques, κ), the ZMP of the written thrust (A-1, A-2), the
support polygons and thrust windows (:mod:`.balance`), the ground's force the rows' motion needs
(:mod:`.motion`), and where the scenario puts the soles. Nothing here calls the planner's physics,
planning, control or optimisers (``tools/check_imports.py``)."""

from __future__ import annotations

import math
from functools import cached_property
from typing import Any

import numpy as np

from jethr1_plan.geometry import SIDES, other_side, pose_from_quaternion
from jethr1_plan.records.plan_columns import PELVIS, TOLERANCE_SHARE, WINDOW
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.verify.balance import sole_edges, thrust_window, zmp_of_thrust
from jethr1_plan.verify.motion import vertical_ground_force
from jethr1_plan.verify.plan_geometry import pair_hull_edges

__all__ = ["OPTIONAL", "TEXT", "RowData", "batched_statics", "expected_sequence", "ground_references",
           "scenario_feet"]

TEXT = ("phase", "support", "reason", "feasible")  # the columns that are not numbers
# empty (NaN) where there is no swing sole, no window, or no tolerance (the share: its own check)
OPTIONAL = ("swing_", "thrust_window_", TOLERANCE_SHARE)


class RowData:
    """The written columns of a plan and what the checks recompute from them (each once)."""

    def __init__(self, c: dict[str, np.ndarray], robot: RobotModel, swing_paths: list[np.ndarray] | None,
                 start_feet: dict[str, np.ndarray] | None, balance: dict | None, summary: dict | None, scenario,
                 torque_limits: bool):
        self.c, self.robot, self.swing_paths, self.start_feet = c, robot, swing_paths, start_feet
        self.summary, self.scenario, self.torque_limits = summary, scenario, torque_limits
        self.balance = balance if balance is not None else (summary or {}).get("balance")
        self.n = len(c["time_s"])
        self.fans = robot.fans
        fmax = np.array([f.thrust_max_n for f in self.fans])
        limit = (summary or {}).get("thrust_max_n")
        self.fmax = np.minimum(fmax, float(limit)) if isinstance(limit, int | float) else fmax
        self.support = c["support"]
        self.single = self.support != "both"

    # --- the written values -----------------------------------------------------------------------

    @cached_property
    def finite(self) -> np.ndarray:
        """(n,) rows whose every number (but those that may be empty) is finite."""
        ok = np.ones(self.n, dtype=bool)
        for k, v in self.c.items():
            if k not in TEXT and not k.startswith(OPTIONAL):
                ok &= np.isfinite(v.astype(float))
        return ok

    @cached_property
    def q_written(self) -> np.ndarray:
        return np.stack([self.c[f"{j}_rad"] for j in self.robot.joint_names], axis=1).astype(float)

    @cached_property
    def q(self) -> np.ndarray:
        """(n, J) the joints, 0 where a cell is empty (that row fails "not a number")."""
        return np.where(np.isfinite(self.q_written), self.q_written, 0.0)

    @cached_property
    def thrust(self) -> np.ndarray:
        return np.stack([self.c[f"thrust_{f.name}_n"] for f in self.fans], axis=1).astype(float).reshape(
            self.n, len(self.fans))

    @cached_property
    def quat(self) -> np.ndarray:
        return np.stack([self.c[f"pelvis_q{k}"] for k in "xyzw"], axis=1).astype(float)

    @property
    def statics(self) -> bool:
        return f"{self.robot.joint_names[0]}_tau_nm" in self.c

    # --- recomputed ---------------------------------------------------------------------------------

    @cached_property
    def fk(self) -> dict:
        """Per row, from the written pelvis pose and joints (fresh PlaCo robot): both sole poses (n, 4, 4),
        the CoM (n, 3), every fan's ground point (n, F, 2); with the torque columns also the static
        torques under the written thrust (n, J) and each leg's κ (n, 2). A row whose pose is not finite
        is left at zero (NaN torques): it fails "not a number".

        PlaCo gives each row's frames, CoM, gravity torques and Jacobians; the torques and κ are then
        solved for every row at once (:func:`batched_statics`), as ``physics.statics`` does row by row."""
        robot, c, n = self.robot, self.c, self.n
        wrapper = robot.wrapper()
        nf, nv = len(robot.fans), 6 + len(robot.joint_names)
        out: dict[str, Any] = {"feet": {s: np.zeros((n, 4, 4)) for s in SIDES},
                               "fans": np.zeros((n, nf, 2)), "com": np.zeros((n, 3)),
                               "tau": np.full((n, len(robot.joint_names)), np.nan), "kappa": np.full((n, 2), np.nan)}
        pelvis = np.stack([c[k] for k in PELVIS], axis=1).astype(float)
        posed = np.isfinite(pelvis).all(axis=1) & np.isfinite(self.q_written).all(axis=1)
        norms = np.array([math.sqrt(float(q @ q)) for q in self.quat])
        posed &= np.isfinite(norms) & (norms >= 1e-9)
        rows_posed = np.flatnonzero(posed)
        statics = self.statics
        gravity = np.zeros((n, nv))
        jac = {s: np.zeros((n, 6, nv)) for s in SIDES}
        fan_z = np.zeros((n, nf, nv))  # the vertical-force row of each fan's Jacobian
        soles = [robot.legs[s].sole for s in SIDES]
        fan_frames = [fan.frame for fan in robot.fans]
        feet, fans_xy, com = out["feet"], out["fans"], out["com"]
        for i in rows_posed.tolist():
            quat = self.quat[i] / norms[i]
            wrapper.set_T_world_fbase(pose_from_quaternion(pelvis[i].tolist(), quat.tolist()))
            wrapper.state.q[7:] = self.q[i]
            wrapper.update_kinematics()
            for s, sole in zip(SIDES, soles, strict=True):
                feet[s][i] = wrapper.get_T_world_frame(sole)
            for k, frame in enumerate(fan_frames):
                fans_xy[i, k] = wrapper.get_T_world_frame(frame)[:2, 3]
            com[i] = wrapper.com_world()
            if statics:
                gravity[i] = wrapper.generalized_gravity()
                for s, sole in zip(SIDES, soles, strict=True):
                    jac[s][i] = wrapper.frame_jacobian(sole, "local_world_aligned")
                for k, frame in enumerate(fan_frames):
                    fan_z[i, k] = wrapper.frame_jacobian(frame, "local_world_aligned")[2]
        if statics and len(rows_posed):
            thrust = np.where(np.isfinite(self.thrust), self.thrust, 0.0)
            tau, kappa = batched_statics(robot, gravity[rows_posed], {s: jac[s][rows_posed] for s in SIDES},
                                         fan_z[rows_posed], thrust[rows_posed], self.support[rows_posed],
                                         {s: feet[s][rows_posed] for s in SIDES})
            out["tau"][rows_posed], out["kappa"][rows_posed] = tau, kappa
        return out

    @cached_property
    def pos(self) -> dict[str, np.ndarray]:
        """Per side, (n, 3) the sole centre [m]."""
        return {s: self.fk["feet"][s][:, :3, 3] for s in SIDES}

    @cached_property
    def swing_pos(self) -> np.ndarray:
        return np.where((self.support == "right")[:, None], self.pos["left"], self.pos["right"])

    @cached_property
    def zmp(self) -> np.ndarray:
        """(n, 2) the ZMP of the written thrust (A-1, A-2) [m]."""
        return zmp_of_thrust(self.fk["com"][:, :2], self.fk["fans"], self.thrust, self.robot.mass_kg)

    @cached_property
    def on_one_sole(self) -> np.ndarray:
        """(n,) rows supported by one sole: their support polygon is that sole's rectangle."""
        return self.single & np.isin(self.support.astype(str), SIDES)

    @cached_property
    def sole_centre(self) -> np.ndarray:
        """(n, 2) the support sole's centre [m] in the rows on one sole (the right sole's elsewhere)."""
        return np.where((self.support == "left")[:, None], self.pos["left"][:, :2], self.pos["right"][:, :2])

    def edges(self, shrink_m: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Per row, the edges of its support polygon (:mod:`.balance`: normals (n, K, 2), offsets (n, K)),
        each sole shrunk by ``shrink_m`` [m]: the support sole's rectangle on one sole, else the hull of both
        (:func:`pair_hull_edges`; a sole's rows repeat its first edge)."""
        r = self.robot
        one = self.on_one_sole
        normals, offsets = sole_edges(self.sole_centre, r.sole_length_m, r.sole_width_m, shrink_m)
        if one.all():
            return normals, offsets
        hull_n, hull_b = pair_hull_edges(self.pos["left"][:, :2], self.pos["right"][:, :2], r.sole_length_m,
                                         r.sole_width_m, shrink_m)
        k = hull_b.shape[1]
        normals = np.concatenate([normals, np.repeat(normals[:, :1], k - 4, axis=1)], axis=1)
        offsets = np.concatenate([offsets, np.repeat(offsets[:, :1], k - 4, axis=1)], axis=1)
        return np.where(one[:, None, None], normals, hull_n), np.where(one[:, None], offsets, hull_b)

    @cached_property
    def support_edges(self) -> tuple[np.ndarray, np.ndarray]:
        """The real support polygon of every row (:meth:`edges`)."""
        return self.edges()

    @cached_property
    def tolerance_edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Every row's support polygon shrunk by the plan's ``sole_margin_m`` [m], where the checks under the
        plan's tolerance hold the ZMP."""
        return self.edges(float((self.balance or {}).get("sole_margin_m", 0.0)))

    @cached_property
    def windows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per row, the thrust window [N] of the fans that carry thrust, in their shares (in a swing row
        without thrust: the first fan the swing may use, its sole's), within every carrying fan's maximum,
        and where it was computed (a row with a written window, a ZMP and a fan to share)."""
        robot = self.robot
        nf = len(robot.fans)
        fmax = np.array([f.thrust_max_n for f in robot.fans])
        lo, hi, computed = np.full(self.n, np.nan), np.full(self.n, np.nan), np.zeros(self.n, dtype=bool)
        written = self.c[WINDOW[0]].astype(float)
        total = self.thrust.sum(axis=1)
        shares = np.zeros((self.n, nf))
        for i in np.flatnonzero(np.isfinite(self.zmp).all(axis=1) & np.isfinite(written)):
            share = None
            if total[i] > 0:
                share = self.thrust[i] / float(np.sum(self.thrust[i]))
            elif self.single[i] and self.support[i] in SIDES:
                usable = robot.swing_fans(other_side(self.support[i]))
                if usable:
                    share = np.isin(np.arange(nf), usable[:1]).astype(float)
            if share is not None:
                computed[i], shares[i] = True, share
        at = np.flatnonzero(computed)
        if len(at):
            normals, offsets = self.support_edges
            w_lo, w_hi = thrust_window(self.fk["com"][at, :2], self.fk["fans"][at], shares[at], normals[at],
                                       offsets[at], robot.mass_kg)
            with np.errstate(divide="ignore"):
                cap = np.min(np.where(shares[at] > 0, fmax / shares[at], np.inf), axis=1)
            lo[at], hi[at] = w_lo, np.minimum(w_hi, cap)
        return lo, hi, computed

    @cached_property
    def vertical_force(self) -> np.ndarray | None:
        """(n,) the vertical force [N] the ground must give for the written rows' motion (:mod:`.motion`):
        None where the rate is unknown or a row's pose is not finite (those rows fail elsewhere)."""
        rate = self.rate_hz
        c = self.c
        pelvis = np.stack([c[k] for k in PELVIS], axis=1).astype(float)
        norms = np.linalg.norm(self.quat, axis=1) if self.n else np.zeros(0)
        if (rate is None or self.n < 3 or not np.isfinite(pelvis).all() or not np.isfinite(self.q_written).all()
                or not np.isfinite(self.thrust).all() or not (np.isfinite(norms) & (norms >= 1e-9)).all()):
            return None
        return vertical_ground_force(self.robot, pelvis, self.quat / norms[:, None], self.q, self.thrust, 1.0 / rate)

    @cached_property
    def rate_hz(self) -> float | None:
        """The plan's row rate: summary.json's, else the scenario's."""
        traj = (self.summary or {}).get("trajectory")
        if isinstance(traj, dict) and isinstance(traj.get("rate_hz"), int | float) and traj["rate_hz"] > 0:
            return float(traj["rate_hz"])
        return self.scenario.timing.rate_hz if self.scenario is not None else None


def expected_sequence(sc, rate_hz: float, summary: dict | None = None) -> list[tuple[str, int, int, str]] | None:
    """(phase, step, sample, support) of every row the scenario's plan has, in order (docs/physics.md,
    "Sequence"): per step a transfer of round(transfer_s·rate) rows (at least one) on both soles, then a
    swing of round(swing_s·rate) rows (at least one) on the support sole; a last transfer one row longer
    (it ends on the final stance). A plan timed fastest (its scenario or ``summary.json`` says so): its phases'
    row counts from ``summary.json``'s ``timing.phases`` (None without them)."""
    raw = (summary or {}).get("timing")
    timed: dict = raw if isinstance(raw, dict) else {}
    if getattr(sc.timing, "fastest", False) or timed.get("mode") == "fastest":
        phases = timed.get("phases")
        if not isinstance(phases, list) or len(phases) != 2 * len(sc.steps) + 1:
            return None
        try:
            counts = [int(p["rows"]) for p in phases]
        except (KeyError, TypeError, ValueError):
            return None
        out = []
        for k, st in enumerate(sc.steps):
            out += [("transfer", k, i, "both") for i in range(counts[2 * k])]
            out += [("swing", k, i, st.support) for i in range(counts[2 * k + 1])]
        return out + [("transfer", len(sc.steps), i, "both") for i in range(counts[-1])]
    n_tr = max(1, round(sc.timing.transfer_s * rate_hz))
    n_sw = max(1, round(sc.timing.swing_s * rate_hz))
    out = []
    for k, st in enumerate(sc.steps):
        out += [("transfer", k, i, "both") for i in range(n_tr)]
        out += [("swing", k, i, st.support) for i in range(n_sw)]
    out += [("transfer", len(sc.steps), i, "both") for i in range(n_tr + 1)]
    return out


def scenario_feet(sc, row_step: np.ndarray, phase: np.ndarray) -> dict[str, np.ndarray]:
    """Per row, where the scenario puts each sole on the ground: the start soles moved by every landing
    before step k (transfers leading into step k, and the support sole of swing k); NaN for the swing
    sole of a swing row."""
    stances = [{s: np.asarray(sc.start[s], dtype=float) for s in SIDES}]
    for st in sc.steps:
        stances.append({**stances[-1], st.swing: np.asarray(st.landing_m, dtype=float)})
    out = {s: np.full((len(phase), 3), np.nan) for s in SIDES}
    for i, (ph, k) in enumerate(zip(phase, row_step, strict=True)):
        k = int(k)
        if not 0 <= k < len(stances):
            continue
        for s in SIDES:
            if ph == "transfer" or (ph == "swing" and k < len(sc.steps) and sc.steps[k].support == s):
                out[s][i] = stances[k][s]
    return out


def ground_references(support: np.ndarray, pos: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Per foot and row, where that foot stands: the median of its position over each stretch of
    consecutive rows in which it is on the ground (so a single tampered row stands out)."""
    n = len(support)
    ref = {}
    for s in SIDES:
        grounded = np.array([sup in (s, "both") for sup in support])
        ref[s] = np.full((n, 3), np.nan)
        start = 0
        while start < n:
            if not grounded[start]:
                start += 1
                continue
            end = start
            while end < n and grounded[end]:
                end += 1
            ref[s][start:end] = np.median(pos[s][start:end], axis=0)
            start = end
    return ref


def _transfer_weights(robot: RobotModel, a: np.ndarray, b: np.ndarray, feet: dict[str, np.ndarray],
                      at: np.ndarray) -> np.ndarray:
    """(k, 2) each sole's weight in a double-support split (``physics.statics.load_split``, restated): the
    ZMP from the wrench the right sole alone would carry (its CoP: the sole's centre plus (−m_y, m_x)/f_z),
    its distance beyond each sole rectangle measured along that sole's heading, max(|x| − L/2, |y| − W/2, 0),
    and β_s = d_other / (d_l + d_r) (½ each where both are 0)."""
    w_right = np.linalg.solve(a[:, :, 6:], b[..., None])[..., 0]  # (k, 6)
    fz = np.where(np.abs(w_right[:, 2]) > 1e-9, w_right[:, 2], 1e-9)
    zmp = feet["right"][at, :2, 3] + np.stack([-w_right[:, 4], w_right[:, 3]], axis=1) / fz[:, None]
    half = np.array([robot.sole_length_m / 2, robot.sole_width_m / 2])
    d = np.empty((len(at), 2))
    for k, s in enumerate(SIDES):
        yaw = np.arctan2(feet[s][at, 1, 0], feet[s][at, 0, 0])  # the sole's heading (its x axis seen from above)
        rel = zmp - feet[s][at, :2, 3]
        local = np.stack([np.cos(yaw) * rel[:, 0] + np.sin(yaw) * rel[:, 1],
                          -np.sin(yaw) * rel[:, 0] + np.cos(yaw) * rel[:, 1]], axis=1)
        d[:, k] = np.maximum(np.max(np.abs(local) - half, axis=1), 0.0)
    total = d.sum(axis=1)
    return np.where(total[:, None] > 0, d[:, ::-1] / np.where(total > 0, total, 1.0)[:, None], 0.5)


def batched_statics(robot: RobotModel, gravity: np.ndarray, jac: dict[str, np.ndarray], fan_z: np.ndarray,
                    thrust_n: np.ndarray, support: np.ndarray, feet: dict[str, np.ndarray]
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Static torques (m, J) [N·m] and each leg's κ (m, 2) of m postures at once, from PlaCo's
    generalised gravity (m, 6+J), the soles' world-aligned Jacobians (m, 6, 6+J) per side and the
    vertical-force row of each fan's (m, F, 6+J), under thrusts (m, F) [N] with ``support`` (m,) on the
    ground: the equations of ``physics.statics.static_torques`` (the six floating-base rows fix the
    support wrench, exactly on one sole; on both the load transfer's weighted least norm, the weights
    from the ZMP's distances beyond the soles at ``feet`` (m, 4, 4) per side: :func:`_transfer_weights`)
    and ``leg_condition_numbers``. A row whose support is neither sole nor
    both keeps NaN torques."""
    m, nj = len(gravity), gravity.shape[1] - 6
    rhs = gravity - np.einsum("mf,mfv->mv", thrust_n, fan_z)
    tau = np.full((m, nj), np.nan)
    for sup in (*SIDES, "both"):
        at = np.flatnonzero(support == sup)
        if not len(at):
            continue
        jc = np.concatenate([jac[s][at] for s in (SIDES if sup == "both" else (sup,))], axis=1)  # (k, 6c, 6+J)
        a = np.transpose(jc[:, :, :6], (0, 2, 1))  # (k, 6, 6c): base rows of J_cᵀ
        b = rhs[at, :6]
        if sup == "both":  # the weighted least-norm wrench: w = W Aᵀ (A W Aᵀ)⁻¹ b, W = diag(β_l I₆, β_r I₆)
            beta = _transfer_weights(robot, a, b, feet, at)
            wt = np.repeat(beta, 6, axis=1)  # (k, 12)
            aw = a * wt[:, None, :]
            y = np.linalg.solve(aw @ np.transpose(a, (0, 2, 1)), b[..., None])
            w = wt * (np.transpose(a, (0, 2, 1)) @ y)[..., 0]
        else:
            w = np.linalg.solve(a, b[..., None])[..., 0]
        tau[at] = rhs[at, 6:] - np.einsum("kcj,kc->kj", jc[:, :, 6:], w)
    kappa = np.empty((m, 2))
    for k, side in enumerate(SIDES):
        legs = jac[side][:, :, 6 + np.asarray(robot.legs[side].index)]
        sv = np.linalg.svd(legs, compute_uv=False)
        with np.errstate(divide="ignore", invalid="ignore"):
            kappa[:, k] = np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)
    return tau, kappa
