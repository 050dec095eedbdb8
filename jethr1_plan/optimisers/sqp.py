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
from typing import NamedTuple

import numpy as np

from jethr1_plan.optimisers.base import PathRequest, PathResult, SampleResult
from jethr1_plan.optimisers.gas import initial_phase
from jethr1_plan.optimisers.problem import SampleProblem, evaluate_candidates, fitness
from jethr1_plan.optimisers.sqp_sample import TRUST_M, AnalyticSample, compass, grid_starts
from jethr1_plan.optimisers.sqp_share import max_share, scaled
from jethr1_plan.physics.balance import NOMINAL
from jethr1_plan.robot.model import RobotModel

__all__ = [
    "AnalyticSample",
    "Found",
    "compass",
    "follow_box",
    "grid_starts",
    "infeasible_between",
    "lower_peaks",
    "optimise_path",
    "smooth_path",
    "solve_from_grid",
    "solve_from_neighbour",
]

ACCEPT_N = 1e-3  # the backward pass keeps its answer unless it needs more thrust than this [N]
BOX_MOVES = 6  # where the trust box holds the forward pass's answer back, it moves up to this many times
SMOOTH_N = 0.03  # the smoothing sweeps may raise a sample's thrust by this much [N]
SMOOTH_SWEEPS = 4
PASS_EPS = 10.0  # the tie-break weight: at most this, smoothness is not priced [N/m²]
PEAK_ROUNDS = 20  # lower_peaks: re-solves at most
PRICED_SWEEPS = 10  # the smoothing sweeps where smoothness is priced (ε > PASS_EPS)
BETWEEN = (0.25, 0.5, 0.75)  # fractions of a segment checked between samples (when the rows' are not given)
SHARE_BACKOFF = (0.002, 0.01, 0.03, 0.1)  # δ: stage 2 solves at s* − δ, the first of these it solves
SHARE_STEP = 0.01  # where a segment's check fails at a sample's share, the sample gives up this much of it
SHARE_GAIN = 1e-3  # a share found again (from another posture) is kept when it is this much larger
SHARE_ROUNDS = 3  # stage 1 and 2 alternate at most this many times at one sample
BETWEEN_ROUNDS = 12  # rounds of wider margins (×2 each) for segments that fail (the robust trial needs 7); more
# while the first failing segment moves on along the path (a repair can push the failure to the next segment: the
# cone turns with the swing foot), at most one per sample


class Found(NamedTuple):
    """A sample's chosen P_body [m], its exact minimal thrust [N], and whether SLSQP settled inside
    its trust box (the box did not hold it back)."""

    p: np.ndarray
    thrust: float
    settled: bool


def _box(centre: np.ndarray, half: float) -> list[tuple[float, float]]:
    return [(float(c) - half, float(c) + half) for c in centre]


def solve_from_neighbour(sample: AnalyticSample, centre: np.ndarray, guess: np.ndarray | None = None
                         ) -> Found | None:
    """SLSQP inside the trust box around the neighbour's P_body ``centre``, from ``guess`` and then,
    if that fails, from the centre; the compass search from the centre where both end infeasible.

    Returns None where nothing feasible was found.
    """
    box = _box(centre, TRUST_M)
    starts = [centre.copy()]
    if guess is not None:
        starts.insert(0, np.clip(guess, centre - TRUST_M, centre + TRUST_M))
    for start in starts:
        x, f, ok = sample.solve(start, box)
        if ok:
            return Found(x, f, bool(np.all(np.abs(x - centre) < TRUST_M - 1e-4)))
    x = compass(sample, centre)
    ok, f = sample.feasible(x)
    return Found(x, f, False) if ok else None


def follow_box(sample: AnalyticSample, r: Found | None) -> Found | None:
    """Where the trust box held ``r`` back (not settled inside it), move the box there and solve again,
    up to ``BOX_MOVES`` times, while the thrust falls by more than ``ACCEPT_N``."""
    for _ in range(BOX_MOVES):
        if r is None or r.settled:
            break
        r2 = solve_from_neighbour(sample, r.p)
        if r2 is None or r2.thrust >= r.thrust - ACCEPT_N:
            break
        r = r2
    return r


def solve_from_grid(sample: AnalyticSample, centre: np.ndarray, half: float) -> Found | None:
    """SLSQP from the three best points of a coarse grid over ``centre`` ± ``half``; the best feasible."""
    best = None
    for x0 in grid_starts(sample, centre, half):
        x, f, ok = sample.solve(x0, _box(centre, half))
        if not ok:
            x = compass(sample, x0, step=0.016)
            ok, f = sample.feasible(x)
        if ok and (best is None or f < best.thrust - 1e-9):
            best = Found(x, f, False)
    return best


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
    robot, solver, problems, nominals = request.robot, request.solver, request.problems, request.nominals
    cfg, rngs, between, row_positions = request.config, request.rngs, request.between, request.row_positions
    n = len(problems)
    half = cfg.initial.half_range_m
    eps = cfg.sqp_smoothness_n_per_m2
    found: list[Found | None] = [None] * n
    shares = np.ones(n)
    evals = np.zeros(n, dtype=np.int64)
    phase = ["sqp"] * n
    robust = [pr.tolerance != NOMINAL for pr in problems]
    # forward pass
    for i in range(n):
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
            r = solve_from_grid(sample, nominals[i] if prev is None else prev.p, half)
            phase[i] = "sqp-grid"
        evals[i] += sample.evaluations
        if r is None and robust[i]:
            got = _share_solve(robot, problems[i], nominals[i] if prev is None else prev.p,
                               None if prev is None else prev.p, eps, half, evals, i)
            if got is not None:
                r, shares[i] = got
                phase[i] = "sqp-share"
        found[i] = r
    # backward pass
    for i in range(n - 2, -1, -1):
        nxt, cur = found[i + 1], found[i]
        if nxt is None:
            continue
        if robust[i] and shares[i] < 1.0:  # the largest share again, from the next posture
            got = _share_solve(robot, problems[i], nxt.p, nxt.p, eps, half, evals, i)
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
    held = [scaled(pr, s) for pr, s in zip(problems, shares, strict=True)]  # each sample at its share
    if eps > PASS_EPS:
        lower_peaks(robot, held, found, evals)
    smooth_path(robot, held, found, evals, eps)
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
    for round_ in range(BETWEEN_ROUNDS + n if between is not None else 0):
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
            if r is None and robust[j] and shares[j] > 0.0:
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
    # the chosen postures, evaluated with the planner's solver
    out = []
    for i, pr in enumerate(held):
        chosen = found[i]
        p = chosen.p if chosen is not None else nominals[i]
        cand = evaluate_candidates(solver, pr, p[None])
        evals[i] += 1
        if not cand.feasible[0]:
            p, _, m = initial_phase(solver, pr, cfg, rngs[i], p)
            cand = evaluate_candidates(solver, pr, p[None])
            evals[i] += m + 1
            phase[i] = "restart"
        f = float(fitness(cand, cfg.constants)[0])
        out.append(SampleResult(cand, f, int(evals[i]), phase[i], float(shares[i])))
        if request.progress:
            request.progress(i + 1)
    return PathResult(out)
