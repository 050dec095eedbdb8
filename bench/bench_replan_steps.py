"""Landing errors of a multi-step scenario in the twin: the whole plan replayed feed-forward (each step
planned from where the previous one was supposed to land) against `jethr1 replan-steps` (each step
planned from where the previous rehearsal measured the soles). docs/robust_planning.md quotes it.

    .venv/bin/python bench/bench_replan_steps.py [configs/scattered_steps.yaml] [--controller feedback]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
JETHR1 = str(ROOT / ".venv" / "bin" / "jethr1")


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("config", nargs="?", type=Path, default=ROOT / "configs" / "scattered_steps.yaml")
    ap.add_argument("--controller", choices=("feedforward", "feedback"), default="feedforward")
    args = ap.parse_args(argv)
    config, controller = args.config, args.controller
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([JETHR1, "plan", str(config), "-o", tmp, "--no-progress"], check=True, capture_output=True)
        folder = next(p for p in Path(tmp).iterdir() if p.is_dir())
        sim = subprocess.run([JETHR1, "simulate", str(folder), "--controller", controller, "--json", "--no-progress"],
                             capture_output=True, text=True)
        doc = json.loads(sim.stdout)
        run = doc["runs"][0] if "runs" in doc else doc
        whole = [1000 * e["xy_m"] for e in run["landing_errors_m"]]
        rs = subprocess.run([JETHR1, "replan-steps", str(config), "-o", tmp, "--controller", controller, "--json",
                             "--no-progress"], capture_output=True, text=True)
        steps = json.loads(rs.stdout)["steps"]
    print(f"{config.name}, {controller}")
    print(f"  whole plan replayed:   landing errors {[round(e, 1) for e in whole]} mm, "
          f"support slip {1000 * run['support_max_slip_m']:.1f} mm, survived {run['survived']}")
    print(f"  re-planned each step:  landing errors {[round(1000 * s['landing_error_m'], 1) for s in steps]} mm, "
          f"support slip {max(1000 * s['support_max_slip_m'] for s in steps):.1f} mm, "
          f"survived {all(s['survived'] for s in steps)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
