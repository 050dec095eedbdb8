"""The robot as data: a URDF and the robot YAML beside it, loaded into a :class:`~.model.RobotModel`."""

__all__: list[str] = []
