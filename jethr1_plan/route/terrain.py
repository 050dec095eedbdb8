"""Terrain files (``jethr1 route``'s input) and seeded random carton fields (``jethr1 terrain random``).

A terrain is a scenario without steps: the robot, the cartons (``terrain.cartons``, each with an
optional ``name``), the start stance, the balance policy and tolerance, the optimiser and the timing,
all with a scenario's keys and meaning, plus

* ``goal``: ``{carton: NAME or INDEX}`` (a sole lands on that carton) or ``{region: {x_m: [LO, HI],
  y_m: [LO, HI]}}`` (both soles end fully inside that rectangle);
* ``limits``: ``max_steps`` and ``peak_thrust_n`` (the most any step may need, by the map);
* ``route``: the planner's options (:class:`RouteOptions`).

The file is checked against :data:`TERRAIN_SCHEMA`; the parts a scenario has are then checked by the
scenario loader itself (a probe scenario of one step in place), so a terrain accepts exactly what a
scenario accepts and its messages name the same keys.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from jethr1_plan.errors import InputError
from jethr1_plan.io.yaml_input import fill_dataclass, read_document, read_text
from jethr1_plan.robot.load import load_robot
from jethr1_plan.scenario import Scenario, load_scenario_text
from jethr1_plan.scenario_schema import DEFAULT_CARTON_M, MAX_FILE_BYTES, MAX_VALUES, SCHEMA
from jethr1_plan.swing_path import Carton

__all__ = ["TERRAIN_SCHEMA", "CostWeights", "Goal", "Limits", "RouteOptions", "Terrain", "dump_yaml", "load_terrain",
           "load_terrain_text", "random_terrain"]

GROUND_Z = -0.14  # the floor the random cartons stand on (Paper A's cartons are 0.14 m tall, their tops at 0) [m]

_p = SCHEMA["properties"]
_pos = {"type": "number", "exclusiveMinimum": 0, "maximum": 1}
_range = {"type": "array", "items": {"type": "number", "minimum": -100, "maximum": 100}, "minItems": 2, "maxItems": 2}
_carton = copy.deepcopy(_p["terrain"]["properties"]["cartons"]["items"])
_carton["properties"]["name"] = {"type": "string", "minLength": 1, "maxLength": 40}
_weight = {"type": "number", "minimum": 0, "maximum": 1000}

#: the terrain file's structure (a scenario's keys but ``steps``, ``body_yaw`` and ``expect``; and goal, limits, route)
TERRAIN_SCHEMA = {
    "type": "object", "additionalProperties": False, "required": ["terrain", "goal"],
    "properties": {
        **{k: _p[k] for k in ("name", "description", "robot", "seed", "start", "optimiser", "balance", "timing")},
        "terrain": {"type": "object", "additionalProperties": False, "required": ["cartons"], "properties": {
            "carton_size_m": _p["terrain"]["properties"]["carton_size_m"],
            "cartons": {"type": "array", "minItems": 1, "maxItems": 200, "items": _carton}}},
        "goal": {"oneOf": [
            {"type": "object", "additionalProperties": False, "required": ["carton"],
             "properties": {"carton": {"type": ["string", "integer"], "minimum": 0, "maxLength": 40}}},
            {"type": "object", "additionalProperties": False, "required": ["region"],
             "properties": {"region": {"type": "object", "additionalProperties": False, "required": ["x_m", "y_m"],
                                       "properties": {"x_m": _range, "y_m": _range}}}}]},
        "limits": {"type": "object", "additionalProperties": False, "properties": {
            "max_steps": {"type": "integer", "minimum": 1, "maximum": 50},
            "peak_thrust_n": {"type": "number", "minimum": 0, "maximum": 1e4}}},
        "route": {"type": "object", "additionalProperties": False, "properties": {
            "foothold_spacing_m": {"type": "number", "minimum": 0.01, "maximum": 1},  # finer than the twin lands
            "edge_margin_m": {"type": "number", "minimum": 0, "maximum": 0.1},
            "clearances_m": {"type": "array", "items": {"type": "number", "exclusiveMinimum": 0, "maximum": 0.5},
                             "minItems": 1, "maxItems": 5},
            "samples": {"type": "integer", "minimum": 5, "maximum": 200},
            "lift_m": {"type": "number", "minimum": 0, "maximum": 0.1},
            "descent_m": {"type": "number", "minimum": 0, "maximum": 0.1},
            "map_resolution_m": {"type": "number", "minimum": 0.01, "maximum": 0.1},  # 1 cm: ~8 min once, cached
            "cost": {"type": "object", "additionalProperties": False, "properties": {
                "step": {"type": "number", "exclusiveMinimum": 0, "maximum": 1000}, "peak_thrust": _weight,
                "mean_thrust": _weight, "margin": _weight, "margin_m": _pos, "edge": _weight,
                "edge_m": _pos}}}},
    },
}


@dataclass(frozen=True)
class CostWeights:
    """The cost of one step: ``step`` + ``peak_thrust`` · F_peak / F_max + ``mean_thrust`` · F_mean / F_max
    + ``margin`` · max(0, 1 − d / ``margin_m``) + ``edge`` · max(0, 1 − e / ``edge_m``), F the map's least
    thrust along the swing path, d the path's least distance to the edge of the balance space [m] and e
    the landing sole's least distance to the edge of its carton's top [m]. Every term but the first is
    ≥ 0, so a route's cost is at least ``step`` times its steps (the search's heuristic counts on it)."""

    step: float = 1.0
    peak_thrust: float = 1.0
    mean_thrust: float = 0.5
    margin: float = 1.0
    margin_m: float = 0.03
    edge: float = 1.0
    edge_m: float = 0.025


#: candidate soles lie inside their carton's top by this, for a robot with no measured landing error [m]
DEFAULT_EDGE_MARGIN_M = 0.005


@dataclass(frozen=True)
class RouteOptions:
    """``route:`` of a terrain."""

    foothold_spacing_m: float = 0.02  # candidate sole centres on a carton top, this far apart [m]
    #: each candidate sole lies this far inside its carton's top [m]; a terrain that does not say takes the robot's
    #: measured landing error (its YAML's execution.landing_error_m: docs/route.md), else DEFAULT_EDGE_MARGIN_M
    edge_margin_m: float = 0.005
    clearances_m: tuple[float, ...] = (0.1, 0.07, 0.05)  # the arcs tried for each step, in this order (sagitta) [m]
    samples: int = 25  # swing samples per step (route.yaml's arcs)
    lift_m: float = 0.02  # each swing leaves its carton straight up by this, then its arc [m] (swing_path)
    descent_m: float = 0.02  # and comes down on the next straight down from this high [m]
    map_resolution_m: float = 0.02  # the balance-space map's grid [m] (docs/route.md: measured)
    cost: CostWeights = field(default_factory=CostWeights)


@dataclass(frozen=True)
class Limits:
    """``limits:`` of a terrain."""

    max_steps: int = 12
    peak_thrust_n: float = math.inf  # the most thrust any step may need, by the map [N]


@dataclass(frozen=True)
class Goal:
    """Where the route ends: a sole on carton ``carton``, or both soles inside ``region`` ((x lo, hi), (y lo, hi))."""

    carton: int | None = None
    region: tuple[tuple[float, float], tuple[float, float]] | None = None

    def describe(self, names: tuple[str, ...]) -> str:
        if self.carton is not None:
            return f"a sole on carton {names[self.carton]}"
        assert self.region is not None
        (x0, x1), (y0, y1) = self.region
        return f"both soles in x {x0:g}..{x1:g} m, y {y0:g}..{y1:g} m"


@dataclass(frozen=True)
class Terrain:
    """A validated terrain file (SI units)."""

    source: str
    name: str
    doc: dict  # the document as read (route.yaml repeats its optimiser, balance and timing)
    base: Scenario  # the terrain as a scenario (its robot, start, cartons, balance, optimiser, timing)
    names: tuple[str, ...]  # each carton's name (its index where the file names none)
    goal: Goal
    limits: Limits
    options: RouteOptions
    text: str = ""

    @property
    def cartons(self) -> tuple[Carton, ...]:
        return self.base.cartons

    @property
    def robot(self):
        return self.base.robot


def load_terrain(path: str | Path) -> Terrain:
    """Read and validate a terrain file.

    Raises:
        InputError: the first problem found (exit 2).
    """
    return load_terrain_text(read_text(path, MAX_FILE_BYTES, "a terrain"), str(path))


def load_terrain_text(text: str, src: str) -> Terrain:
    """A terrain from its YAML ``text``; ``src`` names it in messages."""
    doc = read_document(text, src, TERRAIN_SCHEMA, MAX_VALUES, "a terrain")
    cartons_doc = doc["terrain"]["cartons"]
    names = tuple(str(c.get("name", k)) for k, c in enumerate(cartons_doc))
    for k, name in enumerate(names):
        if name in names[:k]:
            raise InputError(src, f"terrain.cartons[{k}].name", f"{name!r} names two cartons")
    probe = {k: v for k, v in doc.items() if k not in ("goal", "limits", "route")}
    probe["terrain"] = {**doc["terrain"], "cartons": [{k: v for k, v in c.items() if k != "name"} for c in cartons_doc]}
    robot = load_robot_checked(doc, src)
    start = doc.get("start") or {s: [float(v) for v in p] for s, p in robot.start_feet().items()}
    probe["start"] = start
    probe["steps"] = [{"swing": "left", "path": {"kind": "points", "points_m": [start["left"], start["left"]]}}]
    base = load_scenario_text(yaml.safe_dump(probe, sort_keys=False), src)
    goal = _goal(doc["goal"], names, base, src)
    limits = fill_dataclass(Limits(), doc.get("limits", {}))
    opts = dict(doc.get("route", {}))
    cost = fill_dataclass(CostWeights(), opts.pop("cost", {}))
    if "clearances_m" in opts:
        opts["clearances_m"] = tuple(float(c) for c in opts["clearances_m"])
    if "edge_margin_m" not in opts:
        opts["edge_margin_m"] = robot.landing_error_m if robot.landing_error_m is not None else DEFAULT_EDGE_MARGIN_M
    options = fill_dataclass(RouteOptions(), opts, cost=cost)
    return Terrain(source=src, name=doc.get("name", Path(src).stem), doc=doc, base=base, names=names, goal=goal,
                   limits=limits, options=options, text=text)


def load_robot_checked(doc: dict, src: str):
    """The robot a document names (``jethr1`` by default); its problem as the document's ``robot`` key."""
    try:
        return load_robot(doc.get("robot", "jethr1"))
    except InputError as exc:
        raise InputError(src, "robot", str(exc)) from None


def _goal(doc: dict, names: tuple[str, ...], base: Scenario, src: str) -> Goal:
    if "carton" in doc:
        ref = doc["carton"]
        if isinstance(ref, int):
            if ref >= len(names):
                raise InputError(src, "goal.carton", f"{ref}: the terrain has {len(names)} cartons "
                                 f"(0..{len(names) - 1})")
            return Goal(carton=ref)
        if ref not in names:
            raise InputError(src, "goal.carton", f"{ref!r} names no carton (names: {', '.join(names)})")
        return Goal(carton=names.index(ref))
    x, y = doc["region"]["x_m"], doc["region"]["y_m"]
    robot = base.robot
    if x[1] - x[0] < robot.sole_length_m or y[1] - y[0] < robot.sole_width_m:
        raise InputError(src, "goal.region", f"smaller than a sole ({robot.sole_length_m} x {robot.sole_width_m} m)")
    return Goal(region=((float(x[0]), float(x[1])), (float(y[0]), float(y[1]))))


class _Dumper(yaml.SafeDumper):
    """Mappings whose values are all scalars or lists of scalars in flow style (one carton, one step a line)."""


def _represent_dict(dumper: yaml.SafeDumper, data: dict):
    def flat(v) -> bool:
        return not isinstance(v, dict | list) or (isinstance(v, list) and not any(isinstance(x, dict | list)
                                                                                   for x in v))

    small = all(flat(v) for v in data.values()) and len(data) <= 4
    return dumper.represent_mapping("tag:yaml.org,2002:map", data.items(), flow_style=small or None)


_Dumper.add_representer(dict, _represent_dict)


def dump_yaml(doc: dict, header: str = "") -> str:
    """YAML a person reads and edits: keys in order, short mappings and lists in flow style, a ``# `` comment
    header."""
    body = yaml.dump(doc, Dumper=_Dumper, sort_keys=False, default_flow_style=None, width=120, allow_unicode=True)
    lines = "".join(f"# {line}\n" if line else "#\n" for line in header.splitlines())
    return lines + body


def random_terrain(seed: int, cartons: int = 4, gaps_m: tuple[float, float] = (0.05, 0.15),
                   heights_m: float = 0.04, side_m: float = 0.08, policy: str = "robust",
                   robot: str = "jethr1", sole_margin_m: float = 0.005) -> str:
    """A seeded carton field as terrain YAML: the same arguments give the same text.

    Two Paper A cartons under the start stance; then ``cartons`` cartons in rows along +x, each row
    across a ditch of a width drawn from ``gaps_m`` [m] behind the row before, holding one or two
    cartons moved sideways by up to ``side_m`` [m] (and forward by up to 3 cm), its top up to
    ``heights_m`` [m] above or below the row before (every carton stands on the floor at z = −0.14 m);
    last, across one more ditch, a wide carton (0.21 × 0.40 m) whose top is the goal region. The balance
    policy keeps the ZMP ``sole_margin_m`` inside the support sole beyond the tolerance: over a route of
    several steps the twin's landings drift by up to ~2 cm (docs/route.md).
    """
    rng = np.random.default_rng([seed, 29])
    size = DEFAULT_CARTON_M
    half = size[0] / 2
    out = [{"name": "start_left", "top_centre_m": [0.0, 0.1125, 0.0], "size_m": list(size)},
           {"name": "start_right", "top_centre_m": [0.0, -0.1125, 0.0], "size_m": list(size)}]
    front, z, placed, row = half, 0.0, 0, 0

    def r4(v: float) -> float:
        return round(float(v), 4) + 0.0

    while placed < cartons:
        row += 1
        n = min(int(rng.integers(1, 3)), cartons - placed)
        gap = float(rng.uniform(*gaps_m))
        z = _height(z, rng, heights_m)
        centre = front + gap + half
        ys = [0.1125 + rng.uniform(-side_m, side_m), -0.1125 + rng.uniform(-side_m, side_m)] if n == 2 \
            else [rng.uniform(-0.1125 - side_m, 0.1125 + side_m)]
        if n == 2 and ys[0] - ys[1] < size[1]:  # side by side at least: cartons never overlap
            mid = (ys[0] + ys[1]) / 2
            ys = [mid + size[1] / 2, mid - size[1] / 2]
        xs = [centre + rng.uniform(-0.03, 0.03) for _ in ys]
        for k, (x, y) in enumerate(zip(xs, ys, strict=True)):
            out.append({"name": f"r{row}{'ab'[k] if n == 2 else ''}", "top_centre_m": [r4(x), r4(y), z],
                        "size_m": [size[0], size[1], r4(z - GROUND_Z)]})
        front = max(xs) + half
        placed += n
    gap = float(rng.uniform(*gaps_m))
    z = _height(z, rng, heights_m)
    goal_x = r4(front + gap + half)
    out.append({"name": "goal", "top_centre_m": [goal_x, 0.0, z], "size_m": [size[0], 0.4, r4(z - GROUND_Z)]})
    doc = {
        "name": f"random_{seed}",
        "description": f"jethr1 terrain random --seed {seed} --cartons {cartons} --gaps {gaps_m[0]:g}:{gaps_m[1]:g} "
                       f"--heights {heights_m:g}",
        "robot": robot,
        "seed": int(seed),
        "start": {"left": [0.0, 0.1125, 0.0], "right": [0.0, -0.1125, 0.0]},
        "terrain": {"cartons": out},
        "goal": {"region": {"x_m": [r4(goal_x - half), r4(goal_x + half)], "y_m": [-0.2, 0.2]}},
        "balance": {"policy": policy, "thrust_max_n": 23.0, "sole_margin_m": sole_margin_m},
    }
    header = (f"A seeded carton field (jethr1 terrain random --seed {seed}): {cartons} cartons in rows across "
              f"ditches of {gaps_m[0]:g}..{gaps_m[1]:g} m,\nsideways up to {side_m:g} m, heights changing by up to "
              f"{heights_m:g} m a row; the goal is the wide carton at the end.\nRoute it: jethr1 route FILE")
    return dump_yaml(doc, header)


def _height(z: float, rng: np.random.Generator, heights_m: float) -> float:
    """The next row's top [m]: ``z`` changed by up to ±``heights_m``, kept within ±2.5 ``heights_m`` of the start,
    on a 5 mm grid."""
    if heights_m <= 0:
        return 0.0
    z = float(np.clip(z + rng.uniform(-heights_m, heights_m), -2.5 * heights_m, 2.5 * heights_m))
    return round(round(z / 0.005) * 0.005, 4) + 0.0
