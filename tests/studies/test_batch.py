"""`jethr1 batch`: one folder per scenario, a summary, and the exit status CI gates on."""

from __future__ import annotations

import json

import yaml

from jethr1_plan.cli import run
from tests.conftest import ROOT


def _small(tmp_path, name, **changes):
    doc = yaml.safe_load((ROOT / "configs" / "side_step.yaml").read_text())
    doc["optimiser"] = {"initial": {"population": 40, "generations": 10},
                        "intermediate": {"population": 30, "generations": 4}}
    doc["steps"][0]["path"]["samples"] = 15
    doc["timing"] = {"swing_s": 2.0, "transfer_s": 1.0, "rate_hz": 20.0}  # (faster, a GA this small needs more
    # friction than μ / 2 where its path bends between samples: infeasible)
    doc["balance"]["policy"] = "minimal"  # the batch's mechanics, with a GA this small
    for key, value in changes.items():
        doc[key] = value
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


def test_all_expectations_hold(tmp_path, capsys):
    a = _small(tmp_path, "a", expect={"feasible": True, "peak_thrust_n": 23.0})
    b = _small(tmp_path, "b", expect={"feasible": False}, balance={"thrust_max_n": 0.0})
    out = tmp_path / "out"
    assert run(["batch", str(a), str(b), "-o", str(out), "--no-progress", "-j", "2"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert [r["name"] for r in s["scenarios"]] == ["a", "b"] and s["exit_code"] == 0
    assert (out / "a" / "trajectory.csv").exists() and not (out / "b" / "trajectory.csv").exists()
    assert (out / "b" / "summary.json").exists()


def test_failed_expectation_is_exit_4(tmp_path):
    a = _small(tmp_path, "a", expect={"peak_thrust_n": 0.5})
    assert run(["batch", str(a), "-o", str(tmp_path / "o"), "--no-progress", "-j", "1"]) == 4
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert "max thrust" in s["scenarios"][0]["expectations_failed"][0]


def test_unexpected_infeasible_is_exit_3(tmp_path):
    a = _small(tmp_path, "a", balance={"thrust_max_n": 0.0}, expect={})
    ok = _small(tmp_path, "ok", expect={"feasible": True})
    assert run(["batch", str(a), str(ok), "-o", str(tmp_path / "o"), "--no-progress"]) == 3


def test_bad_input_is_one_line_before_any_plan_and_manifest(tmp_path, capsys):
    """Every scenario is read before any is planned: a bad one is exit 2, one line naming it, nothing
    written (the others are not planned either: bad input is refused, not recorded)."""
    _small(tmp_path, "good")
    bad = tmp_path / "bad.yaml"
    bad.write_text("steps: 3\n")
    manifest = tmp_path / "m.yaml"
    manifest.write_text(yaml.safe_dump(["good.yaml", "bad.yaml"]))
    assert run(["batch", "--manifest", str(manifest), "-o", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(bad) in err[0] and "steps" in err[0]
    assert not (tmp_path / "o").exists()
    manifest.write_text(yaml.safe_dump(["good.yaml"]))
    assert run(["batch", "--manifest", str(manifest), "-o", str(tmp_path / "o"), "--no-progress"]) == 0
    assert [r["status"] for r in json.loads((tmp_path / "o" / "summary.json").read_text())["scenarios"]] == [
        "feasible"]


def test_dask_executor_gives_the_same_files(tmp_path):
    import pytest

    pytest.importorskip("distributed")
    a = _small(tmp_path, "a", expect={"feasible": True})
    b = _small(tmp_path, "b", expect={"feasible": True}, seed=7)
    assert run(["batch", str(a), str(b), "-o", str(tmp_path / "loky"), "--no-progress"]) == 0
    assert run(["batch", str(a), str(b), "-o", str(tmp_path / "dask"), "--no-progress", "--executor", "dask"]) == 0
    for name in ("a", "b"):
        for f in ("trajectory.csv", "trajectory.mcap"):
            assert (tmp_path / "loky" / name / f).read_bytes() == (tmp_path / "dask" / name / f).read_bytes()


def test_a_scenario_that_is_not_text_is_one_line(tmp_path, capsys):
    good = _small(tmp_path, "good", expect={"feasible": True})
    bad = tmp_path / "binary.yaml"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)))
    out = tmp_path / "out"
    assert run(["batch", str(bad), str(good), "-o", str(out), "--no-progress", "--json"]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and "binary.yaml" in err[0] and "not UTF-8" in err[0] and captured.out == ""
    assert not out.exists()
