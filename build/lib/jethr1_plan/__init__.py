"""jethr1-plan: thrust-assisted quasistatic stepping over ditches for the Jet-HR1 biped.

Modules, one per concept of the papers:

* :mod:`jethr1_plan.robot_model` — the URDF + robot YAML (mass, joints, fans, sole).
* :mod:`jethr1_plan.balance` — quasistatic balance with thrust, (A-1)..(A-4), (A-10).
* :mod:`jethr1_plan.posture` — P_body + body yaw → 12 joint angles (PlaCo IK).
* :mod:`jethr1_plan.fitness` — candidate evaluation and GAS's fitness (A-15)..(A-22).
* :mod:`jethr1_plan.optimiser` — GAS, GA, GAEx.
* :mod:`jethr1_plan.swing_path` — circular-arc and explicit swing paths, carton clearance.
* :mod:`jethr1_plan.scenario` — scenario files.
* :mod:`jethr1_plan.sequence`, :mod:`jethr1_plan.planner` — steps, transfers, resampling.
* :mod:`jethr1_plan.csv_writer`, :mod:`jethr1_plan.mcap_writer`, :mod:`jethr1_plan.atomic` — outputs.
"""

__version__ = "0.1.0"
__all__ = ["__version__"]
