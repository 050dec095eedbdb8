"""Balance space (Paper A, IV-A, Fig. 5): where the swing sole can be held, with and without thrust.

The support sole is fixed; the swing sole (flat, facing +x) visits every cell of a grid. For each
cell the minimal thrust F* over P_body is found under all of Paper A's constraints: the legs reach
(IK), joint limits (A-8), 0 ≤ F ≤ F_max (A-9), the edge angle (A-10), the ZMP in the support sole
(A-11), with the body yaw of (A-4). The cell is in the space *with* thrust when F* ≤ F_max and in
the space *without* when F* = 0: one sweep gives both.

Two inner searches over P_body:

* ``exhaustive`` (the paper's, ``optimisers.exhaustive``): a P_body grid over every pelvis position from
  which both legs reach, at ``pbody_resolution_m``, then the six best coarse basins refined on a 1 mm grid
  (±2 steps), then 0.2 and 0.04 mm grids around the best; the best valid posture met is the answer.
* ``continuation`` (default, ``balance_space.continuation``): cells seeded from their neighbours' optima
  along x and from generic postures, searched by a compass, optima carried between neighbours by
  Gauss-Seidel relaxation, near-members polished. The agreement bench holds it to ``exhaustive`` on sampled
  cells of both supports (same membership, thrust within 0.1 N) and checks that the space with the left sole
  supporting is the exact mirror of the right's.

Both search over pelvis positions moved onto the legs' reach balls where they lie beyond, and into
the legs' joint limits (:meth:`~jethr1_plan.optimisers.search.Evaluator.into_reach`): the optimum of most cells
has a leg at full stretch, often against a joint limit, where a grid or a pattern search otherwise
stalls (the CoM moves like the square root of the distance; a joint limit is a wall of penalty).

The objective is compiled (``physics.compiled``: closed-form IK, CoM, thrust, edge angle in one numba loop,
equal to the numpy oracles of the tests to rounding, which agree with PlaCo to 1e-9 m); every member's
posture is re-checked by PlaCo inside the task that found it (``balance_space.recheck``). The work is cut
into blocks of fixed size (``balance_space.blocks``): the output does not depend on the number of workers,
their order or the executor.
"""

from __future__ import annotations

import functools
import time
from dataclasses import asdict, dataclass, field
from dataclasses import fields as dataclass_fields

import numpy as np

from jethr1_plan.balance_space.blocks import run_blocks
from jethr1_plan.balance_space.continuation import (
    BlockResult,
    balanced_thrust,
    box_swing,
    search_block,
)
from jethr1_plan.balance_space.recheck import check_members
from jethr1_plan.balance_space.spec import SearchSettings, SweepSpec
from jethr1_plan.physics.balance import body_yaw_eq4
from jethr1_plan.reasons import Reason

__all__ = [
    "CELL_REASONS",
    "LayerResult",
    "SearchSettings",
    "SweepResult",
    "SweepSpec",
    "cell_yaw",
    "summary",
    "sweep",
    "sweep_layers",
    "verify_members",
]

#: the reasons a cell can have, in the order summary.json counts them
CELL_REASONS = (Reason.OK, Reason.OVERLAP, Reason.UNREACHABLE, Reason.JOINT_LIMIT, Reason.NO_BALANCE,
                Reason.EDGE_ANGLE, Reason.THRUST_MAX)


def cell_yaw(spec: SweepSpec, swing: np.ndarray) -> np.ndarray:
    """The body yaw (A-4) [rad] of swing soles ``swing`` (k, 3): the trunk turned to the swing sole's fan."""
    fan = spec.model.fan_for(spec.swing_side)
    offset = np.asarray(fan.offset_m[:2]) if fan is not None else np.zeros(2)
    return body_yaw_eq4(np.asarray(spec.support[:2]), swing[:, :2] + offset, spec.support_side)


@dataclass
class SweepResult:
    """Every cell of a sweep, x-major (then y, then z): the grid of ``spec.axes()`` itself.

    ``swing`` and ``yaw`` follow from the grid and are computed when first read (a sweep holds 33 bytes a cell:
    posture, least thrust, reason).
    """

    spec: SweepSpec
    thrust: np.ndarray  # (N,) F* [N] (inf where nothing balances)
    p_body: np.ndarray  # (N, 3) best posture [m] (NaN where no posture is kinematically valid)
    reason: np.ndarray  # (N,) reason codes
    evaluations: int
    wall_s: float = 0.0
    extra: dict = field(default_factory=dict)

    @functools.cached_property
    def swing(self) -> np.ndarray:
        """(N, 3) swing sole centres [m]."""
        return box_swing(self.spec, (slice(None), slice(None), slice(None)))

    @functools.cached_property
    def yaw(self) -> np.ndarray:
        """(N,) body yaw of (A-4) [rad]."""
        return cell_yaw(self.spec, self.swing)

    def cell_yaw(self, swing: np.ndarray) -> np.ndarray:
        """(k,) the body yaw (A-4) [rad] of swing soles ``swing`` (k, 3) (:func:`cell_yaw`)."""
        return cell_yaw(self.spec, swing)

    def swing_at(self, mask: np.ndarray) -> np.ndarray:
        """The swing sole centres [m] of the cells ``mask`` selects, without building all of :attr:`swing`."""
        axes = self.spec.axes()
        i, j, k = np.unravel_index(np.flatnonzero(mask), tuple(len(a) for a in axes))
        return np.column_stack([axes[0][i], axes[1][j], axes[2][k]])

    def yaw_at(self, mask: np.ndarray) -> np.ndarray:
        """The body yaw (A-4) [rad] of the cells ``mask`` selects, without building all of :attr:`yaw`."""
        return cell_yaw(self.spec, self.swing_at(mask))

    @property
    def with_thrust(self) -> np.ndarray:
        return self.reason == Reason.OK

    @property
    def without_thrust(self) -> np.ndarray:
        return (self.reason == Reason.OK) & (self.thrust == 0.0)


def _in_process(tasks):
    for fn, args in tasks:
        yield fn(*args)


def sweep(spec: SweepSpec, jobs: int = 1, executor: str = "loky", scheduler: str | None = None,
          progress=None, settings: SearchSettings | None = None, forked=None) -> SweepResult:
    """The whole sweep, block by block (``balance_space.blocks``) on ``jobs`` processes (``executor`` "fork": ``jobs``
    workers forked from this process, which loads the kernels first (``balance_space.workers``, Linux; the least
    memory); "loky"; or "dask": a local cluster, or the one at ``scheduler``). The result does not depend on
    ``jobs`` or the executor. ``forked``: a :class:`~jethr1_plan.balance_space.workers.ForkedSweep` of this spec
    and settings already prepared (executor "fork"; made here otherwise). ``result.extra``: ``task_times``
    (:class:`~jethr1_plan.balance_space.blocks.TaskTimes`), ``verified_members`` (every member re-checked by PlaCo
    in its task)."""
    settings = settings or SearchSettings()
    t0 = time.perf_counter()
    if executor == "fork":
        from jethr1_plan.balance_space.workers import ForkedSweep

        with forked or ForkedSweep(spec, settings, jobs) as prepared:
            t0 = min(t0, prepared.t0)
            state, times, evaluations = prepared.result(progress)
    elif executor == "dask":
        from joblib import Parallel, delayed, parallel_config

        from jethr1_plan.io.cluster import dask_client

        with dask_client(scheduler, jobs), parallel_config(backend="dask"):
            par = Parallel(return_as="generator_unordered")
            state, times, evaluations = run_blocks(
                spec, settings, lambda tasks: par(delayed(fn)(*args) for fn, args in tasks), progress)
    elif jobs == 1:
        state, times, evaluations = run_blocks(spec, settings, _in_process, progress)
    else:
        from joblib import Parallel, delayed

        with Parallel(n_jobs=jobs, return_as="generator_unordered") as par:
            state, times, evaluations = run_blocks(
                spec, settings, lambda tasks: par(delayed(fn)(*args) for fn, args in tasks), progress)
    p_body, objective, reason = state.arrays()
    del state  # (its memory freed before the files are built)
    thrust = objective  # in place: the objective of a balanced posture is its least thrust
    thrust[:] = balanced_thrust(thrust, reason)
    result = SweepResult(spec, thrust=thrust, p_body=p_body, reason=reason, evaluations=evaluations,
                         wall_s=time.perf_counter() - t0)
    result.extra["task_times"] = times
    result.extra["verified_members"] = int(np.count_nonzero(result.with_thrust))
    return result


@dataclass
class LayerResult:
    """Per cell of some z layers (arrays over the cells, x-major), searched as one block."""

    swing: np.ndarray  # (C, 3)
    thrust: np.ndarray  # (C,) F* [N] (inf where nothing balances)
    p_body: np.ndarray  # (C, 3) best posture (NaN where no posture is kinematically valid)
    yaw: np.ndarray  # (C,)
    reason: np.ndarray  # (C,) reason codes
    evaluations: int = 0
    cpu_s: float = 0.0


def sweep_layers(spec: SweepSpec, zs: tuple[float, ...], settings: SearchSettings | None = None) -> LayerResult:
    """Every cell of the layers at swing heights ``zs`` [m] (layers of ``spec``'s grid), searched in one block
    over the whole x and y axes (no boundary rounds: a measure of the search itself)."""
    _, _, axis_z = spec.axes()
    k = [int(np.argmin(np.abs(axis_z - z))) for z in zs]
    if not np.allclose(axis_z[k], zs, atol=1e-9) or k != list(range(k[0], k[0] + len(k))):
        raise ValueError(f"layers {zs} are not consecutive layers of the grid")
    box = (slice(None), slice(None), slice(k[0], k[-1] + 1))
    r: BlockResult = search_block(spec, settings or SearchSettings(), box, np.arange(0))
    swing = box_swing(spec, box)
    return LayerResult(swing=swing, thrust=balanced_thrust(r.objective, r.reason), p_body=r.p_body,
                       yaw=cell_yaw(spec, swing), reason=r.reason, evaluations=r.evaluations, cpu_s=r.cpu_s)


def verify_members(result: SweepResult) -> int:
    """Re-check every member cell's best posture by PlaCo forward kinematics, here and now (the sweep's tasks
    did it already: ``result.extra["verified_members"]``); return the count checked.

    Raises:
        AssertionError: a posture whose soles are not where the sweep says (a bug).
    """
    m = result.with_thrust
    swing = result.swing_at(m)
    return check_members(result.spec, swing, result.p_body[m], cell_yaw(result.spec, swing))


def summary(result: SweepResult) -> dict:
    """summary.json of a sweep."""
    spec = result.spec
    res = spec.resolution_m
    sup = np.asarray(spec.support_xyz)
    out = {
        "support": {"side": spec.support_side, "position_m": list(spec.support)},
        "swing": spec.swing_side,
        "robot": spec.model.name,
        "sole": {"length_m": spec.model.sole_length_m, "width_m": spec.model.sole_width_m},
        "bounds_m": {"x": list(spec.x_range), "y": list(spec.y_range), "z": list(spec.z_range)},
        "resolution_m": res,
        "method": spec.method,
        "thrust_max_n": spec.thrust_max_n,
        "cells": len(result.reason),
        "evaluations": int(result.evaluations),
        "wall_s": float(result.wall_s),
    }
    side = 1.0 if spec.swing_side == "left" else -1.0
    for name, mask in (("with_thrust", result.with_thrust), ("without_thrust", result.without_thrust)):
        pts = result.swing_at(mask)
        out[name] = {
            "cells": int(mask.sum()),
            "volume_m3": float(mask.sum() * res ** 3),
            "max_forward_m": float((pts[:, 0] - sup[0]).max()) if len(pts) else None,
            "max_sideways_m": float((side * (pts[:, 1] - sup[1])).max()) if len(pts) else None,
            "max_reach_m": float(np.linalg.norm(pts[:, :2] - sup[:2], axis=1).max()) if len(pts) else None,
        }
    out["reasons"] = {k.message or "member": int(np.sum(result.reason == k)) for k in CELL_REASONS}
    fields = {f.name: getattr(spec, f.name) for f in dataclass_fields(spec)}
    fields["robot"] = spec.model.name
    fields["tolerance"] = asdict(spec.tolerance)
    out["spec"] = {k: (list(v) if isinstance(v, tuple) else v) for k, v in fields.items()}
    return out
