"""route.steps: how two judgements of a step compare (feasible first, then cheaper; of two misses the nearer one
in WHY's order, then the smaller thrust needed), which the frontier uses to say why no step gets there."""

from __future__ import annotations

import itertools

from jethr1_plan.route.steps import TRANSFER_POINTS, WHY, Edge, better


def test_a_feasible_step_beats_any_miss_and_the_cheaper_one_wins() -> None:
    assert better(Edge(True, cost=5.0), Edge(False, why="planner"))
    assert not better(Edge(False, why="planner"), Edge(True, cost=5.0))
    assert better(Edge(True, cost=1.0), Edge(True, cost=2.0))
    assert not better(Edge(True, cost=2.0), Edge(True, cost=1.0))


def test_of_two_misses_the_nearer_reason_then_the_smaller_need() -> None:
    for near, far in itertools.pairwise(WHY):
        assert better(Edge(False, why=near), Edge(False, why=far))
        assert not better(Edge(False, why=far), Edge(False, why=near))
    assert better(Edge(False, why="thrust", need_n=24.0), Edge(False, why="thrust", need_n=30.0))


def test_a_transfer_is_checked_inside_its_line_only() -> None:
    assert TRANSFER_POINTS.min() > 0.0 and TRANSFER_POINTS.max() < 1.0
    assert list(TRANSFER_POINTS) == sorted(TRANSFER_POINTS)
