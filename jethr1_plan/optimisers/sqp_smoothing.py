"""The price of smoothness along a swing path (``optimiser.sqp.smoothness_n_per_m2``, ε): smoothing sweeps that
move each P_body towards the midpoint of its neighbours, and the peaks of thrust lowered again, so that every
move lowers Σ thrust + ε·Σ‖ΔP_body‖² and the path's largest thrust never rises (:mod:`.sqp` runs them after its
two passes).
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.optimisers.problem import SampleProblem
from jethr1_plan.optimisers.sqp_sample import ACCEPT_N, AnalyticSample, Found, follow_box, solve_from_neighbour
from jethr1_plan.robot.model import RobotModel

__all__ = ["PASS_EPS", "PEAK_ROUNDS", "PRICED_SWEEPS", "SMOOTH_N", "SMOOTH_SWEEPS", "lower_peaks", "smooth_path"]

SMOOTH_N = 0.03  # the smoothing sweeps may raise a sample's thrust by this much [N]
SMOOTH_SWEEPS = 4
PASS_EPS = 10.0  # the tie-break weight: at most this, smoothness is not priced [N/m²]
PEAK_ROUNDS = 20  # lower_peaks: re-solves at most
PRICED_SWEEPS = 10  # the smoothing sweeps where smoothness is priced (ε > PASS_EPS)


def smooth_path(robot: RobotModel, problems: list[SampleProblem], found: list[Found | None], evals: np.ndarray,
                smoothness_n_per_m2: float = 0.0, sweeps: int = SMOOTH_SWEEPS) -> None:
    """Gauss–Seidel sweeps that move each P_body towards the midpoint of its neighbours (full, half or
    quarter way, the first accepted) while every constraint holds and the path's largest thrust does
    not rise. A move is accepted when the sample's thrust rises by at most ``SMOOTH_N`` above what the
    passes found (the jitter a local optimum leaves where the thrust is flat goes), or by at most
    ε·(the fall of ‖P − P_prev‖² + ‖P − P_next‖²), ε = ``smoothness_n_per_m2``: the same price as the
    passes' term, so every such move lowers Σ thrust + ε·Σ‖ΔP_body‖² and the sweeps end on the
    trade-off that ε asks for. Up to ``sweeps`` sweeps (more while moves are still being accepted
    under the price: at most ``PRICED_SWEEPS``). Updates ``found`` and ``evals`` in place."""
    n = len(found)
    base = [np.inf if f is None else f.thrust for f in found]  # the thrusts the optimiser found
    peak = max((t for t in base if np.isfinite(t)), default=0.0)
    samples: dict[int, AnalyticSample] = {}
    limit = PRICED_SWEEPS if smoothness_n_per_m2 > PASS_EPS else sweeps
    for _ in range(limit):
        moved = 0
        for i in range(1, n - 1):
            a, b, cur = found[i - 1], found[i + 1], found[i]
            if a is None or b is None or cur is None:
                continue
            mid = 0.5 * (a.p + b.p)
            gap = float(np.sum((mid - cur.p) ** 2))
            if gap < 1e-10:
                continue
            sample = samples.get(i)
            if sample is None:
                sample = samples[i] = AnalyticSample(robot, problems[i], None)
            sample.evaluations = 0
            for alpha in (1.0, 0.5, 0.25):
                p = cur.p + alpha * (mid - cur.p)
                ok, t = sample.feasible(p)
                # ‖p − a‖² + ‖p − b‖² = 2‖p − mid‖² + const: its fall is 2·gap·(1 − (1 − α)²)
                price = smoothness_n_per_m2 * 2.0 * gap * (1.0 - (1.0 - alpha) ** 2)
                if ok and t <= peak and (t <= base[i] + SMOOTH_N or t - cur.thrust <= price):
                    found[i] = Found(p, t, cur.settled)
                    moved += 1
                    break
            evals[i] += sample.evaluations
        if not moved:
            break


def lower_peaks(robot: RobotModel, problems: list[SampleProblem], found: list[Found | None], evals: np.ndarray,
                rounds: int = PEAK_ROUNDS) -> None:
    """Where the smoothness price held the path's largest thrust above what its sample needs, that
    sample is solved again for its least thrust (tie-break weight ``PASS_EPS``, from where it is),
    and so on for the next largest, until the largest is a sample's least thrust (or ``rounds``
    re-solves): the price trades thrust for smoothness, never the path's maximum. Updates ``found``
    and ``evals`` in place."""
    for _ in range(rounds):
        thrusts = np.array([np.inf if f is None else f.thrust for f in found])
        finite = np.isfinite(thrusts)
        if not finite.any():
            return
        i = int(np.argmax(np.where(finite, thrusts, -np.inf)))
        cur = found[i]
        assert cur is not None
        prev = found[i - 1] if i else None
        sample = AnalyticSample(robot, problems[i], None if prev is None else prev.p, PASS_EPS)
        r = follow_box(sample, solve_from_neighbour(sample, cur.p))
        evals[i] += sample.evaluations
        if r is None or r.thrust >= cur.thrust - ACCEPT_N:
            return
        found[i] = r
