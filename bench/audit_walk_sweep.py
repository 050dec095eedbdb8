"""The independent audit of a walk sweep: every length ``jethr1 walk-sweep`` called a success is walked
again and written to a folder, and pinocchio (``tests/oracles/walk_audit.py``: its own model of the
URDF, its own differences, RNEA) judges the written files alone: the ZMP inside the support, the
friction ratio under the soles' μ, every torque within its effort, every joint's second central
difference within the acceleration limit, the knees bent at least the margin, on every row. It also
states how far the written ZMP is from pinocchio's. Not in ``make bench`` (minutes); needs the dev
extra (``pin``).

    .venv/bin/python bench/audit_walk_sweep.py out/walk_sweep/dyros_walk/walk_sweep.json configs/walks/dyros_walk.yaml
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import jethr1_plan.arithmetic  # noqa: F401  (first: NumPy's and OpenBLAS's kernels pinned before they load)

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jethr1_plan.files.walk_folder import read_walk_csv, write_walk_outputs  # noqa: E402
from jethr1_plan.pipeline.walk import run_walk  # noqa: E402
from jethr1_plan.walking.result import walk_summary  # noqa: E402
from jethr1_plan.walking.spec import load_walk  # noqa: E402
from tests.oracles.walk_audit import audit_walk  # noqa: E402


def main(sweep_json: str, walk_yaml: str) -> int:
    doc = json.loads(Path(sweep_json).read_text())
    spec = load_walk(walk_yaml)
    disagree = 0
    with tempfile.TemporaryDirectory() as tmp:
        for row in doc["rows"]:
            if not row["ok"]:
                continue
            varied = spec.varied(step_length_m=row["step_m"], mode=row["mode"])
            result = run_walk(varied, rehearse=False)
            name = f"{row['mode']}_{row['step_m']:.3f}"
            folder, _ = write_walk_outputs(result, f"{name}.yaml", Path(tmp), walk_summary(result))
            audit = audit_walk(folder)
            c = read_walk_csv((folder / "trajectory.csv").read_text())
            written = np.column_stack([c["zmp_x_m"], c["zmp_y_m"]])[1:-1]
            gap = float(np.max(np.linalg.norm(written - audit.zmp[1:-1], axis=1)))
            w = audit.worst
            agree = audit.clean and result.verdict.ok
            disagree += not agree
            verdict = "clean" if audit.clean else "NOT clean"
            print(f"{doc['robot']:15s} {row['mode']:7s} {row['step_m']:.3f} m: audit {verdict} | ZMP "
                  f"{1000 * w['zmp_margin_m']:5.1f} mm inside, friction {w['friction_ratio']:.3f} "
                  f"(μ {audit.mu:g}), torque {w['torque_ratio']:.2f} of effort, joints ≤ "
                  f"{w['joint_acceleration_rad_s2']:5.1f} rad/s², knees ≥ {w['knee_bend_rad']:.3f} rad | written ZMP "
                  f"{gap:.1e} m from pinocchio's", flush=True)
    print(f"{disagree} walks the sweep called a success fail the audit")
    return 1 if disagree else 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
