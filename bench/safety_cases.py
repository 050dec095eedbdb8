"""Issue 25's cases, run as a new user would: every command with files it must not lose, resources it
must not run away with, robot folders and plan folders tampered with. Each case runs ``jethr1`` in
its own process group and reports its exit code, the lines it printed on stderr, whether a traceback
appeared, its wall time, the peak memory of its process tree and what it left on disk.

    .venv/bin/python bench/safety_cases.py [--jethr1 PATH] [--only ID,ID] [--json OUT.json]
    .venv/bin/python bench/safety_cases.py --table BEFORE.json AFTER.json    # the table of docs/safety.md

``--jethr1`` picks the program under test (default: this checkout's), so the same cases measure an
older commit (``git worktree add ../before <commit>`` with its own venv). Mount points are real
tmpfs mounts in a private mount namespace (``unshare -rm``); cases that need one are skipped where
that is not allowed. A case is stopped at ``--timeout`` seconds or when its processes hold more than
``--max-mb`` MB together (reported as such: "stopped").
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import shlex
import shutil
import signal
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
            if int(fields[3]) != sid:  # session id
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

    @property
    def lines(self) -> list[str]:
        return [ln for ln in self.stderr.splitlines() if ln.strip()]

    @property
    def traceback(self) -> bool:
        return "Traceback" in self.stderr


def _default_signals() -> None:
    """In the child: SIGINT as a terminal gives it (a harness started in the background ignores it)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def run_cmd(argv: list[str], timeout: float = 120.0, max_mb: float = 3000.0, cwd: Path | None = None,
            stdout=None, signal_after: tuple[float | Callable[[], bool], int] | None = None,
            env: dict | None = None) -> Outcome:
    """Run ``argv`` in a new session, watch its memory, stop it at ``timeout`` or ``max_mb``;
    ``signal_after`` = (seconds or a condition, signal) sends a signal to the process group after that
    long or once the condition holds."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=stdout if stdout is not None else subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True, cwd=cwd, env=env, preexec_fn=_default_signals)
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
    for t in threads:
        t.join(timeout=5)
    with contextlib.suppress(ProcessLookupError, PermissionError):  # workers the run left behind
        os.killpg(proc.pid, signal.SIGKILL)
    return Outcome(None if stopped else proc.returncode, b"".join(err_chunks).decode("utf-8", "replace"),
                   b"".join(out_chunks).decode("utf-8", "replace"), seconds, peak, procs,
                   first[0] if first else None, stopped)


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
    "nan-fan-thrust.show": ("show", lambda d: d["fans"][0].update(max_thrust_n=float("nan")), None),
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
    args = ap.parse_args(argv)
    if args.table:
        print(table(*(json.loads(Path(p).read_text()) for p in args.table)))
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
        print(f"{cid:38s} exit {res.get('exit')!s:>4s} lines {res.get('lines', '-')!s:>3s} "
              f"{'TRACEBACK ' if res.get('traceback') else ''}{res.get('stopped', '')} "
              f"{res.get('seconds', '-')} s {res.get('peak_mb', '-')} MB  {res.get('last_line', '')[:110]}",
              flush=True)
        if args.json:
            Path(args.json).write_text(json.dumps(results, indent=1))
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
