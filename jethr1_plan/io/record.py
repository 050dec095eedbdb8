"""The record of the files jethr1 wrote in a folder (``.jethr1-files.json``: each file's size and SHA-256), and the
checks every output passes before any work: what may be replaced, names the file system allows, a folder that
can be written with room enough. :mod:`.atomic` states the rule these serve and writes the files.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import shutil
import stat
import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from jethr1_plan.errors import InputError
from jethr1_plan.io.input_file import describe_kind, is_input

__all__ = ["MAX_RECORD_BYTES", "NAME_MAX", "RECORD", "check_names", "check_subfolders", "check_targets",
           "check_writable", "file_sha256", "nearest_existing", "os_problem", "read_record", "record_text",
           "write_record"]

RECORD = ".jethr1-files.json"  # in every folder jethr1 writes into: the files it wrote there, size and SHA-256
MAX_RECORD_BYTES = 10_000_000
NAME_MAX = 255  # bytes in one name (Linux, macOS), where the file system does not say


def os_problem(exc: OSError) -> str:
    """What went wrong with a path, in words (an OS error's)."""
    if exc.errno == errno.ENAMETOOLONG:
        return "a name longer than the file system allows"
    if exc.errno == errno.ELOOP:
        return "a loop of symbolic links"
    return exc.strerror or str(exc)


def nearest_existing(path: Path) -> Path:
    """``path`` itself or its nearest ancestor that exists (as anything: a file, a folder)."""
    p = Path(os.path.abspath(path))
    while not os.path.lexists(p) and p != p.parent:
        p = p.parent
    return p


def file_sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes, hex."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def check_names(path: Path, names: Iterable[str] = ()) -> None:
    """Refuse a path (or a name to be written in it) with a component longer than the file system allows."""
    parts = [*Path(os.path.abspath(path)).parts, *names]
    for part in parts:
        n = len(os.fsencode(part))
        if n > NAME_MAX:
            raise InputError(str(path), "", f"a name of {n} bytes ({part[:24]}...): the file system allows "
                             f"{NAME_MAX}; nothing written")
    if len(os.fsencode(os.path.abspath(path))) > 3800:
        raise InputError(str(path), "", "a path longer than the file system allows; nothing written")


def read_record(folder: Path, strict: bool = False) -> dict[str, dict[str, Any]]:
    """The files jethr1 wrote in ``folder`` (its :data:`RECORD`): name → {"sha256", "bytes"}; empty where it has
    none, or (unless ``strict``) one that is not jethr1's.

    Raises:
        InputError: the record's name holds something other than a file (a link, a folder, a FIFO); with
            ``strict``, a file of that name that is not jethr1's record (a commit never replaces it).
    """
    p = Path(folder) / RECORD
    try:
        st = os.lstat(p)
    except FileNotFoundError:
        return {}
    except OSError as exc:
        raise InputError(str(p), "", f"cannot read jethr1's record of its files: {os_problem(exc)}") from None
    if not stat.S_ISREG(st.st_mode):
        raise InputError(str(p), "", f"{describe_kind(st.st_mode)} where jethr1 keeps its record of the files it "
                         "wrote here; nothing written")
    doc: Any = None
    if st.st_size <= MAX_RECORD_BYTES:
        try:
            fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | os.O_NOFOLLOW | os.O_CLOEXEC)
            with os.fdopen(fd, "rb") as f:
                doc = json.loads(f.read(MAX_RECORD_BYTES + 1).decode("utf-8"))
        except (OSError, ValueError, UnicodeDecodeError, RecursionError):
            doc = None
    files = doc.get("files") if isinstance(doc, dict) and doc.get("written_by") == "jethr1" else None
    if not isinstance(files, dict):
        if strict:
            raise InputError(str(p), "", "a file of the name jethr1 keeps its record of the files it wrote under, "
                             "which is not that record: move it away or choose another output; nothing written")
        return {}
    return {k: v for k, v in files.items() if isinstance(k, str) and isinstance(v, dict)
            and isinstance(v.get("sha256"), str) and isinstance(v.get("bytes"), int)}


def record_text(files: dict[str, dict[str, Any]]) -> str:
    """The text of a folder's :data:`RECORD` naming ``files`` (name → {"sha256", "bytes"})."""
    return json.dumps({"written_by": "jethr1", "format": 1, "what": "the files jethr1 wrote in this folder, "
                       "which it may replace; it never replaces any other file",
                       "files": dict(sorted(files.items()))}, indent=1) + "\n"


def check_targets(folder: Path, names: Iterable[str], record: dict[str, dict[str, Any]] | None = None,
                  digests: dict[str, str] | None = None) -> None:
    """Refuse, with one line, any name of ``names`` in ``folder`` that holds something jethr1 may not replace
    (see the module): not a regular file, one of this command's inputs, not in the folder's record, or
    changed since jethr1 wrote it. ``digests``: the current SHA-256 of files already hashed.

    Raises:
        InputError: the first such name (exit 2), "nothing written".
    """
    folder = Path(folder)
    if record is None:
        record = read_record(folder, strict=True) if folder.is_dir() else {}
    for name in names:
        p = folder / name
        st = _lstat(p)
        if st is None:
            continue
        if not stat.S_ISREG(st.st_mode):
            raise InputError(str(p), "", f"{describe_kind(st.st_mode)} where jethr1 writes its {name}: jethr1 "
                             "replaces only files it wrote; move it away or choose another output; nothing written")
        if is_input(st):
            raise InputError(str(p), "", f"this command's own input, where it writes its {name}: jethr1 never "
                             "writes over its inputs; copy the input elsewhere or choose another output; nothing "
                             "written")
        rec = record.get(name)
        if rec is None:
            why = f"its record here, {RECORD}, does not name it" if record else \
                f"or one an earlier jethr1 wrote: there is no {RECORD} here"
            raise InputError(str(p), "", f"a file jethr1 did not write ({why}): move it away or choose another "
                             "output; nothing written")
        if rec["bytes"] != st.st_size or ((digests or {}).get(name) or file_sha256(p)) != rec["sha256"]:
            raise InputError(str(p), "", "changed since jethr1 wrote it: move it away (or remove it) to write here "
                             "again; nothing written")


def check_writable(folder: Path, need_bytes: int = 0, writes: Iterable[str] = ()) -> None:
    """Check, before any work, that ``folder`` can be created (or written, where it exists), that its file
    system has ``need_bytes`` free, and that every name of ``writes`` may be written there
    (:func:`check_targets`); nothing is created.

    Raises:
        InputError: a file in the way, a folder that cannot be written, too little space, a name that may not
            be replaced (exit 2).
    """
    folder = Path(folder)
    writes = tuple(writes)
    check_names(folder, writes)
    base = nearest_existing(folder)
    if not base.is_dir():
        kind = "a file" if base.is_file() else describe_kind(os.stat(base).st_mode) if base.exists() else \
            "a broken link"
        what = f"exists and is not a folder ({kind})" if base == Path(os.path.abspath(folder)) else \
            f"{base} is not a folder"
        raise InputError(str(folder), "", what)
    try:
        fd, probe = tempfile.mkstemp(prefix=".jethr1-write-check-", dir=base)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        where = "here" if base == Path(os.path.abspath(folder)) else f"in {base}"
        raise InputError(str(folder), "", f"cannot write {where}: {os_problem(exc)}") from None
    if base == Path(os.path.abspath(folder)):
        check_targets(folder, writes)  # (and the folder's record, if any, is jethr1's)
    if need_bytes > 0:
        try:
            free = shutil.disk_usage(base).free
        except OSError:
            return
        if free < need_bytes:
            raise InputError(str(folder), "", f"needs about {need_bytes / 1e6:.1f} MB, {free / 1e6:.1f} MB free "
                             f"in {base}")


def check_subfolders(folder: Path, names: Iterable[str]) -> None:
    """Check, before any work, that each of ``names`` in ``folder`` (subfolders a command writes files into) is
    a folder where it exists, not a file, a link or a device in the way; nothing is created.

    Raises:
        InputError: the first name that is not a folder (exit 2), "nothing written".
    """
    for name in names:
        p = Path(folder) / name
        st = _lstat(p)
        if st is None:
            continue
        if not stat.S_ISDIR(st.st_mode):
            raise InputError(str(p), "", f"{describe_kind(st.st_mode) if not stat.S_ISREG(st.st_mode) else 'a file'} "
                             f"where jethr1 writes its {name}/ folder: move it away or choose another output; "
                             "nothing written")


def _lstat(p: Path) -> os.stat_result | None:
    """What is at ``p`` (not following a link), None where nothing is.

    Raises:
        InputError: ``p`` cannot be looked at (exit 2), "nothing written".
    """
    try:
        return os.lstat(p)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise InputError(str(p), "", f"cannot write here: {os_problem(exc)}; nothing written") from None


def write_record(folder: Path, record: dict[str, dict[str, Any]], tmp: Path) -> None:
    """The folder's record, replaced atomically (written in the staging folder, renamed into place)."""
    staged = tmp / RECORD
    staged.write_text(record_text(record))
    os.replace(staged, folder / RECORD)
