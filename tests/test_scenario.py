"""The scenario loader on valid and invalid files, and the CLI's exit 2 with nothing written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from jethr1_plan.cli import run
from jethr1_plan.errors import InputError
from jethr1_plan.scenario import load_scenario
from tests.conftest import ROOT

CONFIGS = sorted((ROOT / "configs").glob("*.yaml"))
BASE = yaml.safe_load((ROOT / "configs" / "forward_ditch_450.yaml").read_text())


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_shipped_configs_load(path):
    sc = load_scenario(path)
    assert sc.steps and all(len(s.path_m) >= 2 for s in sc.steps)


def test_defaults_are_the_papers():
    sc = load_scenario(ROOT / "configs" / "forward_ditch_450.yaml")
    opt = sc.optimiser
    assert (opt.initial.population, opt.initial.generations, opt.initial.half_range_m) == (200, 50, 0.150)
    assert (opt.intermediate.population, opt.intermediate.generations, opt.intermediate.half_range_m) == (150, 8, 0.025)
    assert (opt.initial.crossover, opt.initial.mutation) == (0.5, 0.01)
    k = opt.constants
    assert (k.c1, k.c2, k.c4_1, k.c4_2, k.omega, k.f3_unit_m) == (11000, 9000, 5000, 10, 50, 0.001)
    assert sc.balance.thrust_max_n == 23.0 and sc.balance.rho_rad == pytest.approx(np.radians(5))
    assert sc.yaw_mode == "eq4"


def _variant(tmp_path: Path, mutate) -> Path:
    doc = yaml.safe_load(yaml.safe_dump(BASE))
    mutate(doc)
    p = tmp_path / "variant.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


BAD = {
    "unknown top-level key": (lambda d: d.update(colour="red"), "colour", "unknown key"),
    "unknown nested key": (lambda d: d["optimiser"].update(methd="gas"), "optimiser.methd", "unknown key"),
    "wrong type": (lambda d: d["balance"].update(thrust_max_n="lots"), "balance.thrust_max_n", "expected number"),
    "NaN": (lambda d: d["balance"].update(thrust_max_n=float("nan")), "balance.thrust_max_n", "finite"),
    "negative thrust": (lambda d: d["balance"].update(thrust_max_n=-1), "balance.thrust_max_n", "below"),
    "thrust beyond the fans": (lambda d: d["balance"].update(thrust_max_n=1e300), "balance.thrust_max_n", "above"),
    "thrust a little beyond the fans": (lambda d: d["balance"].update(thrust_max_n=30.0), "balance.thrust_max_n",
                                        "more than the robot's fans give (23 N)"),
    "absurd sample count": (lambda d: d["steps"][0]["path"].update(samples=100_000_000), "steps[0].path.samples",
                            "above the largest allowed, 1000"),
    "absurd rate": (lambda d: d["timing"].update(rate_hz=1e9), "timing.rate_hz", "above the largest allowed"),
    "too many rows": (lambda d: d["timing"].update(rate_hz=1000, swing_s=300), "timing", "rows; at most 200,000"),
    "GAEx cube too fine": (lambda d: d["optimiser"].update(gaex={"half_m": 0.05, "step_m": 0.0005}),
                           "optimiser.gaex", "more than 50 steps"),
    "unknown method": (lambda d: d["optimiser"].update(method="pso"), "optimiser.method", "pso"),
    "negative sqp smoothness": (lambda d: d["optimiser"].update(sqp={"smoothness_n_per_m2": -1}),
                                "optimiser.sqp.smoothness_n_per_m2", "below"),
    "population of one": (lambda d: d["optimiser"].update(initial={"population": 1}),
                          "optimiser.initial.population", "below the smallest allowed, 2"),
    "short landing vector": (lambda d: d["steps"][0].update(landing_m=[0.6, 0.0]), "steps[0].landing_m",
                             "2 items: expected at least 3"),
    "landing off the carton": (lambda d: d["steps"][0].update(landing_m=[0.45, -0.1125, 0.0]),
                               "steps[0].landing_m", "fully on a carton"),
    "landing in the air": (lambda d: d["steps"][0].update(landing_m=[0.615, -0.1125, 0.02]),
                           "steps[0].landing_m", "fully on a carton"),
    "path that hits a carton edge": (lambda d: d["steps"][0].update(path={"kind": "points", "points_m": [
        [0.0, 0.1125, 0.0], [0.3, 0.0, 0.02], [0.55, -0.1125, -0.01], [0.615, -0.1125, 0.0]]}),
        "steps[0].path", "cannot clear"),
    "points not starting at the foot": (lambda d: d["steps"][0].update(path={"kind": "points", "points_m": [
        [0.1, 0.1125, 0.0], [0.615, -0.1125, 0.0]]}), "steps[0].path.points_m[0]", "current position"),
    "margin eats the sole": (lambda d: d["balance"].update(sole_margin_m=0.05), "balance.sole_margin_m",
                             "no support polygon"),
    "missing steps": (lambda d: d.pop("steps"), "steps", "missing"),
    "a rate of 0": (lambda d: d["timing"].update(rate_hz=0), "timing.rate_hz", "0 is below the smallest allowed, 10"),
    "a rate of 1e-9": (lambda d: d["timing"].update(rate_hz=1e-9), "timing.rate_hz", "below the smallest allowed, 10"),
    "a swing of 4 rows": (lambda d: d["timing"].update(rate_hz=10, swing_s=0.4), "timing.swing_s",
                          "0.4 s at rate_hz 10 is 4 rows: every phase needs at least 5 rows"),
    "a name that climbs out": (lambda d: d.update(name="../../escape"), "name", "must be a plain name"),
    "an absolute name": (lambda d: d.update(name="/tmp/x"), "name", "must be a plain name"),
    "an empty robot": (lambda d: d.update(robot=""), "robot", "empty"),
    "a GA of hours": (lambda d: d.update(optimiser={"method": "gas", "initial": {"population": 10000,
                                                                                 "generations": 10000}}),
                      "optimiser", "would take at least"),
    "a landing 1.5 m ahead": (lambda d: (d["terrain"]["cartons"].append({"top_centre_m": [1.5, -0.1125, 0.0]}),
                                         d["steps"][0].update(landing_m=[1.5, -0.1125, 0.0])),
                              "steps[0].landing_m", "out of reach: the swing sole at [1.5, -0.1125, 0.0] m is 1.500 m "
                              "from the support sole; jethr1's legs span at most 1.120 m"),
    "a path beyond the legs": (lambda d: d["steps"][0].update(path={"kind": "points", "points_m": [
        [0.0, 0.1125, 0.0], [0.3, 0.0, 1.2], [0.615, -0.1125, 0.0]]}), "steps[0].path", "out of reach"),
    "two cartons in one place": (lambda d: d["terrain"]["cartons"].append({"top_centre_m": [0.6, -0.1, 0.0]}),
                                 "terrain.cartons[3]", "overlaps carton 2 (97.5 mm deep)"),
    "a carton inside another": (lambda d: d["terrain"]["cartons"].append({"top_centre_m": [0.635, -0.1125, -0.05],
                                                                          "size_m": [0.05, 0.05, 0.05]}),
                                "terrain.cartons[3]", "overlaps carton 2"),
    "swing foot name": (lambda d: d["steps"][0].update(swing="middle"), "steps[0].swing", "middle"),
}


@pytest.mark.parametrize("case", list(BAD), ids=list(BAD))
def test_invalid_scenarios_name_the_key(tmp_path, case):
    mutate, key, words = BAD[case]
    path = _variant(tmp_path, mutate)
    with pytest.raises(InputError) as info:
        load_scenario(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: {key}:"), msg
    assert words in msg
    assert "\n" not in msg


def test_cli_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, capsys):
    path = _variant(tmp_path, lambda d: d["balance"].update(thrust_max_n=float("inf")))
    out = tmp_path / "out"
    assert run(["plan", str(path), "-o", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "balance.thrust_max_n" in err[0] and str(path) in err[0]
    assert not out.exists()


def test_unreadable_and_non_yaml_files(tmp_path, capsys):
    assert run(["plan", str(tmp_path / "nope.yaml"), "-o", str(tmp_path / "o")]) == 2
    bad = tmp_path / "bad.yaml"
    bad.write_text("steps: [\n  - swing: left\n  landing")
    assert run(["plan", str(bad), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "nope.yaml" in err and "bad.yaml" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def _timed_exit_2(args, capsys):
    """Exit 2, one line, no traceback, in under 5 s and under 200 MB more memory."""
    import resource
    import time

    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    code = run(args)
    elapsed = time.perf_counter() - t0
    grown_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "Traceback" not in err[0], err
    assert elapsed < 5 and grown_kb < 200_000 and len(err[0]) < 400
    return err[0]


def test_bytes_that_are_not_utf8(tmp_path, capsys):
    path = tmp_path / "latin1.yaml"
    path.write_bytes((ROOT / "configs" / "side_step.yaml").read_bytes().replace(b"# Paper A", b"# Papier \xe9t\xe9"))
    line = _timed_exit_2(["plan", str(path), "-o", str(tmp_path / "o"), "--no-progress"], capsys)
    assert "not UTF-8" in line and str(path) in line and not (tmp_path / "o").exists()


def test_a_billion_laughs_is_refused_quickly(tmp_path, capsys):
    """1 KB of nested aliases expands to 10^9 values: refused before anything walks it, and the
    message does not print it."""
    lines = ["a0: &a0 [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]"]
    for k in range(1, 10):
        lines.append(f"a{k}: &a{k} [" + ", ".join([f"*a{k - 1}"] * 10) + "]")
    lines.append("steps: *a9")
    path = tmp_path / "laughs.yaml"
    path.write_text("\n".join(lines) + "\n")
    assert path.stat().st_size < 1500
    line = _timed_exit_2(["plan", str(path), "-o", str(tmp_path / "o"), "--no-progress"], capsys)
    assert "expands to more than 100,000 values" in line


def test_a_recursive_alias_is_refused(tmp_path, capsys):
    path = tmp_path / "loop.yaml"
    path.write_text("steps: &s [*s]\n")
    line = _timed_exit_2(["plan", str(path), "-o", str(tmp_path / "o"), "--no-progress"], capsys)
    assert str(path) in line


def test_a_long_value_is_not_printed(tmp_path, capsys):
    path = _variant(tmp_path, lambda d: d["steps"][0].update(landing_m="x" * 100_000))
    line = _timed_exit_2(["plan", str(path), "-o", str(tmp_path / "o"), "--no-progress"], capsys)
    assert "steps[0].landing_m" in line and "xxxx..." in line


@pytest.mark.parametrize("mutate", [lambda d: d["steps"][0]["path"].update(samples=100_000_000),
                                    lambda d: d["timing"].update(rate_hz=1e9)], ids=["samples", "rate"])
def test_absurd_numbers_are_quick(tmp_path, capsys, mutate):
    _timed_exit_2(["plan", str(_variant(tmp_path, mutate)), "-o", str(tmp_path / "o"), "--no-progress"], capsys)


def test_cartons_that_touch_are_fine(tmp_path):
    """A row of cartons side by side and a stack share faces, not space."""
    path = _variant(tmp_path, lambda d: d["terrain"]["cartons"].extend([
        {"top_centre_m": [0.635, 0.0025, 0.0]},  # beside carton B (0.11 m wide): faces touch
        {"top_centre_m": [0.635, -0.1125, -0.14]}]))  # under carton B (0.14 m high): a stack
    assert len(load_scenario(path).cartons) == 5


def test_schema_and_dataclasses_state_the_same_keys():
    """Every key the schema accepts in a section is a field of the dataclass that holds its default
    (the defaults are stated once, in the dataclasses), and every such field has a key."""
    from dataclasses import fields

    from jethr1_plan.optimisers import GAPhase, OptimiserConfig
    from jethr1_plan.optimisers.problem import FitnessConstants
    from jethr1_plan.physics.balance import Tolerance
    from jethr1_plan.scenario import BalanceConfig, BodyYaw, Timing
    from jethr1_plan.scenario_schema import SCHEMA, TOLERANCE_KEYS

    def keys(*path):
        node = SCHEMA
        for p in path:
            node = node["properties"][p]
        return set(node["properties"])

    def names(cls, skip=()):
        return {f.name for f in fields(cls)} - set(skip)

    assert keys("timing") == names(Timing)
    assert keys("body_yaw") == {"mode", "fixed_rad", "horizon_s", "alpha", "beta"} == names(BodyYaw)
    assert keys("balance") | {"min_share"} == names(BalanceConfig)  # min_share: balance.robust.min_share
    assert {TOLERANCE_KEYS[k] for k in keys("balance", "robust") - {"min_share"}} == names(Tolerance)
    assert keys("optimiser", "initial") == keys("optimiser", "intermediate") == names(GAPhase)
    assert keys("optimiser", "fitness") - {"f3_unit"} | {"f3_unit_m"} == names(FitnessConstants, ["weight_n"])
    top = keys("optimiser") - {"initial", "intermediate", "fitness", "gaex", "sqp", "nominal_height_m"}
    assert (top | {f"gaex_{k}" for k in keys("optimiser", "gaex")} | {f"sqp_{k}" for k in keys("optimiser", "sqp")}
            | {"initial", "intermediate", "constants"}) == names(OptimiserConfig, ["tournament_size", "elites"])
