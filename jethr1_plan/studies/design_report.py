"""What ``jethr1 design`` writes: one row per variant (``design.csv``, ``design.json``), the Pareto fronts, the
plots, and the best variants as robot folders ready for ``jethr1 plan``.

Every figure comes from the variants' results (``studies.design``); nothing here depends on how or where they
were computed, so the files are the same bytes for any ``-j`` and executor (the timings go to ``timings.json``,
the one file that differs from run to run).
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np

from jethr1_plan.io.csv_table import csv_text, number_text
from jethr1_plan.studies.design_spec import DesignSpec, Variant

__all__ = ["COLUMNS", "OWN_FILES", "SUBFOLDERS", "best_folders", "best_variants", "design_csv", "design_doc",
           "design_png", "pareto_front", "readme_text", "scenario_text", "variant_rows"]

MASS_DIGITS = 9  # masses in the files to the microgram [kg]: sums of link masses differ from the design by rounding
OWN_FILES = frozenset({"design.csv", "design.json", "design.png", "timings.json"})
SUBFOLDERS = ("robots", "scenarios")  # the best variants' robot folders and their crossings
LEVEL_NAMES = ("whole", "half", "crossed")
#: design.csv's columns after the axes' (each axis a column of its own, named as in the design file)
COLUMNS = (
    "fans",  # fans present
    "mass_kg",  # the variant's total mass
    "added_mass_kg",  # its mass less the base robot's
    "fan_mass_kg",  # its fans' mass
    "total_thrust_n",  # the sum of its fans' maximum thrusts
    "whole_gap_m",  # the widest ditch crossed with the whole tolerance on every row (empty: none)
    "whole_next_failing_m",  # the next gap planned beyond it, which fails (empty: the lattice's end)
    "whole_peak_thrust_n", "whole_mean_thrust_n", "whole_energy_j", "whole_impulse_ns",  # that crossing's
    "half_gap_m", "half_next_failing_m", "half_share", "half_peak_thrust_n",
    "crossed_gap_m", "crossed_next_failing_m", "crossed_share", "crossed_peak_thrust_n",
    "minimal_peak_thrust_n",  # Paper A's minimal plan at crossed_gap_m: its peak thrust (empty: infeasible)
    "plans",  # plans made to judge it
    "monotone",  # no wider gap held a level a narrower one failed (the bisection's premise)
    "pareto_mass",  # on the front of added mass against whole_gap_m
    "pareto_thrust",  # on the front of total thrust against whole_gap_m
    "status",  # ok, or why not (refused: the robot checks; error: a bug)
)


def _num(x: float | None) -> str:
    return "" if x is None else number_text(float(x))


def pareto_front(cost: list[float | None], gain: list[float | None]) -> list[int]:
    """Indices of the points no other point beats: less (or equal) ``cost`` and more (or equal) ``gain``, one of
    them strictly; points with either missing are on no front. In index order."""
    pts = [(c, g, i) for i, (c, g) in enumerate(zip(cost, gain, strict=True)) if c is not None and g is not None]
    front = []
    for c, g, i in pts:
        if not any((c2 <= c and g2 >= g) and (c2 < c or g2 > g) for c2, g2, _ in pts):
            front.append(i)
    return front


def variant_rows(spec: DesignSpec, variants: list[Variant], keys: list[str], results: dict[str, dict[str, Any]],
                 base_mass_kg: float) -> list[dict[str, Any]]:
    """One record per variant (in order): its axis values, its design's figures and its result's."""
    rows = []
    for v, key in zip(variants, keys, strict=True):
        r = results[key]
        fan_mass = round(sum(f.mass_kg for f in v.design.fans), MASS_DIGITS)
        row: dict[str, Any] = {"variant": v.name, "values": dict(v.values),
                               "fans": len(v.design.fans), "fan_mass_kg": fan_mass,
                               "total_thrust_n": sum(f.thrust_max_n for f in v.design.fans),
                               "design": {"fans": [{"name": f.name, "mount": f.mount, "offset_m": list(f.offset_m),
                                                    "thrust_max_n": f.thrust_max_n, "mass_kg": f.mass_kg,
                                                    "lag_s": f.lag_s, "radius_m": f.radius_m}
                                                   for f in v.design.fans],
                                          "trunk_mass_scale": v.design.trunk_mass_scale,
                                          "leg_length_scale": v.design.leg_length_scale},
                               "status": r.get("status", "error"), "result": r}
        if r.get("status") == "ok":
            row["mass_kg"] = round(r["mass_kg"], MASS_DIGITS)
            row["added_mass_kg"] = round(r["mass_kg"] - base_mass_kg, MASS_DIGITS)
        rows.append(row)
    ok = [i for i, r in enumerate(rows) if r["status"] == "ok"]
    whole = [rows[i]["result"]["widest"]["whole"]["gap_m"] if i in ok else None for i in range(len(rows))]
    for name, cost in (("pareto_mass", "added_mass_kg"), ("pareto_thrust", "total_thrust_n")):
        front = set(pareto_front([rows[i].get(cost) if i in ok else None for i in range(len(rows))], whole))
        for i, row in enumerate(rows):
            row[name] = i in front
    return rows


def design_csv(spec: DesignSpec, rows: list[dict[str, Any]]) -> str:
    """``design.csv``: ``variant``, the axes, :data:`COLUMNS`."""
    axes = [a.name for a in spec.axes]
    header = ["variant", *axes, *COLUMNS]
    lines = []
    for row in rows:
        r = row["result"]
        ok = row["status"] == "ok"
        w = r.get("widest", {}) if ok else {}

        def lv(level: str, field: str, w=w) -> str:
            return _num(w.get(level, {}).get(field)) if w else ""

        minimal = (r.get("minimal") or {}) if ok else {}
        cells = [row["variant"], *(_num(row["values"][a]) for a in axes), str(row["fans"]),
                 _num(row.get("mass_kg")), _num(row.get("added_mass_kg")), _num(row["fan_mass_kg"]),
                 _num(row["total_thrust_n"]),
                 lv("whole", "gap_m"), lv("whole", "next_failing_m"), lv("whole", "peak_thrust_n"),
                 lv("whole", "mean_thrust_n"), lv("whole", "energy_j"), lv("whole", "impulse_ns"),
                 lv("half", "gap_m"), lv("half", "next_failing_m"), lv("half", "share"), lv("half", "peak_thrust_n"),
                 lv("crossed", "gap_m"), lv("crossed", "next_failing_m"), lv("crossed", "share"),
                 lv("crossed", "peak_thrust_n"), _num(minimal.get("peak_thrust_n")),
                 str(r.get("plans", "")) if ok else "", ("true" if r.get("monotone") else "false") if ok else "",
                 "true" if row["pareto_mass"] else "false", "true" if row["pareto_thrust"] else "false",
                 row["status"] if ok else f"{row['status']}: {r.get('reason', '')}"]
        lines.append(cells)
    return csv_text(header, lines)


def best_variants(rows: list[dict[str, Any]], count: int) -> list[dict[str, Any]]:
    """The front of added mass against the widest robust ditch, widest first (then lightest), at most ``count``."""
    front = [r for r in rows if r["pareto_mass"]]
    front.sort(key=lambda r: (-r["result"]["widest"]["whole"]["gap_m"], r["added_mass_kg"], r["variant"]))
    return front[:count]


def design_doc(spec: DesignSpec, base: dict[str, Any], rows: list[dict[str, Any]], best: list[str]) -> dict[str, Any]:
    """``design.json``: the design space, the base robot, the judge, every variant (its design and result), the
    fronts and the best variants."""
    return {
        "name": spec.name, "description": spec.description, "source": spec.source,
        "base_robot": base, "sampling": {"method": spec.method, "samples": spec.samples, "seed": spec.seed},
        "axes": [{"name": a.name, **({"values": list(a.values)} if a.values is not None else
                                     {"range": list(a.range or ()), "count": a.count})} for a in spec.axes],
        "judge": {**spec.judge.as_dict(), "levels": {"whole": "every row holds the whole tolerance (share >= 1)",
                                                    "half": "every row holds half of it (share >= 0.5)",
                                                    "crossed": "a plan exists (share >= 0): Paper A's minimal "
                                                               "criterion"}},
        "variants": [{k: v for k, v in r.items()} for r in rows],
        "pareto": {"added_mass": [r["variant"] for r in rows if r["pareto_mass"]],
                   "total_thrust": [r["variant"] for r in rows if r["pareto_thrust"]]},
        "best": best,
    }


def design_png(spec: DesignSpec, rows: list[dict[str, Any]]) -> bytes:
    """Left: the widest ditch crossed with the whole tolerance and at all against the first axis (a colour per value
    of the second, where there is one). Middle and right: the widest robust ditch against added mass and against
    total thrust, coloured by the first axis, with the fronts."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r["status"] == "ok"]
    fig, axs = plt.subplots(1, 3, figsize=(16, 5.2), constrained_layout=True)
    first = spec.axes[0].name
    second = spec.axes[1].name if len(spec.axes) > 1 else None
    ax = axs[0]
    groups: dict[float, list[dict[str, Any]]] = {}
    for r in ok:
        groups.setdefault(r["values"][second] if second else 0.0, []).append(r)
    values = sorted(groups)
    norm = matplotlib.colors.Normalize(min(values), max(values) if max(values) > min(values) else min(values) + 1)
    cmap = plt.get_cmap("plasma")
    connect = spec.method == "grid"  # lines through a grid's points; a Latin hypercube's stand alone
    for value in values:
        members = sorted(groups[value], key=lambda r: r["values"][first])
        x = [r["values"][first] for r in members]
        for level, style in (("whole", "o-"), ("crossed", "x:")):
            gaps = [r["result"]["widest"][level]["gap_m"] for r in members]
            ax.plot(x, [np.nan if g is None else 1000 * g for g in gaps], style if connect else style[0], ms=4,
                    color=cmap(norm(value)), lw=1)
    ax.plot([], [], "ko-", ms=4, lw=1, label="the whole tolerance")
    ax.plot([], [], "kx:", ms=4, lw=1, label="crossed at all")
    ax.set_xlabel(first)
    ax.set_ylabel("widest ditch [mm]")
    ax.set_title("the widest ditch crossed")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if second:
        fig.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, label=second)
    for ax, cost, front, label in ((axs[1], "added_mass_kg", "pareto_mass", "added mass [kg]"),
                                   (axs[2], "total_thrust_n", "pareto_thrust", "total maximum thrust [N]")):
        whole = [r["result"]["widest"]["whole"]["gap_m"] for r in ok]
        sc = ax.scatter(np.array([r[cost] for r in ok], dtype=float),
                        np.array([np.nan if g is None else 1000 * g for g in whole]),
                        c=np.array([r["values"][first] for r in ok], dtype=float), s=18, cmap="viridis")
        f = sorted((r for r in ok if r[front]), key=lambda r: r[cost])
        ax.plot([r[cost] for r in f], [1000 * r["result"]["widest"]["whole"]["gap_m"] for r in f], "r-", lw=1.5,
                label="Pareto front")
        ax.set_xlabel(label)
        ax.set_ylabel("widest ditch with the whole tolerance [mm]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        fig.colorbar(sc, ax=ax, label=first)
    fig.suptitle(f"{spec.name}: {len(ok)} variants of {spec.base_robot}, judged by the ditch curve")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return buf.getvalue()


def scenario_text(name: str, robot_path: str, gap_m: float, judge: dict[str, Any], thrust_max_n: float,
                  sole_length_m: float) -> str:
    """A scenario (``jethr1 plan``) of Paper A's forward step over a ditch of ``gap_m`` [m] for the robot at
    ``robot_path``, with the judge's tolerance as its robust objective (the geometry of ``jethr1 ditch-curve``)."""
    from jethr1_plan.studies.ditch_curve import HEEL_INSIDE_M, SUPPORT_Y_M, TOE_X_M

    half = 0.21 / 2
    landing = TOE_X_M + gap_m + HEEL_INSIDE_M + sole_length_m / 2
    t = judge["tolerance"]
    return (f"# Paper A's forward step over a {1000 * gap_m:.0f} mm ditch (the geometry of jethr1 ditch-curve) for a "
            f"design variant,\n# written by jethr1 design. The robot path is read from where the command runs.\n"
            f"name: {name}\nrobot: {robot_path}\nseed: {judge['seed']}\nstart:\n"
            f"  left: [0.0, {-SUPPORT_Y_M!r}, 0.0]\n  right: [0.0, {SUPPORT_Y_M!r}, 0.0]\n"
            f"terrain:\n  cartons:\n"
            f"    - {{top_centre_m: [{round(TOE_X_M - half, 9)!r}, {SUPPORT_Y_M!r}, 0.0]}}\n"
            f"    - {{top_centre_m: [{round(TOE_X_M - half, 9)!r}, {-SUPPORT_Y_M!r}, 0.0]}}\n"
            f"    - {{top_centre_m: [{round(TOE_X_M + gap_m + half, 9)!r}, {SUPPORT_Y_M!r}, 0.0]}}\n"
            f"steps:\n  - swing: left\n    landing_m: [{round(landing, 9)!r}, {SUPPORT_Y_M!r}, 0.0]\n"
            f"    path: {{kind: arc, clearance_m: 0.06, samples: 60}}\n"
            f"optimiser:\n  method: {judge['optimiser']}\n"
            f"balance:\n  policy: robust\n  robust: {{thrust_error: {t['thrust_error']!r}, mass_error: "
            f"{t['mass_error']!r}, com_error_m: {t['com_error_m']!r}}}\n  thrust_max_n: {thrust_max_n!r}\n"
            f"timing:\n  swing_s: 7.5\n  transfer_s: 3.0\n  rate_hz: 50.0\n")


def readme_text(spec: DesignSpec, row: dict[str, Any], name: str) -> str:
    """The README of a best variant's robot folder: what it is and what the judge found."""
    d = row["design"]
    w = row["result"]["widest"]
    lines = [f"# {name}: a design variant of {spec.base_robot}", "",
             f"Written by `jethr1 design {spec.source}` (variant {row['variant']}). Everything "
             "but the fans and the scales below is the base robot's.", "",
             "| fan | mount | offset [m] | max thrust [N] | mass [kg] |", "| --- | --- | --- | ---: | ---: |"]
    for f in d["fans"]:
        lines.append(f"| {f['name']} | {f['mount']} | {', '.join(f'{v:g}' for v in f['offset_m'])} | "
                     f"{f['thrust_max_n']:g} | {f['mass_kg']:.4g} |")
    lines += ["", f"Trunk mass × {d['trunk_mass_scale']:g}, leg length × {d['leg_length_scale']:g}; total mass "
              f"{row['mass_kg']:.4g} kg ({row['added_mass_kg']:+.4g} kg against the base).", "",
              "Widest ditch of Paper A's forward step (jethr1 ditch-curve's geometry):", ""]
    for level, what in (("whole", "with the whole tolerance"), ("half", "with half of it"), ("crossed", "at all")):
        gap = w[level]["gap_m"]
        lines.append(f"* {what}: " + ("none of the gaps judged" if gap is None else
                                      f"{1000 * gap:.0f} mm (peak thrust {w[level]['peak_thrust_n']:.2f} N)"))
    lines += ["", f"Plan the crossing: `jethr1 plan scenarios/{name}_ditch_whole.yaml` (in the design's output folder) "
              "from the folder the design command ran in.", ""]
    return "\n".join(lines)


def best_folders(spec: DesignSpec, best: list[dict[str, Any]], outdir: Path) -> dict[str, bytes]:
    """The files of the best variants (relative path → bytes): their robot folders ``robots/<name>/`` (the URDF, the
    YAML, a README) and ``scenarios/<name>_ditch_whole.yaml`` (the crossing of the widest robust ditch), ``<name>``
    being ``<design name>_<variant>``."""
    from jethr1_plan.robot.load import load_robot
    from jethr1_plan.robot.variant import FanDesign, VariantDesign, variant_files

    base = load_robot(spec.base_robot)
    out: dict[str, bytes] = {}
    for row in best:
        name = f"{spec.name}_{row['variant']}"
        d = row["design"]
        design = VariantDesign(tuple(FanDesign(f["name"], f["mount"], tuple(f["offset_m"]), f["thrust_max_n"],
                                               f["mass_kg"], f["lag_s"], f["radius_m"]) for f in d["fans"]),
                               d["trunk_mass_scale"], d["leg_length_scale"])
        files = variant_files(base.yaml_path, design, name, f"A design variant of {base.name} ({spec.name} "
                              f"{row['variant']}).")
        for fname, data in files.items():
            out[f"robots/{name}/{fname}"] = data
        out[f"robots/{name}/README.md"] = readme_text(spec, row, name).encode()
        gap = row["result"]["widest"]["whole"]["gap_m"]
        robot_path = (Path(outdir) / "robots" / name).as_posix()
        out[f"scenarios/{name}_ditch_whole.yaml"] = scenario_text(
            f"{name}_ditch_{1000 * gap:.0f}", robot_path, gap, spec.judge.as_dict(), row["result"]["thrust_max_n"],
            base.sole_length_m).encode()
    return out
