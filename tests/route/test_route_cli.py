"""``jethr1 route`` and ``jethr1 terrain`` as a user runs them: the route folder is a plan folder that
``verify`` accepts, ``route.yaml`` re-plans to the same bytes, the maps are computed once, no route is
exit 3 naming the frontier, a bad terrain is one line and exit 2 with nothing written."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import yaml

from jethr1_plan.cli import run
from jethr1_plan.files.mcap import read_mcap
from jethr1_plan.files.route import ROUTE_TOPICS
from jethr1_plan.route.terrain import load_terrain_text, random_terrain
from jethr1_plan.scenario import load_scenario
from jethr1_plan.swing_path import sole_on_carton
from tests.conftest import SMALL_TERRAIN


def test_the_route_folder_is_a_plan_that_verify_accepts(small_route):
    names = {p.name for p in small_route.iterdir()}
    assert {"route.yaml", "route.mcap", "route.png", "trajectory.csv", "trajectory.mcap", "summary.json"} <= names
    summary = json.loads((small_route / "summary.json").read_text())
    assert summary["feasible"] and summary["scenario_file"] == str((small_route / "route.yaml").resolve())
    # the route keeps its optimised steps, so that `simulate` executes it step by step without optimising again
    from jethr1_plan.sim.rehearsal import load_plan
    from jethr1_plan.studies.step_by_step import nominal_plan

    notes: list[str] = []
    _, kept = nominal_plan(small_route, summary, load_plan(small_route), notes.append)
    assert notes == [] and len(kept) == len(summary["steps"])
    r = summary["route"]
    assert len(r["steps"]) == len(summary["steps"]) >= 2
    for step in r["steps"]:
        assert step["plan"]["peak_thrust_n"] <= 23.0 and step["map"]["peak_thrust_n"] <= 23.0
        assert step["plan"]["least_zmp_margin_m"] >= 0.0
    sc = load_scenario(small_route / "route.yaml")
    feet = dict(sc.start)
    for st in sc.steps:  # both soles end inside the goal region, every landing on a carton top
        assert any(sole_on_carton(st.landing_m, 0.0, 0.16, 0.09, c) for c in sc.cartons)
        feet[st.swing] = st.landing_m
    for p in feet.values():
        assert 0.495 + 0.08 - 1e-9 <= p[0] <= 0.705 - 0.08 + 1e-9 and abs(p[1]) <= 0.2 - 0.045 + 1e-9
    assert run(["verify", str(small_route)]) == 0


def test_the_routes_swings_keep_the_multibody_zmp_inside_the_sole_margin(small_route):
    """The route plans strictly: every swing row's multibody ZMP (the rows' own motion; pinocchio's RNEA on
    the written files, independent of the planner) stays the terrain's 5 mm sole margin inside the support
    sole, paced where the minimum-jerk law would not keep it there (docs/route.md)."""
    import csv

    from tests.oracles.plan_audit import audit_plan

    audit = audit_plan(small_route)
    with open(small_route / "trajectory.csv", newline="") as f:
        phase = np.array([r["phase"] for r in csv.DictReader(f)])
    swing = np.flatnonzero(phase == "swing")
    swing = swing[(swing > 0) & (swing < len(phase) - 1)]
    assert len(swing) and np.all(audit.margin_dynamic[swing] >= 0.005 - 1e-9)


def test_route_yaml_re_plans_to_the_same_bytes(small_route, tmp_path):
    assert run(["plan", str(small_route / "route.yaml"), "-o", str(tmp_path), "--no-progress"]) == 0
    for name in ("trajectory.csv", "trajectory.mcap"):
        assert (tmp_path / "route" / name).read_bytes() == (small_route / name).read_bytes(), name


def test_the_maps_are_computed_once_and_the_route_is_the_same(small_route, route_cache, tmp_path, capfd):
    (tmp_path / "small.yaml").write_text(SMALL_TERRAIN)
    capfd.readouterr()
    assert run(["route", str(tmp_path / "small.yaml"), "-o", str(tmp_path), "--cache", str(route_cache),
                "--no-progress", "-j", "2"]) == 0
    err = capfd.readouterr().err
    assert err.count("reused") == 2 and "computing" not in err
    assert len(list((route_cache / "balance_space").glob("*.npz"))) == 2
    for name in ("route.yaml", "trajectory.csv", "trajectory.mcap", "route.mcap"):  # the same for any -j
        assert (tmp_path / "small" / name).read_bytes() == (small_route / name).read_bytes(), name


def test_the_route_survives_the_twin_feed_forward_at_nominal(small_route, tmp_path, capfd):
    """``simulate --whole`` works on the route's folder as on any plan: the twin (MuJoCo, not the planner's
    model) walks the chosen steps without a fall and ends with both soles on carton tops, each landing within
    2 cm (step by step, the robot stands between its steps: this toy terrain's 1 s transfers are too short
    for that)."""
    folder = tmp_path / "small"
    shutil.copytree(small_route, folder)
    capfd.readouterr()
    assert run(["simulate", str(folder), "--whole", "--json", "--no-progress"]) == 0
    (r,) = json.loads(capfd.readouterr().out)["runs"]
    assert r["survived"] and r["fell"] is None and all(r["soles_on_cartons_at_end"].values())
    steps = len(load_scenario(folder / "route.yaml").steps)
    assert len(r["landing_errors_m"]) == steps and max(e["xy_m"] for e in r["landing_errors_m"]) < 0.02


def test_route_mcap_carries_the_terrain_footholds_route_and_slices(small_route):
    msgs = read_mcap((small_route / "route.mcap").read_bytes())
    assert {(m[0], m[1]) for m in msgs} == {(name, t.type) for name, t in ROUTE_TOPICS.items()}
    steps = len(load_scenario(small_route / "route.yaml").steps)
    slices = [m for m in msgs if m[0] == "/route/balance_space"]
    assert len(slices) == steps and all(m[2].width > 0 for m in slices)
    (footsteps,) = [m[2] for m in msgs if m[0] == "/route/footsteps"]
    assert sum(mk.ns == "landings" for mk in footsteps.markers) == steps


def test_no_route_is_exit_3_naming_the_frontier(route_cache, tmp_path, capfd):
    doc = yaml.safe_load(SMALL_TERRAIN)
    doc["terrain"]["cartons"][-1]["top_centre_m"] = [1.5, 0.0, 0.0]  # the goal carton 1.3 m beyond the row
    doc["goal"] = {"carton": "goal"}
    (tmp_path / "far.yaml").write_text(yaml.safe_dump(doc))
    capfd.readouterr()
    code = run(["route", str(tmp_path / "far.yaml"), "-o", str(tmp_path / "out"), "--cache", str(route_cache),
                "--no-progress", "--json"])
    out, err = capfd.readouterr()
    assert code == 3
    line = err.strip().splitlines()[-1]
    assert "frontier reached cartons start_left, start_right, a, b" in line and "goal" in line
    assert "out of reach" in line
    doc = json.loads(out)
    assert doc["feasible"] is False and doc["nearest"] == "goal" and doc["why"] == "reach"
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("edit, key", [
    (lambda d: d.update(steps=[]), "steps"),
    (lambda d: d.update(goal={"carton": "nowhere"}), "goal.carton"),
    (lambda d: d.update(goal={"carton": 9}), "goal.carton"),
    (lambda d: d["start"].update(left=[0.0, 0.5, 0.0]), "start.left"),
    (lambda d: d["terrain"]["cartons"][2].update(name="b"), "terrain.cartons[3].name"),
    (lambda d: d["route"].update(samples=1), "route.samples"),
    (lambda d: d["balance"].update(thrust_max_n=40.0), "balance.thrust_max_n"),
])
def test_a_bad_terrain_is_one_line_and_exit_2_with_nothing_written(tmp_path, capfd, edit, key):
    doc = yaml.safe_load(SMALL_TERRAIN)
    edit(doc)
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(doc))
    capfd.readouterr()
    assert run(["route", str(tmp_path / "bad.yaml"), "-o", str(tmp_path / "out"), "--cache",
                str(tmp_path / "cache")]) == 2
    err = capfd.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"bad.yaml: {key}" in err
    assert not (tmp_path / "out").exists() and not (tmp_path / "cache").exists()


def test_terrain_random_is_the_same_file_for_the_same_seed(tmp_path, capfd):
    for name in ("a.yaml", "b.yaml"):
        assert run(["terrain", "random", "--seed", "11", "--cartons", "5", "--gaps", "0.1:0.2", "-o",
                    str(tmp_path / name)]) == 0
    assert (tmp_path / "a.yaml").read_bytes() == (tmp_path / "b.yaml").read_bytes()
    capfd.readouterr()
    assert run(["terrain", "random", "--seed", "11", "--cartons", "5", "--gaps", "0.1:0.2"]) == 0
    assert capfd.readouterr().out == (tmp_path / "a.yaml").read_text()
    t = load_terrain_text((tmp_path / "a.yaml").read_text(), "a.yaml")
    assert len(t.cartons) == 5 + 3  # the two start cartons, five, the goal
    other = load_terrain_text(random_terrain(12, 5, (0.1, 0.2)), "b")
    assert [c.top_centre_m for c in other.cartons] != [c.top_centre_m for c in t.cartons]
    assert run(["terrain", "random", "--seed", "1", "--gaps", "0.3:0.1"]) == 2


def test_random_ditches_are_as_wide_as_asked():
    """Between consecutive rows the ditch (rear edge minus front edge, cartons moved forward by up to 3 cm)
    lies within the asked widths; heights change by at most the asked amount a row."""
    for seed in range(20):
        t = load_terrain_text(random_terrain(seed, 8, (0.1, 0.2), heights_m=0.03), "t")
        rows: dict[str, list] = {}
        for name, c in zip(t.names[2:], t.cartons[2:], strict=True):
            rows.setdefault(name.rstrip("ab"), []).append(c)
        fronts = [0.105]
        tops = [0.0]
        for cs in rows.values():
            rear = min(c.top_centre_m[0] for c in cs) - 0.105
            assert 0.1 - 0.03 - 1e-9 <= rear - fronts[-1] <= 0.2 + 0.06 + 1e-9
            fronts.append(max(c.top_centre_m[0] for c in cs) + 0.105)
            z = cs[0].top_centre_m[2]
            assert abs(z - tops[-1]) <= 0.03 + 0.0025 + 1e-9
            tops.append(z)
            assert all(np.isclose(c.size_m[2], c.top_centre_m[2] + 0.14) for c in cs)  # on the floor


def test_a_route_planned_fastest_verifies_where_its_fixed_timing_is_too_fast(tmp_path, route_cache, small_route,
                                                                               capsys):
    """``route --timing fastest``: the same footholds and samples, each step timed fastest (route.yaml says so),
    and the plan verifies with the motion's own checks. The small terrain's fixed timing (2 s swings, 1 s
    transfers) is faster than those checks allow: its rows, held to the same limits, fail them, and the
    fastest plan is the longer one."""
    import json
    import shutil

    from jethr1_plan.cli import run
    from tests.conftest import SMALL_TERRAIN, rewritten

    (tmp_path / "small.yaml").write_text(SMALL_TERRAIN)
    assert run(["route", str(tmp_path / "small.yaml"), "-o", str(tmp_path), "--cache", str(route_cache),
                "--timing", "fastest", "--no-progress"]) == 0
    fast, fixed = (json.loads((d / "summary.json").read_text()) for d in (tmp_path / "small", small_route))
    assert fast["timing"]["mode"] == "fastest" and "timing" not in fixed
    assert fast["sample_count"] == fixed["sample_count"]
    assert "mode: fastest" in (tmp_path / "small" / "route.yaml").read_text()
    capsys.readouterr()
    assert run(["verify", str(tmp_path / "small")]) == 0
    held = tmp_path / "fixed_held"
    shutil.copytree(small_route, held)
    (held / "trajectory.mcap").unlink()
    fixed["timing"] = {k: fast["timing"][k] for k in ("mode", "dynamic_share", "safety_factor", "spin_down_n")}
    (held / "summary.json").write_text(json.dumps(fixed))
    rewritten(held)  # one thing again (its digests): its rows are what verify checks
    capsys.readouterr()
    assert run(["verify", str(held / "trajectory.csv"), "--json"]) != 0
    found = {f["check"] for f in json.loads(capsys.readouterr().out)["failures"]}
    assert found & {"dynamic limit broken", "joint too fast", "fan cannot follow"}
    assert fast["trajectory"]["rows"] > fixed["trajectory"]["rows"]
