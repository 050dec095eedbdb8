"""jethr1-plan: thrust-assisted quasistatic stepping over ditches for the Jet-HR1 biped.

Modules, one per concept of the papers:

* :mod:`jethr1_plan.robot.model` — the URDF + robot YAML (mass, joints, fans, sole).
* :mod:`jethr1_plan.physics.balance` — quasistatic balance with thrust, (A-1)..(A-4), (A-10).
* :mod:`jethr1_plan.kinematics.placo` — P_body + body yaw → 12 joint angles (PlaCo IK).
* :mod:`jethr1_plan.optimisers.problem` — candidate evaluation and GAS's fitness (A-15)..(A-22).
* :mod:`jethr1_plan.optimisers.gas` — GAS, GA, GAEx.
* :mod:`jethr1_plan.swing_path` — circular-arc and explicit swing paths, carton clearance.
* :mod:`jethr1_plan.scenario` — scenario files.
* :mod:`jethr1_plan.planning.sequence`, :mod:`jethr1_plan.planning.plan` — steps, transfers, resampling.
* :mod:`jethr1_plan.files.plan_csv`, :mod:`jethr1_plan.files.plan_mcap` (ROS 2 MCAP), :mod:`jethr1_plan.io.atomic` —
  outputs.
"""

__version__ = "0.1.0"
__all__ = ["__version__"]
