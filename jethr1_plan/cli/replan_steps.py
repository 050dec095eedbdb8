"""``jethr1 replan-steps``: kept as an alias of ``jethr1 plan SCENARIO`` followed by ``jethr1 simulate`` of its
folder, which executes a plan of several steps step by step."""

from __future__ import annotations

from pathlib import Path

import click

from jethr1_plan.cli.common import Progress
from jethr1_plan.errors import EXIT_REHEARSAL_FELL

__all__ = ["replan_steps_cmd"]


@click.command("replan-steps")
@click.argument("scenario_path", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", default="out", show_default=True,
              type=click.Path(file_okay=False, path_type=Path),
              help="The plan goes to OUTDIR/<scenario stem>/, as jethr1 plan writes it; simulate's files beside it.")
@click.option("--controller", type=click.Choice(["feedforward", "feedback", "imu_tilt_pid", "cop_edge_pi"]),
              default="feedforward", show_default=True, help="As jethr1 simulate's.")
@click.option("--json", "as_json", is_flag=True, help="Print simulation.json on stdout.")
@click.option("--no-progress", is_flag=True)
def replan_steps_cmd(scenario_path: Path, outdir: Path, controller: str, as_json: bool, no_progress: bool) -> None:
    """Plan SCENARIO.yaml, then execute it step by step in the twin (jethr1 plan + jethr1 simulate).

    Each step is planned again from where the robot estimates its soles stand to where it perceives the
    next foothold (docs/rehearsal.md, "Step by step"). Exit 0 when the run survives, 6 when it falls or
    ends off the cartons, 3 when the scenario cannot be planned, 2 on bad input.
    """
    from jethr1_plan.cli.simulate import simulate_folder
    from jethr1_plan.pipeline.plan import plan_to_folder
    from jethr1_plan.scenario import load_scenario

    scenario = load_scenario(scenario_path)
    with Progress(not no_progress, f"plan {scenario.name}") as progress:
        _, _, folder, _ = plan_to_folder(scenario, outdir, progress=progress)
    if not simulate_folder(folder, controller, as_json=as_json, progress=not no_progress):
        raise click.exceptions.Exit(EXIT_REHEARSAL_FELL)
