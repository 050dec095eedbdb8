"""Paper A's optimisers of P_body along a swing path: GAS, GA and GAEx (III-D, IV-B).

* **GAS**: binary GA (A-14). Initial phase (Table 2) without f3 over ±150 mm around a nominal
  pelvis; intermediate phase (Table 3) with the smoothness term f3 over ±25 mm around the previous
  P_body.
* **GA**: GAS without f3.
* **GAEx**: GAS's initial phase, then for each sample the 12 mm cube at 1 mm around the previous
  P_body, visited nearest first; the first candidate that satisfies every constraint is taken,
  without minimising thrust.

Choices the paper leaves open (README, "Optimiser choices"): binary tournament selection,
single-point crossover on the 30-bit string with probability ``crossover``, per-bit mutation,
one elite carried over unchanged, genomes evaluated once per sample (a cache keyed by the bit
string), and a *restart*: where the intermediate phase finds no feasible candidate, the initial
phase is run again at that sample before the sample is declared infeasible.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from jethr1_plan.kinematics import PostureSolver
from jethr1_plan.optimisers.base import GAPhase, OptimiserConfig, PathRequest, PathResult, SampleResult
from jethr1_plan.optimisers.problem import Candidates, FitnessConstants, SampleProblem, evaluate_candidates, fitness
from jethr1_plan.physics.balance import NOMINAL
from jethr1_plan.physics.share import largest_shares
from jethr1_plan.reasons import has_posture, ik_failed

__all__ = [
    "GA_METHODS",
    "GAPhase",
    "OptimiserConfig",
    "SampleResult",
    "decode",
    "exhaustive_cube",
    "genome_keys",
    "initial_phase",
    "mutate",
    "optimise_path",
    "optimise_sample",
    "run_ga",
    "share_fitness",
    "share_phase",
    "single_point_crossover",
    "tournament_select",
]

GA_METHODS = ("gas", "ga", "gaex")
SHARE_BACKOFF = 0.002  # δ: after the share pass the usual phases run at s* − δ


# --- binary GA operators, pure functions -------------------------------------------


def decode(genomes: np.ndarray, lb: np.ndarray, ub: np.ndarray, bits: int) -> np.ndarray:
    """(P, 3·bits) of 0/1 to P_body (P, 3) [m]: lb + (ub − lb)·value / (2^bits − 1) per axis (A-14)."""
    weights = 1 << np.arange(bits - 1, -1, -1)
    values = genomes.reshape(len(genomes), 3, bits).astype(np.int64) @ weights
    return lb + (ub - lb) * values / float((1 << bits) - 1)


def genome_keys(genomes: np.ndarray) -> np.ndarray:
    """One integer per genome (its bit string read as a binary number)."""
    n = genomes.shape[1]
    return genomes.astype(np.int64) @ (1 << np.arange(n - 1, -1, -1, dtype=np.int64))


def tournament_select(fit: np.ndarray, n: int, size: int, rng: np.random.Generator) -> np.ndarray:
    """Indices of ``n`` parents, each the fittest (lowest ``fit``) of ``size`` drawn at random."""
    contenders = rng.integers(0, len(fit), size=(n, size))
    return contenders[np.arange(n), np.argmin(fit[contenders], axis=1)]


def single_point_crossover(parents: np.ndarray, rate: float, rng: np.random.Generator) -> np.ndarray:
    """Children of consecutive parent pairs: with probability ``rate`` their tails after a random cut swap."""
    children = parents.copy()
    n_pairs = len(parents) // 2
    length = parents.shape[1]
    cross = rng.random(n_pairs) < rate
    cuts = rng.integers(1, length, size=n_pairs)
    swap = cross[:, None] & (np.arange(length)[None, :] >= cuts[:, None])  # (pairs, bits)
    a, b = parents[0:2 * n_pairs:2], parents[1:2 * n_pairs:2]
    children[0:2 * n_pairs:2] = np.where(swap, b, a)
    children[1:2 * n_pairs:2] = np.where(swap, a, b)
    return children


def mutate(genomes: np.ndarray, rate: float, rng: np.random.Generator) -> np.ndarray:
    """Flip each bit with probability ``rate``."""
    return genomes ^ (rng.random(genomes.shape) < rate).astype(genomes.dtype)


def run_ga(objective: Callable[[np.ndarray], np.ndarray], lb: np.ndarray, ub: np.ndarray, phase: GAPhase,
           bits: int, rng: np.random.Generator, tournament_size: int = 2, elites: int = 1
           ) -> tuple[np.ndarray, float, int]:
    """Minimise ``objective`` (P_body (M, 3) → fitness (M,)) over the box [lb, ub].

    Returns the best P_body found, its fitness and the number of distinct candidates evaluated.
    """
    cache: dict[int, float] = {}
    pop = rng.integers(0, 2, size=(phase.population, 3 * bits), dtype=np.uint8)
    best_f, best_genome = np.inf, pop[0]

    def score(genomes: np.ndarray) -> np.ndarray:
        keys = genome_keys(genomes)
        todo = {}
        for i, key in enumerate(keys.tolist()):
            if key not in cache and key not in todo:
                todo[key] = i
        if todo:
            idx = np.fromiter(todo.values(), dtype=np.int64)
            values = objective(decode(genomes[idx], lb, ub, bits))
            for key, v in zip(todo, values.tolist(), strict=True):
                cache[key] = v
        return np.array([cache[k] for k in keys.tolist()])

    for gen in range(phase.generations):
        fit = score(pop)
        i = int(np.argmin(fit))
        if fit[i] < best_f:
            best_f, best_genome = float(fit[i]), pop[i].copy()
        if gen == phase.generations - 1:
            break
        order = np.argsort(fit, kind="stable")
        parents = pop[tournament_select(fit, phase.population, tournament_size, rng)]
        children = mutate(single_point_crossover(parents, phase.crossover, rng), phase.mutation, rng)
        children[:elites] = pop[order[:elites]]
        pop = children
    return decode(best_genome[None], lb, ub, bits)[0], best_f, len(cache)


# --- per-sample drivers -----------------------------------------------------------------------


def _objective(solver: PostureSolver, problem: SampleProblem, k: FitnessConstants, previous: np.ndarray | None):
    return lambda p: fitness(evaluate_candidates(solver, problem, p), k, previous)


def initial_phase(solver: PostureSolver, problem: SampleProblem, cfg: OptimiserConfig, rng: np.random.Generator,
                  nominal: np.ndarray) -> tuple[np.ndarray, float, int]:
    """Table 2's phase: no f3, ±half_range around ``nominal``: (P_body [m], fitness, evaluations)."""
    half = cfg.initial.half_range_m
    p, f, n = run_ga(_objective(solver, problem, cfg.constants, None), nominal - half, nominal + half,
                     cfg.initial, cfg.bits, rng, cfg.tournament_size, cfg.elites)
    return p, f, n


def exhaustive_cube(solver: PostureSolver, problem: SampleProblem, centre: np.ndarray, half_m: float,
                    step_m: float, chunk: int = 128) -> tuple[Candidates, int]:
    """GAEx's local exhaustion: the cube of half-width ``half_m`` at ``step_m`` around ``centre``,
    nearest first; returns the first feasible candidate (or the one of lowest thrust if none is)
    and the number evaluated."""
    n = round(half_m / step_m)
    ax = np.arange(-n, n + 1) * step_m
    grid = np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), axis=-1).reshape(-1, 3)
    order = np.lexsort((grid[:, 2], grid[:, 1], grid[:, 0], np.round(np.sum(grid * grid, axis=1), 12)))
    grid = centre + grid[order]
    best, best_thrust, count = None, np.inf, 0
    for s in range(0, len(grid), chunk):
        c = evaluate_candidates(solver, problem, grid[s:s + chunk])
        count += len(c.p_body)
        hits = np.flatnonzero(c.feasible)
        if len(hits):
            return c.take(int(hits[0])), count
        key = np.where(has_posture(c.violation), c.thrust_n, np.inf)
        i = int(np.argmin(key)) if np.isfinite(key).any() else 0
        if best is None or key[i] < best_thrust:
            best, best_thrust = c.take(i), key[i]
    assert best is not None  # the cube is never empty
    return best, count


def _gas_sample(solver: PostureSolver, problem: SampleProblem, cfg: OptimiserConfig, rng: np.random.Generator,
                previous: np.ndarray | None, nominal: np.ndarray) -> SampleResult:
    """Choose P_body at one sample with ``cfg.method`` (the problem's tolerance as it is)."""
    evals = 0
    if previous is None:
        p, f, n = initial_phase(solver, problem, cfg, rng, nominal)
        phase = "initial"
        evals += n
    elif cfg.method == "gaex":
        best, n = exhaustive_cube(solver, problem, previous, cfg.gaex_half_m, cfg.gaex_step_m)
        evals += n
        if best.feasible[0]:
            return SampleResult(best, float(fitness(best, cfg.constants)[0]), evals,
                                "exhaustive")
        p, f, n = initial_phase(solver, problem, cfg, rng, previous)
        phase, evals = "restart", evals + n
    else:
        prev_f3 = previous if cfg.method == "gas" else None
        half = cfg.intermediate.half_range_m
        p, f, n = run_ga(_objective(solver, problem, cfg.constants, prev_f3), previous - half, previous + half,
                         cfg.intermediate, cfg.bits, rng, cfg.tournament_size, cfg.elites)
        evals += n
        phase = "intermediate"
        best = evaluate_candidates(solver, problem, p[None])
        if not best.feasible[0]:
            p, f, n = initial_phase(solver, problem, cfg, rng, previous)
            phase, evals = "restart", evals + n
    best = evaluate_candidates(solver, problem, p[None])
    return SampleResult(best, float(f), evals, phase)


def share_fitness(solver: PostureSolver, problem: SampleProblem, k: FitnessConstants, p_body: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The share pass's fitness of candidates ``p_body`` (M, 3) [m] and their largest shares s*(P) (M,):

        f = f1 + f2 + C_s·(1 − s*(P)),   C_s = C4-1,

    f1 and f2 of (A-16), (A-17) (graded as :func:`~jethr1_plan.optimisers.problem.fitness`), s*(P) the
    largest share of the problem's tolerance under which some thrust within the fans' maxima balances
    the posture (``physics.share.largest_shares``). A posture no thrust balances even without errors
    scores C_s·2 plus C4-2 × how far its nominal window is from opening (at most M·g): below every
    posture that balances, above every one that fails (A-16). No f3: the share comes first; the usual
    phases then trade thrust for smoothness at the share found."""
    nominal = evaluate_candidates(solver, replace(problem, tolerance=NOMINAL), p_body)
    caps = np.minimum(problem.fan_max_n, problem.thrust_max_n)
    fans = problem.fans_at(p_body)
    share = largest_shares(nominal.com[:, :2], fans, problem.support_polygon, problem.mass_kg, problem.tolerance, caps)
    failed = ik_failed(nominal.violation)
    edge_ok = nominal.edge_excess_rad <= 0
    f = np.where(failed, k.c1, 0.0) + np.where(edge_ok, 0.0, k.c2)
    if k.graded:
        f = f + np.where(~failed & ~edge_ok, k.c4_2 * np.degrees(np.where(failed, 0, nominal.edge_excess_rad)), 0.0)
    gap = np.minimum(np.where(np.isfinite(nominal.window_gap_n), nominal.window_gap_n, k.weight_n), k.weight_n)
    f = f + np.where(share >= 0, k.c4_1 * (1.0 - share), k.c4_1 * 2.0 + k.c4_2 * gap)
    return f, np.where(failed, -1.0, share)


def share_phase(solver: PostureSolver, problem: SampleProblem, cfg: OptimiserConfig, rng: np.random.Generator,
                centre: np.ndarray) -> tuple[np.ndarray, float, int]:
    """GAS's share pass: the initial phase's GA (Table 2's population, generations and box around
    ``centre``) on :func:`share_fitness`; (P_body [m], its largest share s*, −1 where none balances, evaluations)."""
    half = cfg.initial.half_range_m
    p, _, n = run_ga(lambda P: share_fitness(solver, problem, cfg.constants, P)[0], centre - half, centre + half,
                     cfg.initial, cfg.bits, rng, cfg.tournament_size, cfg.elites)
    _, s = share_fitness(solver, problem, cfg.constants, p[None])
    return p, float(s[0]), n + 1


def optimise_sample(solver: PostureSolver, problem: SampleProblem, cfg: OptimiserConfig, rng: np.random.Generator,
                    previous: np.ndarray | None, nominal: np.ndarray) -> SampleResult:
    """Choose P_body at one sample with ``cfg.method``.

    Under a tolerance no posture reaches (the robust policy), the sample takes the largest share of
    it that one does: the share pass (:func:`share_phase`) finds a posture P_s and its largest share
    s*, then the usual phases run again at s* − δ (δ = ``SHARE_BACKOFF``); where they find nothing,
    P_s itself at that share is the answer.

    Args:
        previous: P_body at the previous sample of the same step, or None at the step's first sample.
        nominal: centre of the initial phase's search box [m].
    """
    if cfg.method not in GA_METHODS:
        raise ValueError(f"method {cfg.method!r} is not one of the GA family {GA_METHODS}")
    res = _gas_sample(solver, problem, cfg, rng, previous, nominal)
    if res.feasible or problem.tolerance == NOMINAL:
        return res
    p_s, s_max, n = share_phase(solver, problem, cfg, rng, nominal if previous is None else previous)
    evals = res.evaluations + n
    if s_max < 0:
        return SampleResult(res.best, res.fitness, evals, res.phase)
    share = max(0.0, s_max - SHARE_BACKOFF)
    held = replace(problem, tolerance=problem.tolerance.scaled(share))
    again = _gas_sample(solver, held, cfg, rng, previous, nominal)
    evals += again.evaluations
    if again.feasible:
        return SampleResult(again.best, again.fitness, evals, "share", share)
    best = evaluate_candidates(solver, held, p_s[None])
    return SampleResult(best, float(fitness(best, cfg.constants)[0]), evals + 1, "share", share)


def optimise_path(request: PathRequest) -> PathResult:
    """GAS, GA or GAEx (``request.config.method``) along a swing path, one sample after the other,
    each from the previous sample's P_body; stops at the first infeasible sample when asked to."""
    out = PathResult()
    previous = None
    for i, problem in enumerate(request.problems):
        res = optimise_sample(request.solver, problem, request.config, request.rngs[i], previous, request.nominals[i])
        out.samples.append(res)
        previous = res.p_body
        if request.progress:
            request.progress(i + 1)
        if not res.feasible and request.stop_at_infeasible:
            break
    return out
