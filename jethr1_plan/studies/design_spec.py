"""The design file of ``jethr1 design``: a base robot, the axes of a design space, the variants' fans written
in terms of the axes, and how each variant is judged.

A value in ``fans``, ``trunk_mass_scale`` or ``leg_length_scale`` is a number or an axis by name, ``$name``
(``-$name``: its negative, for a mirrored mount). The variants are every combination of the axes' values
(``sampling.method: grid``) or a seeded Latin hypercube over their ranges (``lhs``, scipy.stats.qmc, ``samples``
points): a ``range`` axis takes any value in it, a ``values`` axis one of its values. The same file gives the same
variants, in the same order.

A fan's mass is the fan unit's (duct, motor, mount) as a function of its maximum thrust, ``fan_mass``: a line
``kg + kg_per_n · F`` or a table of (F [N], kg) interpolated linearly (a thrust outside the table is an error);
a fan's own ``mass_kg`` overrides it. Every problem is one line naming the file and the key (exit 2).
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.io.yaml_input import read_document, read_text
from jethr1_plan.optimisers import METHODS
from jethr1_plan.physics.balance import Tolerance
from jethr1_plan.robot.variant import DUCT_RADIUS_M, FanDesign, VariantDesign

__all__ = ["MAX_VARIANTS", "SCHEMA", "Axis", "DesignSpec", "JudgeSettings", "Variant", "load_design"]

MAX_FILE_BYTES = 200_000
MAX_VALUES = 20_000
MAX_VARIANTS = 100_000  # a sweep of this many variants is days of CPU: anything larger is a typo
MAX_AXES = 8
ROBUST_TOLERANCE = Tolerance(thrust=0.10, mass=0.05, com_m=0.01)  # a scenario's balance.robust default
REF = re.compile(r"^(-?)\$([A-Za-z_][A-Za-z0-9_]*)$")

_ref = {"type": "string", "pattern": REF.pattern, "description": "a number, or an axis by name: $name or -$name"}


def _num_or_ref(lo: float, hi: float) -> dict:
    return {"oneOf": [{"type": "number", "minimum": lo, "maximum": hi}, _ref]}


def _obj(props: dict, required: tuple = ()) -> dict:
    return {"type": "object", "properties": props, "required": list(required), "additionalProperties": False}


_finite = {"type": "number", "minimum": -1e6, "maximum": 1e6}
_axis = {"oneOf": [
    _obj({"range": {"type": "array", "items": _finite, "minItems": 2, "maxItems": 2},
          "count": {"type": "integer", "minimum": 1, "maximum": MAX_VARIANTS}}, ("range",)),
    _obj({"values": {"type": "array", "items": _finite, "minItems": 1, "maxItems": MAX_VARIANTS}}, ("values",)),
]}
_fan = _obj({
    "name": {"type": "string", "pattern": "^[A-Za-z0-9_]+$", "maxLength": 100},
    "mount": {"type": "string", "minLength": 1, "maxLength": 200},
    "thrust_max_n": _num_or_ref(0, 1e4),
    "offset_m": {"type": "array", "items": _num_or_ref(-2, 2), "minItems": 3, "maxItems": 3},
    "mass_kg": _num_or_ref(0, 100),
    "lag_s": {"type": "number", "minimum": 0, "maximum": 10},
    "radius_m": {"type": "number", "exclusiveMinimum": 0, "maximum": 1},
    "present": _num_or_ref(0, 1),
}, ("name", "mount", "thrust_max_n", "offset_m"))

SCHEMA = _obj({
    "name": {"type": "string", "pattern": "^[A-Za-z0-9_.-]+$", "maxLength": 100},
    "description": {"type": "string", "maxLength": 5000},
    "base_robot": {"type": "string", "minLength": 1, "maxLength": 1000},
    "seed": {"type": "integer", "minimum": 0, "maximum": 2**63 - 1},
    "sampling": _obj({"method": {"enum": ["grid", "lhs"]},
                      "samples": {"type": "integer", "minimum": 1, "maximum": MAX_VARIANTS}}, ("method",)),
    "axes": {"type": "object", "minProperties": 1, "maxProperties": MAX_AXES,
             "propertyNames": {"pattern": "^[A-Za-z_][A-Za-z0-9_]*$", "maxLength": 60},
             "additionalProperties": _axis},
    "fan_mass": {"oneOf": [
        _obj({"kg": {"type": "number", "minimum": -100, "maximum": 100},
              "kg_per_n": {"type": "number", "minimum": 0, "maximum": 10}}, ("kg_per_n",)),
        _obj({"table": {"type": "array", "minItems": 2, "maxItems": 1000,
                        "items": {"type": "array", "minItems": 2, "maxItems": 2,
                                  "items": {"type": "number", "minimum": 0, "maximum": 1e4}}}}, ("table",)),
    ]},
    "fans": {"type": "array", "minItems": 1, "maxItems": 16, "items": _fan},
    "trunk_mass_scale": _num_or_ref(0.01, 100),
    "leg_length_scale": _num_or_ref(0.1, 10),
    "judge": _obj({
        "gaps_m": {"type": "array", "minItems": 2, "maxItems": 2,
                   "items": {"type": "number", "exclusiveMinimum": 0, "maximum": 5}},
        "resolution_m": {"type": "number", "minimum": 0.001, "maximum": 1},
        "optimiser": {"enum": list(METHODS)},
        "seed": {"type": "integer", "minimum": 0, "maximum": 2**63 - 1},
        "tolerance": _obj({"thrust_error": {"type": "number", "minimum": 0, "maximum": 0.9},
                           "mass_error": {"type": "number", "minimum": 0, "maximum": 0.9},
                           "com_error_m": {"type": "number", "minimum": 0, "maximum": 0.1}}),
    }),
    "best": {"type": "integer", "minimum": 0, "maximum": 1000},
}, ("axes", "fans"))


@dataclass(frozen=True)
class JudgeSettings:
    """How a variant is judged (docs/design.md): Paper A's forward step over ditches of ``gaps_m`` [m] (searched on
    a lattice ``resolution_m`` [m] apart), planned by ``optimiser`` with ``seed``, with ``tolerance`` as the
    robust objective (a scenario's ``balance.robust``)."""

    gaps_m: tuple[float, float] = (0.20, 0.70)
    resolution_m: float = 0.01
    optimiser: str = "sqp"
    seed: int = 1
    tolerance: Tolerance = ROBUST_TOLERANCE

    def lattice(self) -> np.ndarray:
        """The gaps a search may plan [m]: lo, lo + resolution, ... up to hi (rounded to 1e-9 m)."""
        lo, hi = self.gaps_m
        n = math.floor((hi - lo) / self.resolution_m + 1e-9) + 1
        return np.array([round(lo + k * self.resolution_m, 9) for k in range(n)])

    def as_dict(self) -> dict[str, Any]:
        t = self.tolerance
        return {"gaps_m": list(self.gaps_m), "resolution_m": self.resolution_m, "optimiser": self.optimiser,
                "seed": self.seed,
                "tolerance": {"thrust_error": t.thrust, "mass_error": t.mass, "com_error_m": t.com_m}}


@dataclass(frozen=True)
class Axis:
    """One axis of the design space: a range [lo, hi] (``count`` values on a grid) or a list of values."""

    name: str
    values: tuple[float, ...] | None = None
    range: tuple[float, float] | None = None
    count: int | None = None

    def grid(self) -> tuple[float, ...]:
        if self.values is not None:
            return self.values
        assert self.range is not None and self.count is not None
        lo, hi = self.range
        return tuple(float(v) for v in np.linspace(lo, hi, self.count)) if self.count > 1 else (float(lo),)

    def at(self, u: float) -> float:
        """The value at a point ``u`` ∈ [0, 1) of a Latin hypercube: in the range, or one of the values."""
        if self.values is not None:
            return self.values[min(int(u * len(self.values)), len(self.values) - 1)]
        assert self.range is not None
        lo, hi = self.range
        return float(lo + u * (hi - lo))


@dataclass(frozen=True)
class Variant:
    """One point of the design space: its index in the sweep, its axis values and the robot design they give."""

    index: int
    values: dict[str, float]
    design: VariantDesign

    @property
    def name(self) -> str:
        return f"v{self.index:04d}"


@dataclass(frozen=True)
class DesignSpec:
    """A design file, read and checked."""

    source: str
    name: str
    description: str
    base_robot: str
    seed: int
    method: str  # grid | lhs
    samples: int | None
    axes: tuple[Axis, ...]
    fans: tuple[dict, ...]  # as written (values or axis references)
    fan_mass: dict
    trunk_mass_scale: float | str
    leg_length_scale: float | str
    judge: JudgeSettings
    best: int
    doc: dict = field(repr=False, default_factory=dict)

    def points(self) -> list[dict[str, float]]:
        """The axis values of every variant, in sweep order."""
        names = [a.name for a in self.axes]
        if self.method == "grid":
            return [dict(zip(names, combo, strict=True)) for combo in itertools.product(*(a.grid() for a in self.axes))]
        from scipy.stats import qmc

        assert self.samples is not None
        u = qmc.LatinHypercube(d=len(self.axes), seed=np.random.default_rng(self.seed)).random(self.samples)
        return [{a.name: a.at(float(row[k])) for k, a in enumerate(self.axes)} for row in u]

    def variants(self) -> list[Variant]:
        """Every variant, its fans resolved (a value out of its bound is an InputError naming the key)."""
        return [Variant(i, values, self.design_at(values, i)) for i, values in enumerate(self.points())]

    def fan_mass_kg(self, thrust_n: float, key: str, where: str) -> float:
        fm = self.fan_mass
        if not fm:
            raise InputError(self.source, key, "no mass for this fan: give its mass_kg or a fan_mass line or table")
        if "table" in fm:
            table = np.array(fm["table"], dtype=float)
            f, m = table[:, 0], table[:, 1]
            if thrust_n < f.min() - 1e-12 or thrust_n > f.max() + 1e-12:
                raise InputError(self.source, "fan_mass.table", f"{thrust_n:g} N {where} is outside the table's "
                                 f"{f.min():g}..{f.max():g} N")
            return float(np.interp(thrust_n, f, m))
        return float(fm.get("kg", 0.0) + fm["kg_per_n"] * thrust_n)

    def value(self, v: float | str, values: dict[str, float]) -> float:
        if isinstance(v, str):
            sign, name = REF.match(v).groups()  # type: ignore[union-attr]
            return -values[name] if sign else values[name]
        return float(v)

    def design_at(self, values: dict[str, float], index: int) -> VariantDesign:
        where = "at variant " + str(index) + " (" + ", ".join(f"{k} = {v:g}" for k, v in values.items()) + ")"
        fans = []
        for k, fd in enumerate(self.fans):
            key = f"fans[{k}]"
            if "present" in fd:
                present = self.value(fd["present"], values)
                if present not in (0.0, 1.0):
                    raise InputError(self.source, f"{key}.present", f"{present:g} {where}: expected 0 or 1")
                if present == 0.0:
                    continue
            thrust = self.value(fd["thrust_max_n"], values)
            if not 0 <= thrust <= 1e4:
                raise InputError(self.source, f"{key}.thrust_max_n", f"{thrust:g} N {where}: expected 0..10000 N")
            offset = tuple(self.value(v, values) for v in fd["offset_m"])
            if any(abs(v) > 2 for v in offset):
                raise InputError(self.source, f"{key}.offset_m", f"{offset} m {where}: expected within ±2 m")
            mass = (self.value(fd["mass_kg"], values) if "mass_kg" in fd
                    else self.fan_mass_kg(thrust, f"{key}.thrust_max_n", where))
            if not mass > 0:
                raise InputError(self.source, f"{key}.mass_kg" if "mass_kg" in fd else "fan_mass",
                                 f"{mass:g} kg {where}: a fan's mass is positive")
            fans.append(FanDesign(fd["name"], fd["mount"], (offset[0], offset[1], offset[2]), thrust, mass,
                                  float(fd.get("lag_s", 0.05)), float(fd.get("radius_m", DUCT_RADIUS_M))))
        if not fans:
            raise InputError(self.source, "fans", f"no fan present {where}: a plan steps with thrust")
        scales = []
        for key, lo, hi in (("trunk_mass_scale", 0.01, 100), ("leg_length_scale", 0.1, 10)):
            s = self.value(getattr(self, key), values)
            if not lo <= s <= hi:
                raise InputError(self.source, key, f"{s:g} {where}: expected {lo:g}..{hi:g}")
            scales.append(s)
        return VariantDesign(tuple(fans), scales[0], scales[1])


def _refs(doc: dict) -> list[tuple[str, str]]:
    """(key path, axis name) of every axis reference in the document."""
    out = []
    for k, fd in enumerate(doc["fans"]):
        for name in ("thrust_max_n", "mass_kg", "present"):
            if isinstance(fd.get(name), str):
                out.append((f"fans[{k}].{name}", fd[name]))
        for i, v in enumerate(fd["offset_m"]):
            if isinstance(v, str):
                out.append((f"fans[{k}].offset_m[{i}]", v))
    for name in ("trunk_mass_scale", "leg_length_scale"):
        if isinstance(doc.get(name), str):
            out.append((name, doc[name]))
    return out


def load_design(path: str | Path) -> DesignSpec:
    """Read and check a design file (see the module); its variants are not built here.

    Raises:
        InputError: the first problem found (exit 2).
    """
    src = str(path)
    doc = read_document(read_text(path, MAX_FILE_BYTES, "a design file"), src, SCHEMA, MAX_VALUES, "a design file")
    sampling = doc.get("sampling", {"method": "grid"})
    method = sampling["method"]
    axes = []
    for name, a in doc["axes"].items():
        if "values" in a:
            if len(set(a["values"])) != len(a["values"]):
                raise InputError(src, f"axes.{name}.values", "a value appears twice")
            axes.append(Axis(name, values=tuple(float(v) for v in a["values"])))
            continue
        lo, hi = (float(v) for v in a["range"])
        if not lo <= hi:
            raise InputError(src, f"axes.{name}.range", f"[{lo:g}, {hi:g}]: expected LOW <= HIGH")
        if method == "grid" and "count" not in a:
            raise InputError(src, f"axes.{name}.count", "missing: a grid takes count values of a range")
        if method == "lhs" and "count" in a:
            raise InputError(src, f"axes.{name}.count", "a Latin hypercube takes any value of a range: no count "
                             "(give values for a discrete axis)")
        axes.append(Axis(name, range=(lo, hi), count=a.get("count")))
    known = {a.name for a in axes}
    used = set()
    for key, ref in _refs(doc):
        name = REF.match(ref).group(2)  # type: ignore[union-attr]
        if name not in known:
            raise InputError(src, key, f"{ref}: no axis {name!r} (axes: {', '.join(sorted(known))})")
        used.add(name)
    unused = sorted(known - used)
    if unused:
        raise InputError(src, f"axes.{unused[0]}", "used by no fan or scale")
    names = [f["name"] for f in doc["fans"]]
    if len(set(names)) != len(names):
        raise InputError(src, "fans", "two fans share a name")
    if method == "lhs":
        if "samples" not in sampling:
            raise InputError(src, "sampling.samples", "missing: how many points of the Latin hypercube")
        count = sampling["samples"]
    else:
        if "samples" in sampling:
            raise InputError(src, "sampling.samples", "a grid takes every combination: no samples")
        count = math.prod(len(a.grid()) for a in axes)
    if count > MAX_VARIANTS:
        raise InputError(src, "axes", f"{count:,} variants: at most {MAX_VARIANTS:,}")
    if "table" in doc.get("fan_mass", {}):
        thrusts = [row[0] for row in doc["fan_mass"]["table"]]
        if any(b <= a for a, b in itertools.pairwise(thrusts)):
            raise InputError(src, "fan_mass.table", "the thrusts must increase from row to row")
    j = doc.get("judge", {})
    default = JudgeSettings()
    gaps = tuple(float(v) for v in j.get("gaps_m", default.gaps_m))
    if not gaps[0] < gaps[1]:
        raise InputError(src, "judge.gaps_m", f"[{gaps[0]:g}, {gaps[1]:g}]: expected LOW < HIGH")
    resolution = float(j.get("resolution_m", default.resolution_m))
    if (gaps[1] - gaps[0]) / resolution > 1000:
        raise InputError(src, "judge.resolution_m",
                         f"{resolution:g} m: more than 1000 gaps in {gaps[0]:g}..{gaps[1]:g} m")
    t = j.get("tolerance", {})
    tol = Tolerance(thrust=float(t.get("thrust_error", default.tolerance.thrust)),
                    mass=float(t.get("mass_error", default.tolerance.mass)),
                    com_m=float(t.get("com_error_m", default.tolerance.com_m)))
    if tol == Tolerance():
        raise InputError(src, "judge.tolerance", "all zero: the judge needs a tolerance to hold (the minimal policy is "
                         "judged beside it)")
    judge = JudgeSettings((gaps[0], gaps[1]), resolution, j.get("optimiser", default.optimiser),
                          int(j.get("seed", default.seed)), tol)
    return DesignSpec(source=src, name=doc.get("name", Path(path).stem), description=doc.get("description", ""),
                      base_robot=doc.get("base_robot", "jethr1"), seed=int(doc.get("seed", 1)), method=method,
                      samples=sampling.get("samples"), axes=tuple(axes), fans=tuple(doc["fans"]),
                      fan_mass=doc.get("fan_mass", {}), trunk_mass_scale=doc.get("trunk_mass_scale", 1.0),
                      leg_length_scale=doc.get("leg_length_scale", 1.0), judge=judge, best=int(doc.get("best", 5)),
                      doc=doc)
