"""The kernels a plan calls from Python, compiled ahead of time (numba's ``pycc``) into one extension module, so that
``jethr1 plan`` and ``jethr1 simulate`` run them without importing numba (its import and code generator's set-up:
about 0.45 s of CPU in every such command, docs/benchmarks.md).

:data:`EXPORTS` names each exported kernel and its argument types. :func:`.aot_build.build` (``jethr1 warm-up``,
so ``make install``) compiles them from the same sources as numba's JIT, with every array in any layout (``A``), and
writes the module next to numba's cache of the same sources (:func:`~.jit.cache_dir`, keyed on all kernel
sources, numba's and Python's versions; the file also on NumPy's version), atomically. :func:`exported` gives a
kernel's compiled function and a check of the arguments' types: the compiled code does not check them itself (an
array of another dtype or rank would be read as raw memory), so where they differ the call goes to numba's
dispatcher instead (:class:`~.jit.Kernel`). Where no module was built (no C compiler) or ``JETHR1_AOT=0`` is set,
every kernel runs through numba as before; ``JETHR1_AOT=FILE`` loads that module file instead. The floats are the
JIT's: ``tests/physics/test_aot.py``.
"""

from __future__ import annotations

import functools
import importlib.machinery
import importlib.util
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["EXPORTS", "MODULE_NAME", "export_name", "exported", "forget_loaded", "load_file", "module_path"]

MODULE_NAME = "jethr1_kernels_aot"
F1, F2, F3 = "float64[:]", "float64[:, :]", "float64[:, :, :]"
#: "module:function" → its argument types (numba's type strings; arrays in any layout)
EXPORTS: dict[str, tuple[str, ...]] = {
    "jethr1_plan.physics.compiled.sample:sample_terms": (
        F2, "float64", F2, F1, F1, F1, F3, F3, F2, "boolean[:]", F1, F1, F1, "float64", F1, F2, F1,
        "float64", "float64", "float64", "float64"),
    "jethr1_plan.physics.compiled.legs:postures": (F2, F1, F3, F2, F1, F1, F3, F3, F2),
    "jethr1_plan.physics.compiled.edge:edge_errors": (F2, F2, F2),
    "jethr1_plan.physics.compiled.windows:windows": (F2, F2, F2, F1, "float64", "float64", "float64", "float64"),
    "jethr1_plan.physics.share:_row": (F2, F3, F2, F2, F1, "float64", "float64", "float64", "float64", "int64"),
}
_DTYPES = {"float64": np.dtype(np.float64), "boolean": np.dtype(np.bool_), "int64": np.dtype(np.int64)}
_SCALARS: dict[str, tuple[type, ...]] = {"float64": (float, np.float64), "int64": (int, np.int64),
                                         "boolean": (bool, np.bool_)}


def export_name(key: str) -> str:
    """The module's name for the kernel ``key`` ("module:function"): the module's last part and the function's."""
    module, name = key.split(":")
    return f"{module.rsplit('.', 1)[1]}__{name.lstrip('_')}"


def module_path(directory: str | Path) -> Path:
    """The extension module's file in ``directory`` (numba's cache of the same kernel sources, numba and Python:
    :func:`~.jit.cache_dir`), for this NumPy."""
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    return Path(directory) / f"{MODULE_NAME}-numpy{np.__version__}{suffix}"


def _accepts(types: tuple[str, ...]) -> Callable[..., bool]:
    """A check that positional arguments are of ``types``: arrays of that dtype and rank (any strides, aligned),
    scalars of the Python or NumPy types numba would type as such. Written as one expression (for the 21 arguments
    of ``sample_terms`` about half the time of a loop over per-argument checks)."""
    terms: list[str] = []
    env: dict[str, Any] = {"ndarray": np.ndarray}
    for i, t in enumerate(types):
        base, _, dims = t.partition("[")
        if dims:
            env[f"d{i}"] = _DTYPES[base]
            terms.append(f"type(a{i}) is ndarray and a{i}.ndim == {dims.count(':')} "
                         f"and (a{i}.dtype is d{i} or a{i}.dtype == d{i}) and a{i}.flags.aligned")
        else:
            env[f"k{i}"] = _SCALARS[base]
            terms.append(f"type(a{i}) in k{i}")
    names = "".join(f"a{i}, " for i in range(len(types)))
    source = (f"def accepts(*args):\n    if len(args) != {len(types)}:\n        return False\n"
              f"    {names}= args\n    return bool({' and '.join(terms)})\n")
    exec(source, env)  # (types come from EXPORTS alone)
    accepts: Callable[..., bool] = env["accepts"]
    return accepts


@functools.lru_cache(maxsize=1)
def _module(directory: str) -> Any:
    """The extension module built in ``directory``, or None (not built, not loadable, or ``JETHR1_AOT=0``;
    ``JETHR1_AOT=FILE``: that file instead)."""
    setting = os.environ.get("JETHR1_AOT", "")
    if setting == "0":
        return None
    path = Path(setting) if setting else module_path(directory)
    if not path.is_file():
        return None
    try:
        return load_file(path)
    except ImportError:  # a broken or foreign file: numba's JIT instead
        return None


def load_file(path: Path) -> Any:
    """The extension module in the file ``path`` (not entered in ``sys.modules``). Raises ImportError where the file
    is not such a module."""
    loader = importlib.machinery.ExtensionFileLoader(MODULE_NAME, str(path))
    spec = importlib.util.spec_from_file_location(MODULE_NAME, path, loader=loader)
    if spec is None:
        raise ImportError(f"{path}: not an extension module")
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def exported(py_func: Callable, directory: str) -> tuple[Callable[..., Any], Callable[..., bool]] | None:
    """The ahead-of-time compiled function of the kernel ``py_func`` (from the module built in ``directory``) and
    the check of its arguments' types, or None (not exported, or no module built)."""
    key = f"{py_func.__module__}:{py_func.__qualname__}"
    if key not in EXPORTS:
        return None
    module = _module(directory)
    if module is None:
        return None
    compiled = getattr(module, export_name(key), None)
    return None if compiled is None else (compiled, _accepts(EXPORTS[key]))


def forget_loaded() -> None:
    """Look for the module again at the next call (after a build, or another ``JETHR1_AOT``)."""
    _module.cache_clear()
