"""Input files, read as data and never as streams: every file a command reads goes through here.

* **Regular files only.** A path is looked at (``stat``) before it is opened: a FIFO, a device, a
  socket or a folder is one line naming it, never an ``open`` that waits for a writer or a read that
  never ends; a loop of symbolic links, a name longer than the file system allows or a path through a
  file are said as such, not as a missing file. The file is opened with ``O_NONBLOCK`` and looked at
  again through its descriptor, so that a FIFO put in its place in between cannot block either.
* **Sizes bounded before reading.** Every reader gives the largest size its kind of file can have;
  a larger file is refused from its size alone, before a byte of it is read.
* **Inputs are known.** Every file read is recorded (:func:`inputs`): a command never writes over one
  of its own inputs (``io.atomic``).

Every problem is an :class:`~jethr1_plan.errors.InputError` (exit 2) naming the file.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from jethr1_plan.errors import InputError

__all__ = ["check_input_file", "check_input_path", "describe_kind", "forget_inputs", "input_folder", "inputs",
           "is_input", "read_input", "read_input_text"]

_INPUTS: dict[tuple[int, int], Path] = {}  # (device, inode) of every file this process read → its path


def inputs() -> dict[tuple[int, int], Path]:
    """The files this process has read (or checked for a library to read), by (device, inode)."""
    return dict(_INPUTS)


def forget_inputs() -> None:
    """Start a new command's list of inputs (a process that runs several commands, as the tests do)."""
    _INPUTS.clear()


def is_input(st: os.stat_result) -> bool:
    """Whether the file of ``st`` is one this process read."""
    return (st.st_dev, st.st_ino) in _INPUTS


def describe_kind(mode: int) -> str:
    """What a file of mode ``mode`` is, for a message (``a FIFO (named pipe)``, ``a character device``, ...)."""
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    return "not a regular file"


def _os_problem(exc: OSError) -> str:
    """An OSError of a path as the words a user reads."""
    if exc.errno == errno.ENOENT:
        return "no such file"
    if exc.errno == errno.ELOOP:
        return "a loop of symbolic links (or too many of them)"
    if exc.errno == errno.ENAMETOOLONG:
        return "a name longer than the file system allows"
    if exc.errno == errno.ENOTDIR:
        return "a path through something that is not a folder"
    if exc.errno in (errno.EACCES, errno.EPERM):
        return "cannot read: permission denied"
    return f"cannot read: {exc.strerror or exc}"


def _stat(path: Path, src: str) -> os.stat_result:
    try:
        return os.stat(path)
    except OSError as exc:
        raise InputError(src, "", _os_problem(exc)) from None
    except ValueError:  # a NUL byte in the path
        raise InputError(src, "", "not a valid path") from None


def check_input_file(path: str | Path, max_bytes: int, what: str, key: str = "") -> os.stat_result:
    """Check that ``path`` is a regular file of at most ``max_bytes`` (a file another library reads: a URDF for
    PlaCo, a mesh); record it as an input. ``what``: the kind of file, for messages (``a scenario``).

    Raises:
        InputError: missing, not a regular file, too large (exit 2).
    """
    src = str(path)
    st = _stat(Path(path), src)
    if not stat.S_ISREG(st.st_mode):
        raise InputError(src, key, f"{describe_kind(st.st_mode)}, not {what} file: jethr1 reads files, not streams "
                         "or devices")
    if st.st_size > max_bytes:
        raise InputError(src, key, f"{_size(st.st_size)}: larger than {what} can be ({_size(max_bytes)} at most)")
    _INPUTS[(st.st_dev, st.st_ino)] = Path(os.path.abspath(path))
    return st


def read_input(path: str | Path, max_bytes: int, what: str, key: str = "") -> bytes:
    """The bytes of the regular file ``path`` (at most ``max_bytes``; see the module); recorded as an input.

    Raises:
        InputError: missing, not a regular file, too large, unreadable (exit 2).
    """
    src = str(path)
    check_input_file(path, max_bytes, what, key)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:
        raise InputError(src, key, _os_problem(exc)) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):  # replaced between the look and the open
            raise InputError(src, key, f"{describe_kind(st.st_mode)}, not {what} file")
        if st.st_size > max_bytes:
            raise InputError(src, key, f"{_size(st.st_size)}: larger than {what} can be ({_size(max_bytes)} at most)")
        _INPUTS[(st.st_dev, st.st_ino)] = Path(os.path.abspath(path))
        chunks, left = [], max_bytes + 1
        while left > 0:
            data = os.read(fd, min(left, 1 << 24))
            if not data:
                break
            chunks.append(data)
            left -= len(data)
    except OSError as exc:
        raise InputError(src, key, _os_problem(exc)) from None
    finally:
        os.close(fd)
    out = b"".join(chunks)
    if len(out) > max_bytes:  # it grew while read
        raise InputError(src, key, f"larger than {what} can be ({_size(max_bytes)} at most)")
    return out


def read_input_text(path: str | Path, max_bytes: int, what: str, key: str = "") -> str:
    """The UTF-8 text of ``path`` (:func:`read_input`).

    Raises:
        InputError: as :func:`read_input`, or bytes that are not UTF-8.
    """
    data = read_input(path, max_bytes, what, key)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(str(path), key, f"not UTF-8 text (byte {data[exc.start]:#04x} at offset {exc.start})") \
            from None


def check_input_path(path: str | Path, what: str) -> os.stat_result:
    """``path``'s status, checked to be a regular file or a folder (``what``: what it should be, for messages).

    Raises:
        InputError: missing, a loop of links, or something else (a FIFO, a device, a socket).
    """
    st = _stat(Path(path), str(path))
    if not (stat.S_ISDIR(st.st_mode) or stat.S_ISREG(st.st_mode)):
        raise InputError(str(path), "", f"{describe_kind(st.st_mode)}, not a file or a folder: expected {what}")
    return st


def input_folder(path: str | Path, what: str) -> Path:
    """``path``, checked to be a folder (``what``: what it should hold, for messages).

    Raises:
        InputError: missing, or not a folder (a file, a FIFO, a device).
    """
    src = str(path)
    st = _stat(Path(path), src)
    if not stat.S_ISDIR(st.st_mode):
        raise InputError(src, "", f"{describe_kind(st.st_mode) if not stat.S_ISREG(st.st_mode) else 'a file'}, "
                         f"not a folder: expected {what}")
    return Path(path)


def _size(n: float) -> str:
    for unit, size in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{int(n)} bytes"
