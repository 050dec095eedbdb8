"""The ``jethr1`` command line: a thin shell around the planner (CONTRACT.md).

Exit codes: 0 done, 1 a bug, 2 bad input, 3 infeasible plan, 4 a batch expectation failed.
Progress and messages go to stderr; ``--json`` prints one JSON document on stdout.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import click
import numpy as np
from rich.console import Console
from rich.table import Table

from jethr1_plan.cli_common import FiniteFloat, Progress, err_console, range_spec, report_kept
from jethr1_plan.cli_walk import walk_cmd, walk_sweep_cmd
from jethr1_plan.errors import InfeasiblePlan, InputError, Jethr1Error
from jethr1_plan.io.json_text import json_text
from jethr1_plan.optimisers import METHODS


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="jethr1-plan")
def main() -> None:
    """Plan thrust-assisted steps over ditches for the Jet-HR1 biped (SI units throughout)."""


@main.group()
def robot() -> None:
    """Robot models."""


@robot.command("show")
@click.argument("name", default="jethr1")
@click.option("--json", "as_json", is_flag=True, help="Print the model summary as JSON on stdout.")
def robot_show(name: str, as_json: bool) -> None:
    """Mass, height, leg length, joints, fans and sole of robot NAME (a name, folder or YAML path)."""
    from jethr1_plan.robot.model import load_robot, robot_summary

    summary = robot_summary(load_robot(name))
    if as_json:
        click.echo(json_text(summary), nl=False)
        return
    out = Console()
    out.print(f"[bold]{summary['name']}[/]  {summary['urdf']}")
    out.print(f"mass {summary['mass_kg']:.3f} kg   height {summary['height_m']:.3f} m   "
              f"leg {summary['leg_length_m']:.3f} m   hip width {summary['hip_width_m']:.3f} m   "
              f"sole {summary['sole']['length_m']:.3f} x {summary['sole']['width_m']:.3f} m")
    t = Table(title="joints")
    for col in ("joint", "lower [rad]", "upper [rad]", "effort [N·m]", "servo limit [N·m]"):
        t.add_column(col, justify="right" if col != "joint" else "left")
    for j in summary["joints"]:
        t.add_row(j["name"], f"{j['lower_rad']:+.3f}", f"{j['upper_rad']:+.3f}", f"{j['effort_nm']:.3f}",
                  f"{j['servo_limit_nm']:.3f}")
    out.print(t)
    f = Table(title="fans")
    for col in ("fan", "frame", "on", "max thrust [N]", "offset in its mount [m]"):
        f.add_column(col)
    for fan in summary["fans"]:
        f.add_row(fan["name"], fan["frame"], fan["mount"], f"{fan['max_thrust_n']:.1f}",
                  ", ".join(f"{v:+.3f}" for v in fan["offset_m"]))
    out.print(f)


LAYOUT = Path(__file__).resolve().parent / "foxglove_layout.json"  # Foxglove: the plan, its rehearsal, thrust


@main.command()
@click.argument("scenario_path", metavar="SCENARIO.yaml", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", default="out", show_default=True, type=click.Path(file_okay=False,
              path_type=Path), help="Output directory; files go to OUTDIR/<scenario stem>/.")
@click.option("--optimiser", type=click.Choice(list(METHODS)), help="Override optimiser.method.")
@click.option("--seed", type=click.IntRange(min=0), help="Override the scenario's seed.")
@click.option("--json", "as_json", is_flag=True, help="Print summary.json on stdout.")
@click.option("--no-progress", is_flag=True, help="No progress bar.")
@click.option("--write-infeasible", is_flag=True,
              help="On an infeasible plan, still write the trajectory; infeasible rows say so.")
@click.option("-j", "--jobs", default=1, show_default=True, type=click.IntRange(min=1),
              help="Processes optimising steps in parallel (output does not depend on it).")
@click.option("--kinematics", type=click.Choice(["placo", "analytic"]), default="placo", show_default=True,
              help="Leg IK: PlaCo's solver, or the closed form (same postures to 1e-9 m, faster).")
@click.option("--strict-torque", is_flag=True, help="Rows whose static torque exceeds a servo limit are infeasible.")
@click.option("--policy", type=click.Choice(["robust", "minimal"]),
              help="Override balance.policy: robust (thrust that survives model errors) or minimal (Paper A).")
def plan(scenario_path: Path, outdir: Path, optimiser: str | None, seed: int | None, as_json: bool,
         no_progress: bool, write_infeasible: bool, jobs: int, kinematics: str, strict_torque: bool,
         policy: str | None) -> None:
    """Plan SCENARIO.yaml: optimise P_body along each swing, write CSV, MCAP and summary.json."""
    from dataclasses import replace

    from jethr1_plan.io.atomic import check_writable
    from jethr1_plan.io.plan_files import write_plan_outputs, write_summary_only
    from jethr1_plan.planning import plan as run_plan
    from jethr1_plan.planning import plan_summary
    from jethr1_plan.scenario import load_scenario

    scenario = load_scenario(scenario_path)
    if policy is not None:
        scenario = replace(scenario, balance=replace(scenario.balance, policy=policy))
    check_writable(outdir)
    try:
        with Progress(not no_progress, scenario.name) as progress:
            result = run_plan(scenario, method=optimiser, seed=seed, progress=progress, keep_going=write_infeasible,
                              jobs=jobs, kinematics=kinematics, strict_torque=strict_torque)
    except InfeasiblePlan as exc:
        report_kept(*write_summary_only(scenario, outdir, exc.summary))
        raise
    summary = plan_summary(result)
    folder, kept = write_plan_outputs(result, outdir, summary, trajectory=True, strict_torque=strict_torque)
    report_kept(folder, kept)
    if as_json:
        click.echo(json_text(summary), nl=False)
    bad = result.first_infeasible
    if bad is not None:
        raise InfeasiblePlan(f"infeasible: {bad['reason']} (step {bad['step']} {bad['phase']} sample {bad['sample']}); "
                             "trajectory written with infeasible rows marked")
    _report_plan(summary, folder)


def _report_plan(summary: dict, folder: Path) -> None:
    c = err_console
    c.print(f"[green]feasible[/] {summary['scenario']}: {summary['sample_count']} swing samples, "
            f"max thrust {summary['max_thrust_n']:.2f} N, mean {summary['mean_thrust_n']:.2f} N, "
            f"{summary['evaluations']} evaluations in {summary['wall_s']:.1f} s")
    b = summary["balance"]
    tol = b["tolerance"]
    policy = ("minimal thrust (Paper A: the ZMP on the sole's edge)" if b["policy"] == "minimal" else
              f"robust to ±{100 * tol['thrust_error']:g} % thrust, ±{100 * tol['mass_error']:g} % mass, "
              f"{1000 * tol['com_error_m']:g} mm of CoM error")
    rob = summary.get("robustness", {})
    c.print(f"balance: {policy}")
    if rob.get("least_zmp_margin_m") is not None:
        at = rob["least_zmp_margin_at"]
        margin_mm = round(1000 * rob["least_zmp_margin_m"], 1) + 0.0  # no "-0.0"
        line = (f"least ZMP margin {margin_mm:.1f} mm (step {at['step']} {at['phase']} row {at['row']}, "
                f"t = {at['time_s']:.2f} s)")
        if "narrowest_window_n" in rob:
            lo, hi = rob["narrowest_window_n"]
            at = rob["narrowest_window_at"]
            line += (f"; narrowest thrust window [{lo:.2f}, {hi:.2f}] N (step {at['step']} {at['phase']} row "
                     f"{at['row']}, t = {at['time_s']:.2f} s)")
        c.print(line)
    c.print(f"wrote {folder}/trajectory.csv, trajectory.mcap, summary.json")
    c.print(f"Foxglove: open trajectory.mcap and import the layout {LAYOUT} (the robot comes from the "
            "file's /robot_description; its rehearsal, simulation.mcap, plays beside it)", markup=False)


def _require_dask(executor: str) -> None:
    """Exit 2 with the install hint when --executor dask is asked for without the extra."""
    if executor == "dask":
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise InputError("--executor", "dask",
                             "needs the optional extra: pip install 'jethr1-plan[dask]'") from None


def _pair(ctx, param, value):
    if value is None:
        return None
    lo, hi = value
    if not lo < hi:
        raise click.BadParameter(f"expected LOW < HIGH, got {lo} {hi}")
    return (float(lo), float(hi))


@main.command("balance-space")
@click.option("--robot", "robot_name", default="jethr1", show_default=True, help="Robot name or path.")
@click.option("--support", type=click.Choice(["left", "right"]), default="right", show_default=True,
              help="Which sole supports; the other one sweeps.")
@click.option("--support-position", nargs=3, type=FiniteFloat(-100, 100), default=None, metavar="X Y Z",
              help="Support sole centre [m] (default: where the robot stands, its stance width apart).")
@click.option("--x-range", nargs=2, type=FiniteFloat(-100, 100), callback=_pair, metavar="LOW HIGH",
              help="Swing sole x bounds [m].")
@click.option("--y-range", nargs=2, type=FiniteFloat(-100, 100), callback=_pair, metavar="LOW HIGH",
              help="Swing sole y bounds [m].")
@click.option("--z-range", nargs=2, type=FiniteFloat(-100, 100), callback=_pair, metavar="LOW HIGH",
              help="Swing sole z bounds [m].")
@click.option("--resolution", default=0.01, show_default=True, type=FiniteFloat(0.001, 1.0), help="Grid step [m].")
@click.option("--thrust-max", default=None, type=FiniteFloat(0.0, 1e4),
              help="F_max of every fan [N] (default: each fan's own maximum).")
@click.option("--method", type=click.Choice(["continuation", "exhaustive"]), default="continuation", show_default=True,
              help="Inner search over P_body.")
@click.option("--pbody-resolution", default=0.01, show_default=True, type=FiniteFloat(0.001, 0.1),
              help="P_body grid step of the exhaustive method [m].")
@click.option("-j", "--jobs", default=2, show_default=True, type=click.IntRange(min=1), help="Worker processes.")
@click.option("--executor", type=click.Choice(["loky", "dask"]), default="loky", show_default=True)
@click.option("--scheduler", default=None, help="Dask scheduler address (with --executor dask); default: local.")
@click.option("-o", "--output", "outdir", default="out/balance_space", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print summary.json on stdout.")
@click.option("--no-progress", is_flag=True)
def balance_space(robot_name, support, support_position, x_range, y_range, z_range, resolution, thrust_max, method,
                  pbody_resolution, jobs, executor, scheduler, outdir, as_json, no_progress) -> None:
    """Sweep the swing sole over a grid: the balance space with and without thrust (Paper A, Fig. 5)."""
    from jethr1_plan.balance_space import SweepSpec, summary, sweep, verify_members
    from jethr1_plan.io.atomic import check_writable, staged_directory
    from jethr1_plan.io.balance_space_files import balance_space_csv, balance_space_mcap, balance_space_png
    from jethr1_plan.robot.model import load_robot

    robot = load_robot(robot_name)
    check_writable(outdir.parent)
    if support_position is None:
        support_position = tuple(float(v) for v in robot.start_feet()[support])
    fan_max = max(f.max_thrust_n for f in robot.fans)
    if thrust_max is not None and thrust_max > fan_max:
        raise InputError("--thrust-max", f"{thrust_max:g}", f"more than the robot's fans give ({fan_max:g} N)")
    sx, sy, sz = support_position
    sgn = 1.0 if support == "right" else -1.0  # the swing foot is on the +y side of a right support
    spec = SweepSpec(robot=robot, support_side=support, support_xyz=tuple(support_position),
                     x_range=x_range or (sx - 0.8, sx + 0.9),
                     y_range=y_range or ((sy - 0.7875, sy + 0.9125) if sgn > 0 else (sy - 0.9125, sy + 0.7875)),
                     z_range=z_range or (sz, sz + 0.3), resolution_m=resolution, thrust_max_n=thrust_max,
                     method=method, pbody_resolution_m=pbody_resolution)
    _require_dask(executor)
    with Progress(not no_progress, "balance space") as progress:
        result = sweep(spec, jobs=jobs, executor=executor, scheduler=scheduler, progress=progress)
    checked = verify_members(result)
    doc = summary(result)
    doc["verified_members"] = checked
    with staged_directory(outdir, frozenset({"balance_space.csv", "balance_space.mcap", "balance_space.png",
                                             "summary.json"})) as staging:
        tmp = staging.path
        (tmp / "balance_space.csv").write_text(balance_space_csv(result))
        (tmp / "balance_space.mcap").write_bytes(balance_space_mcap(result, robot.sole_length_m, robot.sole_width_m))
        (tmp / "balance_space.png").write_bytes(balance_space_png(result, robot.sole_length_m, robot.sole_width_m))
        (tmp / "summary.json").write_text(json_text(doc))
    if as_json:
        click.echo(json_text(doc), nl=False)
    w, wo = doc["with_thrust"], doc["without_thrust"]

    def metres(v: float | None) -> str:
        return "-" if v is None else f"{v:.3f} m"

    err_console.print(f"balance space: {w['cells']} cells with thrust (reach forward {metres(w['max_forward_m'])}, "
                      f"sideways {metres(w['max_sideways_m'])}), {wo['cells']} without (forward "
                      f"{metres(wo['max_forward_m'])}, sideways {metres(wo['max_sideways_m'])}) "
                      f"in {doc['wall_s']:.1f} s; wrote {outdir}/")


@main.command()
@click.argument("scenarios", nargs=-1, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--manifest", type=click.Path(dir_okay=False, path_type=Path),
              help="A YAML list of scenario paths (relative to the manifest).")
@click.option("-o", "--output", "outdir", default="out/batch", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("-j", "--jobs", default=2, show_default=True, type=click.IntRange(min=1), help="Worker processes.")
@click.option("--executor", type=click.Choice(["loky", "dask"]), default="loky", show_default=True)
@click.option("--scheduler", default=None, help="Dask scheduler address (with --executor dask); default: local.")
@click.option("--json", "as_json", is_flag=True, help="Print the batch summary on stdout.")
@click.option("--no-progress", is_flag=True)
def batch(scenarios, manifest, outdir, jobs, executor, scheduler, as_json, no_progress) -> None:
    """Plan many scenarios: one subdirectory each, a summary.json and a table; exit 0 when every
    expectation holds, 3 when a plan is unexpectedly infeasible, 4 when an expectation fails."""
    from jethr1_plan.batch import batch_exit_code, read_manifest, run_batch
    from jethr1_plan.io.atomic import write_text_atomic

    paths = list(scenarios) + (read_manifest(manifest) if manifest else [])
    if not paths:
        raise InputError("batch", "SCENARIOS", "give scenario files or --manifest")
    stems = [p.stem for p in paths]
    if len(set(stems)) != len(stems):
        raise InputError("batch", "SCENARIOS", "two scenarios share a file name; their outputs would collide")
    _require_dask(executor)
    from jethr1_plan.io.atomic import check_writable

    check_writable(outdir)
    with Progress(not no_progress, "batch") as progress:
        records = run_batch(paths, outdir, jobs=jobs, executor=executor, scheduler=scheduler, progress=progress)
    code = batch_exit_code(records)
    doc: dict[str, Any] = {"exit_code": code, "scenarios": [{k: v for k, v in r.items() if k != "summary"} | {
        "max_thrust_n": (r.get("summary") or {}).get("max_thrust_n"),
        "mean_thrust_n": (r.get("summary") or {}).get("mean_thrust_n"),
        "feasible": (r.get("summary") or {}).get("feasible"),
        "wall_s": (r.get("summary") or {}).get("wall_s")} for r in records]}
    write_text_atomic(outdir / "summary.json", json_text(doc))
    if as_json:
        click.echo(json_text(doc), nl=False)
    t = Table(title=f"batch: {len(records)} scenarios -> {outdir}")
    for col in ("scenario", "status", "max thrust [N]", "mean [N]", "wall [s]", "expectations"):
        t.add_column(col)
    def fmt(v):
        return "" if v is None else f"{v:.2f}"

    for r in doc["scenarios"]:
        t.add_row(r["name"], r["status"], fmt(r["max_thrust_n"]), fmt(r["mean_thrust_n"]), fmt(r["wall_s"]),
                  "; ".join(r.get("expectations_failed") or []) or ("ok" if r.get("expect") else "-"))
    err_console.print(t)
    for r in records:
        if r["exit_code"] and r.get("error"):
            err_console.print(f"{r['name']}: {r['error']}", markup=False)
    if code:
        raise click.exceptions.Exit(code)


@main.command()
@click.argument("path", type=click.Path(path_type=Path))
@click.option("--scenario", type=click.Path(dir_okay=False, path_type=Path),
              help="Also check the feet against this scenario (default: the one named in summary.json).")
@click.option("--json", "as_json", is_flag=True, help="Print the verdict as JSON on stdout.")
def verify(path: Path, scenario: Path | None, as_json: bool) -> None:
    """Re-check a trajectory (CSV, MCAP or an output folder) with PlaCo, independently of the planner.

    Exit 0 when every row holds, 5 when any fails (one line per failing row on stderr).
    """
    from jethr1_plan.verify import verify_path

    n, failures, what = verify_path(path, scenario)
    if as_json:
        click.echo(json_text({"file": what, "rows": n, "ok": not failures,
                          "failures": [f.__dict__ for f in failures]}), nl=False)
    by_row: dict[int, list] = {}
    for f in failures:
        by_row.setdefault(f.row, []).append(f)
    for row, fs in by_row.items():
        checks = "; ".join(f"{f.check}: {f.detail}" for f in fs)
        err_console.print(f"{what}: row {row} (t = {fs[0].time_s:.3f} s): {checks}", markup=False, soft_wrap=True)
    if failures:
        err_console.print(f"[red]verify: {len(by_row)} failing rows{'+' if len(failures) >= 50 else ''} of {n}[/]")
        raise click.exceptions.Exit(5)
    err_console.print(f"[green]verify: all {n} rows of {what} hold[/]")


@main.command("compare")
@click.argument("scenario_path", metavar="SCENARIO.yaml", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", default=None, type=click.Path(file_okay=False, path_type=Path),
              help="Write compare.json and the figures here (default: out/compare/<scenario stem>).")
@click.option("--methods", default=None,
              help="Comma-separated optimisers [default: gas,ga,gaex,sqp; with --pareto gas,sqp].")
@click.option("--seed", type=click.IntRange(min=0), help="Override the scenario's seed.")
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
    from jethr1_plan.compare import compare, comparison_pngs
    from jethr1_plan.io.atomic import staged_directory
    from jethr1_plan.scenario import load_scenario

    methods = methods or ("gas,sqp" if pareto else "gas,ga,gaex,sqp")
    names = tuple(m.strip() for m in methods.split(",") if m.strip())
    unknown = [m for m in names if m not in METHODS]
    if unknown or not names:
        raise InputError("--methods", ",".join(unknown) or methods, f"unknown optimiser (known: {', '.join(METHODS)})")
    from jethr1_plan.scenario import YAW_MODES

    modes = tuple(m.strip() for m in yaw_modes.split(",") if m.strip())
    if not modes or any(m not in YAW_MODES for m in modes):
        raise InputError("--yaw-modes", yaw_modes, f"expected modes among {', '.join(YAW_MODES)}")
    scenario = load_scenario(scenario_path)
    outdir = outdir or Path("out") / "compare" / Path(scenario.source).stem
    from jethr1_plan.io.atomic import check_writable

    check_writable(outdir.parent)
    if pareto:
        _pareto(scenario, names, seed, jobs, outdir, as_json, no_progress)
        return
    with Progress(not no_progress, "compare") as progress:
        doc = compare(scenario, names, seed, reference, progress, modes)
    with staged_directory(outdir, frozenset({"compare.json", "compare_trajectories.png", "compare_time.png"})
                          ) as staging:
        tmp = staging.path
        (tmp / "compare.json").write_text(json_text(doc))
        for name, data in comparison_pngs(doc).items():
            (tmp / name).write_bytes(data)
    if as_json:
        click.echo(json_text(doc), nl=False)
    def fmt(v, digits):
        return "" if v is None else f"{v:.{digits}f}"

    t = Table(title=f"{scenario.name}: optimisers (seed {doc['seed']})")
    cols = ["method", "max F [N]", "mean F [N]", "Σ‖ΔP‖² [m²]", "max ‖ΔP‖ [m]", "max ΔF [N]", "evaluations",
            "wall [s]", "feasible", "peak yaw rate [rad/s]", "peak yaw acc [rad/s²]"] + (
        ["gap max [N]", "gap mean [N]"] if reference else [])
    for col in cols:
        t.add_column(col, justify="right")
    for name, m in doc["methods"].items():
        row = [name, f"{m['max_thrust_n']:.3f}", f"{m['mean_thrust_n']:.3f}", f"{m['smoothness_m2']:.2e}",
               f"{m['max_step_m']:.4f}", f"{m['max_thrust_jump_n']:.3f}", str(m["evaluations"]), f"{m['wall_s']:.2f}",
               str(m["feasible"]), fmt(m["peak_yaw_rate_rad_s"], 4), fmt(m["peak_yaw_accel_rad_s2"], 4)]
        if reference:
            row += [f"{m['gap_max_n']:.3f}", f"{m['gap_mean_n']:.3f}"]
        t.add_row(*row)
    err_console.print(t)
    err_console.print(f"wrote {outdir}/compare.json, compare_trajectories.png, compare_time.png")


def _pareto(scenario, names, seed, jobs, outdir, as_json, no_progress) -> None:
    """``compare --pareto``: the fronts, their table, pareto.json and pareto.png."""
    from jethr1_plan.compare import pareto, pareto_png
    from jethr1_plan.io.atomic import staged_directory

    with Progress(not no_progress, "pareto") as progress:
        doc = pareto(scenario, names, seed, jobs=jobs, progress=progress)
    with staged_directory(outdir, frozenset({"pareto.json", "pareto.png"})) as staging:
        (staging.path / "pareto.json").write_text(json_text(doc))
        (staging.path / "pareto.png").write_bytes(pareto_png(doc))
    if as_json:
        click.echo(json_text(doc), nl=False)
    t = Table(title=f"{scenario.name}: thrust against smoothness ({doc['policy']} policy, seed {doc['seed']})")
    for col in ("method", "weight", "max F [N]", "mean F [N]", "Σ‖ΔP‖² [m²]", "evaluations", "wall [s]", "front"):
        t.add_column(col, justify="right")
    for m, pts in doc["fronts"].items():
        for p in pts:
            t.add_row(m + (" (default)" if p["default"] else ""), f"{p['weight']:g}",
                      f"{p['max_thrust_n']:.3f}" if p["max_thrust_n"] is not None else "",
                      f"{p['mean_thrust_n']:.3f}" if p["mean_thrust_n"] is not None else "",
                      f"{p['smoothness_m2']:.2e}", str(p["evaluations"]), f"{p['wall_s']:.2f}",
                      "yes" if p["on_front"] else ("infeasible" if not p["feasible"] else ""))
    err_console.print(t)
    for m, v in doc.get("verdict", {}).items():
        word = "dominates" if v["dominates_gas"] else "does not dominate"
        err_console.print(f"{m} at its default {word} GAS: max {v['max_thrust_n'][0]:.3f} vs "
                          f"{v['max_thrust_n'][1]:.3f} N,"
                          f" mean {v['mean_thrust_n'][0]:.3f} vs {v['mean_thrust_n'][1]:.3f} N, Σ‖ΔP‖² "
                          f"{v['smoothness_m2'][0]:.2e} vs {v['smoothness_m2'][1]:.2e} m², "
                          f"{v['evaluation_factor']:.1f}x fewer evaluations", markup=False)
    err_console.print(f"wrote {outdir}/pareto.json, pareto.png")


@main.command("reach")
@click.option("--robot", "robot_name", default="jethr1", show_default=True,
              help="Read l_leg, l_pel from this model (unless given) and search its reach numerically.")
@click.option("--l-leg", type=FiniteFloat(0, 100, lo_open=True), help="Leg length [m] (hip joint to sole).")
@click.option("--z0", type=FiniteFloat(0, 100, lo_open=True), help="Hip height over the soles [m].")
@click.option("--l-pel", type=FiniteFloat(0, 100), help="Pelvis width between the hip joints [m].")
@click.option("--w-step", type=FiniteFloat(0, 100), help="Lateral distance between the feet [m].")
@click.option("--theta-pel-deg", default=45.0, show_default=True, type=FiniteFloat(0, 90),
              help="Pelvic yaw [deg].")
@click.option("--dyros-jet", is_flag=True, help="Use Paper B's Dyros-Jet figures (0.75, 0.68, 0.21, 0.243 m, 45 deg).")
@click.option("--json", "as_json", is_flag=True)
def reach_cmd(robot_name, l_leg, z0, l_pel, w_step, theta_pel_deg, dyros_jet, as_json) -> None:
    """Paper B's step-length analysis (B-1..B-5), and the robot's numerical reach with PlaCo IK."""
    from jethr1_plan.reach import DYROS_JET, ReachFigures, discrepancy_note, numerical_reach, step_lengths
    from jethr1_plan.robot.model import load_robot

    numeric = None
    if dyros_jet:
        fig = ReachFigures(**DYROS_JET)
    else:
        robot = load_robot(robot_name)
        leg = l_leg or robot.leg_length_m
        fig = ReachFigures(l_leg=leg, z0=z0 or 0.9 * leg, l_pel=l_pel if l_pel is not None else 2 * robot.hip_offset_m,
                           w_step=w_step if w_step is not None else 0.225, theta_pel_deg=theta_pel_deg)
        if fig.z0 > fig.l_leg:
            raise InputError("--z0", f"{fig.z0}", f"higher than the leg ({fig.l_leg} m)")
        if l_leg is None:
            numeric = {name: numerical_reach(robot_name, fig.z0, fig.w_step, math.radians(yaw))
                       for name, yaw in (("fixed", 0.0), ("turned", -theta_pel_deg))}
    out = {"inputs": fig.__dict__, **step_lengths(fig)}
    out["note"] = discrepancy_note(out) if dyros_jet else None
    if numeric is not None:
        out["numerical"] = numeric
    if as_json:
        click.echo(json_text(out), nl=False)
        return
    c = Console()
    c.print(f"(B-1) standing, pelvis fixed:    {out['standing_fixed_m']:.4f} m")
    c.print(f"(B-3) kinematic limit:           {out['kinematic_limit_m']:.4f} m")
    c.print(f"(B-4) static, pelvis fixed:      {out['fixed_m']:.4f} m")
    c.print(f"(B-5) static, pelvis turned {fig.theta_pel_deg:g}°: {out['rotating_m']:.4f} m (+{out['gain_pct']:.0f} %)")
    if out["note"]:
        c.print(out["note"])
    for name, n in (numeric or {}).items():
        c.print(f"numerical reach, pelvis {name}: {n['step_m']:.3f} m (PlaCo IK converged: {n['placo_converged']})")


@main.command("ditch-curve")
@click.option("--gaps", default="0.30:0.50:0.01", show_default=True, help="Ditch widths LO:HI:STEP [m].")
@click.option("--scales", default="0,0.25,0.5,0.75,1", show_default=True,
              help="Tolerances as multiples of the scenario's robust tolerance (0: Paper A's minimal thrust).")
@click.option("--scenario", "base_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Take the robot, optimiser, timing and robust tolerance from this scenario (default: defaults).")
@click.option("--optimiser", type=click.Choice(list(METHODS)), help="Override the optimiser.")
@click.option("-j", "--jobs", default=2, show_default=True, type=click.IntRange(min=1), help="Worker processes.")
@click.option("-o", "--output", "outdir", default="out/ditch_curve", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print ditch_curve.json on stdout.")
@click.option("--no-progress", is_flag=True)
def ditch_curve_cmd(gaps, scales, base_path, optimiser, jobs, outdir, as_json, no_progress) -> None:
    """The widest ditch crossable at each tolerance, and the thrust it needs (Paper A's forward step)."""
    from dataclasses import replace

    from jethr1_plan.ditch_curve import curve, curve_png, default_base
    from jethr1_plan.io.atomic import staged_directory
    from jethr1_plan.scenario import load_scenario

    gap_values = np.array(range_spec(gaps, "--gaps"))
    try:
        scale_values = tuple(float(v) for v in scales.split(","))
    except ValueError:
        raise InputError("--scales", scales, "expected comma-separated numbers") from None
    if not scale_values or any(not math.isfinite(v) or v < 0 or v > 5 for v in scale_values):
        raise InputError("--scales", scales, "expected numbers in [0, 5]")
    from jethr1_plan.io.atomic import check_writable

    base = load_scenario(base_path) if base_path else default_base()
    check_writable(outdir.parent)
    if optimiser:
        base = replace(base, optimiser=replace(base.optimiser, method=optimiser))
    robot = base.robot
    with Progress(not no_progress, "ditch curve") as progress:
        doc = curve(base, gap_values, scale_values, robot.sole_length_m, jobs=jobs, progress=progress)
    with staged_directory(outdir, frozenset({"ditch_curve.json", "ditch_curve.png"})) as staging:
        tmp = staging.path
        (tmp / "ditch_curve.json").write_text(json_text(doc))
        (tmp / "ditch_curve.png").write_bytes(curve_png(doc))
    if as_json:
        click.echo(json_text(doc), nl=False)
    t = Table(title=f"widest ditch per tolerance ({doc['optimiser']}, F_max {doc['thrust_max_n']:g} N)")
    for col in ("thrust error", "mass error", "CoM error [m]", "widest gap [m]", "max thrust there [N]"):
        t.add_column(col, justify="right")
    for row in doc["tolerances"]:
        t.add_row(f"±{100 * row['thrust_error']:.1f} %", f"±{100 * row['mass_error']:.1f} %",
                  f"{row['com_error_m']:.4f}", "-" if row["widest_gap_m"] is None else f"{row['widest_gap_m']:.3f}",
                  "-" if row["thrust_at_widest_n"] is None else f"{row['thrust_at_widest_n']:.2f}")
    err_console.print(t)
    err_console.print(f"wrote {outdir}/ditch_curve.json, ditch_curve.png")


@main.command("simulate")
@click.argument("plan_dir", metavar="PLAN_DIR", type=click.Path(file_okay=False, path_type=Path))
@click.option("--controller", type=click.Choice(["feedforward", "feedback"]), default="feedforward", show_default=True,
              help="The planned thrust alone, or corrected by the plan's feedback law on the centre of pressure.")
@click.option("--mass-scale", type=FiniteFloat(0.5, 2.0), default=1.0, show_default=True,
              help="Every link's mass and inertia times this.")
@click.option("--thrust-scale", type=FiniteFloat(0.0, 2.0), default=1.0, show_default=True,
              help="Every fan gives this times its command.")
@click.option("--fan-lag-s", type=FiniteFloat(0.0, 1.0, lo_open=True), default=0.05, show_default=True,
              help="Time constant of the fans' first-order lag [s].")
@click.option("--trials", type=click.IntRange(1, 10000), default=None,
              help="Randomised trials instead of one run: mass ±5 %, CoM within 5 mm, thrust gain 0.8..1.1, "
                   "lag 30..80 ms, servo stiffness 0.8..1.25 (the scales above are then not used).")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Seed of the trials.")
@click.option("--raw", is_flag=True,
              help="Servos follow the joint columns and fans the thrust columns as written, without the plan's "
                   "sag and lag compensation (what a replay reading only the CSV does).")
@click.option("-j", "--jobs", default=1, show_default=True, type=click.IntRange(min=1),
              help="Processes for the trials (results do not depend on it).")
@click.option("--json", "as_json", is_flag=True, help="Print simulation.json on stdout.")
@click.option("--no-progress", is_flag=True)
def simulate_cmd(plan_dir, controller, mass_scale, thrust_scale, fan_lag_s, trials, seed, raw, jobs, as_json,
                 no_progress) -> None:
    """Rehearse a written plan in a MuJoCo twin of the robot and its cartons (physics, not the planner's model).

    Writes PLAN_DIR/simulation.json and simulation.mcap. Exit 0 when every run succeeds (no fall,
    both soles on carton tops at the end), 6 when any fails, 2 on bad input.
    """

    from jethr1_plan.io.atomic import check_writable, write_bytes_atomic, write_text_atomic
    from jethr1_plan.io.mcap import simulation_mcap
    from jethr1_plan.sim.rehearsal import Perturbation, load_plan, simulate

    track = load_plan(plan_dir)
    check_writable(plan_dir)
    if trials is None:
        perturbations = [Perturbation(mass_scale, (0.0, 0.0), thrust_scale, fan_lag_s)]
    else:
        perturbations = [Perturbation.draw(np.random.default_rng([seed, k])) for k in range(trials)]
    with Progress(not no_progress, f"simulate {plan_dir}") as progress:
        runs = simulate(plan_dir, controller, perturbations, jobs=jobs, progress=progress, compensate=not raw)
    from jethr1_plan.sim.controller import Gains

    ok = sum(r.survived for r in runs)
    simulated, wall = sum(r.simulated_s for r in runs), sum(r.wall_s for r in runs)
    doc = {"plan": str(plan_dir), "controller": controller, "compensated": not raw,
           "gains": Gains.of(track.robot).__dict__,
           "trials": trials, "seed": seed if trials else None, "runs": [r.as_dict() for r in runs],
           "succeeded": ok, "total": len(runs), "success_rate": ok / len(runs),
           "timing": {"simulated_s": simulated, "wall_s": wall, "realtime_factor": simulated / wall if wall else None}}
    write_text_atomic(plan_dir / "simulation.json", json_text(doc))
    if runs[0].record is not None:
        write_bytes_atomic(plan_dir / "simulation.mcap", simulation_mcap(track.robot, runs[0].record, track.cartons))
    if as_json:
        click.echo(json_text(doc), nl=False)
    t = Table(title=f"{plan_dir}: {controller} in the twin")
    for col in ("run", "mass ×", "thrust ×", "lag [s]", "result", "max tilt [deg]", "landing [m]", "slip [m]",
                "CoP margin [m]", "max thrust [N]"):
        t.add_column(col, justify="right")
    for k, r in enumerate(runs):
        p = r.perturbation
        land = max((e["xy_m"] for e in r.landing_errors_m), default=None)
        verdict = "survived" if r.survived else (f"fell: {r.fell['reason']} at {r.fell['phase']} row "
                                                 f"{r.fell['row']}" if r.fell else "off the cartons")
        t.add_row(str(k), f"{p['mass_scale']:.3f}", f"{p['thrust_gain']:.3f}", f"{p['fan_lag_s']:.3f}", verdict,
                  f"{r.max_trunk_tilt_deg:.2f}", "-" if land is None else f"{land:.4f}", f"{r.support_max_slip_m:.4f}",
                  "-" if r.least_cop_margin_m is None else f"{r.least_cop_margin_m:.4f}", f"{r.max_thrust_n:.2f}")
    err_console.print(t)
    rtf = doc["timing"]["realtime_factor"]
    line = (f"simulate: {ok}/{len(runs)} runs survived ({controller}); "
            f"{simulated:.1f} s simulated in {wall:.1f} s ({rtf:.0f}x real time); wrote {plan_dir}/simulation.json")
    err_console.print(f"[{'green' if ok == len(runs) else 'red'}]{line}[/]")
    if ok < len(runs):
        raise click.exceptions.Exit(6)


main.add_command(walk_cmd)
main.add_command(walk_sweep_cmd)


def run(argv: list[str] | None = None) -> int:
    """Entry point: run the CLI and map expected failures to exit codes (no traceback)."""
    try:
        rv = main.main(args=argv, prog_name="jethr1", standalone_mode=False)
        if isinstance(rv, int):  # click returns an Exit's code instead of raising it here
            return rv
    except click.exceptions.Exit as exc:
        return int(exc.exit_code)
    except click.ClickException as exc:  # usage: one line, as every other bad input
        ctx = getattr(exc, "ctx", None)
        where = f"jethr1 {ctx.command_path.split(' ', 1)[1]}" if ctx is not None and " " in ctx.command_path \
            else "jethr1"
        print(f"{where}: {exc.format_message()}".replace("\n", " "), file=sys.stderr)
        return 2
    except (click.exceptions.Abort, KeyboardInterrupt):
        if _TERMINATED:
            print("jethr1: terminated (SIGTERM); workers stopped, nothing written", file=sys.stderr)
            return 143
        print("jethr1: interrupted; workers stopped, nothing written", file=sys.stderr)
        return 130
    except Jethr1Error as exc:
        message = str(exc).replace("\n", " ")
        print(f"jethr1: {message}", file=sys.stderr)
        return exc.exit_code
    return 0


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised as an interrupt so that it unwinds as Ctrl-C does: worker processes are ended,
    staging folders removed, nothing half-written is left."""


_TERMINATED: list[int] = []  # set by SIGTERM: joblib and click turn the interrupt into their own exceptions


def _on_sigterm(signum, frame) -> None:
    _TERMINATED.append(signum)
    raise Terminated()


def entry() -> None:
    import signal

    signal.signal(signal.SIGTERM, _on_sigterm)
    sys.exit(run())


__all__ = ["InputError", "entry", "main", "run"]
