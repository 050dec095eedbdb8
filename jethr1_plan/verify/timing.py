"""The checks of a plan timed fastest (``timing: {mode: fastest}``): its rows' own motion within the limits
its ``summary.json`` says it was timed under, recomputed from the written rows and their written times.

Restated here from docs/physics.md ("The fastest timing"), with nothing of the planner's physics, so that a
bug in one is caught by the other:

* the motion: second central differences of the written rows over their written times (the trunk's on
  SE(3), in its own frame; unequal spacing allowed), the robot held at rest beyond the file's ends;
* the wrench W = (f, n) the world must supply, about the world's origin: the floating base's six rows of
  M(q)·a + h(q, v) (PlaCo's model of the URDF) turned into the world frame;
* per edge n_k·z ≤ b_k of the support (the sole, or the hull of both soles, shrunk by the plan's
  ``dynamic_share`` × ``balance.sole_margin_m``), with D_k = n_ky·n_x − n_kx·n_y − b_k·f_z and the fans'
  levers a_ik = n_k·p_i − b_k: (1 ± Y)·(D_k + ε·f_z) ≤ Σ_i F_i·(a_ik − X·|a_ik|), X, Y, ε the plan's
  tolerance × ``dynamic_share`` × the row's written tolerance share;
* the ground pushes and grips: (1 − Y)·f_z − (1 + X)·Σ F_i > 0 and (1 + Y)·(|f_x| + |f_y|) ≤
  μ·safety·((1 − Y)·f_z − (1 + X)·Σ F_i), μ the robot's sole friction; on one sole the yaw moment about
  its centre (1 + Y)·|n_z − c_x·f_y + c_y·f_x| within the same times 0.02 m;
* each joint's speed |q̇_j| ≤ safety × its URDF velocity limit; its torque (the joint rows of the inverse
  dynamics less the fans' thrust and the support's least-norm share) within safety × its servo limit;
* each fan's lead command F + (τ/safety)·Ḟ within [−ΔF, F_max] (Ḟ by central differences over the
  written times; ΔF the plan's ``spin_down_n``).
"""

from __future__ import annotations

import math

import numpy as np

from jethr1_plan.geometry import SIDES, convex_hull, sole_polygon
from jethr1_plan.records.plan_columns import PELVIS, TOLERANCE_SHARE
from jethr1_plan.verify.checks import RowCheck, registrar
from jethr1_plan.verify.plan_rows import RowData

__all__ = ["CHECKS", "DYNAMIC_TOL", "fastest_settings"]

CHECKS: list[RowCheck] = []  # in the order they run
check = registrar(CHECKS)

TORSION_RADIUS_M = 0.02  # the yaw moment a sole's friction resists: μ·f_z times this [m] (docs/physics.md)
DYNAMIC_TOL = 1e-4  # [N·m, N]: the written rows' rounding and the forward kinematics' 1e-9 m
RATE_TOL = 1e-6  # [rad/s, N]


def fastest_settings(x: RowData) -> dict | None:
    """The limits a plan timed fastest says it was timed under (``summary.json``'s ``timing``), none looser than
    the robot's own (a safety factor above 1 or a dynamic share below 0 is read as 1 and 0); None for a plan
    of fixed timing (neither its summary nor its scenario says fastest)."""
    doc = (x.summary or {}).get("timing")
    sc_fast = x.scenario is not None and getattr(x.scenario.timing, "mode", "fixed") == "fastest"
    if not (isinstance(doc, dict) and doc.get("mode") == "fastest") and not sc_fast:
        return None
    doc = doc if isinstance(doc, dict) else {}
    tm = x.scenario.timing if x.scenario is not None else None

    def num(key: str, default: float) -> float:
        v = doc.get(key, getattr(tm, key, default) if tm is not None else default)
        return float(v) if isinstance(v, int | float) and math.isfinite(v) else default

    return {"dynamic_share": min(max(num("dynamic_share", 1.0), 0.0), 1.0),
            "safety": min(max(num("safety_factor", 1.0), 1e-3), 1.0),
            "spin_down_n": max(num("spin_down_n", 0.0), 0.0)}


def _pose(x: RowData) -> np.ndarray:
    """(N, 4, 4) the written trunk poses (unit quaternions; the unit check reports the others)."""
    c = x.c
    p = np.stack([c[k] for k in PELVIS], axis=1).astype(float)
    qx, qy, qz, qw = (x.quat / np.maximum(np.linalg.norm(x.quat, axis=1), 1e-12)[:, None]).T
    T = np.zeros((x.n, 4, 4))
    T[:, 0] = np.stack([1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw), p[:, 0]], 1)
    T[:, 1] = np.stack([2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw), p[:, 1]], 1)
    T[:, 2] = np.stack([2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy), p[:, 2]], 1)
    T[:, 3, 3] = 1.0
    return T


def _local_twist(T0: np.ndarray, T1: np.ndarray) -> np.ndarray:
    """(N, 6) the twist (linear, angular) in T0's frame that carries T0 to T1 in unit time: the SE(3) logarithm
    of T0⁻¹·T1 (rotation by Rodrigues; the linear part through the inverse of its left Jacobian)."""
    R0, R1 = T0[:, :3, :3], T1[:, :3, :3]
    R = np.einsum("nji,njk->nik", R0, R1)
    t = np.einsum("nji,nj->ni", R0, T1[:, :3, 3] - T0[:, :3, 3])
    cos = np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0)
    th = np.arccos(cos)
    skew = np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], axis=1)
    small = th < 1e-6
    k = np.where(small, 0.5 + th**2 / 12, th / (2 * np.sin(np.where(small, 1.0, th))))
    w = skew * k[:, None]
    out = np.zeros((len(T0), 6))
    for i in range(len(T0)):
        W = np.array([[0, -w[i, 2], w[i, 1]], [w[i, 2], 0, -w[i, 0]], [-w[i, 1], w[i, 0], 0]])
        a = th[i]
        if a < 1e-6:
            Vinv = np.eye(3) - 0.5 * W + W @ W / 12
        else:
            Vinv = np.eye(3) - 0.5 * W + (1 - a * np.sin(a) / (2 * (1 - np.cos(a)))) / a**2 * (W @ W)
        out[i, :3], out[i, 3:] = Vinv @ t[i], w[i]
    return out


def _motion(x: RowData) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(v, a (N, 6 + J), Ḟ (N, F)) by central differences over the written times (held beyond the ends)."""
    t = x.c["time_s"].astype(float)
    n = x.n
    T, q = _pose(x), x.q
    nxt, prv = np.minimum(np.arange(n) + 1, n - 1), np.maximum(np.arange(n) - 1, 0)
    hp = np.where(nxt > np.arange(n), t[nxt] - t, 0.0)
    hm = np.where(prv < np.arange(n), t - t[prv], 0.0)
    dt_end = float(np.median(np.diff(t))) if n > 1 else 1.0
    hp = np.where(hp > 0, hp, np.where(hm > 0, hm, dt_end))
    hm = np.where(hm > 0, hm, hp)
    dp = np.concatenate([_local_twist(T, T[nxt]), q[nxt] - q], axis=1)
    dm = np.concatenate([_local_twist(T, T[prv]), q[prv] - q], axis=1)
    den = (hp * hm * (hp + hm))[:, None]
    v = ((hm**2)[:, None] * dp - (hp**2)[:, None] * dm) / den
    a = 2 * (hm[:, None] * dp + hp[:, None] * dm) / den
    F = x.thrust
    Fd = np.zeros_like(F)
    if n > 1:
        Fd[1:-1] = (F[2:] - F[:-2]) / (t[2:] - t[:-2])[:, None]
        Fd[0], Fd[-1] = (F[1] - F[0]) / (t[1] - t[0]), (F[-1] - F[-2]) / (t[-1] - t[-2])
    return v, a, Fd


def _support_polygon(x: RowData, i: int, margin: float) -> np.ndarray:
    r = x.robot
    down = SIDES if x.support[i] == "both" else (str(x.support[i]),)
    polys = [sole_polygon(x.pos[s][i, :2], 0.0, r.sole_length_m, r.sole_width_m, margin) for s in down]
    return polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys))


def _edges(polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(K, 2) outward normals and (K,) offsets of a counter-clockwise polygon's edges."""
    d = np.roll(polygon, -1, axis=0) - polygon
    normals = np.stack([d[:, 1], -d[:, 0]], axis=1) / np.linalg.norm(d, axis=1)[:, None]
    return normals, np.einsum("ij,ij->i", normals, polygon)


def _rate_findings(x: RowData, v: np.ndarray, Fd: np.ndarray, vmax: np.ndarray, lag: np.ndarray, safety: float,
                   spin_down_n: float) -> tuple[list[tuple[int, str]], list[tuple[int, str]]]:
    """Every row's joints within ``safety`` of their velocity limits ``vmax`` [rad/s] (v: the rows' generalised
    velocities), and every fan's lead command F + lag·Ḟ within [−``spin_down_n``, F_max] [N]: (speed, fan)
    findings."""
    r, F, fmax = x.robot, x.thrust, x.fmax
    speed: list[tuple[int, str]] = []
    fan: list[tuple[int, str]] = []
    for i in range(x.n):
        fast = np.abs(v[i, 6:]) > safety * vmax + RATE_TOL
        if fast.any():
            j = int(np.argmax(np.abs(v[i, 6:]) / vmax))
            speed.append((i, f"{r.joint_names[j]} turns at {abs(v[i, 6 + j]):.3f} rad/s; the plan was timed to "
                          f"{safety:g} x its limit {vmax[j]:g} rad/s"))
        lead = F[i] + lag * Fd[i]
        off = (lead < -spin_down_n - RATE_TOL) | (lead > fmax + RATE_TOL)
        if off.any():
            k = int(np.argmax(off))
            fan.append((i, f"{r.fans[k].name} fan changes its thrust at {Fd[i, k]:+.2f} N/s from "
                        f"{F[i, k]:.3f} N: its lag ({lag[k]:.3f} s with the plan's safety factor) asks a "
                        f"command of {lead[k]:.3f} N, outside [{-spin_down_n:g}, {fmax[k]:g}] N"))
    return speed, fan


def _dynamic_findings(x: RowData) -> dict[str, list[tuple[int, str]]]:
    """Every row's findings of the dynamic checks, by check (computed once per file)."""
    cached = getattr(x, "_fastest_findings", None)
    if cached is not None:
        return cached
    out: dict[str, list[tuple[int, str]]] = {"dyn": [], "speed": [], "fan": []}
    s = fastest_settings(x)
    if s is None or x.n < 3 or not np.all(np.isfinite(x.c["time_s"].astype(float))):
        x._fastest_findings = out  # type: ignore[attr-defined]
        return out
    r = x.robot
    kappa, safety = s["dynamic_share"], s["safety"]
    tol = (x.balance or {}).get("tolerance") or {}
    X0, Y0, E0 = (float(tol.get(k, 0.0) or 0.0) for k in ("thrust_error", "mass_error", "com_error_m"))
    margin = float((x.balance or {}).get("sole_margin_m") or 0.0) * kappa
    shares = x.c[TOLERANCE_SHARE].astype(float) if TOLERANCE_SHARE in x.c else np.full(x.n, np.nan)
    v, a, Fd = _motion(x)
    w = r.wrapper()
    vmax = np.asarray(w.model.velocityLimit, dtype=float)[6:].copy()
    vmax[~(vmax > 0) | (vmax > 1e30)] = np.inf
    mu = r.sole_friction * safety
    lag = np.array([f.lag_s for f in r.fans]) / safety
    T = _pose(x)
    F = x.thrust
    out["speed"], out["fan"] = _rate_findings(x, v, Fd, vmax, lag, safety, s["spin_down_n"])
    for i in range(x.n):
        w.set_T_world_fbase(T[i])
        w.state.q[7:] = x.q[i]
        w.state.qd = v[i]
        w.state.qdd = a[i]
        w.update_kinematics()
        rows = w.mass_matrix() @ a[i] + w.non_linear_effects()
        R, p = T[i, :3, :3], T[i, :3, 3]
        f = R @ rows[:3]
        n_world = R @ rows[3:6] + np.cross(p, f)
        fans_xy = np.array([w.get_T_world_frame(fan.frame)[:2, 3] for fan in r.fans]).reshape(-1, 2)
        share = float(shares[i]) if np.isfinite(shares[i]) else 1.0
        X, Y, E = (kappa * share * e for e in (X0, Y0, E0))
        normals, offsets = _edges(_support_polygon(x, i, margin))
        D = normals[:, 1] * n_world[0] - normals[:, 0] * n_world[1] - offsets * f[2]
        lever = fans_xy @ normals.T - offsets
        held = F[i] @ (lever - X * np.abs(lever))
        zmp = (1 + Y) * np.maximum(D + E * f[2], (1 - Y) / (1 + Y) * (D + E * f[2])) - held
        ground = (1 - Y) * f[2] - (1 + X) * float(F[i].sum())
        grip = (1 + Y) * (abs(f[0]) + abs(f[1])) - mu * ground
        if x.support[i] != "both":  # the yaw moment about the support sole's centre
            sole = w.get_T_world_frame(r.legs[str(x.support[i])].sole)[:2, 3]
            twist = n_world[2] - sole[0] * f[1] + sole[1] * f[0]
            grip = max(grip, (1 + Y) * abs(twist) - mu * TORSION_RADIUS_M * ground)
        down = SIDES if x.support[i] == "both" else (str(x.support[i]),)
        rhs = rows.copy()
        for fan, thrust in zip(r.fans, F[i], strict=True):
            rhs -= w.frame_jacobian(fan.frame, "local_world_aligned")[2] * thrust
        Jc = np.vstack([w.frame_jacobian(r.legs[sd].sole, "local_world_aligned") for sd in down])
        split, *_ = np.linalg.lstsq(Jc[:, :6].T, rhs[:6], rcond=None)
        tau = rhs[6:] - Jc[:, 6:].T @ split
        over = np.abs(tau) - safety * r.servo_limit_nm
        if zmp.max() > DYNAMIC_TOL:
            k = int(np.argmax(zmp))
            out["dyn"].append((i, f"the rows' motion (central differences over the written times) puts the ZMP "
                               f"outside support edge {k} under {kappa:g} of the row's tolerance share "
                               f"({zmp[k]:.4f} N·m short)"))
        elif ground <= 0:
            out["dyn"].append((i, f"the motion needs the ground to pull ({ground:.2f} N)"))
        elif grip > DYNAMIC_TOL:
            out["dyn"].append((i, f"the motion needs {grip:.3f} N more grip than friction {mu:.3f} gives"))
        elif over.max() > DYNAMIC_TOL:
            j = int(np.argmax(over))
            out["dyn"].append((i, f"{r.joint_names[j]} needs {abs(tau[j]):.2f} N·m for the motion, above {safety:g} x "
                               f"its servo limit {r.servo_limit_nm[j]:.2f} N·m"))
    x._fastest_findings = out  # type: ignore[attr-defined]
    return out


@check("dynamic limit broken", "a plan timed fastest: every row's motion (central differences over the written "
       "times) keeps the ZMP in the support under its share of the tolerance, the ground pushing and gripping, "
       "the servos within their torque (docs/physics.md, the fastest timing)")
def _dynamic_limits(x: RowData) -> list[tuple[int, str]]:
    return _dynamic_findings(x)["dyn"]


@check("joint too fast", "a plan timed fastest: every joint's speed over the written times within its share of the "
       "URDF's velocity limit")
def _joint_speed(x: RowData) -> list[tuple[int, str]]:
    return _dynamic_findings(x)["speed"]


@check("fan cannot follow", "a plan timed fastest: each fan's thrust changes no faster than its lag allows (the "
       "lead command within [−spin-down allowance, F_max])")
def _fan_rate(x: RowData) -> list[tuple[int, str]]:
    return _dynamic_findings(x)["fan"]
