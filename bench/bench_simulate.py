"""The twin's speed: simulated time over wall time for the robust trial, on one core (one run each of
feed-forward and feedback), against the real-time floor the rehearsal must beat (10x).

    .venv/bin/python bench/bench_simulate.py
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jethr1_plan.cli import run  # noqa: E402
from jethr1_plan.sim.rehearsal import load_plan, rehearse  # noqa: E402


def main() -> None:
    out = Path(tempfile.mkdtemp(prefix="bench-sim-"))
    assert run(["plan", str(ROOT / "configs" / "jet_hr1_trial_robust.yaml"), "-o", str(out), "--no-progress"]) == 0
    track = load_plan(out / "jet_hr1_trial_robust")
    runs = {}
    for controller in ("feedforward", "feedback"):
        t0 = time.perf_counter()
        runs[controller] = (rehearse(track, controller), time.perf_counter() - t0)
    for controller, (r, wall) in runs.items():
        ratio, loop = r.simulated_s / wall, r.simulated_s / r.wall_s
        print(f"simulate {controller:11s}: {r.simulated_s:.1f} s simulated in {wall:.2f} s wall "
              f"({ratio:.1f}x real time, loop alone {loop:.1f}x); survived={r.survived}")


if __name__ == "__main__":
    main()
