"""``jethr1 ditch-curve``: the widest ditch a robot can cross, and the thrust it needs, at each tolerance.

Paper A's forward step (motion 2) over a gap g between two cartons: the right sole supports on
carton A with its toe on A's front edge (x = 0.080 m, the sole at (0, −0.1125, 0) m of Fig. 6), the
left sole starts beside it and lands with its heel 5 mm inside carton B, whose rear edge is at
0.080 + g: the landing sole centre is at (g + 0.165, −0.1125, 0) m. For every gap and every tolerance
(the scenario's robust tolerance scaled by k; k = 0 is Paper A's minimal thrust) the step is planned
in full (samples and output rows); a gap is crossable when the plan is feasible. The planner does
the work: what is crossable is exactly what ``jethr1 plan`` would plan.
"""

from __future__ import annotations

import io
from dataclasses import replace
from typing import Any

import numpy as np

from jethr1_plan.errors import InfeasiblePlan
from jethr1_plan.physics.balance import Tolerance
from jethr1_plan.scenario import BalanceConfig, Scenario, Step, Timing
from jethr1_plan.swing_path import Carton, arc_path

__all__ = ["TOE_X_M", "curve", "curve_png", "ditch_scenario", "landing_x"]

TOE_X_M = 0.080  # carton A's front edge: the support sole's toe [m]
HEEL_INSIDE_M = 0.005  # the landing sole's heel lies this far inside carton B [m]
SUPPORT_Y_M = -0.1125  # Fig. 6's support foot [m]


def landing_x(gap_m: float, sole_length_m: float) -> float:
    """x [m] of the landing sole centre for a gap ``gap_m`` [m]."""
    return TOE_X_M + gap_m + HEEL_INSIDE_M + sole_length_m / 2


def ditch_scenario(base: Scenario, gap_m: float, tolerance: Tolerance, sole_length_m: float) -> Scenario:
    """``base`` (its robot, optimiser, timing, balance limits) on Paper A's ditch of width ``gap_m``,
    planned with ``tolerance`` (all zero: the minimal policy)."""
    size = (0.21, 0.11, 0.14)
    landing = np.array([landing_x(gap_m, sole_length_m), SUPPORT_Y_M, 0.0])
    start = {"left": np.array([0.0, -SUPPORT_Y_M, 0.0]), "right": np.array([0.0, SUPPORT_Y_M, 0.0])}
    cartons = (Carton((TOE_X_M - size[0] / 2, SUPPORT_Y_M, 0.0), size),
               Carton((TOE_X_M - size[0] / 2, -SUPPORT_Y_M, 0.0), size),
               Carton((TOE_X_M + gap_m + size[0] / 2, SUPPORT_Y_M, 0.0), size))
    path = arc_path(start["left"], landing, 0.06, 60)
    policy = "minimal" if tolerance == Tolerance() else "robust"
    balance = BalanceConfig(base.balance.thrust_max_n, base.balance.rho_rad, base.balance.sole_margin_m, policy,
                            tolerance)
    return replace(base, name=f"ditch_{gap_m:.3f}", start=start, cartons=cartons, steps=(Step("left", path),),
                   balance=balance, expect={})


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
    """The ditch curve: per tolerance (``scales`` × the scenario's robust tolerance), the max thrust
    [N] at every gap (None: infeasible), the widest crossable gap [m] and its thrust.

    Gaps beyond two infeasible ones in a row are not planned (a wider ditch is not easier); they
    count as infeasible, with that reason.
    """
    from joblib import Parallel, delayed

    robust = base.balance.robust
    tolerances = [robust.scaled(k) for k in scales]
    rows: list[dict[str, Any]] = []
    for tol in tolerances:
        rows.append({"thrust_error": tol.thrust, "mass_error": tol.mass, "com_error_m": tol.com_m,
                     "max_thrust_n": [None] * len(gaps_m), "reason": [None] * len(gaps_m)})
    # one wave of gaps at a time per tolerance, so that a run of failures can stop a tolerance early
    pending = {t: 0 for t in range(len(tolerances))}
    misses = {t: 0 for t in range(len(tolerances))}
    done, total = 0, len(gaps_m) * len(tolerances)
    with Parallel(n_jobs=jobs) as parallel:
        while pending:
            batch = [(t, pending[t]) for t in sorted(pending)]
            outs = parallel(delayed(_feasible_thrust)(ditch_scenario(base, float(gaps_m[g]), tolerances[t],
                                                                     sole_length_m)) for t, g in batch)
            for (t, g), (thrust, reason) in zip(batch, outs, strict=True):
                rows[t]["max_thrust_n"][g], rows[t]["reason"][g] = thrust, reason
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
        ok = [g for g, f in zip(gaps_m, row["max_thrust_n"], strict=True) if f is not None]
        row["widest_gap_m"] = float(max(ok)) if ok else None
        row["thrust_at_widest_n"] = (row["max_thrust_n"][list(gaps_m).index(max(ok))] if ok else None)
    return {"robot": base.robot.name, "optimiser": base.optimiser.method, "thrust_max_n": base.balance.thrust_max_n,
            "geometry": {"toe_x_m": TOE_X_M, "heel_inside_m": HEEL_INSIDE_M, "support_y_m": SUPPORT_Y_M},
            "scales": list(scales), "gaps_m": [float(g) for g in gaps_m], "tolerances": rows}


def curve_png(doc: dict) -> bytes:
    """Max thrust against gap, one line per tolerance, the widest gap of each marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5), constrained_layout=True)
    gaps = np.array(doc["gaps_m"])
    for row in doc["tolerances"]:
        f = np.array([np.nan if v is None else v for v in row["max_thrust_n"]])
        label = ("minimal (Paper A)" if row["thrust_error"] == 0 and row["mass_error"] == 0 and row["com_error_m"] == 0
                 else f"±{100 * row['thrust_error']:.1f} % F, ±{100 * row['mass_error']:.1f} % M, "
                      f"{1000 * row['com_error_m']:.1f} mm CoM")
        line, = ax.plot(gaps * 1000, f, "o-", ms=3, label=label)
        if row["widest_gap_m"] is not None:
            ax.plot(row["widest_gap_m"] * 1000, row["thrust_at_widest_n"], "*", ms=14, color=line.get_color())
    ax.axhline(doc["thrust_max_n"], color="k", ls="--", lw=1, label="fan maximum")
    ax.set_xlabel("ditch width [mm]")
    ax.set_ylabel("max thrust of the plan [N]")
    ax.set_title(f"{doc['robot']}: widest ditch per tolerance (stars), {doc['optimiser']}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def default_base() -> Scenario:
    """A scenario with every default (robot jethr1, Paper A's timing), as the curve's base."""
    from jethr1_plan.optimisers import OptimiserConfig
    from jethr1_plan.robot.model import load_robot
    from jethr1_plan.scenario import BodyYaw

    robot = load_robot("jethr1")
    return Scenario(source="ditch-curve", name="ditch", robot=robot, seed=1, start={}, cartons=(), steps=(),
                    optimiser=OptimiserConfig(),
                    balance=BalanceConfig(thrust_max_n=max(f.max_thrust_n for f in robot.fans)), body_yaw=BodyYaw(),
                    timing=Timing(7.5, 3.0, 50.0), nominal_height_m=None)
