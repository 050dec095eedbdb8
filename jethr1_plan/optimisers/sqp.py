"""A better optimiser for P_body than a binary GA: SLSQP along the swing path, forward then backward.

For one swing sample the problem is 3-variable, bounded and smooth almost everywhere: minimise the
exact minimal thrust H(P_body) (A-5) subject to (A-8) joint limits, the legs' reach, (A-9)
0 ≤ F ≤ F_max and (A-10) the edge angle. Sequential quadratic programming (scipy's SLSQP) solves
such a problem in a few iterations when it starts near the answer, and along a swing path the
neighbouring sample's P_body is such a start (continuation). Written with the thrust as a variable,
the balance condition is smooth (``AnalyticSample``); gradients are forward differences of the
closed-form kinematics, compiled with the constraints in one loop (``physics.compiled.sample_terms``),
exact to rounding, three postures per gradient.

Smoothness is the same kind of term as GAS's f3, ε·‖P_body − P_neighbour‖², and ε
(``optimiser.sqp.smoothness_n_per_m2``) is its price against thrust: the passes below and the
smoothing sweeps all lower Σ thrust + ε·Σ‖ΔP_body‖². At ε ≤ ``PASS_EPS`` (10 N/m²: a 1 cm move costs
0.001 N) it is a tie-break and the path is the least thrust's; the default 7·10⁴ N/m² is the weight
``jethr1 compare --pareto`` picks from the front: on the configs it reaches GAS's smoothness at less
maximum and mean thrust (Paper A's ω = 50 per mm² against 10 per N is 5·10⁶ N/m²). A price never
raises the path's maximum: ``lower_peaks`` solves the largest-thrust samples again for their least
thrust, and the smoothing sweeps do not go above it. Three passes:

1. *forward*: each sample from the previous sample's P_body (kept when it needs no thrust and
   holds every constraint; else a predictor, the last move repeated, then the previous P_body
   itself), inside a ±20 mm trust box (SLSQP's linearisation is poor far away: the closed-form
   legs change branch in deep crouches); the first sample, or one where that fails, from the three
   best points of a coarse grid;
2. *backward*: each sample again (except where the forward pass settled on a thrust optimum
   inside its box), now from the next sample's final P_body with the tie-break towards it. The
   result replaces the forward one when its thrust is no higher (within ``ACCEPT_N``). Where no
   thrust is needed the postures so line up behind the first sample that needs thrust, and the
   pelvis moves once instead of twice;
3. *smoothing*: sweeps move each P_body towards the midpoint of its neighbours where that holds
   every constraint and costs at most ``SMOOTH_N`` of thrust (jitter in directions where the thrust is
   flat) or at most the price of the smoothness gained (``smooth_path``).

SLSQP starts are first brought inside the constraints by least-norm Gauss-Newton steps (the
neighbour's posture is often just outside them: the foot has moved), and an answer that ends a
hair outside is stepped back in the same way; where SLSQP still fails, a compass search follows.
Constraints keep small margins, so that postures interpolated between samples (the 50 Hz rows)
and PlaCo's check of the chosen postures pass too: ZMP 0.1 mm inside the sole, 0.002 rad inside
the (A-10) cone, 0.002 rad inside the joint limits, the knees bent by at least about 0.05 rad.
Each chosen P_body is finally evaluated with the planner's posture solver (PlaCo by default); a
sample that fails there falls back to GAS's initial phase around it.
"""


from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from jethr1_plan.optimisers.base import PathRequest, PathResult, SampleResult
from jethr1_plan.optimisers.gas import initial_phase
from jethr1_plan.optimisers.problem import SampleProblem, evaluate_candidates, fitness
from jethr1_plan.optimisers.sqp_sample import (
    ACCEPT_N,
    TRUST_M,
    AnalyticSample,
    Found,
    follow_box,
    solve_from_grid,
    solve_from_neighbour,
)
from jethr1_plan.optimisers.sqp_share import max_share, scaled
from jethr1_plan.optimisers.sqp_smoothing import PASS_EPS, lower_peaks, smooth_path
from jethr1_plan.physics.balance import NOMINAL
from jethr1_plan.robot.model import RobotModel

__all__ = ["infeasible_between", "optimise_path", "repair_path_between", "resolve_path"]

BETWEEN = (0.25, 0.5, 0.75)  # fractions of a segment checked between samples (when the rows' are not given)
SHARE_BACKOFF = (0.002, 0.01, 0.03, 0.1)  # δ: stage 2 solves at s* − δ, the first of these it solves
SHARE_STEP = 0.01  # where a segment's check fails at a sample's share, the sample gives up this much of it
SHARE_GAIN = 1e-3  # a share found again (from another posture) is kept when it is this much larger
SHARE_ROUNDS = 3  # stage 1 and 2 alternate at most this many times at one sample
BETWEEN_ROUNDS = 12  # rounds of wider margins (×2 each) for segments that fail (the robust trial needs 7); more


def infeasible_between(robot: RobotModel, found: list[Found | None], between: Callable[[int, float], SampleProblem],
                       evals: np.ndarray, fractions: dict[int, list[float]] | None = None,
                       samples: dict[tuple[int, float], AnalyticSample] | None = None) -> list[int]:
    """Indices i whose segment to sample i + 1 holds a posture that breaks a constraint: the rows
    the sequence builds there interpolate P_body and the swing sole linearly. Checked without
    margins (the (A-10) cone without SLSQP's slack either: the rows are held to it exactly) at
    ``fractions[i]`` (the fractions of the way at which the rows fall), or, without them, at a
    quarter, half and three quarters of the way. ``samples`` keeps the problems between
    samples from one call to the next (they do not change as P_body does)."""
    bad = []
    samples = {} if samples is None else samples
    for i in range(len(found) - 1):
        a, b = found[i], found[i + 1]
        if a is None or b is None:
            continue
        for lam in (BETWEEN if fractions is None else fractions.get(i, ())):
            sample = samples.get((i, lam))
            if sample is None:
                sample = samples[(i, lam)] = AnalyticSample(robot, between(i, lam), None, margin_scale=0.0)
            sample.evaluations = 0
            ok, _ = sample.feasible((1 - lam) * a.p + lam * b.p, strict_edge=True)
            evals[i] += sample.evaluations
            if not ok:
                bad.append(i)
                break
    return bad


def _share_solve(robot: RobotModel, problem: SampleProblem, centre: np.ndarray, anchor: np.ndarray | None,
                 eps: float, half: float, evals: np.ndarray, i: int) -> tuple[Found, float] | None:
    """Where no posture reaches the whole tolerance: stage 1 (``sqp_share.max_share``, the largest
    share s* some posture reaches, searched from ``centre``, or, where SLSQP finds no start there, from
    a posture that balances without the tolerance, searched over ``centre`` ± ``half``), then stage 2,
    the usual least-thrust solve
    at s* − δ from that posture (δ = ``SHARE_BACKOFF``, widened while stage 2 fails). (Found, share)
    or None where no posture balances even without the tolerance."""
    full = AnalyticSample(robot, problem, None)
    stage1 = max_share(full, centre, TRUST_M)
    if stage1 is None:  # SLSQP found no start: from a posture that balances without the tolerance
        nominal = AnalyticSample(robot, scaled(problem, 0.0), anchor, eps)
        r0 = follow_box(nominal, solve_from_neighbour(nominal, centre)) or solve_from_grid(nominal, centre, half)
        evals[i] += nominal.evaluations
        if r0 is not None:
            stage1 = max_share(full, r0.p, TRUST_M) or (0.0, r0.p)
    evals[i] += full.evaluations
    if stage1 is None:
        return None
    best = None
    for _ in range(SHARE_ROUNDS):  # stage 2, then stage 1 again from its answer while the share grows
        s_max, p_star = stage1
        got = None
        for backoff in SHARE_BACKOFF:
            share = max(0.0, s_max - backoff) if s_max < 1.0 else 1.0
            sample = AnalyticSample(robot, scaled(problem, share), anchor, eps)
            r = follow_box(sample, solve_from_neighbour(sample, p_star))
            evals[i] += sample.evaluations
            if r is not None:
                got = (r, share)
                break
            if share == 0.0:
                break
        if got is None or (best is not None and got[1] <= best[1] + SHARE_GAIN):
            break
        best = got
        if best[1] >= 1.0:
            break
        again = max_share(full, best[0].p, TRUST_M)
        evals[i] += full.evaluations
        if again is None or again[0] <= s_max + SHARE_GAIN:
            break
        stage1 = again
    return best


@dataclass
class _Path:
    """The state of one path's solve, sample by sample: the chosen P_body (``found``), the share of the tolerance
    each holds, the evaluations it took, the phase that found it, whether it is robust."""

    robot: RobotModel
    problems: list[SampleProblem]
    nominals: np.ndarray  # (N, 3) each sample's nominal P_body [m]
    eps: float  # the smoothness price [N/m²]
    half: float  # the grid's half range [m]
    found: list[Found | None]
    shares: np.ndarray
    evals: np.ndarray
    phase: list[str]
    robust: list[bool]


def optimise_path(request: PathRequest) -> PathResult:
    """P_body at every sample of one swing path (see the module docstring).

    The whole path is solved at once (``request.stop_at_infeasible`` is not used). Segments whose
    postures at ``request.row_positions`` (through ``request.between``) break a constraint get their
    two samples re-solved with wider margins. Where the chosen posture fails the planner's solver,
    the sample falls back on GAS's initial phase with its random stream ``request.rngs[i]``.

    Where a sample's tolerance cannot be reached, the sample takes the largest share of it that can
    (:func:`_share_solve`, in the forward pass from the previous posture and again in the backward
    pass from the next one, keeping the larger); every later step (the backward pass, the peaks, the
    smoothing, the checks between samples, at shares interpolated as the rows are) holds each
    sample to its share. The shares are in the results (``SampleResult.share``).
    """
    problems = request.problems
    n = len(problems)
    path = _Path(request.robot, problems, request.nominals, request.config.sqp_smoothness_n_per_m2,
                 request.config.initial.half_range_m, [None] * n, np.ones(n), np.zeros(n, dtype=np.int64),
                 ["sqp"] * n, [pr.tolerance != NOMINAL for pr in problems])
    _forward(path)
    _backward(path)
    held = [scaled(pr, s) for pr, s in zip(problems, path.shares, strict=True)]  # each sample at its share
    if path.eps > PASS_EPS:
        lower_peaks(path.robot, held, path.found, path.evals)
    smooth_path(path.robot, held, path.found, path.evals, path.eps)
    if request.between is not None:
        _repair_between(path, held, request.between, request.row_positions)
    return _evaluated(path, held, request)


def _forward(path: _Path) -> None:
    """The forward pass: each sample from the previous one's P_body (kept where it needs no thrust; else a
    predictor, the last move repeated, then the previous P_body), else from a coarse grid; a robust sample that
    reaches no posture takes the largest share of its tolerance it can."""
    robot, problems, nominals, eps, found = path.robot, path.problems, path.nominals, path.eps, path.found
    for i in range(len(problems)):
        prev = found[i - 1] if i else None
        sample = AnalyticSample(robot, problems[i], None if prev is None else prev.p, eps)
        r = None
        if prev is not None:
            ok, f = sample.feasible(prev.p)
            if ok and f == 0.0:  # no thrust needed and no move: the optimum of u + tie-break
                r = Found(prev.p.copy(), 0.0, True)
            else:  # predictor: the last move repeated; corrector: SLSQP
                before = found[i - 2] if i >= 2 else None
                guess = 2 * prev.p - before.p if before is not None and before.thrust > 0 else None
                r = solve_from_neighbour(sample, prev.p, guess)
                if r is None and guess is not None:  # the box moved on along the path
                    r = solve_from_neighbour(sample, guess)
                r = follow_box(sample, r)
        if r is None:
            r = solve_from_grid(sample, nominals[i] if prev is None else prev.p, path.half)
            path.phase[i] = "sqp-grid"
        path.evals[i] += sample.evaluations
        if r is None and path.robust[i]:
            got = _share_solve(robot, problems[i], nominals[i] if prev is None else prev.p,
                               None if prev is None else prev.p, eps, path.half, path.evals, i)
            if got is not None:
                r, path.shares[i] = got
                path.phase[i] = "sqp-share"
        found[i] = r


def _backward(path: _Path) -> None:
    """The backward pass: each sample again from the next one's P_body (a share-limited sample first for a larger
    share), kept where its thrust is no higher than the forward pass's (within ``ACCEPT_N``)."""
    robot, problems, eps, found, shares, evals = path.robot, path.problems, path.eps, path.found, path.shares, \
        path.evals
    for i in range(len(problems) - 2, -1, -1):
        nxt, cur = found[i + 1], found[i]
        if nxt is None:
            continue
        if path.robust[i] and shares[i] < 1.0:  # the largest share again, from the next posture
            got = _share_solve(robot, problems[i], nxt.p, nxt.p, eps, path.half, evals, i)
            if got is not None and got[1] > shares[i] + SHARE_GAIN:
                found[i], shares[i] = got
                continue
        cur = found[i]
        sample = AnalyticSample(robot, scaled(problems[i], shares[i]), nxt.p, eps)
        ok, f = sample.feasible(nxt.p)  # the next posture itself, when it serves as well, is the answer
        if ok and cur is not None and f <= cur.thrust + ACCEPT_N:
            r = Found(nxt.p.copy(), f, True)
        elif cur is not None and cur.thrust > 0 and cur.settled:
            r = None  # the forward pass settled on a thrust optimum there: nothing to gain
        else:
            r = solve_from_neighbour(sample, nxt.p)
        evals[i] += sample.evaluations
        if r is not None and (cur is None or r.thrust <= cur.thrust + ACCEPT_N):
            found[i] = r


def _repair_between(path: _Path, held: list[SampleProblem], between: Callable[[int, float], SampleProblem],
                    row_positions: np.ndarray | None) -> None:
    """The segments whose rows (at ``row_positions``, the share interpolated as the rows' is) break a constraint:
    their two samples solved again with margins twice as wide, round after round (``BETWEEN_ROUNDS``, more while
    the first failing segment moves on); where a robust sample finds no room, a little less of its tolerance
    (``SHARE_STEP``) at the usual margins. ``held`` follows the shares."""
    robot, problems, eps, found, shares, evals = path.robot, path.problems, path.eps, path.found, path.shares, \
        path.evals
    n = len(problems)
    scale = np.ones(n)
    fractions: dict[int, list[float]] | None = None
    if row_positions is not None:
        fractions = {}
        for u in np.asarray(row_positions, dtype=float):
            i = int(np.floor(u))
            if u - i > 1e-12 and i < n - 1:
                fractions.setdefault(i, []).append(float(u - i))

    def held_between(i: int, lam: float) -> SampleProblem:  # the share interpolated as the rows' is
        return scaled(between(i, lam), (1.0 - lam) * shares[i] + lam * shares[i + 1])

    kept: dict[tuple[int, float], AnalyticSample] = {}
    first_bad = -1
    for round_ in range(BETWEEN_ROUNDS + n):
        bad = infeasible_between(robot, found, held_between, evals, fractions, kept)
        if not bad or (round_ >= BETWEEN_ROUNDS and bad[0] <= first_bad):
            break
        first_bad = bad[0]
        redo = sorted({j for i in bad for j in (i, i + 1)})
        scale[redo] *= 2.0
        for j in redo:
            before, here = found[j - 1] if j else None, found[j]
            assert here is not None  # a segment is checked only between two found samples
            sample = AnalyticSample(robot, held[j], None if before is None else before.p, eps,
                                    margin_scale=scale[j])
            r = solve_from_neighbour(sample, here.p)
            evals[j] += sample.evaluations
            if r is None and path.robust[j] and shares[j] > 0.0:
                # no room for wider margins at this share (a share-limited sample, or one that just
                # reaches the whole tolerance): a little less of the tolerance, at the usual margins
                share = max(0.0, shares[j] - SHARE_STEP)
                sample = AnalyticSample(robot, scaled(problems[j], share), None if before is None else before.p, eps)
                r = solve_from_neighbour(sample, here.p)
                evals[j] += sample.evaluations
                if r is not None:
                    shares[j], held[j], scale[j] = share, scaled(problems[j], share), 1.0
                    for key in [k for k in kept if k[0] in (j - 1, j)]:  # the segments' shares changed
                        del kept[key]
            if r is not None:
                found[j] = r


def resolve_path(robot: RobotModel, problems: list[SampleProblem], start_m: np.ndarray, shares: np.ndarray,
                 eps: float, half: float) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """P_body at every sample of a path solved again from given postures ``start_m`` (N, 3) [m] that held the
    shares ``shares`` (N,) of the samples' tolerances on a nearby path (a plan's own samples, their path's ends
    moved by millimetres): the planner's own sample program (:class:`AnalyticSample`: (A-8) joint limits, the
    legs' reach, (A-9), (A-10) and the ZMP, all with their margins; the tolerance at the sample's share) warm-started
    from each posture instead of from a neighbour or a grid.

    A posture is kept where it holds every constraint at its share; else SLSQP solves the sample at that share inside
    the trust box around it, with the tie-break towards it (``eps`` [N/m²]), the box following the answer while it
    holds it back. A robust sample that finds no posture at its share takes the largest share it reaches from its
    start (:func:`_share_solve`, as the backward pass does; ``half`` [m] its grid's half range where SLSQP finds no
    start), never more than it held: the shares the optimiser gave up so that the rows between samples hold stay
    given up. Returns (P_body (N, 3) [m], shares (N,), evaluations (N,)), or None where a sample finds no posture
    that balances.
    """
    n = len(problems)
    found = np.array(start_m, dtype=float, copy=True)
    held = np.array(shares, dtype=float, copy=True)
    evals = np.zeros(n, dtype=np.int64)
    for i, pr in enumerate(problems):
        sample = AnalyticSample(robot, scaled(pr, held[i]), found[i], eps)
        ok, _ = sample.feasible(found[i])  # as the optimiser accepts its own answers
        r = None if ok else follow_box(sample, solve_from_neighbour(sample, found[i]))
        evals[i] += sample.evaluations
        if ok:
            continue
        if r is None and pr.tolerance != NOMINAL:
            got = _share_solve(robot, pr, found[i], found[i], eps, half, evals, i)
            if got is not None:
                r, held[i] = got[0], min(got[1], held[i])
        if r is None:
            return None
        found[i] = r.p
    return found, held, evals


def repair_path_between(robot: RobotModel, problems: list[SampleProblem], p_body_m: np.ndarray, shares: np.ndarray,
                        eps: float, half: float, between: Callable[[int, float], SampleProblem],
                        row_positions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A path's postures ``p_body_m`` (N, 3) [m] holding ``shares`` (N,) of their samples' tolerances (every one
    feasible, :func:`resolve_path`'s answer) with the segments whose rows (at ``row_positions``, through
    ``between``) break a constraint solved again as the optimiser's last pass does (:func:`_repair_between`: the
    two samples with margins twice as wide, round after round; a robust sample without room, a little less of its
    tolerance). Returns (P_body (N, 3) [m], shares (N,), evaluations (N,))."""
    n = len(problems)
    found: list[Found | None] = []
    for pr, p, share in zip(problems, np.asarray(p_body_m, dtype=float), shares, strict=True):
        found.append(Found(p.copy(), AnalyticSample(robot, scaled(pr, float(share)), None).feasible(p)[1], True))
    path = _Path(robot, problems, np.asarray(p_body_m, dtype=float), eps, half, found,
                 np.array(shares, dtype=float, copy=True), np.zeros(n, dtype=np.int64), ["sqp"] * n,
                 [pr.tolerance != NOMINAL for pr in problems])
    held = [scaled(pr, s) for pr, s in zip(problems, path.shares, strict=True)]
    _repair_between(path, held, between, row_positions)
    return np.array([f.p for f in path.found if f is not None]), path.shares, path.evals


def _evaluated(path: _Path, held: list[SampleProblem], request: PathRequest) -> PathResult:
    """The chosen postures evaluated with the planner's solver; a sample that fails there falls back on GAS's
    initial phase around it."""
    solver, cfg = request.solver, request.config
    out = []
    for i, pr in enumerate(held):
        chosen = path.found[i]
        p = chosen.p if chosen is not None else path.nominals[i]
        cand = evaluate_candidates(solver, pr, p[None])
        path.evals[i] += 1
        if not cand.feasible[0]:
            p, _, m = initial_phase(solver, pr, cfg, request.rngs[i], p)
            cand = evaluate_candidates(solver, pr, p[None])
            path.evals[i] += m + 1
            path.phase[i] = "restart"
        f = float(fitness(cand, cfg.constants)[0])
        out.append(SampleResult(cand, f, int(path.evals[i]), path.phase[i], float(path.shares[i])))
        if request.progress:
            request.progress(i + 1)
    return PathResult(out)
