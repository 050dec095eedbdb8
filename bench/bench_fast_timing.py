"""The price of speed: total time against survival for the fastest timing, swept over the share of each row's
tolerance share the motion must leave held (``timing.dynamic_share``), on the 450 mm trial and the 350 mm
robust trial (docs/physics.md, "The fastest timing").

Per config and share: the plan (``jethr1 plan``, ``timing.mode: fastest``), its total time and slowest swing,
the least dynamic ZMP margin, the independent replay of its CSV (tests/oracles/replay_csv.py: feed-forward and
trunk-tilt PID at servo stiffness ×0.8, ×1, ×1.25; passes of 6), and a certificate of N randomised trials inside
the plan's tolerance with the feedback law (as ``jethr1 simulate --trials N --within-tolerance --controller
feedback``, seed 0). The fixed timing (24 s) is the reference point. Writes ``out/bench_fast_timing.json`` and
the figure ``docs/img/fast_timing_tradeoff.png``.

    .venv/bin/python bench/bench_fast_timing.py [--trials 40] [--shares 0.2,0.4,0.6,0.7,0.8,0.9] [-j 2]
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
from tests.oracles.replay_csv import replay  # noqa: E402

CONFIGS = {"jet_hr1_trial": "450 mm trial (share 0.516)", "jet_hr1_trial_robust": "350 mm robust trial"}


def certify(folder: Path, trials: int, jobs: int) -> dict:
    track = load_plan(folder)
    ps = draws(0, trials, "within_tolerance", track.tolerance)
    runs = simulate(folder, "feedback", ps, jobs=jobs)
    cert = certificate(runs, ps, track.tolerance, "within_tolerance")
    out = {k: cert[k] for k in ("survived", "trials", "rate", "lower_bound", "upper_bound")}
    out["failures"] = [{"trial": f.get("trial"), "why": f.get("why"), "perturbation": f.get("perturbation")}
                       for f in cert.get("failures", [])]
    return out


def point(name: str, share: float | None, work: Path, trials: int, jobs: int) -> dict:
    text = (ROOT / "configs" / f"{name}.yaml").read_text()
    label = f"{name}_fixed" if share is None else f"{name}_k{share:g}"
    if share is not None:
        text = text.replace("timing:\n", f"timing:\n  mode: fastest\n  dynamic_share: {share}\n", 1)
    text = text.replace(f"name: {name}\n", f"name: {label}\n", 1)
    scenario = work / f"{label}.yaml"
    scenario.write_text(text)
    t0 = time.perf_counter()
    code = run(["plan", str(scenario), "-o", str(work), "--no-progress"])
    out = {"config": name, "dynamic_share": share, "plan_exit": code, "plan_s": time.perf_counter() - t0}
    if code != 0:
        return out
    folder = work / label
    s = json.loads((folder / "summary.json").read_text())
    t = s.get("timing")
    out["total_s"] = t["total_s"] if t else (s["trajectory"]["rows"] - 1) / s["trajectory"]["rate_hz"]
    out["slowest_swing_s"] = max((p["duration_s"] for p in t["phases"] if p["phase"] == "swing"), default=None) if t \
        else None
    out["least_dynamic_zmp_margin_m"] = s["dynamics"]["least_zmp_margin_m"]
    robot = ROOT / "robots" / "jethr1" / "jethr1.yaml"
    out["replay"] = [{"stiffness": k, "pid": pid, "passed": (r := replay(folder, scenario, robot, k, pid)).passed,
                      "landings_mm": [round(1000 * e, 1) for e in r.landings_m], "fell": r.fell}
                     for pid in (False, True) for k in (0.8, 1.0, 1.25)]
    t0 = time.perf_counter()
    out["certificate"] = certify(folder, trials, jobs)
    out["certificate_s"] = time.perf_counter() - t0
    return out


def plot(points: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    for name, label in CONFIGS.items():
        fast = sorted((p for p in points if p["config"] == name and p["dynamic_share"] is not None
                       and "certificate" in p), key=lambda p: p["dynamic_share"])
        fixed = [p for p in points if p["config"] == name and p["dynamic_share"] is None and "certificate" in p]
        if not fast:
            continue
        ax1.plot([p["dynamic_share"] for p in fast], [p["total_s"] for p in fast], "o-", label=label)
        ts = [p["total_s"] for p in fast] + [p["total_s"] for p in fixed]
        rate = [p["certificate"]["rate"] for p in fast] + [p["certificate"]["rate"] for p in fixed]
        low = [p["certificate"]["lower_bound"] for p in fast] + [p["certificate"]["lower_bound"] for p in fixed]
        line = ax2.plot(ts[:len(fast)], rate[:len(fast)], "o-", label=f"{label}: survival rate")[0]
        ax2.plot(ts[:len(fast)], low[:len(fast)], "v--", color=line.get_color(), alpha=0.6,
                 label=f"{label}: 95 % lower bound")
        for p in fast:
            ax2.annotate(f"{p['dynamic_share']:g}", (p["total_s"], p["certificate"]["rate"]), fontsize=7,
                         xytext=(3, 3), textcoords="offset points")
        if fixed:
            ax2.plot(ts[len(fast):], rate[len(fast):], "s", color=line.get_color(), label=f"{label}: fixed 24 s")
    ax1.set_xlabel("dynamic_share (the share of each row's tolerance share the motion leaves held)")
    ax1.set_ylabel("total time [s]")
    ax1.grid(True, alpha=0.3)
    ax1.legend(fontsize=8)
    ax2.set_xlabel("total time [s]")
    ax2.set_ylabel("trials survived inside the tolerance (feedback)")
    ax2.grid(True, alpha=0.3)
    ax2.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=40)
    ap.add_argument("--shares", default="0.2,0.4,0.6,0.7,0.8,0.9")
    ap.add_argument("--configs", default=",".join(CONFIGS))
    ap.add_argument("--no-fixed", action="store_true", help="skip the fixed timing's reference point")
    ap.add_argument("-j", "--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "bench_fast_timing.json")
    ap.add_argument("--figure", type=Path, default=ROOT / "docs" / "img" / "fast_timing_tradeoff.png")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bench-fast-"))
    shares: list[float | None] = [float(x) for x in args.shares.split(",")]
    if not args.no_fixed:
        shares.append(None)
    points = []
    print(f"{'config':22s} {'share':>6s} {'total [s]':>9s} {'slowest swing':>13s} {'replay':>7s} "
          f"{'survived':>9s} {'95 % lower':>10s}", flush=True)
    for name in args.configs.split(","):
        for share in shares:
            p = point(name, share, work, args.trials, args.jobs)
            points.append(p)
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(json.dumps(points, indent=1))
            if "certificate" not in p:
                print(f"{name:22s} {share!s:>6s} plan exit {p['plan_exit']}", flush=True)
                continue
            c = p["certificate"]
            sw = "" if p["slowest_swing_s"] is None else f"{p['slowest_swing_s']:.2f}"
            print(f"{name:22s} {share if share is not None else 'fixed'!s:>6s} {p['total_s']:9.2f} {sw:>13s} "
                  f"{sum(r['passed'] for r in p['replay'])}/6 {c['survived']:>4d}/{c['trials']:<4d} "
                  f"{c['lower_bound']:10.4f}", flush=True)
    plot(points, args.figure)
    print(f"wrote {args.out} and {args.figure}")


if __name__ == "__main__":
    main()
