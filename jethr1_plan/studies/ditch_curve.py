"""``jethr1 ditch-curve``: how robust a crossing of each ditch can be, and the thrust it needs.

Paper A's forward step (motion 2) over a gap g between two cartons: the right sole supports on
carton A with its toe on A's front edge (x = 0.080 m, the sole at (0, −0.1125, 0) m of Fig. 6), the
left sole starts beside it and lands with its heel 5 mm inside carton B, whose rear edge is at
0.080 + g: the landing sole centre is at (g + 0.165, −0.1125, 0) m.

**The robustness curve** (:func:`robustness_curve`): every gap is planned in full under the robust
policy with the scenario's tolerance T as the objective (``balance.robust``, ``min_share`` 0): each
swing sample takes the largest share of T a posture reaches within F_max, and the plan's least
``tolerance_share`` over its rows is the largest share of T with which that gap is crossed (the share
of the hardest row, usually the landing); beside it the plan's peak and mean thrust. A gap none of
whose postures balances even without errors is not crossable (share None).

**Fixed tolerances** (:func:`curve`, ``--scales``): every gap planned at k × T for each k (k = 0 is
Paper A's minimal thrust) with ``min_share`` 1; a gap is crossable at k when that plan is feasible:
when every row holds the whole of k × T.

The planner does the work: what is reported is exactly what ``jethr1 plan`` would plan.
"""

from __future__ import annotations

import io
from dataclasses import replace
from typing import Any

import numpy as np

from jethr1_plan.errors import InfeasiblePlan
from jethr1_plan.physics.balance import Tolerance
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.scenario import BalanceConfig, Scenario, Step, Timing
from jethr1_plan.swing_path import Carton, arc_path

__all__ = ["TOE_X_M", "curve", "curve_png", "ditch_scenario", "landing_x", "robustness_curve", "share_of_gap"]

TOE_X_M = 0.080  # carton A's front edge: the support sole's toe [m]
HEEL_INSIDE_M = 0.005  # the landing sole's heel lies this far inside carton B [m]
SUPPORT_Y_M = -0.1125  # Fig. 6's support foot [m]


def landing_x(gap_m: float, sole_length_m: float) -> float:
    """x [m] of the landing sole centre for a gap ``gap_m`` [m]."""
    return TOE_X_M + gap_m + HEEL_INSIDE_M + sole_length_m / 2


def ditch_scenario(base: Scenario, gap_m: float, tolerance: Tolerance, sole_length_m: float,
                   min_share: float = 0.0) -> Scenario:
    """``base`` (its robot, optimiser, timing, balance limits) on Paper A's ditch of width ``gap_m``,
    planned with ``tolerance`` (all zero: the minimal policy) as the objective: where the whole of it
    is out of reach a sample takes the largest share of it, and a share below ``min_share`` (1: the
    whole tolerance everywhere) makes the plan infeasible."""
    size = (0.21, 0.11, 0.14)
    landing = np.array([landing_x(gap_m, sole_length_m), SUPPORT_Y_M, 0.0])
    start = {"left": np.array([0.0, -SUPPORT_Y_M, 0.0]), "right": np.array([0.0, SUPPORT_Y_M, 0.0])}
    cartons = (Carton((TOE_X_M - size[0] / 2, SUPPORT_Y_M, 0.0), size),
               Carton((TOE_X_M - size[0] / 2, -SUPPORT_Y_M, 0.0), size),
               Carton((TOE_X_M + gap_m + size[0] / 2, SUPPORT_Y_M, 0.0), size))
    path = arc_path(start["left"], landing, 0.06, 60)
    policy = "minimal" if tolerance == Tolerance() else "robust"
    balance = BalanceConfig(base.balance.thrust_max_n, base.balance.rho_rad, base.balance.sole_margin_m, policy,
                            tolerance, min_share=min_share)
    return replace(base, name=f"ditch_{gap_m:.3f}", start=start, cartons=cartons, steps=(Step("left", path),),
                   balance=balance, expect={})


def share_of_gap(scenario: Scenario, energy: bool = False) -> dict[str, Any]:
    """One gap under the robust policy with its tolerance as the objective: the plan's least
    tolerance share, where, what it means, its peak thrust [N] (output rows) and mean thrust [N]
    (swing samples); share None and the reason where no plan exists. With ``energy``, also the
    joints' energy of the crossing ``energy_j`` [J] (B-44, ``summary.json``'s) and the fans' thrust
    impulse ``impulse_ns`` [N·s] (∫ Σ_i F_i dt over the rows, trapezoidal)."""
    from jethr1_plan.planning.plan import plan
    from jethr1_plan.planning.report import share_summary

    try:
        result = plan(scenario)
    except InfeasiblePlan as exc:
        return {"share": None, "reason": str(exc)}
    if not result.feasible or result.rows is None:
        bad = result.first_infeasible
        return {"share": None, "reason": bad.reason if bad is not None else "infeasible"}
    rows = result.rows
    fans = [f.name for f in scenario.robot.fans]
    peak = float(max(np.max(rows.fan(f)) for f in fans))
    swing = np.concatenate([st.thrust_n for st in result.steps])
    shares = share_summary(rows, scenario.balance.tolerance)
    assert shares is not None  # a robust plan carries a share on every row
    out = {"share": shares["least"], "share_at": shares["least_at"], "tolerance": shares["tolerance"],
           "rows_below_full": shares["rows_below_full"], "peak_thrust_n": peak,
           "mean_thrust_n": float(np.mean(swing[np.isfinite(swing)])), "reason": None}
    if energy:
        total = np.sum([rows.fan(f) for f in fans], axis=0)
        out["energy_j"] = float(rows.analysis["energy_j"])
        out["impulse_ns"] = float(0.5 * np.sum(total[1:] + total[:-1]) / scenario.timing.rate_hz)
    return out


def robustness_curve(base: Scenario, gaps_m: np.ndarray, sole_length_m: float, jobs: int = 1,
                     progress=None) -> list[dict[str, Any]]:
    """Per gap (in order): :func:`share_of_gap` of Paper A's step planned with the base scenario's
    robust tolerance as the objective, with ``gap_m``."""
    from joblib import delayed

    from jethr1_plan.io.pool import parallel

    scenarios = [ditch_scenario(base, float(g), base.balance.robust, sole_length_m) for g in gaps_m]
    out: list[dict[str, Any]] = []
    with parallel(jobs, return_as="generator") as pool:
        for g, r in zip(gaps_m, pool(delayed(share_of_gap)(sc) for sc in scenarios), strict=True):
            out.append({"gap_m": float(g), **r})
            if progress:
                progress(f"{len(out)}/{len(scenarios)} robust plans", len(out), len(scenarios))
    return out


def _feasible_thrust(scenario: Scenario) -> tuple[float | None, str | None]:
    """(max thrust [N], None) of a feasible plan; (None, the reason) of an infeasible one."""
    from jethr1_plan.planning.plan import plan

    try:
        result = plan(scenario)
    except InfeasiblePlan as exc:
        return None, str(exc)
    thrust = np.concatenate([st.thrust_n for st in result.steps])
    return float(thrust.max()), None


def curve(base: Scenario, gaps_m: np.ndarray, scales: tuple[float, ...], sole_length_m: float, jobs: int = 1,
          progress=None) -> dict:
    """The ditch curve: per gap, the largest share of the scenario's robust tolerance that crosses it
    and the thrust it needs (``robustness``, :func:`robustness_curve`); and per fixed tolerance
    (``scales`` × the robust tolerance; none when empty), the max thrust [N] at every gap (None:
    infeasible), the widest crossable gap [m] and its thrust (``tolerances``).

    At fixed tolerances, gaps beyond two infeasible ones in a row are not planned (a wider ditch is
    not easier); they count as infeasible, with that reason.
    """
    robust = base.balance.robust
    return {"robot": base.robot.name, "optimiser": base.optimiser.method, "thrust_max_n": base.balance.thrust_max_n,
            "geometry": {"toe_x_m": TOE_X_M, "heel_inside_m": HEEL_INSIDE_M, "support_y_m": SUPPORT_Y_M},
            "gaps_m": [float(g) for g in gaps_m],
            "robust_tolerance": {"thrust_error": robust.thrust, "mass_error": robust.mass, "com_error_m": robust.com_m},
            "robustness": robustness_curve(base, gaps_m, sole_length_m, jobs, progress),
            "scales": list(scales), "tolerances": _fixed(base, gaps_m, scales, sole_length_m, jobs, progress)}


def _fixed(base: Scenario, gaps_m: np.ndarray, scales: tuple[float, ...], sole_length_m: float, jobs: int,
           progress) -> list[dict[str, Any]]:
    """Per tolerance of ``scales``: the max thrust at every gap, the widest crossable gap and its thrust."""
    from joblib import delayed

    from jethr1_plan.io.pool import parallel

    robust = base.balance.robust
    tolerances = [robust.scaled(k) for k in scales]
    rows: list[dict[str, Any]] = []
    for tol in tolerances:
        rows.append({"thrust_error": tol.thrust, "mass_error": tol.mass, "com_error_m": tol.com_m,
                     "peak_thrust_n": [None] * len(gaps_m), "reason": [None] * len(gaps_m)})
    # one wave of gaps at a time per tolerance, so that a run of failures can stop a tolerance early
    pending = {t: 0 for t in range(len(tolerances))}
    misses = {t: 0 for t in range(len(tolerances))}
    done, total = 0, len(gaps_m) * len(tolerances)
    with parallel(jobs) as pool:
        while pending:
            batch = [(t, pending[t]) for t in sorted(pending)]
            outs = pool(delayed(_feasible_thrust)(ditch_scenario(base, float(gaps_m[g]), tolerances[t],
                                                                     sole_length_m, min_share=1.0))
                            for t, g in batch)
            for (t, g), (thrust, reason) in zip(batch, outs, strict=True):
                rows[t]["peak_thrust_n"][g], rows[t]["reason"][g] = thrust, reason
                misses[t] = 0 if thrust is not None else misses[t] + 1
                pending[t] = g + 1
                done += 1
                if pending[t] >= len(gaps_m) or misses[t] >= 2:
                    for rest in range(pending[t], len(gaps_m)):
                        rows[t]["reason"][rest] = "not planned: two narrower gaps were already infeasible"
                        done += 1
                    del pending[t]
            if progress:
                progress(f"{done}/{total} plans", done, total)
    for row in rows:
        ok = [g for g, f in zip(gaps_m, row["peak_thrust_n"], strict=True) if f is not None]
        row["widest_gap_m"] = float(max(ok)) if ok else None
        row["thrust_at_widest_n"] = (row["peak_thrust_n"][list(gaps_m).index(max(ok))] if ok else None)
    return rows


def curve_png(doc: dict) -> bytes:
    """Above: the largest share of the robust tolerance that crosses each gap. Below: the peak thrust
    that crossing needs, with one line per fixed tolerance (``--scales``), the widest gap of each starred."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, ax) = plt.subplots(2, 1, figsize=(8, 7.5), sharex=True, constrained_layout=True,
                                  gridspec_kw={"height_ratios": [2, 3]})
    gaps = np.array(doc["gaps_m"])
    rob = doc["robustness"]
    t = doc["robust_tolerance"]
    whole = (f"±{100 * t['thrust_error']:.1f} % F, ±{100 * t['mass_error']:.1f} % M, "
             f"{1000 * t['com_error_m']:.1f} mm CoM")
    share = np.array([np.nan if r["share"] is None else r["share"] for r in rob])
    top.plot(gaps * 1000, share, "o-", ms=4, color="tab:green")
    top.set_ylabel("largest share of the tolerance")
    top.set_ylim(-0.02, 1.05)
    top.set_title(f"{doc['robot']}, {doc['optimiser']}: the most robust crossing of each ditch\n"
                  f"(shares of the tolerance {whole})")
    top.grid(alpha=0.3)
    peak = np.array([np.nan if r["share"] is None else r["peak_thrust_n"] for r in rob])
    ax.plot(gaps * 1000, peak, "o-", ms=4, color="tab:green", lw=2, label="most robust plan (share above)")
    for row in doc["tolerances"]:
        f = np.array([np.nan if v is None else v for v in row["peak_thrust_n"]])
        label = ("minimal (Paper A)" if row["thrust_error"] == 0 and row["mass_error"] == 0 and row["com_error_m"] == 0
                 else f"±{100 * row['thrust_error']:.1f} % F, ±{100 * row['mass_error']:.1f} % M, "
                      f"{1000 * row['com_error_m']:.1f} mm CoM")
        line, = ax.plot(gaps * 1000, f, "o--", ms=3, lw=1, label=label)
        if row["widest_gap_m"] is not None:
            ax.plot(row["widest_gap_m"] * 1000, row["thrust_at_widest_n"], "*", ms=12, color=line.get_color())
    ax.axhline(doc["thrust_max_n"], color="k", ls="--", lw=1, label="fan maximum")
    ax.set_xlabel("ditch width [mm]")
    ax.set_ylabel("peak thrust of the plan [N]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def default_base(robot: RobotModel | None = None) -> Scenario:
    """A scenario with every default (Paper A's timing; ``robot``, default jethr1), as the curve's base; F_max
    is the largest maximum of the fans that may thrust while the left foot swings over the ditch."""
    from jethr1_plan.optimisers import OptimiserConfig
    from jethr1_plan.robot.load import load_robot
    from jethr1_plan.scenario import BodyYaw

    robot = robot or load_robot("jethr1")
    fans = [robot.fans[i].thrust_max_n for i in robot.swing_fans("left")]
    return Scenario(source="ditch-curve", name="ditch", robot=robot, seed=1, start={}, cartons=(), steps=(),
                    optimiser=OptimiserConfig(),
                    balance=BalanceConfig(thrust_max_n=max(fans, default=0.0)), body_yaw=BodyYaw(),
                    timing=Timing(7.5, 3.0, 50.0), nominal_height_m=None)
