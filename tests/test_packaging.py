"""A wheel builds without a setuptools warning and holds the robot models: installed without the checkout,
`jethr1` finds them by name from any directory and plans a copied config."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile

from tests.conftest import ROOT


def test_a_wheel_plans_from_another_directory(tmp_path):
    wheels = tmp_path / "wheels"
    source = tmp_path / "source"  # a copy: setuptools builds in the source tree (build/), never in the checkout
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(".venv*", ".git", "out", "build", "__pycache__",
                                                                "*.egg-info"))
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w",
                            str(wheels), str(source)], check=True, capture_output=True, text=True, cwd=tmp_path)
    # a clean configuration: no deprecated license table, no robot folder left out of `packages`
    assert "BuildBackendWarning" not in built.stderr and "SetuptoolsDeprecationWarning" not in built.stderr, \
        built.stderr[-2000:]
    wheel = next(wheels.glob("jethr1_plan-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {"jethr1_plan/robots/jethr1/jethr1.urdf", "jethr1_plan/robots/jethr1/jethr1.yaml",
            "jethr1_plan/sim/twin.py", "jethr1_plan/viewer/show.py", "jethr1_plan/foxglove_layout.json",
            "jethr1_plan/foxglove_walk_layout.json", "jethr1_plan/foxglove_balance_space_layout.json",
            "jethr1_plan/foxglove_route_layout.json"} <= names
    packages = {str(p.relative_to(ROOT)) for p in (ROOT / "jethr1_plan").rglob("__init__.py")}
    assert packages <= names, sorted(packages - names)  # every subpackage ships
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target), str(wheel)],
                   check=True, capture_output=True)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "side_step.yaml").write_text((ROOT / "configs" / "side_step.yaml").read_text())
    env = {**os.environ, "PYTHONPATH": str(target)}
    code = ("import sys, jethr1_plan, jethr1_plan.robot.load as rm; from jethr1_plan.cli import run; "
            "assert jethr1_plan.__file__.startswith(sys.argv[1]), jethr1_plan.__file__; "
            "assert str(rm.load_robot('jethr1').urdf_path).startswith(sys.argv[1]); "
            "sys.exit(run(['plan', 'side_step.yaml', '-o', 'out', '--no-progress', '--optimiser', 'sqp']))")
    done = subprocess.run([sys.executable, "-c", code, str(target)], cwd=elsewhere, env=env, capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stderr[-1000:]
    assert (elsewhere / "out" / "side_step" / "trajectory.csv").exists()
