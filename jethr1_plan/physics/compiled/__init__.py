"""The per-candidate physics, compiled (numba), one module per concept; each is the one implementation its
callers use, and the numpy statements of the same formulas are the tests' oracles (``tests/oracles``):

* :mod:`.legs` — both legs' closed-form IK and the whole-body CoM (``kinematics.closed_form.solve_postures``);
* :mod:`.windows` — the thrust window of (A-1, A-2) under any tolerance, and the least total thrust of
  several fans (``physics.balance``);
* :mod:`.edge` — the edge angle of (A-10);
* :mod:`.reach` — the projection into the legs' reach balls and joint limits (the searches');
* :mod:`.objective` — the balance-space objective fusing all of them in one loop per candidate;
* :mod:`.sample` — one swing sample's constraints and least thrust (``optimisers.sqp``);
* :mod:`.jit` — the decorator that caches every kernel keyed on all their sources.
"""

__all__: list[str] = []
