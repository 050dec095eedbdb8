"""`jethr1 compare`: the paper's comparison on a small scenario, re-checked from its own numbers."""

from __future__ import annotations

import json

import numpy as np
import yaml

from jethr1_plan.cli import run
from jethr1_plan.io.record import RECORD
from tests.conftest import ROOT


def test_compare_reports_and_reference(tmp_path, capsys):
    doc = yaml.safe_load((ROOT / "configs" / "side_step.yaml").read_text())
    doc["optimiser"] = {"initial": {"population": 60, "generations": 12},
                        "intermediate": {"population": 40, "generations": 5}}
    doc["steps"][0]["path"]["samples"] = 8
    doc["timing"] = {"swing_s": 4.0, "transfer_s": 2.0, "rate_hz": 20.0}  # (GAEx's path bends between samples:
    # at 7.5 s and 50 Hz a row needs more friction than μ / 2)
    doc["balance"]["policy"] = "minimal"  # Paper A's comparison
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(doc))
    out = tmp_path / "cmp"
    assert run(["compare", str(path), "-o", str(out), "--reference", "--json", "--no-progress"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert set(d["methods"]) == {"gas", "ga", "gaex", "sqp"}
    ref = np.array([np.nan if v is None else v for v in d["reference"]["thrust_n"][0]])
    for m in d["methods"].values():
        p = np.array(m["p_body_m"][0])
        t = np.array(m["thrust_n"][0], dtype=float)
        # the reported figures follow from the reported samples
        assert abs(m["smoothness_m2"] - np.sum(np.diff(p, axis=0) ** 2)) < 1e-15
        assert m["peak_thrust_n"] == t.max() and abs(m["mean_thrust_n"] - t.mean()) < 1e-12
        assert m["max_step_m"] == np.linalg.norm(np.diff(p, axis=0), axis=1).max()
        assert m["evaluations"] > 0 and m["wall_s"] > 0 and m["feasible"]
        # the rows' own motion judged too: a multibody ZMP margin [m] within the sole's half-width
        assert m["dynamic_zmp_margin_m"] is not None and m["dynamic_zmp_margin_m"] < 0.045
        # the dense exhaustive search is (nearly) the global minimum: no method beats it by more than
        # its grid error, and the reported gap is the largest difference
        assert np.all(t >= ref - 0.2)
        assert abs(m["gap_max_n"] - np.max(t - ref)) < 1e-12
    assert json.loads((out / "compare.json").read_text()) == d
    for png in ("compare_trajectories.png", "compare_time.png"):
        assert (out / png).read_bytes()[:4] == b"\x89PNG"


def test_unknown_method_is_exit_2(tmp_path):
    assert run(["compare", str(ROOT / "configs" / "side_step.yaml"), "--methods", "gas,pso",
                "-o", str(tmp_path / "x")]) == 2
    assert not (tmp_path / "x").exists()


def test_yaw_modes_report_the_cost_of_smoothing(tmp_path, capsys):
    doc = yaml.safe_load((ROOT / "configs" / "side_step.yaml").read_text())
    doc["optimiser"] = {"initial": {"population": 60, "generations": 12},
                        "intermediate": {"population": 40, "generations": 5}}
    doc["steps"][0]["path"]["samples"] = 8
    doc["timing"] = {"swing_s": 4.0, "transfer_s": 2.0, "rate_hz": 20.0}
    doc["balance"]["policy"] = "minimal"
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(doc))
    assert run(["compare", str(path), "--methods", "gas", "--yaw-modes", "eq4,mpc", "-o", str(tmp_path / "c"),
                "--json", "--no-progress"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert set(d["methods"]) == {"gas", "gas+mpc"}
    eq4, mpc = d["methods"]["gas"], d["methods"]["gas+mpc"]
    assert eq4["yaw_mode"] == "eq4" and mpc["yaw_mode"] == "mpc"
    assert mpc["thrust_cost_vs"]["max_n"] == mpc["peak_thrust_n"] - eq4["peak_thrust_n"]
    assert eq4["peak_yaw_rate_rad_s"] is not None and mpc["peak_yaw_rate_rad_s"] is not None


def test_the_reference_follows_the_robust_policy(tmp_path, capsys):
    """Under the robust policy the exhaustive reference minimises the same robust thrust: no method
    beats it by more than its grid error, and it needs more thrust than Paper A's minimal reference."""
    doc = yaml.safe_load((ROOT / "configs" / "side_step.yaml").read_text())
    doc["steps"][0]["path"]["samples"] = 6
    doc["optimiser"]["sqp"] = {"smoothness_n_per_m2": 10.0}  # the least thrust's path (smoothness a tie-break)
    path = tmp_path / "robust.yaml"
    path.write_text(yaml.safe_dump(doc))
    refs = {}
    for policy in ("robust", "minimal"):
        doc["balance"]["policy"] = policy
        path.write_text(yaml.safe_dump(doc))
        assert run(["compare", str(path), "--methods", "sqp", "-o", str(tmp_path / policy), "--reference", "--json",
                    "--no-progress"]) == 0
        d = json.loads(capsys.readouterr().out)
        refs[policy] = np.array([np.nan if v is None else v for v in d["reference"]["thrust_n"][0]])
        t = np.array(d["methods"]["sqp"]["thrust_n"][0], dtype=float)
        assert np.all(t >= refs[policy] - 0.2) and np.all(t <= refs[policy] + 0.5)
    loaded = refs["minimal"] > 0.5
    assert loaded.sum() >= 2 and np.all(refs["robust"][loaded] > refs["minimal"][loaded] + 0.5)


def test_pareto_fronts_and_verdict(tmp_path, capsys, monkeypatch):
    """`compare --pareto` plans each weight, marks the defaults and the front (no point of the method is
    as good in all three measures and better in one), and its verdict is the dominance of the default
    sqp point over GAS's with 10x fewer evaluations, recomputed here from the points."""
    from jethr1_plan.studies import compare as cmp

    monkeypatch.setitem(cmp.PARETO_WEIGHTS, "gas", (50.0,))
    monkeypatch.setitem(cmp.PARETO_WEIGHTS, "sqp", (10.0, 1e6))
    doc = yaml.safe_load((ROOT / "configs" / "side_step.yaml").read_text())
    doc["steps"][0]["path"]["samples"] = 12
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(doc))
    assert run(["compare", str(path), "--pareto", "-o", str(tmp_path / "p"), "--json", "--no-progress"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert sorted(p.name for p in (tmp_path / "p").iterdir() if p.name != RECORD) == ["pareto.json", "pareto.png"]
    assert (tmp_path / "p" / "pareto.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    sqp, gas = d["fronts"]["sqp"], d["fronts"]["gas"]
    assert [p["weight"] for p in sqp] == [10.0, 7e4, 1e6] and [p["default"] for p in sqp] == [False, True, False]
    keys = ("peak_thrust_n", "mean_thrust_n", "smoothness_m2")
    for p in sqp:
        beaten = any(q is not p and all(q[k] <= p[k] for k in keys) and any(q[k] < p[k] for k in keys) for q in sqp)
        assert p["on_front"] == (p["feasible"] and not beaten)
    mine, ref = sqp[1], gas[0]
    verdict = d["verdict"]["sqp"]
    expected = all(mine[k] <= ref[k] for k in keys) and ref["evaluations"] >= 10 * mine["evaluations"]
    assert verdict["dominates_gas"] == expected
    assert verdict["evaluation_factor"] == ref["evaluations"] / mine["evaluations"]
    # the price never raises the path's maximum above the least thrust's path (ε = 10)
    assert all(p["peak_thrust_n"] <= sqp[0]["peak_thrust_n"] + 1e-3 for p in sqp[1:])
