"""The robot as data: a URDF and the robot YAML beside it, loaded into a :class:`~.model.RobotModel`.

* :mod:`.schema` — the robot YAML's schema (every key known, every number bounded);
* :mod:`.urdf` — the URDF's XML read and checked before PlaCo parses it;
* :mod:`.model` — the typed dataclasses (:class:`~.model.RobotModel`, its legs, fans and settings);
* :mod:`.sensors` — what the robot measures, as its YAML declares it;
* :mod:`.load` — :func:`~.load.load_robot`, which puts the URDF and the YAML together;
* :mod:`.summary` — what ``jethr1 robot show`` reports.
"""

__all__: list[str] = []
