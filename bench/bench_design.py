"""``jethr1 design`` (issue 40): a variant's ditch curve on one core, the sweep's scale-out from its per-task times,
and its agreement with ``jethr1 ditch-curve``.

Sections (all by default; name some on the command line to run only those):

* ``curve``: Jet-HR1's own fans (23 N, the sole centre) as a design, and the widest-reaching variant of the study
  (40 N, 140 mm ahead), each judged in this process on one core as a sweep's task judges it (the study's judge:
  0.20-0.80 m every 10 mm): CPU time, plans, and the time per plan; beside it the yardstick of
  ``bench_commands.py`` (60,000 bare PlaCo evaluations) measured in the same run. Target: ≤ 10 s a variant.
* ``scale``: the speed-up of a sweep on 1, 2, 4, ... 32 workers, from the per-task CPU times a sweep measured
  (``timings.json``; ``--timings PATH``, default a 24-variant sweep of the study's corner run here with ``-j 2``):
  the variants scheduled greedily in task order onto n workers (``balance_space.blocks.makespan``), against the
  longest task (the bound); and that sweep run again on a local Dask cluster of 1 and 2 workers (wall time).
* ``agreement``: the study's 23 N variant at the sole centre against ``ditch-curve`` for Jet-HR1 on the gaps around
  its widest robust ditch (``--design PATH``: a study's design.json; default: judged here).

CPU times are per task (``time.process_time`` in the worker): other programs on the machine inflate wall times,
not these (much). ``python bench/bench_design.py curve scale --timings out/jethr1_fans/timings.json``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import jethr1_plan.arithmetic  # noqa: F401  (first: NumPy's and OpenBLAS's kernels pinned before they load)

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
STUDY = ROOT / "configs" / "designs" / "jethr1_fans.yaml"
WORKERS = (1, 2, 4, 8, 16, 32)


def judged(thrust_n: float, fore_m: float) -> tuple[dict, float]:
    """(result, CPU [s]) of one variant of the study judged in this process."""
    from jethr1_plan.studies.design import judge_task, make_tasks
    from jethr1_plan.studies.design_spec import Variant, load_design

    spec = load_design(STUDY)
    v = Variant(0, {"thrust_n": thrust_n, "fore_m": fore_m}, spec.design_at({"thrust_n": thrust_n, "fore_m": fore_m},
                                                                            0))
    keys, tasks = make_tasks(spec, [v])
    _, result, times = judge_task(tasks[keys[0]])
    return result, times["cpu_s"]


def curve() -> None:
    from bench_commands import bare_evaluations_seconds

    judged(23.0, 0.0)  # (the kernels loaded, PlaCo's first robot: a process's first task pays them once)
    _, unit_cpu = bare_evaluations_seconds()
    print(f"a variant's ditch curve on one core (the study's judge; the yardstick, 60,000 bare PlaCo evaluations: "
          f"{unit_cpu:.2f} s CPU):")
    print(f"  {'variant':34s} {'plans':>5s} {'CPU [s]':>8s} {'per plan':>9s} {'units':>6s}  widest whole / half / "
          "crossed [mm]")
    for thrust, fore in ((23.0, 0.0), (40.0, 0.14), (15.0, -0.04)):
        r, cpu = judged(thrust, fore)
        w = r["widest"]
        mm = " / ".join("-" if w[k]["gap_m"] is None else f"{1000 * w[k]['gap_m']:.0f}" for k in ("whole", "half",
                                                                                                   "crossed"))
        print(f"  {f'{thrust:g} N, fan {1000 * fore:+.0f} mm':34s} {r['plans']:5d} {cpu:8.2f} {cpu / r['plans']:9.2f} "
              f"{cpu / unit_cpu:6.2f}  {mm}   (target <= 10 s)")


def corner_spec(folder: Path, n_thrust: int = 6, n_fore: int = 4) -> Path:
    """A sweep of the study's corner (its first thrusts and mounts), as a design file."""
    import yaml

    doc = yaml.safe_load(STUDY.read_text())
    doc["name"] = "corner"
    doc["axes"]["thrust_n"]["values"] = doc["axes"]["thrust_n"]["values"][::4][:n_thrust]
    doc["axes"]["fore_m"]["values"] = doc["axes"]["fore_m"]["values"][::3][:n_fore]
    path = folder / "corner.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def run_design(spec: Path, out: Path, cache: Path, *more: str) -> float:
    w0 = time.perf_counter()
    subprocess.run([str(Path(sys.executable).with_name("jethr1")), "design", str(spec), "-o", str(out), "--cache",
                    str(cache), "--no-progress", *more], check=True, stderr=subprocess.DEVNULL)
    return time.perf_counter() - w0


def scale(timings_path: Path | None) -> None:
    from jethr1_plan.balance_space.blocks import TaskTimes, makespan

    tmp = Path(tempfile.mkdtemp(prefix="bench_design_"))
    try:
        if timings_path is None:
            spec = corner_spec(tmp)
            run_design(spec, tmp / "j2", tmp / "cache_j2", "-j", "2")
            timings_path = tmp / "j2" / "timings.json"
            dask = {n: run_design(spec, tmp / f"dask{n}", tmp / f"cache_dask{n}", "-j", str(n), "--executor", "dask")
                    for n in (1, 2)}
            same = all((tmp / f"dask{n}" / "design.csv").read_bytes() == (tmp / "j2" / "design.csv").read_bytes()
                       for n in (1, 2))
        else:
            dask, same = {}, None
        doc = json.loads(Path(timings_path).read_text())
        cpu = [doc["judged"][k]["cpu_s"] for k in sorted(doc["judged"])]
        times = TaskTimes([cpu])
        one = makespan(times, 1)
        print(f"scale-out of {len(cpu)} variants (per-task CPU times of {timings_path}: {sum(cpu):.0f} s in all, "
              f"{np.mean(cpu):.1f} s a variant, the longest {max(cpu):.1f} s), scheduled greedily in task order:")
        print("  " + ", ".join(f"{n}: {makespan(times, n):.0f} s ({one / makespan(times, n):.1f}x)" for n in WORKERS)
              + f"; bound (the longest task) {one / max(cpu):.0f}x")
        if dask:
            print(f"  the {len(cpu)} variants on a local Dask cluster: 1 worker {dask[1]:.0f} s, 2 workers "
                  f"{dask[2]:.0f} s ({dask[1] / dask[2]:.2f}x, wall, cluster start-up included); design.csv the same "
                  f"bytes as -j 2's: {same}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def agreement(design_path: Path | None) -> None:
    from jethr1_plan.studies.ditch_curve import default_base, ditch_scenario, share_of_gap

    if design_path is not None:
        doc = json.loads(Path(design_path).read_text())
        row = next(v for v in doc["variants"] if v["values"] == {"thrust_n": 23.0, "fore_m": 0.0})
        whole = row["result"]["widest"]["whole"]
    else:
        r, _ = judged(23.0, 0.0)
        whole = r["widest"]["whole"]
    base = default_base()
    shares = {g: share_of_gap(ditch_scenario(base, g, base.balance.robust, 0.16))["share"]
              for g in (0.33, 0.34, 0.35, 0.36, 0.37)}
    curve_whole = max(g for g, s in shares.items() if s is not None and s >= 1 - 1e-9)
    off = 1000 * abs(whole["gap_m"] - curve_whole)
    print(f"Jet-HR1's 23 N fans: the design's widest robust ditch {1000 * whole['gap_m']:.0f} mm (the next gap "
          f"planned, {1000 * whole['next_failing_m']:.0f} mm, fails); ditch-curve's shares "
          + ", ".join(f"{1000 * g:.0f} mm: {s:.3f}" for g, s in shares.items())
          + f": widest robust {1000 * curve_whole:.0f} mm (difference {off:.0f} mm, target <= 10 mm)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sections", nargs="*", default=["curve", "scale", "agreement"])
    ap.add_argument("--timings", type=Path, default=None, help="a sweep's timings.json (scale)")
    ap.add_argument("--design", type=Path, default=None, help="the study's design.json (agreement)")
    args = ap.parse_args()
    for name in args.sections:
        if name == "curve":
            curve()
        elif name == "scale":
            scale(args.timings)
        elif name == "agreement":
            agreement(args.design)
        else:
            raise SystemExit(f"unknown section {name!r}")


if __name__ == "__main__":
    main()
