"""walking.timeline: footsteps in time (Paper B, IV-A, IV-C): each swing a (B-21) cubic between its footholds with
zero velocity at both ends and a raised-cosine height; one support sole while a foot swings; straight footholds a
step length apart."""

from __future__ import annotations

import numpy as np

from jethr1_plan.walking.timeline import Timeline, repetitive_footsteps

START = {"left": np.array([0.0, 0.1, 0.0]), "right": np.array([0.0, -0.1, 0.0])}


def _timeline(steps: int = 3, height: float = 0.05) -> Timeline:
    holds = repetitive_footsteps(START, 0.3, steps, "left")
    return Timeline.build(START, holds, 1.0, 0.8, 0.4, 1.0, height, 0.2, 0.1)


def test_straight_footholds_a_step_length_apart_and_the_last_beside() -> None:
    holds = repetitive_footsteps(START, 0.3, 4, "left")
    assert [s for s, _ in holds] == ["left", "right", "left", "right"]
    xs = [p[0] for _, p in holds]
    assert np.allclose(xs, [0.3, 0.6, 0.9, 0.9])  # each 0.3 m ahead of the other foot, the last beside it
    assert all(p[1] == START[s][1] for s, p in holds)  # straight: each foot keeps its line


def test_the_durations_add_up() -> None:
    tl = _timeline(3)
    assert np.isclose(tl.duration_s, 1.0 + 3 * 0.8 + 2 * 0.4 + 1.0)  # start, 3 swings, 2 double supports, end
    assert np.isclose(tl.steps[1].t_lift - tl.steps[0].t_land, 0.4)


def test_a_swing_leaves_and_lands_at_rest_and_clears_the_ground_by_its_height() -> None:
    tl = _timeline(2, height=0.05)
    st = tl.steps[0]  # the left foot from x = 0 to 0.3 m
    t = np.linspace(st.t_lift, st.t_land, 2001)
    pos, air = tl.feet(t)
    p = pos["left"]
    assert np.allclose(p[0], st.start_m) and np.allclose(p[-1], st.position_m)
    v = np.gradient(p, t, axis=0)
    assert np.allclose(v[[1, -2], :], 0.0, atol=2e-3)  # (B-21): zero velocity at both footholds
    assert np.isclose(p[:, 2].max(), 0.05, atol=1e-6) and np.isclose(p[1000, 0], 0.15)  # mid-swing: half way, top
    assert air["left"][1:-1].all() and not air["right"].any()  # (the right foot swings after this one)
    assert np.allclose(pos["right"], START["right"])  # the support sole does not move


def test_one_sole_supports_while_the_other_swings() -> None:
    tl = _timeline(2)
    s0, s1 = tl.steps
    support, step = tl.phase(np.array([0.5, (s0.t_lift + s0.t_land) / 2, s0.t_land + 0.2,
                                       (s1.t_lift + s1.t_land) / 2, tl.duration_s]))
    assert list(support) == ["both", "right", "both", "left", "both"]
    assert list(step) == [0, 0, 1, 1, 2]
