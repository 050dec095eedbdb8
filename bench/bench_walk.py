"""Paper B's walking, speed: the walk generated (CoM MPC, yaw MPC, QP IK and arm QP at 100 Hz) against
the walk's own duration (real time), then the analysis and the twin's rehearsal, warm (a second run in
the same process: the first pays the imports and the compiled functions' loading), on one core.

    .venv/bin/python bench/bench_walk.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jethr1_plan.sim.walk_rehearsal import rehearse_walk  # noqa: E402
from jethr1_plan.walking.analysis import analyse  # noqa: E402
from jethr1_plan.walking.result import generate_walk  # noqa: E402
from jethr1_plan.walking.spec import load_walk  # noqa: E402


def main() -> None:
    for name in ("dyros_walk", "jethr1_walk"):
        spec = load_walk(ROOT / "configs" / "walks" / f"{name}.yaml")
        t0 = time.perf_counter()
        generate_walk(spec)
        cold = time.perf_counter() - t0
        walk = generate_walk(spec)
        duration = float(walk.timeline.duration_s)
        t0 = time.perf_counter()
        analyse(walk)
        t_analyse = time.perf_counter() - t0
        t0 = time.perf_counter()
        rehearse_walk(walk)
        t_twin = time.perf_counter() - t0
        print(f"walk {name:12s}: {duration:.1f} s walk, {len(walk.t)} rows; generated in {walk.wall_s:.3f} s "
              f"({duration / walk.wall_s:.0f}x real time; first run in the process {cold:.2f} s), analysed in "
              f"{t_analyse:.3f} s, rehearsed in the twin in {t_twin:.3f} s ({duration / t_twin:.0f}x real time)")


if __name__ == "__main__":
    main()
