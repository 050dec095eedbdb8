"""How smooth can a near-optimal P_body path be? A dynamic-programming lower bound.

Issue 5 asks of the new optimiser both an optimality gap ≤ 0.5 % of the thrust limit at every
swing sample and a smoothness Σ‖ΔP_body‖² no worse than GAS's. This script measures whether both
can hold at once on a scenario: per swing sample, every pelvis position on a grid (``--step``)
inside a window (± ``--half``) around the `sqp` optimiser's P_body that holds every constraint with
a thrust within ``--tol`` of the least thrust known for that sample (the lower of `sqp`'s and the
window's); then the path through these sets with the least Σ‖ΔP_body‖², by dynamic programming.
No path within the tolerance (inside the windows, on the grid) is smoother than the printed bound;
a continuous path can be somewhat smoother, so run a series of ``--step`` values and extrapolate
to zero (README, "Thrust against smoothness").

    .venv/bin/python bench/smoothness_bound.py configs/forward_ditch_450.yaml --tol 0.115
"""

from __future__ import annotations

import argparse
import itertools
import time
from dataclasses import replace

import jethr1_plan.arithmetic  # noqa: F401  (first: NumPy's and OpenBLAS's kernels pinned before they load)

import numpy as np

from jethr1_plan.optimisers.search import Evaluator
from jethr1_plan.planning.plan import plan
from jethr1_plan.reasons import Reason
from jethr1_plan.scenario import load_scenario
from jethr1_plan.studies.compare import step_evaluator


def near_optimal_sets(ev: Evaluator, cells, centres: np.ndarray, thrust: np.ndarray, tol: float, step: float,
                      half: float) -> list[np.ndarray]:
    """Per sample, the grid points (K_i, 3) [m] that balance with a thrust within ``tol`` [N] of the least known."""
    ax = np.arange(-half, half + 1e-12, step)
    offsets = np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), axis=-1).reshape(-1, 3)
    out = []
    for i, c in enumerate(centres):
        grid = c + offsets
        _, t, reason = ev(cells, np.full(len(grid), i), grid)
        ok = reason == Reason.OK
        best = min(float(thrust[i]), float(t[ok].min()) if ok.any() else np.inf)
        out.append(grid[ok & (t <= best + tol)])
    return out


def smoothest_path(sets: list[np.ndarray], chunk: int = 2000) -> float:
    """Least Σ‖P_{i+1} − P_i‖² [m²] over paths taking one point of each set, by dynamic programming."""
    cost = np.zeros(len(sets[0]))
    for a, b in itertools.pairwise(sets):
        new = np.empty(len(b))
        for s in range(0, len(b), chunk):
            d = np.sum((b[s:s + chunk, None, :] - a[None]) ** 2, axis=2) + cost[None]
            new[s:s + chunk] = d.min(axis=1)
        cost = new
    return float(cost.min())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario")
    ap.add_argument("--tol", type=float, default=0.115, help="thrust tolerance [N] (0.5 %% of 23 N)")
    ap.add_argument("--step", type=float, default=0.0015, help="grid step [m]")
    ap.add_argument("--half", type=float, default=0.018, help="window half-width [m]")
    args = ap.parse_args()
    sc = load_scenario(args.scenario)
    t0 = time.perf_counter()
    opt = plan(replace(sc, optimiser=replace(sc.optimiser, method="sqp")), build_rows=False)
    gas = plan(replace(sc, optimiser=replace(sc.optimiser, method="gas")), build_rows=False)
    total = 0.0
    for si in range(len(sc.steps)):
        ev, cells = step_evaluator(sc, si)
        sets = near_optimal_sets(ev, cells, opt.steps[si].p_body, opt.steps[si].thrust_n, args.tol, args.step,
                                 args.half)
        bound = smoothest_path(sets)
        total += bound
        sm = {k: float(np.sum(np.diff(r.steps[si].p_body, axis=0) ** 2)) for k, r in (("sqp", opt), ("gas", gas))}
        print(f"step {si}: bound {bound:.5f} m² (sets of {min(map(len, sets))}..{max(map(len, sets))} points); "
              f"sqp {sm['sqp']:.5f}, gas {sm['gas']:.5f}")
    gas_total = sum(float(np.sum(np.diff(s.p_body, axis=0) ** 2)) for s in gas.steps)
    print(f"{sc.name}: within {args.tol} N of the least thrust, smoothness >= {total:.5f} m² "
          f"(GAS: {gas_total:.5f} m²; grid {args.step * 1000:g} mm, window ±{args.half * 1000:g} mm; "
          f"{time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
