"""``jethr1 route`` on seeded random carton fields and on Paper A's terrain (issue 29).

1. The maps: Jet-HR1's robust 2 cm maps (both support sides), computed once into the map cache
   ($JETHR1_CACHE, else ~/.cache/jethr1) and reused by every route below.
2. On N seeded terrains (``jethr1 terrain random --seed S --cartons 4 --gaps 0.05:0.15``, S = 0..N-1):
   the route (A* on the map, then planned for real, refused steps replaced) against the exhaustive search
   (Dijkstra over every reachable stance of the same foothold grid, on the same map): found / not found,
   the cost ratio; each route's plan re-checked by ``verify`` and rehearsed feed-forward at nominal in
   the twin; the time of each route after the maps (search, plan and files; wall and CPU).
3. The cost trade: the routes of the same terrains under four weightings (steps only; the default;
   thrust first; margin first): steps, the map's peak and mean thrust and its least margin.
4. Paper A's trial terrains (configs/terrains/): the route's steps beside Paper A's two hand-placed ones
   (configs/jet_hr1_trial*.yaml), both planned and rehearsed feed-forward.

Usage: python bench/bench_route.py [--terrains N] [--seeds 46,58,90-99] [--trade N] [--json out/bench_route.json].
One core throughout.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import tempfile
import time
from pathlib import Path

import jethr1_plan.arithmetic  # noqa: F401  (first: NumPy's and OpenBLAS's kernels pinned before they load)

import numpy as np

from jethr1_plan.io.json_text import json_text
from jethr1_plan.route.footholds import footholds
from jethr1_plan.route.planner import NoRoute, find_route, route_maps, write_route
from jethr1_plan.route.search import astar, exhaustive
from jethr1_plan.route.steps import StepModel
from jethr1_plan.route.terrain import CostWeights, load_terrain, load_terrain_text, random_terrain

ROOT = Path(__file__).resolve().parents[1]
CARTONS, GAPS = 4, (0.05, 0.15)


def clocks() -> tuple[float, float]:
    return time.perf_counter(), time.process_time()


def rehearse_nominal(folder: Path) -> dict:
    from jethr1_plan.sim.rehearsal import Perturbation, simulate

    (run,) = simulate(folder, "feedforward", [Perturbation()], jobs=1)
    return {"survived": bool(run.survived), "fell": run.fell, "on_cartons": run.soles_on_cartons_at_end,
            "landing_errors_mm": [round(1000 * e["xy_m"], 1) for e in run.landing_errors_m],
            "max_tilt_deg": run.max_trunk_tilt_deg}


def verified(folder: Path) -> bool:
    from jethr1_plan.verify.folder import verify_path

    _, failures, _, _ = verify_path(folder, None)
    return not failures


def route_one(terrain, maps, out: Path) -> dict:
    """Route, plan and write one terrain; verify and rehearse it. Times after the maps."""
    folder = out / Path(terrain.source).stem
    w0, c0 = clocks()
    try:
        o = find_route(terrain, maps, folder)
    except NoRoute as exc:
        w1, c1 = clocks()
        return {"found": False, "why": exc.frontier.get("why"), "nearest": exc.frontier.get("nearest"),
                "blacklisted": len(exc.frontier.get("blacklisted", [])), "wall_s": w1 - w0, "cpu_s": c1 - c0}
    search = sum(s.wall_s for s in o.searches)
    summary, _ = write_route(o, maps, folder, {"search": search, "plan": o.plan_s})
    w1, c1 = clocks()
    rec = {"found": True, "steps": len(o.steps), "cost": summary["route"]["cost"], "replans": len(o.blacklisted),
           "wall_s": w1 - w0, "cpu_s": c1 - c0, "search_s": search, "plan_s": o.plan_s,
           "peak_thrust_n": summary["peak_thrust_n"], "least_zmp_margin_m":
               summary.get("robustness", {}).get("least_zmp_margin_m"), "feasible": summary["feasible"]}
    rec["verify"] = verified(folder)
    rec["rehearsal"] = rehearse_nominal(folder)
    return rec


def random_terrains(seeds: list[int], maps, out: Path, reference: bool = True) -> list[dict]:
    rows = []
    for seed in seeds:
        text = random_terrain(seed, CARTONS, GAPS)
        path = out / f"random_{seed}.yaml"
        path.write_text(text)
        t = load_terrain(path)
        holds = footholds(t)
        w0 = time.perf_counter()
        ex = exhaustive(StepModel(t, holds, maps)) if reference else astar(StepModel(t, holds, maps))
        ex_s = time.perf_counter() - w0
        rec = {"seed": seed, "exhaustive": {"found": ex.steps is not None, "cost": ex.cost if ex.steps else None,
                                            "steps": len(ex.steps) if ex.steps else None, "stances": ex.expanded,
                                            "wall_s": ex_s}}
        rec["route"] = route_one(t, maps, out)
        r = rec["route"]
        line = (f"seed {seed:3d}: exhaustive {'found' if ex.steps else 'none '} ({ex.expanded} stances, {ex_s:.1f} s); "
                f"route {'found ' + str(r.get('steps')) + ' steps' if r['found'] else 'none (' + str(r['why']) + ')'}")
        if r["found"]:
            line += (f", cost {r['cost']:.3f} vs {ex.cost:.3f}, {r['replans']} replans, {r['wall_s']:.1f} s wall / "
                     f"{r['cpu_s']:.1f} s CPU; verify {'ok' if r['verify'] else 'FAILS'}; twin "
                     f"{'survived' if r['rehearsal']['survived'] else 'fell ' + str(r['rehearsal']['fell'])}")
        print(line, flush=True)
        rows.append(rec)
    return rows


def success_table(rows: list[dict]) -> dict:
    n = len(rows)
    ex = [r["exhaustive"]["found"] for r in rows]
    ro = [r["route"]["found"] for r in rows]
    both = [r for r in rows if r["exhaustive"]["found"] and r["route"]["found"]]
    found = [r["route"] for r in rows if r["route"]["found"]]
    ratios = [r["route"]["cost"] / r["exhaustive"]["cost"] for r in both]
    six = [r for r in found if r["steps"] == 6]
    out = {
        "terrains": n, "exhaustive_found": sum(ex), "route_found": sum(ro),
        "agree": sum(a == b for a, b in zip(ex, ro, strict=True)),
        "route_missed": sum(a and not b for a, b in zip(ex, ro, strict=True)),
        "route_only": sum(b and not a for a, b in zip(ex, ro, strict=True)),
        "cost_ratio_max": max(ratios, default=None), "cost_ratio_mean": statistics.mean(ratios) if ratios else None,
        "planned_feasibly": sum(r["feasible"] for r in found), "verified": sum(r["verify"] for r in found),
        "survived_feedforward": sum(r["rehearsal"]["survived"] for r in found),
        "fell_feedforward": sum(r["rehearsal"]["fell"] is not None for r in found),
        "replanned_routes": sum(r["replans"] > 0 for r in found), "replans": sum(r["replans"] for r in found),
        "steps": {k: sum(r["steps"] == k for r in found) for k in sorted({r["steps"] for r in found})},
        "route_wall_s": {"median": statistics.median([r["wall_s"] for r in found]) if found else None,
                         "max": max((r["wall_s"] for r in found), default=None)},
        "route_cpu_s": {"median": statistics.median([r["cpu_s"] for r in found]) if found else None,
                        "max": max((r["cpu_s"] for r in found), default=None)},
        "six_step": {"routes": len(six), "wall_s_max": max((r["wall_s"] for r in six), default=None),
                     "cpu_s_max": max((r["cpu_s"] for r in six), default=None),
                     "search_s_max": max((r["search_s"] for r in six), default=None),
                     "plan_s_max": max((r["plan_s"] for r in six), default=None)},
        "exhaustive_wall_s": {"median": statistics.median([r["exhaustive"]["wall_s"] for r in rows]),
                              "max": max(r["exhaustive"]["wall_s"] for r in rows)},
        "no_route_why": {},
        "fell": [{"seed": r["seed"], "steps": r["route"]["steps"], "fell": r["route"]["rehearsal"]["fell"],
                  "on_cartons": r["route"]["rehearsal"]["on_cartons"],
                  "landing_errors_mm": r["route"]["rehearsal"]["landing_errors_mm"]}
                 for r in rows if r["route"]["found"] and not r["route"]["rehearsal"]["survived"]],
        "survived_by_steps": {k: [sum(r["rehearsal"]["survived"] for r in found if r["steps"] == k),
                                  sum(r["steps"] == k for r in found)] for k in sorted({r["steps"] for r in found})},
    }
    for r in rows:
        if not r["route"]["found"]:
            out["no_route_why"][r["route"]["why"]] = out["no_route_why"].get(r["route"]["why"], 0) + 1
    return out


WEIGHTS = {"steps only": CostWeights(peak_thrust=0.0, mean_thrust=0.0, margin=0.0, edge=0.0),
           "default": CostWeights(),
           "thrust first": CostWeights(peak_thrust=5.0, mean_thrust=2.5),
           "margin first": CostWeights(margin=5.0, margin_m=0.06),
           "carton edges first": CostWeights(edge=5.0, edge_m=0.025)}


def cost_trade(seeds: list[int], maps) -> dict:
    """The map's figures of the routes under each weighting, averaged over the terrains all of them cross."""
    out: dict = {}
    per: dict = {name: {} for name in WEIGHTS}
    for seed in seeds:
        base = load_terrain_text(random_terrain(seed, CARTONS, GAPS), f"random_{seed}")
        holds = footholds(base)
        for name, w in WEIGHTS.items():
            t = dataclasses.replace(base, options=dataclasses.replace(base.options, cost=w))
            r = astar(StepModel(t, holds, maps))
            if r.steps:
                per[name][seed] = {"steps": len(r.steps), "peak_n": max(s.edge.peak_n for s in r.steps),
                                   "mean_n": float(np.mean([s.edge.mean_n for s in r.steps])),
                                   "least_margin_m": min(s.edge.margin_m for s in r.steps),
                                   "least_edge_m": float(min(holds.edge_m[s.to] for s in r.steps))}
    common = set.intersection(*(set(v) for v in per.values())) if per else set()
    for name, got in per.items():
        vals = [got[s] for s in sorted(common)]
        out[name] = {k: statistics.mean(v[k] for v in vals) for k in ("steps", "peak_n", "mean_n", "least_margin_m",
                                                                       "least_edge_m")} if vals else {}
    out["terrains"] = len(common)
    return out


def paper_a(maps_for, out: Path) -> list[dict]:
    """Paper A's trial terrains: the route against the hand-placed two steps."""
    from jethr1_plan.files.plan_folder import write_plan
    from jethr1_plan.pipeline.plan import self_check
    from jethr1_plan.planning.plan import plan
    from jethr1_plan.planning.report import plan_summary
    from jethr1_plan.scenario import load_scenario

    rows = []
    for name in ("jet_hr1_trial_robust", "jet_hr1_trial"):
        t = load_terrain(ROOT / "configs" / "terrains" / f"{name}.yaml")
        maps = maps_for(t)
        r = route_one(t, maps, out / "routes")
        hand = load_scenario(ROOT / "configs" / f"{name}.yaml")
        w0 = time.perf_counter()
        res = plan(hand)
        s = plan_summary(res)
        folder, _ = write_plan(res, out / "hand", s, check=lambda text, res=res, s=s: self_check(text, res, s, False))
        hand_rec = {"steps": len(hand.steps), "peak_thrust_n": s["peak_thrust_n"],
                    "least_zmp_margin_m": s["robustness"]["least_zmp_margin_m"], "wall_s": time.perf_counter() - w0,
                    "landings": [[st.swing, [round(v, 4) for v in st.landing_m.tolist()]] for st in hand.steps],
                    "rehearsal": rehearse_nominal(folder)}
        sc = load_scenario(out / "routes" / name / "route.yaml") if r["found"] else None
        r["landings"] = [[st.swing, [round(v, 4) for v in st.landing_m.tolist()]] for st in sc.steps] if sc else []
        rows.append({"terrain": name, "route": r, "hand": hand_rec})
        print(f"{name}: route {r.get('steps')} steps {r['landings']} max {r.get('peak_thrust_n')} N; Paper A "
              f"{hand_rec['steps']} steps {hand_rec['landings']} max {hand_rec['peak_thrust_n']:.2f} N", flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--terrains", type=int, default=100, help="random terrains (0: Paper A's terrains only)")
    ap.add_argument("--seeds", default=None, help="only these seeds (e.g. 46,58,91 or 40-59) of the N terrains")
    ap.add_argument("--no-exhaustive", action="store_true",
                    help="the A* on the maps as the reference instead of the exhaustive search (quicker; the same "
                         "found / not found and costs, measured on 100 terrains)")
    ap.add_argument("--trade", type=int, default=40, help="terrains of the cost trade (0: none)")
    ap.add_argument("--json", default=str(ROOT / "out" / "bench_route.json"))
    args = ap.parse_args()
    from threadpoolctl import threadpool_limits

    doc: dict = {"cartons": CARTONS, "gaps_m": list(GAPS)}
    with threadpool_limits(limits=1), tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        cache: dict = {}

        def maps_for(t):
            b = t.base.balance  # every setting a map depends on (the cache's own key has them all)
            key = (str(t.robot.yaml_path), b.policy, b.tolerance, b.thrust_max_n, b.sole_margin_m, b.rho_rad,
                   t.options.map_resolution_m)
            if key not in cache:
                w0, c0 = clocks()
                cache[key] = route_maps(t, None, jobs=1, say=lambda line: print(line, flush=True))
                w1, c1 = clocks()
                doc.setdefault("maps", []).append({"policy": b.policy, "resolution_m": t.options.map_resolution_m,
                                                   "reused": all(m.reused for m in cache[key].values()),
                                                   "wall_s": w1 - w0, "cpu_s": c1 - c0,
                                                   "files": [str(m.path) for m in cache[key].values()]})
            return cache[key]

        if args.terrains:
            first = load_terrain_text(random_terrain(0, CARTONS, GAPS), "random_0")
            maps = maps_for(first)
            seeds = list(range(args.terrains))
            if args.seeds:
                pick: set[int] = set()
                for part in args.seeds.split(","):
                    lo, _, hi = part.partition("-")
                    pick.update(range(int(lo), int(hi or lo) + 1))
                seeds = [s for s in seeds if s in pick]
            rows = random_terrains(seeds, maps, out, reference=not args.no_exhaustive)
            doc["random"] = rows
            doc["success"] = success_table(rows)
            found = [r["seed"] for r in rows if r["exhaustive"]["found"]][:args.trade]
            doc["trade"] = cost_trade(found, maps) if args.trade else {"terrains": 0}
        doc["paper_a"] = paper_a(maps_for, out)
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json_text(doc))
    if not args.terrains:
        print(f"\nwrote {args.json}")
        return
    s = doc["success"]
    print("\n## Success on", s["terrains"], "seeded terrains (--cartons", CARTONS, "--gaps", f"{GAPS[0]}:{GAPS[1]})")
    for k, v in s.items():
        if k not in ("fell",):
            print(f"- {k}: {v}")
    print("\n## Cost trade (map figures, mean over", doc["trade"]["terrains"], "terrains every weighting crosses)")
    for name, v in doc["trade"].items():
        if name != "terrains" and v:
            print(f"- {name}: {v['steps']:.2f} steps, peak {v['peak_n']:.2f} N, mean {v['mean_n']:.2f} N, least "
                  f"margin {1000 * v['least_margin_m']:.0f} mm, least room to a carton edge "
                  f"{1000 * v['least_edge_m']:.1f} mm")
    print(f"\nwrote {args.json}")


if __name__ == "__main__":
    sys.exit(main())
