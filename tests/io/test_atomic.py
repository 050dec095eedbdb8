"""The one staging and commit mechanism of every command: a user's file is never moved, replaced or lost
(only files jethr1's record says it wrote, unchanged, are replaced; never an input, a link, a FIFO, a
device or a folder), an output folder that is a mount point is never renamed, a new folder appears whole
or not at all, files get the usual modes, a full disk is one line, a user's folder named like a staging
folder is never touched, and an interrupt during the commit waits for it."""

from __future__ import annotations

import errno
import os
import signal
import stat

import pytest

from jethr1_plan.errors import InputError
from jethr1_plan.io import atomic
from jethr1_plan.io.atomic import STAGING_PREFIX, clean_stale, staged_directory, write_bytes_atomic, write_text_atomic
from jethr1_plan.io.input_file import read_input
from jethr1_plan.io.record import RECORD, check_writable, read_record

OWN = frozenset({"a.csv", "b.json", "c.json"})


def _tree(folder):
    """Every path under ``folder`` but jethr1's records of its files."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.name != RECORD)


def _write(final, **files):
    """One commit of ``files`` (name → text) into ``final``; the staging's ``kept``."""
    with staged_directory(final, OWN) as staging:
        for name, text in files.items():
            (staging.path / name).write_text(text)
    return staging.kept


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
    _write(final, **{"a.csv": "old", "c.json": "old rehearsal"})  # jethr1's, recorded
    (final / "notes.txt").write_text("mine")
    inode = final.stat().st_ino
    with staged_directory(final, OWN) as staging:
        (staging.path / "a.csv").write_text("new")
        assert staging.path.parent == final  # staged inside the folder itself
    assert final.stat().st_ino == inode  # the folder was not replaced
    assert (final / "notes.txt").read_text() == "mine" and (final / "a.csv").read_text() == "new"
    assert not (final / "c.json").exists()  # jethr1 wrote it, unchanged, not part of the new set: gone
    assert staging.kept == ["notes.txt"]
    assert _tree(tmp_path) == ["plan", "plan/a.csv", "plan/notes.txt"]
    assert set(read_record(final)) == {"a.csv"}


@pytest.mark.parametrize("name", ["a.csv", "c.json"])
def test_a_users_file_of_an_outputs_name_is_never_replaced_nor_removed(tmp_path, name):
    final = tmp_path / "plan"
    final.mkdir()
    (final / name).write_text("mine")  # not in jethr1's record: the user's
    if name == "a.csv":  # an output of this run: the commit is refused, nothing written
        with pytest.raises(InputError, match=r"a file jethr1 did not write .*nothing written"):
            _write(final, **{"a.csv": "new", "b.json": "new"})
        with pytest.raises(InputError, match="did not write"):  # and before any work
            check_writable(final, writes=("a.csv", "b.json"))
        assert _tree(tmp_path) == ["plan", "plan/a.csv"]
    else:  # owned but not written this run: left, and named
        assert _write(final, **{"a.csv": "new"}) == ["c.json"]
    assert (final / name).read_text() == "mine"


def test_a_file_jethr1_wrote_and_the_user_edited_is_kept(tmp_path):
    final = tmp_path / "plan"
    _write(final, **{"a.csv": "jethr1's", "c.json": "jethr1's"})
    (final / "a.csv").write_text("edited by hand")
    (final / "c.json").write_text("edited by hand")
    with pytest.raises(InputError, match=r"a\.csv: changed since jethr1 wrote it"):
        _write(final, **{"a.csv": "new"})
    assert _write(final, **{"b.json": "new"}) == ["a.csv", "c.json"]  # owned, not written, edited: kept
    assert (final / "a.csv").read_text() == "edited by hand" == (final / "c.json").read_text()


def test_an_input_is_never_an_output(tmp_path):
    final = tmp_path / "plan"
    _write(final, **{"a.csv": "jethr1's"})
    read_input(final / "a.csv", 100, "a test")  # this process read it: an input now
    with pytest.raises(InputError, match="this command's own input"):
        check_writable(final, writes=("a.csv",))
    with pytest.raises(InputError, match="this command's own input"):
        _write(final, **{"a.csv": "new"})
    assert (final / "a.csv").read_text() == "jethr1's"


def test_links_fifos_devices_and_folders_are_never_outputs(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("mine")
    final = tmp_path / "plan"
    final.mkdir()
    (final / "a.csv").symlink_to(victim)
    os.mkfifo(final / "b.json")
    (final / "c.json").mkdir()
    for name, kind in (("a.csv", "a symbolic link"), ("b.json", r"a FIFO \(named pipe\)"), ("c.json", "a folder")):
        with pytest.raises(InputError, match=f"{kind} where jethr1 writes its {name}"):
            _write(final, **{name: "new"})
    with pytest.raises(InputError, match="a character device"):
        write_text_atomic(os.devnull, "x")
    assert victim.read_text() == "mine" and (final / "a.csv").is_symlink()
    assert stat.S_ISFIFO(os.lstat(final / "b.json").st_mode) and stat.S_ISCHR(os.stat(os.devnull).st_mode)


def test_a_name_longer_than_the_file_system_allows_is_one_line(tmp_path):
    with pytest.raises(InputError, match="a name of 300 bytes"):
        check_writable(tmp_path / ("x" * 300))
    with pytest.raises(InputError, match="a name of 300 bytes"), staged_directory(tmp_path / "o" / ("y" * 300)):
        pass
    assert list(tmp_path.iterdir()) == []


def test_a_precondition_refuses_the_commit_under_the_lock(tmp_path):
    final = tmp_path / "plan"
    _write(final, **{"a.csv": "plan 1"})

    def replanned():
        raise InputError(str(final), "", "planned again meanwhile")
    with pytest.raises(InputError, match="planned again"), \
            staged_directory(final, OWN, precondition=replanned) as staging:
        (staging.path / "c.json").write_text("a rehearsal of plan 1")
    assert _tree(tmp_path) == ["plan", "plan/a.csv"]


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
    with pytest.raises(InputError, match="exists and is not a folder \\(a file\\)"):
        check_writable(tmp_path / "file")
    with pytest.raises(InputError, match=r"needs about .* MB free"):
        check_writable(tmp_path / "new", need_bytes=10**18)
    if os.geteuid() != 0:  # root writes anywhere
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o555)
        with pytest.raises(InputError, match="cannot write"):
            check_writable(ro / "x")
    assert sorted(p.name for p in tmp_path.iterdir()) in (["file"], ["file", "ro"])


def test_only_staging_folders_jethr1_made_are_cleared_never_a_users_folder(tmp_path):
    final = tmp_path / "plan"
    final.mkdir()
    dead = 2**22 + 12345  # above the usual pid_max: no such process
    host = atomic._host()
    mine = atomic._make_staging(tmp_path)  # a run killed before its commit: made by jethr1, its marker inside
    marker = (mine / atomic.MARKER).read_text()
    proven = tmp_path / f"{STAGING_PREFIX}{dead}-{host}-{mine.name.rsplit('-', 1)[1]}"
    os.rename(mine, proven)
    (proven / atomic.MARKER).write_text(marker.replace(f'"pid": {os.getpid()}', f'"pid": {dead}'))
    (proven / "a.csv").write_text("half")
    users = final / f"{STAGING_PREFIX}{dead}-{host}-def"  # a user's folder of that name, no marker: never touched
    users.mkdir()
    (users / "notes.txt").write_text("mine")
    copied = final / f"{STAGING_PREFIX}{dead}-{host}-{proven.name.rsplit('-', 1)[1]}"  # a copy: another inode
    (copied).mkdir()
    (copied / atomic.MARKER).write_text((proven / atomic.MARKER).read_text())
    elsewhere = final / f"{STAGING_PREFIX}{dead}-0000beef-xyz"  # another machine's (a shared folder)
    elsewhere.mkdir()
    old = tmp_path / f".plan.tmp-{dead}-ghi"  # named like an earlier version's: left as it is
    old.mkdir()
    (old / "a.csv").write_text("mine too")
    alive = tmp_path / f"{STAGING_PREFIX}{os.getppid()}-{host}-jkl"  # a live process's
    alive.mkdir()
    assert clean_stale([tmp_path, final]) == [proven]
    assert not proven.exists()
    assert all(p.exists() for p in (users / "notes.txt", copied, elsewhere, old / "a.csv", alive))


def test_an_interrupt_during_the_commit_waits_until_the_set_is_whole(tmp_path, monkeypatch):
    final = tmp_path / "plan"
    _write(final, **dict.fromkeys(OWN, "old"))
    real = os.replace
    calls = []

    def replace_then_interrupt(src, dst):
        calls.append(dst)
        if len(calls) == 1:
            signal.raise_signal(signal.SIGINT)  # Ctrl-C between two files of the set (to this thread: no race)
        return real(src, dst)

    monkeypatch.setattr(atomic.os, "replace", replace_then_interrupt)
    # Ctrl-C as a command's process has it (whatever an earlier test in this worker left behind)
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        _interrupted_commit(final)
    finally:
        signal.signal(signal.SIGINT, before)
    assert len([c for c in calls if os.path.basename(c) in OWN]) == 3 and all((final / n).read_text() == "new"
                                                                            for n in OWN)
    assert final in atomic.committed()  # the interrupt message names it as complete


def _interrupted_commit(final):
    with pytest.raises(KeyboardInterrupt), staged_directory(final, OWN) as staging:
        for name in OWN:
            (staging.path / name).write_text("new")


def test_a_users_file_of_the_records_name_is_never_replaced(tmp_path):
    final = tmp_path / "plan"
    final.mkdir()
    (final / RECORD).write_text("my own notes, by chance of that name")
    with pytest.raises(InputError, match="not that record"):
        check_writable(final, writes=("a.csv",))
    with pytest.raises(InputError, match="not that record"):
        _write(final, **{"a.csv": "new"})
    assert (final / RECORD).read_text() == "my own notes, by chance of that name"
    assert _tree(tmp_path) == ["plan"]
