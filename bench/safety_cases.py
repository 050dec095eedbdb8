"""Issues 25 and 37's cases, run as a new user would: every command with files it must not lose, resources it
must not run away with, robot folders and plan folders tampered with. Each case runs ``jethr1`` in
its own process group and reports its exit code, the lines it printed on stderr, whether a traceback
appeared, its wall time, the peak memory of its process tree and what it left on disk.

Issue 37's 240 cases (``37.<class>.…``, one of the classes of docs/safety.md, "The third probe") are also
judged: the exit the case allows; exit 2 one line and nothing in the case's folder changed (hashed before and
after); any other exit changing only the outputs the case names, never a file of the user's; no traceback; no
process of the command alive 2 s after it ended; under 5 s where there is no real work; under 500 MB.

    .venv/bin/python bench/safety_cases.py [--jethr1 PATH] [--only ID,ID] [--json OUT.json]
    .venv/bin/python bench/safety_cases.py --table BEFORE.json AFTER.json    # the table of docs/safety.md
    .venv/bin/python bench/safety_cases.py --summary RESULTS.json             # issue 37's counts per class

``--jethr1`` picks the program under test (default: this checkout's), so the same cases measure an
older commit (``git worktree add ../before <commit>`` with its own venv). Mount points are real
tmpfs mounts in a private mount namespace (``unshare -rm``); cases that need one are skipped where
that is not allowed. A case is stopped at ``--timeout`` seconds or when its processes hold more than
``--max-mb`` MB together (reported as such: "stopped").
"""

from __future__ import annotations

import argparse
import contextlib
import fnmatch
import hashlib
import json
import os
import re
import shlex
import shutil
import signal
import socket
import stat
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
PAGE = os.sysconf("SC_PAGE_SIZE")


# --- running one command ------------------------------------------------------------------------


def _session_rss_mb(sid: int) -> tuple[float, int]:
    """(resident MB, process count) of every process in session ``sid``."""
    total, count = 0, 0
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            if int(fields[3]) != sid or fields[0] == "Z":  # session id; a zombie has ended (its parent reaps it)
                continue
            with open(f"/proc/{entry}/statm") as f:
                total += int(f.read().split()[1]) * PAGE
            count += 1
        except (OSError, ValueError, IndexError):
            pass
    return total / 1e6, count


@dataclass
class Outcome:
    code: int | None  # None: stopped by the harness
    stderr: str
    stdout: str
    seconds: float
    peak_mb: float
    peak_procs: int
    first_output_s: float | None  # first byte on stderr
    stopped: str = ""  # "timeout" or "memory" when the harness ended it
    left_procs: int = 0  # processes of its session still alive LEFT_AFTER_S after it ended

    @property
    def lines(self) -> list[str]:
        return [ln for ln in self.stderr.splitlines() if ln.strip()]

    @property
    def traceback(self) -> bool:
        return "Traceback" in self.stderr


def _default_signals() -> None:
    """In the child: SIGINT as a terminal gives it (a harness started in the background ignores it)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


LEFT_AFTER_S = 2.0  # a process of the command still alive this long after it ended is left behind [s]


def run_cmd(argv: list[str], timeout: float = 120.0, max_mb: float = 3000.0, cwd: Path | None = None,
            stdout=None, signal_after: tuple[float | Callable[[], bool], int] | None = None,
            env: dict | None = None, main_only: bool = False, stdin=None) -> Outcome:
    """Run ``argv`` in a new session, watch its memory, stop it at ``timeout`` or ``max_mb``;
    ``signal_after`` = (seconds or a condition, signal) sends a signal to the process group after that
    long or once the condition holds (with ``main_only``, to the command's own process alone, as
    ``kill -9 PID`` does). ``left_procs``: the processes of its session alive ``LEFT_AFTER_S`` after it ended."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=stdout if stdout is not None else subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True, cwd=cwd, env=env, preexec_fn=_default_signals,
                            stdin=stdin if stdin is not None else subprocess.DEVNULL)
    err_chunks: list[bytes] = []
    out_chunks: list[bytes] = []
    first: list[float] = []

    def pump(stream, sink, mark):
        while True:
            data = stream.read1(65536) if hasattr(stream, "read1") else stream.read(65536)
            if not data:
                return
            if mark and not first:
                first.append(time.perf_counter() - t0)
            sink.append(data)

    threads = [threading.Thread(target=pump, args=(proc.stderr, err_chunks, True), daemon=True)]
    if proc.stdout is not None:
        threads.append(threading.Thread(target=pump, args=(proc.stdout, out_chunks, False), daemon=True))
    for t in threads:
        t.start()
    peak, procs, stopped, signalled = 0.0, 0, "", False
    while proc.poll() is None:
        mb, n = _session_rss_mb(proc.pid)
        peak, procs = max(peak, mb), max(procs, n)
        elapsed = time.perf_counter() - t0
        if signal_after is not None and not signalled:
            when, sig = signal_after
            if when() if callable(when) else elapsed >= when:
                if main_only:
                    os.kill(proc.pid, sig)
                else:
                    os.killpg(proc.pid, sig)
                signalled = True
        if elapsed > timeout or mb > max_mb:
            stopped = "timeout" if elapsed > timeout else "memory"
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            break
        time.sleep(0.05)
    seconds = time.perf_counter() - t0
    time.sleep(LEFT_AFTER_S)
    left = _session_rss_mb(proc.pid)[1]
    with contextlib.suppress(ProcessLookupError, PermissionError):  # workers the run left behind
        os.killpg(proc.pid, signal.SIGKILL)
    for t in threads:
        t.join(timeout=5)
    return Outcome(None if stopped else proc.returncode, b"".join(err_chunks).decode("utf-8", "replace"),
                   b"".join(out_chunks).decode("utf-8", "replace"), seconds, peak, procs,
                   first[0] if first else None, stopped, left)


# --- the workspace ------------------------------------------------------------------------------


@dataclass
class Ctx:
    jethr1: str
    work: Path
    timeout: float
    max_mb: float
    _fixtures: dict = field(default_factory=dict)

    def run(self, *args: str, **kw) -> Outcome:
        kw.setdefault("timeout", self.timeout)
        kw.setdefault("max_mb", self.max_mb)
        return run_cmd([self.jethr1, *args], **kw)

    def fresh(self, name: str) -> Path:
        d = self.work / name
        if d.exists():
            shutil.rmtree(d)
        d.mkdir(parents=True)
        return d

    def fixture(self, name: str, make: Callable[[], Path]) -> Path:
        if name not in self._fixtures:
            self._fixtures[name] = make()
        return self._fixtures[name]

    # a plan, a walk and a balance space written once, then copied for tampering
    def plan_folder(self) -> Path:
        def make():
            d = self.fresh("fixtures/plan")
            out = self.run("plan", str(ROOT / "configs" / "side_step.yaml"), "-o", str(d), "--no-progress")
            assert out.code == 0, out.stderr
            return d / "side_step"
        return self.fixture("plan", make)

    def walk_folder(self) -> Path:
        def make():
            d = self.fresh("fixtures/walk")
            out = self.run("walk", str(ROOT / "configs" / "walks" / "jethr1_walk.yaml"), "-o", str(d),
                           "--no-rehearse")
            assert out.code == 0, out.stderr
            return d / "jethr1_walk"
        return self.fixture("walk", make)

    def balance_folder(self) -> Path:
        def make():
            d = self.fresh("fixtures/balance_space")
            out = self.run("balance-space", *SMALL_BALANCE, "-o", str(d), "--no-progress")
            assert out.code == 0, out.stderr
            return d
        return self.fixture("balance", make)

    def copy_plan(self, name: str) -> Path:
        d = self.fresh(name)
        shutil.copytree(self.plan_folder(), d / "side_step")
        return d / "side_step"

    def robot(self, name: str, yaml_edit: Callable[[dict], None] | None = None,
              urdf_edit: Callable[[str], str] | None = None) -> Path:
        """A copy of robots/jethr1 with its YAML and URDF edited; the YAML's path."""
        d = self.fresh(f"robots/{name}")
        src = ROOT / "robots" / "jethr1"
        urdf = (src / "jethr1.urdf").read_text()
        (d / "jethr1.urdf").write_text(urdf_edit(urdf) if urdf_edit else urdf)
        doc = yaml.safe_load((src / "jethr1.yaml").read_text())
        if yaml_edit:
            yaml_edit(doc)
        (d / f"{name}.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
        return d / f"{name}.yaml"

    def scenario(self, name: str, edit: Callable[[dict], None], base: str = "side_step") -> Path:
        doc = yaml.safe_load((ROOT / "configs" / f"{base}.yaml").read_text())
        edit(doc)
        d = self.work / "scenarios"
        d.mkdir(parents=True, exist_ok=True)
        path = d / f"{name}.yaml"
        path.write_text(yaml.safe_dump(doc, sort_keys=False))
        return path


SMALL_BALANCE = ["--resolution", "0.1", "--z-range", "0", "0.05", "-j", "1"]
FAST_DITCH = ["--gaps", "0.30:0.30:0.01", "--scales", "0"]
FAST_SWEEP = ["--steps-m", "0.10:0.10:0.01", "--rotation", "none", "--no-rehearse"]


def files_under(d: Path) -> list[str]:
    return sorted(str(p.relative_to(d)) for p in d.rglob("*")) if d.exists() else []


# --- cases --------------------------------------------------------------------------------------

CASES: dict[str, tuple[str, Callable[[Ctx], dict]]] = {}


def case(cid: str, what: str):
    def deco(fn):
        CASES[cid] = (what, fn)
        return fn
    return deco


def report(o: Outcome, **more) -> dict:
    return {"exit": o.code, "lines": len(o.lines), "traceback": o.traceback, "seconds": round(o.seconds, 2),
            "peak_mb": round(o.peak_mb), "procs": o.peak_procs, "stopped": o.stopped,
            "first_output_s": None if o.first_output_s is None else round(o.first_output_s, 2),
            "last_line": (o.lines[-1][:200] if o.lines else ""), **more}


# 1. files in a mount point, read-only mounts, a full disk, a full stdout

MOUNT_COMMANDS = {
    "balance-space": ["balance-space", *SMALL_BALANCE, "--no-progress", "-o", "{mnt}"],
    "ditch-curve": ["ditch-curve", *FAST_DITCH, "-j", "1", "--no-progress", "-o", "{mnt}"],
    "compare": ["compare", str(ROOT / "configs" / "side_step.yaml"), "--methods", "sqp", "--no-progress", "-o",
                "{mnt}"],
    "walk-sweep": ["walk-sweep", str(ROOT / "configs" / "walks" / "jethr1_walk.yaml"), *FAST_SWEEP, "-j", "1",
                   "--no-progress", "-o", "{mnt}"],
    "plan": ["plan", str(ROOT / "configs" / "side_step.yaml"), "--no-progress", "-o", "{mnt}"],
    "walk": ["walk", str(ROOT / "configs" / "walks" / "jethr1_walk.yaml"), "--no-rehearse", "-o", "{mnt}"],
    "batch": ["batch", str(ROOT / "configs" / "side_step.yaml"), "-j", "1", "--no-progress", "-o", "{mnt}"],
}


def unshare_ok() -> bool:
    try:
        return subprocess.run(["unshare", "-rm", "sh", "-c", "mount -t tmpfs tmpfs /mnt 2>/dev/null || "
                               "mount -t tmpfs tmpfs /tmp"], capture_output=True, timeout=10).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def in_mount(ctx: Ctx, args: list[str], size: str = "200m", readonly: bool = False, times: int = 2,
             setup: str = "") -> dict:
    """Run ``jethr1 args`` ``times`` times with ``{mnt}`` a fresh tmpfs mount point (``size``) holding a
    user's file (``setup``: more shell, ``{mnt}`` in it too); report the last run and whether the
    user's file survived every run."""
    mnt = ctx.fresh("mnt") / "usb"
    mnt.mkdir()
    cmd = " ".join(shlex.quote(a.replace("{mnt}", str(mnt))) for a in [ctx.jethr1, *args])
    parts = ["set -u", f"mount -t tmpfs -o size={size} tmpfs {mnt} || exit 99", f"echo 'my notes' > {mnt}/notes.txt"]
    parts += [setup.replace("{mnt}", str(mnt))] if setup else []
    parts += [f"mount -o remount,ro {mnt}"] if readonly else []
    for _ in range(times):
        parts += [cmd, 'echo "__exit=$?" >&2', f"(test -f {mnt}/notes.txt && echo __kept || echo __lost) >&2"]
    parts.append(f"echo \"__left=$(ls -A {mnt} | tr '\\n' ' ')\" >&2")
    script = "; ".join(parts)
    o = run_cmd(["unshare", "-rm", "sh", "-c", script], timeout=ctx.timeout * times, max_mb=ctx.max_mb)
    codes = [int(c) for c in re.findall(r"__exit=(\d+)", o.stderr)]
    kept = o.stderr.count("__kept") == times
    left = re.findall(r"__left=(.*)", o.stderr)
    o.stderr = re.sub(r"__exit=\d+|__kept|__lost|__left=.*", "", o.stderr)
    return report(o, exit=codes[-1] if codes else None, exits=codes, user_file_kept=kept,
                  left=left[0].strip() if left else "")


for _name, _args in MOUNT_COMMANDS.items():
    def _mk(args):
        return lambda ctx: in_mount(ctx, args)
    case(f"1.mount.{_name}", f"{_name} -o MOUNT_POINT (a tmpfs holding notes.txt), twice")(_mk(_args))
for _name in ("balance-space", "ditch-curve", "compare", "walk-sweep"):
    def _mk_ro(args):
        return lambda ctx: in_mount(ctx, args, size="50m", readonly=True, times=1)
    case(f"1.readonly.{_name}", f"{_name} -o READ_ONLY_MOUNT")(_mk_ro(MOUNT_COMMANDS[_name]))


@case("1.simulate-in-mount", "simulate PLAN_DIR where the plan folder is a mount point, twice")
def _(ctx):
    plan = ctx.plan_folder()
    return in_mount(ctx, ["simulate", "{mnt}", "--no-progress"], setup=f"cp {plan}/* {{mnt}}/")


@case("1.full-disk.plan", "plan -o a 1 MB tmpfs (ENOSPC)")
def _(ctx):
    return in_mount(ctx, MOUNT_COMMANDS["plan"], size="1m", times=1)


@case("1.full-disk.balance-space", "balance-space -o a 64 kB tmpfs (ENOSPC)")
def _(ctx):
    return in_mount(ctx, MOUNT_COMMANDS["balance-space"], size="64k", times=1)


@case("1.dev-full", "plan --json > /dev/full")
def _(ctx):
    d = ctx.fresh("devfull")
    with open("/dev/full", "w") as full:
        o = ctx.run("plan", str(ROOT / "configs" / "side_step.yaml"), "--json", "--no-progress", "-o", str(d),
                    stdout=full)
    return report(o)


@case("1.broken-pipe", "plan --json | head -c 10")
def _(ctx):
    d = ctx.fresh("pipe")
    o = run_cmd(["bash", "-c", f"{ctx.jethr1} plan {ROOT / 'configs' / 'side_step.yaml'} --json --no-progress "
                 f"-o {d} | head -c 10 >/dev/null; echo __exit=${{PIPESTATUS[0]}} >&2"], timeout=ctx.timeout)
    codes = re.findall(r"__exit=(\d+)", o.stderr)
    o.stderr = re.sub(r"__exit=\d+", "", o.stderr)
    return report(o, exit=int(codes[0]) if codes else None)


@case("1.modes", "modes of every file written (plan, simulate, batch)")
def _(ctx):
    d = ctx.fresh("modes")
    ctx.run("plan", str(ROOT / "configs" / "side_step.yaml"), "--no-progress", "-o", str(d))
    o = ctx.run("simulate", str(d / "side_step"), "--no-progress")
    ctx.run("batch", str(ROOT / "configs" / "side_step.yaml"), "-j", "1", "--no-progress", "-o", str(d / "batch"))
    modes = {str(p.relative_to(d)): oct(p.stat().st_mode & 0o777) for p in sorted(d.rglob("*")) if p.is_file()}
    return report(o, modes=sorted(set(modes.values())), not_0644=[k for k, v in modes.items() if v != "0o644"])


# 2. resources


@case("2.j1000.ditch-curve", "ditch-curve -j 1000 (2 gaps x 2 scales)")
def _(ctx):
    d = ctx.fresh("j1000dc")
    return report(ctx.run("ditch-curve", "--gaps", "0.30:0.31:0.01", "--scales", "0,1", "-j", "1000", "-o", str(d)))


@case("2.j2.ditch-curve", "ditch-curve -j 2 (the same, capped by hand)")
def _(ctx):
    d = ctx.fresh("j2dc")
    return report(ctx.run("ditch-curve", "--gaps", "0.30:0.31:0.01", "--scales", "0,1", "-j", "2", "-o", str(d)))


@case("2.j1000.balance-space", "balance-space -j 1000 (0.1 m grid)")
def _(ctx):
    d = ctx.fresh("j1000bs")
    return report(ctx.run("balance-space", "--resolution", "0.1", "-j", "1000", "-o", str(d)))


@case("2.j2.balance-space", "balance-space -j 2 (0.1 m grid)")
def _(ctx):
    d = ctx.fresh("j2bs")
    return report(ctx.run("balance-space", "--resolution", "0.1", "-j", "2", "-o", str(d)))


@case("2.j1000.simulate", "simulate --trials 4 -j 1000")
def _(ctx):
    plan = ctx.copy_plan("j1000sim")
    return report(ctx.run("simulate", str(plan), "--trials", "4", "-j", "1000"))


@case("2.j2.simulate", "simulate --trials 4 -j 2")
def _(ctx):
    plan = ctx.copy_plan("j2sim")
    return report(ctx.run("simulate", str(plan), "--trials", "4", "-j", "2"))


@case("2.j1000.batch", "batch side_step -j 1000")
def _(ctx):
    d = ctx.fresh("j1000batch")
    return report(ctx.run("batch", str(ROOT / "configs" / "side_step.yaml"), "-j", "1000", "-o", str(d)))


@case("2.j1000.walk-sweep", "walk-sweep -j 1000 (3 lengths, one mode)")
def _(ctx):
    d = ctx.fresh("j1000ws")
    return report(ctx.run("walk-sweep", str(ROOT / "configs" / "walks" / "jethr1_walk.yaml"), "--steps-m",
                          "0.10:0.12:0.01", "--rotation", "none", "--no-rehearse", "-j", "1000", "-o", str(d)))


@case("2.j2.walk-sweep", "walk-sweep -j 2 (3 lengths, one mode)")
def _(ctx):
    d = ctx.fresh("j2ws")
    return report(ctx.run("walk-sweep", str(ROOT / "configs" / "walks" / "jethr1_walk.yaml"), "--steps-m",
                          "0.10:0.12:0.01", "--rotation", "none", "--no-rehearse", "-j", "2", "-o", str(d)))


@case("2.z-range", "balance-space --z-range 0 100")
def _(ctx):
    d = ctx.fresh("zrange")
    return report(ctx.run("balance-space", "--z-range", "0", "100", "-j", "1", "-o", str(d), timeout=20),
                  written=files_under(d))


@case("2.resolution", "balance-space --resolution 0.001")
def _(ctx):
    d = ctx.fresh("res")
    return report(ctx.run("balance-space", "--resolution", "0.001", "-j", "1", "-o", str(d), timeout=20),
                  written=files_under(d))


@case("2.trials", "simulate --trials 10000 -j 1: bounded or progressing")
def _(ctx):
    plan = ctx.copy_plan("trials")
    return report(ctx.run("simulate", str(plan), "--trials", "10000", "-j", "1", timeout=10))


@case("2.first-output.balance-space", "balance-space at 1 cm, stderr not a terminal: first line")
def _(ctx):
    d = ctx.fresh("firstout")
    return report(ctx.run("balance-space", "-j", "1", "-o", str(d), timeout=8))


@case("2.first-output.plan", "plan jet_hr1_trial, stderr not a terminal: first line")
def _(ctx):
    d = ctx.fresh("firstout_plan")
    return report(ctx.run("plan", str(ROOT / "configs" / "jet_hr1_trial.yaml"), "-o", str(d), timeout=8))


# 3. robot folders


def _knee_swap(urdf: str) -> str:
    m = re.search(r'(<joint name="left_knee".*?<limit[^>]*?lower=")([^"]+)("[^>]*?upper=")([^"]+)"', urdf, re.S)
    assert m, "no knee limit"
    return urdf[:m.start(2)] + m.group(4) + m.group(3) + m.group(2) + urdf[m.end(4):]


def _link_mass(urdf: str, link: str, value: str) -> str:
    m = re.search(rf'<link name="{link}">.*?<mass value="([^"]+)"', urdf, re.S)
    assert m, link
    return urdf[:m.start(1)] + value + urdf[m.end(1):]


def _nan_inertial_origin(urdf: str) -> str:
    m = re.search(r'<link name="left_thigh">.*?<inertial>\s*<origin xyz="([^"]+)"', urdf, re.S)
    assert m
    return urdf[:m.start(1)] + "nan 0 0" + urdf[m.end(1):]


def _robot_case(ctx, name, command, yaml_edit=None, urdf_edit=None):
    path = ctx.robot(name, yaml_edit, urdf_edit)
    out = ctx.fresh(f"robot_out/{name}")
    if command == "plan":
        sc = ctx.scenario(name, lambda d: d.update(robot=str(path)))
        o = ctx.run("plan", str(sc), "-o", str(out), "--no-progress")
    elif command == "reach":
        o = ctx.run("reach", "--robot", str(path))
    elif command == "walk":
        w = yaml.safe_load((ROOT / "configs" / "walks" / "jethr1_walk.yaml").read_text())
        w["robot"] = str(path)
        wp = ctx.work / "scenarios" / f"{name}_walk.yaml"
        wp.parent.mkdir(exist_ok=True, parents=True)
        wp.write_text(yaml.safe_dump(w))
        o = ctx.run("walk", str(wp), "-o", str(out), "--no-rehearse")
    else:
        o = ctx.run("robot", "show", str(path))
    return report(o, written=files_under(out))


ROBOT_CASES = {
    "knee-limits-swapped.plan": ("plan", None, _knee_swap),
    "knee-limits-swapped.reach": ("reach", None, _knee_swap),
    "nan-urdf-origin.show": ("show", None, _nan_inertial_origin),
    "servo-stiffness-0.plan": ("plan", lambda d: d["servos"].update(stiffness_nm_per_rad=0.0), None),
    "servo-stiffness-0.walk": ("walk", lambda d: d["servos"].update(stiffness_nm_per_rad=0.0), None),
    "negative-link-mass.plan": ("plan", None, lambda u: _link_mass(u, "left_thigh", "-0.5")),
    "zero-trunk-mass.plan": ("plan", None, lambda u: _link_mass(u, "trunk", "0")),
    "unknown-key.show": ("show", lambda d: d.update(colour="red"), None),
    "zero-sole-length.plan": ("plan", lambda d: d["sole"].update(length_m=0.0), None),
    "nan-fan-thrust.show": ("show", lambda d: d["fans"][0].update(thrust_max_n=float("nan")), None),
    "negative-lag.show": ("show", lambda d: d["fans"][0].update(lag_s=-0.1), None),
}
for _cid, (_cmd, _ye, _ue) in ROBOT_CASES.items():
    def _mk_robot(cid, cmd, ye, ue):
        return lambda ctx: _robot_case(ctx, cid.replace(".", "_"), cmd, ye, ue)
    case(f"3.{_cid}", f"robot: {_cid.split('.')[0].replace('-', ' ')} -> {_cmd}")(_mk_robot(_cid, _cmd, _ye, _ue))


# 4. the folder check


def _summary_edit(ctx, name, edit):
    d = ctx.copy_plan(name)
    s = json.loads((d / "summary.json").read_text())
    edit(s)
    (d / "summary.json").write_text(json.dumps(s))
    return d


def _nested(s):
    s["terrain"] = json.loads("[" * 100000 + "]" * 100000)


def _deep_summary(ctx, name):
    d = ctx.copy_plan(name)
    text = (d / "summary.json").read_text()
    (d / "summary.json").write_text(text[:-2] + ', "deep": ' + "[" * 100000 + "]" * 100000 + "}")
    return d


def _csv_edit(d: Path, edit):
    lines = (d / "trajectory.csv").read_text().split("\n")
    head, rows = lines[0], [ln for ln in lines[1:] if ln]
    (d / "trajectory.csv").write_text("\n".join([head, *edit(head.split(","), rows)]) + "\n")


def _nan_cell(h, r):
    cells = r[300].split(",")
    cells[h.index("pelvis_x_m")] = "nan"
    r[300] = ",".join(cells)
    return r


def _deleted(ctx: Ctx, name: str, file: str) -> Path:
    d = ctx.copy_plan(name)
    (d / file).unlink()
    return d


VERIFY_CASES: dict[str, Callable[[Ctx, str], Path]] = {
    "mcap-deleted": lambda ctx, n: _deleted(ctx, n, "trajectory.mcap"),
    "csv-deleted": lambda ctx, n: _deleted(ctx, n, "trajectory.csv"),
    "summary-deleted": lambda ctx, n: _deleted(ctx, n, "summary.json"),
    "another-robot": lambda ctx, n: _summary_edit(ctx, n, lambda s: s.update(
        robot="dyros_jet_like", robot_yaml=str(ROOT / "robots" / "dyros_jet_like" / "dyros_jet_like.yaml"))),
    "another-robot-name": lambda ctx, n: _summary_edit(ctx, n, lambda s: s.update(robot="jethr1_trunk_fan",
                                                                                robot_yaml="/nowhere.yaml")),
    "row-count-1e12": lambda ctx, n: _summary_edit(ctx, n, lambda s: (s.update(row_count=1e12),
                                                                     s["trajectory"].update(rows=10**12))),
    "nan-cell": lambda ctx, n: (lambda d: (_csv_edit(d, _nan_cell), d)[1])(ctx.copy_plan(n)),
    "nested-summary": _deep_summary,
    "rows-swapped": lambda ctx, n: (lambda d: (_csv_edit(d, lambda h, r: [*r[:300], r[301], r[300], *r[302:]]),
                                               d)[1])(ctx.copy_plan(n)),
    "terrain-not-a-list": lambda ctx, n: _summary_edit(ctx, n, lambda s: (s.update(terrain={"cartons": 5}),
                                                                         s.update(scenario_file="/nowhere.yaml"),
                                                                         s.pop("scenario_yaml"))),
}
for _cid, _make in VERIFY_CASES.items():
    for _cmd in ("verify", "simulate"):
        def _mk_verify(cid, make, cmd):
            def fn(ctx):
                d = make(ctx, f"{cmd}_{cid}")
                o = ctx.run(cmd, str(d), *(["--no-progress"] if cmd == "simulate" else []), timeout=60)
                return report(o, written=[f for f in files_under(d) if f.startswith("simulation")])
            return fn
        case(f"4.{_cmd}.{_cid}", f"{_cmd} a plan folder: {_cid.replace('-', ' ')}")(_mk_verify(_cid, _make, _cmd))


# 5. CSV quoting


@case("5.robust-reasons", "plan forward_ditch_450 --policy robust --write-infeasible, then verify")
def _(ctx):
    d = ctx.fresh("reasons")
    p = ctx.run("plan", str(ROOT / "configs" / "forward_ditch_450.yaml"), "--policy", "robust",
                "--write-infeasible", "-o", str(d), "--no-progress")
    v = ctx.run("verify", str(d / "forward_ditch_450"))
    return report(v, plan_exit=p.code)


# 6. misleading words and the smaller items


@case("6.simulate-walk", "simulate a walk folder")
def _(ctx):
    return report(ctx.run("simulate", str(ctx.walk_folder()), "--no-progress"))


@case("6.simulate-balance-space", "simulate a balance-space folder")
def _(ctx):
    return report(ctx.run("simulate", str(ctx.balance_folder()), "--no-progress"))


@case("6.rate-hz-0", "a scenario with timing.rate_hz: 0")
def _(ctx):
    sc = ctx.scenario("rate0", lambda d: d["timing"].update(rate_hz=0))
    return report(ctx.run("plan", str(sc), "-o", str(ctx.fresh("rate0"))))


def _interrupted(ctx, name, args, after, sig=signal.SIGINT):
    d = ctx.fresh(name)
    o = ctx.run(*[a.replace("{out}", str(d)) for a in args], signal_after=(after, sig))
    return report(o, written=files_under(d))


@case("6.interrupted-batch", "batch of 2 scenarios, SIGINT once the first is written")
def _(ctx):
    d = ctx.fresh("intbatch")
    o = ctx.run("batch", str(ROOT / "configs" / "side_step.yaml"), str(ROOT / "configs" / "forward_ditch_robust.yaml"),
                "-j", "1", "-o", str(d), "--no-progress",
                signal_after=(lambda: (d / "side_step" / "summary.json").exists(), signal.SIGINT))
    return report(o, written=files_under(d))


@case("6.interrupted-plan", "plan, SIGINT after 3 s")
def _(ctx):
    return _interrupted(ctx, "intplan", ["plan", str(ROOT / "configs" / "side_step.yaml"), "-o", "{out}/new",
                                         "--no-progress"], 3.0)


@case("6.interrupted-walk", "walk, SIGINT after 3 s")
def _(ctx):
    return _interrupted(ctx, "intwalk", ["walk", str(ROOT / "configs" / "walks" / "jethr1_walk.yaml"), "-o",
                                         "{out}/new"], 3.0)


@case("6.interrupted-balance-space", "balance-space -j 2, SIGINT after 6 s (loky warnings?)")
def _(ctx):
    o = _interrupted(ctx, "intbs", ["balance-space", "--resolution", "0.05", "-j", "2", "-o", "{out}/new",
                                    "--no-progress"], 6.0)
    return o


@case("6.verify-dev-null", "verify /dev/null")
def _(ctx):
    return report(ctx.run("verify", "/dev/null"))


@case("6.landing-1.5m", "a landing 1.5 m ahead")
def _(ctx):
    def edit(d):
        d["terrain"]["cartons"].append({"top_centre_m": [1.5, -0.1125, 0.0]})
        d["steps"][0]["landing_m"] = [1.5, -0.1125, 0.0]
    sc = ctx.scenario("far", edit, base="forward_ditch_robust")
    return report(ctx.run("plan", str(sc), "-o", str(ctx.fresh("far")), "--no-progress"))


@case("6.scheduler-without-dask", "batch --scheduler tcp://x:1 (loky executor)")
def _(ctx):
    d = ctx.fresh("sched")
    return report(ctx.run("batch", str(ROOT / "configs" / "side_step.yaml"), "--scheduler", "tcp://127.0.0.1:9",
                          "-o", str(d), "--no-progress"), written=files_under(d))


@case("6.dead-scheduler", "balance-space --executor dask --scheduler tcp://127.0.0.1:9")
def _(ctx):
    d = ctx.fresh("dead")
    return report(ctx.run("balance-space", *SMALL_BALANCE, "--executor", "dask", "--scheduler", "tcp://127.0.0.1:9",
                          "-o", str(d), "--no-progress", timeout=60), written=files_under(d))


@case("7.duplicate-key", "a scenario with a key twice")
def _(ctx):
    path = ctx.work / "scenarios" / "dup.yaml"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text((ROOT / "configs" / "side_step.yaml").read_text().replace("seed: 1\n", "seed: 1\nseed: 2\n"))
    return report(ctx.run("plan", str(path), "-o", str(ctx.fresh("dup"))))


@case("7.overlapping-cartons", "two cartons overlapping at one height")
def _(ctx):
    sc = ctx.scenario("overlap", lambda d: d["terrain"]["cartons"].append({"top_centre_m": [0.0, 0.33, 0.0]}))
    return report(ctx.run("plan", str(sc), "-o", str(ctx.fresh("overlap"))))


@case("7.compare-methods-empty", "compare --methods ''")
def _(ctx):
    return report(ctx.run("compare", str(ROOT / "configs" / "side_step.yaml"), "--methods", "", "-o",
                          str(ctx.fresh("cmpempty")), "--no-progress", timeout=20))


@case("7.compare-infeasible", "compare an infeasible scenario")
def _(ctx):
    sc = ctx.scenario("nothrust", lambda d: (d["balance"].update(thrust_max_n=0.0)))
    return report(ctx.run("compare", str(sc), "--methods", "sqp", "-o", str(ctx.fresh("cmpinf")), "--no-progress"))


@case("7.seed-1e23", "plan --seed 10**23")
def _(ctx):
    return report(ctx.run("plan", str(ROOT / "configs" / "side_step.yaml"), "--seed", str(10**23), "-o",
                          str(ctx.fresh("seed"))))


# --- issue 37: every class of the third probe, each case judged ----------------------------------
#
# Each case runs in a folder of its own (the command's working folder), holding the user's files it
# needs. A case passes when the command exits with a code the case allows; exit 2 is one line on stderr
# and nothing in the folder changed; any other exit changed only the outputs the case names, never a
# file of the user's; no traceback; no process of the command alive 2 s after it ended; under
# LIMIT_S seconds (where the command does no real work) and MAX_MB of memory for its processes together.

LIMIT_S = 5.0
MAX_MB = 500.0
CLASSES = ("data loss", "hang", "resource", "traceback", "silent accept", "exit/leftover/message")


def tree_state(root: Path) -> dict[str, str]:
    """Every entry under ``root`` (symbolic links not followed): its kind and content digest."""
    out: dict[str, str] = {}
    if not root.exists():
        return out
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath, name)
            rel = str(p.relative_to(root))
            try:
                st = os.lstat(p)
            except OSError:
                continue
            if stat.S_ISLNK(st.st_mode):
                out[rel] = "link:" + os.readlink(p)
            elif stat.S_ISDIR(st.st_mode):
                out[rel] = "dir"
            elif stat.S_ISREG(st.st_mode):
                if st.st_size > 50_000_000:  # the sparse giants: their size and time, not their bytes
                    out[rel] = f"big:{st.st_size}:{st.st_mtime_ns}"
                else:
                    out[rel] = "file:" + hashlib.sha256(p.read_bytes()).hexdigest()
            else:
                out[rel] = f"special:{stat.S_IFMT(st.st_mode):o}"
    return out


def changed_paths(before: dict[str, str], after: dict[str, str]) -> list[str]:
    return sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))


@dataclass
class Probe:
    """One case of issue 37: its class, the command (``{W}`` the case's folder, ``{ROOT}`` the checkout),
    the exits it allows, what it may write (fnmatch patterns relative to ``{W}``) and what it must keep."""

    cls: str
    argv: list[str]
    expect: tuple[int, ...] = (2,)
    setup: Callable[[Ctx, Path], None] | None = None
    outputs: tuple[str, ...] = ()
    keep: tuple[str, ...] = ()  # the user's files (relative to W): never changed, whatever the exit
    limit_s: float = LIMIT_S
    timeout: float = 30.0
    kill9: Callable[[], bool] | None = None  # when given: SIGKILL to the command alone once it holds
    kill9_after: float = 0.0
    not_in_message: str = ""  # a regular expression the stderr must not match
    judge: Callable[[Path, Outcome], str] | None = None  # more: "" when fine, else what is wrong
    env: dict | None = None


PROBES: dict[str, Probe] = {}


def probe37(cid: str, what: str, p: Probe) -> None:
    PROBES[cid] = p

    def run(ctx: Ctx, p=p, cid=cid) -> dict:
        return run_probe(ctx, cid, p)
    case(f"37.{cid}", what)(run)


def run_probe(ctx: Ctx, cid: str, p: Probe) -> dict:
    W = ctx.fresh(f"p37/{cid}")
    if p.setup is not None:
        p.setup(ctx, W)
    argv = [a.replace("{W}", str(W)).replace("{ROOT}", str(ROOT)).replace("{CACHE}", str(ctx.cache()))
            for a in p.argv]
    before = tree_state(W)
    kw = {}
    if p.kill9 is not None:
        t_start = time.perf_counter()
        kw = {"signal_after": (lambda: p.kill9(W) and time.perf_counter() - t_start >= p.kill9_after,
                               signal.SIGKILL), "main_only": True}
    o = ctx.run(*argv, cwd=W, timeout=p.timeout, max_mb=max(3 * MAX_MB, ctx.max_mb), env=p.env, **kw)
    time.sleep(0.2 if p.kill9 is None else 3.0)  # (after a kill: what its workers would still write)
    after = tree_state(W)
    changed = changed_paths(before, after)
    problems = []
    if p.kill9 is None:
        if o.code not in p.expect:
            problems.append(f"exit {o.code}, expected {'/'.join(map(str, p.expect))}")
        if o.traceback:
            problems.append("traceback")
        if o.code == 2 and len(o.lines) != 1:
            problems.append(f"{len(o.lines)} lines")
        if o.code == 2 and changed:
            problems.append(f"wrote {', '.join(changed[:3])}")
        elif o.code != 2:
            stray = [c for c in changed if not any(fnmatch.fnmatch(c, pat) for pat in p.outputs)]
            if stray:
                problems.append(f"changed {', '.join(stray[:3])}")
        if o.seconds > p.limit_s:
            problems.append(f"{o.seconds:.1f} s")
    elif o.code is not None and o.code != -signal.SIGKILL:
        problems.append(f"ended by itself (exit {o.code}) before the kill")
    kept = [k for k in p.keep if before.get(k) != after.get(k)]
    if kept:
        problems.append(f"user file changed: {', '.join(kept)}")
    if o.stopped:
        problems.append(f"stopped ({o.stopped})")
    if o.peak_mb > MAX_MB and p.kill9 is None:  # (a kill case runs a pool of workers on purpose: ~250 MB each)
        problems.append(f"{o.peak_mb:.0f} MB")
    if o.left_procs:
        problems.append(f"{o.left_procs} processes left")
    if p.not_in_message and re.search(p.not_in_message, o.stderr):
        problems.append(f"message matches {p.not_in_message!r}")
    if p.judge is not None:
        more = p.judge(W, o)
        if more:
            problems.append(more)
    return report(o, cls=p.cls, ok=not problems, problems=problems, changed=changed[:6], left_procs=o.left_procs)


# the fixtures each case copies into its folder


def _cache(self) -> Path:
    """A route map cache for the cases (a copy of the user's, so a route finds its maps and the user's stays)."""
    d = self.work / "cache"
    if not d.exists():
        home = Path(os.environ.get("JETHR1_CACHE") or Path.home() / ".cache" / "jethr1")
        if home.is_dir():
            shutil.copytree(home, d)
        else:
            d.mkdir(parents=True)
    return d


def _other_plan(self) -> Path:
    def make():
        d = self.fresh("fixtures/other")
        out = self.run("plan", str(ROOT / "configs" / "side_step.yaml"), "--policy", "minimal", "-o", str(d),
                       "--no-progress")
        assert out.code == 0, out.stderr
        return d / "side_step"
    return self.fixture("other", make)


Ctx.cache = _cache  # type: ignore[attr-defined]
Ctx.other_plan = _other_plan  # type: ignore[attr-defined]

SIDE = "{ROOT}/configs/side_step.yaml"
WALK = "{ROOT}/configs/walks/jethr1_walk.yaml"
TERRAIN = "{ROOT}/configs/terrains/jet_hr1_trial.yaml"
NP = "--no-progress"


def _text(rel: str, text: str | bytes) -> Callable[[Ctx, Path], None]:
    def make(ctx: Ctx, W: Path) -> None:
        p = W / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(text, bytes):
            p.write_bytes(text)
        else:
            p.write_text(text)
    return make


def _copy(rel: str, src: str) -> Callable[[Ctx, Path], None]:
    return _text(rel, Path(src.replace("{ROOT}", str(ROOT))).read_text())


def _all(*steps: Callable[[Ctx, Path], None]) -> Callable[[Ctx, Path], None]:
    def make(ctx: Ctx, W: Path) -> None:
        for s in steps:
            s(ctx, W)
    return make


def _fifo(rel: str) -> Callable[[Ctx, Path], None]:
    def make(ctx: Ctx, W: Path) -> None:
        (W / rel).parent.mkdir(parents=True, exist_ok=True)
        os.mkfifo(W / rel)
    return make


def _symlink(rel: str, target: str) -> Callable[[Ctx, Path], None]:
    def make(ctx: Ctx, W: Path) -> None:
        (W / rel).parent.mkdir(parents=True, exist_ok=True)
        os.symlink(target.replace("{W}", str(W)), W / rel)
    return make


def _mkdir(rel: str) -> Callable[[Ctx, Path], None]:
    def make(ctx: Ctx, W: Path) -> None:
        (W / rel).mkdir(parents=True, exist_ok=True)
        (W / rel / "mine.txt").write_text("a file of the user's\n")
    return make


def _sparse(rel: str, size: int) -> Callable[[Ctx, Path], None]:
    def make(ctx: Ctx, W: Path) -> None:
        (W / rel).parent.mkdir(parents=True, exist_ok=True)
        with open(W / rel, "wb") as f:
            f.truncate(size)
    return make


def _plan(rel: str = "plan", which: str = "plan") -> Callable[[Ctx, Path], None]:
    """A copy of the side-step plan folder at W/rel."""
    def make(ctx: Ctx, W: Path) -> None:
        src = ctx.plan_folder() if which == "plan" else ctx.other_plan() if which == "other" else ctx.walk_folder()
        shutil.copytree(src, W / rel)
    return make


def _scenario_yaml(edit: Callable[[dict], None], base: str = "side_step") -> str:
    doc = yaml.safe_load((ROOT / "configs" / f"{base}.yaml").read_text())
    edit(doc)
    return yaml.safe_dump(doc, sort_keys=False)


def _scenario(rel: str, edit: Callable[[dict], None], base: str = "side_step") -> Callable[[Ctx, Path], None]:
    return _text(rel, _scenario_yaml(edit, base))


def _walk_yaml(edit: Callable[[dict], None]) -> str:
    doc = yaml.safe_load((ROOT / "configs" / "walks" / "jethr1_walk.yaml").read_text())
    edit(doc)
    return yaml.safe_dump(doc, sort_keys=False)


def _terrain_yaml(edit: Callable[[dict], None]) -> str:
    doc = yaml.safe_load((ROOT / "configs" / "terrains" / "jet_hr1_trial.yaml").read_text())
    edit(doc)
    return yaml.safe_dump(doc, sort_keys=False)


def _robot(rel: str, yaml_edit: Callable[[dict], None] | None = None,
           urdf_edit: Callable[[str], str] | None = None) -> Callable[[Ctx, Path], None]:
    """A copy of robots/jethr1 at W/rel/ (jethr1.yaml, jethr1.urdf), edited."""
    def make(ctx: Ctx, W: Path) -> None:
        d = W / rel
        d.mkdir(parents=True, exist_ok=True)
        src = ROOT / "robots" / "jethr1"
        urdf = (src / "jethr1.urdf").read_text()
        (d / "jethr1.urdf").write_text(urdf_edit(urdf) if urdf_edit else urdf)
        doc = yaml.safe_load((src / "jethr1.yaml").read_text())
        if yaml_edit:
            yaml_edit(doc)
        (d / "jethr1.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    return make


def _summary(rel: str, edit: Callable[[dict], None]) -> Callable[[Ctx, Path], None]:
    def make(ctx: Ctx, W: Path) -> None:
        p = W / rel / "summary.json"
        s = json.loads(p.read_text())
        edit(s)
        p.write_text(json.dumps(s))
    return make


def _summary_text(rel: str, change: Callable[[str], str]) -> Callable[[Ctx, Path], None]:
    def make(ctx: Ctx, W: Path) -> None:
        p = W / rel / "summary.json"
        p.write_text(change(p.read_text()))
    return make


def _procs_at_least(n: int) -> Callable[[Path], bool]:
    """A condition: the harness's newest session holds ``n`` processes (set by run_cmd's caller below)."""
    def cond(W: Path) -> bool:
        return _LAST_SESSION[0] is not None and _session_rss_mb(_LAST_SESSION[0])[1] >= n
    return cond


_LAST_SESSION: list[int | None] = [None]
_popen = subprocess.Popen


class _TrackedPopen(_popen):  # type: ignore[misc, valid-type]
    """subprocess.Popen, remembering the newest process (its session: the command's)."""

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        _LAST_SESSION[0] = self.pid


subprocess.Popen = _TrackedPopen  # type: ignore[misc]

USER = "a file of the user's\n"
BIG_INT = "1" + "0" * 5000
MCAP_MAGIC = b"\x89MCAP0\r\n"


def _mcap_bomb(ctx: Ctx, W: Path, rel: str = "plan/trajectory.mcap", declared: int = 3_000_000_000) -> None:
    """An MCAP whose one chunk declares 3 GB uncompressed (zstd of zeros: a few kB on disk)."""
    import struct

    import zstandard

    def record(op: int, body: bytes) -> bytes:
        return bytes([op]) + struct.pack("<Q", len(body)) + body

    def text(s: str) -> bytes:
        return struct.pack("<I", len(s)) + s.encode()
    payload = zstandard.ZstdCompressor(level=19).compressobj()
    compressed = b""
    chunk = b"\0" * (1 << 24)
    for _ in range(max(1, declared // len(chunk) // 64)):  # 47 MB of zeros: the bytes; the header claims more
        compressed += payload.compress(chunk)
    compressed += payload.flush()
    header = record(0x01, text("ros2") + text("jethr1-plan"))
    body = struct.pack("<QQQI", 0, 0, declared, 0) + text("zstd") + struct.pack("<Q", len(compressed)) + compressed
    data = MCAP_MAGIC + header + record(0x06, body) + record(0x0F, b"") + record(0x02, struct.pack("<QQI", 0, 0, 0)) \
        + MCAP_MAGIC
    (W / rel).write_bytes(data)


def _cut(rel: str, keep: float) -> Callable[[Ctx, Path], None]:
    def make(ctx: Ctx, W: Path) -> None:
        p = W / rel
        data = p.read_bytes()
        p.write_bytes(data[:int(len(data) * keep)])
    return make


def _copy_file(src_rel: str, dst_rel: str) -> Callable[[Ctx, Path], None]:
    def make(ctx: Ctx, W: Path) -> None:
        shutil.copyfile(W / src_rel, W / dst_rel)
    return make


HOST = hashlib.sha1(socket.gethostname().encode()).hexdigest()[:8]  # as jethr1 names its staging folders


def _staging_like(rel: str) -> Callable[[Ctx, Path], None]:
    """A user's folder named like a staging folder of a process that has ended, holding the user's files."""
    def make(ctx: Ctx, W: Path) -> None:
        d = W / rel
        d.mkdir(parents=True)
        (d / "notes.txt").write_text(USER)
        (d / "summary.json").write_text(USER)
    return make


def _knee(urdf: str, attrs: str) -> str:
    m = re.search(r'<joint name="left_knee" type="revolute">', urdf)
    assert m, "no knee"
    return urdf.replace('<joint name="left_knee" type="revolute">', f'<joint name="left_knee" {attrs}>')


def _mass(urdf: str, link: str, value: str) -> str:
    m = re.search(rf'<link name="{link}">.*?<mass value="([^"]+)"', urdf, re.S)
    assert m, link
    return urdf[:m.start(1)] + value + urdf[m.end(1):]


def _mesh(urdf: str, filename: str) -> str:
    i = urdf.index("<visual>")
    return urdf[:i] + f'<visual><geometry><mesh filename="{filename}"/></geometry></visual>' + urdf[i:]


def _entity(urdf: str) -> str:
    head, rest = urdf.split("<robot", 1)
    return head + '<!DOCTYPE robot [<!ENTITY m "0.35">]>\n<robot' + rest


def _long(n: int = 300) -> str:
    return "x" * n


# 1. data loss: outputs over a user's files, inputs among outputs, staging-like folders, special outputs

_USER_OUT = {  # command: (its argv with -o {W}/o, the user's file that shares an output's name)
    "balance-space": (["balance-space", *SMALL_BALANCE, NP, "-o", "{W}/o"], "o/summary.json"),
    "balance-space.png": (["balance-space", *SMALL_BALANCE, NP, "-o", "{W}/o"], "o/balance_space.png"),
    "batch": (["batch", SIDE, "-j", "1", NP, "-o", "{W}/o"], "o/summary.json"),
    "compare": (["compare", SIDE, "--methods", "sqp", NP, "-o", "{W}/o"], "o/compare.json"),
    "ditch-curve.png": (["ditch-curve", *FAST_DITCH, "-j", "1", NP, "-o", "{W}/o"], "o/ditch_curve.png"),
    "ditch-curve.json": (["ditch-curve", *FAST_DITCH, "-j", "1", NP, "-o", "{W}/o"], "o/ditch_curve.json"),
    "walk-sweep": (["walk-sweep", WALK, *FAST_SWEEP, "-j", "1", NP, "-o", "{W}/o"], "o/walk_sweep.csv"),
    "plan": (["plan", SIDE, NP, "-o", "{W}/o"], "o/side_step/trajectory.csv"),
    "plan.summary": (["plan", SIDE, NP, "-o", "{W}/o"], "o/side_step/summary.json"),
    "walk": (["walk", WALK, "--no-rehearse", "-o", "{W}/o"], "o/jethr1_walk/yaw.png"),
    "replan-steps": (["replan-steps", SIDE, NP, "-o", "{W}/o"], "o/side_step/replan_steps.json"),
    "route": (["route", TERRAIN, "--cache", "{CACHE}", NP, "-o", "{W}/o"], "o/jet_hr1_trial/route.png"),
    "terrain": (["terrain", "random", "--seed", "1", "-o", "{W}/o/t.yaml"], "o/t.yaml"),
    "view": (["view", "{W}/plan", "--save", "{W}/o/x.rrd"], "o/x.rrd"),
}
for _name, (_argv, _user) in _USER_OUT.items():
    probe37(f"data.user-file.{_name}", f"{_name}: a user's {Path(_user).name} inside -o",
            Probe("data loss", _argv, setup=_all(_text(_user, USER), *([_plan()] if _name == "view" else [])),
                  keep=(_user,), timeout=60))

probe37("data.user-file.simulate", "simulate: a user's simulation.mcap in the plan folder",
        Probe("data loss", ["simulate", "{W}/plan", NP], setup=_all(_plan(), _text("plan/simulation.mcap", USER)),
              keep=("plan/simulation.mcap",), timeout=60))
probe37("data.user-file.plan-owned-not-written", "plan: a user's simulation.json in the folder re-planned",
        Probe("data loss", ["plan", SIDE, NP, "-o", "{W}/o"], expect=(0, 2),
              setup=_all(_text("o/side_step/simulation.json", USER)), keep=("o/side_step/simulation.json",),
              outputs=("o/side_step/*", "o/side_step"), limit_s=60, timeout=90))

_INPUT_OUT = {  # the input sits in the output folder under an output's name
    "plan.csv": (["plan", "{W}/o/trajectory/trajectory.csv", NP, "-o", "{W}/o"], "o/trajectory/trajectory.csv", "s"),
    "plan.summary": (["plan", "{W}/o/summary/summary.json", NP, "-o", "{W}/o"], "o/summary/summary.json", "s"),
    "walk.summary": (["walk", "{W}/o/summary/summary.json", "--no-rehearse", "-o", "{W}/o"], "o/summary/summary.json",
                     "w"),
    "route.yaml": (["route", "{W}/o/route/route.yaml", "--cache", "{CACHE}", NP, "-o", "{W}/o"], "o/route/route.yaml",
                   "t"),
    "batch.summary": (["batch", "{W}/o/summary.json", "-j", "1", NP, "-o", "{W}/o"], "o/summary.json", "s"),
    "compare.json": (["compare", "{W}/o/compare.json", "--methods", "sqp", NP, "-o", "{W}/o"], "o/compare.json", "s"),
    "ditch-curve.json": (["ditch-curve", "--scenario", "{W}/o/ditch_curve.json", *FAST_DITCH, "-j", "1", NP, "-o",
                          "{W}/o"], "o/ditch_curve.json", "s"),
    "walk-sweep.json": (["walk-sweep", "{W}/o/walk_sweep.json", *FAST_SWEEP, "-j", "1", NP, "-o", "{W}/o"],
                        "o/walk_sweep.json", "w"),
    "replan-steps.json": (["replan-steps", "{W}/o/side_step/replan_steps.json", NP, "-o", "{W}/o"],
                          "o/side_step/replan_steps.json", "s"),
}
_SOURCES = {"s": SIDE, "w": WALK, "t": TERRAIN}
for _name, (_argv, _input, _kind) in _INPUT_OUT.items():
    probe37(f"data.input-is-output.{_name}", f"{_name.split('.')[0]}: the input is {_input} (an output's name)",
            Probe("data loss", _argv, setup=_copy(_input, _SOURCES[_kind]), keep=(_input,), timeout=90))

for _where in (f"o/.jethr1-tmp-99999-{HOST}-abc", f"o/side_step/.jethr1-tmp-99999-{HOST}-abc",
               "o/.side_step.tmp-99999-abc", "o/.side_step.old-99999-abc", f".jethr1-tmp-99999-{HOST}-abc"):
    probe37(f"data.staging-like.{_where.replace('/', '_').replace(HOST, 'HOST')}",
            f"plan: a user's folder {_where} holding notes.txt",
            Probe("data loss", ["plan", SIDE, NP, "-o", "{W}/o"], expect=(0, 2),
                  setup=_all(_staging_like(_where), _mkdir("o/side_step") if "side_step/" in _where else _mkdir("o")),
                  outputs=("o/side_step", "o/side_step/trajectory.*", "o/side_step/summary.json",
                           "o/side_step/.jethr1*"),
                  keep=(f"{_where}/notes.txt", f"{_where}/summary.json"), limit_s=60, timeout=90))
probe37("data.staging-like.balance-space", "balance-space: a user's folder named like a staging folder in -o",
        Probe("data loss", ["balance-space", *SMALL_BALANCE, NP, "-o", "{W}/o"], expect=(0, 2),
              setup=_staging_like(f"o/.jethr1-tmp-99999-{HOST}-abc"),
              outputs=("o/balance_space.*", "o/summary.json", "o/.jethr1*"),
              keep=(f"o/.jethr1-tmp-99999-{HOST}-abc/notes.txt", f"o/.jethr1-tmp-99999-{HOST}-abc/summary.json"),
              limit_s=60, timeout=90))

probe37("data.user-file.record-name", "plan: a user's file named like jethr1's record in the folder",
        Probe("data loss", ["plan", SIDE, NP, "-o", "{W}/o"], setup=_text("o/side_step/.jethr1-files.json", USER),
              keep=("o/side_step/.jethr1-files.json",), timeout=60))
for _name, (_setup, _keep) in {"dangling-link": (_symlink("o", "{W}/nowhere/o"), ("o",)), "fifo": (_fifo("o"), ("o",)),
                               "file": (_text("o", USER), ("o",))}.items():
    probe37(f"data.output-folder.{_name}", f"plan -o a {_name}",
            Probe("data loss", ["plan", SIDE, NP, "-o", "{W}/o"], setup=_setup, keep=_keep, timeout=60))
probe37("data.batch.two-stems", "batch: two scenarios of one file name (their folders would collide)",
        Probe("data loss", ["batch", SIDE, "{W}/x/side_step.yaml", NP, "-o", "{W}/o"],
              setup=_copy("x/side_step.yaml", SIDE), timeout=60))
probe37("data.terrain.symlink", "terrain -o a symbolic link to a user's file",
        Probe("data loss", ["terrain", "random", "--seed", "1", "-o", "{W}/link.yaml"],
              setup=_all(_text("victim.txt", USER), _symlink("link.yaml", "{W}/victim.txt")), keep=("victim.txt",
                                                                                                     "link.yaml")))
probe37("data.terrain.fifo", "terrain -o a FIFO",
        Probe("data loss", ["terrain", "random", "--seed", "1", "-o", "{W}/pipe"], setup=_fifo("pipe"), keep=("pipe",),
              timeout=15))
def _null_device(rel: str) -> Callable[[Ctx, Path], None]:
    """A character device node like /dev/null at W/rel (as root; a FIFO otherwise). Never /dev/null itself:
    a command that replaces its output by a rename replaces the system's /dev/null with a file."""
    def make(ctx: Ctx, W: Path) -> None:
        try:
            os.mknod(W / rel, stat.S_IFCHR | 0o666, os.makedev(1, 3))
        except PermissionError:
            os.mkfifo(W / rel)
    return make


probe37("data.terrain.device", "terrain -o a device (a node like /dev/null)",
        Probe("data loss", ["terrain", "random", "--seed", "1", "-o", "{W}/null"], setup=_null_device("null"),
              keep=("null",), timeout=15))
probe37("data.terrain.dangling", "terrain -o a dangling symbolic link",
        Probe("data loss", ["terrain", "random", "--seed", "1", "-o", "{W}/dangling.yaml"],
              setup=_symlink("dangling.yaml", "{W}/nowhere/x.yaml"), keep=("dangling.yaml",)))
probe37("data.plan.summary-symlink", "plan: summary.json in the folder is a symbolic link to a user's file",
        Probe("data loss", ["plan", SIDE, NP, "-o", "{W}/o"],
              setup=_all(_text("victim.txt", USER), _symlink("o/side_step/summary.json", "{W}/victim.txt")),
              keep=("victim.txt", "o/side_step/summary.json"), timeout=60))
probe37("data.plan.mcap-is-folder", "plan: trajectory.mcap in the folder is a folder (of the user's)",
        Probe("traceback", ["plan", SIDE, NP, "-o", "{W}/o"], setup=_mkdir("o/side_step/trajectory.mcap"),
              keep=("o/side_step/trajectory.mcap/mine.txt",), timeout=60))
probe37("data.plan.csv-is-fifo", "plan: trajectory.csv in the folder is a FIFO",
        Probe("data loss", ["plan", SIDE, NP, "-o", "{W}/o"], setup=_fifo("o/side_step/trajectory.csv"),
              keep=("o/side_step/trajectory.csv",), timeout=60))
probe37("data.balance-space.csv-is-folder", "balance-space: balance_space.csv in -o is a folder",
        Probe("traceback", ["balance-space", *SMALL_BALANCE, NP, "-o", "{W}/o"], setup=_mkdir("o/balance_space.csv"),
              keep=("o/balance_space.csv/mine.txt",), timeout=60))
probe37("data.simulate.json-is-folder", "simulate: simulation.json in the plan folder is a folder",
        Probe("traceback", ["simulate", "{W}/plan", NP], setup=_all(_plan(), _mkdir("plan/simulation.json")),
              keep=("plan/simulation.json/mine.txt",), timeout=60))
probe37("data.compare.symlink", "compare: compare.json in -o is a symbolic link to a user's file",
        Probe("data loss", ["compare", SIDE, "--methods", "sqp", NP, "-o", "{W}/o"],
              setup=_all(_text("victim.txt", USER), _symlink("o/compare.json", "{W}/victim.txt")),
              keep=("victim.txt", "o/compare.json"), timeout=60))
probe37("data.batch.summary-is-folder", "batch: summary.json in -o is a folder",
        Probe("traceback", ["batch", SIDE, "-j", "1", NP, "-o", "{W}/o"], setup=_mkdir("o/summary.json"),
              keep=("o/summary.json/mine.txt",), timeout=60))
probe37("data.replan-steps.name-up", "replan-steps: a scenario name: ../escape",
        Probe("silent accept", ["replan-steps", "{W}/s.yaml", NP, "-o", "{W}/o/deep"],
              setup=_scenario("s.yaml", lambda d: d.update(name="../../escape")), timeout=60))
probe37("data.replan-steps.name-absolute", "replan-steps: a scenario name that is an absolute path",
        Probe("silent accept", ["replan-steps", "{W}/s.yaml", NP, "-o", "{W}/o"],
              setup=lambda ctx, W: _scenario("s.yaml", lambda d: d.update(name=str(W / "abs")))(ctx, W), timeout=60))
for _name, _argv in {
    "plan": ["plan", SIDE, NP, "-o", "{W}/" + _long()],
    "plan.deep": ["plan", SIDE, NP, "-o", "{W}/o/" + _long() + "/x"],
    "balance-space": ["balance-space", *SMALL_BALANCE, NP, "-o", "{W}/" + _long()],
    "walk": ["walk", WALK, "--no-rehearse", "-o", "{W}/" + _long()],
    "compare": ["compare", SIDE, "--methods", "sqp", NP, "-o", "{W}/" + _long()],
    "ditch-curve": ["ditch-curve", *FAST_DITCH, "-j", "1", NP, "-o", "{W}/" + _long()],
    "batch": ["batch", SIDE, "-j", "1", NP, "-o", "{W}/" + _long()],
    "walk-sweep": ["walk-sweep", WALK, *FAST_SWEEP, "-j", "1", NP, "-o", "{W}/" + _long()],
    "terrain": ["terrain", "random", "--seed", "1", "-o", "{W}/" + _long() + ".yaml"],
    "view": ["view", "{W}/plan", "--save", "{W}/" + _long() + ".rrd"],
    "scenario": ["plan", "{W}/" + _long(260) + ".yaml", NP, "-o", "{W}/o"],
}.items():
    probe37(f"data.long-name.{_name}", f"{_name}: a path component of 300 characters",
            Probe("traceback", _argv, setup=_plan() if _name == "view" else None, timeout=60))


# 2. hangs: a FIFO (or a device) where a file is read

_FIFO_IN = {
    "plan": ["plan", "{W}/in.yaml", NP, "-o", "{W}/o"],
    "compare": ["compare", "{W}/in.yaml", "--methods", "sqp", NP, "-o", "{W}/o"],
    "batch": ["batch", "{W}/in.yaml", "-j", "1", NP, "-o", "{W}/o"],
    "batch.manifest": ["batch", "--manifest", "{W}/in.yaml", "-j", "1", NP, "-o", "{W}/o"],
    "replan-steps": ["replan-steps", "{W}/in.yaml", NP, "-o", "{W}/o"],
    "ditch-curve": ["ditch-curve", "--scenario", "{W}/in.yaml", *FAST_DITCH, "-j", "1", NP, "-o", "{W}/o"],
    "walk": ["walk", "{W}/in.yaml", "--no-rehearse", "-o", "{W}/o"],
    "walk-sweep": ["walk-sweep", "{W}/in.yaml", *FAST_SWEEP, "-j", "1", NP, "-o", "{W}/o"],
    "route": ["route", "{W}/in.yaml", "--cache", "{CACHE}", NP, "-o", "{W}/o"],
    "verify": ["verify", "{W}/in.yaml"],
    "verify.scenario": ["verify", "{W}/plan", "--scenario", "{W}/in.yaml"],
    "view": ["view", "{W}/in.yaml", "--save", "{W}/x.rrd"],
    "robot-show": ["robot", "show", "{W}/in.yaml"],
    "balance-space.robot": ["balance-space", "--robot", "{W}/in.yaml", *SMALL_BALANCE, NP, "-o", "{W}/o"],
    "reach.robot": ["reach", "--robot", "{W}/in.yaml"],
}
for _name, _argv in _FIFO_IN.items():
    probe37(f"hang.fifo.{_name}", f"{_name}: a FIFO as its input",
            Probe("hang", _argv, setup=_all(_fifo("in.yaml"), *([_plan()] if "scenario" in _name else [])),
                  timeout=15, not_in_message=r"[Nn]o such file|missing"))
for _name, (_argv, _setup) in {
    "simulate.csv": (["simulate", "{W}/plan", NP], lambda ctx, W: (
        _plan()(ctx, W), (W / "plan/trajectory.csv").unlink(), os.mkfifo(W / "plan/trajectory.csv"))),
    "simulate.summary": (["simulate", "{W}/plan", NP], lambda ctx, W: (
        _plan()(ctx, W), (W / "plan/summary.json").unlink(), os.mkfifo(W / "plan/summary.json"))),
    "verify.mcap": (["verify", "{W}/plan"], lambda ctx, W: (_plan()(ctx, W), (W / "plan/trajectory.mcap").unlink(),
                                                            os.mkfifo(W / "plan/trajectory.mcap"))),
    "scenario.robot": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"],
                       lambda ctx, W: (_fifo("r.yaml")(ctx, W),
                                       _scenario("s.yaml", lambda d: d.update(robot=str(W / "r.yaml")))(ctx, W))),
    "robot.urdf": (["robot", "show", "{W}/r/jethr1.yaml"],
                   lambda ctx, W: (_robot("r")(ctx, W), (W / "r/jethr1.urdf").unlink(),
                                   os.mkfifo(W / "r/jethr1.urdf"))),
    "walk.robot": (["walk", "{W}/w.yaml", "--no-rehearse", "-o", "{W}/o"],
                   lambda ctx, W: (_fifo("r.yaml")(ctx, W), _text("w.yaml", _walk_yaml(
                       lambda d: d.update(robot=str(W / "r.yaml"))))(ctx, W))),
}.items():
    probe37(f"hang.fifo.{_name}", f"{_name.split('.')[0]}: a FIFO as {_name.split('.')[1]}",
            Probe("hang", _argv, setup=_setup, timeout=15, not_in_message=r"[Nn]o such file|missing"))
for _name, _argv in {
    "plan.dev-zero": ["plan", "/dev/zero", NP, "-o", "{W}/o"],
    "plan.dev-null": ["plan", "/dev/null", NP, "-o", "{W}/o"],
    "batch.manifest-dev-zero": ["batch", "--manifest", "/dev/zero", "-j", "1", NP, "-o", "{W}/o"],
    "route.dev-zero": ["route", "/dev/zero", "--cache", "{CACHE}", NP, "-o", "{W}/o"],
    "walk.dev-urandom": ["walk", "/dev/urandom", "--no-rehearse", "-o", "{W}/o"],
    "verify.dev-zero": ["verify", "/dev/zero"],
    "view.dev-zero": ["view", "/dev/zero", "--save", "{W}/x.rrd"],
    "compare.dev-zero": ["compare", "/dev/zero", "--methods", "sqp", NP, "-o", "{W}/o"],
}.items():
    probe37(f"hang.device.{_name}", f"{_name.split('.')[0]}: a device as its input",
            Probe("hang", _argv, timeout=15, not_in_message=r"[Nn]o such file|missing"))


# 3. resources: giant files, bombs, sizes that run for minutes

for _name, (_argv, _setup) in {
    "verify.sparse-csv": (["verify", "{W}/plan"], _all(_plan(), _sparse("plan/trajectory.csv", 2_500_000_000))),
    "simulate.sparse-csv": (["simulate", "{W}/plan", NP], _all(_plan(), _sparse("plan/trajectory.csv", 2_500_000_000))),
    "verify.lone-sparse-csv": (["verify", "{W}/trajectory.csv"], _sparse("trajectory.csv", 2_500_000_000)),
    "verify.sparse-mcap": (["verify", "{W}/plan"], _all(_plan(), _sparse("plan/trajectory.mcap", 3_000_000_000))),
    "simulate.sparse-mcap": (["simulate", "{W}/plan", NP], _all(_plan(), _sparse("plan/trajectory.mcap",
                                                                                   3_000_000_000))),
    "verify.mcap-bomb": (["verify", "{W}/plan"], _all(_plan(), _mcap_bomb)),
    "simulate.mcap-bomb": (["simulate", "{W}/plan", NP], _all(_plan(), _mcap_bomb)),
    "verify.lone-mcap-bomb": (["verify", "{W}/plan/trajectory.mcap"], _all(_plan(), _mcap_bomb)),
    "view.mcap-bomb": (["view", "{W}/plan", "--save", "{W}/x.rrd"], _all(_plan(), _mcap_bomb)),
    "verify.sparse-summary": (["verify", "{W}/plan"], _all(_plan(), _sparse("plan/summary.json", 2_500_000_000))),
    "plan.sparse-scenario": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"], _sparse("s.yaml", 2_500_000_000)),
    "batch.sparse-manifest": (["batch", "--manifest", "{W}/m.yaml", "-j", "1", NP, "-o", "{W}/o"],
                              _sparse("m.yaml", 2_500_000_000)),
    "robot-show.mesh-3gb": (["robot", "show", "{W}/r/jethr1.yaml"],
                            _all(_robot("r", urdf_edit=lambda u: _mesh(u, "big.stl")), _sparse("r/big.stl",
                                                                                                3_000_000_000))),
    "plan.mesh-3gb": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"],
                      lambda ctx, W: (_robot("r", urdf_edit=lambda u: _mesh(u, str(W / "r/big.stl")))(ctx, W),
                                      _sparse("r/big.stl", 3_000_000_000)(ctx, W),
                                      _scenario("s.yaml", lambda d: d.update(robot=str(W / "r/jethr1.yaml")))(ctx, W))),
    "robot-show.sparse-urdf": (["robot", "show", "{W}/r/jethr1.yaml"],
                               lambda ctx, W: (_robot("r")(ctx, W), _sparse("r/jethr1.urdf", 3_000_000_000)(ctx, W))),
    "route.sparse-cache": (["route", TERRAIN, "--cache", "{W}/cache", NP, "-o", "{W}/o"],
                           lambda ctx, W: [_sparse(f"cache/{p.relative_to(ctx.cache())}", 3_000_000_000)(ctx, W)
                                           for p in ctx.cache().rglob("*.npz")]),
    "plan.ga-limits": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"], _scenario("s.yaml", lambda d: d.update(optimiser={
        "method": "gas", "initial": {"population": 10000, "generations": 10000},
        "intermediate": {"population": 10000, "generations": 10000}}))),
    "compare.ga-limits": (["compare", "{W}/s.yaml", "--methods", "ga", NP, "-o", "{W}/o"],
                          _scenario("s.yaml", lambda d: d.update(optimiser={
                              "method": "gas", "initial": {"population": 10000, "generations": 10000}}))),
    "ditch-curve.500-scales": (["ditch-curve", "--gaps", "0.30:0.30:0.01", "--scales",
                                ",".join(f"{k / 100:g}" for k in range(500)), NP, "-o", "{W}/o"], None),
    "ditch-curve.200-gaps": (["ditch-curve", "--gaps", "0.005:1:0.005", "--scales", "0,1,2", NP, "-o", "{W}/o"],
                             None),
    "compare.1000-yaw-modes": (["compare", SIDE, "--methods", "sqp", "--yaw-modes", ",".join(["eq4", "mpc"] * 500), NP,
                                "-o", "{W}/o"], None),
    "route.tiny-spacing": (["route", "{W}/t.yaml", "--cache", "{CACHE}", NP, "-o", "{W}/o"],
                           _text("t.yaml", _terrain_yaml(lambda d: d.update(route={**d.get("route", {}),
                                                                                   "foothold_spacing_m": 0.005})))),
    "route.tiny-map": (["route", "{W}/t.yaml", "--cache", "{CACHE}", NP, "-o", "{W}/o"],
                       _text("t.yaml", _terrain_yaml(lambda d: d.update(route={**d.get("route", {}),
                                                                               "map_resolution_m": 0.005})))),
    "balance-space.resolution-0.003": (["balance-space", "--resolution", "0.003", NP, "-o", "{W}/o"], None),
    "balance-space.resolution-0.004": (["balance-space", "--resolution", "0.004", NP, "-o", "{W}/o"], None),
    "balance-space.hours": (["balance-space", "--resolution", "0.005", "--x-range", "-3", "3", "--y-range", "-3", "3",
                             NP, "-o", "{W}/o"], None),
    "simulate.trials-10000": (["simulate", "{W}/plan", "--trials", "10000", NP], _plan()),
    "walk-sweep.many": (["walk-sweep", WALK, "--steps-m", "0.01:2:0.01", NP, "-o", "{W}/o"], None),
}.items():
    probe37(f"resource.{_name}", _name.replace(".", ": ", 1), Probe("resource", _argv, setup=_setup, timeout=30))


# 4. tracebacks: integers of 5,000 digits and keys of mixed types in every YAML reader; and the rest

def _yaml_cases() -> dict[str, tuple[list[str], Callable[[Ctx, Path], None]]]:
    side = (ROOT / "configs" / "side_step.yaml").read_text()
    walk = (ROOT / "configs" / "walks" / "jethr1_walk.yaml").read_text()
    terrain = (ROOT / "configs" / "terrains" / "jet_hr1_trial.yaml").read_text()
    robot_yaml = (ROOT / "robots" / "jethr1" / "jethr1.yaml").read_text()
    out: dict[str, tuple[list[str], Callable[[Ctx, Path], None]]] = {}
    for kind, doc, argv in (("scenario", side, ["plan", "{W}/in.yaml", NP, "-o", "{W}/o"]),
                            ("compare", side, ["compare", "{W}/in.yaml", "--methods", "sqp", NP, "-o", "{W}/o"]),
                            ("ditch-curve", side, ["ditch-curve", "--scenario", "{W}/in.yaml", *FAST_DITCH, NP,
                                                   "-o", "{W}/o"]),
                            ("batch", side, ["batch", "{W}/in.yaml", "-j", "1", NP, "-o", "{W}/o"]),
                            ("replan-steps", side, ["replan-steps", "{W}/in.yaml", NP, "-o", "{W}/o"]),
                            ("walk", walk, ["walk", "{W}/in.yaml", "--no-rehearse", "-o", "{W}/o"]),
                            ("walk-sweep", walk, ["walk-sweep", "{W}/in.yaml", *FAST_SWEEP, NP, "-o", "{W}/o"]),
                            ("terrain", terrain, ["route", "{W}/in.yaml", "--cache", "{CACHE}", NP, "-o", "{W}/o"])):
        out[f"{kind}.big-int-seed"] = (argv, _text("in.yaml", re.sub(r"\nseed: \d+", f"\nseed: {BIG_INT}", doc)
                                                   if "\nseed:" in doc else doc + f"\nseed: {BIG_INT}\n"))
        out[f"{kind}.big-int-key"] = (argv, _text("in.yaml", doc + f"\n{BIG_INT}: 1\n"))
        out[f"{kind}.mixed-keys"] = (argv, _text("in.yaml", doc + "\n1: x\nzz: y\n"))
        out[f"{kind}.mixed-keys-nested"] = (argv, _text("in.yaml", doc + "\nextra:\n  1: 2\n  zz: 3\n"))
        out[f"{kind}.null-key"] = (argv, _text("in.yaml", doc + "\n~: x\n"))
        out[f"{kind}.big-int-value"] = (argv, _text("in.yaml", re.sub(r"(rate_hz|control_hz): [\d.]+",
                                                                      rf"\1: {BIG_INT}", doc)))
    out["robot.big-int"] = (["robot", "show", "{W}/r/jethr1.yaml"],
                            _text("r/jethr1.yaml", robot_yaml.replace("stall_torque_nm:", f"x: {BIG_INT}\n  "
                                                                      "stall_torque_nm:", 1)))
    out["robot.mixed-keys"] = (["robot", "show", "{W}/r/jethr1.yaml"], _text("r/jethr1.yaml",
                                                                             robot_yaml + "\n1: x\nzz: y\n"))
    out["robot.big-int-key"] = (["robot", "show", "{W}/r/jethr1.yaml"],
                                _text("r/jethr1.yaml", robot_yaml + f"\n{BIG_INT}: 1\n"))
    out["manifest.big-int"] = (["batch", "--manifest", "{W}/m.yaml", "-j", "1", NP, "-o", "{W}/o"],
                               _text("m.yaml", f"scenarios: [{BIG_INT}]\n"))
    out["manifest.mixed-keys"] = (["batch", "--manifest", "{W}/m.yaml", "-j", "1", NP, "-o", "{W}/o"],
                                  _text("m.yaml", "1: x\nscenarios: [a.yaml]\n"))
    out["manifest.not-yaml"] = (["batch", "--manifest", "{W}/m.yaml", "-j", "1", NP, "-o", "{W}/o"],
                                _text("m.yaml", b"\xff\xfe\x00junk"))
    for cmd in ("verify", "simulate"):
        extra = [NP] if cmd == "simulate" else []
        out[f"summary-yaml.{cmd}.big-int"] = ([cmd, "{W}/plan", *extra], _all(_plan(), _summary(
            "plan", lambda s: (s.update(scenario_yaml=s["scenario_yaml"] + f"\n{BIG_INT}: 1\n"),
                               s.update(scenario_file="/nowhere.yaml")))))
        out[f"summary-yaml.{cmd}.mixed-keys"] = ([cmd, "{W}/plan", *extra], _all(_plan(), _summary(
            "plan", lambda s: (s.update(scenario_yaml=s["scenario_yaml"] + "\n1: x\nzz: y\n"),
                               s.update(scenario_file="/nowhere.yaml")))))
        out[f"summary.{cmd}.nan-rate"] = ([cmd, "{W}/plan", *extra], _all(_plan(), _summary_text(
            "plan", lambda t: re.sub(r'"rate_hz": [\d.]+', '"rate_hz": NaN', t))))
        out[f"summary.{cmd}.inf-rate"] = ([cmd, "{W}/plan", *extra], _all(_plan(), _summary_text(
            "plan", lambda t: re.sub(r'"rate_hz": [\d.]+', '"rate_hz": Infinity', t))))
        out[f"summary.{cmd}.big-int-rows"] = ([cmd, "{W}/plan", *extra], _all(_plan(), _summary_text(
            "plan", lambda t: re.sub(r'"row_count": \d+', f'"row_count": {BIG_INT}', t))))
    return out


for _name, (_argv, _setup) in _yaml_cases().items():
    probe37(f"traceback.{_name}", _name.replace(".", ": ", 1), Probe("traceback", _argv, setup=_setup, timeout=30))

for _name, (_argv, _setup, _expect) in {
    "rate-1e-9.plan": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"],
                       _scenario("s.yaml", lambda d: d["timing"].update(rate_hz=1e-9)), (2,)),
    "continuous-knee.robot-show": (["robot", "show", "{W}/r/jethr1.yaml"],
                                   _robot("r", urdf_edit=lambda u: _knee(u, 'type="continuous"')), (2,)),
    "continuous-knee.plan": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"], lambda ctx, W: (
        _robot("r", urdf_edit=lambda u: _knee(u, 'type="continuous"'))(ctx, W),
        _scenario("s.yaml", lambda d: d.update(robot=str(W / "r/jethr1.yaml")))(ctx, W)), (2,)),
    "continuous-knee.reach": (["reach", "--robot", "{W}/r/jethr1.yaml"],
                              _robot("r", urdf_edit=lambda u: _knee(u, 'type="continuous"')), (2,)),
    "prismatic-knee.robot-show": (["robot", "show", "{W}/r/jethr1.yaml"],
                                  _robot("r", urdf_edit=lambda u: _knee(u, 'type="prismatic"')), (2,)),
    "view-save-missing-folder": (["view", "{W}/plan", "--save", "{W}/missing/deeper/x.rrd"], _plan(), (0, 2)),
    "route.corrupt-cache": (["route", TERRAIN, "--cache", "{W}/cache", NP, "-o", "{W}/o"],
                            lambda ctx, W: [_text(f"cache/{p.relative_to(ctx.cache())}", b"PK\x03\x04junk")(ctx, W)
                                            for p in ctx.cache().rglob("*.npz")], (0, 2)),
    "route.cache-is-file": (["route", TERRAIN, "--cache", "{W}/cache", NP, "-o", "{W}/o"],
                            _text("cache", USER), (2,)),
}.items():
    probe37(f"traceback.{_name}", _name.replace(".", ": ", 1),
            Probe("traceback", _argv, setup=_setup, expect=_expect, timeout=60,
                  outputs=("missing", "missing/*", "o", "o/*", "o/*/*", "cache/*", "cache/*/*")))


# 5. silent accepts

def _rate(r: float) -> Callable[[dict], None]:
    return lambda d: d["timing"].update(rate_hz=r)


for _name, (_argv, _setup) in {
    "rate-0.01.plan": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"], _scenario("s.yaml", _rate(0.01))),
    "rate-0.01.compare": (["compare", "{W}/s.yaml", "--methods", "sqp", NP, "-o", "{W}/o"],
                          _scenario("s.yaml", _rate(0.01))),
    "rate-0.01.ditch-curve": (["ditch-curve", "--scenario", "{W}/s.yaml", *FAST_DITCH, NP, "-o", "{W}/o"],
                              _scenario("s.yaml", _rate(0.01))),
    "rate-1e-9.compare": (["compare", "{W}/s.yaml", "--methods", "sqp", NP, "-o", "{W}/o"],
                          _scenario("s.yaml", _rate(1e-9))),
    "rate-1e-9.ditch-curve": (["ditch-curve", "--scenario", "{W}/s.yaml", *FAST_DITCH, NP, "-o", "{W}/o"],
                              _scenario("s.yaml", _rate(1e-9))),
    "rate-0.01.batch": (["batch", "{W}/s.yaml", "-j", "1", NP, "-o", "{W}/o"], _scenario("s.yaml", _rate(0.01))),
    "rate-0.01.replan-steps": (["replan-steps", "{W}/s.yaml", NP, "-o", "{W}/o"], _scenario("s.yaml", _rate(0.01))),
    "rate-0.01.route": (["route", "{W}/t.yaml", "--cache", "{CACHE}", NP, "-o", "{W}/o"],
                        _text("t.yaml", _terrain_yaml(_rate(0.01)))),
    "rate-2.plan": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"], _scenario("s.yaml", _rate(2.0))),
    "swing-0.01s.plan": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"],
                         _scenario("s.yaml", lambda d: d["timing"].update(swing_s=0.01))),
    "walk.control-1hz": (["walk", "{W}/w.yaml", "--no-rehearse", "-o", "{W}/o"],
                         _text("w.yaml", _walk_yaml(lambda d: d["timing"].update(control_hz=1)))),
    "simulate.mcap-cut": (["simulate", "{W}/plan", NP], _all(_plan(), _cut("plan/trajectory.mcap", 0.5))),
    "simulate.mcap-empty": (["simulate", "{W}/plan", NP], _all(_plan(), _text("plan/trajectory.mcap", b""))),
    "simulate.mcap-junk": (["simulate", "{W}/plan", NP], _all(_plan(), _text("plan/trajectory.mcap", b"junk" * 1000))),
    "simulate.mcap-of-a-walk": (["simulate", "{W}/plan", NP], _all(_plan(), _plan("walk", "walk"),
                                                                    _copy_file("walk/trajectory.mcap",
                                                                               "plan/trajectory.mcap"))),
    "simulate.mcap-of-another-plan": (["simulate", "{W}/plan", NP], _all(_plan(), _plan("other", "other"),
                                                                          _copy_file("other/trajectory.mcap",
                                                                                     "plan/trajectory.mcap"))),
    "simulate.csv-of-another-plan": (["simulate", "{W}/plan", NP], _all(_plan(), _plan("other", "other"),
                                                                         _copy_file("other/trajectory.csv",
                                                                                    "plan/trajectory.csv"))),
    "simulate.another-scenario": (["simulate", "{W}/plan", NP], _all(_plan(), _summary("plan", lambda s: (
        s.update(scenario_file=str(ROOT / "configs" / "forward_ditch_robust.yaml")))))),
    "simulate.another-scenario-yaml": (["simulate", "{W}/plan", NP], _all(_plan(), _summary("plan", lambda s: (
        s.update(scenario_file="/nowhere.yaml",
                 scenario_yaml=(ROOT / "configs" / "forward_ditch_robust.yaml").read_text()))))),
    "verify.mcap-of-another-plan": (["verify", "{W}/plan"], _all(_plan(), _plan("other", "other"),
                                                                 _copy_file("other/trajectory.mcap",
                                                                            "plan/trajectory.mcap"))),
    "view.mcap-of-another-plan": (["view", "{W}/plan", "--save", "{W}/x.rrd"],
                                  _all(_plan(), _plan("other", "other"), _copy_file("other/trajectory.mcap",
                                                                                    "plan/trajectory.mcap"))),
    "replan-steps.name-dots": (["replan-steps", "{W}/s.yaml", NP, "-o", "{W}/o"],
                               _scenario("s.yaml", lambda d: d.update(name=".."))),
    "verify.nan-in-summary": (["verify", "{W}/plan"], _all(_plan(), _summary_text(
        "plan", lambda t: re.sub(r'"peak_thrust_n": [\d.]+', '"peak_thrust_n": NaN', t, count=1)))),
    "simulate.nan-in-summary": (["simulate", "{W}/plan", NP], _all(_plan(), _summary_text(
        "plan", lambda t: re.sub(r'"peak_thrust_n": [\d.]+', '"peak_thrust_n": NaN', t, count=1)))),
    "robot.shank-1e30.show": (["robot", "show", "{W}/r/jethr1.yaml"],
                              _robot("r", urdf_edit=lambda u: _mass(_mass(u, "left_shank", "1e30"), "right_shank",
                                                                    "1e30"))),
    "robot.shank-1e30.plan": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"], lambda ctx, W: (
        _robot("r", urdf_edit=lambda u: _mass(_mass(u, "left_shank", "1e30"), "right_shank", "1e30"))(ctx, W),
        _scenario("s.yaml", lambda d: d.update(robot=str(W / "r/jethr1.yaml")))(ctx, W))),
    "robot.shank-0.show": (["robot", "show", "{W}/r/jethr1.yaml"],
                           _robot("r", urdf_edit=lambda u: _mass(_mass(u, "left_shank", "0"), "right_shank", "0"))),
    "robot.trunk-1e-30.show": (["robot", "show", "{W}/r/jethr1.yaml"],
                               _robot("r", urdf_edit=lambda u: _mass(u, "trunk", "1e-30"))),
    "robot.trunk-1e-30.walk": (["walk", "{W}/w.yaml", "--no-rehearse", "-o", "{W}/o"], lambda ctx, W: (
        _robot("r", urdf_edit=lambda u: _mass(u, "trunk", "1e-30"))(ctx, W),
        _text("w.yaml", _walk_yaml(lambda d: d.update(robot=str(W / "r/jethr1.yaml"))))(ctx, W))),
    "robot.xml-entity.show": (["robot", "show", "{W}/r/jethr1.yaml"], _robot("r", urdf_edit=_entity)),
    "robot.zero-inertia.show": (["robot", "show", "{W}/r/jethr1.yaml"], _robot("r", urdf_edit=lambda u: re.sub(
        r'(<link name="left_shank">.*?<inertia )[^/]*/>', r'\1ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>', u,
        count=1, flags=re.S))),
}.items():
    probe37(f"silent.{_name}", _name.replace(".", ": ", 1), Probe("silent accept", _argv, setup=_setup, timeout=60))


# 6. wrong exit, leftovers, messages

#: a small carton field: its balance-space maps (5 cm) are computed in seconds by a pool of workers (no cache)
SMALL_TERRAIN = """\
name: small
robot: jethr1
terrain:
  cartons:
    - {name: start_left, top_centre_m: [0.0, 0.1125, 0.0]}
    - {name: start_right, top_centre_m: [0.0, -0.1125, 0.0]}
    - {name: a, top_centre_m: [0.3, 0.1125, 0.0]}
    - {name: b, top_centre_m: [0.3, -0.1125, 0.0]}
    - {name: goal, top_centre_m: [0.6, 0.0, 0.0], size_m: [0.21, 0.4, 0.14]}
goal: {region: {x_m: [0.495, 0.705], y_m: [-0.2, 0.2]}}
balance: {policy: robust, thrust_max_n: 23.0, sole_margin_m: 0.005}
timing: {swing_s: 2.0, transfer_s: 1.0, rate_hz: 20.0}
route: {map_resolution_m: 0.05, samples: 10}
"""

for _name, (_argv, _n, _after) in {
    "simulate": (["simulate", "{W}/plan", "--trials", "6", "-j", "2", NP], 3, 4.0),
    "batch": (["batch", SIDE, "{W}/s2.yaml", "-j", "2", NP, "-o", "{W}/o"], 3, 4.0),
    "route": (["route", "{W}/small.yaml", "--cache", "{W}/cold", "-j", "2", NP, "-o", "{W}/o"], 3, 4.0),
    "walk-sweep": (["walk-sweep", WALK, "--steps-m", "0.10:0.14:0.01", "--rotation", "none", "--no-rehearse",
                    "-j", "2", NP, "-o", "{W}/o"], 3, 4.0),
    "ditch-curve": (["ditch-curve", "--gaps", "0.30:0.33:0.01", "--scales", "0", "-j", "2", NP, "-o", "{W}/o"], 3,
                    4.0),
    "compare-pareto": (["compare", SIDE, "--pareto", "--methods", "sqp", "-j", "2", NP, "-o", "{W}/o"], 3, 4.0),
    "balance-space": (["balance-space", "--resolution", "0.02", "-j", "2", NP, "-o", "{W}/o"], 3, 4.0),
}.items():
    probe37(f"exit.kill9.{_name}", f"kill -9 {_name} once its workers run: none left",
            Probe("exit/leftover/message", _argv, timeout=120, kill9=_procs_at_least(_n), kill9_after=_after,
                  setup=_all(_plan(), _copy("s2.yaml", "{ROOT}/configs/forward_ditch_robust.yaml"),
                             _text("small.yaml", SMALL_TERRAIN))))


@case("37.exit.replan-while-simulating", "plan re-writes a folder while simulate rehearses it: no stale rehearsal")
def _(ctx: Ctx) -> dict:
    W = ctx.fresh("p37/exit.replan-while-simulating")
    _plan("o/side_step")(ctx, W)
    t0 = time.perf_counter()
    sim = _popen([ctx.jethr1, "simulate", str(W / "o" / "side_step"), "--trials", "3", "-j", "1", NP],
                 stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=W)
    time.sleep(1.5)
    plan = _popen([ctx.jethr1, "plan", str(ROOT / "configs" / "side_step.yaml"), "--policy", "minimal", NP, "-o",
                   str(W / "o")], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=W)
    plan_err = plan.communicate(timeout=300)[1].decode()
    sim_err = sim.communicate(timeout=300)[1].decode()
    seconds = time.perf_counter() - t0
    o = Outcome(sim.returncode, sim_err, "", seconds, 0.0, 0, None)
    problems = [] if plan.returncode == 0 else [f"plan exit {plan.returncode}: {plan_err[-200:]}"]
    folder = W / "o" / "side_step"
    if (folder / "simulation.json").exists():
        doc = json.loads((folder / "simulation.json").read_text())
        summary = json.loads((folder / "summary.json").read_text())
        if doc.get("plan", {}) if isinstance(doc.get("plan"), dict) else None:
            pass
        digests = summary.get("files")
        if not digests or doc.get("plan_files") != digests:
            problems.append("a rehearsal of the old plan left beside the new plan")
    if sim.returncode == 2 and len([ln for ln in sim_err.splitlines() if ln.strip()]) != 1:
        problems.append("simulate exit 2 with more than one line")
    if "Traceback" in sim_err:
        problems.append("traceback")
    return report(o, cls="exit/leftover/message", ok=not problems, problems=problems, plan_exit=plan.returncode)


PROBES["exit.replan-while-simulating"] = Probe("exit/leftover/message", [])

for _name, (_argv, _setup) in {
    "loop.plan": (["plan", "{W}/loop.yaml", NP, "-o", "{W}/o"], _symlink("loop.yaml", "{W}/loop.yaml")),
    "loop.verify": (["verify", "{W}/loop"], _symlink("loop", "{W}/loop")),
    "loop.walk": (["walk", "{W}/loop.yaml", "--no-rehearse", "-o", "{W}/o"], _symlink("loop.yaml", "{W}/loop.yaml")),
    "loop.robot-show": (["robot", "show", "{W}/loop.yaml"], _symlink("loop.yaml", "{W}/loop.yaml")),
    "loop.simulate": (["simulate", "{W}/loop", NP], _symlink("loop", "{W}/loop")),
    "loop.route": (["route", "{W}/loop.yaml", "--cache", "{CACHE}", NP, "-o", "{W}/o"],
                   _symlink("loop.yaml", "{W}/loop.yaml")),
    "device.plan": (["plan", "/dev/zero", NP, "-o", "{W}/o"], None),
    "fifo.verify-csv": (["verify", "{W}/trajectory.csv"], _fifo("trajectory.csv")),
    "robot-empty.plan": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"], _scenario("s.yaml", lambda d: d.update(robot=""))),
    "robot-empty.walk": (["walk", "{W}/w.yaml", "--no-rehearse", "-o", "{W}/o"],
                         _text("w.yaml", _walk_yaml(lambda d: d.update(robot="")))),
    "robot-empty.terrain": (["route", "{W}/t.yaml", "--cache", "{CACHE}", NP, "-o", "{W}/o"],
                            _text("t.yaml", _terrain_yaml(lambda d: d.update(robot="")))),
    "robot-dot.plan": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"], _scenario("s.yaml", lambda d: d.update(robot="."))),
    "balance-space.robot-empty": (["balance-space", "--robot", "", *SMALL_BALANCE, NP, "-o", "{W}/o"], None),
    "mesh-junk.robot-show": (["robot", "show", "{W}/r/jethr1.yaml"], _all(
        _robot("r", urdf_edit=lambda u: _mesh(u, "m.stl")), _text("r/m.stl", "solid junk\n"))),
    "mesh-missing.robot-show": (["robot", "show", "{W}/r/jethr1.yaml"],
                                _robot("r", urdf_edit=lambda u: _mesh(u, "none.stl"))),
    "mesh-package.robot-show": (["robot", "show", "{W}/r/jethr1.yaml"],
                                _robot("r", urdf_edit=lambda u: _mesh(u, "package://jethr1/m.stl"))),
    "robot-1e30.plan-exit": (["plan", "{W}/s.yaml", NP, "-o", "{W}/o"], lambda ctx, W: (
        _robot("r", urdf_edit=lambda u: re.sub(r'<mass value="[^"]+"', '<mass value="1e30"', u))(ctx, W),
        _scenario("s.yaml", lambda d: d.update(robot=str(W / "r/jethr1.yaml")))(ctx, W))),
}.items():
    probe37(f"exit.{_name}", _name.replace(".", ": ", 1),
            Probe("exit/leftover/message", _argv, setup=_setup, timeout=30,
                  not_in_message=r"\.cpp|From file" if _name.startswith("mesh") else
                  r"[Nn]o such file|missing|current folder|\.cpp|out of reach|unknown robot \(known"))


def probe_summary(results: dict) -> str:
    """Per class: the issue-37 cases that pass, of those run; and the names of those that fail."""
    lines = ["| class | pass | fail |", "| --- | --- | --- |"]
    failing = []
    for cls in CLASSES:
        rs = {k: r for k, r in results.items() if r.get("cls") == cls}
        ok = sum(bool(r.get("ok")) for r in rs.values())
        lines.append(f"| {cls} | {ok} | {len(rs) - ok} |")
        failing += [f"  {k}: {'; '.join(r.get('problems', []))}" for k, r in rs.items() if not r.get("ok")]
    total = [r for r in results.values() if "cls" in r]
    lines.append(f"| all | {sum(bool(r.get('ok')) for r in total)} | {sum(not r.get('ok') for r in total)} |")
    return "\n".join([*lines, "", "failing:", *failing])



# --- main ---------------------------------------------------------------------------------------


def _cell(r: dict | None) -> str:
    """One result as a table cell: exit code, what else went wrong or was kept."""
    if r is None or "exit" not in r:
        return "-" if r is None else r.get("skipped", r.get("harness_error", "?"))
    first = r.get("first_output_s")
    said = "silent" if first is None else f"first line at {first:.1f} s"
    if r.get("stopped"):
        return f"stopped ({r['stopped']}: {r['seconds']:.0f} s, {r['peak_mb']} MB, {r['procs']} processes, {said})"
    out = [f"**{r['exit']}**"]
    if r.get("traceback"):
        out.append("traceback")
    elif r.get("lines") is not None:
        out.append(f"{r['lines']} line{'s' if r['lines'] != 1 else ''}")
    if "user_file_kept" in r:
        out.append("notes kept" if r["user_file_kept"] else "**notes lost**")
    if r.get("written"):
        out.append(f"left {', '.join(r['written'][:2])}")
    if r.get("not_0644"):
        out.append(f"not 0644: {', '.join(r['not_0644'])}")
    if first is not None and first > 2:
        out.append(said)
    out.append(f"{r['seconds']:.1f} s")
    if r.get("peak_mb", 0) >= 300:
        out.append(f"{r['peak_mb']} MB")
    return ", ".join(out)


def table(before: dict, after: dict) -> str:
    """A markdown table: each case, before and after."""
    rows = ["| case | before | after |", "|---|---|---|"]
    for cid, r in after.items():
        rows.append(f"| {cid} {r['what']} | {_cell(before.get(cid))} | {_cell(r)} |")
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jethr1", default=str(ROOT / ".venv" / "bin" / "jethr1"))
    ap.add_argument("--only", default="", help="comma-separated case ids or prefixes")
    ap.add_argument("--json", default=None, help="write the results here")
    ap.add_argument("--timeout", type=float, default=120.0)
    ap.add_argument("--max-mb", type=float, default=3000.0)
    ap.add_argument("--work", default=None)
    ap.add_argument("--table", nargs=2, metavar=("BEFORE.json", "AFTER.json"),
                    help="print the markdown table of two runs' results and stop")
    ap.add_argument("--summary", metavar="RESULTS.json", help="print the issue-37 counts of a run's results and stop")
    args = ap.parse_args(argv)
    if args.table:
        print(table(*(json.loads(Path(p).read_text()) for p in args.table)))
        return
    if args.summary:
        print(probe_summary(json.loads(Path(args.summary).read_text())))
        return
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="safety-"))
    ctx = Ctx(args.jethr1, work, args.timeout, args.max_mb)
    wanted = [w for w in args.only.split(",") if w]
    mounts = unshare_ok()
    results = {}
    for cid, (what, fn) in CASES.items():
        if wanted and not any(cid == w or cid.startswith(w) for w in wanted):
            continue
        if not mounts and ("mount" in cid or "readonly" in cid or "full-disk" in cid):
            results[cid] = {"what": what, "skipped": "no unshare -rm here"}
            continue
        try:
            res = fn(ctx)
        except Exception as exc:  # a harness problem, not the program's
            res = {"harness_error": f"{type(exc).__name__}: {exc}"}
        res = {"what": what, **res}
        results[cid] = res
        verdict = "" if "ok" not in res else ("ok   " if res["ok"] else "FAIL ")
        print(f"{verdict}{cid:38s} exit {res.get('exit')!s:>4s} lines {res.get('lines', '-')!s:>3s} "
              f"{'TRACEBACK ' if res.get('traceback') else ''}{res.get('stopped', '')} "
              f"{res.get('seconds', '-')} s {res.get('peak_mb', '-')} MB  {res.get('last_line', '')[:110]}"
              + (f"  [{'; '.join(res.get('problems', []))}]" if res.get("problems") else ""), flush=True)
        if args.json:
            Path(args.json).write_text(json.dumps(results, indent=1))
    if any("cls" in r for r in results.values()):
        print(probe_summary(results))
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
