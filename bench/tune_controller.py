"""Tune the thrust feedback law (jethr1_plan/sim/controller.py) on the twin, not by hand.

Plans the robust configs, then rehearses each with every combination of the law's settings below
over randomised trials (``Perturbation.draw``, seeds 1000.. so that the trials ``jethr1 simulate
--trials`` draws, seeds 0.., are not the ones tuned on). A setting scores by the runs it keeps
upright and on the cartons, then by the mean of each run's least centre-of-pressure margin. Prints
every setting's score and the best one as the robot YAML's ``controller:`` block.

    .venv/bin/python bench/tune_controller.py [--trials 12] [-j 2]
"""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jethr1_plan.cli import run  # noqa: E402
from jethr1_plan.control.thrust_feedback import Gains  # noqa: E402
from jethr1_plan.sim.rehearsal import Perturbation, load_plan, rehearse  # noqa: E402

CONFIGS = ("side_step", "forward_ditch_robust", "jet_hr1_trial_robust")
GRID = {"band_margin_m": (0.01, 0.015, 0.02), "kp_n_per_m": (300.0, 600.0, 1200.0),
        "ki_n_per_m_s": (0.0, 3000.0, 10000.0)}


def one(folder: str, gains: Gains, seed: int) -> tuple[bool, float]:
    r = rehearse(load_plan(Path(folder)), "feedback", Perturbation.draw(np.random.default_rng([seed])), gains)
    return r.survived, (r.least_cop_margin_m if r.least_cop_margin_m is not None else -1.0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=12)
    ap.add_argument("-j", "--jobs", type=int, default=2)
    args = ap.parse_args()
    out = Path(tempfile.mkdtemp(prefix="tune-"))
    for name in CONFIGS:
        assert run(["plan", str(ROOT / "configs" / f"{name}.yaml"), "-o", str(out), "--no-progress"]) == 0
    settings = [dict(zip(GRID, values, strict=True)) for values in itertools.product(*GRID.values())]
    t0 = time.perf_counter()
    jobs = [(k, name, s) for k in range(len(settings)) for name in CONFIGS for s in range(1000, 1000 + args.trials)]
    results = Parallel(n_jobs=args.jobs)(delayed(one)(str(out / name), Gains(**settings[k]), s) for k, name, s in jobs)
    table = {}
    for (k, _name, _s), (ok, margin) in zip(jobs, results, strict=True):
        table.setdefault(k, []).append((ok, margin))
    rows = sorted(((sum(ok for ok, _ in v), float(np.mean([m for _, m in v])), k) for k, v in table.items()),
                  key=lambda r: (-r[0], -r[1]))
    total = len(CONFIGS) * args.trials
    print(f"{len(jobs)} runs in {time.perf_counter() - t0:.0f} s ({args.trials} trials x {len(CONFIGS)} configs "
          f"per setting)")
    print("survived  mean least CoP margin [mm]  setting")
    for ok, margin, k in rows:
        print(f"{ok:3d}/{total}  {1000 * margin:8.2f}                  {settings[k]}")
    best = settings[rows[0][2]]
    print("\nbest, for the robot YAML:\ncontroller:\n  rate_hz: 500.0")
    for key, value in best.items():
        print(f"  {key}: {value}")
    print(f"  leak_time_s: {Gains().leak_time_s}")


if __name__ == "__main__":
    main()
