"""Robot models, as data: one folder per robot with its URDF, its YAML and a README of assumptions.

Installed with the package as ``jethr1_plan.robots`` (this folder is mapped there in pyproject.toml),
so a non-editable install finds them by name from any directory.
"""
