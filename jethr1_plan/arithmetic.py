"""The same bytes on every machine: the floating-point kernels pinned before NumPy and SciPy load.

OpenBLAS (NumPy's and SciPy's) chooses its kernels by the processor it finds, and NumPy dispatches some
functions (``exp``, ``log``, ``sin``, ...) to AVX-512 code where the processor has it. Each choice rounds
differently in the last bits, and the SLSQP problems of a plan amplify those bits into different plans: the
route of ``jethr1 terrain random --seed 12`` differs from line 2 of its ``trajectory.csv`` on when OpenBLAS
runs its Sandy Bridge kernels instead of its Haswell ones on the same machine. On an x86-64 processor with AVX2
and FMA (every such server and desktop since 2013-2015), the package therefore runs OpenBLAS's Haswell kernels
and NumPy without its AVX-512 code paths, whatever the processor: a plan, a certificate or a design sweep then
has the same bytes on a laptop, in CI and on each worker of a cluster. Elsewhere (other processors, ARM) the
kernels stay the machine's own and the bytes may differ in the last digits.

Set by :func:`pin_arithmetic` in the environment of this process (and so of every process it starts) when the
package is imported, which must come before NumPy's import to take effect; ``JETHR1_NATIVE_ARITHMETIC=1`` keeps
the machine's own kernels.
"""

from __future__ import annotations

import functools
import os
import platform
import sys
from collections.abc import Mapping, MutableMapping
from pathlib import Path
from types import ModuleType

__all__ = ["BLAS_CORE", "NATIVE_VARIABLE", "NUMPY_AVX512", "blas_cores", "cpu_flags", "pin_arithmetic",
           "pinned_environment", "scipy_extension", "scipy_extension_file", "signature"]

BLAS_CORE = "Haswell"  # the OpenBLAS kernels every AVX2 + FMA processor runs (OPENBLAS_CORETYPE)
#: NumPy's AVX-512 dispatch targets (NPY_DISABLE_CPU_FEATURES): without them NumPy runs its AVX2 code everywhere
NUMPY_AVX512 = ("AVX512F", "AVX512CD", "AVX512_KNL", "AVX512_KNM", "AVX512_SKX", "AVX512_CLX", "AVX512_CNL",
                "AVX512_ICL", "AVX512_SPR")
NATIVE_VARIABLE = "JETHR1_NATIVE_ARITHMETIC"  # set to 1: the machine's own kernels (bytes may differ by machine)
_NEEDED_FLAGS = frozenset({"avx2", "fma"})  # what the Haswell kernels execute


def cpu_flags(cpuinfo: str = "/proc/cpuinfo") -> frozenset[str]:
    """The processor's feature flags as Linux lists them (empty where there is no such file)."""
    try:
        with open(cpuinfo, encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("flags"):
                    return frozenset(line.partition(":")[2].split())
    except OSError:
        pass
    return frozenset()


def pinned_environment(environ: Mapping[str, str], machine: str, flags: frozenset[str]) -> dict[str, str]:
    """The variables to set (name → value) so that OpenBLAS and NumPy compute alike on every x86-64 processor
    with AVX2 and FMA; none elsewhere, or where ``environ`` asks for the machine's own kernels. A feature list
    the user gave NumPy already is kept, the AVX-512 targets added to it."""
    if environ.get(NATIVE_VARIABLE, "") not in ("", "0"):
        return {}
    if machine.lower() not in ("x86_64", "amd64") or not flags >= _NEEDED_FLAGS:
        return {}
    have = environ.get("NPY_DISABLE_CPU_FEATURES", "").replace(",", " ").split()
    disabled = have + [f for f in NUMPY_AVX512 if f not in have]
    return {"OPENBLAS_CORETYPE": BLAS_CORE, "NPY_DISABLE_CPU_FEATURES": " ".join(disabled)}


def pin_arithmetic(environ: MutableMapping[str, str] | None = None) -> dict[str, str]:
    """Set :func:`pinned_environment` in ``environ`` (default: this process's) unless NumPy is loaded already (then
    it is too late: nothing is set). Returns what was set."""
    env = os.environ if environ is None else environ
    if "numpy" in sys.modules:
        return {}
    pins = pinned_environment(env, platform.machine(), cpu_flags())
    env.update(pins)
    return pins


def scipy_extension_file(subpackage: str, name: str) -> Path | None:
    """The file of SciPy's compiled module ``scipy.<subpackage>.<name>`` where SciPy's wheels put it, found without
    importing ``scipy.<subpackage>`` (None: no such file)."""
    import importlib.machinery
    import importlib.util

    try:
        spec = importlib.util.find_spec("scipy")
    except (ImportError, ValueError):  # pragma: no cover - no SciPy
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    folder = Path(next(iter(spec.submodule_search_locations))) / subpackage
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        if (folder / f"{name}{suffix}").is_file():
            return folder / f"{name}{suffix}"
    return None


def scipy_extension(subpackage: str, name: str) -> ModuleType | None:
    """SciPy's compiled module ``scipy.<subpackage>.<name>`` loaded from its file (:func:`scipy_extension_file`),
    without running ``scipy.<subpackage>``'s ``__init__``, which imports the whole subpackage (``scipy.optimize``,
    ``scipy.linalg``: 0.25-0.35 s of CPU each); the same compiled file SciPy loads, not entered in ``sys.modules``.
    None where the file is not found or does not load."""
    import importlib.machinery
    import importlib.util

    path = scipy_extension_file(subpackage, name)
    if path is None:
        return None
    full = f"scipy.{subpackage}.{name}"
    try:
        spec = importlib.util.spec_from_file_location(full, path,
                                                      loader=importlib.machinery.ExtensionFileLoader(full, str(path)))
        if spec is None or spec.loader is None:  # pragma: no cover
            return None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    except (ImportError, OSError):  # pragma: no cover - an unusual SciPy build
        return None
    return module


def blas_cores() -> list[str]:
    """The kernels of each OpenBLAS loaded in this process (SciPy's loaded first), by threadpoolctl."""
    from threadpoolctl import threadpool_info

    if scipy_extension("linalg", "cython_blas") is None:  # SciPy's own OpenBLAS, which the SLSQP step uses
        import scipy.linalg  # noqa: F401

    return sorted(str(i.get("architecture")) for i in threadpool_info() if i.get("internal_api") == "openblas")


@functools.cache  # (the libraries' kernels are chosen once, when they load)
def signature() -> str:
    """How this process computes, in one line: the processor's architecture, each OpenBLAS's kernels and the
    highest NumPy code path in use (e.g. ``x86_64, OpenBLAS Haswell/Haswell, NumPy AVX2``). Two processes of the
    same signature write the same bytes."""
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

    paths = [f for f in __cpu_dispatch__ if __cpu_features__.get(f)]
    return (f"{platform.machine()}, OpenBLAS {'/'.join(blas_cores()) or 'none'}, NumPy "
            f"{paths[-1] if paths else 'baseline'}")
