"""The default balance-space sweep (1 cm over the default volume, both spaces) on both cores, and the
continuation search's agreement with the exhaustive one on randomly sampled cells."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from jethr1_plan.balance_space.sweep import SweepSpec, summary, sweep, sweep_layers
from jethr1_plan.optimisers.search import Evaluator, exhaustive_cell
from jethr1_plan.reasons import Reason
from jethr1_plan.robot.model import load_robot

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.physics.test_compiled import numpy_objective  # the numpy path the test compares with


def kernel_speed(spec: SweepSpec, n: int = 200_000) -> None:
    """The compiled objective against the numpy functions it fuses, on the same random candidates."""
    ev = Evaluator(load_robot(spec.robot), spec.support_stance())
    rng = np.random.default_rng(0)
    swing = np.column_stack([rng.uniform(-0.6, 0.7, 2000), rng.uniform(-0.7, 0.6, 2000), rng.uniform(0, 0.3, 2000)])
    cells = ev.cells(swing)
    idx = rng.integers(0, len(swing), n)
    P = (ev.support + swing[idx]) / 2 + np.column_stack([rng.normal(0, 0.08, n), rng.normal(0, 0.08, n),
                                                         rng.uniform(0.15, 0.45, n)])
    ev(cells, idx[:10], P[:10])  # compile
    best = {}
    for name, fn in (("compiled", lambda: ev(cells, idx, P)), ("numpy", lambda: numpy_objective(ev, cells, idx, P))):
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        best[name] = min(times) / n * 1e6
    print(f"objective per candidate (best of 5, {n:,} candidates, one core): compiled {best['compiled']:.3f} µs, "
          f"numpy {best['numpy']:.3f} µs, ratio {best['numpy'] / best['compiled']:.1f}")


def _four_layers(spec: SweepSpec):
    """The layers z = 0.02..0.05 m swept on one core: (result, wall [s])."""
    zs = tuple(float(z) for z in spec.axes()[2][2:6])
    t0 = time.perf_counter()
    return sweep_layers(spec, zs), time.perf_counter() - t0


def relaxation_ratio(spec: SweepSpec, default) -> None:
    """Four layers with the relaxation offering each optimum once per direction (``default``: result, wall),
    against offering it on every pass (the previous method), in this run: the same cells, fewer evaluations."""
    import jethr1_plan.balance_space.sweep as bs

    bs.OFFER_ONCE = False
    old, t_old = _four_layers(spec)
    bs.OFFER_ONCE = True
    new, t_new = default
    same = all(np.array_equal(getattr(old, f), getattr(new, f), equal_nan=True) for f in ("thrust", "p_body", "reason"))
    print(f"relaxation, 4 layers ({len(new.swing)} cells), one core: offered once {new.evaluations:,} evaluations "
          f"{t_new:.1f} s, every pass (previous) {old.evaluations:,} evaluations {t_old:.1f} s; ratio "
          f"{old.evaluations / new.evaluations:.2f}x evaluations, {t_old / t_new:.2f}x time; same cells: {same}")


def polling_ratio(spec: SweepSpec, default) -> None:
    """Four layers with the compass polling a few directions at a time, the last move's first (``default``:
    result, wall), against complete polls (every direction, then the best: the previous method), in this run."""
    from jethr1_plan import search

    chunk = search.POLL_CHUNK
    search.POLL_CHUNK = len(search.FINE_DIRECTIONS)
    old, t_old = _four_layers(spec)
    search.POLL_CHUNK = chunk
    new, t_new = default
    m_old, m_new = old.reason == Reason.OK, new.reason == Reason.OK
    both = m_old & m_new
    gap = new.thrust[both].mean() - old.thrust[both].mean()
    print(f"compass polls, 4 layers ({len(new.swing)} cells), one core: {chunk} at a time {new.evaluations:,} "
          f"evaluations {t_new:.1f} s, complete (previous) {old.evaluations:,} evaluations {t_old:.1f} s; ratio "
          f"{old.evaluations / new.evaluations:.2f}x evaluations, {t_old / t_new:.2f}x time; members {m_new.sum()} "
          f"against {m_old.sum()}, mean thrust of common members {gap:+.4f} N")


def projection_ratio(spec: SweepSpec, default) -> None:
    """Four layers with the searches moving the pelvis into the legs' joint limits (``default``: result,
    wall), against the reach balls only (the previous release's projection), in this run."""
    import jethr1_plan.balance_space.sweep as bs
    from jethr1_plan import search

    level, polish = search.SEARCH_LEVEL, bs.POLISH_LEVEL
    search.SEARCH_LEVEL = bs.POLISH_LEVEL = search.INTO_REACH
    old, t_old = _four_layers(spec)
    search.SEARCH_LEVEL, bs.POLISH_LEVEL = level, polish
    new, t_new = default
    m_old, m_new = old.reason == Reason.OK, new.reason == Reason.OK
    both = m_old & m_new
    lower = np.mean(new.thrust[both] < old.thrust[both] - 1e-6)
    print(f"projection, 4 layers ({len(new.swing)} cells), one core: into the joint limits {new.evaluations:,} "
          f"evaluations {t_new:.1f} s, reach balls only (previous) {old.evaluations:,} evaluations {t_old:.1f} s; "
          f"ratio {new.evaluations / old.evaluations:.2f}x evaluations, {t_new / t_old:.2f}x time; members "
          f"{m_new.sum()} against {m_old.sum()}; of the common members {lower:.1%} lower, mean thrust "
          f"{new.thrust[both].mean() - old.thrust[both].mean():+.4f} N")


def main(resolution: float = 0.01, samples: int = 1000) -> None:
    spec = SweepSpec(resolution_m=float(resolution))
    kernel_speed(spec)
    sweep_layers(SweepSpec(resolution_m=0.05), (0.0,))  # compile (or load) every kernel before timing
    default = _four_layers(spec)  # the default search, the reference of both ratios
    relaxation_ratio(spec, default)
    polling_ratio(spec, default)
    projection_ratio(spec, default)
    t0 = time.perf_counter()
    result = sweep(spec, jobs=2)
    wall = time.perf_counter() - t0
    s = summary(result)
    print(f"sweep at {spec.resolution_m} m: {s['cells']} cells, {s['evaluations']:,} evaluations, {wall:.1f} s "
          f"on 2 processes (target < 30 s)")
    for name in ("with_thrust", "without_thrust"):
        w = s[name]
        print(f"  {name}: {w['cells']} cells, {w['volume_m3']:.4f} m^3, forward {w['max_forward_m']} m, "
              f"sideways {w['max_sideways_m']} m")
    robot = load_robot(spec.robot)
    ev = Evaluator(robot, spec.support_stance())
    cells = ev.cells(result.swing)
    rng = np.random.default_rng(1)
    candidates = np.flatnonzero((result.reason != Reason.OVERLAP) & ev.reach_possible(cells))
    picks = rng.choice(candidates, int(samples), replace=False)
    t0 = time.perf_counter()
    reference = _exhaustive(spec, result.swing[picks])
    agree, differ = 0, []
    for i, (f_ex, r_ex) in zip(picks, reference, strict=True):
        same = (result.reason[i] == Reason.OK) == (r_ex == Reason.OK)
        gap = result.thrust[i] - f_ex if same and r_ex == Reason.OK else 0.0
        if same and abs(gap) <= 0.1:
            agree += 1
        else:
            differ.append((result.swing[i], result.thrust[i], f_ex))
    print(f"agreement with exhaustive (P_body grid {REFERENCE_GRID_M * 1000:.0f} mm) on {len(picks)} sampled reachable "
          f"cells ({time.perf_counter() - t0:.0f} s on 2 processes): {agree} same membership and within 0.1 N")
    for swing, f_cont, f_ex in differ:
        print(f"  differs at swing {np.round(swing, 3)} m: continuation {f_cont:.3f} N, exhaustive {f_ex:.3f} N")


REFERENCE_GRID_M = 0.005  # the reference's P_body grid: finer than the sweep's default (1 cm), which misses members


def _exhaustive_part(spec: SweepSpec, swing: np.ndarray) -> list[tuple[float, int]]:
    ev = Evaluator(load_robot(spec.robot), spec.support_stance())
    cells = ev.cells(swing)
    return [exhaustive_cell(ev, cells, i, REFERENCE_GRID_M)[1:] for i in range(len(swing))]


def _exhaustive(spec: SweepSpec, swing: np.ndarray) -> list[tuple[float, int]]:
    """The exhaustive search's (thrust [N], reason) of every swing sole position, on 2 processes."""
    from joblib import Parallel, delayed

    parts = Parallel(n_jobs=2)(delayed(_exhaustive_part)(spec, swing[k::2]) for k in range(2))
    out: list[tuple[float, int]] = [(0.0, 0)] * len(swing)
    for k, part in enumerate(parts):
        out[k::2] = part
    return out


if __name__ == "__main__":
    main(*sys.argv[1:])
