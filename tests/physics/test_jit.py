"""numba's on-disk cache never runs a stale kernel: every kernel that calls another module's kernel is cached
under a key of all the kernel sources (numba checks only the function's own file, numba issue #1833)."""

from __future__ import annotations

import importlib
import pkgutil
import shutil
from pathlib import Path

import numba
from numba.core.registry import CPUDispatcher

import jethr1_plan
from jethr1_plan.physics.compiled.jit import KERNEL_SOURCES, PACKAGE, cache_dir, sources_digest


def _modules():
    out = []
    for info in pkgutil.walk_packages(jethr1_plan.__path__, "jethr1_plan."):
        try:
            out.append(importlib.import_module(info.name))
        except ImportError:  # an optional extra (rerun) missing: nothing compiled there
            continue
    return out


def _names(code) -> set[str]:
    """Every global name a function's code (and its nested code) reads."""
    names = set(code.co_names)
    for const in code.co_consts:
        if hasattr(const, "co_names"):
            names |= _names(const)
    return names


def _rel(module) -> str:
    return Path(module.__file__).resolve().relative_to(PACKAGE).as_posix()


def test_every_kernel_calling_another_modules_kernel_is_keyed_on_all_sources():
    """A kernel whose code calls a kernel of another module, and that callee, live in KERNEL_SOURCES; and every
    kernel of those modules is cached in the keyed directory."""
    from jethr1_plan.physics.compiled.jit import jit_all

    modules = _modules()
    jit_all()  # (every kernel numba's dispatcher, bound as such in every module)
    crossing = set()
    kernels = 0
    for module in modules:
        for value in vars(module).values():
            if not isinstance(value, CPUDispatcher) or value.py_func.__module__ != module.__name__:
                continue
            kernels += 1
            for name in _names(value.py_func.__code__):
                callee = value.py_func.__globals__.get(name)
                if isinstance(callee, CPUDispatcher) and callee.py_func.__module__ != module.__name__:
                    crossing |= {_rel(module), _rel(importlib.import_module(callee.py_func.__module__))}
            if _rel(module) in KERNEL_SOURCES:
                assert value._cache._cache_path.startswith(cache_dir()), value
    assert kernels > 30
    assert "optimisers/compass.py" in crossing and "physics/compiled/objective.py" in crossing
    assert crossing <= set(KERNEL_SOURCES), crossing - set(KERNEL_SOURCES)


def test_the_cache_key_changes_with_any_kernel_source(tmp_path):
    """A copy of the sources hashes alike; one byte changed in any kernel module gives another key."""
    for rel in KERNEL_SOURCES:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(PACKAGE / rel, tmp_path / rel)
    base = sources_digest(tmp_path)
    assert base == sources_digest() and cache_dir().endswith(base)
    for rel in KERNEL_SOURCES:
        text = (tmp_path / rel).read_bytes()
        (tmp_path / rel).write_bytes(text + b"#")
        assert sources_digest(tmp_path) != base, rel
        (tmp_path / rel).write_bytes(text)
    assert sources_digest(tmp_path) == base


def test_kernels_leave_other_librarys_cache_setting_alone(monkeypatch):
    """The keyed directory is set only while a kernel is decorated."""
    from jethr1_plan.physics.compiled.jit import kernel

    monkeypatch.setattr(numba.config, "CACHE_DIR", "")
    def add_one(x):
        return x + 1

    k = kernel(add_one)
    assert numba.config.CACHE_DIR == ""
    assert k._cache._cache_path.startswith(cache_dir())



def test_a_second_process_loads_the_kernels_from_the_cache_without_compiling():
    """Issue 28: a command pays for loading compiled kernels, never for compiling them again."""
    import os
    import subprocess
    import sys

    code = ("import numpy as np\n"
            "from jethr1_plan.geometry import sole_polygon\n"
            "from jethr1_plan.kinematics.closed_form import solve_postures\n"
            "from jethr1_plan.physics.balance import thrust_window\n"
            "from jethr1_plan.robot.load import load_robot\n"
            "thrust_window(np.zeros((2, 2)), np.ones((2, 2)), sole_polygon((0, 0), 0.0, 0.2, 0.1), 6.8)\n"
            "feet = {'left': (np.array([0.0, 0.09, 0.0]), 0.0), 'right': (np.array([0.0, -0.09, 0.0]), 0.0)}\n"
            "solve_postures(load_robot('jethr1'), np.array([[0.0, 0.0, 0.3]]), 0.0, feet)\n")
    env = {**os.environ, "NUMBA_DEBUG_CACHE": "1", "JETHR1_AOT": "0"}  # (numba's path, not the AOT module's)
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
            for _ in range(2)]  # the first may compile (a cold cache); the second must not
    said = [line for line in (runs[1].stdout + runs[1].stderr).splitlines() if line.startswith("[cache]")]
    assert sum(line.startswith("[cache] data loaded") for line in said) == 2  # both kernels from the cache
    assert all(" loaded from " in line for line in said)  # nothing saved: nothing was compiled


def test_loading_a_kernel_leaves_scipy_linalg_unimported_and_numba_its_blas():
    """numba checks SciPy's BLAS by its file, not by importing scipy.linalg (0.25 s of every command): the check
    answers as numba's own (BLAS found), and a kernel that calls BLAS still compiles and computes NumPy's product."""
    import os
    import subprocess
    import sys

    code = ("import sys, numpy as np, numba\n"
            "from jethr1_plan.geometry import sole_polygon\n"
            "from jethr1_plan.physics.balance import thrust_window\n"
            "thrust_window(np.zeros((2, 2)), np.ones((2, 2)), sole_polygon((0, 0), 0.0, 0.2, 0.1), 6.8)\n"
            "import numba.np.arraymath as am\n"
            "before = 'scipy.linalg' in sys.modules\n"
            "a = np.random.default_rng(0).standard_normal((5, 5))\n"
            "dot = numba.njit(lambda x, y: np.dot(x, y))\n"
            "print(before, am._HAVE_BLAS, bool(np.allclose(dot(a, a), a @ a, rtol=1e-12, atol=1e-12)))\n")
    env = {**os.environ, "JETHR1_AOT": "0"}  # (numba's path, not the AOT module's)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env=env).stdout.split()
    assert out == ["False", "True", "True"]
