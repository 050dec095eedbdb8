"""``jethr1 compare``: Paper A's comparison (IV-B, Figs. 7, 9, 10) on any scenario.

Runs each optimiser on the same scenario and seed and reports, per method, the thrust (max, mean),
the smoothness of P_body (Σ‖ΔP_body‖², the largest single step) and of the thrust (largest jump),
the evaluations and the wall time. With ``reference``, every swing sample is also solved by a dense
exhaustive search (every pelvis position from which the legs reach within their joint limits, on a
1 cm grid, the six best basins refined on a 1 mm grid, then 0.2 and 0.04 mm grids around the best;
``optimisers.exhaustive``), and each method's optimality gap is reported against it.

``pareto`` (``compare --pareto``) sweeps each method's smoothness weight instead and reports the
fronts of max and mean thrust against Σ‖ΔP_body‖², with the verdict on the default optimiser: its
point dominates GAS's with at least ``EVALUATION_FACTOR`` times fewer evaluations.
"""

from __future__ import annotations

import io
import time
from dataclasses import replace
from typing import Any

import numpy as np

from jethr1_plan.optimisers.exhaustive import exhaustive_cell
from jethr1_plan.optimisers.search import Cells, Evaluator, SupportStance
from jethr1_plan.planning.plan import plan
from jethr1_plan.planning.problems import feet_before_each_step
from jethr1_plan.planning.report import plan_summary, smoothness
from jethr1_plan.reasons import Reason
from jethr1_plan.scenario import Scenario

__all__ = ["EVALUATION_FACTOR", "GA_OMEGAS", "MEASURES", "PARETO_WEIGHTS", "compare", "comparison_pngs",
           "default_weight", "dominates", "pareto", "pareto_png", "reference_thrust", "run_method", "step_evaluator",
           "with_weight"]


def run_method(scenario: Scenario, method: str, seed: int | None) -> dict:
    """One optimiser over every step; the wall time is the optimisation's, the yaw figures come from
    the output-rate sequence (feasible plans only)."""
    result = plan(scenario, method=method, seed=seed, keep_going=True)
    wall = result.optimise_s
    yaw = plan_summary(result).get("yaw", {}) if result.feasible else {}
    p_body = [st.p_body for st in result.steps]
    thrust = [st.thrust_n for st in result.steps]
    allt = np.concatenate(thrust)
    sm = [smoothness(p, t) for p, t in zip(p_body, thrust, strict=True)]
    finite = allt[np.isfinite(allt)]
    dyn = result.rows.analysis.get("dynamics") if result.rows is not None else None
    least = dyn.least()[1] if dyn is not None and len(dyn.margin) else None
    return {
        "peak_thrust_n": float(finite.max()) if len(finite) else None,
        "mean_thrust_n": float(finite.mean()) if len(finite) else None,
        "smoothness_m2": float(sum(s["smoothness_m2"] for s in sm)),
        "max_step_m": float(max(s["max_step_m"] for s in sm)),
        "max_thrust_jump_n": float(max(s["max_thrust_jump_n"] for s in sm)),
        "evaluations": int(result.evaluations),
        "yaw_mode": scenario.yaw_mode,
        "peak_yaw_rate_rad_s": yaw.get("peak_rate_rad_s"),
        "peak_yaw_accel_rad_s2": yaw.get("peak_accel_rad_s2"),
        "wall_s": float(wall),
        "feasible": bool(result.feasible),
        # the rows' own motion (physics.row_dynamics): the multibody ZMP's least margin [m] (None: a row
        # needs the ground to pull)
        "dynamic_zmp_margin_m": least if least is not None and np.isfinite(least) else None,
        "first_infeasible": None if result.first_infeasible is None else result.first_infeasible.to_dict(),
        "p_body_m": [p.tolist() for p in p_body],
        "thrust_n": [[float(x) if np.isfinite(x) else None for x in t] for t in thrust],
    }


def step_evaluator(scenario: Scenario, si: int) -> tuple[Evaluator, Cells]:
    """The search objective of step ``si`` (its support sole, balance settings and body yaw (A-4))
    and its swing samples as cells: what the exhaustive search runs on."""
    st = scenario.steps[si]
    feet = feet_before_each_step(scenario)[si]
    b = scenario.balance
    stance = SupportStance(st.support, tuple(feet[st.support]), b.rho_rad, b.thrust_max_n, b.sole_margin_m,
                           b.tolerance)
    ev = Evaluator(scenario.robot, stance)
    return ev, ev.cells(st.path_m)


def reference_thrust(scenario: Scenario, pbody_resolution_m: float = 0.01) -> list[list[float | None]]:
    """Per step and sample, the least thrust [N] found by the dense exhaustive search (None: none)."""
    out = []
    for si, st in enumerate(scenario.steps):
        ev, cells = step_evaluator(scenario, si)
        row = []
        for i in range(len(st.path_m)):
            _, f, reason = exhaustive_cell(ev, cells, i, pbody_resolution_m)
            row.append(float(f) if reason == Reason.OK else None)
        out.append(row)
    return out


def compare(scenario: Scenario, methods: tuple[str, ...] = ("gas", "ga", "gaex", "sqp"), seed: int | None = None,
            reference: bool = False, progress=None, yaw_modes: tuple[str, ...] = ("eq4",)) -> dict:
    """The comparison document (``--json``). Methods run under each body-yaw mode; a mode other
    than the first is reported as ``method+mode`` (e.g. ``gas+mpc``) with its thrust cost."""
    doc: dict[str, Any] = {"scenario": scenario.name, "seed": scenario.seed if seed is None else seed, "methods": {}}
    runs = [(m, y) for y in yaw_modes for m in methods]
    for k, (m, y) in enumerate(runs):
        key = m if y == yaw_modes[0] else f"{m}+{y}"
        doc["methods"][key] = run_method(replace(scenario, body_yaw=replace(scenario.body_yaw, mode=y)), m, seed)
        if y != yaw_modes[0]:
            base = doc["methods"][m]
            r = doc["methods"][key]
            r["thrust_cost_vs"] = {"against": m, "max_n": (r["peak_thrust_n"] or 0) - (base["peak_thrust_n"] or 0),
                                   "mean_n": (r["mean_thrust_n"] or 0) - (base["mean_thrust_n"] or 0)}
        if progress:
            progress(key, k + 1, len(runs) + int(reference))
    if reference:
        t0 = time.perf_counter()
        ref = reference_thrust(scenario)
        doc["reference"] = {"thrust_n": ref, "wall_s": time.perf_counter() - t0}
        limit = scenario.balance.thrust_max_n
        for m in doc["methods"]:
            gaps = [t - r for tt, rr in zip(doc["methods"][m]["thrust_n"], ref, strict=True)
                    for t, r in zip(tt, rr, strict=True) if t is not None and r is not None]
            g = np.array(gaps) if gaps else np.zeros(1)
            doc["methods"][m]["gap_max_n"] = float(g.max())
            doc["methods"][m]["gap_mean_n"] = float(g.mean())
            doc["methods"][m]["gap_max_pct_of_limit"] = float(100 * g.max() / limit) if limit > 0 else None
        if progress:
            progress("reference", len(runs) + 1, len(runs) + 1)
    return doc


def comparison_pngs(doc: dict) -> dict[str, bytes]:
    """Figs. 7/9 (P_body components and thrust along each swing) and Fig. 10 (computation time)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = {}
    methods = doc["methods"]
    n_steps = len(next(iter(methods.values()))["p_body_m"])
    fig, axes = plt.subplots(4, n_steps, figsize=(6 * n_steps, 11), squeeze=False, sharex="col",
                             constrained_layout=True)
    for s in range(n_steps):
        for name, m in methods.items():
            p = np.array(m["p_body_m"][s])
            t = np.array([np.nan if v is None else v for v in m["thrust_n"][s]])
            for k, label in enumerate(("P_body x [m]", "P_body y [m]", "P_body z [m]")):
                axes[k, s].plot(p[:, k], label=name)
                axes[k, s].set_ylabel(label)
            axes[3, s].plot(t, label=name)
        if "reference" in doc:
            r = np.array([np.nan if v is None else v for v in doc["reference"]["thrust_n"][s]])
            axes[3, s].plot(r, "k--", lw=1, label="exhaustive reference")
        axes[3, s].set_ylabel("thrust [N]")
        axes[3, s].set_xlabel("swing sample")
        axes[0, s].set_title(f"{doc['scenario']}: step {s}")
        for ax in axes[:, s]:
            ax.grid(alpha=0.3)
        axes[3, s].legend(fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    out["compare_trajectories.png"] = buf.getvalue()
    fig, ax = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    names = list(methods)
    ax[0].bar(names, [methods[n]["wall_s"] for n in names])
    ax[0].set_ylabel("computation time [s]")
    ax[1].bar(names, [methods[n]["evaluations"] for n in names])
    ax[1].set_ylabel("posture evaluations")
    for a in ax:
        a.grid(alpha=0.3, axis="y")
    fig.suptitle(f"{doc['scenario']}: computation (Paper A, Fig. 10)")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    out["compare_time.png"] = buf.getvalue()
    return out


#: the smoothness weights ``compare --pareto`` sweeps: the GAs' ω [per mm², against 10 per N] and sqp's ε [N/m²]
GA_OMEGAS = (5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0)
PARETO_WEIGHTS: dict[str, tuple[float, ...]] = {"gas": GA_OMEGAS, "ga": GA_OMEGAS, "gaex": GA_OMEGAS,
                                                "sqp": (10.0, 1e3, 1e4, 3e4, 7e4, 1e5, 2e5, 5e5, 1e6)}
MEASURES = ("peak_thrust_n", "mean_thrust_n", "smoothness_m2")  # what the fronts compare (lower is better)
#: what the Pareto verdict asks of a method against GAS at its default: fewer evaluations by this factor
EVALUATION_FACTOR = 10.0


def with_weight(scenario: Scenario, method: str, weight: float) -> Scenario:
    """``scenario`` with ``method``'s smoothness weight set (ω for the GAs, ε for sqp)."""
    o = scenario.optimiser
    if method == "sqp":
        o = replace(o, method=method, sqp_smoothness_n_per_m2=float(weight))
    else:
        o = replace(o, method=method, constants=replace(o.constants, omega=float(weight)))
    return replace(scenario, optimiser=o)


def default_weight(scenario: Scenario, method: str) -> float:
    """The scenario's (or the default) smoothness weight of ``method``."""
    o = scenario.optimiser
    return float(o.sqp_smoothness_n_per_m2 if method == "sqp" else o.constants.omega)


def dominates(a: dict, b: dict) -> bool:
    """Whether plan ``a`` is at least as good as ``b`` in max thrust, mean thrust and Σ‖ΔP_body‖² (all
    lower is better)."""
    return all(a[k] is not None and b[k] is not None and a[k] <= b[k] for k in MEASURES)


def _point(scenario: Scenario, method: str, weight: float, seed: int | None) -> dict:
    r = run_method(with_weight(scenario, method, weight), method, seed)
    return {"weight": weight, **{k: r[k] for k in ("peak_thrust_n", "mean_thrust_n", "smoothness_m2", "max_step_m",
                                                   "evaluations", "wall_s", "feasible")}}


def pareto(scenario: Scenario, methods: tuple[str, ...] = ("gas", "sqp"), seed: int | None = None,
           weights: dict[str, tuple[float, ...]] | None = None, jobs: int = 1, progress=None) -> dict:
    """The fronts of max and mean thrust against Σ‖ΔP_body‖² as each method's smoothness weight is swept
    (``PARETO_WEIGHTS``; one plan per weight, in ``jobs`` processes: the document does not depend on it
    but for wall times). Each point says whether it is on its method's front (no other point of the
    method is as good in all three and better in one). ``verdict``: per method, whether its point at the
    scenario's weight dominates GAS's at its weight with ``EVALUATION_FACTOR`` times fewer evaluations.
    """
    from joblib import delayed

    from jethr1_plan.io.pool import parallel

    weights = {**PARETO_WEIGHTS, **(weights or {})}
    runs = [(m, w) for m in methods for w in sorted(set(weights[m]) | {default_weight(scenario, m)})]
    if jobs > 1:
        points = list(parallel(jobs)(delayed(_point)(scenario, m, w, seed) for m, w in runs))
    else:
        points = []
        for k, (m, w) in enumerate(runs):
            points.append(_point(scenario, m, w, seed))
            if progress:
                progress(f"{m} at {w:g}", k + 1, len(runs))
    doc: dict[str, Any] = {"scenario": scenario.name, "seed": scenario.seed if seed is None else seed,
                           "policy": scenario.balance.policy, "default_method": scenario.optimiser.method,
                           "defaults": {m: default_weight(scenario, m) for m in methods}, "fronts": {}}
    for m in methods:
        pts = [p for (mm, _), p in zip(runs, points, strict=True) if mm == m]
        for p in pts:
            p["default"] = p["weight"] == doc["defaults"][m]
            beaten = any(q is not p and q["feasible"] and dominates(q, p) and any(q[k] < p[k] for k in MEASURES)
                         for q in pts)
            p["on_front"] = bool(p["feasible"]) and not beaten
        doc["fronts"][m] = pts
    if "gas" in methods:
        ref = next(p for p in doc["fronts"]["gas"] if p["default"])
        doc["verdict"] = {}
        for m in methods:
            if m == "gas":
                continue
            mine = next(p for p in doc["fronts"][m] if p["default"])
            factor = ref["evaluations"] / max(mine["evaluations"], 1)
            doc["verdict"][m] = {
                "dominates_gas": bool(mine["feasible"] and dominates(mine, ref) and factor >= EVALUATION_FACTOR),
                "peak_thrust_n": [mine["peak_thrust_n"], ref["peak_thrust_n"]],
                "mean_thrust_n": [mine["mean_thrust_n"], ref["mean_thrust_n"]],
                "smoothness_m2": [mine["smoothness_m2"], ref["smoothness_m2"]],
                "evaluation_factor": factor,
            }
    return doc


def pareto_png(doc: dict) -> bytes:
    """Max and mean thrust against Σ‖ΔP_body‖², a line per method through its weights; the defaults starred."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    for ax, key, label in ((axes[0], "peak_thrust_n", "max thrust [N]"), (axes[1], "mean_thrust_n", "mean thrust [N]")):
        for m, pts in doc["fronts"].items():
            ok = [p for p in pts if p["feasible"]]
            line, = ax.plot([p["smoothness_m2"] for p in ok], [p[key] for p in ok], "o-", label=m, ms=4)
            for p in ok:
                ax.annotate(f"{p['weight']:g}", (p["smoothness_m2"], p[key]), fontsize=6, alpha=0.7,
                            xytext=(3, 3), textcoords="offset points")
            d = [p for p in ok if p["default"]]
            if d:
                ax.plot(d[0]["smoothness_m2"], d[0][key], "*", ms=16, color=line.get_color(), mec="k",
                        label=f"{m} default ({d[0]['weight']:g})")
        ax.set_xlabel("Σ‖ΔP_body‖² [m²]")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"{doc['scenario']} ({doc['policy']} policy): thrust against smoothness as the weight is swept "
                 "(GAS: ω per mm²; sqp: ε N/m²)")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return buf.getvalue()
