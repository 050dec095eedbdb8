"""Output files: one rule for every file any command writes, implemented here and nowhere else.

**The rule.** A command writes only names it owns, into a folder it made or into one it finds, and it
replaces only a file that jethr1 wrote there and that nobody changed since:

* **A record of what jethr1 wrote.** Every folder jethr1 writes into holds a record,
  ``.jethr1-files.json``: each file jethr1 wrote there, with its size and SHA-256. A file of an
  output's name that is not in the record (a user's ``summary.json``), or that differs from it (edited
  since), is never replaced or removed: the command says so in one line and writes nothing.
* **Inputs are never outputs.** A file the command read (``io.input_file``) is never replaced, under
  any name, whatever folder it sits in.
* **Only files.** A symbolic link, a FIFO, a device, a socket or a folder where an output goes is
  refused with one line (never written through, never replaced); so is a name longer than the file
  system allows.
* **Checked first.** :func:`check_writable` runs these checks before any work, with the names the
  command will write: a refusal costs a second, not the plan; the commit checks again under a lock.

How files are written:

* **Nothing is created before the work is done.** :func:`check_writable` probes the nearest folder
  that exists on the way to the output (a hidden file created and removed there) and, where the size
  is known, its free space; an interrupted run leaves no empty folder behind.
* **Staging beside the files.** Where the output folder exists, the new files are written into a
  hidden folder inside it (``.jethr1-tmp-<pid>-<host>-<random>``) and each is moved into place with
  :func:`os.replace` at the commit: the folder itself is never renamed, so it may be a mount point (a
  USB stick, a container volume, a tmpfs). Where it does not exist, the new files are staged in a
  hidden folder in the nearest folder that exists and renamed into place as one folder.
* **Files owned, not written, go.** At the commit, files the command owns (``own``) that this run did
  not write (a rehearsal of the plan a re-plan replaces) are removed where the record says jethr1
  wrote them and they are unchanged; otherwise they are left and named in :attr:`Staging.kept`, as is
  every other file in the folder.
* **One commit at a time.** A commit holds a lock on its folder (``flock``) and may be given a
  ``precondition``, checked under the lock (``simulate``: the plan it rehearsed is still the folder's).
* **No half set.** SIGINT and SIGTERM that arrive during the commit are held until it ends; a run that
  fails or is interrupted before it removes its staging folder. A staging folder holds a marker naming
  the very folder (its device and inode) and the run that made it; the next run into the same place
  removes a staging folder whose run has ended only when its marker proves jethr1 made it: a folder of
  the user's that merely has such a name is never touched.
* **Usual modes.** Files are written ``0666 & ~umask`` (``0644`` under the usual umask), folders
  ``0777 & ~umask``.
* **One-line errors.** A full disk, a read-only file system or a folder that cannot be written is an
  :class:`~jethr1_plan.errors.InputError` naming the place (exit 2), with nothing written.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import secrets
import shutil
import signal
import socket
import stat
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from jethr1_plan.errors import InputError
from jethr1_plan.io.input_file import describe_kind, is_input
from jethr1_plan.io.record import (
    RECORD,
    check_names,
    check_targets,
    file_sha256,
    nearest_existing,
    os_problem,
    read_record,
    record_text,
    write_record,
)

__all__ = ["MARKER", "STAGING_PREFIX", "Staging", "clean_stale", "committed", "deferred_signals", "note_committed",
           "staged_directory", "write_bytes_atomic", "write_text_atomic"]

STAGING_PREFIX = ".jethr1-tmp-"  # + "<pid>-<host>-<random>": a staging folder of process <pid> on machine <host>
MARKER = ".jethr1-staging"  # inside a staging folder: {"pid", "host", "token", "device", "inode"} of that folder
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
        InputError: the folder cannot be written (full, read-only), or ``path`` may not be replaced.
    """
    path = Path(path)
    with staged_directory(path.parent, frozenset({path.name})) as staging:
        try:
            (staging.path / path.name).write_bytes(data)
        except OSError as exc:
            raise InputError(str(path), "", f"cannot write: {os_problem(exc)}; nothing written") from None


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


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):  # another user's process; a number no process has
        return True
    return True


def _proven_stale(entry: Path) -> bool:
    """Whether ``entry`` is a staging folder jethr1 made (its marker names this very folder and the run in its
    name) on this machine, whose run has ended."""
    parts = entry.name[len(STAGING_PREFIX):].split("-", 2)
    if len(parts) != 3 or not parts[0].isdigit() or parts[1] != _host():
        return False
    pid = int(parts[0])
    if pid == os.getpid() or _alive(pid):
        return False
    try:
        st = os.lstat(entry)
        if not stat.S_ISDIR(st.st_mode):
            return False
        fd = os.open(entry / MARKER, os.O_RDONLY | os.O_NONBLOCK | os.O_NOFOLLOW | os.O_CLOEXEC)
        with os.fdopen(fd, "rb") as f:
            if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
                return False
            marker = json.loads(f.read(4096).decode("utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return False
    return isinstance(marker, dict) and marker.get("token") == parts[2] and marker.get("pid") == pid and \
        marker.get("host") == parts[1] and marker.get("device") == st.st_dev and marker.get("inode") == st.st_ino


def clean_stale(places: list[Path]) -> list[Path]:
    """Remove, from ``places``, the staging folders of runs that ended before their commit (killed), where
    their marker proves jethr1 made them (:func:`_proven_stale`); return those removed. Anything else of
    that name, a user's folder among them, is left as it is."""
    removed: list[Path] = []
    for place in dict.fromkeys(places):
        try:
            entries = list(place.iterdir()) if place.is_dir() else []
        except OSError:
            continue
        for entry in entries:
            if entry.name.startswith(STAGING_PREFIX) and _proven_stale(entry):
                shutil.rmtree(entry, ignore_errors=True)
                removed.append(entry)
    return removed


def _make_staging(base: Path) -> Path:
    """A new staging folder in ``base``, with its marker."""
    token = secrets.token_hex(8)
    tmp = base / f"{STAGING_PREFIX}{os.getpid()}-{_host()}-{token}"
    os.mkdir(tmp, 0o700)
    st = os.lstat(tmp)
    (tmp / MARKER).write_text(json.dumps({"pid": os.getpid(), "host": _host(), "token": token,
                                          "device": st.st_dev, "inode": st.st_ino}))
    os.chmod(tmp, 0o777 & ~_umask())
    return tmp


@contextmanager
def _locked(folder: Path) -> Iterator[None]:
    """An exclusive lock on ``folder`` (``flock`` of the folder itself) for the block; none where the file
    system has none."""
    try:
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    except OSError:
        yield
        return
    try:
        with contextlib.suppress(OSError):
            import fcntl

            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


@contextmanager
def staged_directory(final: Path, own: frozenset[str] = frozenset(),
                     precondition: Callable[[], None] | None = None) -> Iterator[Staging]:
    """Yield a :class:`Staging` whose ``path`` receives the new files of folder ``final``; at the end
    of the block they are committed (see the module). ``own``: every name this command writes into
    such a folder, whether or not this run writes it. ``precondition``: called under the folder's lock
    just before an existing folder's files are replaced (it raises to refuse the commit).

    On an exception nothing is committed, the staging folder is removed and ``final`` is untouched.

    Raises:
        InputError: the place cannot be written (a full disk, a read-only file system), or a name there
            may not be replaced (:func:`check_targets`).
    """
    final = Path(os.path.abspath(final))
    check_names(final, own)
    base = nearest_existing(final)
    if not base.is_dir():
        raise InputError(str(final), "", f"{base} is not a folder")
    clean_stale([base, final.parent, final])
    try:
        tmp = _make_staging(base)
    except OSError as exc:
        raise InputError(str(final), "", f"cannot write in {base}: {os_problem(exc)}") from None
    inner = tmp.joinpath(*final.relative_to(base).parts)  # tmp mirrors the path from base down to final
    staging = Staging(inner)
    try:
        inner.mkdir(parents=True, exist_ok=True)
        yield staging
        _commit(tmp, base, final, own, staging, precondition)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise InputError(str(final), "", f"cannot write: {os_problem(exc)}; nothing written") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    shutil.rmtree(tmp, ignore_errors=True)
    staging.path = final


def _written(inner: Path) -> list[str]:
    """The files staged in ``inner`` (relative names), the staging marker and any record aside."""
    out = []
    for p in sorted(inner.rglob("*")):
        rel = str(p.relative_to(inner))
        if rel in (MARKER, RECORD) or p.is_dir():
            continue
        if p.is_symlink() or not p.is_file():
            raise InputError(str(p), "", "not a file: only files are written")  # (a bug of the command)
        out.append(rel)
    return out


def _commit(tmp: Path, base: Path, final: Path, own: frozenset[str], staging: Staging,
            precondition: Callable[[], None] | None) -> None:
    """Move the staged files into ``final``: as one folder where none of it exists yet, else file by file."""
    inner = tmp.joinpath(*final.relative_to(base).parts)
    written = _written(inner)
    digests = {rel: file_sha256(inner / rel) for rel in written}
    sizes = {rel: (inner / rel).stat().st_size for rel in written}
    while True:
        there = nearest_existing(final)
        if there == final:
            break
        if not there.is_dir():
            raise InputError(str(final), "", f"{there} is not a folder")
        (inner / RECORD).write_text(record_text({rel: {"sha256": digests[rel], "bytes": sizes[rel]}
                                                  for rel in written}))
        top = there / final.relative_to(there).parts[0]  # the first missing folder on the way
        src = tmp.joinpath(*top.relative_to(base).parts)
        try:
            with deferred_signals():
                os.rename(src, top)  # a new folder: its files arrive together
                _COMMITTED.append(final)
            return
        except OSError as exc:
            if exc.errno not in (errno.EEXIST, errno.ENOTEMPTY, errno.ENOTDIR):
                raise
            # another process made it meanwhile: look again
    st = os.stat(final)
    if not stat.S_ISDIR(st.st_mode):
        raise InputError(str(final), "", f"exists and is {describe_kind(st.st_mode)}, not a folder")
    (inner / RECORD).unlink(missing_ok=True)
    with _locked(final):
        record = read_record(final, strict=True)
        check_targets(final, written, record)
        if precondition is not None:
            precondition()
        with deferred_signals():
            for rel in written:
                dest = final / rel
                dest.parent.mkdir(parents=True, exist_ok=True)
                os.replace(inner / rel, dest)
                record[rel] = {"sha256": digests[rel], "bytes": sizes[rel]}
            for name in sorted(own - set(written)):
                _remove_owned(final / name, record.get(name), staging)
                if not os.path.lexists(final / name):
                    record.pop(name, None)
            record = {k: v for k, v in record.items() if os.path.lexists(final / k)}
            write_record(final, record, tmp)
            _COMMITTED.append(final)
    names = set(written) | own
    for entry in sorted(final.iterdir()):
        if entry.name not in names and not entry.name.startswith("."):
            staging.kept.append(entry.name)


def _remove_owned(p: Path, rec: dict[str, Any] | None, staging: Staging) -> None:
    """Remove a file the command owns but did not write this run, where jethr1 wrote it and it is unchanged."""
    try:
        st = os.lstat(p)
    except OSError:
        return
    if rec is not None and stat.S_ISREG(st.st_mode) and not is_input(st) and rec["bytes"] == st.st_size and \
            file_sha256(p) == rec["sha256"]:
        p.unlink()
    else:
        staging.kept.append(p.name)
