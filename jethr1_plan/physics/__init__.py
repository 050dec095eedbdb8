"""The ground floor: the balance model with thrust (:mod:`.balance`), the statics of a posture
(:mod:`.statics`) and the compiled per-candidate physics every search uses (:mod:`.compiled`)."""

__all__: list[str] = []
