"""The balance-space sweep (issue 28): each figure a ratio measured in this run, plus absolute times.

Sections (all by default; name some on the command line to run only those):

* ``kernel``: the compiled objective against the numpy functions it fuses.
* ``search``: four layers of the 1 cm grid with each of the search's savings switched off, against the default
  (evaluations and CPU time; whether the cells stay the same).
* ``timing``: ``jethr1 balance-space`` at 1 cm as a whole command on 2 processes (wall time, peak memory of the
  command and its workers), then both supports' sweeps in process (CPU time of every task; the wall time two quiet
  cores would take, scheduled from those times).
* ``mirror``: the left support's space against the right's at the mirror image, every cell.
* ``agreement``: the continuation against the exhaustive search on both supports: 1,000 random cells each, and
  the cells where the two most likely disagree (``balance_space.agreement.suspect_cells``).
* ``limit``: the 1 cm command inside a memory limit of 300 MB (and 250, 225, 200 MB; ``-j 1`` in 225, 200), as a
  container or
  ``systemd-run -p MemoryMax=`` runs it: a memory cgroup, the page cache dropped before each run so that every page
  the command reads is charged to it; its wall time against the same run without a limit (needs root and a
  writable memory cgroup, v1 or v2; says so otherwise).
* ``scale``: the 0.5 cm sweep on 2 processes; a local Dask cluster of 1, 2, ... workers at 1 cm (as many as
  there are cores: more cannot run faster here); the speed-up 1, 2, 4, 8, 16 workers would get, from the
  measured task times (critical path and greedy schedule: ``balance_space.blocks.makespan``).

CPU times are per task (``time.process_time`` in the worker): other programs on the machine inflate wall times,
not these (much). ``python bench/bench_balance_space.py timing mirror`` runs two sections.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import jethr1_plan.arithmetic  # noqa: F401  (first: NumPy's and OpenBLAS's kernels pinned before they load)

import numpy as np

from jethr1_plan.balance_space.agreement import (
    AGREE_N,
    REFERENCE_GRID_M,
    agree,
    exhaustive_cells,
    mirror_report,
    searchable,
    suspect_cells,
)
from jethr1_plan.balance_space.blocks import TaskTimes, makespan
from jethr1_plan.balance_space.spec import SearchSettings
from jethr1_plan.balance_space.sweep import SweepResult, SweepSpec, sweep, sweep_layers
from jethr1_plan.io.forked import fork_available
from jethr1_plan.optimisers.search import FINE_DIRECTIONS, INTO_REACH, Evaluator
from jethr1_plan.reasons import Reason

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.physics.test_compiled import numpy_objective  # the numpy path the test compares with

WORKERS = (1, 2, 4, 8, 16)
TARGET_MB = 300  # peak memory of the 1 cm command on 2 processes (issue 28)
LIMITS_MB = ((2, 300), (2, 250), (2, 225), (2, 200), (1, 225), (1, 200))  # (--jobs, limit [MB]), 1 cm
EXECUTOR = "fork" if fork_available() else "loky"  # the command's default
JETHR1 = str(Path(sys.executable).with_name("jethr1"))


def spec_of(side: str, resolution: float) -> SweepSpec:
    """The command's default sweep of ``side``'s support (the left's grid the mirror image of the right's)."""
    return SweepSpec(resolution_m=resolution, support_side=side,
                     y_range=(-0.9, 0.8) if side == "right" else (-0.8, 0.9))


def kernel_speed(n: int = 200_000) -> None:
    spec = spec_of("right", 0.01)
    ev = Evaluator(spec.model, spec.support_stance())
    rng = np.random.default_rng(0)
    swing = np.column_stack([rng.uniform(-0.6, 0.7, 2000), rng.uniform(-0.7, 0.6, 2000), rng.uniform(0, 0.3, 2000)])
    cells = ev.cells(swing)
    idx = rng.integers(0, len(swing), n)
    P = (ev.support + swing[idx]) / 2 + np.column_stack([rng.normal(0, 0.08, n), rng.normal(0, 0.08, n),
                                                         rng.uniform(0.15, 0.45, n)])
    ev(cells, idx[:10], P[:10])  # compile
    best = {}
    for name, fn in (("compiled", lambda: ev(cells, idx, P)), ("numpy", lambda: numpy_objective(ev, cells, idx, P))):
        times = []
        for _ in range(5):
            t0 = time.process_time()
            fn()
            times.append(time.process_time() - t0)
        best[name] = min(times) / n * 1e9
    print(f"objective per candidate (best of 5, {n:,} candidates, CPU time): compiled {best['compiled']:.0f} ns, "
          f"numpy {best['numpy']:.0f} ns, ratio {best['numpy'] / best['compiled']:.1f}")


def search_savings() -> None:
    """Four layers (z = 0.08..0.11 m) of the 1 cm grid in one block, each saving switched off in turn."""
    spec = spec_of("right", 0.01)
    zs = tuple(float(z) for z in spec.axes()[2][8:12])
    base = sweep_layers(spec, zs)
    print(f"search, 4 layers ({len(base.swing):,} cells, one block, one process): default {base.evaluations:,} "
          f"evaluations, {base.cpu_s:.1f} s CPU, {np.count_nonzero(base.reason == Reason.OK)} members")
    variants = {
        "offer every optimum on every pass": SearchSettings(offer_once=False),
        "complete compass polls": SearchSettings(poll_chunk=len(FINE_DIRECTIONS)),
        "search into the reach balls only": SearchSettings(search_level=INTO_REACH, polish_level=INTO_REACH),
        "no forward-pass marks": SearchSettings(forward_marks=False),
        "search cells at zero thrust": SearchSettings(skip_zero=False),
        "no hip-yaw gate": SearchSettings(hip_yaw_gate=False),
    }
    for name, settings in variants.items():
        r = sweep_layers(spec, zs, settings)
        same = agree(base.thrust, base.reason, r.thrust, r.reason)
        both = (base.reason == Reason.OK) & (r.reason == Reason.OK)
        print(f"  {name}: {r.evaluations / base.evaluations:.2f}x evaluations, {r.cpu_s / base.cpu_s:.2f}x CPU; "
              f"members {np.count_nonzero(r.reason == Reason.OK)}, {np.count_nonzero(~same)} cells differ "
              f"(> {AGREE_N} N or membership), mean thrust of common members "
              f"{np.mean(r.thrust[both] - base.thrust[both]):+.4f} N")


class TreeMemory:
    """The peak memory of a process and all its descendants, sampled every 50 ms: the sum of their RSS (shared
    pages counted in each), of their PSS (shared pages divided among their sharers) and of the part of the PSS not
    backed by a file (``Pss_Anon`` + ``Pss_Shmem``: what the system cannot reclaim without swap; the rest is code
    and data mapped from the libraries' files, which it drops under pressure and reads again when needed)."""

    def __init__(self, pid: int):
        import psutil

        self.root = psutil.Process(pid)
        self.rss = self.pss = self.unfiled = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._poll, daemon=True)
        self._thread.start()

    def _poll(self) -> None:
        import psutil

        while not self._stop.is_set():
            try:
                procs = [self.root, *self.root.children(recursive=True)]
            except psutil.Error:
                break
            rss = pss = unfiled = 0
            for p in procs:
                try:
                    m = p.memory_full_info()
                except psutil.Error:
                    continue
                rss, pss, unfiled = rss + m.rss, pss + m.pss, unfiled + _unfiled_bytes(p.pid)
            self.rss, self.pss, self.unfiled = max(self.rss, rss), max(self.pss, pss), max(self.unfiled, unfiled)
            self._stop.wait(0.05)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()


def _unfiled_bytes(pid: int) -> int:
    """``Pss_Anon`` + ``Pss_Shmem`` of ``pid`` [B] (0 where it has ended)."""
    try:
        with open(f"/proc/{pid}/smaps_rollup") as f:
            return sum(int(line.split()[1]) * 1024 for line in f if line.startswith(("Pss_Anon:", "Pss_Shmem:")))
    except (OSError, ValueError):
        return 0


def whole_command(resolution: float, jobs: int, side: str = "right") -> None:
    """The command from the shell twice: once alone for its wall time, once with its memory sampled (reading every
    process's page map 20 times a second takes CPU from the sweep, so that run's wall time is not the command's)."""
    with tempfile.TemporaryDirectory() as tmp:
        args = [JETHR1, "balance-space", "--support", side, "--resolution", str(resolution), "-j", str(jobs),
                "--no-progress", "-o", str(Path(tmp) / "out")]
        t0 = time.perf_counter()
        subprocess.run(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        wall = time.perf_counter() - t0
        proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        mem = TreeMemory(proc.pid)
        _, err = proc.communicate()
        mem.stop()
        if proc.returncode:
            raise RuntimeError(err)
        print(f"jethr1 balance-space --resolution {resolution} -j {jobs} (whole command): {wall:.1f} s wall; peak "
              f"memory of the command and its processes (a second run, sampled) {mem.pss / 2**20:.0f} MB PSS, "
              f"{mem.pss / 2**20 / TARGET_MB:.2f} of the {TARGET_MB} MB target ({mem.rss / 2**20:.0f} MB RSS summed), "
              f"of it not backed by a file {mem.unfiled / 2**20:.0f} MB ({mem.unfiled / 2**20 / TARGET_MB:.2f})")


class MemoryCgroup:
    """A memory cgroup of its own (v1 or v2, made under the mounted hierarchy; root only) that one command at a
    time runs in, as ``docker run --memory`` or ``systemd-run -p MemoryMax=`` would run it. :meth:`made` gives
    None where none can be made here."""

    def __init__(self, path: Path, v2: bool):
        self.path, self.v2 = path, v2

    @classmethod
    def made(cls) -> MemoryCgroup | None:
        name = f"jethr1-bench-{os.getpid()}"
        for base, v2 in ((Path("/sys/fs/cgroup/memory"), False), (Path("/sys/fs/cgroup"), True),
                         (Path("/sys/fs/cgroup/unified"), True)):
            try:
                (base / name).mkdir()
            except OSError:
                continue
            cg = cls(base / name, v2)
            if (cg.path / ("memory.max" if v2 else "memory.limit_in_bytes")).exists():
                return cg
            cg.remove()
        return None

    def _write(self, name: str, value: str) -> None:
        (self.path / name).write_text(value)

    def _read(self, name: str) -> str:
        try:
            return (self.path / name).read_text()
        except OSError:
            return ""

    def stat(self, key: str) -> int:
        for line in self._read("memory.stat").splitlines():
            k, _, v = line.partition(" ")
            if k == key:
                return int(v)
        return 0

    def run(self, args: list[str], limit_mb: int | None, timeout_s: float) -> dict:
        """``args`` run in the cgroup under ``limit_mb`` (None: no limit), the page cache dropped first (so that
        the libraries it reads are charged to it, as on a machine that has not run it before): exit code (None:
        still running after ``timeout_s``, then killed), wall time [s], peak usage [MB], the times the limit was
        hit and the file pages read again after they were dropped."""
        limit = str(limit_mb * 2**20) if limit_mb else "max" if self.v2 else "-1"
        self._write("memory.max" if self.v2 else "memory.limit_in_bytes", limit)
        if not self.v2:
            self._write("memory.max_usage_in_bytes", "0")
            self._write("memory.failcnt", "0")
        refaults0 = self.stat("workingset_refault_file")
        os.sync()
        try:
            Path("/proc/sys/vm/drop_caches").write_text("3")
        except OSError:
            print("  (the page cache could not be dropped: pages read before this run are not charged to it)")
        procs = self.path / "cgroup.procs"
        t0 = time.perf_counter()
        proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                preexec_fn=lambda: procs.write_text(str(os.getpid())))
        try:
            _, err = proc.communicate(timeout=timeout_s)
            code: int | None = proc.returncode
        except subprocess.TimeoutExpired:
            err, code = "", None
        wall = time.perf_counter() - t0
        self.kill_all()
        proc.wait()
        peak = self._read("memory.peak" if self.v2 else "memory.max_usage_in_bytes").strip()
        hits = self._read("memory.failcnt").strip() if not self.v2 else \
            next((line.split()[1] for line in self._read("memory.events").splitlines() if line.startswith("max ")), "0")
        last = (err.strip().splitlines() or [""])[-1]
        return {"code": code, "wall_s": wall, "peak_mb": int(peak or 0) / 2**20, "hits": int(hits or 0),
                "refaults": self.stat("workingset_refault_file") - refaults0, "last": last}

    def kill_all(self) -> None:
        for _ in range(50):
            pids = [int(p) for p in self._read("cgroup.procs").split()]
            if not pids:
                return
            for pid in pids:
                with contextlib.suppress(OSError):
                    os.kill(pid, 9)
            time.sleep(0.1)

    def remove(self) -> None:
        self.kill_all()
        with contextlib.suppress(OSError):
            self.path.rmdir()


def section_limit(results: dict) -> None:
    """The 1 cm command in memory limits (see the module); each run's wall time against the run without one."""
    cg = MemoryCgroup.made()
    if cg is None:
        print("memory limit: not measured here (needs root and a writable memory cgroup, v1 or v2)")
        return
    try:
        with tempfile.TemporaryDirectory() as tmp:
            def args(jobs: int) -> list[str]:
                return [JETHR1, "balance-space", "--resolution", "0.01", "-j", str(jobs), "--no-progress", "-o",
                        str(Path(tmp) / "out")]

            free = cg.run(args(2), None, 600)
            if free["code"] != 0:
                raise RuntimeError(f"the 1 cm command failed without a limit: {free['last']}")
            print(f"1 cm command, -j 2, page cache dropped, no memory limit: {free['wall_s']:.1f} s wall, peak "
                  f"{free['peak_mb']:.0f} MB charged (with the page cache of everything it read and wrote)")
            for jobs, mb in LIMITS_MB:
                shutil.rmtree(Path(tmp) / "out", ignore_errors=True)
                r = cg.run(args(jobs), mb, 3 * free["wall_s"])
                how = (f"done in {r['wall_s']:.1f} s ({r['wall_s'] / free['wall_s']:.2f} of the run without a "
                       f"limit on 2 processes)" if r["code"] == 0 else
                       f"did not end within {r['wall_s']:.0f} s (pages dropped and read again over and over): "
                       "killed" if r["code"] is None else f"exit {r['code']}: {r['last'][:100]}...")
                print(f"  -j {jobs} in {mb} MB: {how}; the limit reached {r['hits']:,} times, {r['refaults']:,} "
                      "file pages read again after they were dropped")
    finally:
        cg.remove()


def timed_sweep(side: str, resolution: float, jobs: int, executor: str = EXECUTOR) -> tuple[SweepResult, float]:
    t0 = time.perf_counter()
    r = sweep(spec_of(side, resolution), jobs=jobs, executor=executor)
    return r, time.perf_counter() - t0


def describe_times(label: str, times: TaskTimes, wall: float, jobs: int, target_s: float | None = None) -> None:
    stages = ", ".join(str(len(s)) for s in times.stages)
    pass1 = np.array(times.stages[0])
    two = makespan(times, 2)
    goal = f" (target < {target_s:.0f} s)" if target_s else ""
    print(f"{label}: {wall:.1f} s wall on {jobs} processes; tasks {times.total_s:.1f} s CPU in all, stages of "
          f"[{stages}] tasks, the first pass's {pass1.sum():.1f} s (longest task {pass1.max():.2f} s), boundary "
          f"rounds {times.total_s - pass1.sum():.1f} s; on 2 quiet cores (scheduled from the task times) "
          f"{two:.1f} s{goal}; wall/2-core schedule {wall / two:.2f}")


def section_timing(results: dict) -> None:
    whole_command(0.01, 2)
    for side in ("right", "left"):
        r, wall = timed_sweep(side, 0.01, 2)
        results[side] = r
        w = int(np.count_nonzero(r.with_thrust))
        describe_times(f"sweep 1 cm, {side} support ({len(r.reason):,} cells, {w:,} members, {r.evaluations:,} "
                       f"evaluations)", r.extra["task_times"], wall, 2, 30.0)


def section_mirror(results: dict) -> None:
    for side in ("right", "left"):
        if side not in results:
            results[side] = timed_sweep(side, 0.01, 2)[0]
    r, lft = results["right"], results["left"]
    m = mirror_report(r.spec, r.thrust, r.reason, r.p_body, lft.spec, lft.thrust, lft.reason, lft.p_body)
    print(f"mirror, 1 cm, every cell ({m.cells:,}): {m.membership_differs} differ in membership, {m.beyond_n} "
          f"by more than {AGREE_N} N (worst {m.worst_n:.3g} N), {m.bitwise:,} the same to the bit (thrust, reason, "
          f"mirrored posture)")


def section_agreement(results: dict, samples: int = 1000, suspects: int = 200) -> None:
    for k, side in enumerate(("right", "left")):
        if side not in results:
            results[side] = timed_sweep(side, 0.01, 2)[0]
        r = results[side]
        rng = np.random.default_rng(11 + k)
        ok = searchable(r.spec, r.swing, r.reason)
        random = rng.choice(np.flatnonzero(ok), samples, replace=False)
        suspect = suspect_cells(r.spec, r.thrust, r.reason, suspects)
        for name, picks in (("random", random), ("suspect", suspect)):
            t0 = time.process_time()
            c0 = time.perf_counter()
            f_ex, r_ex = exhaustive_cells(r.spec, r.swing[picks], jobs=2)
            same = agree(r.thrust[picks], r.reason[picks], f_ex, r_ex)
            members = int(np.count_nonzero(r_ex == Reason.OK))
            print(f"agreement with exhaustive (P_body grid {REFERENCE_GRID_M * 1000:.0f} mm), {side} support, "
                  f"{len(picks)} {name} cells ({members} members by exhaustive; {time.perf_counter() - c0:.0f} s "
                  f"wall on 2 processes, parent {time.process_time() - t0:.0f} s CPU): {int(same.sum())} agree "
                  f"(same membership, within {AGREE_N} N)")
            for i, fe, re_ in zip(picks[~same], f_ex[~same], r_ex[~same], strict=True):
                print(f"  differs at swing {np.round(r.swing[i], 3)} m: continuation {r.thrust[i]:.3f} N "
                      f"({Reason(r.reason[i]).name}), exhaustive {fe:.3f} N ({Reason(re_).name})")


def speedups(label: str, times: TaskTimes) -> None:
    one = makespan(times, 1)
    cells = ", ".join(f"{n}: {makespan(times, n):.1f} s ({one / makespan(times, n):.1f}x)" for n in WORKERS)
    print(f"{label}, from the measured task times (greedy schedule per stage): {cells}; critical path "
          f"{times.critical_path_s:.1f} s (bound {one / times.critical_path_s:.1f}x)")


def section_scale(results: dict) -> None:
    r, wall = timed_sweep("right", 0.005, 2)
    times = r.extra["task_times"]
    describe_times(f"sweep 0.5 cm, right support ({len(r.reason):,} cells, {int(r.with_thrust.sum()):,} members)",
                   times, wall, 2, 240.0)
    speedups("  0.5 cm: workers", times)
    del r
    if "right" in results:
        speedups("  1 cm: workers", results["right"].extra["task_times"])
    cores = os.cpu_count() or 1
    walls = {}
    for n in WORKERS:
        if n > cores:
            break
        _, walls[n] = timed_sweep("right", 0.01, n, executor="dask")
    print("  1 cm on a local Dask cluster (processes, measured, cluster start-up included): " + ", ".join(
        f"{n} workers {w:.1f} s ({walls[1] / w:.2f}x)" for n, w in walls.items()) + f"; {cores} cores here")


SECTIONS = {"kernel": lambda results: kernel_speed(), "search": lambda results: search_savings(),
            "timing": section_timing, "mirror": section_mirror, "agreement": section_agreement,
            "limit": section_limit, "scale": section_scale}


def main(names: list[str]) -> None:
    unknown = set(names) - set(SECTIONS)
    if unknown:
        raise SystemExit(f"unknown sections {sorted(unknown)}: choose from {list(SECTIONS)}")
    sweep_layers(SweepSpec(resolution_m=0.05), (0.0,))  # compile (or load) every kernel before timing
    results: dict = {}
    for name, fn in SECTIONS.items():
        if not names or name in names:
            fn(results)


if __name__ == "__main__":
    main(sys.argv[1:])
