"""``jethr1 replan-steps``: a multi-step scenario one step at a time, each re-planned from the measured landing."""

from __future__ import annotations

from pathlib import Path

import click
from rich.table import Table

from jethr1_plan.cli.common import Progress, err_console, print_json
from jethr1_plan.errors import EXIT_REHEARSAL_FELL
from jethr1_plan.io.json_text import json_text

__all__ = ["replan_steps_cmd"]


@click.command("replan-steps")
@click.argument("scenario_path", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", default="out", show_default=True,
              type=click.Path(file_okay=False, path_type=Path),
              help="Files go to OUTDIR/<scenario name>/: a plan folder per step and replan_steps.json.")
@click.option("--controller", type=click.Choice(["feedforward", "feedback"]), default="feedforward",
              show_default=True, help="The rehearsal's thrust: the plan's alone, or with its feedback law.")
@click.option("--json", "as_json", is_flag=True, help="Print replan_steps.json on stdout.")
@click.option("--no-progress", is_flag=True)
def replan_steps_cmd(scenario_path: Path, outdir: Path, controller: str, as_json: bool, no_progress: bool) -> None:
    """Execute SCENARIO.yaml step by step, each step re-planned from the measured landing.

    Plan one step, rehearse it in the MuJoCo twin, measure where the soles stand, plan the next step
    from there to its landing on its carton, and so on.

    Exit 0 when every step's rehearsal survives, 6 when one falls or ends off the cartons (the steps
    after it are not planned), 3 when a step cannot be planned from where the soles stand, 2 on bad input.
    """
    from jethr1_plan.files.plan_folder import PLAN_WRITES
    from jethr1_plan.io.atomic import check_writable, write_text_atomic
    from jethr1_plan.scenario import load_scenario
    from jethr1_plan.studies.step_by_step import replan_steps

    scenario = load_scenario(scenario_path)
    folder = outdir / scenario.name  # (a name is one plain file name: the scenario's schema)
    check_writable(folder, writes=("replan_steps.json",))
    for k in range(len(scenario.steps)):
        check_writable(folder / f"{scenario.name}_step{k}", writes=PLAN_WRITES)
    with Progress(not no_progress, f"{scenario.name}: steps") as progress:
        doc = replan_steps(scenario, folder, controller, progress)
    write_text_atomic(folder / "replan_steps.json", json_text(doc))
    if as_json:
        print_json(doc)
    t = Table(title=f"{scenario.name}: each step planned from the measured soles ({controller})")
    for col in ("step", "swing", "landing error [mm]", "x, y [mm]", "support drift [mm]", "max thrust [N]",
                "tilt [deg]", "rehearsal"):
        t.add_column(col, justify="right")
    for s in doc["steps"]:
        e = s["landing_error_xy_m"]
        t.add_row(str(s["step"]), s["swing"], f"{1000 * s['landing_error_m']:.1f}",
                  f"{1000 * e[0]:+.1f}, {1000 * e[1]:+.1f}", f"{1000 * s['support_drift_m']:.1f}",
                  f"{s['max_thrust_n']:.2f}", f"{s['max_trunk_tilt_deg']:.2f}",
                  "survived" if s["survived"] else f"FELL: {(s['fell'] or {}).get('reason', 'off the cartons')}")
    err_console.print(t)
    if doc["max_landing_error_m"] is not None:
        err_console.print(f"largest landing error {1000 * doc['max_landing_error_m']:.1f} mm; wrote {folder}/"
                          "replan_steps.json and a plan folder per step")
    if not doc["all_survived"]:
        raise click.exceptions.Exit(EXIT_REHEARSAL_FELL)
