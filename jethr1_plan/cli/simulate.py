"""``jethr1 simulate``: a written plan rehearsed in the MuJoCo twin; a plan of several steps executed step by step."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import click
import numpy as np
from rich.table import Table

from jethr1_plan.cli.common import (
    SEED,
    FiniteFloat,
    Progress,
    cap_jobs,
    check_memory,
    check_time,
    cores,
    err_console,
    print_json,
)
from jethr1_plan.errors import EXIT_REHEARSAL_FELL, InputError
from jethr1_plan.io.json_text import json_text

__all__ = ["simulate_cmd", "simulate_folder"]

TRIAL_BYTES = 20_000  # a trial's result held until the end (its measurements, landing errors) [bytes]
REALTIME_FACTOR = 10.0  # the most the twin runs faster than real time (measured 4-5x) [1]
CONTROLLERS = ["feedforward", "feedback", "imu_tilt_pid", "cop_edge_pi"]


@click.command("simulate")
@click.argument("plan_dir", metavar="PLAN_DIR", type=click.Path(file_okay=False, path_type=Path))
@click.option("--controller", type=click.Choice(CONTROLLERS), default="feedforward", show_default=True,
              help="The plan's commands alone, or corrected by the robot's feedback law (feedback: the one its "
                   "sensors allow, summary.json's controller.law), or a law by name; the controller reads only "
                   "the sensors the robot YAML declares, with their noise, bias and delay (docs/rehearsal.md).")
@click.option("--mass-scale", type=FiniteFloat(0.5, 2.0), default=1.0, show_default=True,
              help="Every link's mass and inertia times this.")
@click.option("--thrust-scale", type=FiniteFloat(0.0, 2.0), default=1.0, show_default=True,
              help="Every fan gives this times its command.")
@click.option("--fan-lag-s", type=FiniteFloat(0.0, 1.0, lo_open=True), default=0.05, show_default=True,
              help="Time constant of the fans' first-order lag [s].")
@click.option("--stiffness-scale", type=FiniteFloat(0.1, 10.0), default=1.0, show_default=True,
              help="Every servo's stiffness and damping times this (the plan's commands assume 1).")
@click.option("--trials", type=click.IntRange(1, 10000), default=None,
              help="Randomised trials instead of one run: mass ±5 %, CoM within 5 mm, thrust gain 0.8..1.1, "
                   "lag 30..80 ms, servo stiffness 0.8..1.25, the sensors' biases, offsets and delays, and (step "
                   "by step) the perception error (the scales above are then not used); reports the survivors "
                   "with a 95 % Clopper–Pearson bound (docs/rehearsal.md).")
@click.option("--within-tolerance", is_flag=True,
              help="With --trials: draw thrust, mass and CoM errors only inside the tolerance the plan holds "
                   "(its summary.json), the rest as above.")
@click.option("--seed", type=SEED, default=0, show_default=True,
              help="Seed of the trials (and of the sensors' noise of a single run).")
@click.option("--whole", is_flag=True,
              help="A plan of several steps replayed in one go as written, not executed step by step.")
@click.option("--raw", is_flag=True,
              help="Servos follow the joint columns and fans the thrust columns as written, without the plan's "
                   "sag and lag compensation (what a replay reading only the CSV does). Implies --whole.")
@click.option("-j", "--jobs", default=1, show_default=True, type=click.IntRange(min=1),
              help="Processes for the trials (results do not depend on it).")
@click.option("--json", "as_json", is_flag=True, help="Print simulation.json on stdout.")
@click.option("--no-progress", is_flag=True)
def simulate_cmd(plan_dir, controller, mass_scale, thrust_scale, fan_lag_s, stiffness_scale, trials, within_tolerance,
                 seed, whole, raw, jobs, as_json, no_progress) -> None:
    """Rehearse a written plan in a MuJoCo twin of the robot and its cartons (physics, not the planner's model).

    A plan of several steps (a scenario's or a route's) is executed step by step, as the robot would:
    each step planned again from where the robot estimates its soles stand (its encoders and IMU) to
    where it perceives the next foothold, in one continuous run; the steps executed are written as a
    plan folder, PLAN_DIR/executed/. Writes PLAN_DIR/simulation.json and simulation.mcap (the first
    run). With --trials, trial k draws from the generator seeded [seed, k], so the draws and verdicts
    do not depend on -j; the JSON's "certificate" holds the survivors, their Clopper–Pearson bound and
    the failures with their draws. Exit 0 when every run succeeds (no fall, both soles on carton tops at
    the end), 6 when any fails, 2 on bad input.
    """
    ok = simulate_folder(plan_dir, controller, trials=trials, within_tolerance=within_tolerance, seed=seed,
                         whole=whole or raw, raw=raw, jobs=jobs, as_json=as_json, progress=not no_progress,
                         single=(mass_scale, thrust_scale, fan_lag_s, stiffness_scale))
    if not ok:
        raise click.exceptions.Exit(EXIT_REHEARSAL_FELL)


def simulate_folder(plan_dir: Path, controller: str, *, trials: int | None = None, within_tolerance: bool = False,
                    seed: int = 0, whole: bool = False, raw: bool = False, jobs: int = 1, as_json: bool = False,
                    progress: bool = True, single: tuple[float, float, float, float] = (1.0, 1.0, 0.05, 1.0)) -> bool:
    """``jethr1 simulate``'s work (also ``replan-steps``'): rehearse or execute the plan in ``plan_dir``, write
    its files, print the tables; whether every run succeeded."""
    from jethr1_plan.files.plan_folder import SIMULATION_FILES
    from jethr1_plan.files.simulation import simulation_mcap
    from jethr1_plan.io.atomic import staged_directory
    from jethr1_plan.sim.certificate import certificate, describe, draws
    from jethr1_plan.sim.rehearsal import Perturbation, law_of, load_plan, simulate

    if within_tolerance and trials is None:
        raise click.BadParameter("needs --trials", param_hint="'--within-tolerance'")
    track = load_plan(plan_dir)
    law_of(track.robot, controller)
    steps = len(np.unique(track.step[track.phase == "swing"]))
    stepwise = steps >= 2 and not whole
    _check_room(plan_dir, track, stepwise, trials, jobs)
    jobs = cap_jobs(jobs)
    randomisation = "within_tolerance" if within_tolerance else "default"
    if trials is None:
        mass_scale, thrust_scale, fan_lag_s, stiffness_scale = single
        perturbations = [Perturbation(mass_scale, (0.0, 0.0), thrust_scale, fan_lag_s, stiffness_scale)]
    else:
        perturbations = draws(seed, trials, randomisation, track.tolerance, track.robot)
    executions = None
    label = f"simulate {plan_dir}" + (" step by step" if stepwise else "")
    if stepwise:
        import json

        from jethr1_plan.studies.step_by_step import execution_record, nominal_plan, run_steps, write_executed

        summary = json.loads((Path(plan_dir) / "summary.json").read_text())
        scenario, nominal = nominal_plan(Path(plan_dir), summary, track, note=lambda why: err_console.print(
            f"simulate: {why}", highlight=False, markup=False, soft_wrap=True))
        with Progress(progress, label) as bar:
            executions = run_steps(Path(plan_dir), summary, scenario, nominal, controller, perturbations, jobs, bar,
                                   seed)
        runs = [ex.run for ex in executions]
    else:
        with Progress(progress, label) as bar:
            runs = simulate(plan_dir, controller, perturbations, jobs=jobs, progress=bar, compensate=not raw,
                            track=track, seed=seed)
    ok = sum(r.survived for r in runs)
    simulated, wall = sum(r.simulated_s for r in runs), sum(r.wall_s for r in runs)
    law = runs[0].law
    run_docs = [r.as_dict() for r in runs]
    if executions is not None:
        for doc_r, ex in zip(run_docs, executions, strict=True):
            doc_r["step_by_step"] = execution_record(ex)
    cert = certificate(runs, perturbations, track.tolerance, randomisation) if trials is not None else None
    doc = _simulation_doc(plan_dir, track, stepwise, controller, law, raw, trials, seed, run_docs, ok, cert,
                          (simulated, wall))
    if executions is not None:
        executed, feasible = write_executed(Path(plan_dir), scenario, executions[0])
        doc["executed"] = {"folder": str(executed), "feasible": feasible}
    written = ["simulation.json"]
    precondition = _still_the_plan(plan_dir, track.summary_sha256)
    with staged_directory(plan_dir, SIMULATION_FILES, precondition=precondition) as staging:  # both or neither
        (staging.path / "simulation.json").write_text(json_text(doc))
        if runs[0].record is not None:
            (staging.path / "simulation.mcap").write_bytes(simulation_mcap(track.robot, runs[0].record,
                                                                           track.cartons))
            written.append("simulation.mcap")
    if as_json:
        print_json(doc)
    _table(plan_dir, controller, runs, perturbations, track, executions)
    if cert is not None:
        for text in describe(cert):
            err_console.print(text, highlight=False)
    rtf = doc["timing"]["realtime_factor"]
    line = (f"simulate: {ok}/{len(runs)} runs survived ({controller}{', ' + law if law and law != controller else ''}"
            f"{', step by step' if stepwise else ''}); {simulated:.1f} s simulated in {wall:.1f} s "
            f"({rtf:.0f}x real time); wrote {plan_dir}/{', '.join(written)}"
            + (f" and {doc['executed']['folder']}/" if executions is not None else ""))
    err_console.print(f"[{'green' if ok == len(runs) else 'red'}]{line}[/]")
    if ok < len(runs) and controller == "feedforward" and track.robot.feedback_law is not None:
        err_console.print(f"simulate: that was the plan's commands alone (feedforward); the law the robot runs on "
                          f"its own sensors ({track.robot.feedback_law}) with --controller feedback", highlight=False)
    return ok == len(runs)


def _still_the_plan(plan_dir: Path, summary_sha256: str) -> Callable[[], None]:
    """The commit's precondition, checked under the folder's lock: a rehearsal is committed only beside the plan it
    is of (its summary.json unchanged)."""
    from jethr1_plan.io.record import file_sha256

    def check() -> None:
        try:
            now = file_sha256(plan_dir / "summary.json")
        except OSError:
            now = ""
        if now != summary_sha256:
            raise InputError(str(plan_dir), "", "planned again while it was rehearsed: this rehearsal is of a plan "
                             "no longer there; nothing written (simulate it again)")
    return check


def _check_room(plan_dir: Path, track, stepwise: bool, trials: int | None, jobs: int) -> None:
    """Refuse, before any run, a folder that cannot take the files (about 600 bytes a row, twice step by step),
    trials whose results would not fit in memory, or trials estimated to take too long."""
    from jethr1_plan.files.plan_folder import SIMULATION_FILES
    from jethr1_plan.io.record import check_writable

    check_writable(plan_dir, need_bytes=len(track) * (1200 if stepwise else 600), writes=sorted(SIMULATION_FILES))
    if trials is not None:
        check_memory("--trials", str(trials), trials * TRIAL_BYTES, f"{trials} trials' results")
        check_time(("--trials", str(trials)), trials * float(track.time_s[-1]) / REALTIME_FACTOR / min(jobs, cores()),
                   f"{trials} rehearsals of {float(track.time_s[-1]):.1f} s")


def _simulation_doc(plan_dir: Path, track, stepwise: bool, controller: str, law: str | None, raw: bool,
                    trials: int | None, seed: int, run_docs: list[dict], ok: int, cert: dict | None,
                    times: tuple[float, float]) -> dict:
    """simulation.json: the plan and its files, the mode, the controller and its law's loop, the sensors, the
    runs and their certificate, the simulated and wall times [s]."""
    from jethr1_plan.control.feedback import controller_summary

    simulated, wall = times
    return {"plan": str(plan_dir), "plan_files": track.plan_files, "mode": "step_by_step" if stepwise else "whole",
            "controller": controller, "law": law, "compensated": not raw, "sensors": track.robot.sensors.describe(),
            "loop": controller_summary(track.robot, track.tolerance["thrust_error"], track.tolerance["mass_error"],
                                       track.thrust_max_n) if law is not None else None,
            "trials": trials, "seed": seed if trials else None, "runs": run_docs,
            "succeeded": ok, "total": len(run_docs), "success_rate": ok / len(run_docs),
            "certificate": cert,
            "timing": {"simulated_s": simulated, "wall_s": wall,
                       "realtime_factor": simulated / wall if wall else None}}


def _table(plan_dir, controller, runs, perturbations, track, executions) -> None:
    shown = list(enumerate(runs)) if len(runs) <= 20 else [(k, r) for k, r in enumerate(runs) if not r.survived]
    title = f"{plan_dir}: {controller} in the twin" + ("" if len(shown) == len(runs) else " (the failed runs)")
    t = Table(title=title)
    for col in ("run", "mass ×", "thrust ×", "CoM [mm]", "lag [s]", "stiffness ×", "in tol.", "result",
                "max tilt [deg]", "landing [m]", "slip [m]", "CoP margin [m]", "max thrust [N]"):
        t.add_column(col, justify="right")
    for k, r in shown:
        p = r.perturbation
        if executions is not None:
            land = executions[k].steps and max((s.get("landing_error_m", 0.0) for s in executions[k].steps),
                                               default=None)
        else:
            land = max((e["xy_m"] for e in r.landing_errors_m), default=None)
        verdict = "survived" if r.survived else (f"fell: {r.fell['reason']} at {r.fell['phase']} row "
                                                 f"{r.fell['row']}" if r.fell else "off the cartons")
        if executions is not None and executions[k].refused is not None:
            verdict = f"step {executions[k].refused['step']} not planned"
        inside = perturbations[k].inside(track.tolerance)["all"]
        t.add_row(str(k), f"{p['mass_scale']:.3f}", f"{p['thrust_gain']:.3f}",
                  f"{1000 * float(np.hypot(*p['com_offset_m'])):.1f}", f"{p['fan_lag_s']:.3f}",
                  f"{p['servo_stiffness_scale']:.3f}", "yes" if inside else "no", verdict,
                  f"{r.max_trunk_tilt_deg:.2f}", "-" if not land else f"{land:.4f}", f"{r.support_max_slip_m:.4f}",
                  "-" if r.least_cop_margin_m is None else f"{r.least_cop_margin_m:.4f}", f"{r.peak_thrust_n:.2f}")
    if shown:
        err_console.print(t)
    if executions is not None and len(runs) == 1:
        s = Table(title="step by step: each step planned from where the robot estimates its soles stand")
        for col in ("step", "swing", "planned", "landing error [mm]", "x, y [mm]", "support slip [mm]",
                    "support turn [deg]", "parts: inherited / slip / sag / thrust / touchdown / slide [mm]"):
            s.add_column(col, justify="right")
        for rec in executions[0].steps:
            j = rec.get("judge") or {}
            parts = j.get("parts_xy_m") or {}
            e = rec.get("landing_error_xy_m", [float("nan")] * 2)
            s.add_row(str(rec["step"]), rec["swing"], rec["mode"],
                      f"{1000 * rec.get('landing_error_m', float('nan')):.1f}",
                      f"{1000 * e[0]:+.1f}, {1000 * e[1]:+.1f}", f"{1000 * j.get('support_slip_m', float('nan')):.1f}",
                      f"{np.degrees(j.get('support_turn_rad', float('nan'))):+.2f}",
                      " / ".join(f"{1000 * float(np.hypot(*v)):.1f}" for v in parts.values()) or "-")
        err_console.print(s)
