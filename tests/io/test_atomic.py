"""The one staging and commit mechanism of every command: a user's file is never moved or lost, an
output folder that is a mount point is never renamed, a new folder appears whole or not at all,
files get the usual modes, a full disk is one line, and an interrupt during the commit waits for it."""

from __future__ import annotations

import errno
import os
import signal
import stat

import pytest

from jethr1_plan.errors import InputError
from jethr1_plan.io import atomic
from jethr1_plan.io.atomic import (
    STAGING_PREFIX,
    check_writable,
    clean_stale,
    staged_directory,
    write_bytes_atomic,
    write_text_atomic,
)

OWN = frozenset({"a.csv", "b.json", "c.json"})


def _tree(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_a_new_folder_appears_whole_and_nothing_else_is_created(tmp_path):
    final = tmp_path / "out" / "deeper" / "plan"
    with staged_directory(final, OWN) as staging:
        (staging.path / "a.csv").write_text("1")
        (staging.path / "b.json").write_text("{}")
        assert not (tmp_path / "out").exists()  # staged in the nearest folder that exists, hidden
        assert [p.name.startswith(STAGING_PREFIX) for p in tmp_path.iterdir()] == [True]
    assert staging.path == final.resolve()
    assert _tree(tmp_path) == ["out", "out/deeper", "out/deeper/plan", "out/deeper/plan/a.csv",
                               "out/deeper/plan/b.json"]


def test_an_existing_folder_keeps_the_users_files_and_loses_only_jethr1s_stale_ones(tmp_path):
    final = tmp_path / "plan"
    final.mkdir()
    (final / "notes.txt").write_text("mine")
    (final / "c.json").write_text("old rehearsal")  # jethr1's, from an earlier run: not part of the new set
    (final / "a.csv").write_text("old")
    inode = final.stat().st_ino
    with staged_directory(final, OWN) as staging:
        (staging.path / "a.csv").write_text("new")
        assert staging.path.parent == final  # staged inside the folder itself
    assert final.stat().st_ino == inode  # the folder was not replaced
    assert (final / "notes.txt").read_text() == "mine" and (final / "a.csv").read_text() == "new"
    assert not (final / "c.json").exists()
    assert staging.kept == ["notes.txt"]
    assert _tree(tmp_path) == ["plan", "plan/a.csv", "plan/notes.txt"]


def test_a_folder_that_cannot_be_renamed_is_written_file_by_file(tmp_path, monkeypatch):
    """A mount point (a USB stick, a container volume) cannot be renamed, nor anything renamed onto it
    (EBUSY): emulated here for os.rename and os.replace, two runs in a row."""
    mount = tmp_path / "usb"
    mount.mkdir()
    (mount / "notes.txt").write_text("mine")
    real = {"rename": os.rename, "replace": os.replace}

    def refusing(kind):
        def call(src, dst):
            if str(mount) in (os.path.abspath(src), os.path.abspath(dst)):
                raise OSError(errno.EBUSY, "Device or resource busy", str(src))
            return real[kind](src, dst)
        return call

    monkeypatch.setattr(atomic.os, "rename", refusing("rename"))
    monkeypatch.setattr(atomic.os, "replace", refusing("replace"))
    for run in range(2):
        with staged_directory(mount, OWN) as staging:
            (staging.path / "a.csv").write_text(f"run {run}")
        assert (mount / "notes.txt").read_text() == "mine"
        assert (mount / "a.csv").read_text() == f"run {run}"
        with staged_directory(mount / "plan", OWN) as staging:  # a folder inside the mount point
            (staging.path / "b.json").write_text(f"run {run}")
    assert _tree(tmp_path) == ["usb", "usb/a.csv", "usb/notes.txt", "usb/plan", "usb/plan/b.json"]


def test_a_failed_run_leaves_everything_as_it_was(tmp_path):
    final = tmp_path / "plan"
    final.mkdir()
    (final / "a.csv").write_text("old")
    with pytest.raises(RuntimeError), staged_directory(final, OWN) as staging:
        (staging.path / "a.csv").write_text("new")
        raise RuntimeError("the self-check failed")
    assert _tree(tmp_path) == ["plan", "plan/a.csv"] and (final / "a.csv").read_text() == "old"
    with pytest.raises(RuntimeError), staged_directory(tmp_path / "new" / "plan", OWN) as staging:
        (staging.path / "a.csv").write_text("new")
        raise RuntimeError
    assert _tree(tmp_path) == ["plan", "plan/a.csv"]  # no empty folder left behind


def test_files_get_the_usual_modes(tmp_path):
    old = os.umask(0o022)
    try:
        write_text_atomic(tmp_path / "x" / "summary.json", "{}")  # mkstemp alone gives 0600
        with staged_directory(tmp_path / "y", OWN) as staging:
            (staging.path / "a.csv").write_text("1")
    finally:
        os.umask(old)
    for p in (tmp_path / "x" / "summary.json", tmp_path / "y" / "a.csv"):
        assert stat.S_IMODE(p.stat().st_mode) == 0o644
    for p in (tmp_path / "x", tmp_path / "y"):
        assert stat.S_IMODE(p.stat().st_mode) == 0o755


def test_a_full_disk_is_one_line_and_nothing_is_written(tmp_path, monkeypatch):
    final = tmp_path / "plan"
    final.mkdir()
    (final / "a.csv").write_text("old")

    def full(self, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(type(final), "write_bytes", full)
    with pytest.raises(InputError, match="No space left on device; nothing written"):
        write_bytes_atomic(final / "b.json", b"{}")
    with pytest.raises(InputError, match="No space left on device; nothing written"), \
            staged_directory(final, OWN) as staging:
        (staging.path / "c.json").write_bytes(b"x")
    assert _tree(tmp_path) == ["plan", "plan/a.csv"]


def test_writability_and_space_are_checked_before_and_create_nothing(tmp_path):
    check_writable(tmp_path / "a" / "b" / "c")
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="is not a folder"):
        check_writable(tmp_path / "file" / "below")
    with pytest.raises(InputError, match="exists and is not a folder"):
        check_writable(tmp_path / "file")
    with pytest.raises(InputError, match=r"needs about .* MB free"):
        check_writable(tmp_path / "new", need_bytes=10**18)
    if os.geteuid() != 0:  # root writes anywhere
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o555)
        with pytest.raises(InputError, match="cannot write"):
            check_writable(ro / "x")
    assert sorted(p.name for p in tmp_path.iterdir()) in (["file"], ["file", "ro"])


def test_stale_staging_folders_are_cleared_but_never_a_users_file(tmp_path):
    final = tmp_path / "plan"
    final.mkdir()
    dead = 2**22 + 12345  # above the usual pid_max: no such process
    host = atomic._host()
    mine = tmp_path / f"{STAGING_PREFIX}{dead}-{host}-abc"  # this version's: only jethr1's files, removed whole
    (mine / "plan").mkdir(parents=True)
    (mine / "plan" / "a.csv").write_text("half")
    inside = final / f"{STAGING_PREFIX}{dead}-{host}-def"
    elsewhere = final / f"{STAGING_PREFIX}{dead}-0000beef-xyz"  # another machine's (a shared folder): not touched
    elsewhere.mkdir()
    inside.mkdir()
    (inside / "a.csv").write_text("half")
    old = tmp_path / f".plan.tmp-{dead}-ghi"  # an earlier version moved the user's notes into its staging folder
    old.mkdir()
    (old / "a.csv").write_text("half")
    (old / "notes.txt").write_text("mine")
    alive = tmp_path / f"{STAGING_PREFIX}{os.getppid()}-{host}-jkl"  # a live process's: not touched
    alive.mkdir()
    left = clean_stale([tmp_path, final], OWN, "plan")
    assert left == [old]
    assert not mine.exists() and not inside.exists() and alive.exists() and elsewhere.exists()
    assert sorted(p.name for p in old.iterdir()) == ["notes.txt"]
    with staged_directory(final, OWN) as staging:  # a run reports what it left
        (staging.path / "a.csv").write_text("1")
    assert any(old.name in k for k in staging.kept)


def test_an_interrupt_during_the_commit_waits_until_the_set_is_whole(tmp_path, monkeypatch):
    final = tmp_path / "plan"
    final.mkdir()
    for name in OWN:
        (final / name).write_text("old")
    real = os.replace
    calls = []

    def replace_then_interrupt(src, dst):
        calls.append(dst)
        if len(calls) == 1:
            os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C between two files of the set
        return real(src, dst)

    monkeypatch.setattr(atomic.os, "replace", replace_then_interrupt)
    with pytest.raises(KeyboardInterrupt), staged_directory(final, OWN) as staging:
        for name in OWN:
            (staging.path / name).write_text("new")
    assert len(calls) == 3 and all((final / n).read_text() == "new" for n in OWN)
    assert final in atomic.committed()  # the interrupt message names it as complete
