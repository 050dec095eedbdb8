"""Routes on seeded terrains executed WHOLE from their CSV by an independent replay (tests/oracles/replay.py:
its own MuJoCo model, its own servos, contacts and fans, no re-planning, none of jethr1_plan's code):
feed-forward at nominal servo stiffness, and a trunk-tilt PID (Paper A's IMU law) at stiffness x0.8, x1 and
x1.25. A route passes when no run falls, both soles end on cartons and every landing lies within 15 mm
(feed-forward) and 10 mm (PID) of the plan; a terrain passes when its route passes or the route refuses it
(exit 3). docs/route.md quotes it.

Terrains: ``jethr1 terrain random --seed S`` for S = --first, --first + 1, ... (the defaults: 4 cartons,
ditches 0.05..0.15 m) until --routes of them have a route; the benchmark set of bench_route.py is seeds 0..99.

    .venv/bin/python bench/bench_replay.py [--first 1000] [--routes 5] [-j 2] [--json out/bench_replay.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

from joblib import Parallel, delayed

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jethr1_plan.cli import run  # noqa: E402
from tests.oracles.replay import replay  # noqa: E402

CASES = (("feedforward", 1.0, 0.015), ("pid", 0.8, 0.010), ("pid", 1.0, 0.010), ("pid", 1.25, 0.010))


def one(folder: str, controller: str, scale: float, limit: float) -> dict:
    t0 = time.perf_counter()
    r = replay(Path(folder), controller, scale)
    worst = r.worst_landing_m
    return {"controller": controller, "stiffness_scale": scale, "limit_m": limit, "fell": r.fell,
            "on_cartons": r.on_cartons, "landings_mm": [round(1000 * e["xy_m"], 1) for e in r.landings_m],
            "slip_mm": [round(1000 * s["slip_m"], 1) for s in r.swings],
            "turn_deg": [round(57.29578 * s["turn_rad"], 2) for s in r.swings],
            "max_tilt_deg": round(r.max_tilt_deg, 2), "worst_landing_mm": round(1000 * worst, 1),
            "passed": r.survived and worst <= limit, "wall_s": time.perf_counter() - t0}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--first", type=int, default=1000, help="the first terrain seed")
    ap.add_argument("--routes", type=int, default=5, help="terrains with a route to replay")
    ap.add_argument("--max-seeds", type=int, default=40, help="give up after this many seeds")
    ap.add_argument("-j", "--jobs", type=int, default=2)
    ap.add_argument("--json", default=str(ROOT / "out" / "bench_replay.json"))
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bench-replay-"))
    terrains: list[dict] = []
    routed = 0
    seed = args.first
    while routed < args.routes and seed < args.first + args.max_seeds:
        path = work / f"random_{seed}.yaml"
        assert run(["terrain", "random", "--seed", str(seed), "-o", str(path)]) == 0
        code = run(["route", str(path), "-o", str(work), "--no-progress"])
        rec: dict = {"seed": seed, "route_exit": code}
        if code == 0:
            routed += 1
            summary = json.loads((work / path.stem / "summary.json").read_text())
            rec["steps"] = len(summary["steps"])
            rec["folder"] = str(work / path.stem)
        terrains.append(rec)
        print(f"seed {seed}: route exit {code}" + (f", {rec['steps']} steps" if code == 0 else ""), flush=True)
        seed += 1
    jobs = [(t, c) for t in terrains if t["route_exit"] == 0 for c in CASES]
    results = Parallel(n_jobs=args.jobs)(delayed(one)(t["folder"], *c) for t, c in jobs)
    for (t, _), r in zip(jobs, results, strict=True):
        t.setdefault("runs", []).append(r)
    print(f"\n{'seed':>5} {'steps':>5} {'run':>14} {'result':>7} {'landings [mm]':40s} {'slip [mm]':28s} turn [deg]")
    crossed = failing = refused = 0
    for t in terrains:
        if t["route_exit"] != 0:
            refused += t["route_exit"] == 3
            print(f"{t['seed']:>5} {'-':>5} {'route exit ' + str(t['route_exit']):>14}")
            continue
        ok = all(r["passed"] for r in t["runs"])
        t["passed"] = ok
        crossed += ok
        failing += not ok
        for r in t["runs"]:
            label = f"{r['controller'][:4]} x{r['stiffness_scale']:.2f}"
            print(f"{t['seed']:>5} {t['steps']:>5} {label:>14} {'pass' if r['passed'] else 'FAIL':>7} "
                  f"{r['landings_mm']!s:40s} {r['slip_mm']!s:28s} {r['turn_deg']}")
    print(f"\n{routed} terrains routed: {crossed} crossed (every run within its limits), {failing} failing; "
          f"{refused} refused (exit 3) on the way")
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps({"terrains": terrains, "crossed": crossed, "failing": failing,
                                           "refused": refused}, indent=1) + "\n")
    print(f"wrote {args.json}")
    return 0 if failing == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
