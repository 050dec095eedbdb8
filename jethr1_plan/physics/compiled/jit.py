"""The decorator of every compiled kernel: ``numba.njit(cache=True)`` with the cache keyed on ALL kernel sources.

numba's on-disk cache (``cache=True``) checks only the source file of the function it loads: a kernel that
calls (or inlines) a kernel of another module keeps running the callee's old machine code after that other
module changed (numba issue #1833; seen here: after an edit of the objective, the compass in
``optimisers.search`` went on scoring with the old one). :func:`kernel` puts every kernel's cache in a
directory named after a hash of every module in :data:`KERNEL_SOURCES`, so any edit of any of them starts a
fresh cache (compiled once) and a stale one is never loaded. ``tests/physics/test_jit.py`` checks that
every module whose kernels call another module's is listed.

The directory: ``$NUMBA_CACHE_DIR/jethr1_plan-<hash>`` where that variable is set, else
``jethr1_plan/__pycache__/numba-<hash>`` where the package can be written, else
``~/.cache/jethr1_plan/numba-<hash>`` (``$XDG_CACHE_HOME``).
"""

from __future__ import annotations

import functools
import hashlib
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from jethr1_plan.arithmetic import scipy_extension_file

import numba
import numba.np.linalg as numba_linalg
from numba.core import event as numba_event

__all__ = ["KERNEL_SOURCES", "cache_dir", "kernel", "sources_digest"]


def _ensure_blas_by_its_file(numba_check: Callable[[], None] = numba_linalg.ensure_blas) -> None:
    """numba's check that SciPy's BLAS is there (``numba.np.linalg.ensure_blas``, run once when numba loads its first
    kernel, ``numba.np.arraymath``'s import), made without ``import scipy.linalg.cython_blas``: that import runs
    ``scipy.linalg``'s ``__init__`` (about 0.25 s of CPU in every command that loads a kernel, for a module no
    kernel loaded from the cache calls). The module's file is looked for instead, then numba's own check of the
    BLAS's integer width; numba imports the module itself where it compiles a kernel that calls BLAS. Where the
    file is not found, numba's check as it is."""
    if scipy_extension_file("linalg", "cython_blas") is None:
        numba_check()
        return
    width = getattr(numba_linalg, "_check_lapack_int_width", None)
    if width is not None:
        width()


if "numba.np.arraymath" not in sys.modules:  # (arraymath binds the check when it is imported)
    numba_linalg.ensure_blas = _ensure_blas_by_its_file

PACKAGE = Path(__file__).resolve().parents[2]  # jethr1_plan/
#: every module (relative to the package) whose kernels may call a kernel of another module, and every callee's
KERNEL_SOURCES = (
    "physics/compiled/jit.py",
    "physics/compiled/legs.py",
    "physics/compiled/windows.py",
    "physics/compiled/edge.py",
    "physics/compiled/reach.py",
    "physics/compiled/objective.py",
    "physics/compiled/sample.py",
    "physics/share.py",
    "optimisers/compass.py",
)


def sources_digest(root: Path = PACKAGE, sources: tuple[str, ...] = KERNEL_SOURCES) -> str:
    """The hash (16 hex digits) of the kernel sources' bytes, with numba's and Python's versions."""
    h = hashlib.sha256(f"{numba.__version__} {sys.version_info[:2]}".encode())
    for rel in sources:
        h.update(rel.encode() + b"\0" + (root / rel).read_bytes() + b"\0")
    return h.hexdigest()[:16]


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(path, os.W_OK)


@functools.lru_cache(maxsize=1)
def cache_dir() -> str:
    """Where the kernels of this process's sources are cached (created)."""
    digest = sources_digest()
    user = os.environ.get("NUMBA_CACHE_DIR")
    if user:
        return os.path.join(user, f"jethr1_plan-{digest}")
    local = PACKAGE / "__pycache__" / f"numba-{digest}"
    if _writable(local):
        return str(local)
    home = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return str(home / "jethr1_plan" / f"numba-{digest}")


class _CompileNotice(numba_event.Listener):
    """Warns (:class:`~jethr1_plan.errors.CompileNotice`) the first time this process compiles one of the package's
    kernels: a kernel loaded from the cache is not compiled, and says nothing."""

    said = False

    def on_start(self, event) -> None:
        dispatcher = (event.data or {}).get("dispatcher")
        module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
        if self.said or not (module.startswith("jethr1_plan.") or getattr(dispatcher, "jethr1_kernel", False)):
            return
        type(self).said = True
        import warnings

        from jethr1_plan.errors import CompileNotice

        warnings.warn(CompileNotice(f"compiling the planner's kernels for this machine, once (about a minute on one "
                                    f"core; cached in {cache_dir()}; `jethr1 warm-up` compiles them ahead)"),
                      stacklevel=2)

    def on_end(self, event) -> None:
        pass


numba_event.register("numba:compile", _CompileNotice())


def kernel(fn: Callable | None = None, **options: Any) -> Any:
    """``numba.njit(cache=True, **options)`` cached in :func:`cache_dir`; as ``@kernel`` or ``@kernel(inline=...)``.

    numba picks a function's cache directory when it is decorated (``numba.config.CACHE_DIR``, read then):
    it is set for that moment only, so other libraries' caches stay where they were.
    """
    def wrap(f: Callable) -> Any:
        config: Any = numba.config  # (numba ships no type information for its settings)
        saved = config.CACHE_DIR
        config.CACHE_DIR = cache_dir()
        try:
            compiled = numba.njit(cache=True, **{"error_model": "numpy", **options})(f)
            compiled.jethr1_kernel = True  # (the compile notice knows the package's kernels by it)
            return compiled
        finally:
            config.CACHE_DIR = saved

    return wrap if fn is None else wrap(fn)
