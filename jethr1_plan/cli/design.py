"""``jethr1 design``: sweep robot variants (fans, their mounts and masses, trunk and legs) and judge each by the
widest ditch it crosses."""

from __future__ import annotations

import time
from pathlib import Path

import click
from rich.table import Table

from jethr1_plan.cli.common import (
    Progress,
    cap_jobs,
    check_memory,
    err_console,
    print_json,
    report_kept,
    require_dask,
)
from jethr1_plan.errors import InputError

__all__ = ["design_cmd"]


@click.command("design")
@click.argument("spec_path", metavar="SPEC.yaml", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", default="out/design", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("-j", "--jobs", default=2, show_default=True, type=click.IntRange(min=1),
              help="Worker processes (a local Dask cluster's workers with --executor dask). The output does not "
                   "depend on it.")
@click.option("--executor", type=click.Choice(["loky", "dask"]), default="loky", show_default=True,
              help="loky (processes on this machine) or dask (a cluster: --scheduler, else a local one). Either "
                   "way each variant is judged in a child process replaced after a fixed number of them: the memory "
                   "stays bounded.")
@click.option("--scheduler", default=None, help="Dask scheduler address (with --executor dask); default: local.")
@click.option("--cache", "cache", default=None, type=click.Path(file_okay=False, path_type=Path),
              help="Where each variant's result is kept as it arrives, so that a run interrupted and started again "
                   "judges only the rest (default: $JETHR1_CACHE, else $XDG_CACHE_HOME/jethr1, else ~/.cache/jethr1).")
@click.option("--json", "as_json", is_flag=True, help="Print design.json on stdout.")
@click.option("--no-progress", is_flag=True)
def design_cmd(spec_path: Path, outdir: Path, jobs: int, executor: str, scheduler: str | None, cache: Path | None,
               as_json: bool, no_progress: bool) -> None:
    """Judge every variant of a base robot that SPEC.yaml describes by the widest ditch it crosses (Paper A's
    forward step: with the whole tolerance, half of it, at all), and write design.csv, design.json, design.png,
    timings.json and the best variants as robot folders (OUTDIR/robots/)."""
    from jethr1_plan.io.atomic import staged_directory
    from jethr1_plan.io.json_text import json_text
    from jethr1_plan.robot.load import load_robot
    from jethr1_plan.studies.design import check_first, make_tasks, run_tasks
    from jethr1_plan.studies.design_report import (
        OWN_FILES,
        best_folders,
        best_variants,
        design_csv,
        design_doc,
        design_png,
        variant_rows,
    )
    from jethr1_plan.studies.design_spec import load_design

    t0 = time.perf_counter()
    spec = load_design(spec_path)
    try:
        base = load_robot(spec.base_robot)
    except InputError as exc:
        raise InputError(str(spec_path), "base_robot", str(exc)) from None
    variants = spec.variants()
    require_dask(executor, scheduler)
    folder = check_places(spec_path, outdir, cache, len(variants))
    keys, tasks = make_tasks(spec, variants)
    check_first(spec, tasks[keys[0]])
    jobs = cap_jobs(jobs) if scheduler is None else jobs
    err_console.print(f"design {spec.name}: {len(variants)} variants of {base.name} ({len(tasks)} distinct), "
                      f"judged on ditches of {spec.judge.gaps_m[0]:g}-{spec.judge.gaps_m[1]:g} m every "
                      f"{1000 * spec.judge.resolution_m:g} mm; results kept in {folder}/design/",
                      markup=False, highlight=False)
    try:
        with Progress(not no_progress, f"design {spec.name}") as progress:
            results, timings = run_tasks(tasks, folder, jobs=jobs, executor=executor, scheduler=scheduler,
                                         progress=progress)
    except KeyboardInterrupt:
        err_console.print(f"jethr1 design: the variants judged so far are kept in {folder}/design/: the same command "
                          "judges only the rest", markup=False, highlight=False)
        raise
    refused = [(v, results[k]) for v, k in zip(variants, keys, strict=True) if results[k].get("status") == "refused"]
    if refused:
        v, r = refused[0]
        raise InputError(str(spec_path), f"variant {v.index}", f"the robot checks refuse it: {r['reason']}")
    rows = variant_rows(spec, variants, keys, results, base.mass_kg)
    best = best_variants(rows, spec.best)
    base_info = {"name": base.name, "mass_kg": base.mass_kg,
                 "fans": [{"name": f.name, "mount": f.mount, "thrust_max_n": f.thrust_max_n,
                           "offset_m": list(f.offset_m)} for f in base.fans]}
    doc = design_doc(spec, base_info, rows, [r["variant"] for r in best])
    names = {k: v.name for v, k in zip(variants, keys, strict=True)}
    wall = time.perf_counter() - t0
    timing_doc = {"variants": len(variants), "distinct": len(tasks), "from_cache": timings["from_cache"],
                  "judged": {names[k]: t for k, t in sorted(timings["judged"].items(), key=lambda kv: names[kv[0]])},
                  "jobs": jobs, "executor": executor, "wall_s": wall}
    files = best_folders(spec, best, outdir)
    with staged_directory(outdir, OWN_FILES) as staging:
        (staging.path / "design.csv").write_text(design_csv(spec, rows))
        (staging.path / "design.json").write_text(json_text(doc))
        (staging.path / "design.png").write_bytes(design_png(spec, rows))
        (staging.path / "timings.json").write_text(json_text(timing_doc))
        for rel, data in files.items():
            (staging.path / rel).parent.mkdir(parents=True, exist_ok=True)
            (staging.path / rel).write_bytes(data)
    report_kept(outdir, staging.kept)
    if as_json:
        print_json(doc)
    err_console.print(best_table(spec, best))
    judged = len(timings["judged"])
    cpu = sum(t["cpu_s"] for t in timings["judged"].values())
    written = f", robots/ and scenarios/ ({len(best)} variants)" if best else ""
    err_console.print(f"{judged} variants judged ({cpu:.0f} s of CPU), {timings['from_cache']} from the cache; "
                      f"{wall:.0f} s in all. Wrote {outdir}/design.csv, design.json, design.png, timings.json{written}",
                      markup=False, highlight=False)


def check_places(spec_path: Path, outdir: Path, cache: Path | None, variants: int) -> Path:
    """Before any work: the memory holds the ``variants``' robot files, the output folder can take the files (none
    of its names a file of the user's, robots/ and scenarios/ folders where they exist, room for a row a variant)
    and the cache can keep results; the cache's folder.

    Raises:
        InputError: the first problem (exit 2).
    """
    from jethr1_plan.io.record import check_subfolders, check_writable
    from jethr1_plan.studies.design import VARIANT_BYTES, check_cache, default_cache
    from jethr1_plan.studies.design_report import OWN_FILES, SUBFOLDERS

    check_memory(str(spec_path), "axes", variants * VARIANT_BYTES, f"{variants:,} variants' robot files")
    check_writable(outdir, need_bytes=200_000 + 2_000 * variants, writes=sorted(OWN_FILES))
    check_subfolders(outdir, SUBFOLDERS)
    folder = default_cache(cache)
    check_cache(folder)
    return folder


def best_table(spec, best) -> Table:
    """The best variants: their axis values, mass, and widest ditches."""
    t = Table(title=f"{spec.name}: the front of added mass against the widest robust ditch (at most {spec.best})")
    for col in ("variant", *(a.name for a in spec.axes), "added mass [kg]", "whole [mm]", "half [mm]",
                "crossed [mm]", "peak thrust [N]"):
        t.add_column(col, justify="right")

    def mm(level: dict) -> str:
        return "-" if level["gap_m"] is None else f"{1000 * level['gap_m']:.0f}"

    for r in best:
        w = r["result"]["widest"]
        t.add_row(r["variant"], *(f"{r['values'][a.name]:g}" for a in spec.axes), f"{r['added_mass_kg']:+.3f}",
                  mm(w["whole"]), mm(w["half"]), mm(w["crossed"]), f"{w['whole']['peak_thrust_n']:.2f}")
    return t
