"""``jethr1 walk`` and ``jethr1 walk-sweep``: Paper B's walking with pelvic rotation, as thin shells
around :mod:`jethr1_plan.walking`.

Exit codes as every command: 0 done, 2 bad input, 3 the walk fails its success criteria (the first
failing time and its reason on stderr).
"""

from __future__ import annotations

from contextlib import nullcontext
from dataclasses import replace
from pathlib import Path

import click
from rich.table import Table

from jethr1_plan.cli.common import Progress, cap_jobs, err_console, print_json, range_spec, report_kept
from jethr1_plan.errors import InfeasiblePlan, InputError
from jethr1_plan.io.json_text import json_text

__all__ = ["walk_cmd", "walk_sweep_cmd"]


def _load(walk_path: Path, rehearse: bool | None):
    from jethr1_plan.walking.spec import load_walk

    spec = load_walk(walk_path)
    if rehearse is not None:
        spec = replace(spec, success=replace(spec.success, rehearse=rehearse))
    return spec


@click.command("walk")
@click.argument("walk_path", metavar="WALK.yaml", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", default="out", show_default=True,
              type=click.Path(file_okay=False, path_type=Path), help="Files go to OUTDIR/<walk file stem>/.")
@click.option("--json", "as_json", is_flag=True, help="Print summary.json on stdout.")
@click.option("--rehearse/--no-rehearse", default=None,
              help="Rehearse the walk in the MuJoCo twin (default: the walk file's success.rehearse).")
@click.option("--write-infeasible", is_flag=True, help="On a failed walk, still write its trajectory and figures.")
def walk_cmd(walk_path: Path, outdir: Path, as_json: bool, rehearse: bool | None, write_infeasible: bool) -> None:
    """Walk WALK.yaml (Paper B): CoM by MPC, pelvic rotation by look-ahead MPC, QP IK, arm swing; write
    trajectory.csv, trajectory.mcap, summary.json and the yaw, momentum and κ figures."""
    from jethr1_plan.files.walk_folder import WALK_FILES, walk_folder, write_walk_outputs
    from jethr1_plan.io.record import check_writable
    from jethr1_plan.pipeline.walk import run_walk
    from jethr1_plan.walking.result import walk_summary

    spec = _load(walk_path, rehearse)
    check_writable(walk_folder(outdir, spec.source), writes=sorted(WALK_FILES))
    with err_console.status(f"walking {spec.name}", spinner="dots") if err_console.is_terminal else nullcontext():
        result = run_walk(spec)
    summary = walk_summary(result)
    folder, kept = write_walk_outputs(result, spec.source, outdir, summary,
                                      trajectory=result.ok or write_infeasible)
    report_kept(folder, kept)
    if as_json:
        print_json(summary)
    failure = result.failure
    if failure is not None:
        at = "" if failure[0] is None else f" at t = {failure[0]:.2f} s"
        wrote = "trajectory written" if write_infeasible else "summary.json written"
        raise InfeasiblePlan(f"{spec.source}: the walk fails{at}: {failure[1]} ({wrote} to {folder}/)")
    _report_walk(summary, folder)


def _report_walk(s: dict, folder: Path) -> None:
    c = err_console
    mom = s["yaw_momentum"]
    c.print(f"[green]walked[/] {s['name']} on {s['robot']}: {len(s['steps'])} steps of "
            f"{s['spec']['footsteps']['step_length_m']:g} m, pelvic rotation {s['spec']['pelvis_rotation']['mode']}, "
            f"{s['rows']} rows over {s['duration_s']:.1f} s, generated in {s['wall_s']:.2f} s "
            f"({s['realtime_factor']:.0f}x real time)")
    c.print(f"peak yaw {s['peak_yaw_rad']:.3f} rad, peak κ {s['peak_kappa']:.1f} (legs "
            f"{max(s['peak_kappa_leg'].values()):.1f}), least knee bend {s['least_knee_bend_rad']:.3f} rad, "
            f"E_con over two steps {s['energy_two_steps_j']:.1f} J")
    c.print(f"from the rows' second differences: least ZMP margin {1000 * s['least_zmp_margin_m']:.1f} mm, peak "
            f"friction ratio {s['peak_friction_ratio']:.2f} (μ {s['sole_friction']:g}), peak torque "
            f"{100 * s['peak_torque_ratio']:.0f} % of its servo's, peak joint acceleration "
            f"{s['peak_joint_acceleration_rad_s2']:.0f} rad/s² (limit "
            f"{s['spec']['ik']['max_joint_acceleration_rad_s2']:g})")
    line = f"peak yaw momentum {mom['peak_total_nms']:.3f} N·m·s"
    if mom["peak_with_arms_held_nms"] is not None:
        line += f" ({mom['peak_with_arms_held_nms']:.3f} with the arms held: {100 * mom['reduction']:.0f} % less)"
    c.print(line)
    r = s["rehearsal"]
    if r is not None:
        c.print(f"MuJoCo twin: survived, trunk tilt at most {r['max_trunk_tilt_deg']:.2f} deg, soles "
                f"{1000 * r['landing_error_m']:.1f} mm from their last footholds")
    c.print(f"wrote {folder}/trajectory.csv, trajectory.mcap, summary.json, yaw.png, momentum.png, kappa.png")
    from jethr1_plan.cli.plan import WALK_LAYOUT

    c.print(f"Foxglove/Lichtblick: open trajectory.mcap and import the layout {WALK_LAYOUT}; Rerun: jethr1 view "
            f"{folder}", markup=False)


@click.command("walk-sweep")
@click.argument("walk_path", metavar="WALK.yaml", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--steps-m", default="0.10:0.45:0.01", show_default=True, help="Step lengths LO:HI:STEP [m].")
@click.option("--rotation", default="none,paper_b", show_default=True,
              help="Comma-separated pelvic rotation modes (none, paper_b).")
@click.option("-j", "--jobs", default=2, show_default=True, type=click.IntRange(min=1), help="Worker processes.")
@click.option("--rehearse/--no-rehearse", default=None,
              help="Rehearse every walk in the MuJoCo twin (default: the walk file's success.rehearse).")
@click.option("-o", "--output", "outdir", default=None, type=click.Path(file_okay=False, path_type=Path),
              help="Output folder [default: out/walk_sweep/<walk file stem>].")
@click.option("--json", "as_json", is_flag=True, help="Print walk_sweep.json on stdout.")
@click.option("--no-progress", is_flag=True)
def walk_sweep_cmd(walk_path: Path, steps_m: str, rotation: str, jobs: int, rehearse: bool | None,
                   outdir: Path | None, as_json: bool, no_progress: bool) -> None:
    """Walk WALK.yaml at every step length with and without pelvic rotation: the longest step each
    mode reaches, E_con over two steps, peak κ, yaw and yaw momentum (walk_sweep.json, .csv, .png)."""
    from jethr1_plan.io.atomic import staged_directory
    from jethr1_plan.io.record import check_writable
    from jethr1_plan.studies.walk_sweep import sweep, sweep_png
    from jethr1_plan.walking.spec import ROTATION_MODES, check_walk

    lengths = range_spec(steps_m, "--steps-m")
    modes = [m.strip() for m in rotation.split(",") if m.strip()]
    bad = [m for m in modes if m not in ROTATION_MODES]
    if not modes or bad or len(set(modes)) != len(modes):
        raise InputError("--rotation", rotation, f"expected distinct modes among {', '.join(ROTATION_MODES)}")
    spec = _load(walk_path, rehearse)
    if spec.footsteps.kind != "repetitive":
        raise InputError(spec.source, "footsteps.kind", "walk-sweep varies the step length: it needs repetitive "
                         "footsteps")
    for length in lengths:  # every length must make a valid walk (soles apart, rows bounded, within reach)
        try:
            check_walk(spec.varied(step_length_m=length), spec.source)
        except InputError as exc:
            raise InputError("--steps-m", steps_m, f"{length:g} m: {exc.problem}") from None
    outdir = outdir if outdir is not None else Path("out/walk_sweep") / Path(spec.source).stem
    check_writable(outdir, writes=SWEEP_FILES)
    jobs = cap_jobs(jobs)
    with Progress(not no_progress, f"walk-sweep {spec.name}") as progress:
        doc = sweep(spec, lengths, modes, jobs=jobs, progress=progress)
    with staged_directory(outdir, frozenset(SWEEP_FILES)) as staging:
        (staging.path / "walk_sweep.json").write_text(json_text(doc))
        (staging.path / "walk_sweep.csv").write_text(_sweep_csv(doc))
        (staging.path / "walk_sweep.png").write_bytes(sweep_png(doc))
    report_kept(outdir, staging.kept)
    if as_json:
        print_json(doc)
    _report_sweep(doc, outdir)


SWEEP_FILES = ("walk_sweep.json", "walk_sweep.csv", "walk_sweep.png")
_SWEEP_COLUMNS = ("step_m", "mode", "ok", "energy_two_steps_j", "peak_kappa", "peak_kappa_leg", "peak_yaw_rad",
                  "peak_yaw_momentum_nms", "peak_yaw_momentum_arms_held_nms", "least_knee_bend_rad",
                  "least_zmp_margin_m", "peak_friction_ratio", "peak_torque_ratio", "peak_joint_acceleration_rad_s2",
                  "reason")


def _sweep_csv(doc: dict) -> str:
    from jethr1_plan.io.csv_table import csv_text, number_text

    def cell(k: str, v) -> str:
        if k == "ok":
            return "true" if v else "false"
        if k in ("mode", "reason"):
            return "" if v is None else str(v)
        return "" if v is None else number_text(v)

    return csv_text(_SWEEP_COLUMNS, ([cell(k, r.get(k)) for k in _SWEEP_COLUMNS] for r in doc["rows"]))


def _cell(row: dict, key: str, fmt: str) -> str:
    v = row.get(key)
    return "-" if v is None else format(v, fmt)


def _report_sweep(doc: dict, outdir: Path) -> None:
    from jethr1_plan.studies.walk_sweep import NOT_WALKED

    t = Table(title=f"{doc['name']} on {doc['robot']}: CoM {doc['com_height_m']:g} m, k_pel {doc['k_pel']:g}, "
                    f"arm swing {'on' if doc['arm_swing'] else 'off (or no arms)'}")
    for col in ("step [m]", "mode", "walks", "E_con 2 steps [J]", "peak κ", "legs' κ", "knee bend [rad]",
                "peak yaw [rad]", "peak h_z [N·m·s]", "arms held", "why not"):
        t.add_column(col, justify="right" if col not in ("mode", "why not") else "left")
    for r in doc["rows"]:
        if r.get("reason") == NOT_WALKED:
            continue
        t.add_row(f"{r['step_m']:.3f}", r["mode"], "[green]yes[/]" if r["ok"] else "[red]no[/]",
                  *(_cell(r, key, fmt) for key, fmt in (("energy_two_steps_j", ".1f"), ("peak_kappa", ".1f"),
                                                        ("peak_kappa_leg", ".3g"), ("least_knee_bend_rad", ".3f"),
                                                        ("peak_yaw_rad", ".3f"), ("peak_yaw_momentum_nms", ".3f"),
                                                        ("peak_yaw_momentum_arms_held_nms", ".3f"))),
                  (r.get("reason") or "")[:60])
    err_console.print(t)
    parts = []
    for m in doc["modes"]:
        best = doc["max_step_m"][m]
        gain = doc["step_gain_over_none"].get(m)
        parts.append(f"{m}: {'-' if best is None else f'{best:.3f} m'}"
                     + ("" if gain is None or m == "none" else f" ({100 * (gain - 1):+.0f} % over none)"))
    err_console.print("longest step walked (every shorter one too): " + "; ".join(parts))
    err_console.print(f"wrote {outdir}/walk_sweep.json, walk_sweep.csv, walk_sweep.png")
