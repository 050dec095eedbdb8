"""A command imports only what it uses (issue 28): ``jethr1 plan`` and ``jethr1 verify`` of a plan pay
for no simulator (MuJoCo), plotting (matplotlib), viewer (Rerun) or cluster (Dask) library, and
``jethr1 --help`` for none of the planner's either. Each runs in a fresh interpreter, as from the shell;
what it loaded is read from ``sys.modules`` afterwards."""

from __future__ import annotations

import json
import subprocess
import sys

from tests.conftest import ROOT

HEAVY = ("matplotlib", "mujoco", "rerun", "dask", "distributed")


def _loaded_after(argv: list[str]) -> tuple[int, set[str]]:
    """(exit code, top-level modules loaded) of ``jethr1 argv`` run in a fresh interpreter."""
    code = ("import json, sys\nfrom jethr1_plan.cli import run\nrc = run(sys.argv[1:])\n"
            "print(json.dumps([rc, sorted({m.split('.')[0] for m in sys.modules})]))")
    out = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, cwd=ROOT, check=True)
    rc, modules = json.loads(out.stdout.strip().splitlines()[-1])
    return rc, set(modules)


def test_help_loads_no_planner_library():
    rc, loaded = _loaded_after(["--help"])
    assert rc == 0
    assert not loaded & {*HEAVY, "placo", "pinocchio", "numba", "scipy", "mcap"}


def test_a_plan_and_its_verify_load_no_simulator_plotting_viewer_or_cluster_library(tmp_path):
    rc, loaded = _loaded_after(["plan", "configs/jet_hr1_trial.yaml", "-o", str(tmp_path), "--no-progress"])
    assert rc == 0 and (tmp_path / "jet_hr1_trial" / "trajectory.mcap").is_file()
    assert "placo" in loaded  # (the check sees the planner's own libraries; numba only without the AOT module)
    assert not loaded & set(HEAVY)
    rc, loaded = _loaded_after(["verify", str(tmp_path / "jet_hr1_trial")])
    assert rc == 0
    assert not loaded & set(HEAVY)
