"""Processes and files: SIGTERM ends the workers as Ctrl-C does, a killed run's staging folder is
removed by the next run, files a user put in an output folder survive a new plan, and an unwritable
output is found before any planning."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from jethr1_plan.cli import run
from tests.conftest import ROOT


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


def _children(pid: int) -> list[int]:
    out = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    if int(f.read().rsplit(")", 1)[1].split()[1]) == pid:
                        out.append(int(entry))
            except (OSError, ValueError, IndexError):
                pass
    return out


def test_sigterm_ends_the_workers(tmp_path):
    proc = subprocess.Popen([sys.executable, "-c", "from jethr1_plan.cli import entry; entry()", "plan",
                             str(ROOT / "configs" / "jet_hr1_trial.yaml"), "-o", str(tmp_path / "o"), "-j", "2",
                             "--no-progress"], stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.time() + 30
    while time.time() < deadline and len(_children(proc.pid)) < 2:  # the workers are up
        time.sleep(0.1)
    assert len(_children(proc.pid)) >= 2
    proc.send_signal(signal.SIGTERM)
    err = proc.communicate(timeout=30)[1]
    assert proc.returncode == 143 and "Traceback" not in err and "leaked" not in err
    assert err.strip().splitlines()[-1] == "jethr1: terminated (SIGTERM); workers stopped, nothing written"
    deadline = time.time() + 10
    while time.time() < deadline and _group_alive(proc.pid):
        time.sleep(0.1)
    assert not _group_alive(proc.pid)  # no orphaned worker
    assert not (tmp_path / "o").exists()  # not even an empty output folder


def test_a_killed_runs_staging_folder_is_removed_and_foreign_files_are_kept(tmp_path, capsys):
    from jethr1_plan.files.plan_folder import SIMULATION_FILES
    from jethr1_plan.io import atomic, record

    out = tmp_path / "out"
    scenario = ROOT / "configs" / "side_step.yaml"
    assert run(["plan", str(scenario), "-o", str(out), "--no-progress"]) == 0
    folder = out / "side_step"
    (folder / "notes.txt").write_text("tested on the robot, 2026-11-20")
    with atomic.staged_directory(folder, SIMULATION_FILES) as staging:  # the old plan's rehearsal: jethr1's, stale
        (staging.path / "simulation.json").write_text("{}")
    dead = 2**22 + 999  # no such process
    stale = atomic._make_staging(out)  # a run that was killed before its commit
    marker = (stale / atomic.MARKER).read_text().replace(f'"pid": {os.getpid()}', f'"pid": {dead}')
    stale = stale.rename(out / stale.name.replace(f"-{os.getpid()}-", f"-{dead}-"))
    (stale / atomic.MARKER).write_text(marker)
    (stale / "trajectory.csv").write_text("half")
    users = out / ".side_step.tmp-999999-abcd"  # named like an earlier version's staging folder: the user's now
    users.mkdir()
    (users / "trajectory.csv").write_text("mine")
    capsys.readouterr()
    assert run(["plan", str(scenario), "-o", str(out), "--no-progress"]) == 0
    assert not stale.exists() and (users / "trajectory.csv").read_text() == "mine"
    assert (folder / "notes.txt").read_text() == "tested on the robot, 2026-11-20"
    assert not (folder / "simulation.json").exists()
    assert "kept notes.txt" in capsys.readouterr().err
    assert sorted(p.name for p in folder.iterdir()) == [record.RECORD, "notes.txt", "optimised_steps.json",
                                                       "summary.json", "trajectory.csv", "trajectory.mcap"]


@pytest.mark.parametrize("target", ["file", "under a file"])
def test_an_unwritable_output_is_found_before_planning(tmp_path, capsys, target):
    blocker = tmp_path / "blocker"
    blocker.write_text("")
    out = blocker if target == "file" else blocker / "out"
    t0 = time.perf_counter()
    assert run(["plan", str(ROOT / "configs" / "jet_hr1_trial.yaml"), "-o", str(out), "--no-progress"]) == 2
    assert time.perf_counter() - t0 < 2  # before a single sample is planned
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "blocker" in err[0]


def _live(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie waiting for its parent to read its exit does not)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
    except OSError:
        return False


def _start_sweep(tmp_path) -> tuple[subprocess.Popen, list[int]]:
    """A 1 cm balance-space sweep started as a user starts it: the command and its two workers."""
    proc = subprocess.Popen([sys.executable, "-c", "from jethr1_plan.cli import entry; entry()", "balance-space",
                             "-j", "2", "--executor", "fork", "-o", str(tmp_path / "bs"), "--no-progress"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.time() + 60
    while time.time() < deadline:
        workers = _children(proc.pid)
        if len(workers) == 2:
            return proc, workers
        time.sleep(0.05)
    proc.kill()
    raise AssertionError("the sweep's workers did not start")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forked sweep: Linux")
def test_a_command_killed_from_outside_leaves_no_sweep_running(tmp_path):
    """The out-of-memory killer (or kill -9) ends the command: its workers end with it, at once."""
    proc, workers = _start_sweep(tmp_path)
    proc.kill()
    proc.wait(timeout=10)
    deadline = time.time() + 5
    while time.time() < deadline and any(map(_live, workers)):
        time.sleep(0.05)
    assert not any(map(_live, workers))
    assert not (tmp_path / "bs").exists()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forked sweep: Linux")
def test_a_worker_killed_from_outside_is_one_line_and_exit_7(tmp_path):
    proc, workers = _start_sweep(tmp_path)
    os.kill(workers[0], signal.SIGKILL)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == 7, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert "killed by SIGKILL" in err and "fewer --jobs" in err
    assert not (tmp_path / "bs").exists()
    deadline = time.time() + 5
    while time.time() < deadline and any(map(_live, workers)):
        time.sleep(0.05)
    assert not any(map(_live, workers))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forked sweep: Linux")
def test_sigterm_ends_a_sweep_and_its_workers(tmp_path):
    proc, workers = _start_sweep(tmp_path)
    proc.send_signal(signal.SIGTERM)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == 143 and "Traceback" not in err
    assert err.strip().splitlines()[-1] == "jethr1: terminated (SIGTERM); workers stopped, nothing written"
    assert not any(map(_live, workers))  # killed, not left to finish their tasks
    assert not (tmp_path / "bs").exists()


def _cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


def test_a_batch_worker_killed_from_outside_is_one_line_and_exit_7(tmp_path):
    """A loky worker of `jethr1 batch` killed (the out-of-memory killer): exit 7, one line naming the scenarios
    already written; each written folder is whole."""
    configs = sorted((ROOT / "configs").glob("*.yaml"))
    proc = subprocess.Popen([sys.executable, "-c", "from jethr1_plan.cli import entry; entry()", "batch",
                             *map(str, configs), "-j", "2", "-o", str(tmp_path / "b"), "--no-progress"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.time() + 60
    workers: list[int] = []
    while time.time() < deadline and not workers:
        workers = [c for c in _children(proc.pid) if b"popen_loky" in _cmdline(c)]
        time.sleep(0.05)
    assert workers
    time.sleep(1.0)
    os.kill(workers[0], signal.SIGKILL)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == 7, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert "a worker process was killed" in err and "fewer --jobs" in err
    for folder in (tmp_path / "b").iterdir() if (tmp_path / "b").exists() else ():
        assert not folder.name.startswith("."), folder  # no staging folder left
        assert str(folder) in err and {"summary.json", "trajectory.csv"} <= {f.name for f in folder.iterdir()}
