"""The judge of ``jethr1 design``: a robot's widest ditches (docs/design.md).

Paper A's forward step over ditches (``studies.ditch_curve``: the robust policy with the tolerance T as the
objective, ``min_share`` 0, exactly what ``jethr1 ditch-curve`` plans), on a lattice of gaps: the widest ditch
crossed with the whole of T (every row's share ≥ 1 − 1e-9), with half of it (≥ 0.5) and at all (some share ≥ 0:
a posture balances without errors, Paper A's minimal criterion, where a plan under the minimal policy then gives the
thrust Paper A would need). The share that crosses a ditch does not grow with its width (a wider ditch is not
easier), so each widest gap is found by bisection on the lattice (:func:`widest_gaps`), the three searches sharing
their plans: about 11 plans per variant at 10 mm over 0.2-0.8 m.

A variant's cached result depends on this module and the planner's code (``studies.design.code_digest``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from jethr1_plan.errors import InfeasiblePlan
from jethr1_plan.physics.balance import Tolerance
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.studies.design_spec import JudgeSettings

__all__ = ["LEVELS", "design_base", "judge_robot", "widest_gaps"]

#: the widest-ditch levels, each the least share of the tolerance a crossing must hold at every row
LEVELS: dict[str, float] = {"crossed": 0.0, "half": 0.5, "whole": 1.0 - 1e-9}


def widest_gaps(n: int, evaluate: Callable[[int], float | None]) -> dict[int, float | None]:
    """The share of each lattice gap :func:`widest_gaps` planned (index → share, None: not crossable), enough of
    them to place every level of :data:`LEVELS`: for each level (crossed, half, whole, in turn), the largest
    index whose share holds it and the next index planned fails it, found by bisection between the indices
    planned so far (-1 and ``n`` stand for "below" and "beyond" the lattice). Exact for shares that do not grow
    with the index; ``evaluate(k)`` is called at most once per index."""
    shares: dict[int, float | None] = {}
    for level in LEVELS.values():
        while True:
            lo, hi = _bracket(shares, level, n)
            if hi - lo <= 1:
                break
            k = (lo + hi) // 2
            shares[k] = evaluate(k)
    return shares


def _holds(share: float | None, level: float) -> bool:
    return share is not None and share >= level


def _bracket(shares: dict[int, float | None], level: float, n: int) -> tuple[int, int]:
    """(the largest planned index holding ``level`` or -1, the smallest planned index above it failing or n)."""
    lo = max((k for k, s in shares.items() if _holds(s, level)), default=-1)
    hi = min((k for k, s in shares.items() if k > lo and not _holds(s, level)), default=n)
    return lo, hi


def design_base(robot: RobotModel, judge: JudgeSettings):
    """The ditch curve's base scenario for ``robot`` under ``judge``'s optimiser, seed and tolerance."""
    from dataclasses import replace

    from jethr1_plan.studies.ditch_curve import default_base

    base = default_base(robot)
    return replace(base, seed=judge.seed, optimiser=replace(base.optimiser, method=judge.optimiser),
                   balance=replace(base.balance, robust=judge.tolerance))


def _minimal_crossing(scenario) -> dict[str, Any]:
    """Paper A's minimal plan of ``scenario``: its peak thrust over the rows [N], or the reason it is infeasible."""
    import numpy as np

    from jethr1_plan.planning.plan import plan

    try:
        result = plan(scenario)
    except InfeasiblePlan as exc:
        return {"feasible": False, "peak_thrust_n": None, "reason": str(exc)}
    rows = result.rows
    assert rows is not None
    peak = max(float(np.max(rows.fan(f.name))) for f in scenario.robot.fans)
    return {"feasible": True, "peak_thrust_n": peak, "reason": None}


def judge_robot(robot: RobotModel, judge: JudgeSettings) -> dict[str, Any]:
    """A robot's widest ditches (see the module): per level the widest gap crossed [m] (None: not even the
    narrowest), the next gap planned beyond it that fails (None: beyond the lattice's end) and that crossing's
    figures; every gap planned; Paper A's minimal plan at the widest gap crossed."""
    from jethr1_plan.studies.ditch_curve import ditch_scenario, share_of_gap

    base = design_base(robot, judge)
    lattice = judge.lattice()
    planned: dict[int, dict[str, Any]] = {}

    def evaluate(k: int) -> float | None:
        r = share_of_gap(ditch_scenario(base, float(lattice[k]), judge.tolerance, robot.sole_length_m), energy=True)
        planned[k] = r
        return r["share"]

    shares = widest_gaps(len(lattice), evaluate)
    widest: dict[str, Any] = {}
    for name, level in LEVELS.items():
        lo, hi = _bracket(shares, level, len(lattice))
        entry: dict[str, Any] = {"gap_m": float(lattice[lo]) if lo >= 0 else None,
                                 "next_failing_m": float(lattice[hi]) if hi < len(lattice) else None}
        if lo >= 0:
            r = planned[lo]
            entry.update({"share": r["share"], "peak_thrust_n": r["peak_thrust_n"], "mean_thrust_n": r["mean_thrust_n"],
                          "energy_j": r["energy_j"], "impulse_ns": r["impulse_ns"]})
        widest[name] = entry
    ordered = sorted(shares)
    monotone = all(not (_holds(shares[b], lv) and not _holds(shares[a], lv))
                   for lv in LEVELS.values() for i, a in enumerate(ordered) for b in ordered[i + 1:])
    minimal = None
    if widest["crossed"]["gap_m"] is not None:
        sc = ditch_scenario(base, widest["crossed"]["gap_m"], Tolerance(), robot.sole_length_m)
        minimal = {"gap_m": widest["crossed"]["gap_m"], **_minimal_crossing(sc)}
    gaps = []
    for k in ordered:
        r = planned[k]
        gaps.append({"gap_m": float(lattice[k]), "share": r["share"],
                     **({"peak_thrust_n": r["peak_thrust_n"], "mean_thrust_n": r["mean_thrust_n"],
                         "energy_j": r["energy_j"], "impulse_ns": r["impulse_ns"],
                         "least_at": r["share_at"]} if r["share"] is not None else {"reason": r["reason"]})})
    fans = [{"name": f.name, "mount": f.mount, "thrust_max_n": f.thrust_max_n, "offset_m": list(f.offset_m)}
            for f in robot.fans]
    return {"status": "ok", "mass_kg": robot.mass_kg, "fans": fans, "thrust_max_n": base.balance.thrust_max_n,
            "widest": widest, "minimal": minimal, "monotone": monotone, "plans": len(planned) + (minimal is not None),
            "gaps": gaps}
