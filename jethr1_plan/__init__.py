"""jethr1-plan: thrust-assisted quasistatic stepping over ditches for the Jet-HR1 biped (Paper A) and
walking with pelvic rotation (Paper B).

The package is layered, lowest first; a layer imports only its own and the layers below
(``tools/check_imports.py`` holds them, ``make lint`` checks them, docs/architecture.md explains them):

0. :mod:`.arithmetic` — the same bytes on every machine; :mod:`.errors` — the exception tree; :mod:`.reasons`
   — why things fail; :mod:`.geometry` — the words everything uses
1. :mod:`.io` — YAML, JSON, CSV tables, atomic writes
2. :mod:`.robot` — the robot as data
3. :mod:`.records` — what the planner produces, typed
4. :mod:`.physics` — the balance model with thrust
5. :mod:`.kinematics` — P_body and body yaw to joints and CoM
6. :mod:`.optimisers` — the optimisers of P_body along a swing path
7. :mod:`.scenario` — what a user asks for; :mod:`.scenario_schema` — the scenario file's schema;
   :mod:`.swing_path` — the swing foot's path
8. :mod:`.control` — what is sent to the robot and the loops that run on it
9. :mod:`.planning` — Paper A's plan; :mod:`.walking` — Paper B's walk; :mod:`.balance_space` — Paper A's
   balance space
10. :mod:`.files` — every file format, written and read in one place
11. :mod:`.folders` — written folders read back whole, with the scenario they were planned from (``plan.py``
12. :mod:`.sim` — the MuJoCo twin and rehearsals
13. :mod:`.verify` — independent re-checks of written files
14. :mod:`.pipeline` — input file to checked output folder
15. :mod:`.route` — footholds chosen on the balance space, then planned (``jethr1 route``)
16. :mod:`.studies` — comparisons, curves, sweeps, batches
17. :mod:`.viewer` — written folders shown in Rerun (``jethr1 view``)
18. :mod:`.cli` — the command line
"""

from jethr1_plan.arithmetic import pin_arithmetic

pin_arithmetic()  # before any import of NumPy: the same bytes on every x86-64 machine (arithmetic.py)

__version__ = "0.1.0"
__all__ = ["__version__"]
