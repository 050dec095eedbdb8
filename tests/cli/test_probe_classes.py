"""Issue 37's classes, one representative case each, as a user meets them (docs/safety.md, "The third probe"):
data loss (a user's file of an output's name, the input among the outputs, a user's folder named like a staging
folder), hangs (a FIFO as an input), resources (a sparse giant, an MCAP bomb, a grid of hours), tracebacks (huge
integers and keys of mixed types in YAML, a folder where an output file goes), silent accepts (a rate that leaves
one row a phase, another plan's MCAP), and the leftovers (workers after ``kill -9``, a stale rehearsal) and
messages (a FIFO, a loop of links and an empty robot said as such). Each is exit 2, one line, nothing written
(or the right result), in seconds."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import struct
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
import yaml

from jethr1_plan.cli import run
from jethr1_plan.io.record import RECORD
from tests.conftest import ROOT

SIDE = str(ROOT / "configs" / "side_step.yaml")


def _tree(folder):
    """Every path under ``folder`` with its bytes' digest (links as their targets, others by kind)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_symlink():
            out[str(p)] = "-> " + os.readlink(p)
        elif p.is_file():
            out[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest() if p.stat().st_size < 10**8 else p.stat().st_size
        else:
            out[str(p)] = "dir" if p.is_dir() else "special"
    return out


def _refused(capfd, argv, folder, *words):
    """``jethr1 argv`` is exit 2, one line holding ``words``, and nothing under ``folder`` changed."""
    before = _tree(folder)
    assert run([str(a) for a in argv]) == 2
    err = capfd.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err[-2000:]
    for w in words:
        assert w in lines[0], lines[0]
    assert _tree(folder) == before
    return lines[0]


# data loss


def test_a_users_file_of_an_outputs_name_is_never_replaced(tmp_path, capfd):
    mine = tmp_path / "o" / "side_step" / "summary.json"
    mine.parent.mkdir(parents=True)
    mine.write_text("my notes\n")
    t0 = time.perf_counter()
    _refused(capfd, ["plan", SIDE, "-o", tmp_path / "o", "--no-progress"], tmp_path, "a file jethr1 did not write")
    assert time.perf_counter() - t0 < 30  # refused before the plan, not after it
    (tmp_path / "victim.txt").write_text("mine\n")
    (tmp_path / "t.yaml").symlink_to(tmp_path / "victim.txt")
    _refused(capfd, ["terrain", "random", "--seed", "1", "-o", tmp_path / "t.yaml"], tmp_path, "a symbolic link")


def test_the_input_is_never_among_the_outputs(tmp_path, capfd):
    scenario = tmp_path / "o" / "summary" / "summary.json"  # planned into o/summary/: its own summary.json
    scenario.parent.mkdir(parents=True)
    shutil.copyfile(SIDE, scenario)
    _refused(capfd, ["plan", scenario, "-o", tmp_path / "o", "--no-progress"], tmp_path, "this command's own input")


def test_a_users_folder_named_like_a_staging_folder_is_never_touched(tmp_path, capfd):
    from jethr1_plan.io import atomic

    out = tmp_path / "o"
    mine = out / f"{atomic.STAGING_PREFIX}99999999-{atomic._host()}-abc"  # a process that has ended, this machine
    mine.mkdir(parents=True)
    (mine / "notes.txt").write_text("mine\n")
    assert run(["terrain", "random", "--seed", "1", "-o", str(out / "t.yaml")]) == 0
    assert (mine / "notes.txt").read_text() == "mine\n"


# hangs


def test_a_fifo_as_an_input_is_one_line_not_a_hang(tmp_path):
    fifo = tmp_path / "in.yaml"
    os.mkfifo(fifo)
    for argv in (["plan", fifo, "-o", tmp_path / "o"], ["batch", "--manifest", fifo, "-o", tmp_path / "o"],
                 ["route", fifo, "-o", tmp_path / "o"], ["verify", fifo]):
        p = subprocess.run([sys.executable, "-c", "from jethr1_plan.cli import entry; entry()", *map(str, argv)],
                           capture_output=True, text=True, timeout=60)
        assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
        assert "a FIFO (named pipe)" in p.stderr and "no such file" not in p.stderr
    assert sorted(q.name for q in tmp_path.iterdir()) == ["in.yaml"]


# resources


def _copy_plan(side_step_plan, tmp_path):
    d = tmp_path / "side_step"
    shutil.copytree(side_step_plan, d)
    return d


def test_a_sparse_giant_csv_is_refused_by_its_size(side_step_plan, tmp_path, capfd):
    d = _copy_plan(side_step_plan, tmp_path)
    with open(d / "trajectory.csv", "r+b") as f:
        f.truncate(2_500_000_000)  # sparse: 2.5 GB of nothing
    t0 = time.perf_counter()
    _refused(capfd, ["verify", d], tmp_path, "trajectory.csv", "larger than")
    assert time.perf_counter() - t0 < 10


def test_an_mcap_bomb_is_refused_before_it_is_decompressed(side_step_plan, tmp_path, capfd):
    import zstandard

    from jethr1_plan.files.mcap import MCAP_MAGIC, McapTooLarge, mcap_expanded_bytes

    def record(op, body):
        return bytes([op]) + struct.pack("<Q", len(body)) + body

    def text(s):
        return struct.pack("<I", len(s)) + s.encode()
    zeros = zstandard.ZstdCompressor().compress(b"\0" * 50_000_000)  # says it holds 50 MB (its frame header)
    chunk = struct.pack("<QQQI", 0, 0, 1000, 0) + text("zstd") + struct.pack("<Q", len(zeros)) + zeros
    bomb = MCAP_MAGIC + record(1, text("ros2") + text("x")) + record(6, chunk) + MCAP_MAGIC
    with pytest.raises(McapTooLarge, match="expands to 50,000,000 bytes, though it says 1,000"):
        mcap_expanded_bytes(bomb)
    d = _copy_plan(side_step_plan, tmp_path)
    (d / "trajectory.mcap").write_bytes(bomb)
    _refused(capfd, ["verify", d / "trajectory.mcap"], tmp_path, "trajectory.mcap")  # beside its summary: not it
    (d / "summary.json").unlink()
    _refused(capfd, ["verify", d / "trajectory.mcap"], tmp_path, "expands to 50,000,000 bytes")  # alone: its chunks


def test_requests_of_hours_are_refused_before_they_start(tmp_path, capfd):
    _refused(capfd, ["balance-space", "--resolution", "0.003", "-o", tmp_path / "b"], tmp_path, "--resolution")
    _refused(capfd, ["ditch-curve", "--scales", ",".join(f"{k / 100:g}" for k in range(500)), "-o", tmp_path / "d"],
             tmp_path, "--scales", "at most 21")
    _refused(capfd, ["compare", SIDE, "--yaw-modes", ",".join(["eq4", "mpc"] * 500), "-o", tmp_path / "c"], tmp_path,
             "--yaw-modes", "distinct")
    doc = yaml.safe_load(Path(SIDE).read_text())
    doc["optimiser"] = {"method": "gas", "initial": {"population": 10000, "generations": 10000}}
    (tmp_path / "ga.yaml").write_text(yaml.safe_dump(doc))
    _refused(capfd, ["plan", tmp_path / "ga.yaml", "-o", tmp_path / "o"], tmp_path, "optimiser", "would take at least")


# tracebacks


@pytest.mark.parametrize("text, words", [
    ("seed: 1" + "0" * 5000 + "\n", "an integer of 5,001 digits"),
    ("1: x\nzz: y\n", "the key 1 is not text"),
    ("extra: {1: 2, zz: 3}\n", "the key 1 is not text"),
])
def test_every_yaml_reader_refuses_huge_integers_and_keys_that_are_not_text(tmp_path, capfd, text, words):
    side = Path(SIDE).read_text().replace("seed: 1\n", "")
    robot = (ROOT / "robots" / "jethr1" / "jethr1.yaml").read_text()
    shutil.copyfile(ROOT / "robots" / "jethr1" / "jethr1.urdf", tmp_path / "jethr1.urdf")
    files = {"s.yaml": side + text, "r.yaml": robot + text, "m.yaml": "scenarios: [s.yaml]\n" + text}
    for name, content in files.items():
        (tmp_path / name).write_text(content)
    _refused(capfd, ["plan", tmp_path / "s.yaml", "-o", tmp_path / "o"], tmp_path, words)
    _refused(capfd, ["robot", "show", tmp_path / "r.yaml"], tmp_path, words)
    _refused(capfd, ["batch", "--manifest", tmp_path / "m.yaml", "-o", tmp_path / "o"], tmp_path, words)


def test_a_folder_where_an_output_file_goes_is_one_line_and_no_half_set(side_step_plan, tmp_path, capfd):
    d = _copy_plan(side_step_plan, tmp_path)
    (d / "simulation.json").mkdir()
    (d / "simulation.json" / "mine.txt").write_text("mine\n")
    _refused(capfd, ["simulate", d, "--no-progress"], tmp_path, "a folder where jethr1 writes its simulation.json")


# silent accepts


def test_a_rate_that_leaves_a_phase_a_row_or_two_is_refused_by_every_command(tmp_path, capfd):
    doc = yaml.safe_load(Path(SIDE).read_text())
    doc["timing"]["rate_hz"] = 0.01
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    for argv in (["plan", tmp_path / "s.yaml"], ["compare", tmp_path / "s.yaml"],
                 ["ditch-curve", "--scenario", tmp_path / "s.yaml"], ["batch", tmp_path / "s.yaml"]):
        _refused(capfd, [*argv, "-o", tmp_path / "o"], tmp_path, "timing.rate_hz", "below the smallest allowed, 10")


def test_a_plan_folder_is_one_thing(side_step_plan, tmp_path, capfd):
    d = _copy_plan(side_step_plan, tmp_path)
    summary = json.loads((d / "summary.json").read_text())
    for name in ("trajectory.csv", "trajectory.mcap"):
        assert summary["files"][name]["sha256"] == hashlib.sha256((d / name).read_bytes()).hexdigest()
    data = (d / "trajectory.mcap").read_bytes()
    (d / "trajectory.mcap").write_bytes(data[: len(data) // 2])  # cut: simulate reads the MCAP it does not parse
    _refused(capfd, ["simulate", d, "--no-progress"], tmp_path, "trajectory.mcap", "not the trajectory.mcap that "
             "summary.json records")
    (d / "trajectory.mcap").write_bytes(data)
    text = (d / "summary.json").read_text()
    (d / "summary.json").write_text(text.replace('"scenario_file": ', '"scenario_file": "/elsewhere.yaml", "x": '))
    _refused(capfd, ["verify", d], tmp_path, "summary.json", "changed since jethr1 wrote it")


# leftovers and messages


def test_pool_workers_die_with_their_command_under_kill_9(tmp_path):
    script = textwrap.dedent("""
        import sys, time
        from joblib import delayed
        from jethr1_plan.io.pool import parallel
        def task(k):
            import os
            print(os.getpid(), flush=True)
            time.sleep(60)
        parallel(2)(delayed(task)(k) for k in range(2))
    """)
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, cwd=tmp_path)
    workers = [int(p.stdout.readline()) for _ in range(2)]
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    deadline = time.monotonic() + 10
    alive = workers
    while alive and time.monotonic() < deadline:
        time.sleep(0.1)
        alive = [w for w in workers if _running(w)]
    assert not alive


def _running(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_inputs_that_are_not_files_are_said_as_such(tmp_path, capfd):
    (tmp_path / "loop.yaml").symlink_to(tmp_path / "loop.yaml")
    line = _refused(capfd, ["plan", tmp_path / "loop.yaml", "-o", tmp_path / "o"], tmp_path, "a loop of symbolic links")
    assert "no such file" not in line
    doc = yaml.safe_load(Path(SIDE).read_text())
    doc["robot"] = ""
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    _refused(capfd, ["plan", tmp_path / "s.yaml", "-o", tmp_path / "o"], tmp_path, "robot", "empty")
    _refused(capfd, ["plan", "/dev/zero", "-o", tmp_path / "o"], tmp_path, "a character device")


def test_a_record_is_written_beside_every_output(side_step_plan):
    record = json.loads((side_step_plan / RECORD).read_text())
    assert record["written_by"] == "jethr1"
    assert set(record["files"]) == {"trajectory.csv", "trajectory.mcap", "summary.json", "optimised_steps.json"}
