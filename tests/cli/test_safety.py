"""Issue 25's cases, as a user meets them: files in a mount point survive every run, a read-only or
full place is one line before or instead of a traceback, a closed or full stdout is one line,
workers are capped at the machine's cores, grids bounded by the memory they need, a long command
speaks within seconds without a terminal, and the smaller words say what happened."""

from __future__ import annotations

import json
import os
import re
import shlex
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from jethr1_plan.cli import common, run
from jethr1_plan.io.record import RECORD
from tests.conftest import ROOT

JETHR1 = [sys.executable, "-c", "from jethr1_plan.cli import entry; entry()"]
TINY_BALANCE = ["balance-space", "--x-range", "0.1", "0.2", "--y-range", "0.2", "0.3", "--z-range", "0", "0.01",
                "--resolution", "0.1", "-j", "1", "--no-progress"]


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err[-2000:]
    return lines[0]


def _unshare_ok() -> bool:
    try:
        return subprocess.run(["unshare", "-rm", "sh", "-c", "mount -t tmpfs tmpfs /mnt"], capture_output=True,
                              timeout=10).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


needs_mounts = pytest.mark.skipif(not _unshare_ok(), reason="no private mount namespace (unshare -rm) here")


def _in_mount(tmp_path, args: list[str], size: str = "20m", readonly: bool = False, times: int = 2):
    """Run jethr1 ``times`` times with ``{mnt}`` a fresh tmpfs mount point that holds notes.txt;
    (exit codes, stderr, names left in the mount point, notes.txt still there)."""
    mnt = tmp_path / "usb"
    mnt.mkdir()
    cmd = " ".join(shlex.quote(a.replace("{mnt}", str(mnt))) for a in [*JETHR1, *args])
    parts = [f"mount -t tmpfs -o size={size} tmpfs {mnt} || exit 99", f"echo mine > {mnt}/notes.txt"]
    parts += [f"mount -o remount,ro {mnt}"] if readonly else []
    parts += [f'{cmd}; echo "__exit=$?" >&2'] * times
    parts += [f"cat {mnt}/notes.txt >&2", f'echo "__left=$(ls -A {mnt} | tr "\\n" " ")" >&2']
    proc = subprocess.run(["unshare", "-rm", "sh", "-c", "; ".join(parts)], capture_output=True, text=True,
                          timeout=300)
    err = proc.stderr
    codes = [int(line.split("=")[1]) for line in err.splitlines() if line.startswith("__exit=")]
    left = next(line.split("=", 1)[1].split() for line in err.splitlines() if line.startswith("__left="))
    text = "\n".join(ln for ln in err.splitlines() if not ln.startswith(("__", "mine")))
    return codes, text, sorted(left), "mine" in err.splitlines()


def _small_scenario(tmp_path):
    doc = yaml.safe_load((ROOT / "configs" / "side_step.yaml").read_text())
    doc["steps"][0]["path"]["samples"] = 6
    path = tmp_path / "side_step.yaml"
    path.write_text(yaml.safe_dump(doc))
    return str(path)


#: the four commands that wrote straight into -o, and what they leave there
INTO_MOUNT = {
    "balance-space": (lambda tmp: TINY_BALANCE, ["balance_space.csv", "balance_space.mcap", "balance_space.png",
                                                 "summary.json"]),
    "ditch-curve": (lambda tmp: ["ditch-curve", "--gaps", "0.3:0.3:0.01", "--scales", "0", "-j", "1",
                                 "--no-progress"], ["ditch_curve.json", "ditch_curve.png"]),
    "compare": (lambda tmp: ["compare", _small_scenario(tmp), "--methods", "sqp", "--no-progress"],
                ["compare.json", "compare_time.png", "compare_trajectories.png"]),
    "walk-sweep": (lambda tmp: ["walk-sweep", str(ROOT / "configs" / "walks" / "jethr1_walk.yaml"), "--steps-m",
                                "0.1:0.1:0.01", "--rotation", "none", "--no-rehearse", "-j", "1", "--no-progress"],
                   ["walk_sweep.csv", "walk_sweep.json", "walk_sweep.png"]),
}


@needs_mounts
@pytest.mark.parametrize("command", list(INTO_MOUNT))
def test_a_users_file_in_a_mount_point_survives_two_runs(tmp_path, command):
    """These four once moved the files of -o into a staging folder beside it, failed to rename the
    mount point (EBUSY), and the next run deleted that folder with the user's file in it."""
    args, written = INTO_MOUNT[command]
    codes, err, left, kept = _in_mount(tmp_path, [*args(tmp_path), "-o", "{mnt}"])
    assert codes == [0, 0] and kept and "Traceback" not in err, err
    assert left == sorted([*written, "notes.txt", RECORD])


@needs_mounts
@pytest.mark.parametrize("command", list(INTO_MOUNT))
def test_a_read_only_mount_point_is_found_before_the_work(tmp_path, command):
    args, _ = INTO_MOUNT[command]
    codes, err, left, kept = _in_mount(tmp_path, [*args(tmp_path), "-o", "{mnt}"], readonly=True, times=1)
    assert codes == [2] and kept and left == ["notes.txt"]
    assert _one_line(err).endswith("cannot write here: Read-only file system")


@needs_mounts
def test_a_full_disk_is_one_line_and_leaves_nothing(tmp_path):
    codes, err, left, kept = _in_mount(tmp_path, [*TINY_BALANCE, "-o", "{mnt}"], size="48k", times=1)
    assert codes == [2] and kept and left == ["notes.txt"]
    assert _one_line(err).endswith(": cannot write: No space left on device; nothing written")


def test_a_full_stdout_is_one_line(tmp_path):
    with open("/dev/full", "w") as full:
        proc = subprocess.run([*JETHR1, "robot", "show", "--json"], stdout=full, stderr=subprocess.PIPE, text=True,
                              timeout=60)
    assert proc.returncode == 2
    assert _one_line(proc.stderr) == "jethr1: cannot write to stdout: No space left on device"


def test_a_closed_stdout_is_one_line():
    r, w = os.pipe()
    os.close(r)
    proc = subprocess.run([*JETHR1, "robot", "show", "--json"], stdout=w, stderr=subprocess.PIPE, text=True,
                          timeout=120)
    os.close(w)
    assert proc.returncode == 2 and _one_line(proc.stderr) == "jethr1: cannot write to stdout: Broken pipe"


def test_workers_are_capped_at_the_cores_and_said_once(monkeypatch, capsys):
    monkeypatch.setattr(common.os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    monkeypatch.setattr(common, "_CAPPED", [])
    assert common.cap_jobs(1) == 1 and common.cap_jobs(2) == 2
    assert common.cap_jobs(1000) == 2 and common.cap_jobs(500, "--jobs") == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "jethr1: -j 1000: this machine gives 2 cores; using 2 worker processes"]


def test_j_1000_runs_on_the_cores(tmp_path, capsys):
    out = tmp_path / "bs"
    assert run([*[a for a in TINY_BALANCE if a not in ("-j", "1")], "-j", "1000", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert f"-j 1000: this machine gives {common.cores()} cores" in err


@pytest.mark.parametrize("args, option", [
    (["--z-range", "0", "100"], "--z-range: 0 100: 171 x 171 x 10001 = 292,439,241 cells at 0.01 m need about "),
    (["--resolution", "0.005", "--x-range", "-5", "5", "--y-range", "-5", "5"],
     "--x-range: -5 5: 2001 x 2001 x 61 = 244,244,061 cells at 0.005 m need about "),
])
def test_a_grid_larger_than_memory_is_refused_at_once(tmp_path, capsys, args, option):
    t0 = time.perf_counter()
    assert run(["balance-space", *args, "-o", str(tmp_path / "bs")]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"jethr1: {option}") and "of memory is available" in line
    assert time.perf_counter() - t0 < 5 and not (tmp_path / "bs").exists()


def test_progress_speaks_without_a_terminal(monkeypatch, capsys):
    monkeypatch.setattr(common.Progress, "interval_s", 0.0)
    with common.Progress(True, "sweep") as progress:
        progress("layer 1", 1, 3)
        progress("layer 2", 2, 3)
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines[0] == "sweep: started"
    assert lines[1].startswith("sweep: 1/3 done after 0 s (layer 1)") and len(lines) == 3
    with common.Progress(False, "quiet") as progress:  # --no-progress: nothing
        progress("x", 1, 1)
    assert capsys.readouterr().err == ""


def _cpu_s(pid: int) -> float:
    """The CPU time [s] process ``pid`` has used so far (Linux's /proc/PID/stat: user + system)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux's /proc")
def test_a_long_command_speaks_within_seconds(tmp_path):
    """balance-space at its default 1 cm runs for a minute: its first line comes before the sweep, even into a
    pipe. Judged by the command's own CPU time when the line arrives, which a busy machine does not stretch as it
    stretches the wall time, against a command that only loads the robot and prints it (``robot show``) on the
    same machine: the sweep's set-up before its first line (forking its workers) may take up to four times that,
    the sweep itself about fifty times."""
    shown = subprocess.Popen([*JETHR1, "robot", "show"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(shown.pid, 0)
    shown.returncode = os.waitstatus_to_exitcode(status)
    assert shown.returncode == 0
    robot_show_cpu = usage.ru_utime + usage.ru_stime
    proc = subprocess.Popen([*JETHR1, "balance-space", "-j", "1", "-o", str(tmp_path / "bs")], stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    try:
        first = proc.stderr.readline()
        cpu = _cpu_s(proc.pid)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    assert first.startswith("balance space (906,471 cells): started"), first
    assert cpu < 4 * robot_show_cpu, (cpu, robot_show_cpu)


def test_scheduler_without_dask_and_a_dead_scheduler(tmp_path, capsys):
    assert run(["batch", str(ROOT / "configs" / "side_step.yaml"), "--scheduler", "tcp://127.0.0.1:9", "-o",
                str(tmp_path / "b")]) == 2
    assert _one_line(capsys.readouterr().err) == ("jethr1: --scheduler: tcp://127.0.0.1:9: a Dask scheduler needs "
                                                  "--executor dask")
    pytest.importorskip("distributed")
    t0 = time.perf_counter()
    assert run([*TINY_BALANCE, "--executor", "dask", "--scheduler", "tcp://127.0.0.1:9", "-o",
                str(tmp_path / "bs")]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("jethr1: --scheduler: tcp://127.0.0.1:9: no Dask scheduler answered within 5 s")
    assert time.perf_counter() - t0 < 15 and not (tmp_path / "bs").exists()


def test_compare_refuses_no_methods_and_exits_3_when_infeasible(tmp_path, capsys):
    assert run(["compare", str(ROOT / "configs" / "side_step.yaml"), "--methods", "", "-o", str(tmp_path / "c")]) == 2
    assert "--methods: '': expected distinct optimisers among" in _one_line(capsys.readouterr().err)
    doc = yaml.safe_load((ROOT / "configs" / "side_step.yaml").read_text())
    doc["steps"][0]["path"]["samples"] = 6
    doc["balance"]["thrust_max_n"] = 0.0
    path = tmp_path / "nothrust.yaml"
    path.write_text(yaml.safe_dump(doc))
    assert run(["compare", str(path), "--methods", "sqp", "-o", str(tmp_path / "c"), "--no-progress"]) == 3
    assert "no feasible plan from sqp (compare.json written" in capsys.readouterr().err
    assert json.loads((tmp_path / "c" / "compare.json").read_text())["methods"]["sqp"]["feasible"] is False


@pytest.mark.parametrize("command", ["plan", "compare", "simulate"])
def test_a_seed_beyond_the_yamls_bound_is_refused(tmp_path, capsys, command):
    target = str(tmp_path) if command == "simulate" else str(ROOT / "configs" / "side_step.yaml")
    assert run([command, target, "--seed", str(10**23)]) == 2
    assert "--seed': 100000000000000000000000 is not in the range 0<=x<=9223372036854775807" in _one_line(
        capsys.readouterr().err)


def test_simulation_files_are_written_together_with_the_usual_modes(side_step_plan, tmp_path, capsys):
    import shutil

    from jethr1_plan.files.plan_folder import SIMULATION_FILES
    from jethr1_plan.io.atomic import staged_directory

    d = tmp_path / "side_step"
    shutil.copytree(side_step_plan, d)
    with staged_directory(d, SIMULATION_FILES) as staging:  # an old rehearsal, jethr1's: replaced
        (staging.path / "simulation.mcap").write_text("an old rehearsal's")
    old = os.umask(0o022)
    try:
        assert run(["simulate", str(d), "--no-progress"]) == 0
    finally:
        os.umask(old)
    assert {p.name: stat.S_IMODE(p.stat().st_mode) for p in d.iterdir()} == {
        "trajectory.csv": 0o644, "trajectory.mcap": 0o644, "summary.json": 0o644, "simulation.json": 0o644,
        "simulation.mcap": 0o644, "optimised_steps.json": 0o644, RECORD: 0o644}
    assert (d / "simulation.mcap").read_bytes()[:5] == b"\x89MCAP"


def test_reasons_with_commas_are_quoted_and_verify_reads_them(tmp_path, capsys):
    """The robust policy's reasons hold commas ("within ±10 % thrust, ±5 % mass, ..."): once written
    unquoted, verify took them for a cut line (exit 2) instead of failing the rows (exit 5)."""
    doc = yaml.safe_load((ROOT / "configs" / "forward_ditch_450.yaml").read_text())
    doc["steps"][0]["path"]["samples"] = 12
    path = tmp_path / "forward_ditch_450.yaml"
    path.write_text(yaml.safe_dump(doc))
    assert run(["plan", str(path), "--policy", "robust", "--write-infeasible", "-o", str(tmp_path),
                "--no-progress"]) == 3
    import csv

    with open(tmp_path / "forward_ditch_450" / "trajectory.csv", newline="") as f:
        table = list(csv.reader(f))
    reasons = [row[table[0].index("reason")] for row in table[1:]]
    assert any("," in r for r in reasons) and all(len(row) == len(table[0]) for row in table)
    capsys.readouterr()
    assert run(["verify", str(tmp_path / "forward_ditch_450")]) == 5
    err = capsys.readouterr().err
    # the whole reason, commas and all, up to the next check (the rows between 12 samples hold a share of the
    # tolerance, so its figures are the share's)
    assert re.search(r"marked infeasible: trajectory\.csv: the planner says: no thrust can balance within ±[0-9.]+ % "
                     r"thrust, ±[0-9.]+ % mass and [0-9.]+ mm of CoM error; ", err)


def test_an_interrupted_batch_names_what_it_completed(tmp_path):
    out = tmp_path / "b"
    proc = subprocess.Popen([*JETHR1, "batch", str(ROOT / "configs" / "side_step.yaml"),
                             str(ROOT / "configs" / "forward_ditch_robust.yaml"), "-j", "1", "-o", str(out),
                             "--no-progress"], stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.time() + 120
    while time.time() < deadline and not (out / "side_step" / "summary.json").exists() and proc.poll() is None:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == 130, err
    assert _one_line(err) == (f"jethr1: interrupted; workers stopped, complete before the interrupt: "
                              f"{out / 'side_step'}; nothing half-written")
    assert sorted(p.name for p in out.iterdir()) == ["side_step"]


def _kernel_interrupted(*args, **kwargs):
    """What a Ctrl-C landing inside a compiled kernel raises: a SystemError whose cause is the interrupt."""
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt as stop:
        raise SystemError("CPUDispatcher(<function sample_terms>) returned a result with an exception set") from stop


def test_ctrl_c_inside_a_compiled_kernel_is_an_interrupt_not_a_bug(tmp_path, monkeypatch, capsys):
    """The batch above once reported 'a bug: SystemError' when its interrupt landed in a kernel."""
    from jethr1_plan.io import atomic
    from jethr1_plan.pipeline import plan as pipeline
    from jethr1_plan.studies import batch

    monkeypatch.setattr(atomic, "_COMMITTED", [])  # (other tests in this process committed outputs)
    monkeypatch.setattr(pipeline, "plan_to_folder", _kernel_interrupted)
    with pytest.raises(KeyboardInterrupt):  # the batch stops instead of recording a bug and going on
        batch.run_scenario(str(ROOT / "configs" / "side_step.yaml"), str(tmp_path))
    assert run(["plan", str(ROOT / "configs" / "side_step.yaml"), "-o", str(tmp_path), "--no-progress"]) == 130
    assert _one_line(capsys.readouterr().err) == "jethr1: interrupted; workers stopped, nothing written"
    assert list(tmp_path.iterdir()) == []

    def a_bug(*args, **kwargs):
        raise SystemError("a genuine bug")

    monkeypatch.setattr(pipeline, "plan_to_folder", a_bug)
    with pytest.raises(SystemError):  # anything else stays a bug (a traceback, exit 1)
        run(["plan", str(ROOT / "configs" / "side_step.yaml"), "-o", str(tmp_path), "--no-progress"])
