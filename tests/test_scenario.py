"""The scenario loader on valid and invalid files, and the CLI's exit 2 with nothing written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from jethr1_plan.cli import run
from jethr1_plan.errors import InputError
from jethr1_plan.scenario import load_scenario

from .conftest import ROOT

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
    "wrong type": (lambda d: d["balance"].update(thrust_max_n="lots"), "balance.thrust_max_n", "not of type"),
    "NaN": (lambda d: d["balance"].update(thrust_max_n=float("nan")), "balance.thrust_max_n", "finite"),
    "negative thrust": (lambda d: d["balance"].update(thrust_max_n=-1), "balance.thrust_max_n", "minimum"),
    "unknown method": (lambda d: d["optimiser"].update(method="pso"), "optimiser.method", "pso"),
    "negative sqp smoothness": (lambda d: d["optimiser"].update(sqp={"smoothness_n_per_m2": -1}),
                                "optimiser.sqp.smoothness_n_per_m2", "minimum"),
    "population of one": (lambda d: d["optimiser"].update(initial={"population": 1}),
                          "optimiser.initial.population", "minimum"),
    "short landing vector": (lambda d: d["steps"][0].update(landing_m=[0.6, 0.0]), "steps[0].landing_m", "short"),
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
