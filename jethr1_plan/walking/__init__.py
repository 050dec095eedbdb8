"""Paper B's walking with pelvic rotation: the walk file (:mod:`.spec`), footsteps in time
(:mod:`.timeline`), the CoM MPC (:mod:`.com_mpc`, B-18), the look-ahead yaw reference
(:mod:`.pelvis_yaw`), the QP IK with joint windows (:mod:`.ik`, :mod:`.joint_window`, :mod:`.knees`),
the arm swing (:mod:`.arm_swing`), the generator (:mod:`.generator`), the judge (:mod:`.analysis`) and
a walk's result (:mod:`.result`)."""
