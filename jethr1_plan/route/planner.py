"""``jethr1 route``: a terrain in; the footholds chosen on the balance space, planned for real, written.

1. The maps (:mod:`.balance_map`): one per support side, computed once per robot and setting.
2. The search (:mod:`.search`): the least-cost route on the maps.
3. The route as an ordinary scenario (``route.yaml``), loaded by the scenario loader and planned by
   the project's planner (:func:`.incremental.plan_route`). A step the loader refuses or the
   planner cannot balance is blacklisted and the search resumes (at most :data:`MAX_REPLANS` times);
   the steps a new route shares with an earlier one from its start are not optimised again
   (:mod:`.incremental`: the same steps, bit for bit).
4. The plan folder: the plan's own files (re-checked by ``verify`` before they are written, as
   ``jethr1 plan`` does) with the route's (``route.yaml``, ``route.mcap``, ``route.png``) in one commit.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from pathlib import Path

from jethr1_plan.errors import InfeasiblePlan, InputError
from jethr1_plan.files.plan_folder import PLAN_FILES, write_plan
from jethr1_plan.files.plan_steps import scenario_steps_key
from jethr1_plan.files.route import ROUTE_FILES, route_mcap, route_png
from jethr1_plan.geometry import SIDES
from jethr1_plan.pipeline.plan import self_check
from jethr1_plan.planning.report import plan_summary
from jethr1_plan.records.infeasible import Infeasible, InfeasibleAt
from jethr1_plan.robot.load import ROBOTS_DIR
from jethr1_plan.route.balance_map import BalanceMap, MapSettings, cached_map
from jethr1_plan.route.footholds import Footholds, footholds
from jethr1_plan.route.incremental import RouteMemo, plan_route
from jethr1_plan.route.report import RouteOutcome, drawing, route_summary, steps_text
from jethr1_plan.route.search import Frontier, RouteStep, SearchResult, astar
from jethr1_plan.route.steps import StepModel
from jethr1_plan.route.terrain import Terrain, dump_yaml
from jethr1_plan.scenario import load_scenario_text

__all__ = [
    "MAX_REPLANS",
    "ROUTE_OWN",
    "NoRoute",
    "RouteOutcome",
    "check_map_cache",
    "find_route",
    "route_maps",
    "route_scenario_text",
    "steps_text",
    "write_route",
]

MAX_REPLANS = 25  # steps blacklisted before the route gives up
ROUTE_OWN = PLAN_FILES | ROUTE_FILES

Say = Callable[[str], None]


class NoRoute(InfeasiblePlan):
    """No route to the goal on the maps (exit 3); ``frontier`` says how far the search got."""

    def __init__(self, message: str, frontier: dict):
        super().__init__(message)
        self.frontier = frontier


def _map_settings(terrain: Terrain, side: str) -> MapSettings:
    b = terrain.base.balance
    return MapSettings(side, terrain.options.map_resolution_m, b.thrust_max_n, b.rho_rad, b.sole_margin_m, b.tolerance)


def check_map_cache(terrain: Terrain, cache: Path | str | None = None) -> None:
    """Before any work: the cache can hold the maps, and the maps it holds for the terrain read.

    Raises:
        InputError: a cache folder that cannot be written, a cached map that is not one (corrupt, edited).
    """
    for side in SIDES:
        cached_map(terrain.robot, _map_settings(terrain, side), cache, compute=False)


def route_maps(terrain: Terrain, cache: Path | str | None = None, jobs: int = 1, say: Say | None = None,
               progress=None) -> dict[str, BalanceMap]:
    """The map of each support side for the terrain's robot, balance policy, tolerance and resolution."""
    maps = {side: cached_map(terrain.robot, _map_settings(terrain, side), cache, jobs=jobs, say=say, progress=progress)
            for side in SIDES}
    return {side: m for side, m in maps.items() if m is not None}  # (computed where not cached: each is there)


def _flow(value) -> str:
    """``value`` as one line of YAML (flow style)."""
    import yaml

    if isinstance(value, dict | list):
        return yaml.safe_dump(value, default_flow_style=True, width=10**6, sort_keys=False).strip()
    return yaml.safe_dump([value], default_flow_style=True, width=10**6).strip()[1:-1]


def _robot_ref(terrain: Terrain) -> str:
    """How route.yaml names the robot: by name where it is a shipped one, else by its YAML's absolute path."""
    given = str(terrain.doc.get("robot", "jethr1"))
    robot = terrain.robot
    shipped = Path(ROBOTS_DIR) / given / f"{given}.yaml"
    if shipped.is_file() and shipped.resolve() == Path(robot.yaml_path).resolve():
        return given
    return str(Path(robot.yaml_path).resolve())


def route_scenario_text(terrain: Terrain, holds: Footholds, steps: list[RouteStep]) -> str:
    """``route.yaml``: the route as an ordinary scenario (a person may edit it and plan it with ``jethr1 plan``)."""
    doc = terrain.doc
    names = terrain.names
    opt = terrain.options
    lines = [f"# The route `jethr1 route` chose over terrain {terrain.name!r} ({Path(terrain.source).name}): "
             f"{steps_text(len(steps))} to {terrain.goal.describe(names)}.",
             "# An ordinary scenario: edit it, then plan it with `jethr1 plan route.yaml`.",
             f"name: {_flow(terrain.name)}"]
    if "description" in doc:
        lines.append(f"description: {_flow(doc['description'])}")
    lines += [f"robot: {_flow(_robot_ref(terrain))}", f"seed: {int(terrain.base.seed)}", "start:"]
    for side in SIDES:
        lines.append(f"  {side}: {_flow([float(v) for v in terrain.base.start[side]])}")
    lines += ["terrain:", "  cartons:"]
    for c, name in zip(terrain.cartons, names, strict=True):
        lines.append(f"    - {_flow({'top_centre_m': list(c.top_centre_m), 'size_m': list(c.size_m)})}  # {name}")
    lines.append("steps:")
    for k, st in enumerate(steps):
        land = [float(v) for v in holds.xyz[st.to]]
        step = {"swing": st.swing, "landing_m": land,
                "path": {"kind": "arc", "clearance_m": float(st.edge.clearance_m), "samples": int(opt.samples),
                         **({"lift_m": float(opt.lift_m)} if opt.lift_m > 0 else {}),
                         **({"descent_m": float(opt.descent_m)} if opt.descent_m > 0 else {})}}
        lines.append(f"  - {_flow(step)}  # {k + 1}: onto {names[holds.carton[st.to]]}; map: peak "
                     f"{st.edge.peak_n:.2f} N, mean {st.edge.mean_n:.2f} N, margin {1000 * st.edge.margin_m:.0f} mm")
    text = "\n".join(lines) + "\n"
    rest = {k: doc[k] for k in ("optimiser", "balance", "timing") if k in doc}
    return text + (dump_yaml(rest) if rest else "")


_STEP_KEY = re.compile(r"steps\[(\d+)\]")


def _states(holds: Footholds, steps: list[RouteStep]) -> list[tuple[int, int, str | None]]:
    """(left, right, the foot that swung last) before each step, and after the last."""
    left, right, last = holds.start["left"], holds.start["right"], None
    out: list[tuple[int, int, str | None]] = [(left, right, last)]
    for st in steps:
        if st.swing == "left":
            left = st.to
        else:
            right = st.to
        out.append((left, right, st.swing))
    return out


def find_route(terrain: Terrain, maps: dict[str, BalanceMap], folder: Path, jobs: int = 1, say: Say | None = None,
               progress=None, holds: Footholds | None = None) -> RouteOutcome:
    """Search, write the route as a scenario, plan it; blacklist what fails and search again.

    Raises:
        NoRoute: no route on the maps (or none the planner can balance within MAX_REPLANS).
    """
    holds = holds if holds is not None else footholds(terrain)
    model = StepModel(terrain, holds, maps)
    searches: list[SearchResult] = []
    blacklisted: list[dict] = []
    plan_s = 0.0
    memo = RouteMemo()  # the steps optimised so far, and their rows: a re-planned route does not redo them
    for _ in range(MAX_REPLANS + 1):
        found = astar(model)
        searches.append(found)
        if found.steps is None:
            assert found.frontier is not None
            raise _no_route(terrain, found.frontier, blacklisted)
        text = route_scenario_text(terrain, holds, found.steps)
        try:
            scenario = load_scenario_text(text, str(folder / "route.yaml"))
        except InputError as exc:  # the loader's own checks refuse a step (a rounding the map missed)
            m = _STEP_KEY.match(exc.key or "")
            if m is None:
                raise
            bad = found.steps[int(m.group(1))]
            model.blacklist.add(bad.key)
            blacklisted.append({"step": int(m.group(1)), "swing": bad.swing, "landing_m": holds.xyz[bad.to].tolist(),
                                "why": f"the scenario loader: {exc.problem}"})
            continue
        t0 = time.perf_counter()
        try:
            result = plan_route(scenario, memo, jobs=jobs, progress=progress)
        except InfeasibleAt as exc:
            plan_s += time.perf_counter() - t0
            first: Infeasible = exc.first
            n = len(found.steps)
            k = min(max(first.step, 0), n)
            why = f"{first.reason} ({first.phase})"
            if first.phase == "transfer":
                left, right, last = _states(holds, found.steps)[k]
                nxt = found.steps[k].swing if k < n else None
                model.transfer_blacklist.add((left, right, last, nxt))
                what = (f"the transfer before step {k + 1}" if k < n else "the final transfer") + \
                    f" (left on {terrain.names[holds.carton[left]]}, right on {terrain.names[holds.carton[right]]})"
                blacklisted.append({"transfer": k, "left_m": holds.xyz[left].tolist(),
                                    "right_m": holds.xyz[right].tolist(), "why": f"the planner: {exc}"})
            else:
                k = min(k, n - 1)
                bad = found.steps[k]
                model.blacklist.add(bad.key)
                what = f"step {k + 1} ({bad.swing} foot onto {terrain.names[holds.carton[bad.to]]})"
                blacklisted.append({"step": k, "swing": bad.swing, "landing_m": holds.xyz[bad.to].tolist(),
                                    "why": f"the planner: {exc}"})
            if say:
                say(f"route: {what} does not plan ({why}); searching again without it")
            continue
        plan_s += time.perf_counter() - t0
        return RouteOutcome(terrain, holds, found.steps, scenario, text, result, searches, blacklisted, plan_s)
    raise _no_route(terrain, Frontier([], 0, why="planner", detail=f"{MAX_REPLANS} routes failed to plan"),
                    blacklisted)


def _no_route(terrain: Terrain, f: Frontier, blacklisted: list[dict]) -> NoRoute:
    names = terrain.names
    reached = ", ".join(names[k] for k in f.reached) or "none"
    msg = (f"{terrain.source}: no route to {terrain.goal.describe(names)}: the frontier reached cartons {reached} "
           f"({f.states} stances explored")
    msg += f", {len(blacklisted)} steps the planner refused)" if blacklisted else ")"
    if f.nearest is not None:
        msg += f"; the nearest carton not reached is {names[f.nearest]}, {_WHY_TEXT[f.why]}: {f.detail}"
    elif f.detail:
        msg += f"; {f.detail}"
    doc = {"feasible": False, "terrain": terrain.name, "reached": [names[k] for k in f.reached], "states": f.states,
           "nearest": None if f.nearest is None else names[f.nearest], "why": f.why, "detail": f.detail,
           "blacklisted": blacklisted}
    return NoRoute(msg, doc)


_WHY_TEXT = {"reach": "out of reach", "thrust": "beyond the thrust limit", "margin": "at the edge of the balance "
             "space (margin)", "balance": "unbalanced", "collision": "blocked by cartons",
             "joint limits": "beyond the joint limits", "overlap": "behind the support sole",
             "planner": "refused by the planner", "transfer": "its transfers leave the joint limits", "goal": "",
             "": "not reached"}


def write_route(o: RouteOutcome, maps: dict[str, BalanceMap], folder: Path, wall: dict[str, float]
                ) -> tuple[dict, list[str]]:
    """Write the plan folder with the route's files (after the plan's self-check); (summary, files kept)."""
    summary = plan_summary(o.result)
    summary["route"] = route_summary(o, maps, wall)
    d = drawing(o, maps)
    extra = {"route.yaml": o.text.encode("utf-8"), "route.mcap": route_mcap(d), "route.png": route_png(d)}
    key = scenario_steps_key(o.result.scenario, o.result.method, o.result.seed)
    _, kept = write_plan(o.result, folder.parent, summary, check=lambda text: self_check(text, o.result, summary,
                                                                                          False),
                         folder=folder, extra=extra, own=ROUTE_OWN, steps_key=key)
    return summary, kept
