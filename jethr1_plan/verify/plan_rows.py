"""A plan's rows as the checks of :mod:`.plan_checks` read them: the written columns and what is
recomputed from them, each once: forward kinematics of each row's pelvis pose and joints in a fresh
PlaCo robot (soles, CoM, fans, static torques, κ), the ZMP of the written thrust (A-1, A-2), the
support polygons and thrust windows, and where the scenario puts the soles."""

from __future__ import annotations

import math
from functools import cached_property
from typing import Any

import numpy as np

from jethr1_plan.geometry import GRAVITY, SIDES, convex_hull, other_side, pose_from_quaternion, sole_polygon
from jethr1_plan.robot.model import RobotModel

__all__ = ["OPTIONAL", "TEXT", "RowData", "distance_to_polyline", "expected_sequence", "ground_references",
           "scenario_feet"]

TEXT = ("phase", "support", "reason", "feasible")  # the columns that are not numbers
# empty (NaN) where there is no swing sole, no window, or no tolerance (the share: its own check)
OPTIONAL = ("swing_", "thrust_window_", "tolerance_share")


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
        fmax = np.array([f.max_thrust_n for f in self.fans])
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
        is left at zero (NaN torques): it fails "not a number"."""
        from jethr1_plan.physics.statics import leg_condition_numbers, static_torques

        robot, c, n = self.robot, self.c, self.n
        wrapper = robot.wrapper()
        out: dict[str, Any] = {"feet": {s: np.zeros((n, 4, 4)) for s in SIDES},
                               "fans": np.zeros((n, len(robot.fans), 2)), "com": np.zeros((n, 3)),
                               "tau": np.full((n, len(robot.joint_names)), np.nan), "kappa": np.full((n, 2), np.nan)}
        pelvis = np.stack([c["pelvis_x_m"], c["pelvis_y_m"], c["pelvis_z_m"]], axis=1).astype(float)
        posed = np.isfinite(pelvis).all(axis=1) & np.isfinite(self.q_written).all(axis=1)
        for i in np.flatnonzero(posed):
            quat = self.quat[i]
            norm = math.sqrt(float(quat @ quat))
            if not math.isfinite(norm) or norm < 1e-9:
                continue
            wrapper.set_T_world_fbase(pose_from_quaternion(pelvis[i].tolist(), (quat / norm).tolist()))
            wrapper.state.q[7:] = self.q[i]
            wrapper.update_kinematics()
            for s in SIDES:
                out["feet"][s][i] = wrapper.get_T_world_frame(robot.legs[s].sole)
            for k, fan in enumerate(robot.fans):
                out["fans"][i, k] = wrapper.get_T_world_frame(fan.frame)[:2, 3]
            out["com"][i] = wrapper.com_world()
            if self.statics:
                sup = c["support"][i]
                supports = SIDES if sup == "both" else ((sup,) if sup in SIDES else ())
                if supports:
                    thrust = self.thrust[i]
                    out["tau"][i], _ = static_torques(robot, wrapper, np.where(np.isfinite(thrust), thrust, 0.0),
                                                      supports)
                kappa = leg_condition_numbers(robot, wrapper)
                out["kappa"][i] = kappa["left"], kappa["right"]
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
        w = self.robot.mass_kg * GRAVITY
        with np.errstate(invalid="ignore", divide="ignore"):
            moment = sum(self.thrust[:, k, None] * self.fk["fans"][:, k] for k in range(len(self.fans)))
            return (w * self.fk["com"][:, :2] - moment) / (w - self.thrust.sum(axis=1))[:, None]

    @cached_property
    def polygons(self) -> list[np.ndarray]:
        """Per row, the real support polygon: the support sole, or the hull of both soles."""
        out = []
        for i in range(self.n):
            soles = [SIDES.index(self.support[i])] if self.single[i] and self.support[i] in SIDES else [0, 1]
            polys = [sole_polygon(self.pos[SIDES[k]][i, :2], 0.0, self.robot.sole_length_m, self.robot.sole_width_m)
                     for k in soles]
            out.append(polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys)))
        return out

    @cached_property
    def windows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per row, the thrust window [N] of the fans that carry thrust, in their shares (in a swing row
        without thrust: the first fan the swing may use, its sole's), and where it was computed (a row
        with a written window, a ZMP and a fan to share)."""
        from jethr1_plan.physics.balance import shared_window, thrust_window

        robot = self.robot
        fmax = np.array([f.max_thrust_n for f in robot.fans])
        lo, hi, computed = np.full(self.n, np.nan), np.full(self.n, np.nan), np.zeros(self.n, dtype=bool)
        written = self.c["thrust_window_lo_n"].astype(float)
        com = self.fk["com"][:, :2]
        for i, poly in enumerate(self.polygons):
            if not (np.all(np.isfinite(self.zmp[i])) and np.isfinite(written[i])):
                continue
            total = float(np.sum(self.thrust[i]))
            share = None
            if total > 0:
                share = self.thrust[i] / total
            elif self.single[i] and self.support[i] in SIDES:
                usable = robot.swing_fans(other_side(self.support[i]))
                if usable:
                    share = np.isin(np.arange(len(fmax)), usable[:1]).astype(float)
            if share is None:
                continue
            computed[i] = True
            carry = np.flatnonzero(share > 0)
            if len(carry) == 1:
                w_lo, w_hi = thrust_window(com[i], self.fk["fans"][i, carry[0]], poly, robot.mass_kg)
                lo[i], hi[i] = float(w_lo), min(float(w_hi), float(fmax[carry[0]]))
            else:
                w_lo, w_hi = shared_window(com[i], self.fk["fans"][i, carry], share[carry], poly, robot.mass_kg)
                lo[i], hi[i] = float(w_lo), min(float(w_hi), float(np.min(fmax[carry] / share[carry])))
        return lo, hi, computed

    @cached_property
    def rate_hz(self) -> float | None:
        """The plan's row rate: summary.json's, else the scenario's."""
        traj = (self.summary or {}).get("trajectory")
        if isinstance(traj, dict) and isinstance(traj.get("rate_hz"), int | float) and traj["rate_hz"] > 0:
            return float(traj["rate_hz"])
        return self.scenario.timing.rate_hz if self.scenario is not None else None


def expected_sequence(sc, rate_hz: float) -> list[tuple[str, int, int, str]]:
    """(phase, step, sample, support) of every row the scenario's plan has, in order (``sequence``)."""
    from jethr1_plan.control.time_laws import swing_row_positions

    n_tr = max(1, round(sc.timing.transfer_s * rate_hz))
    out = []
    for k, st in enumerate(sc.steps):
        out += [("transfer", k, i, "both") for i in range(n_tr)]
        out += [("swing", k, i, st.support) for i in range(len(swing_row_positions(len(st.path_m), sc.timing.swing_s,
                                                                                   rate_hz)))]
    out += [("transfer", len(sc.steps), i, "both") for i in range(n_tr + 1)]
    return out


def scenario_feet(sc, row_step: np.ndarray, phase: np.ndarray) -> dict[str, np.ndarray]:
    """Per row, where the scenario puts each sole on the ground: before step k (transfers leading into
    step k, and the support sole of swing k); NaN for the swing sole of a swing row."""
    from jethr1_plan.planning.problems import feet_before_each_step

    before = feet_before_each_step(sc)
    final = {k: v.copy() for k, v in before[-1].items()}
    final[sc.steps[-1].swing] = sc.steps[-1].landing_m.copy()
    before.append(final)
    out = {s: np.full((len(phase), 3), np.nan) for s in SIDES}
    for i, (ph, k) in enumerate(zip(phase, row_step, strict=True)):
        k = int(k)
        if not 0 <= k < len(before):
            continue
        for s in SIDES:
            if ph == "transfer" or (ph == "swing" and k < len(sc.steps) and sc.steps[k].support == s):
                out[s][i] = before[k][s]
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


def distance_to_polyline(p: np.ndarray, pts: np.ndarray) -> float:
    a, b = pts[:-1], pts[1:]
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-30), 0, 1)
    return float(np.min(np.linalg.norm(a + t[:, None] * ab - p, axis=1)))
