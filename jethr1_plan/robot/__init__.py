"""The robot as data: a URDF and the robot YAML beside it, loaded into a :class:`~.model.RobotModel`.

* :mod:`.schema` — the robot YAML's schema (every key known, every number bounded);
* :mod:`.urdf` — the URDF's XML read and checked before PlaCo parses it;
* :mod:`.model` — the typed dataclasses and :func:`~.model.load_robot`, which puts the two together;
* :mod:`.summary` — what ``jethr1 robot show`` reports.
"""

__all__: list[str] = []
