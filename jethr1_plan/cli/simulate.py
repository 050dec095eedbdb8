"""``jethr1 simulate``: a written plan rehearsed in the MuJoCo twin."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np
from rich.table import Table

from jethr1_plan.cli.common import SEED, FiniteFloat, Progress, cap_jobs, check_memory, err_console, print_json
from jethr1_plan.errors import EXIT_REHEARSAL_FELL
from jethr1_plan.io.json_text import json_text

__all__ = ["simulate_cmd"]

TRIAL_BYTES = 20_000  # a trial's result held until the end (its measurements, landing errors) [bytes]


@click.command("simulate")
@click.argument("plan_dir", metavar="PLAN_DIR", type=click.Path(file_okay=False, path_type=Path))
@click.option("--controller", type=click.Choice(["feedforward", "feedback", "imu_tilt_pid", "cop_edge_pi"]),
              default="feedforward", show_default=True,
              help="The plan's commands alone, or corrected by the robot's feedback law (feedback: the one its "
                   "sensors allow, summary.json's controller.law), or a law by name; the controller reads only "
                   "the sensors the robot YAML declares, with their noise, bias and delay (docs/rehearsal.md).")
@click.option("--mass-scale", type=FiniteFloat(0.5, 2.0), default=1.0, show_default=True,
              help="Every link's mass and inertia times this.")
@click.option("--thrust-scale", type=FiniteFloat(0.0, 2.0), default=1.0, show_default=True,
              help="Every fan gives this times its command.")
@click.option("--fan-lag-s", type=FiniteFloat(0.0, 1.0, lo_open=True), default=0.05, show_default=True,
              help="Time constant of the fans' first-order lag [s].")
@click.option("--trials", type=click.IntRange(1, 10000), default=None,
              help="Randomised trials instead of one run: mass ±5 %, CoM within 5 mm, thrust gain 0.8..1.1, "
                   "lag 30..80 ms, servo stiffness 0.8..1.25 (the scales above are then not used); reports the "
                   "survivors with a 95 % Clopper–Pearson bound (docs/rehearsal.md).")
@click.option("--within-tolerance", is_flag=True,
              help="With --trials: draw thrust, mass and CoM errors only inside the tolerance the plan holds "
                   "(its summary.json), lag and stiffness as above.")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of the trials.")
@click.option("--raw", is_flag=True,
              help="Servos follow the joint columns and fans the thrust columns as written, without the plan's "
                   "sag and lag compensation (what a replay reading only the CSV does).")
@click.option("-j", "--jobs", default=1, show_default=True, type=click.IntRange(min=1),
              help="Processes for the trials (results do not depend on it).")
@click.option("--json", "as_json", is_flag=True, help="Print simulation.json on stdout.")
@click.option("--no-progress", is_flag=True)
def simulate_cmd(plan_dir, controller, mass_scale, thrust_scale, fan_lag_s, trials, within_tolerance, seed, raw, jobs,
                 as_json, no_progress) -> None:
    """Rehearse a written plan in a MuJoCo twin of the robot and its cartons (physics, not the planner's model).

    Writes PLAN_DIR/simulation.json and simulation.mcap (the first run). With --trials, trial k draws
    from the generator seeded [seed, k], so the draws and verdicts do not depend on -j; the JSON's
    "certificate" holds the survivors, their Clopper–Pearson bound and the failures with their draws.
    Exit 0 when every run succeeds (no fall, both soles on carton tops at the end), 6 when any fails,
    2 on bad input.
    """

    from jethr1_plan.files.plan_folder import SIMULATION_FILES
    from jethr1_plan.files.simulation import simulation_mcap
    from jethr1_plan.io.atomic import check_writable, staged_directory
    from jethr1_plan.sim.certificate import certificate, describe, draws
    from jethr1_plan.sim.rehearsal import Perturbation, load_plan, simulate

    if within_tolerance and trials is None:
        raise click.BadParameter("needs --trials", param_hint="'--within-tolerance'")
    track = load_plan(plan_dir)
    check_writable(plan_dir, need_bytes=len(track) * 600)
    if trials is not None:
        check_memory("--trials", str(trials), trials * TRIAL_BYTES, f"{trials} trials' results")
    jobs = cap_jobs(jobs)
    if trials is None:
        perturbations = [Perturbation(mass_scale, (0.0, 0.0), thrust_scale, fan_lag_s)]
    else:
        randomisation = "within_tolerance" if within_tolerance else "default"
        perturbations = draws(seed, trials, randomisation, track.tolerance, track.robot)
    with Progress(not no_progress, f"simulate {plan_dir}") as progress:
        runs = simulate(plan_dir, controller, perturbations, jobs=jobs, progress=progress, compensate=not raw,
                        track=track, seed=seed)
    from jethr1_plan.control.feedback import controller_summary

    ok = sum(r.survived for r in runs)
    simulated, wall = sum(r.simulated_s for r in runs), sum(r.wall_s for r in runs)
    law = runs[0].law
    doc = {"plan": str(plan_dir), "controller": controller, "law": law, "compensated": not raw,
           "sensors": track.robot.sensors.describe(),
           "loop": controller_summary(track.robot, track.tolerance["thrust_error"], track.tolerance["mass_error"],
                                      track.thrust_max_n) if law is not None else None,
           "trials": trials, "seed": seed if trials else None, "runs": [r.as_dict() for r in runs],
           "succeeded": ok, "total": len(runs), "success_rate": ok / len(runs),
           "certificate": (certificate(runs, perturbations, track.tolerance, randomisation)
                           if trials is not None else None),
           "timing": {"simulated_s": simulated, "wall_s": wall, "realtime_factor": simulated / wall if wall else None}}
    with staged_directory(plan_dir, SIMULATION_FILES) as staging:  # both files or neither
        (staging.path / "simulation.json").write_text(json_text(doc))
        if runs[0].record is not None:
            (staging.path / "simulation.mcap").write_bytes(simulation_mcap(track.robot, runs[0].record,
                                                                           track.cartons))
    if as_json:
        print_json(doc)
    shown = list(enumerate(runs)) if len(runs) <= 20 else [(k, r) for k, r in enumerate(runs) if not r.survived]
    title = f"{plan_dir}: {controller} in the twin" + ("" if len(shown) == len(runs) else " (the failed runs)")
    t = Table(title=title)
    for col in ("run", "mass ×", "thrust ×", "CoM [mm]", "lag [s]", "stiffness ×", "in tol.", "result",
                "max tilt [deg]", "landing [m]", "slip [m]", "CoP margin [m]", "max thrust [N]"):
        t.add_column(col, justify="right")
    for k, r in shown:
        p = r.perturbation
        land = max((e["xy_m"] for e in r.landing_errors_m), default=None)
        verdict = "survived" if r.survived else (f"fell: {r.fell['reason']} at {r.fell['phase']} row "
                                                 f"{r.fell['row']}" if r.fell else "off the cartons")
        inside = perturbations[k].inside(track.tolerance)["all"]
        t.add_row(str(k), f"{p['mass_scale']:.3f}", f"{p['thrust_gain']:.3f}",
                  f"{1000 * float(np.hypot(*p['com_offset_m'])):.1f}", f"{p['fan_lag_s']:.3f}",
                  f"{p['servo_stiffness_scale']:.3f}", "yes" if inside else "no", verdict,
                  f"{r.max_trunk_tilt_deg:.2f}", "-" if land is None else f"{land:.4f}", f"{r.support_max_slip_m:.4f}",
                  "-" if r.least_cop_margin_m is None else f"{r.least_cop_margin_m:.4f}", f"{r.max_thrust_n:.2f}")
    if shown:
        err_console.print(t)
    if doc["certificate"] is not None:
        for text in describe(doc["certificate"]):
            err_console.print(text, highlight=False)
    rtf = doc["timing"]["realtime_factor"]
    line = (f"simulate: {ok}/{len(runs)} runs survived ({controller}); "
            f"{simulated:.1f} s simulated in {wall:.1f} s ({rtf:.0f}x real time); wrote {plan_dir}/simulation.json")
    err_console.print(f"[{'green' if ok == len(runs) else 'red'}]{line}[/]")
    if ok < len(runs):
        raise click.exceptions.Exit(EXIT_REHEARSAL_FELL)

