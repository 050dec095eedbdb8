"""Building the ahead-of-time module of :mod:`.aot` (numba's ``pycc``, setuptools and a C compiler): run by
``jethr1 warm-up``."""

from __future__ import annotations

import importlib
import importlib.machinery
import os
import tempfile
import warnings
from pathlib import Path

from jethr1_plan.physics.compiled.aot import EXPORTS, MODULE_NAME, export_name, forget_loaded, module_path
from jethr1_plan.physics.compiled.jit import cache_dir, jit_all

__all__ = ["build"]


def build(directory: str | Path | None = None) -> Path:
    """Compile :data:`EXPORTS` into the extension module at :func:`module_path` (written atomically: built in a
    temporary folder, then moved). Needs numba's ``pycc``, setuptools and a C compiler; raises what they raise."""
    from jethr1_plan.errors import CompileNotice

    jit_all()
    from numba.core.errors import NumbaPendingDeprecationWarning

    target = module_path(directory or cache_dir())
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="jethr1-aot-", dir=target.parent) as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore", NumbaPendingDeprecationWarning)  # (pycc: no replacement released yet)
        warnings.simplefilter("ignore", CompileNotice)  # (pycc compiles the kernels anew by design)
        from numba.pycc import CC

        cc = CC(MODULE_NAME)
        cc.output_dir = tmp
        cc.verbose = False
        for key, types in EXPORTS.items():
            module, name = key.split(":")
            py_func = getattr(importlib.import_module(module), name).py_func
            cc.export(export_name(key), f"({', '.join(types)})")(py_func)
        cc.compile()
        built = Path(tmp) / f"{MODULE_NAME}{importlib.machinery.EXTENSION_SUFFIXES[0]}"
        if not built.is_file():
            raise RuntimeError(f"numba's pycc wrote {sorted(p.name for p in Path(tmp).iterdir())}, not {built.name}")
        os.replace(built, target)
    forget_loaded()
    return target
