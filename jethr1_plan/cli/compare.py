"""``jethr1 compare``: Paper A's comparison of the optimisers, and their Pareto fronts."""

from __future__ import annotations

from pathlib import Path

import click
from rich.table import Table

from jethr1_plan.cli.common import SEED, Progress, cap_jobs, cores, err_console, print_json
from jethr1_plan.errors import InfeasiblePlan, InputError
from jethr1_plan.io.json_text import json_text
from jethr1_plan.optimisers import METHODS

__all__ = ["compare_cmd"]

COMPARE_FILES = ("compare.json", "compare_trajectories.png", "compare_time.png")
PARETO_FILES = ("pareto.json", "pareto.png")


@click.command("compare")
@click.argument("scenario_path", metavar="SCENARIO.yaml", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", default=None, type=click.Path(file_okay=False, path_type=Path),
              help="Write compare.json and the figures here (default: out/compare/<scenario stem>).")
@click.option("--methods", default=None,
              help="Comma-separated optimisers [default: gas,ga,gaex,sqp; with --pareto gas,sqp].")
@click.option("--seed", type=SEED, help="Override the scenario's seed.")
@click.option("--reference", is_flag=True, help="Also solve every sample exhaustively and report optimality gaps.")
@click.option("--yaw-modes", default="eq4", show_default=True,
              help="Comma-separated body-yaw modes (eq4, mpc, ...); later ones are reported as method+mode.")
@click.option("--pareto", is_flag=True,
              help="Sweep each method's smoothness weight (GAS's ω, sqp's ε): fronts of max and mean thrust against "
                   "Σ‖ΔP‖² (pareto.json, pareto.png) and whether the default dominates GAS.")
@click.option("-j", "--jobs", default=1, show_default=True, type=click.IntRange(min=1),
              help="--pareto: processes planning the weights (output does not depend on it, but for wall times).")
@click.option("--json", "as_json", is_flag=True, help="Print the comparison as JSON on stdout.")
@click.option("--no-progress", is_flag=True)
def compare_cmd(scenario_path, outdir, methods, seed, reference, yaw_modes, pareto, jobs, as_json,
                no_progress) -> None:
    """Paper A's comparison of the optimisers (thrust, smoothness, evaluations, time; Figs. 7, 9, 10)."""
    from jethr1_plan.io.atomic import staged_directory
    from jethr1_plan.scenario import REFERENCE_SAMPLE_S, check_plan_time, load_scenario
    from jethr1_plan.studies.compare import compare, comparison_pngs

    methods = ("gas,sqp" if pareto else "gas,ga,gaex,sqp") if methods is None else methods
    names = tuple(m.strip() for m in methods.split(",") if m.strip())
    unknown = [m for m in names if m not in METHODS]
    if unknown:
        raise InputError("--methods", ",".join(unknown), f"unknown optimiser (known: {', '.join(METHODS)})")
    if not names or len(set(names)) != len(names):
        raise InputError("--methods", repr(methods), f"expected distinct optimisers among {', '.join(METHODS)}")
    from jethr1_plan.scenario_schema import YAW_MODES

    modes = tuple(m.strip() for m in yaw_modes.split(",") if m.strip())
    if not modes or any(m not in YAW_MODES for m in modes) or len(set(modes)) != len(modes):
        raise InputError("--yaw-modes", yaw_modes[:60], f"expected distinct modes among {', '.join(YAW_MODES)}")
    scenario = load_scenario(scenario_path)
    from jethr1_plan.studies.compare import PARETO_WEIGHTS

    runs = max(len(PARETO_WEIGHTS.get(m, ())) for m in names) if pareto else len(modes)
    samples = sum(len(st.path_m) for st in scenario.steps)
    check_plan_time(scenario, names, plans=runs, workers=min(jobs, cores()) if pareto else 1,
                    key="--reference" if reference else "--methods", what=f"the comparison ({runs} plans per method"
                    f"{', and the exhaustive reference' if reference else ''})",
                    extra_s=len(modes) * samples * REFERENCE_SAMPLE_S if reference and not pareto else 0.0)
    outdir = outdir or Path("out") / "compare" / Path(scenario.source).stem
    from jethr1_plan.io.record import check_writable

    check_writable(outdir, writes=PARETO_FILES if pareto else COMPARE_FILES)
    jobs = cap_jobs(jobs)
    if pareto:
        _pareto(scenario, names, seed, jobs, outdir, as_json, no_progress)
        return
    with Progress(not no_progress, "compare") as progress:
        doc = compare(scenario, names, seed, reference, progress, modes)
    with staged_directory(outdir, frozenset(COMPARE_FILES)) as staging:
        tmp = staging.path
        (tmp / "compare.json").write_text(json_text(doc))
        for name, data in comparison_pngs(doc).items():
            (tmp / name).write_bytes(data)
    if as_json:
        print_json(doc)

    def fmt(v, digits):
        return "" if v is None else f"{v:.{digits}f}"

    def _dynamic(v):
        return "pull" if v is None else f"{1000 * v:.1f}"

    t = Table(title=f"{scenario.name}: optimisers (seed {doc['seed']})")
    cols = ["method", "max F [N]", "mean F [N]", "Σ‖ΔP‖² [m²]", "max ‖ΔP‖ [m]", "max ΔF [N]", "evaluations",
            "wall [s]", "feasible", "dynamic ZMP margin [mm]", "peak yaw rate [rad/s]", "peak yaw acc [rad/s²]"] + (
        ["gap max [N]", "gap mean [N]"] if reference else [])
    for col in cols:
        t.add_column(col, justify="right")
    for name, m in doc["methods"].items():
        row = [name, f"{m['peak_thrust_n']:.3f}", f"{m['mean_thrust_n']:.3f}", f"{m['smoothness_m2']:.2e}",
               f"{m['max_step_m']:.4f}", f"{m['max_thrust_jump_n']:.3f}", str(m["evaluations"]), f"{m['wall_s']:.2f}",
               str(m["feasible"]), _dynamic(m.get("dynamic_zmp_margin_m")), fmt(m["peak_yaw_rate_rad_s"], 4),
               fmt(m["peak_yaw_accel_rad_s2"], 4)]
        if reference:
            row += [f"{m['gap_max_n']:.3f}", f"{m['gap_mean_n']:.3f}"]
        t.add_row(*row)
    err_console.print(t)
    err_console.print(f"wrote {outdir}/compare.json, compare_trajectories.png, compare_time.png")
    infeasible = [name for name, m in doc["methods"].items() if not m["feasible"]]
    if infeasible:
        raise InfeasiblePlan(f"{scenario.name}: no feasible plan from {', '.join(infeasible)} (compare.json written "
                             f"to {outdir}/)")



def _pareto(scenario, names, seed, jobs, outdir, as_json, no_progress) -> None:
    """``compare --pareto``: the fronts, their table, pareto.json and pareto.png."""
    from jethr1_plan.io.atomic import staged_directory
    from jethr1_plan.studies.compare import pareto, pareto_png

    with Progress(not no_progress, "pareto") as progress:
        doc = pareto(scenario, names, seed, jobs=jobs, progress=progress)
    with staged_directory(outdir, frozenset(PARETO_FILES)) as staging:
        (staging.path / "pareto.json").write_text(json_text(doc))
        (staging.path / "pareto.png").write_bytes(pareto_png(doc))
    if as_json:
        print_json(doc)
    t = Table(title=f"{scenario.name}: thrust against smoothness ({doc['policy']} policy, seed {doc['seed']})")
    for col in ("method", "weight", "max F [N]", "mean F [N]", "Σ‖ΔP‖² [m²]", "evaluations", "wall [s]", "front"):
        t.add_column(col, justify="right")
    for m, pts in doc["fronts"].items():
        for p in pts:
            t.add_row(m + (" (default)" if p["default"] else ""), f"{p['weight']:g}",
                      f"{p['peak_thrust_n']:.3f}" if p["peak_thrust_n"] is not None else "",
                      f"{p['mean_thrust_n']:.3f}" if p["mean_thrust_n"] is not None else "",
                      f"{p['smoothness_m2']:.2e}", str(p["evaluations"]), f"{p['wall_s']:.2f}",
                      "yes" if p["on_front"] else ("infeasible" if not p["feasible"] else ""))
    err_console.print(t)
    for m, v in doc.get("verdict", {}).items():
        word = "dominates" if v["dominates_gas"] else "does not dominate"
        err_console.print(f"{m} at its default {word} GAS: max {v['peak_thrust_n'][0]:.3f} vs "
                          f"{v['peak_thrust_n'][1]:.3f} N,"
                          f" mean {v['mean_thrust_n'][0]:.3f} vs {v['mean_thrust_n'][1]:.3f} N, Σ‖ΔP‖² "
                          f"{v['smoothness_m2'][0]:.2e} vs {v['smoothness_m2'][1]:.2e} m², "
                          f"{v['evaluation_factor']:.1f}x fewer evaluations", markup=False)
    err_console.print(f"wrote {outdir}/pareto.json, pareto.png")
    none = [m for m, pts in doc["fronts"].items() if not any(p["feasible"] for p in pts)]
    if none:
        raise InfeasiblePlan(f"{scenario.name}: no weight gives a feasible plan from {', '.join(none)} "
                             f"(pareto.json written to {outdir}/)")

