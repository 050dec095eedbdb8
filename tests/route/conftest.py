"""Synthetic balance-space maps (no sweep) for the search's tests, and one coarse real map cache for the
command's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jethr1_plan.physics.balance import NOMINAL
from jethr1_plan.reasons import Reason
from jethr1_plan.route.balance_map import BalanceMap, MapSettings

SOLE = (0.16, 0.09)


def synthetic_map(side: str, reach_m: float = 0.45, free_m: float = 0.3, slope_n_per_m: float = 80.0,
                  res: float = 0.02, fmax: float = 23.0) -> BalanceMap:
    """A map whose space is every swing position within ``reach_m`` of the support sole (horizontally, its
    footprint left out, 0.1 m below to 0.2 m above it), needing no thrust within ``free_m`` and then
    ``slope_n_per_m`` more per metre (cells needing more than ``fmax`` are THRUST_MAX); the best posture
    halfway between the soles, 0.38 m up."""
    settings = MapSettings(side, res, fmax, math.radians(5), 0.0, NOMINAL, x_range=(-0.6, 0.6), y_range=(-0.6, 0.6),
                           z_range=(-0.1, 0.2))
    axes = tuple(np.round(lo + res * np.arange(math.floor((hi - lo) / res + 1e-9) + 1), 9)
                 for lo, hi in (settings.x_range, settings.y, settings.z_range))
    X, Y, _ = np.meshgrid(*axes, indexing="ij")
    d = np.hypot(X, Y)
    overlap = (np.abs(X) < SOLE[0]) & (np.abs(Y) < SOLE[1])
    thrust = np.where(d <= reach_m, np.clip(slope_n_per_m * (d - free_m), 0.0, None), np.inf)
    reason = np.full(X.shape, Reason.UNREACHABLE, dtype=np.int8)
    reason[np.isfinite(thrust)] = Reason.OK
    reason[np.isfinite(thrust) & (thrust > fmax)] = Reason.THRUST_MAX
    reason[overlap] = Reason.OVERLAP
    thrust[overlap] = np.inf
    p_body = np.stack([X / 2, Y / 2, np.full(X.shape, 0.38)], axis=-1)
    return BalanceMap(settings, axes, thrust, reason, p_body)


@pytest.fixture(scope="session")
def synthetic_maps() -> dict[str, BalanceMap]:
    return {side: synthetic_map(side) for side in ("left", "right")}
