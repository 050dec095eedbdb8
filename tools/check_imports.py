"""The import graph of ``jethr1_plan``, checked (``make lint``): no circle between modules or between
packages, no layer importing a higher one, and no unit of :data:`ONLY` importing beyond its list.

The layers, lowest first, are written down here once, with what lives in each unit (:data:`WHAT`);
``tools/architecture.py`` writes them into docs/architecture.md's layer table and the package's docstring.
A unit is a subpackage or a top-level module of ``jethr1_plan``. A unit may import units of its own
layer or below. Every import counts, at module level or inside a function; ``if TYPE_CHECKING:``
imports too.
"""

from __future__ import annotations

import ast
import sys
from collections import defaultdict
from pathlib import Path

LAYERS: list[tuple[str, ...]] = [
    ("__init__", "arithmetic", "errors", "reasons", "geometry"),  # the words everything uses
    ("io",),  # YAML, JSON, CSV tables, atomic writes
    ("robot",),  # the robot as data
    ("records",),  # what the planner produces, typed: rows, columns, topics, the first infeasible sample
    ("physics",),  # balance with thrust, statics, the compiled per-candidate physics
    ("kinematics",),  # P_body and yaw to joints and CoM
    ("optimisers",),  # P_body along a swing path; the P_body search of one cell
    ("scenario", "scenario_schema", "swing_path"),  # what a user asks for
    ("control",),  # what is sent to the robot and the loops that run on it
    ("planning", "walking", "balance_space"),  # Paper A's plan, Paper B's walk, the balance space
    ("files",),  # every file format, written and read
    ("folders",),  # written folders read back whole, with the scenario they were planned from
    ("sim",),  # the MuJoCo twin and rehearsals
    ("verify",),  # independent re-checks of written files
    ("pipeline",),  # input file to checked output folder
    ("route",),  # footholds chosen on the balance space, then planned (jethr1 route)
    ("studies",),  # comparisons, curves, sweeps, batches
    ("viewer",),  # written folders shown in Rerun (jethr1 view)
    ("cli",),  # the command line
]

#: what lives in each unit: "<in a few words>: <in detail>" (the package docstring gives the few words,
#: docs/architecture.md's layer table the whole; ``tools/architecture.py`` writes both). ``__init__`` is the
#: package's own docstring, which the table does not list.
WHAT: dict[str, str] = {
    "__init__": "the package: its version and this map of the house",
    "arithmetic": "the same bytes on every machine: OpenBLAS's and NumPy's kernels pinned before they load, on "
                  "every x86-64 processor with AVX2 and FMA",
    "errors": "the exception tree: every expected failure carries its exit code (`InputError` 2, `InfeasiblePlan` "
              "3, ...)",
    "reasons": "why things fail: one vocabulary of why a posture, a sample or a cell fails (`Reason`, with "
               "messages)",
    "geometry": "the words everything uses: each stated once, `Side`/`other_side`, gravity, sole rectangles, convex "
                "hull, polygon margins, quaternions and poses",
    "io": "YAML, JSON, CSV tables, atomic writes: every input read as a regular file of bounded size "
          "(`io/input_file.py`), YAML checked by a schema, JSON, wide CSV tables (the `csv` module), the one rule "
          "of every output: staging and commit (`io/atomic.py`) and the record of the files jethr1 wrote with the "
          "checks before a write (`io/record.py`), work forked to a child process (`io/forked.py`), worker pools "
          "whose workers die with their command (`io/pool.py`), calls made in a child process replaced after a "
          "number of them (`io/recycled.py`), the Dask client",
    "robot": "the robot as data: the typed `RobotModel` (`model.py`), the sensors it declares (`sensors.py`), "
             "`load_robot` putting the URDF and the robot YAML together (`load.py`), the YAML's schema, the URDF "
             "read and checked, `robot show`'s summary, a robot's design variants written as robot folders "
             "(`variant.py`), PlaCo's robot wrappers kept for reuse within a process (`wrappers.py`)",
    "records": "what the planner produces, typed: the plan's rows with fixed fields (`plan_rows.py`), every plan and "
               "walk column name (`plan_columns.py`, `walk_columns.py`), the topics and their message types "
               "(`topics.py`), the first infeasible sample (`infeasible.py`)",
    "physics": "**the balance model** with thrust: ZMP, thrust window, least thrust of several fans, (A-4), (A-10) "
               "(`balance.py`), the statics of a posture (`statics.py`), the compiled per-candidate physics every "
               "search calls",
    "kinematics": "P_body and body yaw to joints and CoM: the `PostureSolver` protocol, PlaCo's IK, the closed form",
    "optimisers": "**the optimisers** of P_body along a swing path: one interface `optimise_path(PathRequest) -> "
                  "PathResult` and a registry: GAS/GA/GAEx (`gas.py`), SLSQP (`sqp.py`, a sample's solves in "
                  "`sqp_sample.py`, the price of smoothness in `sqp_smoothing.py`); the fitness (`problem.py`); the "
                  "P_body search of one cell (`search.py`: compass and exhaustive)",
    "scenario": "what a user asks for: the validating scenario loader",
    "scenario_schema": "the scenario file's schema: every key known, every number bounded",
    "swing_path": "the swing foot's path: arcs, explicit paths, cartons and clearance",
    "control": "**what is sent to the robot and the loops that run on it**: servo and fan commands, the body-yaw "
               "MPC, time laws; **the robot's loop** (`feedback.py`: a `Measurement` in, a `Command` out), the "
               "thrust laws (`imu_thrust.py` on the IMU, `thrust_feedback.py` on the soles' CoP), the swing-foot "
               "placement; the records between robot and loop (`measurement.py`)",
    "planning": "Paper A's plan: a scenario's problems, their optimisation, the output-rate sequence, the fastest "
                "timing, results and `summary.json`",
    "walking": "Paper B's walk: footsteps in time, CoM MPC, yaw reference, QP IK with joint windows, arm swing, the "
               "judge",
    "balance_space": "Paper A's balance space: the sweep of swing-sole cells",
    "folders": "written folders read back whole, with the scenario they were planned from (`plan.py`: "
               "`read_plan`, `PlanFolder`)",
    "files": "**every file format, written and read in one place**: the plan's column contract (`plan_table.py`), "
             "`trajectory.csv`, `trajectory.mcap`, the plan folder (`plan_folder.py`: `write_plan`, `read_plan`), "
             "the rehearsal's files, the walk folder, the balance-space files, the ROS 2 MCAP container and CDR "
             "encoder",
    "sim": "the MuJoCo twin and rehearsals: the twin (`twin.py`), the robot's sensors in it and its own kinematics "
           "(`sensors.py`), the plan as the twin follows it and a run's model errors (`track.py`), a run "
           "(`run.py`) and its judge (`judge.py`), rehearsals of plans and walks, step-by-step execution "
           "(`stepwise.py`), and the certificates of randomised trials",
    "verify": "independent re-checks of written files: plans and walks, by named checks (`checks.py`; the file and "
              "the poses, the balance, the analysis, the timing) with their own forward kinematics and "
              "differences, their own balance, motion and commands (`balance.py`, `motion.py`, `commands.py`)",
    "pipeline": "input file to checked output folder: a scenario's plan, a walk",
    "route": "footholds chosen on the balance space, then planned (`jethr1 route`): the terrain, the balance maps, "
             "the footholds, a step judged on the map (`steps.py`), the search (A*), the planner",
    "studies": "comparisons, curves, sweeps, batches: `compare`, `ditch-curve`, Paper B's reach, `batch`, "
               "`walk-sweep`, a written plan of several steps executed step by step (`step_by_step.py`: `simulate`, "
               "`replan-steps`), `design` (robot variants judged by the ditch curve: the design file, the judge, the "
               "sweep and its cache, the files)",
    "viewer": "written folders shown in Rerun (`jethr1 view`): what a path holds (`files.py`), the messages logged "
              "(`topics.py`), the view (`show.py`)",
    "cli": "the command line: the `jethr1` command, one thin module per command",
}

#: units that may import only these units, whatever their layer allows. ``verify`` re-checks what the planner
#: wrote: it reads the files, the robot and the scenario, and restates the physics it holds them to
#: (verify/balance.py, motion.py, commands.py); a mistake in the planner's physics, kinematics, optimisers,
#: commands, plans, walks or balance space must not be repeated in its verdict, so it imports none of them.
ONLY: dict[str, tuple[str, ...]] = {
    "verify": ("__init__", "errors", "reasons", "geometry", "io", "robot", "records", "scenario", "swing_path", "files",
               "folders", "verify"),
}


def modules(root: Path) -> dict[str, Path]:
    """Dotted name → file of every module of the package under ``root``."""
    out = {}
    for p in sorted((root / "jethr1_plan").rglob("*.py")):
        parts = p.relative_to(root).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = p
    return out


def imports(path: Path, name: str, known: set[str]) -> set[str]:
    """The package's modules that ``name`` imports (resolved to the longest known module)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = set()
    is_pkg = path.name == "__init__.py"
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")
                base = base if is_pkg else base[:-1]
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            targets = [mod] + [f"{mod}.{a.name}" for a in node.names]
        for t in targets:
            while t and t not in known:
                t = t.rpartition(".")[0]
            if t and t.startswith("jethr1_plan") and t != name:
                found.add(t)
    return found


def unit(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10_000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def main(root: Path) -> int:
    mods = modules(root)
    known = set(mods)
    graph = {m: imports(p, m, known) for m, p in mods.items()}
    layer_of = {u: k for k, layer in enumerate(LAYERS) for u in layer}
    problems = []
    units = {unit(m) for m in mods}
    for u in sorted(units - set(layer_of)):
        problems.append(f"jethr1_plan.{u} is in no layer (tools/check_imports.py LAYERS)")
    # a package imports its own submodules: only edges between different modules count for circles
    for comp in cycles(graph):
        problems.append("modules import each other in a circle: " + " -> ".join(comp))
    package_graph: dict[str, set[str]] = defaultdict(set)
    for m, targets in graph.items():
        for t in targets:
            if unit(t) != unit(m):
                package_graph[unit(m)].add(unit(t))
    for comp in cycles(package_graph):
        problems.append("packages import each other in a circle: " + " -> ".join(comp))
    for m, targets in sorted(graph.items()):
        for t in sorted(targets):
            a, b = layer_of.get(unit(m)), layer_of.get(unit(t))
            if a is not None and b is not None and b > a:
                problems.append(f"{m} (layer {a}: {unit(m)}) imports {t} (layer {b}: {unit(t)}), a higher layer")
    for m, targets in sorted(graph.items()):
        allowed = ONLY.get(unit(m))
        for t in sorted(targets):
            if allowed is not None and unit(t) not in allowed:
                problems.append(f"{m} imports {t}: {unit(m)} may import only {', '.join(allowed)}")
    for p in problems:
        print(p)
    edges = sum(len(v) for v in graph.values())
    print(f"import graph: {len(mods)} modules, {edges} imports, {len(LAYERS)} layers: "
          + ("ok" if not problems else f"{len(problems)} problems"))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(Path(__file__).resolve().parents[1]))
