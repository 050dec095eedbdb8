"""``jethr1 route``: the planner chooses the footholds over a field of cartons, on the balance space."""

from __future__ import annotations

import time
from pathlib import Path

import click

from jethr1_plan.cli.common import Progress, cap_jobs, err_console, print_json, report_kept, warn_minimal_policy

__all__ = ["route_cmd"]


@click.command("route")
@click.argument("terrain_path", metavar="TERRAIN.yaml", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", default="out", show_default=True,
              type=click.Path(file_okay=False, path_type=Path),
              help="Output directory; the plan and the route go to OUTDIR/<terrain stem>/.")
@click.option("--json", "as_json", is_flag=True, help="Print summary.json on stdout (on exit 3: the frontier).")
@click.option("-j", "--jobs", default=1, show_default=True, type=click.IntRange(min=1),
              help="Processes for the maps and for planning the steps (output does not depend on it).")
@click.option("--cache", "cache", default=None, type=click.Path(file_okay=False, path_type=Path),
              help="Where the balance-space maps are kept (default: $JETHR1_CACHE, else $XDG_CACHE_HOME/jethr1, "
                   "else ~/.cache/jethr1).")
@click.option("--no-progress", is_flag=True)
@click.option("--timing", "timing_mode", type=click.Choice(["fixed", "fastest"]),
              help="Override the terrain's timing.mode: fastest plans every step as fast as its rows' own dynamics "
                   "allow (route.yaml says so).")
def route_cmd(terrain_path: Path, outdir: Path, as_json: bool, jobs: int, cache: Path | None,
              no_progress: bool, timing_mode: str | None) -> None:
    """Choose which foot swings and where each lands over TERRAIN.yaml's cartons, then plan every step.

    Writes OUTDIR/<stem>/: route.yaml (an ordinary scenario), the plan (trajectory.csv, trajectory.mcap,
    summary.json), route.mcap and route.png. Exit 3 when no route exists, naming the frontier reached.
    """
    from jethr1_plan.files.plan_folder import SIMULATION_FILES
    from jethr1_plan.io.record import check_writable
    from jethr1_plan.route.planner import (
        ROUTE_OWN,
        NoRoute,
        check_map_cache,
        find_route,
        route_maps,
        steps_text,
        write_route,
    )
    from jethr1_plan.route.terrain import load_terrain

    t0 = time.perf_counter()
    terrain = load_terrain(terrain_path)
    if timing_mode is not None:
        from dataclasses import replace

        from jethr1_plan.scenario import check_fastest

        timing = replace(terrain.base.timing, mode=timing_mode)
        if timing.fastest:
            check_fastest(timing, terrain.base.yaw_mode, terrain.base.balance, str(terrain_path))
        doc_timing = {**terrain.doc.get("timing", {}), "mode": timing_mode}
        terrain = replace(terrain, doc={**terrain.doc, "timing": doc_timing}, base=replace(terrain.base, timing=timing))
    folder = Path(outdir) / Path(terrain_path).stem
    check_writable(folder, need_bytes=2_000_000, writes=sorted(ROUTE_OWN - SIMULATION_FILES))
    check_map_cache(terrain, cache)
    jobs = cap_jobs(jobs)

    def say(line: str) -> None:
        err_console.print(line, markup=False, highlight=False)

    with Progress(not no_progress, "balance-space map") as progress:
        maps = route_maps(terrain, cache, jobs=jobs, say=say, progress=progress)
    t_maps = time.perf_counter() - t0
    try:
        with Progress(not no_progress, f"route {terrain.name}") as progress:
            outcome = find_route(terrain, maps, folder, jobs=jobs, say=say, progress=progress)
    except NoRoute as exc:
        if as_json:
            print_json(exc.frontier)
        raise
    t_route = time.perf_counter() - t0 - t_maps
    search_s = sum(s.wall_s for s in outcome.searches)
    wall = {"maps": t_maps, "search": search_s, "plan": outcome.plan_s, "total": time.perf_counter() - t0}
    summary, kept = write_route(outcome, maps, folder, wall)
    report_kept(folder, kept)
    if as_json:
        print_json(summary)
    r = summary["route"]
    say(f"route {terrain.name}: {steps_text(len(outcome.steps))} to {r['goal']} (cost {r['cost']:.3f}; "
        f"{r['search']['stances_expanded']} stances expanded, {r['search']['steps_judged']} steps judged on the map "
        f"in {search_s:.2f} s; planned in {outcome.plan_s:.1f} s; {t_route:.1f} s after the maps)")
    warn_minimal_policy(terrain.base.balance.policy)
    for s in r["steps"]:
        p = s["plan"] or {}
        at = [round(v, 4) for v in s["landing_m"]]
        line = (f"  {s['index'] + 1}. {s['swing']:5s} foot -> {s['carton']:>8s} at {at}: plan max "
                f"{p.get('peak_thrust_n', float('nan')):.2f} N, least ZMP margin "
                f"{1000 * (p.get('least_zmp_margin_m') or 0.0):.1f} mm")
        if p.get("least_tolerance_share") is not None:
            line += f", tolerance share {100 * p['least_tolerance_share']:.0f} %"
        say(line + f"; map peak {s['map']['peak_thrust_n']:.2f} N, margin {1000 * s['map']['least_margin_m']:.0f} mm")
    if outcome.blacklisted:
        say(f"  {len(outcome.blacklisted)} steps the planner refused were replaced")
    say(f"wrote {folder}/route.yaml, route.mcap, route.png, trajectory.csv, trajectory.mcap, summary.json")
    say(f"verify: jethr1 verify {folder}; simulate: jethr1 simulate {folder}; re-plan: jethr1 plan "
        f"{folder}/route.yaml")
    from jethr1_plan.cli.plan import ROUTE_LAYOUT

    say(f"Foxglove/Lichtblick: open trajectory.mcap and route.mcap together and import the layout {ROUTE_LAYOUT}; "
        f"Rerun: jethr1 view {folder}")
