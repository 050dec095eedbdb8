"""``timing: {mode: fastest}``: TOPP-RA's law, the constraints at rest, the fast trial against its targets, and
``verify`` re-checking a fast plan's motion (a faster re-timing by hand fails)."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from jethr1_plan.cli import run
from jethr1_plan.control.time_optimal import fastest_law
from tests.conftest import ROOT, rewritten


def test_the_fastest_law_of_a_bounded_acceleration_is_bang_bang():
    """|s̈| ≤ 2 over s ∈ [0, 1], at rest at both ends: accelerate to the middle, brake: T = 2·√(L/a) = √2 s;
    with ṡ ≤ 0.5 as well: T = L/v + v/a = 2.25 s."""
    grid = np.linspace(0.0, 1.0, 401)
    a = np.tile([[1.0], [-1.0]], (1, len(grid))).T
    b, c = np.zeros_like(a), np.full_like(a, -2.0)
    law = fastest_law(grid, a, b, c, np.full(len(grid), np.inf))
    assert law is not None and law.duration_s == pytest.approx(np.sqrt(2.0), rel=2e-3)
    assert np.argmax(law.sd) in range(195, 206) and law.positions(np.array([law.duration_s / 2]))[0] == pytest.approx(
        0.5, abs=2e-3)
    capped = fastest_law(grid, a, b, c, np.full(len(grid), 0.25))
    assert capped is not None and capped.duration_s == pytest.approx(2.25, rel=2e-3)
    assert fastest_law(grid, a, b, c + 3.0, np.full(len(grid), np.inf)) is None  # not even rest holds


@pytest.fixture(scope="module")
def fast_trial(tmp_path_factory):
    out = tmp_path_factory.mktemp("fast")
    assert run(["plan", str(ROOT / "configs" / "jet_hr1_trial_fast.yaml"), "-o", str(out), "--no-progress"]) == 0
    return out / "jet_hr1_trial_fast"


def test_the_fast_trial_meets_its_targets_and_verifies(fast_trial, capsys):
    """Paper A's 450 mm trial (its steps and tolerance share) timed fastest: ≤ 10 s in all, each swing ≤ 3 s, every
    phase bound by a named constraint, the rows on the output clock, and verify's own re-check holds."""
    s = json.loads((fast_trial / "summary.json").read_text())
    t = s["timing"]
    assert t["mode"] == "fastest" and t["total_s"] <= 10.0 and t["fixed_total_s"] == 24.0
    swings = [p for p in t["phases"] if p["phase"] == "swing"]
    assert len(swings) == 2 and all(p["duration_s"] <= 3.0 for p in swings)
    assert sum(p["rows"] for p in t["phases"]) == s["trajectory"]["rows"]
    for p in t["phases"]:
        assert p["speed_up"] > 1.0 and sum(b["time_fraction"] for b in p["binding"]) == pytest.approx(1.0)
    assert s["robustness"]["tolerance_share"]["least"] == pytest.approx(0.516, abs=0.01)  # the trial's share kept
    assert run(["verify", str(fast_trial)]) == 0
    capsys.readouterr()


def _retimed(src, dst, factor: float):
    shutil.copytree(src, dst)
    (dst / "trajectory.mcap").unlink()
    lines = (dst / "trajectory.csv").read_text().split("\n")
    head = lines[0].split(",")
    k = head.index("time_s")
    rows = [ln.split(",") for ln in lines[1:] if ln]
    for r in rows:
        r[k] = repr(float(r[k]) * factor)
    (dst / "trajectory.csv").write_text("\n".join([lines[0], *[",".join(r) for r in rows]]) + "\n")
    s = json.loads((dst / "summary.json").read_text())
    s["trajectory"]["rate_hz"] /= factor  # the tamperer keeps the file consistent with itself
    (dst / "summary.json").write_text(json.dumps(s))
    return rewritten(dst) / "trajectory.csv"  # and the folder one thing (its digests): its rows are what is checked


def test_verify_rejects_the_fast_plan_re_timed_faster_by_hand(fast_trial, tmp_path, capsys):
    """The same rows 10 % faster (time_s × 0.9, the summary's rate to match): the motion's own checks fail; the
    same file re-timed 10 % slower passes them (slower never breaks what the faster held)."""
    faster = _retimed(fast_trial, tmp_path / "faster", 0.9)
    assert run(["verify", str(faster), "--json"]) != 0
    found = {f["check"] for f in json.loads(capsys.readouterr().out)["failures"]}
    assert found & {"dynamic limit broken", "joint too fast", "fan cannot follow"}
    slower = _retimed(fast_trial, tmp_path / "slower", 1.1)
    run(["verify", str(slower), "--json"])
    found = {f["check"] for f in json.loads(capsys.readouterr().out)["failures"]}
    assert not found & {"dynamic limit broken", "joint too fast", "fan cannot follow"}


def test_verify_restates_the_planners_dynamic_constraints(fast_trial, robot):
    """verify's own statement of the robust dynamic ZMP, grip and torques flags exactly the rows the planner's
    ``physics.path_dynamics`` finds over their limits, on the fast trial's rows held to less of the motion's budget
    (dynamic_share 0.95: a few hundred rows over)."""
    from jethr1_plan.folders.plan import read_plan
    from jethr1_plan.geometry import SIDES, convex_hull, sole_polygon
    from jethr1_plan.physics.path_dynamics import Limits, path_constraints
    from jethr1_plan.physics.row_dynamics import row_derivatives
    from jethr1_plan.verify.plan_rows import RowData
    from jethr1_plan.verify.timing import _dynamic_findings

    plan = read_plan(fast_trial, suffixes=(".csv",), strict=True, purpose="test")
    summary = dict(plan.summary)
    summary["timing"] = {**summary["timing"], "dynamic_share": 0.95}
    c = plan.table
    x = RowData(c, robot, None, None, None, summary, None, True)
    flagged = {i for i, _ in _dynamic_findings(x)["dyn"]}
    yaw = 2 * np.arctan2(c["pelvis_qz"].astype(float), c["pelvis_qw"].astype(float))
    base = np.zeros((x.n, 4, 4))
    base[:, 0, 0], base[:, 0, 1], base[:, 1, 0], base[:, 1, 1] = np.cos(yaw), -np.sin(yaw), np.sin(yaw), np.cos(yaw)
    base[:, 2, 2] = base[:, 3, 3] = 1.0
    base[:, :3, 3] = np.stack([c["pelvis_x_m"], c["pelvis_y_m"], c["pelvis_z_m"]], axis=1).astype(float)
    v, a = row_derivatives(base, x.q, 0.02)
    tol = summary["balance"]["tolerance"]
    over = set()
    for i in range(x.n):
        down = SIDES if x.support[i] == "both" else (str(x.support[i]),)
        polys = [sole_polygon(x.pos[s][i, :2], 0.0, robot.sole_length_m, robot.sole_width_m) for s in down]
        poly = polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys))
        lim = Limits((tol["thrust_error"], tol["mass_error"], tol["com_error_m"]),
                     np.array([0.95 * float(c["tolerance_share"][i])]), 0.8, robot.sole_friction)
        con = path_constraints(robot, base[i:i + 1], x.q[i:i + 1], v[i:i + 1], a[i:i + 1], x.thrust[i:i + 1],
                               np.zeros((1, len(robot.fans))), down, poly, lim)
        if np.max(con.b + con.c) > 1e-4:
            over.add(i)
    assert len(over) > 20
    assert flagged == over


def test_a_fastest_timing_is_refused_where_it_cannot_be_planned(tmp_path, capsys):
    """A yaw MPC (laid out on the fixed rows) or a plan with no margin to spend: one line, exit 2."""
    text = (ROOT / "configs" / "side_step.yaml").read_text()
    bad = tmp_path / "mpc.yaml"
    bad.write_text(text.replace("timing:", "body_yaw: {mode: mpc}\ntiming:\n  mode: fastest", 1))
    assert run(["plan", str(bad), "-o", str(tmp_path / "o"), "--no-progress"]) == 2
    assert "fastest cannot be combined with body_yaw.mode mpc" in capsys.readouterr().err
    assert run(["plan", str(ROOT / "configs" / "side_step.yaml"), "--timing", "fastest", "--policy", "minimal", "-o",
                str(tmp_path / "o"), "--no-progress"]) == 2
    assert "needs a margin" in capsys.readouterr().err
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").rglob("*.csv"))


@pytest.mark.parametrize(("stiffness", "pid"), [(0.8, False), (1.25, True)])
def test_the_fast_trial_survives_an_independent_replay_of_its_csv(fast_trial, stiffness, pid):
    """tests/oracles/replay_csv.py (its own model, servos and contact; only the CSV's commands): no fall, landings
    within 10 mm, soles on the cartons, with the servos' stiffness off by −20 % (feed-forward) and +25 % (a
    trunk-tilt PID on the thrust)."""
    from tests.oracles.replay_csv import replay

    r = replay(fast_trial, ROOT / "configs" / "jet_hr1_trial_fast.yaml", ROOT / "robots" / "jethr1" / "jethr1.yaml",
               stiffness, pid)
    assert r.fell is None and r.on_cartons and len(r.landings_m) == 2, r
    assert max(r.landings_m) <= 0.010
