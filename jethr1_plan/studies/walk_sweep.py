"""``jethr1 walk-sweep``: one walk file walked at many step lengths with and without pelvic rotation
(Paper B, VI: the longest step, Table 1's energy, Fig. 13's κ, Figs. 12/16's momentum).

Per mode the lengths are walked in increasing order; after ``STOP_AFTER`` failures in a row that
follow a success, the longer lengths are not walked (a longer step is not easier) and say so. The
document does not depend on ``jobs``: lengths walked beyond the stopping point by a parallel wave
are dropped as if never walked.
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np

from jethr1_plan.pipeline.walk import run_walk
from jethr1_plan.walking.result import walk_summary
from jethr1_plan.walking.spec import WalkSpec

__all__ = ["NOT_WALKED", "STOP_AFTER", "max_contiguous_step", "sweep", "sweep_png", "walk_point"]

STOP_AFTER = 3  # failures in a row, after a success, that end a mode's sweep
NOT_WALKED = f"not walked: {STOP_AFTER} shorter steps in a row failed"


def walk_point(spec: WalkSpec) -> dict[str, Any]:
    """One length and mode: its verdict and Paper B's measures (SI units), as the walk's summary states them."""
    s = walk_summary(run_walk(spec))
    mom = s["yaw_momentum"]
    return {"ok": s["ok"], "reason": None if s["failure"] is None else s["failure"]["reason"],
            "failure_time_s": None if s["failure"] is None else s["failure"]["time_s"],
            "energy_two_steps_j": s["energy_two_steps_j"], "peak_kappa": s["peak_kappa"],
            "peak_kappa_leg": max(s["peak_kappa_leg"].values()),
            "peak_yaw_rad": s["peak_yaw_rad"], "peak_yaw_momentum_nms": mom["peak_total_nms"],
            "peak_yaw_momentum_arms_held_nms": mom["peak_with_arms_held_nms"],
            "least_knee_bend_rad": s["least_knee_bend_rad"], "least_zmp_margin_m": s["least_zmp_margin_m"],
            "peak_friction_ratio": s["peak_friction_ratio"],
            "peak_joint_acceleration_rad_s2": s["peak_joint_acceleration_rad_s2"],
            "peak_torque_ratio": s["peak_torque_ratio"],
            "rehearsal_survived": None if s["rehearsal"] is None else s["rehearsal"]["survived"]}


def max_contiguous_step(lengths_m: list[float], ok: list[bool]) -> float | None:
    """The longest step [m] such that every swept length up to it succeeded (None: the shortest failed)."""
    best = None
    for length, good in zip(lengths_m, ok, strict=True):
        if not good:
            break
        best = length
    return best


def _stop_index(ok: list[bool | None]) -> int | None:
    """Index after which a mode stops (STOP_AFTER failures in a row after a success), or None."""
    seen, misses = False, 0
    for k, good in enumerate(ok):
        if good is None:
            return None
        seen |= bool(good)
        misses = 0 if good else misses + 1
        if seen and misses >= STOP_AFTER:
            return k
    return None


def sweep(spec: WalkSpec, lengths_m: list[float], modes: list[str], jobs: int = 1, progress=None) -> dict[str, Any]:
    """Walk ``spec`` at every length of ``lengths_m`` [m] in every rotation mode; the sweep document."""
    from joblib import delayed

    from jethr1_plan.io.pool import parallel

    results: dict[str, list[dict | None]] = {m: [None] * len(lengths_m) for m in modes}
    nxt = dict.fromkeys(modes, 0)
    stopped: dict[str, int] = {}
    done, total = 0, len(lengths_m) * len(modes)
    with parallel(jobs) as pool:
        while any(m not in stopped and nxt[m] < len(lengths_m) for m in modes):
            live = [m for m in modes if m not in stopped and nxt[m] < len(lengths_m)]
            per = max(1, jobs // len(live))
            batch = [(m, k) for m in live for k in range(nxt[m], min(nxt[m] + per, len(lengths_m)))]
            outs = pool(delayed(walk_point)(spec.varied(step_length_m=lengths_m[k], mode=m)) for m, k in batch)
            for (m, k), out in zip(batch, outs, strict=True):
                results[m][k] = out
                nxt[m] = max(nxt[m], k + 1)
            for m in live:
                stop = _stop_index([None if r is None else r["ok"] for r in results[m][:nxt[m]]])
                if stop is not None:
                    stopped[m] = stop
            done = sum(1 for m in modes for r in results[m] if r is not None)
            if progress:
                progress(f"{done}/{total} walks", done, total)
    rows = []
    for m in modes:
        end = stopped.get(m, len(lengths_m) - 1)
        for k, length in enumerate(lengths_m):
            r = results[m][k] if k <= end else None
            if r is None:
                r = {"ok": False, "reason": NOT_WALKED}
            rows.append({"step_m": length, "mode": m, **r})
    max_step = {m: max_contiguous_step(lengths_m, [r["ok"] for r in rows if r["mode"] == m]) for m in modes}
    longest_ok = {m: max((r["step_m"] for r in rows if r["mode"] == m and r["ok"]), default=None) for m in modes}
    base = max_step.get("none")
    gain: dict[str, float | None] = {}
    for m in modes:
        best = max_step[m]
        gain[m] = None if base is None or base == 0 or best is None else best / base
    return {"kind": "walk-sweep", "walk_file": spec.source, "name": spec.name, "robot": spec.robot.name,
            "com_height_m": spec.com.height_m, "timing": {"single_support_s": spec.timing.single_support_s,
                                                          "double_support_s": spec.timing.double_support_s},
            "k_pel": spec.rotation.k_pel,
            "arm_swing": spec.arms.enabled and bool(spec.robot.walking.arm_swing), "rehearsed": spec.success.rehearse,
            "steps_m": list(lengths_m), "modes": list(modes), "max_step_m": max_step,
            "longest_successful_step_m": longest_ok, "step_gain_over_none": gain, "rows": rows}


def sweep_png(doc: dict) -> bytes:
    """Table 1 and Fig. 13 as pictures: E_con over two steps and peak κ against step length per mode,
    failed lengths hollow, each mode's longest step marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5), constrained_layout=True)
    colors = {"none": "tab:blue", "paper_b": "tab:red"}
    for m in doc["modes"]:
        rows = [r for r in doc["rows"] if r["mode"] == m and "energy_two_steps_j" in r]
        if not rows:
            continue
        x = np.array([r["step_m"] for r in rows])
        ok = np.array([r["ok"] for r in rows])
        c = colors.get(m, "k")
        for ax, key in zip(axes, ("energy_two_steps_j", "peak_kappa", "peak_yaw_momentum_nms"), strict=True):
            y = np.array([r[key] for r in rows], dtype=float)
            ax.plot(x, y, color=c, lw=1, alpha=0.6)
            ax.scatter(x[ok], y[ok], color=c, s=18, label=f"{m}: max step {doc['max_step_m'][m]} m")
            ax.scatter(x[~ok], y[~ok], facecolors="none", edgecolors=c, s=18)
            if key == "peak_kappa":
                legs = np.array([r["peak_kappa_leg"] for r in rows], dtype=float)
                ax.plot(x, legs, color=c, ls="--", lw=1, label=f"{m}, the legs' own κ")
            if key == "peak_yaw_momentum_nms":
                held = np.array([np.nan if r.get("peak_yaw_momentum_arms_held_nms") is None
                                 else r["peak_yaw_momentum_arms_held_nms"] for r in rows], dtype=float)
                if np.isfinite(held).any():
                    ax.plot(x, held, color=c, ls=":", lw=1, label=f"{m}, arms held")
        best = doc["max_step_m"][m]
        if best is not None:
            for ax in axes:
                ax.axvline(best, color=c, ls="--", lw=0.8)
    axes[1].set_yscale("log")
    titles = ("E_con over two steps (B-44, Table 1) [J]", "peak κ(J_low) (B-45, Fig. 13) and the legs' κ",
              "peak yaw momentum (Figs. 12, 16) [N·m·s]")
    for ax, title in zip(axes, titles, strict=True):
        ax.set_xlabel("step length [m]")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"{doc['name']} on {doc['robot']} (filled: walked, hollow: failed)", fontsize=11)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()
