"""The ground floor: the balance model with thrust (:mod:`.balance`, A-1..A-5, A-10), the statics of a
posture (:mod:`.statics`: torques, κ, energy, yaw momentum) and the compiled per-candidate physics
every search uses (:mod:`.compiled`)."""
