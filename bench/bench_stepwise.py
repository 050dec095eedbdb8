"""Certificates of plans of several steps executed step by step, as Jet-HR1 would with its own sensors (a
pelvis IMU and joint encoders: its IMU law), under the default randomisation (thrust gain 0.8..1.1, mass
±5 %, CoM 5 mm, fan lag 30..80 ms, servo stiffness 0.8..1.25) extended by the sensors' biases, offsets and
delays and the perception error: ``configs/scattered_steps.yaml`` and the routes of seeded terrains
(``jethr1 terrain random --seed S``, S = 0, 1, ... until --routes have a route). Each plan: N trials (trial
k from ``default_rng([0, k])``, as ``jethr1 simulate PLAN --controller feedback --trials N``), the
survivors and their 95 % Clopper–Pearson interval, the failures with their draws, the steps planned in
each way (``modes``: re-anchored, optimised, and the fall-backs ``stepwise.plan_anew``), and the landings'
distance to their footholds over all trials, and every landing (trial, step, mode, distance), so that the
landings of all plans can be pooled (the route's edge margin, robots/jethr1/jethr1.yaml
``execution.landing_error_m``, is to cover their 99th percentile). docs/rehearsal.md quotes it.

Resumable: a plan whose certificate is in --json already is not run again.

    .venv/bin/python bench/bench_stepwise.py [--trials 200] [--routes 20] [-j 2] [--json out/bench_stepwise.json]
        [--seeds 2,3,9]
    .venv/bin/python bench/bench_stepwise.py --report --json docs/data/stepwise_certificates_2026-11-29.json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import jethr1_plan.arithmetic  # noqa: F401  (first: NumPy's and OpenBLAS's kernels pinned before they load)

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jethr1_plan.cli import run  # noqa: E402
from jethr1_plan.io.json_text import json_text  # noqa: E402
from jethr1_plan.sim.certificate import certificate, draws  # noqa: E402
from jethr1_plan.sim.rehearsal import load_plan  # noqa: E402
from jethr1_plan.sim.stepwise import MODES  # noqa: E402
from jethr1_plan.studies.step_by_step import nominal_plan, run_steps  # noqa: E402

SEED = 0  # simulate's default seed


def _progress(name: str, every: int = 10):
    """A line on stderr every ``every`` trials: how many are done, and the time since the plan's first."""
    t0 = time.perf_counter()

    def say(_what: str, done: int, total: int) -> None:
        if done % every == 0 or done == total:
            print(f"  {name}: {done}/{total} trials, {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    return say


def certify(folder: Path, trials: int, jobs: int) -> dict:
    track = load_plan(folder)
    summary = json.loads((folder / "summary.json").read_text())
    scenario, nominal = nominal_plan(folder, summary, track)
    ps = draws(SEED, trials, "default", track.tolerance, track.robot)
    t0 = time.perf_counter()
    execs = run_steps(folder, summary, scenario, nominal, "feedback", ps, jobs, _progress(folder.name), SEED)
    wall = time.perf_counter() - t0
    runs = [ex.run for ex in execs]
    cert = certificate(runs, ps, track.tolerance, "default")
    cert.pop("inside")
    landings = [s["landing_error_m"] for ex in execs for s in ex.steps if "landing_error_m" in s]
    slips = [s["judge"]["support_slip_m"] for ex in execs for s in ex.steps if "judge" in s]
    turns = [abs(s["judge"]["support_turn_rad"]) for ex in execs for s in ex.steps if "judge" in s]
    simulated = sum(r.simulated_s for r in runs)
    return {"steps": len(scenario.steps), "certificate": cert,
            "refused": [{"trial": k, **ex.refused} for k, ex in enumerate(execs) if ex.refused],
            "modes": {m: sum(s["mode"] == m for ex in execs for s in ex.steps) for m in MODES},
            "landing_error_m": _stats(landings), "support_slip_m": _stats(slips), "support_turn_rad": _stats(turns),
            "simulated_s": simulated, "wall_s": wall, "realtime_factor": simulated / wall if wall else None,
            # every landing: [trial, step, how it was planned, its distance to the foothold [m] (0.1 µm)]
            "landings": [[k, s["step"], s["mode"], round(s["landing_error_m"], 7)]
                         for k, ex in enumerate(execs) for s in ex.steps if "landing_error_m" in s]}


def _stats(x: list[float]) -> dict:
    if not x:
        return {}
    a = np.asarray(x)
    return {"n": len(a), "mean": float(a.mean()), "p50": float(np.percentile(a, 50)),
            "p95": float(np.percentile(a, 95)), "p99": float(np.percentile(a, 99)), "max": float(a.max())}


def plan_line(name: str, rec: dict) -> str:
    """One plan's certificate and landings on a line."""
    c, e = rec["certificate"], rec["landing_error_m"]
    return (f"{name:18s} {rec['steps']} steps  {c['survived']:4d}/{c['trials']:<4d} lower bound "
            f"{c['lower_bound']:.4f}  landing p50 {1000 * e.get('p50', np.nan):.1f} p99 "
            f"{1000 * e.get('p99', np.nan):.1f} max {1000 * e.get('max', np.nan):.1f} mm  {rec['wall_s']:.0f} s "
            f"({rec['realtime_factor']:.1f}x)")


def report(plans: dict[str, dict]) -> None:
    """The certificates together: how many reach 0.95, the landings' 99th percentiles, and the landings kept one by one
    pooled, over all and by how their step was planned, against the route's edge margin (Jet-HR1's
    ``execution.landing_error_m``, which is to cover the pooled 99th percentile)."""
    from jethr1_plan.robot.load import load_robot

    margin = load_robot("jethr1").landing_error_m
    margin_mm = 1000 * margin if margin is not None else np.inf
    landings = [v for r in plans.values() for v in [r["landing_error_m"].get("p99")] if v is not None]
    passed = sum(r["certificate"]["lower_bound"] >= 0.95 for r in plans.values())
    print(f"\n{passed} of {len(plans)} plans reach a 95 % lower bound of 0.95; the landings' 99th percentile per plan: "
          f"at most {1000 * max(landings):.1f} mm" if landings else "")
    rows = [row for r in plans.values() for row in r.get("landings", [])]
    if not rows:
        return
    kept = [name for name, r in plans.items() if r.get("landings")]

    def stats(mm: np.ndarray) -> str:
        return (f"median {np.median(mm):.1f} mm, 99th percentile {np.percentile(mm, 99):.1f} mm, largest "
                f"{mm.max():.1f} mm, {int((mm > margin_mm).sum())} beyond the {margin_mm:.1f} mm margin")
    every = 1000 * np.array([row[3] for row in rows])
    print(f"all {len(every)} landings of {len(kept)} plans: {stats(every)}")
    for mode in dict.fromkeys(row[2] for row in rows):
        mm = 1000 * np.array([row[3] for row in rows if row[2] == mode])
        print(f"  steps {mode}: {len(mm)} landings, {stats(mm)}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--trials", type=int, default=200)
    ap.add_argument("--routes", type=int, default=20, help="seeded terrains with a route")
    ap.add_argument("--first", type=int, default=0, help="the first terrain seed")
    ap.add_argument("--seeds", default=None, help="only these terrain seeds, comma-separated (each must have a route)")
    ap.add_argument("-j", "--jobs", type=int, default=2)
    ap.add_argument("--json", default=str(ROOT / "out" / "bench_stepwise.json"))
    ap.add_argument("--work", default=None, help="where the plans go (default: a temporary folder)")
    ap.add_argument("--report", action="store_true",
                    help="only print the certificates already in --json (e.g. docs/data/stepwise_certificates_*.json)")
    args = ap.parse_args()
    out = Path(args.json)
    doc = json.loads(out.read_text()) if out.exists() else {"trials": args.trials, "plans": {}}
    if args.report:
        if not out.exists():
            print(f"{out}: no such file (--report prints the certificates a --json holds)", file=sys.stderr)
            return 2
        for name, rec in doc["plans"].items():
            print(plan_line(name, rec))
        report(doc["plans"])
        return 0
    if doc.get("trials") != args.trials:
        doc = {"trials": args.trials, "plans": {}}
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="bench-stepwise-"))
    work.mkdir(parents=True, exist_ok=True)
    folders: dict[str, Path] = {}
    assert run(["plan", str(ROOT / "configs" / "scattered_steps.yaml"), "-o", str(work), "--no-progress"]) == 0
    folders["scattered_steps"] = work / "scattered_steps"
    chosen = [int(v) for v in args.seeds.split(",")] if args.seeds else None
    seed, found = (chosen.pop(0) if chosen else args.first), 0
    while found < args.routes and seed < args.first + 200 and (chosen is None or seed >= 0):
        path = work / f"random_{seed}.yaml"
        if not (work / path.stem / "trajectory.csv").exists():
            assert run(["terrain", "random", "--seed", str(seed), "-o", str(path)]) == 0
            code = run(["route", str(path), "-o", str(work), "--no-progress"])
        else:
            code = 0
        if code == 0:
            folders[path.stem] = work / path.stem
            found += 1
        elif chosen is not None:
            raise SystemExit(f"terrain seed {seed} has no route")
        seed = seed + 1 if chosen is None else (chosen.pop(0) if chosen else -1)
    print(f"{len(folders)} plans, {args.trials} trials each, feedback (Jet-HR1's IMU law), step by step, "
          f"-j {args.jobs}", flush=True)
    for name, folder in folders.items():
        if name in doc["plans"]:
            continue
        rec = certify(folder, args.trials, args.jobs)
        doc["plans"][name] = rec
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json_text(doc))
        print(plan_line(name, rec), flush=True)
        c = rec["certificate"]
        for f in c["failures"]:
            p = f["perturbation"]
            print(f"    trial {f['trial']}: {f['why']}; thrust x{p['thrust_gain']:.3f} mass x{p['mass_scale']:.3f} "
                  f"lag {1000 * p['fan_lag_s']:.0f} ms stiffness x{p['servo_stiffness_scale']:.2f}", flush=True)
    report(doc["plans"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
