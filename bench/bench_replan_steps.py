"""Landing errors of a multi-step scenario in the twin, at nominal: the whole plan replayed in one go (each step
planned from where the previous one was supposed to land: ``jethr1 simulate PLAN --whole``) against the plan
executed step by step (each step planned from where the robot estimates its soles stand, to the foothold it
perceives: ``jethr1 simulate PLAN``). docs/rehearsal.md quotes it.

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
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([JETHR1, "plan", str(args.config), "-o", tmp, "--no-progress"], check=True, capture_output=True)
        folder = next(p for p in Path(tmp).iterdir() if p.is_dir())
        out = {}
        for mode in ("--whole", None):
            cmd = [JETHR1, "simulate", str(folder), "--controller", args.controller, "--json", "--no-progress"]
            sim = subprocess.run(cmd + ([mode] if mode else []), capture_output=True, text=True)
            out[mode or "steps"] = json.loads(sim.stdout)["runs"][0]
    whole, steps = out["--whole"], out["steps"]
    rec = steps["step_by_step"]["steps"]
    print(f"{args.config.name}, {args.controller}")
    errors = [round(1000 * e["xy_m"], 1) for e in whole["landing_errors_m"]]
    print(f"  whole plan replayed:   landing errors {errors} mm, "
          f"support slip {1000 * whole['support_max_slip_m']:.1f} mm, survived {whole['survived']}")
    print(f"  step by step:          landing errors {[round(1000 * s['landing_error_m'], 1) for s in rec]} mm "
          f"(against the footholds), support slip {max(1000 * s['judge']['support_slip_m'] for s in rec):.1f} mm "
          f"per swing, survived {steps['survived']}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
