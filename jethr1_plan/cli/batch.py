"""``jethr1 batch``: many scenarios, one summary, an exit status a CI job can gate on."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import click
from rich.table import Table

from jethr1_plan.cli.common import Progress, cap_jobs, err_console, print_json, require_dask
from jethr1_plan.errors import InputError, lost_worker_behind
from jethr1_plan.io.json_text import json_text

__all__ = ["batch"]


@click.command()
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
    from jethr1_plan.io.atomic import write_text_atomic
    from jethr1_plan.studies.batch import batch_exit_code, read_manifest, run_batch

    paths = list(scenarios) + (read_manifest(manifest) if manifest else [])
    if not paths:
        raise InputError("batch", "SCENARIOS", "give scenario files or --manifest")
    stems = [p.stem for p in paths]
    if len(set(stems)) != len(stems):
        raise InputError("batch", "SCENARIOS", "two scenarios share a file name; their outputs would collide")
    require_dask(executor, scheduler)
    from jethr1_plan.files.plan_folder import PLAN_WRITES
    from jethr1_plan.io.record import check_writable
    from jethr1_plan.scenario import load_scenario

    for path in paths:  # bad input is one line and nothing written: every scenario read before any is planned
        load_scenario(path)
    check_writable(outdir, writes=("summary.json",))
    for stem in stems:
        check_writable(Path(outdir) / stem, writes=PLAN_WRITES)
    jobs = cap_jobs(jobs)
    started = time.time()
    try:
        with Progress(not no_progress, "batch") as progress:
            records = run_batch(paths, outdir, jobs=jobs, executor=executor, scheduler=scheduler,
                                progress=progress)
    except KeyboardInterrupt:
        _note_written(outdir, stems, started)
        raise
    except Exception as exc:
        if lost_worker_behind(exc) is not None:  # the scenarios done before it: reported as written
            _note_written(outdir, stems, started)
        raise
    code = batch_exit_code(records)
    doc: dict[str, Any] = {"exit_code": code, "scenarios": [{k: v for k, v in r.items() if k != "summary"} | {
        "peak_thrust_n": (r.get("summary") or {}).get("peak_thrust_n"),
        "mean_thrust_n": (r.get("summary") or {}).get("mean_thrust_n"),
        "feasible": (r.get("summary") or {}).get("feasible"),
        "wall_s": (r.get("summary") or {}).get("wall_s")} for r in records]}
    write_text_atomic(outdir / "summary.json", json_text(doc))
    if as_json:
        print_json(doc)
    t = Table(title=f"batch: {len(records)} scenarios -> {outdir}")
    for col in ("scenario", "status", "max thrust [N]", "mean [N]", "wall [s]", "expectations"):
        t.add_column(col)
    def fmt(v):
        return "" if v is None else f"{v:.2f}"

    for r in doc["scenarios"]:
        t.add_row(r["name"], r["status"], fmt(r["peak_thrust_n"]), fmt(r["mean_thrust_n"]), fmt(r["wall_s"]),
                  "; ".join(r.get("expectations_failed") or []) or ("ok" if r.get("expect") else "-"))
    err_console.print(t)
    for r in records:
        if r["exit_code"] and r.get("error"):
            err_console.print(f"{r['name']}: {r['error']}", markup=False)
    if code:
        raise click.exceptions.Exit(code)



def _note_written(outdir: Path, stems: list[str], since: float) -> None:
    """Name, for the interrupt message, the scenario folders this batch completed (their worker
    processes wrote them) before it was interrupted; the batch's summary.json is not written."""
    from jethr1_plan.io.atomic import note_committed

    for stem in stems:
        summary = Path(outdir) / stem / "summary.json"
        try:
            if summary.stat().st_mtime >= since:
                note_committed(summary.parent)
        except OSError:
            pass
