"""The decorator of every compiled kernel: ``numba.njit(cache=True)`` with the cache keyed on ALL kernel sources.

numba's on-disk cache (``cache=True``) checks only the source file of the function it loads: a kernel that
calls (or inlines) a kernel of another module keeps running the callee's old machine code after that other
module changed (numba issue #1833; seen here: after an edit of the objective, the compass in
``optimisers.search`` went on scoring with the old one). :func:`kernel` puts every kernel's cache in a
directory named after a hash of every module in :data:`KERNEL_SOURCES`, so any edit of any of them starts a
fresh cache (compiled once) and a stale one is never loaded. ``tests/physics/test_jit.py`` checks that
every module whose kernels call another module's is listed.

:func:`kernel` gives a :class:`Kernel`: the kernels a plan calls from Python run the module compiled ahead of time
next to that cache (:mod:`.aot`) where it was built, without importing numba; any other call makes every kernel
numba's dispatcher (:func:`jit_all`).

The directory: ``$NUMBA_CACHE_DIR/jethr1_plan-<hash>`` where that variable is set, else
``jethr1_plan/__pycache__/numba-<hash>`` where the package can be written, else
``~/.cache/jethr1_plan/numba-<hash>`` (``$XDG_CACHE_HOME``).
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import os
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from jethr1_plan.arithmetic import scipy_extension_file

from jethr1_plan.physics.compiled import aot

__all__ = ["KERNEL_SOURCES", "Kernel", "cache_dir", "jit_all", "kernel", "sources_digest"]


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
    "physics/compiled/aot.py",  # (the exports' types: a module built from other ones is never loaded)
)


def sources_digest(root: Path = PACKAGE, sources: tuple[str, ...] = KERNEL_SOURCES) -> str:
    """The hash (16 hex digits) of the kernel sources' bytes, with numba's and Python's versions."""
    h = hashlib.sha256(f"{sys.version_info[:2]}".encode() + _numba_version_bytes())
    for rel in sources:
        h.update(rel.encode() + b"\0" + (root / rel).read_bytes() + b"\0")
    return h.hexdigest()[:16]


def _numba_version_bytes() -> bytes:
    """numba's version, read without importing numba (about 0.2 s of CPU): its ``_version.py`` file's bytes (the
    version string where that file is not found)."""
    spec = importlib.util.find_spec("numba")
    if spec is not None and spec.origin:
        version_file = Path(spec.origin).with_name("_version.py")
        if version_file.is_file():
            return version_file.read_bytes()
    from importlib.metadata import version

    return version("numba").encode()


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


@functools.lru_cache(maxsize=1)
def _numba() -> Any:
    """numba, imported when a kernel is first compiled or loaded from the cache (not where every kernel called
    runs ahead-of-time compiled code: :mod:`.aot`), with the package's two hooks: SciPy's BLAS checked by its file
    (:func:`_ensure_blas_by_its_file`) and the compile notice (:class:`~jethr1_plan.errors.CompileNotice`)."""
    import numba
    import numba.np.linalg as numba_linalg
    from numba.core import event as numba_event

    if "numba.np.arraymath" not in sys.modules:  # (arraymath binds the check when it is imported)
        numba_linalg.ensure_blas = functools.partial(_ensure_blas_by_its_file, numba_linalg, numba_linalg.ensure_blas)

    class CompileNotice(numba_event.Listener):
        """Warns the first time this process compiles one of the package's kernels: a kernel loaded from the
        cache is not compiled, and says nothing."""

        said = False

        def on_start(self, event: Any) -> None:
            dispatcher = (event.data or {}).get("dispatcher")
            module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
            if self.said or not (module.startswith("jethr1_plan.") or getattr(dispatcher, "jethr1_kernel", False)):
                return
            type(self).said = True
            import warnings

            from jethr1_plan.errors import CompileNotice as Notice

            warnings.warn(Notice(f"compiling the planner's kernels for this machine, once (about a minute on one "
                                 f"core; cached in {cache_dir()}; `jethr1 warm-up` compiles them ahead)"),
                          stacklevel=2)

        def on_end(self, event: Any) -> None:
            pass

    numba_event.register("numba:compile", CompileNotice())
    return numba


def _ensure_blas_by_its_file(numba_linalg: Any, numba_check: Callable[[], None]) -> None:
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


def _njit(f: Callable, options: dict[str, Any]) -> Any:
    """``numba.njit(cache=True, **options)`` of ``f``, cached in :func:`cache_dir`. numba picks a function's cache
    directory when it is decorated (``numba.config.CACHE_DIR``, read then): it is set for that moment only, so other
    libraries' caches stay where they were."""
    numba = _numba()
    config: Any = numba.config  # (numba ships no type information for its settings)
    saved = config.CACHE_DIR
    config.CACHE_DIR = cache_dir()
    try:
        compiled = numba.njit(cache=True, **{"error_model": "numpy", **options})(f)
        compiled.jethr1_kernel = True  # (the compile notice knows the package's kernels by it)
        return compiled
    finally:
        config.CACHE_DIR = saved


class Kernel:
    """A compiled kernel as the package's Python code calls it. Where the function was compiled ahead of time
    (:mod:`.aot`, ``jethr1 warm-up``) and the arguments are of the exported types, that code runs, and numba is not
    imported; otherwise numba's dispatcher (:func:`jit_all`), its machine code loaded from numba's cache or compiled.
    Both are the same LLVM code of the same source: the same floats (``tests/physics/test_aot.py``)."""

    def __init__(self, f: Callable, options: dict[str, Any]):
        functools.update_wrapper(self, f)
        self.py_func, self.options = f, options
        self.dispatcher: Any = None
        self._call: Callable[..., Any] = self._first_call

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        if kwargs:
            return self.jit()(*args, **kwargs)
        return self._call(*args)

    def jit(self) -> Any:
        """numba's dispatcher of this kernel (numba imported, every kernel made a dispatcher: :func:`jit_all`)."""
        if self.dispatcher is None:
            jit_all()
            if self.dispatcher is None:  # (one not made by the decorator)
                self.dispatcher = _njit(self.py_func, self.options)
        return self.dispatcher

    def _first_call(self, *args: Any) -> Any:
        ahead = aot.exported(self.py_func, cache_dir())
        if ahead is None:
            self._call = self.jit()
        else:
            compiled, accepts = ahead

            def call(*a: Any) -> Any:
                global _ahead_calls
                if _ahead_calls < AHEAD_CALLS_MAX and accepts(*a):
                    _ahead_calls += 1
                    return compiled(*a)
                self._call = self.jit()  # (other types, or a long run: numba's from now on)
                return self._call(*a)

            self._call = call
        return self._call(*args)

    def __getattr__(self, name: str) -> Any:  # numba's attributes (py_func's own are set above)
        if name.startswith("__") or name in ("dispatcher", "_call", "py_func", "options"):
            raise AttributeError(name)
        return getattr(self.jit(), name)

    def __repr__(self) -> str:
        return f"<kernel {self.py_func.__module__}.{self.py_func.__qualname__}>"


#: calls of the module's kernels after which a process makes every kernel numba's: the module saves numba's
#: import and set-up (about 0.45 s of CPU) once, and costs more per call than numba's dispatcher (``sample_terms``
#: on a slow night: 3.5 µs for the generic unboxing of its arguments, 6.3 µs for their check), so a process that
#: calls far more than a plan does (a design sweep's worker, a route: hundreds of plans) is faster with numba. The
#: shipped scenarios' plans make 3,600-17,300 calls.
AHEAD_CALLS_MAX = 30_000
_ahead_calls = 0
_KERNELS: list[Kernel] = []
_JIT_LOCK = threading.Lock()


def jit_all() -> None:
    """Import numba and make every kernel decorated so far numba's dispatcher; in every module of the package a name
    bound to a :class:`Kernel` is bound to its dispatcher instead, since numba resolves a kernel's callees by the
    global names its code reads (kernels decorated later are dispatchers at once)."""
    with _JIT_LOCK:  # (threads of a Dask worker)
        _numba()
        for k in _KERNELS:
            if k.dispatcher is None:
                k.dispatcher = _njit(k.py_func, k.options)
    for module in list(sys.modules.values()):
        if not getattr(module, "__name__", "").startswith("jethr1_plan"):
            continue
        namespace = vars(module)
        for name, value in list(namespace.items()):
            if type(value) is Kernel and value.dispatcher is not None:
                namespace[name] = value.dispatcher


def kernel(fn: Callable | None = None, **options: Any) -> Any:
    """``numba.njit(cache=True, **options)`` cached in :func:`cache_dir`, as ``@kernel`` or
    ``@kernel(inline=...)``: a :class:`Kernel` until numba is imported, numba's dispatcher after."""
    def wrap(f: Callable) -> Any:
        if _numba.cache_info().currsize:  # numba is here: the dispatcher itself
            return _njit(f, options)
        k = Kernel(f, options)
        _KERNELS.append(k)
        return k

    return wrap if fn is None else wrap(fn)
