"""Atomic output: a run that stops halfway leaves no half-written file behind.

* Single files go through a temporary file in the same directory and a rename.
* An output folder is staged beside its final place (``.<name>.tmp-<pid>-…``) and swapped in as a
  whole. Staging folders of runs that were killed (their process is gone) are removed by the next
  run into the same place. Files in the old folder that this command did not write and does not own
  (a user's notes) are kept: moved into the new folder, and named in :attr:`Staging.kept`.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from jethr1_plan.errors import InputError

__all__ = ["Staging", "check_writable", "staged_directory", "write_bytes_atomic", "write_text_atomic"]


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file in the same directory and a rename."""
    write_bytes_atomic(path, text.encode("utf-8"))


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same directory and a rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def check_writable(folder: Path) -> None:
    """Make ``folder`` (and its parents) and check a file can be created in it, before any work.

    Raises:
        InputError: it cannot be made or written (exit 2).
    """
    folder = Path(folder)
    try:
        if folder.exists() and not folder.is_dir():
            raise InputError(str(folder), "", "exists and is not a folder")
        folder.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".write-check-", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise InputError(str(folder), "", f"cannot write here: {exc.strerror or exc}") from None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def clean_stale(final: Path) -> list[Path]:
    """Remove the staging folders beside ``final`` whose process has gone; return them."""
    removed: list[Path] = []
    parent = Path(final).parent
    if not parent.is_dir():
        return removed
    for kind in ("tmp", "old"):
        prefix = f".{Path(final).name}.{kind}-"
        for entry in parent.iterdir():
            if not entry.name.startswith(prefix):
                continue
            pid = entry.name[len(prefix):].split("-", 1)[0]
            if pid.isdigit() and not _alive(int(pid)):
                shutil.rmtree(entry, ignore_errors=True)
                removed.append(entry)
    return removed


@dataclass
class Staging:
    """A staged output folder: write into ``path``; after the ``with`` block, ``kept`` names the files
    of the old folder that were not this command's and were carried over."""

    path: Path
    kept: list[str] = field(default_factory=list)


@contextmanager
def staged_directory(final: Path, own: frozenset[str] = frozenset()) -> Iterator[Staging]:
    """Yield a staging folder beside ``final``; on success it replaces ``final`` as a whole.

    ``own``: names this command writes into such a folder (whether or not this run writes them): in
    the old folder they are replaced or dropped; any other file there is carried over into the new
    folder. On an exception the staging folder is removed and ``final`` is left untouched.
    """
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    clean_stale(final)
    pid = os.getpid()
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.tmp-{pid}-", dir=final.parent))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)
    staging = Staging(tmp)
    try:
        yield staging
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    old = None
    if final.exists():
        for entry in sorted(final.iterdir()):
            if entry.name not in own and not (tmp / entry.name).exists():
                shutil.move(str(entry), str(tmp / entry.name))
                staging.kept.append(entry.name)
        old = Path(tempfile.mkdtemp(prefix=f".{final.name}.old-{pid}-", dir=final.parent))
        os.replace(final, old / "x")
    staging.path = final
    os.replace(tmp, final)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
