"""The same bytes on every machine (``jethr1_plan.arithmetic``): OpenBLAS's and NumPy's kernels pinned before
they load, whatever the processor would choose. Another processor cannot be run here; OpenBLAS's
``OPENBLAS_CORETYPE`` makes this one run another processor's kernels (Sandy Bridge's: no FMA), which is what a
different machine does to the bytes."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from pathlib import Path

from jethr1_plan.arithmetic import BLAS_CORE, NATIVE_VARIABLE, NUMPY_AVX512, cpu_flags, pinned_environment, signature

import pytest

from jethr1_plan.errors import InputError
from jethr1_plan.io.cluster import _same_arithmetic

ROOT = Path(__file__).resolve().parents[1]
AVX2 = frozenset({"sse2", "avx", "avx2", "fma"})
PINNED_HERE = bool(pinned_environment({}, platform.machine(), cpu_flags()))
here_only = pytest.mark.skipif(not PINNED_HERE, reason="this processor is not x86-64 with AVX2 and FMA")

# a matrix product and a solve through NumPy's and SciPy's OpenBLAS, printed as digests of their bytes
PROBE = ("import jethr1_plan, hashlib, numpy as np, scipy.linalg; from jethr1_plan.arithmetic import signature;"
         "a = np.random.default_rng(1).standard_normal((40, 40));"
         "print(hashlib.sha256((a @ a).tobytes() + scipy.linalg.solve(a, a[:, 0]).tobytes()).hexdigest());"
         "print(signature())")


def _probe(**env: str) -> tuple[str, str]:
    base = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES",
                                                             NATIVE_VARIABLE)}
    out = subprocess.run([sys.executable, "-c", PROBE], env={**base, **env}, capture_output=True, text=True,
                         check=True).stdout.split("\n")
    return out[0], out[1]


def test_an_avx2_processor_is_pinned_to_the_haswell_kernels_and_numpy_without_avx512() -> None:
    pins = pinned_environment({}, "x86_64", AVX2)
    assert pins["OPENBLAS_CORETYPE"] == BLAS_CORE
    assert pins["NPY_DISABLE_CPU_FEATURES"].split() == list(NUMPY_AVX512)


@pytest.mark.parametrize("machine, flags, env", [
    ("aarch64", AVX2, {}),  # ARM: its own kernels
    ("x86_64", AVX2 - {"fma"}, {}),  # the Haswell kernels would not run
    ("x86_64", AVX2 - {"avx2"}, {}),
    ("x86_64", AVX2, {NATIVE_VARIABLE: "1"}),  # the user keeps the machine's own
])
def test_nothing_is_pinned_where_the_kernels_would_not_run_or_the_user_says_so(machine, flags, env) -> None:
    assert pinned_environment(env, machine, flags) == {}


def test_the_users_own_numpy_features_are_kept() -> None:
    pins = pinned_environment({"NPY_DISABLE_CPU_FEATURES": "AVX2,AVX512F"}, "AMD64", AVX2)
    got = pins["NPY_DISABLE_CPU_FEATURES"].split()
    assert got[:2] == ["AVX2", "AVX512F"] and sorted(got[2:]) == sorted(set(NUMPY_AVX512) - {"AVX512F"})


def test_the_flags_are_read_from_linux_cpuinfo(tmp_path) -> None:
    info = tmp_path / "cpuinfo"
    info.write_text("processor\t: 0\nmodel name\t: X\nflags\t\t: fpu sse2 avx2 fma\n\nprocessor\t: 1\n")
    assert cpu_flags(str(info)) == {"fpu", "sse2", "avx2", "fma"}
    assert cpu_flags(str(tmp_path / "absent")) == frozenset()


@here_only
def test_another_processors_kernels_do_not_change_the_bytes() -> None:
    native, _ = _probe(**{NATIVE_VARIABLE: "1"})
    other, other_sig = _probe(OPENBLAS_CORETYPE="Sandybridge", **{NATIVE_VARIABLE: "1"})
    assert other != native and "Sandybridge" in other_sig  # unpinned, other kernels give other bytes
    pinned, pinned_sig = _probe(OPENBLAS_CORETYPE="Sandybridge")
    default, default_sig = _probe()
    assert pinned == default and pinned_sig == default_sig == signature()
    assert f"OpenBLAS {BLAS_CORE}/{BLAS_CORE}" in pinned_sig and "AVX512" not in pinned_sig


@here_only
def test_a_plan_has_the_same_bytes_with_another_processors_kernels(tmp_path) -> None:
    base = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", NATIVE_VARIABLE)}
    outs = []
    for name, env in (("default", {}), ("other", {"OPENBLAS_CORETYPE": "Sandybridge"})):
        subprocess.run([sys.executable, "-c", "from jethr1_plan.cli import entry; entry()", "plan",
                        str(ROOT / "configs" / "side_step.yaml"),
                        "-o", str(tmp_path / name), "--no-progress"], env={**base, **env}, check=True,
                       capture_output=True)
        outs.append((tmp_path / name / "side_step" / "trajectory.csv").read_bytes())
        summary = json.loads((tmp_path / name / "side_step" / "summary.json").read_text())
        assert summary["arithmetic"] == signature()  # (the folder names the arithmetic that wrote it)
    assert outs[0] == outs[1]


class _Cluster:
    def __init__(self, signatures: dict[str, str]) -> None:
        self.signatures = signatures

    def run(self, fn):  # as distributed.Client.run: the function's value per worker
        assert fn is signature
        return self.signatures


def test_a_cluster_whose_workers_compute_otherwise_is_refused_naming_the_worker() -> None:
    mine = signature()
    _same_arithmetic(_Cluster({"tcp://a:1": mine, "tcp://b:1": mine}), "tcp://s:8786")
    with pytest.raises(InputError) as exc:
        _same_arithmetic(_Cluster({"tcp://a:1": mine, "tcp://b:1": "x86_64, OpenBLAS SkylakeX/SkylakeX, NumPy "
                                                                 "AVX512_SKX"}), "tcp://s:8786")
    text = str(exc.value)
    assert "--scheduler" in text and "tcp://b:1" in text and "SkylakeX" in text and exc.value.exit_code == 2


@here_only
def test_this_test_process_computes_as_the_command_line_does() -> None:
    # (the tests compare files written by the commands with results computed here: both must be pinned)
    assert signature() == _probe()[1]



@here_only
def test_a_real_cluster_with_a_worker_on_other_kernels_is_refused() -> None:
    distributed = pytest.importorskip("distributed")
    from jethr1_plan.io.cluster import dask_client

    other = {"OPENBLAS_CORETYPE": "Sandybridge", NATIVE_VARIABLE: "1"}  # a worker as an older processor runs
    for env, refused in (({}, False), (other, True)):
        with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
                                      env=env) as cluster:
            if not refused:
                with dask_client(cluster.scheduler_address, 1) as client:  # workers started like the command
                    assert set(client.run(signature).values()) == {signature()}
                continue
            with pytest.raises(InputError) as exc, dask_client(cluster.scheduler_address, 1):
                pass
            assert "Sandybridge" in str(exc.value) and "OPENBLAS_CORETYPE='Haswell'" in str(exc.value)


def test_scipys_compiled_modules_load_from_their_files_without_their_subpackages() -> None:
    # the same files SciPy imports, loaded alone: scipy.linalg's and scipy.optimize's __init__ not run
    code = ("import sys; from jethr1_plan.arithmetic import scipy_extension, scipy_extension_file, signature\n"
            "blas = scipy_extension('linalg', 'cython_blas'); step = scipy_extension('optimize', '_slsqplib')\n"
            "alone = [m for m in ('scipy.linalg', 'scipy.optimize') if m in sys.modules]\n"
            "first = signature()\n"
            "import scipy.linalg.cython_blas as real, scipy.optimize._slsqplib as real_step\n"
            "from jethr1_plan.arithmetic import blas_cores\n"
            "print(alone, str(scipy_extension_file('linalg', 'cython_blas')) == real.__file__,\n"
            "      sorted(blas.__pyx_capi__) == sorted(real.__pyx_capi__), callable(step.slsqp),\n"
            "      step.__file__ == real_step.__file__, first.split(', ')[1] == 'OpenBLAS ' + '/'.join(blas_cores()),\n"
            "      scipy_extension('linalg', 'no_such_module') is None)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    # nothing of either subpackage imported; the very files SciPy loads; the arithmetic signature (summary.json's
    # line) reads the same libraries whether SciPy's linear algebra is imported or not
    assert out == "[] True True True True True True"
