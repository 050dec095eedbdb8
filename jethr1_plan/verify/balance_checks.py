"""The checks of a plan's balance: each fan's thrust in range and off the support foot, the ZMP inside the
support sole, the written CoM, ZMP, margin and thrust window restated from the written joints and thrust, the
robust policy's tolerance and share (docs/physics.md, docs/robust_planning.md); one small function each
(:mod:`.checks`).
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.geometry import other_side
from jethr1_plan.records.plan_columns import COM, TOLERANCE_SHARE, WINDOW, ZMP, ZMP_MARGIN
from jethr1_plan.verify.balance import Tolerance, balance_slack, largest_share, support_margin
from jethr1_plan.verify.checks import Finding, RowCheck, registrar, rows
from jethr1_plan.verify.common import TOL_M
from jethr1_plan.verify.plan_rows import RowData

__all__ = ["CHECKS"]

# The fans' positions from forward kinematics differ from the planned ones by up to the IK tolerance
# (1e-6 m); about the sole's edge that moves the thrust window by ~M·g·1e-6 m / 0.1 m ≈ 1e-3 N and a
# balance moment by ~1e-4 N·m.
WINDOW_TOL_N = 1e-3
SLACK_TOL_NM = 1e-4
# the share of a row moves with its slack at about 0.7..3 N·m per unit of share: the FK's 1e-4 N·m
# moves it by less than 2e-4
SHARE_TOL = 1e-3

CHECKS: list[RowCheck] = []  # in the order they run
check = registrar(CHECKS)


@check("thrust out of range", "each fan's thrust within [0, F_max] of the fan and of the scenario")
def _thrust_range(x: RowData) -> list[Finding]:
    out = []
    for k, fan in enumerate(x.fans):
        f = x.thrust[:, k]
        out += rows(~((f >= 0.0) & (f <= x.fmax[k] + 1e-9)), lambda i, k=k, fan=fan: f"{fan.name} fan "
                    f"{x.thrust[i, k]:.3f} N outside [0, {x.fmax[k]:g}] N (the fan's rating and the scenario's limit)")
    return out


@check("thrust on the support foot", "a fan on a sole never pushes while its foot alone supports the robot")
def _support_fan(x: RowData) -> list[Finding]:
    out = []
    for k, fan in enumerate(x.fans):
        if fan.leg is not None:
            out += rows((x.support == fan.leg) & (x.thrust[:, k] != 0.0), lambda i, k=k, fan=fan: f"{fan.name} fan "
                        f"{x.thrust[i, k]:.3f} N while its foot supports the robot")
    return out


@check("ZMP outside support", "the ZMP of the written thrust (A-1, A-2) in the support sole (double support: the "
       "hull of both)")
def _zmp_inside(x: RowData) -> list[Finding]:
    # the minimal thrust puts the ZMP on the sole's edge; the fan's FK position may differ from the
    # planned one by the IK tolerance, so the edge is given that much
    margin = support_margin(x.zmp, *x.support_edges)
    outside = ~(margin >= -TOL_M)
    where = np.where(x.on_one_sole, "the support sole", "the hull of both soles")
    total = x.thrust.sum(axis=1)
    return rows(outside, lambda i: f"ZMP {np.round(x.zmp[i], 4).tolist()} m with the written thrust ({total[i]:.3f} N) "
                f"is outside {where[i]}")


@check("ground would have to pull", "the rows' own motion (second central differences of the written poses, "
       "the fans' written thrust) needs the ground to push, not pull, on every inner row")
def _ground_pushes(x: RowData) -> list[Finding]:
    fz = x.vertical_force
    if fz is None:
        return []
    pull = np.zeros(x.n, dtype=bool)
    pull[1:-1] = fz[1:-1] <= 0.0
    return rows(pull, lambda i: f"the motion needs {fz[i]:.2f} N of vertical ground force: the trunk falls faster "
                "than gravity between the rows around it")


@check("CoM column wrong", "the written CoM is the posture's", needs=(COM[0],))
def _com_column(x: RowData) -> list[Finding]:
    c, com = x.c, x.fk["com"]
    written = np.stack([c[COM[0]], c[COM[1]], c[COM[2]]], axis=1).astype(float)
    return rows(~(np.linalg.norm(written - com, axis=1) <= 1e-9), lambda i: f"written "
                f"{np.round(written[i], 6).tolist()}, recomputed {np.round(com[i], 6).tolist()}")


@check("ZMP column wrong", "the written ZMP is the written thrust's", needs=(ZMP[0],))
def _zmp_column(x: RowData) -> list[Finding]:
    wz = np.stack([x.c[ZMP[0]], x.c[ZMP[1]]], axis=1).astype(float)
    return rows(~(np.linalg.norm(wz - x.zmp, axis=1) <= TOL_M), lambda i: f"written {np.round(wz[i], 6).tolist()}, "
                f"recomputed {np.round(x.zmp[i], 6).tolist()}")


@check("ZMP margin column wrong", "the written ZMP margin is the ZMP's distance inside the support",
       needs=(WINDOW[0], ZMP_MARGIN))
def _margin_column(x: RowData) -> list[Finding]:
    margin_w = x.c[ZMP_MARGIN].astype(float)
    margin = support_margin(x.zmp, *x.support_edges)
    check = np.isfinite(x.zmp).all(axis=1)
    return rows(check & ~(np.abs(margin - margin_w) <= TOL_M), lambda i: f"written {margin_w[i]:.6f} m, recomputed "
                f"{margin[i]:.6f} m")


@check("thrust window column wrong", "the written thrust window is the posture's", needs=(WINDOW[0],))
def _window_column(x: RowData) -> list[Finding]:
    lo, hi, computed = x.windows
    lo_w, hi_w = x.c[WINDOW[0]].astype(float), x.c[WINDOW[1]].astype(float)
    bad = computed & ~((np.abs(lo - lo_w) <= WINDOW_TOL_N) & (np.abs(hi - hi_w) <= WINDOW_TOL_N))
    return rows(bad, lambda i: f"written [{lo_w[i]:.4f}, {hi_w[i]:.4f}] N, recomputed [{lo[i]:.4f}, {hi[i]:.4f}] N")


@check("thrust outside its window", "the written thrust within the posture's window", needs=(WINDOW[0],))
def _in_window(x: RowData) -> list[Finding]:
    lo, hi, computed = x.windows
    total = x.thrust.sum(axis=1)
    bad = computed & ~((lo - WINDOW_TOL_N <= total) & (total <= hi + WINDOW_TOL_N))

    def detail(i: int) -> str:
        share = x.thrust[i] / total[i] if total[i] > 0 else np.zeros(len(x.fans))
        carry = np.flatnonzero(share > 0) if total[i] > 0 else np.array(x.robot.swing_fans(
            other_side(x.support[i]))[:1], dtype=int)
        names = "+".join(x.robot.fans[k].name for k in carry)
        return f"{names} fan {total[i]:.3f} N outside [{lo[i]:.3f}, {hi[i]:.3f}] N"
    return rows(bad, detail)


def _plan_tolerance(x: RowData) -> Tolerance:
    """The plan's tolerance, from its ``balance`` block."""
    tol_doc = (x.balance or {}).get("tolerance", {})
    return Tolerance(*(float(tol_doc.get(key, 0.0)) for key in ("thrust_error", "mass_error", "com_error_m")))


@check("below the tolerance", "under the plan's tolerance, the ZMP in the support for every error within the "
       "row's share of it (the whole of it where the plan has no shares)", needs=(WINDOW[0],))
def _tolerance(x: RowData) -> list[Finding]:
    if x.balance is None:
        return []
    tol = _plan_tolerance(x)
    shares = x.c[TOLERANCE_SHARE].astype(float) if TOLERANCE_SHARE in x.c else np.full(x.n, np.nan)
    share = np.where(np.isfinite(shares) & (not tol.nominal), shares, 1.0)
    at = np.flatnonzero(np.isfinite(x.zmp).all(axis=1))
    normals, offsets = x.tolerance_edges
    slack = np.full(x.n, np.inf)
    slack[at] = balance_slack(x.fk["com"][at, :2], x.fk["fans"][at], x.thrust[at], normals[at], offsets[at],
                              x.robot.mass_kg, tol, share[at])

    def detail(i: int) -> str:
        held = tol.times(float(share[i]))
        return (f"the written thrust keeps the ZMP in the support only without ±{100 * held.thrust:g} % thrust, "
                f"±{100 * held.mass:g} % mass and {1000 * held.com_m:g} mm CoM error ({-slack[i]:.4f} N·m short)"
                + (f" ({share[i]:.4f} of the plan's tolerance)" if share[i] < 1.0 else ""))
    return rows(slack < -SLACK_TOL_NM, detail)


@check("tolerance share column wrong", "under a tolerance, the written share is the largest share of it the row's "
       "thrust holds (recomputed, ``verify.balance.largest_share``)", needs=(TOLERANCE_SHARE,))
def _share_column(x: RowData) -> list[Finding]:
    if x.balance is None:
        return []
    tol = _plan_tolerance(x)
    if tol.nominal:
        return []
    written = x.c[TOLERANCE_SHARE].astype(float)
    at = np.flatnonzero(np.isfinite(x.zmp).all(axis=1))
    normals, offsets = x.tolerance_edges
    again = np.full(x.n, np.nan)
    again[at] = largest_share(x.fk["com"][at, :2], x.fk["fans"][at], x.thrust[at], normals[at], offsets[at],
                              x.robot.mass_kg, tol)
    out = []
    for i in at.tolist():
        if not np.isfinite(written[i]):
            out.append((i, "empty under a tolerance"))
        elif abs(again[i] - written[i]) > SHARE_TOL:
            out.append((i, f"written {written[i]:.6f}, recomputed {again[i]:.6f}"))
    return out


@check("below the least share", "every row's tolerance share at least the plan's ``min_share``",
       needs=(TOLERANCE_SHARE,))
def _least_share(x: RowData) -> list[Finding]:
    least = float((x.balance or {}).get("min_share") or 0.0)
    written = x.c[TOLERANCE_SHARE].astype(float)
    return rows(np.isfinite(written) & (written < least - SHARE_TOL),
                lambda i: f"tolerance share {written[i]:.4f} below the plan's min_share {least:g}")
