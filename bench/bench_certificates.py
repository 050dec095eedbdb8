"""Certificates of every shipped config: N randomised rehearsals with the feedback law, drawn inside
the plan's tolerance and with the default (wider) randomisation, each with its survivors and the 95 %
Clopper–Pearson interval (docs/rehearsal.md).

Each config is planned as shipped (``jethr1 plan``), then rehearsed by the same code as
``jethr1 simulate PLAN --controller feedback --trials N [--within-tolerance] --seed 0``: trial k
draws from ``default_rng([0, k])``, so the figures do not depend on ``-j``. Prints a table and
writes ``out/bench_certificates.json`` (every certificate, its failures and their draws).

    .venv/bin/python bench/bench_certificates.py [--trials 200] [-j 2] [--configs side_step,...]

Time: about 200 × 2 runs per config at 2–10 s each (the 2-step trials the longest): an hour or more
on two cores for the six configs.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jethr1_plan.cli import run  # noqa: E402
from jethr1_plan.sim.certificate import certificate, draws  # noqa: E402
from jethr1_plan.sim.rehearsal import load_plan, simulate  # noqa: E402

SEED = 0  # simulate's default seed


def certify(folder: Path, trials: int, randomisation: str, jobs: int) -> dict:
    track = load_plan(folder)
    ps = draws(SEED, trials, randomisation, track.tolerance, track.robot)
    t0 = time.perf_counter()
    runs = simulate(folder, "feedback", ps, jobs=jobs)
    cert = certificate(runs, ps, track.tolerance, randomisation)
    cert.pop("inside")  # per-trial flags: the failures keep theirs
    return {**cert, "wall_s": time.perf_counter() - t0}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=200)
    ap.add_argument("-j", "--jobs", type=int, default=2)
    ap.add_argument("--configs", default=",".join(sorted(p.stem for p in (ROOT / "configs").glob("*.yaml"))),
                    help="comma-separated config names (configs/<name>.yaml)")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "bench_certificates.json")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bench-cert-"))
    results = {}
    print(f"{args.trials} trials per config and randomisation, feedback law, -j {args.jobs}")
    print(f"{'config':28s} {'randomisation':17s} {'survived':>9s} {'95 % lower bound':>17s} {'interval':>18s}  "
          f"{'inside tol.':>11s} {'tolerance held':28s} {'wall [s]':>8s}")
    for name in args.configs.split(","):
        assert run(["plan", str(ROOT / "configs" / f"{name}.yaml"), "-o", str(work), "--no-progress"]) == 0
        summary = json.loads((work / name / "summary.json").read_text())
        results[name] = {"peak_thrust_n": summary["peak_thrust_n"], "mean_thrust_n": summary["mean_thrust_n"]}
        for randomisation in ("within_tolerance", "default"):
            c = certify(work / name, args.trials, randomisation, args.jobs)
            results[name][randomisation] = c
            t, inside = c["tolerance"], c["inside_tolerance"]
            held = f"±{100 * t['thrust_error']:.1f}%/±{100 * t['mass_error']:.1f}%/{1000 * t['com_error_m']:.1f}mm"
            print(f"{name:28s} {randomisation:17s} {c['survived']:4d}/{c['trials']:<4d} {c['lower_bound']:17.4f} "
                  f"[{c['lower_bound']:.4f}, {c['upper_bound']:.4f}]  {inside['survived']:4d}/{inside['trials']:<6d} "
                  f"{held:28s} {c['wall_s']:8.0f}", flush=True)
            for f in c["failures"]:
                p = f["perturbation"]
                print(f"    trial {f['trial']}: {f['why']}; thrust x{p['thrust_gain']:.3f} mass x{p['mass_scale']:.3f} "
                      f"lag {1000 * p['fan_lag_s']:.0f} ms stiffness x{p['servo_stiffness_scale']:.2f} "
                      f"inside={f['inside_tolerance']['all']}", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
