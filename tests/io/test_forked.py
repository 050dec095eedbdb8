"""A file made by a forked child: its bytes, its failures raised here, and an interrupted child leaving no file."""

from __future__ import annotations

import os
import signal
import time

import pytest

from jethr1_plan.errors import WorkerLost
from jethr1_plan.io import forked
from jethr1_plan.io.forked import ForkedFile, fork_available

needs_fork = pytest.mark.skipif(not fork_available(), reason="Linux (fork) only")


@needs_fork
def test_the_child_writes_the_bytes_while_this_process_goes_on(tmp_path):
    parent = os.getpid()
    with ForkedFile(tmp_path / "a.bin", lambda: str(os.getpid()).encode()) as f:
        (tmp_path / "b.txt").write_text("here")  # this process goes on meanwhile
        f.wait()
    child = int((tmp_path / "a.bin").read_bytes())
    assert child != parent  # made in another process
    assert (tmp_path / "b.txt").read_text() == "here"


@needs_fork
def test_a_failure_in_the_child_is_raised_here_and_writes_nothing(tmp_path):
    def make() -> bytes:
        raise ValueError("no picture of an empty grid")

    with (pytest.raises(RuntimeError, match=r"a\.png failed: ValueError: no picture of an empty grid"),
          ForkedFile(tmp_path / "a.png", make) as f):
        f.wait()
    assert not (tmp_path / "a.png").exists()


@needs_fork
def test_a_full_disk_in_the_child_is_the_os_error_this_process_would_raise(tmp_path):
    def make() -> bytes:
        raise OSError(28, "No space left on device", str(tmp_path / "a.png"))

    with pytest.raises(OSError) as caught, ForkedFile(tmp_path / "a.png", make) as f:
        f.wait()
    assert caught.value.errno == 28 and caught.value.filename == str(tmp_path / "a.png")


@needs_fork
def test_leaving_early_ends_the_child_before_it_writes(tmp_path):
    def slow() -> bytes:
        time.sleep(30)
        return b"late"

    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt), ForkedFile(tmp_path / "a.bin", slow):
        raise KeyboardInterrupt  # as a Ctrl-C here would
    assert time.monotonic() - t0 < 10
    assert not (tmp_path / "a.bin").exists()


@needs_fork
def test_a_child_killed_from_outside_is_a_lost_worker_and_writes_nothing(tmp_path):
    def slow() -> bytes:
        time.sleep(30)
        return b"late"

    lost = r"a\.bin was killed by SIGKILL .*: run again with more memory$"
    with pytest.raises(WorkerLost, match=lost), ForkedFile(tmp_path / "a.bin", slow) as f:
        assert f._process is not None
        os.kill(f._process.pid, signal.SIGKILL)  # as the out-of-memory killer does
        f.wait()
    assert not (tmp_path / "a.bin").exists()


def test_without_fork_the_file_is_made_here_at_once(tmp_path, monkeypatch):
    monkeypatch.setattr(forked, "fork_available", lambda: False)
    with ForkedFile(tmp_path / "a.bin", lambda: str(os.getpid()).encode()) as f:
        assert int((tmp_path / "a.bin").read_bytes()) == os.getpid()
        f.wait()
