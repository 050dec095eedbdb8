"""The kernels compiled ahead of time (``physics.compiled.aot``) compute numba's JIT floats to the bit, take only
arguments of their exported types (others go to numba), and let a plan run without importing numba, its files
byte-identical to the plan numba's kernels make."""

from __future__ import annotations

import filecmp
import json
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from jethr1_plan.physics.compiled import aot
from tests.conftest import ROOT

#: run in a fresh interpreter with the AOT module: the trial planned, the arguments of the first calls of each
#: exported kernel pickled (argv: the output folder, the pickle)
RECORD = """import pickle, sys
from jethr1_plan.physics.compiled import aot
calls = {key: [] for key in aot.EXPORTS}
found = aot.exported
def recording(py_func, directory):
    key, ahead = f"{py_func.__module__}:{py_func.__qualname__}", found(py_func, directory)
    if ahead is None:
        return None
    def record(*args):
        if len(calls[key]) < 40:
            calls[key].append(args)
        return ahead[0](*args)
    return record, ahead[1]
aot.exported = recording
from jethr1_plan.cli import run
assert run(["plan", "configs/jet_hr1_trial.yaml", "-o", sys.argv[1], "--no-progress"]) == 0
assert "numba" not in sys.modules
pickle.dump(calls, open(sys.argv[2], "wb"))
"""


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    """The extension module built into a temporary folder (numba's pycc and the C compiler, as ``jethr1 warm-up``)."""
    from jethr1_plan.physics.compiled.aot_build import build

    return build(tmp_path_factory.mktemp("aot"))


def _dispatcher(key: str):
    import importlib

    from jethr1_plan.physics.compiled.jit import jit_all

    jit_all()
    module, name = key.split(":")
    return getattr(importlib.import_module(module), name)


def _same(a, b) -> bool:
    a, b = (a if isinstance(a, tuple) else (a,)), (b if isinstance(b, tuple) else (b,))
    return len(a) == len(b) and all(np.asarray(x).dtype == np.asarray(y).dtype and np.asarray(x).shape ==
                                    np.asarray(y).shape and np.asarray(x).tobytes() == np.asarray(y).tobytes()
                                    for x, y in zip(a, b, strict=True))


def test_every_exported_kernel_gives_numbas_floats_on_a_plans_own_arguments(built, tmp_path):
    """Each kernel's first calls in the trial's plan (up to 40 each), replayed through the AOT module: every
    output array equal to numba's dispatcher's, byte for byte."""
    pickled = tmp_path / "calls.pkl"
    subprocess.run([sys.executable, "-c", RECORD, str(tmp_path / "out"), str(pickled)], cwd=ROOT, check=True,
                   env={**os.environ, "JETHR1_AOT": str(built)}, capture_output=True)
    calls = pickle.loads(pickled.read_bytes())
    module = aot.load_file(built)
    for key, recorded in calls.items():
        assert recorded, f"the trial's plan never called {key}: the export list is stale"
        compiled = getattr(module, aot.export_name(key))
        jit = _dispatcher(key)
        for args in recorded:
            assert aot._accepts(aot.EXPORTS[key])(*args), key  # the plan passes the exported types
            assert _same(compiled(*args), jit(*args)), key


def test_only_arguments_of_the_exported_types_are_accepted():
    """The compiled code reads any array as the exported dtype and rank: the check must refuse every other kind
    (numba then takes the call), and accept any strides (the exports are of layout A)."""
    accepts = aot._accepts(aot.EXPORTS["jethr1_plan.physics.compiled.edge:edge_errors"])
    a = np.zeros((4, 2))
    assert accepts(a, a, a)
    assert accepts(np.asfortranarray(a), a[::2], np.zeros((2, 4)).T)  # any strides
    assert not accepts(a.astype(np.float32), a, a)  # dtype
    assert not accepts(a.astype(np.int64), a, a)
    assert not accepts(a.ravel(), a, a)  # rank
    assert not accepts(a.tolist(), a, a)  # not an array
    assert not accepts(a, a)  # count
    scalars = aot._accepts(("float64", "int64"))
    assert scalars(1.0, 2) and scalars(np.float64(1.0), np.int64(2))
    assert not scalars(1, 2)  # numba would type an int as int64, not as the float64 compiled
    assert not scalars(1.0, 2.0)


def test_a_kernel_given_other_types_computes_through_numba(built, monkeypatch):
    """edge_errors given float32 or Fortran-ordered arrays through the package's kernel object, the AOT module
    loaded: the float32 call is numba's (its own specialisation), the strided one the AOT code's, both numba's
    floats."""
    from jethr1_plan.physics.compiled.jit import Kernel

    monkeypatch.setenv("JETHR1_AOT", str(built))
    aot.forget_loaded()
    try:
        key = "jethr1_plan.physics.compiled.edge:edge_errors"
        jit = _dispatcher(key)
        proxy = Kernel(jit.py_func, {})
        rng = np.random.default_rng(3)
        origin, com, ankle = (rng.normal(size=(6, 2)) for _ in range(3))
        assert _same(proxy(origin, com, ankle), jit(origin, com, ankle))
        assert proxy._call.__name__ == "call"  # (the AOT path, with its check)
        f32 = [x.astype(np.float32) for x in (origin, com, ankle)]
        assert _same(proxy(*f32), jit(*f32))
        fortran = [np.asfortranarray(x) for x in (origin, com, ankle)]
        assert _same(proxy(*fortran), jit(origin, com, ankle))
    finally:
        monkeypatch.delenv("JETHR1_AOT")
        aot.forget_loaded()


def test_a_long_run_goes_over_to_numba(built, monkeypatch):
    """Past AHEAD_CALLS_MAX calls of the module's kernels in one process, a kernel becomes numba's dispatcher (the
    same floats), as numba's faster calls then repay its import."""
    from jethr1_plan.physics.compiled import jit
    from jethr1_plan.physics.compiled.jit import Kernel

    monkeypatch.setenv("JETHR1_AOT", str(built))
    aot.forget_loaded()
    try:
        dispatcher = _dispatcher("jethr1_plan.physics.compiled.edge:edge_errors")
        proxy = Kernel(dispatcher.py_func, {})
        args = tuple(np.random.default_rng(5).normal(size=(4, 2)) for _ in range(3))
        monkeypatch.setattr(jit, "_ahead_calls", jit.AHEAD_CALLS_MAX - 1)
        first = proxy(*args)  # the last call the module takes
        assert proxy._call.__name__ == "call" and jit._ahead_calls == jit.AHEAD_CALLS_MAX
        second = proxy(*args)
        assert proxy._call is proxy.jit()
        assert _same(first, dispatcher(*args)) and _same(second, first)
    finally:
        monkeypatch.delenv("JETHR1_AOT")
        aot.forget_loaded()


def test_a_plan_with_the_aot_module_imports_no_numba_and_writes_numbas_bytes(built, tmp_path):
    """The trial planned in a fresh interpreter with the module and with ``JETHR1_AOT=0``: numba imported only in
    the second; trajectory.csv, trajectory.mcap and optimised_steps.json byte-identical."""
    code = ("import json, sys\nfrom jethr1_plan.cli import run\n"
            "rc = run(['plan', 'configs/jet_hr1_trial.yaml', '-o', sys.argv[1], '--no-progress'])\n"
            "print(json.dumps([rc, 'numba' in sys.modules]))")
    seen = {}
    for setting in (str(built), "0"):
        out = tmp_path / setting.replace("/", "_")
        done = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True, cwd=ROOT,
                              env={**os.environ, "JETHR1_AOT": setting}, check=True)
        seen[setting] = (out / "jet_hr1_trial", json.loads(done.stdout.strip().splitlines()[-1]))
    (aot_dir, (rc_aot, numba_aot)), (jit_dir, (rc_jit, numba_jit)) = seen[str(built)], seen["0"]
    assert rc_aot == rc_jit == 0
    assert not numba_aot and numba_jit
    for name in ("trajectory.csv", "trajectory.mcap", "optimised_steps.json"):
        assert filecmp.cmp(aot_dir / name, jit_dir / name, shallow=False), name
