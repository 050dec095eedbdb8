"""Output files, staged and committed so that nothing a user owns is ever moved or lost.

Every command writes its output through :func:`staged_directory` (a set of files in one folder) or
:func:`write_bytes_atomic` (one file). The rules:

* **Nothing is created before the work is done.** :func:`check_writable` probes the nearest folder
  that exists on the way to the output (a hidden file created and removed there) and, where the size
  is known, its free space; an interrupted run leaves no empty folder behind.
* **Staging beside the files.** Where the output folder exists, the new files are written into a
  hidden folder inside it (``.jethr1-tmp-<pid>-…``) and each is moved into place with
  :func:`os.replace` at the commit: the folder itself is never renamed, so it may be a mount point (a
  USB stick, a container volume, a tmpfs). Where it does not exist, the new files are staged in a
  hidden folder in the nearest folder that exists and renamed into place as one folder.
* **Only jethr1's files are touched.** At the commit, files the command owns (``own``) that this run
  did not write (an old ``simulation.json`` after re-planning) are removed; every other file in the
  folder is left where it is and named in :attr:`Staging.kept`.
* **No half set.** SIGINT and SIGTERM that arrive during the commit are held until it ends; a run that
  fails or is interrupted before it removes its staging folder. Staging folders of runs that were
  killed (their process on this machine is gone) are cleared by the next run into the same place: jethr1's own
  files in them are removed, anything else is left (and reported) rather than deleted.
* **Usual modes.** Files are written ``0666 & ~umask`` (``0644`` under the usual umask), folders
  ``0777 & ~umask``.
* **One-line errors.** A full disk, a read-only file system or a folder that cannot be written is an
  :class:`~jethr1_plan.errors.InputError` naming the place (exit 2), with nothing written.
"""

from __future__ import annotations

import errno
import hashlib
import os
import shutil
import signal
import socket
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from jethr1_plan.errors import InputError

__all__ = ["STAGING_PREFIX", "Staging", "check_writable", "clean_stale", "committed", "deferred_signals",
           "nearest_existing", "note_committed", "staged_directory", "write_bytes_atomic", "write_text_atomic"]

STAGING_PREFIX = ".jethr1-tmp-"  # + "<pid>-<host>-<random>": a staging folder of process <pid> on machine <host>
_OLD_PREFIXES = (".tmp-", ".old-")  # staging folders of earlier versions: ".<name>.tmp-<pid>-…", ".<name>.old-<pid>-…"
_COMMITTED: list[Path] = []  # every output committed by this process, in order (the interrupt message names them)


def committed() -> list[Path]:
    """The folders and files this process (or workers it has heard from) committed so far."""
    return list(_COMMITTED)


def note_committed(path: Path) -> None:
    """Count ``path`` as committed (an output a worker process wrote)."""
    _COMMITTED.append(Path(path))


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _os_problem(exc: OSError) -> str:
    return exc.strerror or str(exc)


def nearest_existing(path: Path) -> Path:
    """``path`` itself or its nearest ancestor that exists (as anything: a file, a folder)."""
    p = Path(os.path.abspath(path))
    while not os.path.lexists(p) and p != p.parent:
        p = p.parent
    return p


def check_writable(folder: Path, need_bytes: int = 0) -> None:
    """Check, before any work, that ``folder`` can be created (or written, where it exists) and that
    its file system has ``need_bytes`` free; nothing is created.

    Raises:
        InputError: a file in the way, a folder that cannot be written, too little space (exit 2).
    """
    folder = Path(folder)
    base = nearest_existing(folder)
    if not base.is_dir():
        what = "exists and is not a folder" if base == Path(os.path.abspath(folder)) else f"{base} is not a folder"
        raise InputError(str(folder), "", what)
    try:
        fd, probe = tempfile.mkstemp(prefix=".jethr1-write-check-", dir=base)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        where = "here" if base == Path(os.path.abspath(folder)) else f"in {base}"
        raise InputError(str(folder), "", f"cannot write {where}: {_os_problem(exc)}") from None
    if need_bytes > 0:
        try:
            free = shutil.disk_usage(base).free
        except OSError:
            return
        if free < need_bytes:
            raise InputError(str(folder), "", f"needs about {need_bytes / 1e6:.1f} MB, {free / 1e6:.1f} MB free "
                             f"in {base}")


@contextmanager
def deferred_signals() -> Iterator[None]:
    """Hold SIGINT and SIGTERM until the block ends, then deliver them (main thread only: elsewhere
    signals go to the main thread's handlers anyway)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []
    previous: dict[signal.Signals, Any] = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.signal(sig, lambda signum, frame: held.append(signum))
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for signum in held:
            signal.raise_signal(signum)


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file beside it and a rename."""
    write_bytes_atomic(path, text.encode("utf-8"))


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file beside it and a rename (see the module).

    Raises:
        InputError: the folder cannot be written (full, read-only).
    """
    path = Path(path)
    with staged_directory(path.parent, frozenset({path.name})) as staging:
        try:
            (staging.path / path.name).write_bytes(data)
        except OSError as exc:
            raise InputError(str(path), "", f"cannot write: {_os_problem(exc)}; nothing written") from None


@dataclass
class Staging:
    """A staged output folder: write into ``path``; after the ``with`` block ``path`` is the final
    folder and ``kept`` names the files in it that jethr1 did not write (left untouched)."""

    path: Path
    kept: list[str] = field(default_factory=list)


def _host() -> str:
    """This machine, as 8 hex digits (a shared folder may hold the staging folders of other machines,
    whose processes this one cannot see)."""
    return hashlib.sha1(socket.gethostname().encode()).hexdigest()[:8]


def _pid_of(rest: str, host: bool) -> int | None:
    """The process id at the start of a staging folder's name after its prefix (and, with ``host``,
    only where this machine made it), or None."""
    parts = rest.split("-", 2)
    if host and (len(parts) < 3 or parts[1] != _host()):
        return None
    return int(parts[0]) if parts[0].isdigit() else None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def _clear_own(folder: Path, own: frozenset[str]) -> bool:
    """Remove the files named in ``own`` from a folder, then the folders left empty; True when it is gone."""
    for root, dirs, files in os.walk(folder, topdown=False):
        for name in files:
            if name in own:
                Path(root, name).unlink(missing_ok=True)
        for name in dirs:
            with suppress(OSError):
                Path(root, name).rmdir()
    try:
        folder.rmdir()
    except OSError:
        return False
    return True


def clean_stale(places: list[Path], own: frozenset[str] = frozenset(), final_name: str = "") -> list[Path]:
    """Clear the staging folders in ``places`` whose process has gone; return those left in place.

    A staging folder of this version holds only files jethr1 wrote: it is removed. One of an earlier
    version (``.<final_name>.tmp-<pid>-…`` or ``.old-…``) may hold a user's files moved there: only
    the ``own`` files are removed from it, and it is left (and returned) when anything else remains.
    """
    left: list[Path] = []
    old = tuple(f".{final_name}{kind}" for kind in _OLD_PREFIXES) if final_name else ()
    for place in dict.fromkeys(places):
        try:
            entries = list(place.iterdir()) if place.is_dir() else []
        except OSError:
            continue
        for entry in entries:
            name = entry.name
            prefix = STAGING_PREFIX if name.startswith(STAGING_PREFIX) else next(
                (p for p in old if name.startswith(p)), None)
            if prefix is None or not entry.is_dir() or entry.is_symlink():
                continue
            pid = _pid_of(name[len(prefix):], host=prefix == STAGING_PREFIX)
            if pid is None or pid == os.getpid() or _alive(pid):
                continue
            if prefix == STAGING_PREFIX:
                shutil.rmtree(entry, ignore_errors=True)
            elif not _clear_own(entry, own | ({"x"} if ".old-" in prefix else frozenset())):
                left.append(entry)
    return left


@contextmanager
def staged_directory(final: Path, own: frozenset[str] = frozenset()) -> Iterator[Staging]:
    """Yield a :class:`Staging` whose ``path`` receives the new files of folder ``final``; at the end
    of the block they are committed (see the module). ``own``: every name this command writes into
    such a folder, whether or not this run writes it.

    On an exception nothing is committed, the staging folder is removed and ``final`` is untouched.

    Raises:
        InputError: the place cannot be written (a full disk, a read-only file system).
    """
    final = Path(os.path.abspath(final))
    base = nearest_existing(final)
    if not base.is_dir():
        raise InputError(str(final), "", f"{base} is not a folder")
    left = clean_stale([base, final.parent, final], own, final.name)
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f"{STAGING_PREFIX}{os.getpid()}-{_host()}-", dir=base))
        os.chmod(tmp, 0o777 & ~_umask())
    except OSError as exc:
        raise InputError(str(final), "", f"cannot write in {base}: {_os_problem(exc)}") from None
    inner = tmp.joinpath(*final.relative_to(base).parts)  # tmp mirrors the path from base down to final
    staging = Staging(inner, kept=[f"{p.name}/ (left by an interrupted run: it holds files jethr1 did not write)"
                                   for p in left])
    try:
        inner.mkdir(parents=True, exist_ok=True)
        yield staging
        with deferred_signals():
            _commit(tmp, base, final, own, staging)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EFBIG,
                         errno.EIO):
            raise InputError(str(final), "", f"cannot write: {_os_problem(exc)}; nothing written") from None
        raise
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    shutil.rmtree(tmp, ignore_errors=True)
    staging.path = final


def _commit(tmp: Path, base: Path, final: Path, own: frozenset[str], staging: Staging) -> None:
    """Move the staged files into ``final``: as one folder where none of it exists yet, else file by file."""
    while True:
        there = nearest_existing(final)
        if there == final:
            break
        if not there.is_dir():
            raise InputError(str(final), "", f"{there} is not a folder")
        top = there / final.relative_to(there).parts[0]  # the first missing folder on the way
        src = tmp.joinpath(*top.relative_to(base).parts)
        try:
            os.rename(src, top)  # a new folder: its files arrive together
            _COMMITTED.append(final)
            return
        except OSError as exc:
            if exc.errno not in (errno.EEXIST, errno.ENOTEMPTY, errno.ENOTDIR):
                raise
            # another process made it meanwhile: look again
    if not final.is_dir():
        raise InputError(str(final), "", "exists and is not a folder")
    inner = tmp.joinpath(*final.relative_to(base).parts)
    written = sorted(p.relative_to(inner) for p in inner.rglob("*") if not p.is_dir())
    for rel in written:
        dest = final / rel
        dest.parent.mkdir(parents=True, exist_ok=True)
        os.replace(inner / rel, dest)
    names = {str(rel) for rel in written}
    for entry in sorted(final.iterdir()):
        if entry.name in names or entry.name.startswith(STAGING_PREFIX):
            continue
        if entry.name in own and (entry.is_file() or entry.is_symlink()):
            entry.unlink()  # jethr1's, from an earlier run, not part of this set
        elif not entry.name.startswith("."):
            staging.kept.append(entry.name)
    _COMMITTED.append(final)
