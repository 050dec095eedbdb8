"""The ``jethr1`` command line: a thin shell around the planner (CONTRACT.md).

Exit codes: 0 done, 1 a bug, 2 bad input, 3 infeasible plan, 4 a batch expectation failed.
Progress and messages go to stderr; ``--json`` prints one JSON document on stdout.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click
from rich.console import Console
from rich.table import Table

from .errors import InfeasiblePlan, InputError, Jethr1Error

err_console = Console(stderr=True)


def _dump(doc: dict) -> str:
    return json.dumps(doc, indent=2, sort_keys=False, allow_nan=False, default=_jsonable) + "\n"


def _jsonable(x):
    import numpy as np

    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


class _Progress:
    """A rich progress bar on stderr, off when stderr is not a terminal or with --no-progress."""

    def __init__(self, enabled: bool, label: str):
        self.enabled = enabled and err_console.is_terminal
        self.label = label
        self._p = None

    def __enter__(self):
        if self.enabled:
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            self._p = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                               TimeElapsedColumn(), console=err_console, transient=True)
            self._p.__enter__()
            self._task = self._p.add_task(self.label, total=None)
        return self

    def __call__(self, label: str, done: int, total: int) -> None:
        if self._p is not None:
            self._p.update(self._task, completed=done, total=total, description=f"{self.label}: {label}")

    def __exit__(self, *exc):
        if self._p is not None:
            self._p.__exit__(*exc)


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
    from .robot_model import load_robot, robot_summary

    summary = robot_summary(load_robot(name))
    if as_json:
        click.echo(_dump(summary), nl=False)
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
    for col in ("frame", "on", "max thrust [N]", "offset in foot [m]"):
        f.add_column(col)
    for fan in summary["fans"]:
        f.add_row(fan["frame"], fan["foot"], f"{fan['max_thrust_n']:.1f}",
                  ", ".join(f"{v:+.3f}" for v in fan["offset_in_foot_m"]))
    out.print(f)


def write_plan_outputs(result, outdir: Path, summary: dict, trajectory: bool) -> Path:
    """Write summary.json (and the trajectory files) into OUTDIR/<stem>/ atomically; return that folder."""
    from .atomic import staged_directory
    from .csv_writer import trajectory_csv
    from .mcap_writer import trajectory_mcap

    final = outdir / Path(result.scenario.source).stem
    with staged_directory(final) as tmp:
        if trajectory and result.rows is not None:
            (tmp / "trajectory.csv").write_text(trajectory_csv(result.rows))
            (tmp / "trajectory.mcap").write_bytes(trajectory_mcap(result.robot, result.rows, result.scenario.cartons,
                                                                  [st.path_m for st in result.steps]))
        (tmp / "summary.json").write_text(_dump(summary))
    return final


@main.command()
@click.argument("scenario_path", metavar="SCENARIO.yaml", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", default="out", show_default=True, type=click.Path(file_okay=False,
              path_type=Path), help="Output directory; files go to OUTDIR/<scenario stem>/.")
@click.option("--optimiser", type=click.Choice(["gas", "ga", "gaex"]), help="Override optimiser.method.")
@click.option("--seed", type=click.IntRange(min=0), help="Override the scenario's seed.")
@click.option("--json", "as_json", is_flag=True, help="Print summary.json on stdout.")
@click.option("--no-progress", is_flag=True, help="No progress bar.")
@click.option("--write-infeasible", is_flag=True,
              help="On an infeasible plan, still write the trajectory; infeasible rows say so.")
@click.option("-j", "--jobs", default=1, show_default=True, type=click.IntRange(min=1),
              help="Processes optimising steps in parallel (output does not depend on it).")
@click.option("--kinematics", type=click.Choice(["placo", "analytic"]), default="placo", show_default=True,
              help="Leg IK: PlaCo's solver, or the closed form (same postures to 1e-9 m, faster).")
def plan(scenario_path: Path, outdir: Path, optimiser: str | None, seed: int | None, as_json: bool,
         no_progress: bool, write_infeasible: bool, jobs: int, kinematics: str) -> None:
    """Plan SCENARIO.yaml: optimise P_body along each swing, write CSV, MCAP and summary.json."""
    from .planner import plan as run_plan
    from .planner import plan_summary
    from .scenario import load_scenario

    scenario = load_scenario(scenario_path)
    try:
        with _Progress(not no_progress, scenario.name) as progress:
            result = run_plan(scenario, method=optimiser, seed=seed, progress=progress, keep_going=write_infeasible,
                              jobs=jobs, kinematics=kinematics)
    except InfeasiblePlan as exc:
        write_plan_outputs_summary_only(scenario, outdir, exc.summary)
        raise
    summary = plan_summary(result)
    folder = write_plan_outputs(result, outdir, summary, trajectory=True)
    if as_json:
        click.echo(_dump(summary), nl=False)
    if not result.feasible:
        raise InfeasiblePlan(f"infeasible: {result.first_infeasible['reason']} "
                             f"(step {result.first_infeasible['step']} {result.first_infeasible['phase']} sample "
                             f"{result.first_infeasible['sample']}); trajectory written with infeasible rows marked")
    _report_plan(summary, folder)


def write_plan_outputs_summary_only(scenario, outdir: Path, summary: dict | None) -> None:
    from .atomic import staged_directory

    if summary is None:
        return
    with staged_directory(outdir / Path(scenario.source).stem) as tmp:
        (tmp / "summary.json").write_text(_dump(summary))


def _report_plan(summary: dict, folder: Path) -> None:
    c = err_console
    c.print(f"[green]feasible[/] {summary['scenario']}: {summary['sample_count']} swing samples, "
            f"max thrust {summary['max_thrust_n']:.2f} N, mean {summary['mean_thrust_n']:.2f} N, "
            f"{summary['evaluations']} evaluations in {summary['wall_s']:.1f} s")
    c.print(f"wrote {folder}/trajectory.csv, trajectory.mcap, summary.json")
    c.print("Foxglove: open trajectory.mcap, add a 3D panel, add the URDF layer "
            "(robots/jethr1/jethr1.urdf) and set the display frame to 'world'; /tf moves it, "
            "/terrain shows the cartons.")


def run(argv: list[str] | None = None) -> int:
    """Entry point: run the CLI and map expected failures to exit codes (no traceback)."""
    try:
        main.main(args=argv, prog_name="jethr1", standalone_mode=False)
    except click.exceptions.Exit as exc:
        return int(exc.exit_code)
    except click.ClickException as exc:
        exc.show()
        return 2
    except click.exceptions.Abort:
        err_console.print("aborted")
        return 130
    except Jethr1Error as exc:
        message = str(exc).replace("\n", " ")
        print(f"jethr1: {message}", file=sys.stderr)
        return exc.exit_code
    return 0


def entry() -> None:
    sys.exit(run())


__all__ = ["InputError", "entry", "main", "run"]
