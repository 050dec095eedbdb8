"""Compiling is said, once, as one line; a kernel loaded from the cache says nothing; ``jethr1 warm-up``'s small
inputs are valid scenarios, and a bad terrain is exit 2 before any work."""

from __future__ import annotations

import subprocess
import sys
import warnings

import pytest

from jethr1_plan.cli import run
from jethr1_plan.errors import CompileNotice, show_notices_as_lines

PROBE = """import warnings
from jethr1_plan.errors import CompileNotice
from jethr1_plan.physics.compiled import jit
import probed
with warnings.catch_warnings(record=True) as seen:
    warnings.simplefilter("always")
    probed.twice(1.0)
    probed.twice(2.5)
print(sum(issubclass(w.category, CompileNotice) for w in seen))
"""
PROBED = """from jethr1_plan.physics.compiled.jit import kernel
@kernel
def twice(x):
    return 2.0 * x
"""


def test_a_compile_is_said_once_and_a_cache_load_not_at_all(tmp_path):
    """A kernel compiled in a fresh cache warns once (two calls, one notice); the next process loads it from the
    cache and says nothing."""
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "numba"), "PATH": "/usr/bin:/bin"}
    script = tmp_path / "probe.py"
    script.write_text(PROBE)
    (tmp_path / "probed.py").write_text(PROBED)
    runs = [subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env) for _ in range(2)]
    assert all(r.returncode == 0 for r in runs), [(r.returncode, r.stderr[-1500:]) for r in runs]
    assert [r.stdout.strip() for r in runs] == ["1", "0"]


def test_the_command_line_shows_the_notice_as_one_line(capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        show_notices_as_lines()
        warnings.warn(CompileNotice("compiling the planner's kernels (a test)"), stacklevel=1)
    err = capsys.readouterr().err.splitlines()
    assert err == ["jethr1: compiling the planner's kernels (a test)"]


POOL = """import warnings
from joblib import delayed
from jethr1_plan.errors import CompileNotice
from jethr1_plan.io.pool import parallel

def notice(k):
    warnings.warn(CompileNotice(f"compiling (worker {k})"), stacklevel=1)
    return k

with parallel(2) as par:
    print(sum(par(delayed(notice)(k) for k in range(2))))
"""


def test_a_pool_worker_shows_the_notice_as_one_line(tmp_path):
    """A design or batch worker that compiles the kernels says so as the command does: one line each, not
    Python's warning with its file and source line."""
    script = tmp_path / "pool.py"
    script.write_text(POOL)
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-1500:]
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert sorted(lines) == ["jethr1: compiling (worker 0)", "jethr1: compiling (worker 1)"], done.stderr[-1500:]


def test_the_warm_up_inputs_are_valid_scenarios_and_walks(tmp_path):
    """Every command the warm-up runs names inputs that load (scenarios, a walk) and options the commands take."""
    from jethr1_plan.cli import COMMANDS
    from jethr1_plan.cli.warm_up import exercises
    from jethr1_plan.scenario import load_scenario
    from jethr1_plan.walking.spec import load_walk

    groups = exercises(tmp_path)
    assert len(groups) == 2 and all(groups)
    for argv in (a for g in groups for a in g):
        assert argv[0] in COMMANDS
    robust, trunk = load_scenario(tmp_path / "robust.yaml"), load_scenario(tmp_path / "trunk_fan.yaml")
    assert robust.balance.policy == "robust" and trunk.balance.policy == "minimal"
    assert len(trunk.robot.fans) == 3 and trunk.balance.thrust_max_n == 20.0
    # GAS's share pass runs only where the whole tolerance cannot be held: beyond Jet-HR1's widest robust ditch,
    # 350 mm (docs/robust_planning.md)
    edge = load_scenario(tmp_path / "edge.yaml")
    assert edge.balance.policy == "robust" and edge.steps[0].landing_m[0] - robust.steps[0].landing_m[0] == \
        pytest.approx(0.1)
    assert any("edge.yaml" in a and "gas" in a for g in groups for a in map(" ".join, g))
    load_walk(tmp_path / "walk.yaml")
    arms = load_walk(tmp_path / "arms.yaml")  # the arm-swing kernels: a robot with arms that swing
    assert arms.arms.enabled and arms.robot.name == "dyros_jet_like"


@pytest.mark.parametrize("terrain", ["missing.yaml", "bad.yaml"])
def test_a_bad_terrain_is_exit_2_before_any_work(tmp_path, capsys, terrain):
    (tmp_path / "bad.yaml").write_text("goal: {carton: 0}\nnot_a_key: 1\n")
    assert run(["warm-up", str(tmp_path / terrain), "--cache", str(tmp_path / "maps")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and terrain in err[0]
    assert not (tmp_path / "maps").exists()


def test_a_local_dask_workers_notices_are_one_line_too():
    """`--executor dask` (a local cluster): its workers show a compile notice as the command does."""
    pytest.importorskip("distributed")
    from jethr1_plan.io.cluster import dask_client

    def installed() -> bool:
        import warnings

        return bool(getattr(warnings.showwarning, "jethr1_notices", False))

    with dask_client(None, 1) as client:
        assert list(client.run(installed).values()) == [True]


def test_the_warm_up_says_why_when_the_ahead_of_time_module_cannot_be_built(monkeypatch, tmp_path):
    """No C compiler (pycc's build fails): one line with the builder's last line and what the commands do instead;
    the warm-up goes on."""
    import jethr1_plan.cli.warm_up as warm_up
    from jethr1_plan.physics.compiled import aot

    monkeypatch.setattr(aot, "module_path", lambda directory: tmp_path / "not_built.so")

    stderr = "Traceback ...\ndistutils.errors.CompileError: command 'gcc' failed"
    failed = subprocess.CompletedProcess([], 1, "", stderr)
    monkeypatch.setattr(warm_up.subprocess, "run", lambda *a, **k: failed)
    said: list[str] = []
    warm_up._build_ahead(lambda line, **_: said.append(line))
    assert said[-1] == ("jethr1 warm-up: no ahead-of-time module (distutils.errors.CompileError: command 'gcc' "
                        "failed); plan and simulate load their kernels from numba's cache instead (about 0.45 s more "
                        "each)")


def test_the_warm_up_builds_no_module_that_is_there(monkeypatch, tmp_path):
    """The module of these kernel sources, numba, Python and NumPy is there: the warm-up says where, and starts no
    build."""
    import jethr1_plan.cli.warm_up as warm_up
    from jethr1_plan.physics.compiled import aot

    there = tmp_path / "built.so"
    there.write_bytes(b"")
    monkeypatch.setattr(aot, "module_path", lambda directory: there)
    monkeypatch.setattr(warm_up.subprocess, "run", lambda *a, **k: pytest.fail("a build was started"))
    said: list[str] = []
    warm_up._build_ahead(lambda line, **_: said.append(line))
    assert said == [f"jethr1 warm-up: the plan's kernels compiled ahead of time are in {there}"]
