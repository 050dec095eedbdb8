"""The judge of a run in the twin, from the twin's truth (never a controller's): when the robot has fallen, where
each landing is judged and what it is made of (:class:`StepJudge`), whether a sole stands on a carton top, the
soles' true loads, and a run's verdict (:class:`RunResult`).

A run **falls** when the trunk tilts more than ``FALL_TILT_DEG`` from level or the pelvis drops more
than ``FALL_DROP_M`` below the plan; it **succeeds** when it does not fall and both soles end on
carton tops (on the ground where the scenario has no cartons).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from jethr1_plan.control.swing_placement import yaw_of
from jethr1_plan.geometry import SIDES, other_side
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.sim.track import PlanTrack
from jethr1_plan.sim.twin import Twin
from jethr1_plan.swing_path import Carton, sole_on_carton

__all__ = ["FALL_DROP_M", "FALL_TILT_DEG", "ON_TOP_TOL_M", "RunResult", "StepJudge", "landing_rows", "on_cartons",
           "sole_loads"]

FALL_TILT_DEG = 10.0  # a trunk tilted more than this from level has fallen [deg]
FALL_DROP_M = 0.10  # a pelvis this far below the plan has fallen [m]
ON_TOP_TOL_M = 0.005  # a sole within this of a carton's top (height) stands on it [m]


@dataclass
class RunResult:
    """One run's verdict and measurements (SI units, angles in degrees where named so)."""

    controller: str
    compensated: bool  # the plan's sag and lag compensation in the feed-forward
    perturbation: dict
    survived: bool
    fell: dict | None
    max_trunk_tilt_deg: float
    support_max_tilt_deg: float
    support_max_slip_m: float
    least_cop_margin_m: float | None
    least_cop_margin_at: dict | None
    landing_errors_m: list[dict]
    soles_on_cartons_at_end: dict[str, bool]
    peak_thrust_n: float
    simulated_s: float
    wall_s: float
    record: dict | None = None
    law: str | None = None  # the thrust law the controller ran (None: feed-forward)
    steps: list[dict] = field(default_factory=list)  # per swing: support slip and turn, the landing error's parts
    stopped: str | None = None  # why the robot stopped before the plan's end without falling (step by step)

    def as_dict(self) -> dict:
        """The verdict and measurements as plain data, without the recorded states (not copied)."""
        out = asdict(replace(self, record=None))  # the record's states are not deep-copied to be dropped
        out.pop("record")
        return out


def sole_loads(twin: Twin, d, buf: np.ndarray) -> dict[str, tuple[float, np.ndarray]]:
    """Per sole: the normal force [N] of its contacts and their centre of pressure (x, y, z) [m]
    (the sole's centre where it carries nothing). The contact forces are the constraint solver's: the
    twin's elliptic cones keep each contact's force in its frame (normal, then tangential) at its
    ``efc_address`` (what ``mj_contactForce`` reads)."""
    n = d.ncon
    picked: dict[str, list[int]] = {s: [] for s in twin.sole_geoms}
    if n:
        # which sole each contact touches, in plain Python (a handful of contacts: cheaper than masks per sole)
        contact = d.contact
        adr = contact.efc_address[:n].tolist()
        side_of = twin.sole_of_geom
        for j, (g0, g1) in enumerate(contact.geom[:n].tolist()):
            if adr[j] >= 0:
                for g in (g0, g1) if g0 != g1 else (g0,):
                    side = side_of.get(g)
                    if side is not None:
                        picked[side].append(j)
        frames, f = contact.frame[:n].tolist(), d.efc_force.tolist()
    out = {}
    for side, idx in picked.items():
        force = 0.0  # [N]
        if idx:
            # the world z component of each contact's force (its frame's rows are the normal and tangents), element
            # by element in floats as numpy's elementwise products and sums give them
            z = np.array([abs(frames[j][2] * f[adr[j]] + frames[j][5] * f[adr[j] + 1] + frames[j][8] * f[adr[j] + 2])
                          for j in idx])
            force = float(z.sum())
            if force > 1e-9:
                out[side] = (force, (z @ contact.pos[idx]) / force)  # Σ force · contact point / Σ force [m]
                continue
        out[side] = (force, d.xpos[twin.foot_bodies[side]].copy())
    return out


class StepJudge:
    """Per swing, from the twin's truth (the judge's, never a controller's): the support sole's slip and
    turn over the swing, and the landing error (the swing sole at the end of the transfer after it, against
    the plan) in parts that add up to it:

    * ``inherited``: where the landing would be had the support sole not moved during the swing and the
      legs held the planned relative pose: the support sole's error at the swing's start, carried over;
    * ``support_slip``: the support sole's slip and turn during the swing, carried to the landing;
    * ``servo_sag``: the legs' joints off the plan at touchdown (the servos' sag beyond the plan's
      compensation, their tracking lag), less the thrust part;
    * ``thrust``: the swing leg's deflection under the thrust's deviation from the plan at touchdown
      (J_solẹ·k⁻¹·J_fanᵀ·ΔF, the nominal stiffness scaled by the run's);
    * ``touchdown``: the plan's own swing sole not yet at (or past) its landing when the sole touched;
    * ``slide``: the landed sole's motion from touchdown to the end of the transfer.

    Touchdown: the first tick after the swing's middle with the swing sole carrying over 2 N (in the
    transfer, where it never did during the swing)."""

    TOUCH_N = 2.0  # a sole carrying this has touched down [N]

    def __init__(self, twin: Twin, track: PlanTrack, stiffness_scale: float) -> None:
        self.twin, self.track = twin, track
        self.k = twin.robot.servo_stiffness_nm_per_rad * stiffness_scale
        self.swings: dict[int, dict] = {}
        for st in np.unique(track.step[track.phase == "swing"]):
            rows = np.flatnonzero((track.phase == "swing") & (track.step == st))
            sup = str(track.support[rows[0]])
            self.swings[int(st)] = {"first": int(rows[0]), "last": int(rows[-1]), "support": sup,
                                    "swing": other_side(sup)}
        self.judge = {step: row for row, step, _ in landing_rows(track)}
        self.current: dict | None = None
        self.done: list[dict] = []
        self.jacp = np.zeros((3, twin.model.nv))
        self.jacr = np.zeros((3, twin.model.nv))

    def _pose(self, d, side: str) -> tuple[np.ndarray, np.ndarray]:
        b = self.twin.foot_bodies[side]
        return d.xpos[b].copy(), d.xmat[b].reshape(3, 3).copy()

    def tick(self, d, i: int, t: float, loads: dict, applied: np.ndarray) -> None:
        """After a physics step at plan row ``i`` (time ``t`` [s]): ``loads`` the soles' true normal forces,
        ``applied`` the fans' true thrust."""
        track = self.track
        step = int(track.step[i])
        cur = self.current
        if cur is None and track.phase[i] == "swing" and step in self.swings:
            info = self.swings[step]
            sup = info["support"]
            si, wi = SIDES.index(sup), SIDES.index(info["swing"])
            landing = track.feet[info["last"], wi]
            r_plan = _yaw_rotation(float(track.feet_yaw[info["first"], si]))
            p0, r0 = self._pose(d, sup)
            cur = self.current = {**info, "step": step, "landing": landing,
                                  "land_rel": r_plan.T @ (landing - track.feet[info["first"], si]),
                                  "p0": p0, "r0": r0, "touch": None, "swing_end": None}
            return
        if cur is None:
            return
        sup, sw = cur["support"], cur["swing"]
        if cur["swing_end"] is None and (track.phase[i] != "swing" or int(track.step[i]) != cur["step"]):
            p, r = self._pose(d, sup)
            cur["swing_end"] = (p, r)
        if cur["touch"] is None and i > (cur["first"] + cur["last"]) / 2 and loads[sw] > self.TOUCH_N:
            cur["touch"] = self._touchdown(d, i, applied)
        judge = self.judge.get(cur["step"])
        if judge is not None and t >= track.time_s[judge] - 1e-9:
            self._finish(d)

    def _touchdown(self, d, i: int, applied: np.ndarray) -> dict:
        import mujoco

        track, cur, twin = self.track, self.current, self.twin
        assert cur is not None
        sup, sw = cur["support"], cur["swing"]
        si, wi = SIDES.index(sup), SIDES.index(sw)
        p, r = self._pose(d, sup)
        pw, _ = self._pose(d, sw)
        land_rel, landing = cur["land_rel"], cur["landing"]
        r_plan = _yaw_rotation(float(track.feet_yaw[i, si]))
        rel_plan = r_plan.T @ (track.feet[i, wi] - track.feet[i, si])
        rel = r.T @ (pw - p)
        # the swing leg's deflection under the thrust's deviation from the plan (the swing sole's fans)
        fans = [k for k, f in enumerate(twin.robot.fans) if f.leg == sw]
        leg = np.array(twin.robot.legs[sw].index)
        dq = np.zeros(len(self.k))
        for k in fans:
            body = twin.fan_bodies[twin.robot.fans[k].frame]
            mujoco.mj_jac(twin.model, d, self.jacp, None, d.xpos[body], body)
            dq += self.jacp[2, twin.dof_adr] * (float(applied[k]) - float(track.thrust[i, k])) / self.k
        mujoco.mj_jacBody(twin.model, d, self.jacp, self.jacr, twin.foot_bodies[sw])
        thrust_part = self.jacp[:, twin.dof_adr[leg]] @ dq[leg]
        servo = r @ (rel - rel_plan)
        return {"row": i, "time_s": float(track.time_s[i]), "world": (pw - landing)[:2],
                "inherited": (cur["p0"] + cur["r0"] @ land_rel - landing)[:2],
                "support_slip": (p + r @ land_rel - cur["p0"] - cur["r0"] @ land_rel)[:2],
                "servo_sag": (servo - thrust_part)[:2], "thrust": thrust_part[:2],
                "touchdown": (r @ (rel_plan - land_rel))[:2]}

    def _finish(self, d) -> None:
        cur = self.current
        assert cur is not None
        sup, sw = cur["support"], cur["swing"]
        pw, _ = self._pose(d, sw)
        end, r_end = cur["swing_end"] or self._pose(d, sup)
        slip = (end - cur["p0"])[:2]
        err = (pw - cur["landing"])[:2]
        rec = {"step": cur["step"], "swing": sw, "support": sup, "landed_m": [float(v) for v in pw],
               "target_m": [float(v) for v in cur["landing"]],
               "support_slip_m": float(np.hypot(*slip)), "support_slip_xy_m": [float(v) for v in slip],
               "support_turn_rad": float(yaw_of(r_end) - yaw_of(cur["r0"])),
               "landing_error_m": float(np.hypot(*err)), "landing_error_xy_m": [float(v) for v in err],
               "touchdown": None, "parts_xy_m": None}
        touch = cur["touch"]
        if touch is not None:
            rec["touchdown"] = {"row": touch["row"], "time_s": touch["time_s"]}
            parts = {k: touch[k] for k in ("inherited", "support_slip", "servo_sag", "thrust", "touchdown")}
            parts["slide"] = err - touch["world"]
            rec["parts_xy_m"] = {k: [float(v[0]), float(v[1])] for k, v in parts.items()}
        self.done.append(rec)
        self.current = None


def _yaw_rotation(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def landing_rows(track: PlanTrack) -> list[tuple[int, int, str]]:
    """(row, step, sole) at which each landing is judged: the last row of the transfer that follows
    the swing of ``step`` (transfers carry the index of the step they lead into), in time order."""
    out = []
    n = len(track)
    for i in range(n):
        last_of_transfer = track.phase[i] == "transfer" and (i + 1 == n or track.phase[i + 1] != "transfer")
        if last_of_transfer and track.step[i] >= 1:
            step = int(track.step[i]) - 1
            swing_rows = np.flatnonzero((track.phase == "swing") & (track.step == step))
            if len(swing_rows):
                sup = track.support[swing_rows[0]]
                out.append((i, step, other_side(sup)))
    return out


def on_cartons(robot: RobotModel, cartons: tuple[Carton, ...], xyz: np.ndarray, xmat: np.ndarray) -> bool:
    """Whether a sole, at its simulated pose, lies on a carton top (the ground without cartons)."""
    yaw = math.atan2(xmat[3], xmat[0])
    level = xmat[8] > math.cos(math.radians(5.0))
    if not cartons:
        return bool(level and abs(xyz[2]) < ON_TOP_TOL_M)
    return bool(level and any(abs(xyz[2] - c.top_z) < ON_TOP_TOL_M
                              and sole_on_carton(np.array([xyz[0], xyz[1], c.top_z]), yaw, robot.sole_length_m,
                                                 robot.sole_width_m, c, tol_m=ON_TOP_TOL_M)
                              for c in cartons))


