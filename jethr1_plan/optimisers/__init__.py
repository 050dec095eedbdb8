"""Optimisers of P_body along a swing path: one interface (:mod:`.base`), a registry by name.

* ``gas``, ``ga``, ``gaex`` — Paper A's binary GAs (:mod:`.gas`), over the fitness of :mod:`.problem`;
* ``sqp`` — SLSQP along the path, forward then backward (:mod:`.sqp`).

A new optimiser is a module with ``optimise_path(PathRequest) -> PathResult`` and a line in
:data:`OPTIMISERS`.
"""

from __future__ import annotations

import importlib

from jethr1_plan.optimisers.base import GAPhase, OptimiserConfig, PathRequest, PathResult, SampleResult

__all__ = [
    "METHODS",
    "OPTIMISERS",
    "GAPhase",
    "OptimiserConfig",
    "PathRequest",
    "PathResult",
    "SampleResult",
    "optimise_path",
]

#: method name → the module whose ``optimise_path`` runs it (imported when first used)
OPTIMISERS = {"gas": "gas", "ga": "gas", "gaex": "gas", "sqp": "sqp"}
METHODS = tuple(OPTIMISERS)


def optimise_path(request: PathRequest) -> PathResult:
    """Run the optimiser ``request.config.method`` on one swing path."""
    method = request.config.method
    if method not in OPTIMISERS:
        raise ValueError(f"unknown optimiser {method!r} (known: {', '.join(METHODS)})")
    module = importlib.import_module(f"jethr1_plan.optimisers.{OPTIMISERS[method]}")
    result: PathResult = module.optimise_path(request)
    return result
