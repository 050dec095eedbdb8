"""The sweep against its references: the mirror image (every cell) and the exhaustive search on the cells where
the two most likely disagree, on both supports."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.balance_space.agreement import (
    agree,
    exhaustive_cells,
    mirror_report,
    suspect_cells,
)
from jethr1_plan.balance_space.spec import SearchSettings, SweepSpec
from jethr1_plan.balance_space.sweep import sweep, sweep_layers
from jethr1_plan.reasons import Reason

SMALL = SearchSettings(block_y_cells=6, block_z_layers=2)


def _spec(side: str, **kw) -> SweepSpec:
    """The command's default sweep of ``side``'s support (the left's grid the mirror image of the right's)."""
    kw.setdefault("y_range", (-0.9, 0.8) if side == "right" else (-0.8, 0.9))
    return SweepSpec(support_side=side, **kw)


def test_the_left_support_space_is_the_mirror_of_the_right_one_to_the_bit():
    """Jet-HR1 is symmetric: with the left sole supporting, every cell (in many blocks, after boundary rounds)
    has the membership, least thrust and reason of its mirror image (y → −y) with the right sole supporting,
    and the mirrored posture, to the bit."""
    r = sweep(_spec("right", resolution_m=0.05), settings=SMALL)
    lft = sweep(_spec("left", resolution_m=0.05), settings=SMALL)
    assert lft.swing[:, 1].min() == pytest.approx(-0.8) and np.count_nonzero(r.with_thrust) > 100
    m = mirror_report(r.spec, r.thrust, r.reason, r.p_body, lft.spec, lft.thrust, lft.reason, lft.p_body)
    assert (m.membership_differs, m.beyond_n, m.bitwise) == (0, 0, m.cells)
    # the report sees a difference: one cell's thrust raised by 0.2 N in the left sweep
    i = int(np.flatnonzero(lft.with_thrust)[0])
    thrust = lft.thrust.copy()
    thrust[i] += 0.2
    bad = mirror_report(r.spec, r.thrust, r.reason, r.p_body, lft.spec, thrust, lft.reason, lft.p_body)
    assert (bad.membership_differs, bad.beyond_n, bad.bitwise) == (0, 1, m.cells - 1)
    with pytest.raises(ValueError, match="mirror"):
        mirror_report(r.spec, r.thrust, r.reason, r.p_body, r.spec, r.thrust, r.reason, r.p_body)


def test_suspects_are_bumps_and_the_fan_limit():
    """Half the suspects rank by how far a cell's thrust stands above its neighbours' lowest (the highest bump
    first), half by how close it is to the fan's maximum."""
    spec = SweepSpec(resolution_m=0.1)
    n = int(np.prod([len(a) for a in spec.axes()]))
    thrust = np.full(n, 5.0)
    reason = np.full(n, Reason.OK, dtype=np.int8)
    thrust[100] = 8.0
    assert suspect_cells(spec, thrust, reason, 1).tolist() == [100]
    thrust[200] = spec.fan_limit_n + 0.001  # a bump too, but a smaller one than 100's once that is out of reach
    reason[200] = Reason.THRUST_MAX
    thrust[100], reason[100] = np.inf, Reason.NO_BALANCE  # counts as fan_limit_n + 5 N
    assert suspect_cells(spec, thrust, reason, 2).tolist() == [100, 200]


@pytest.mark.parametrize("side", ["right", "left"])
def test_continuation_agrees_with_exhaustive_where_they_most_likely_differ(side):
    """On one layer across the edge of the space with thrust, on each support: the continuation's most suspect
    cells (the bench takes 200 of the whole 1 cm sweep) agree with the exhaustive search (same membership, least
    thrust within 0.1 N)."""
    spec = _spec(side, x_range=(0.25, 0.75), y_range=(-0.35, 0.35))
    layer = sweep_layers(spec, (0.15,))
    layer_spec = _spec(side, x_range=(0.25, 0.75), y_range=(-0.35, 0.35), z_range=(0.15, 0.15))
    picks = suspect_cells(layer_spec, layer.thrust, layer.reason, 8)
    f_ex, r_ex = exhaustive_cells(spec, layer.swing[picks])
    same = agree(layer.thrust[picks], layer.reason[picks], f_ex, r_ex)
    assert same.all(), (layer.swing[picks][~same], layer.thrust[picks][~same], f_ex[~same])
    assert 0 < np.count_nonzero(r_ex == Reason.OK) < len(picks)  # both kinds of cell among the suspects
