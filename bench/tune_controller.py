"""Tune the thrust feedback law (jethr1_plan/control/thrust_feedback.py) on the twin, not by hand.

The procedure (docs/rehearsal.md, "Tuning the law"):

1. Plan the tuning set: the robust configs (side_step, forward_ditch_robust, jet_hr1_trial_robust)
   and two plans at their limit, where the law has work to do: the side step planned with
   ``--policy minimal`` (the ZMP on the sole's edge) and Paper A's 450 mm crossing planned by GAS
   (``forward_ditch_450 --optimiser gas``, its least thrust).
2. Rehearse every plan with every setting of the grid below (band margin m, k_p, k_i; the leak and the
   rate fixed) over the same randomised trials (``Perturbation.draw``, the default randomisation,
   seeds ``[1000, k]`` so that the trials ``jethr1 simulate --trials`` draws, seeds ``[seed, k]``
   with small ``seed``, are not the ones tuned on).
3. Score a setting by the runs it keeps upright and on the cartons, then by the mean of each run's
   least centre-of-pressure margin; print every setting's score and the best one as the robot YAML's
   ``controller:`` block. The same draws for every setting: the comparison is paired.

    .venv/bin/python bench/tune_controller.py [--trials 4] [-j 2] [--setting '{"kp_n_per_m": 600}' ...]
"""

from __future__ import annotations

import argparse
import itertools
import json
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

#: (folder name, config, extra `jethr1 plan` arguments)
PLANS = (("side_step", "side_step", ()),
         ("forward_ditch_robust", "forward_ditch_robust", ()),
         ("jet_hr1_trial_robust", "jet_hr1_trial_robust", ()),
         ("side_step_minimal", "side_step", ("--policy", "minimal")),
         ("forward_ditch_450_gas", "forward_ditch_450", ("--optimiser", "gas", "--policy", "minimal")))
GRID = {"band_margin_m": (0.01, 0.02), "kp_n_per_m": (300.0, 600.0, 1200.0), "ki_n_per_m_s": (0.0, 3000.0)}
SEED = 1000  # the tuning draws' seed (simulate's default is 0)


def one(folder: str, gains: Gains, k: int) -> tuple[bool, float]:
    p = Perturbation.draw(np.random.default_rng([SEED, k]))
    r = rehearse(load_plan(Path(folder)), "feedback", p, gains)
    return r.survived, (r.least_cop_margin_m if r.least_cop_margin_m is not None else -1.0)


def plan_all(out: Path) -> dict[str, Path]:
    folders = {}
    for name, config, extra in PLANS:
        where = out / name
        assert run(["plan", str(ROOT / "configs" / f"{config}.yaml"), "-o", str(where), "--no-progress",
                    *extra]) == 0
        folders[name] = where / config
    return folders


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=4, help="randomised draws per plan and setting")
    ap.add_argument("-j", "--jobs", type=int, default=2)
    ap.add_argument("--setting", action="append", default=None,
                    help="score only this setting (JSON of Gains fields; repeatable) instead of the grid")
    args = ap.parse_args()
    folders = plan_all(Path(tempfile.mkdtemp(prefix="tune-")))
    settings = ([json.loads(text) for text in args.setting] if args.setting else
                [dict(zip(GRID, values, strict=True)) for values in itertools.product(*GRID.values())])
    t0 = time.perf_counter()
    jobs = [(i, name, k) for i in range(len(settings)) for name in folders for k in range(args.trials)]
    results = Parallel(n_jobs=args.jobs)(delayed(one)(str(folders[name]), Gains(**settings[i]), k)
                                         for i, name, k in jobs)
    table: dict[int, list] = {}
    per_plan: dict[tuple[int, str], int] = {}
    for (i, name, _k), (ok, margin) in zip(jobs, results, strict=True):
        table.setdefault(i, []).append((ok, margin))
        per_plan[i, name] = per_plan.get((i, name), 0) + ok
    rows = sorted(((sum(ok for ok, _ in v), float(np.mean([m for _, m in v])), i) for i, v in table.items()),
                  key=lambda r: (-r[0], -r[1]))
    total = len(folders) * args.trials
    print(f"{len(jobs)} runs in {time.perf_counter() - t0:.0f} s ({args.trials} trials x {len(folders)} plans "
          f"per setting; survivors per plan in the order {', '.join(folders)})")
    print("survived  mean least CoP margin [mm]  per plan        setting")
    for ok, margin, i in rows:
        per = " ".join(str(per_plan[i, name]) for name in folders)
        print(f"{ok:3d}/{total}  {1000 * margin:8.2f}                  {per:14s}  {settings[i]}")
    best = settings[rows[0][2]]
    print("\nbest, for the robot YAML:\ncontroller:\n  rate_hz: 500.0")
    for key, value in best.items():
        print(f"  {key}: {value}")
    print(f"  leak_time_s: {Gains().leak_time_s}")


if __name__ == "__main__":
    main()
