"""Physics rehearsal: a MuJoCo digital twin of a robot and its terrain, the thrust controller a robot
can run, and the rehearsal of a written plan in the twin (``jethr1 simulate``).

* :mod:`jethr1_plan.sim.twin` — the twin: the URDF with a free-floating trunk, position servos at
  the robot YAML's limits, sole contact boxes, cartons, fans as forces with a first-order lag.
* :mod:`jethr1_plan.control.thrust_feedback` — the thrust feedback law on the measured centre of pressure.
* :mod:`jethr1_plan.sim.rehearsal` — a plan replayed in the twin: falls, tilt, slip, landings.
* :mod:`jethr1_plan.sim.certificate` — randomised trials' draws, survivors and their Clopper–Pearson bound.

The twin renders nothing: unless the environment chooses an OpenGL backend (``MUJOCO_GL``), MuJoCo is
imported without one (its import then skips loading GLFW, a tenth of a second).
"""

import os

os.environ.setdefault("MUJOCO_GL", "disable")

__all__: list[str] = []
