"""``jethr1 design``: variants of Jet-HR1 judged by the widest ditch they cross. Physical facts (more thrust never
narrows the widest ditch; Jet-HR1's own fans as a design cross what Jet-HR1 crosses), the bisection's exactness,
the same bytes on every executor, and a sweep interrupted and run again that judges only what it had not."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from jethr1_plan.cli import run
from jethr1_plan.io import atomic
from jethr1_plan.studies import design as design_mod
from jethr1_plan.studies.design_judge import LEVELS, widest_gaps
from jethr1_plan.studies.design_report import pareto_front
from jethr1_plan.studies.design_spec import load_design

FANS = """fan_mass: {kg_per_n: 0.0100869565217391}
fans:
  - {name: left, mount: left_foot, thrust_max_n: $thrust_n, offset_m: [0.0, 0.095, 0.035]}
  - {name: right, mount: right_foot, thrust_max_n: $thrust_n, offset_m: [0.0, -0.095, 0.035]}
"""
#: two variants, 18 N and Jet-HR1's 23 N, both fans of Jet-HR1's 0.232 kg, on five gaps 40 mm apart
SPEC = "name: two\naxes:\n  thrust_n: {values: [18.0, 23.0]}\n" + \
       FANS.replace("thrust_max_n: $thrust_n,", "thrust_max_n: $thrust_n, mass_kg: 0.232,") + \
       "judge: {gaps_m: [0.34, 0.50], resolution_m: 0.04}\nbest: 2\n"
FILES = ("design.csv", "design.json", "design.png")


def design(spec: Path, out: Path, cache: Path, *more: str) -> int:
    return run(["design", str(spec), "-o", str(out), "--cache", str(cache), "--no-progress", *more])


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """The two-variant sweep with -j 1 into a cache of its own."""
    root = tmp_path_factory.mktemp("design")
    spec = root / "two.yaml"
    spec.write_text(SPEC)
    assert design(spec, root / "j1", root / "cache", "-j", "1") == 0
    doc = json.loads((root / "j1" / "design.json").read_text())
    return root, spec, doc


def test_more_thrust_never_narrows_the_widest_ditch(swept):
    """Fans of the same mass: 23 N crosses at every level at least as wide a ditch as 18 N (None: not even the
    narrowest; every plan of 18 N's is one 23 N's fans can fly); the 18 N fans' crossings need no more than 18 N,
    and Paper A's minimal plan at the widest crossed gap exists."""
    _, _, doc = swept
    weak, strong = (v["result"] for v in doc["variants"])
    for level in LEVELS:
        a, b = weak["widest"][level]["gap_m"], strong["widest"][level]["gap_m"]
        assert a is None or (b is not None and b >= a), level
    assert strong["widest"]["crossed"]["gap_m"] > weak["widest"]["crossed"]["gap_m"]
    assert all(g.get("peak_thrust_n") is None or g["peak_thrust_n"] <= 18.0 + 1e-6 for g in weak["gaps"])
    for r in (weak, strong):
        assert r["minimal"]["feasible"] and r["minimal"]["peak_thrust_n"] <= r["thrust_max_n"] + 1e-6
        # the widest gap at each level is crossed, and the next gap planned beyond it is not (the bisection's answer)
        for level, share in LEVELS.items():
            w = r["widest"][level]
            by_gap = {g["gap_m"]: g["share"] for g in r["gaps"]}
            if w["gap_m"] is not None:
                assert by_gap[w["gap_m"]] >= share
            if w["next_failing_m"] is not None:
                assert by_gap[w["next_failing_m"]] is None or by_gap[w["next_failing_m"]] < share


def test_jethr1_s_fans_as_a_design_cross_what_jethr1_crosses(swept):
    """The 23 N variant is Jet-HR1 with its fans rebuilt: its share at each gap planned is ditch-curve's for
    Jet-HR1 (the planner's own numbers, to 1e-6), and its widest robust ditch on this lattice is 340 mm
    (docs/robust_planning.md: 350 mm whole, 360 mm at 0.968)."""
    from jethr1_plan.studies.ditch_curve import default_base, ditch_scenario, share_of_gap

    _, _, doc = swept
    r = doc["variants"][1]["result"]
    assert r["widest"]["whole"]["gap_m"] == pytest.approx(0.34) and r["widest"]["whole"]["next_failing_m"] == \
        pytest.approx(0.38)
    base = default_base()
    g = next(g for g in r["gaps"] if g["share"] is not None and g["share"] < 1)
    ref = share_of_gap(ditch_scenario(base, g["gap_m"], base.balance.robust, 0.16))
    assert g["share"] == pytest.approx(ref["share"], abs=1e-6)
    assert g["peak_thrust_n"] == pytest.approx(ref["peak_thrust_n"], abs=1e-6)


def test_the_files_and_a_best_variant_ready_for_plan(swept):
    """design.csv has one row per variant with the design's figures; the best variant's folder loads through the
    robot checks, and its scenario plans the widest robust ditch holding the whole tolerance on every row."""
    from jethr1_plan.io.csv_table import read_csv_table
    from jethr1_plan.planning.plan import plan
    from jethr1_plan.planning.report import share_summary
    from jethr1_plan.robot.load import load_robot
    from jethr1_plan.scenario import load_scenario

    root, _, doc = swept
    table = read_csv_table((root / "j1" / "design.csv").read_text(), "design.csv", lambda h: True,
                           text_columns=("variant", "status"), bool_columns=("monotone", "pareto_mass",
                                                                                   "pareto_thrust"))
    np.testing.assert_array_equal(table["thrust_n"], [18.0, 23.0])
    np.testing.assert_allclose(table["total_thrust_n"], [36.0, 46.0])
    np.testing.assert_array_equal(table["fan_mass_kg"], [0.464, 0.464])
    np.testing.assert_array_equal(table["added_mass_kg"], [0.0, 0.0])  # Jet-HR1's fans' mass (to the microgram)
    np.testing.assert_array_equal(table["mass_kg"], [6.8, 6.8])
    assert list(table["status"]) == ["ok", "ok"] and doc["best"]
    name = f"two_{doc['best'][0]}"
    folder = root / "j1" / "robots" / name
    robot = load_robot(folder)
    assert robot.name == name and len(robot.fans) == 2
    scenario = load_scenario(root / "j1" / "scenarios" / f"{name}_ditch_whole.yaml")
    row = next(v for v in doc["variants"] if v["variant"] == doc["best"][0])
    assert scenario.steps[0].landing_m[0] == pytest.approx(0.08 + row["result"]["widest"]["whole"]["gap_m"] + 0.085)
    result = plan(scenario)
    assert result.feasible and share_summary(result.rows, scenario.balance.tolerance)["least"] >= 1 - 1e-9


def test_a_best_variant_plans_and_walks_its_ditch_in_the_twin(swept, tmp_path):
    """The best variant's folder and crossing, as a user runs them: ``jethr1 plan`` of its scenario writes a feasible
    plan within the variant's fans, and ``jethr1 simulate`` with the robot's own feedback law (its IMU and encoders,
    with their noise) crosses the ditch in the MuJoCo twin: no fall, the trunk within 5 deg of level, both soles
    on carton tops, the landing within 10 mm of the plan's."""
    root, _, doc = swept
    name = f"two_{doc['best'][0]}"
    assert run(["plan", str(root / "j1" / "scenarios" / f"{name}_ditch_whole.yaml"), "-o", str(tmp_path),
                "--no-progress"]) == 0
    folder = tmp_path / f"{name}_ditch_whole"
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["feasible"] and summary["peak_thrust_n"] <= summary["thrust_max_n"] + 1e-9
    assert run(["simulate", str(folder), "--controller", "feedback", "--no-progress"]) == 0
    sim = json.loads((folder / "simulation.json").read_text())
    r = sim["runs"][0]
    assert sim["law"] == "imu_tilt_pid" and r["survived"] and r["fell"] is None
    assert r["max_trunk_tilt_deg"] < 5.0 and all(r["soles_on_cartons_at_end"].values())
    assert r["landing_errors_m"] and max(e["xy_m"] for e in r["landing_errors_m"]) < 0.010


def test_run_again_judges_nothing_and_writes_the_same_bytes(swept, tmp_path):
    root, spec, _ = swept
    assert design(spec, tmp_path / "again", root / "cache", "-j", "2") == 0
    timings = json.loads((tmp_path / "again" / "timings.json").read_text())
    assert timings["judged"] == {} and timings["from_cache"] == 2
    for name in FILES[:2]:
        assert (tmp_path / "again" / name).read_bytes() == (root / "j1" / name).read_bytes()


def test_two_processes_and_a_dask_cluster_give_the_same_bytes(swept, tmp_path):
    """Judged afresh (empty caches) on 2 loky workers and on a local Dask cluster of 2: design.csv and design.json
    are the bytes of -j 1's."""
    root, spec, _ = swept
    assert design(spec, tmp_path / "j2", tmp_path / "cache_j2", "-j", "2") == 0
    assert design(spec, tmp_path / "dask", tmp_path / "cache_dask", "-j", "2", "--executor", "dask") == 0
    for out in ("j2", "dask"):
        assert json.loads((tmp_path / out / "timings.json").read_text())["from_cache"] == 0
        for name in FILES[:2]:
            assert (tmp_path / out / name).read_bytes() == (root / "j1" / name).read_bytes(), (out, name)


def test_a_new_process_for_every_variant_gives_the_same_bytes(swept, tmp_path, monkeypatch):
    """Each variant judged in a child process of its own (VARIANTS_PER_PROCESS 1: two children for two variants)
    writes the bytes of -j 1's run, where one child judged both: nothing of a variant's judging leaks into the
    next (a wrapper handed out again, a cache)."""
    from jethr1_plan.io import recycled

    root, spec, _ = swept
    started: list[int] = []

    class Counted(recycled.Child):
        def __init__(self, limit: int) -> None:
            super().__init__(limit)
            started.append(self.proc.pid)

    monkeypatch.setattr(design_mod, "VARIANTS_PER_PROCESS", 1)
    monkeypatch.setattr(recycled, "Child", Counted)
    assert design(spec, tmp_path / "each", tmp_path / "cache_each", "-j", "1") == 0
    assert len(set(started)) == 2
    for name in FILES[:2]:
        assert (tmp_path / "each" / name).read_bytes() == (root / "j1" / name).read_bytes(), name


@pytest.fixture()
def tiny(tmp_path):
    """The two variants judged on one gap, 0.46 m (a plan or two each)."""
    spec = tmp_path / "tiny.yaml"
    spec.write_text(SPEC.replace("gaps_m: [0.34, 0.50], resolution_m: 0.04",
                                 "gaps_m: [0.46, 0.47], resolution_m: 0.02"))
    return spec


def test_an_interrupted_sweep_resumes_without_judging_again(tiny, tmp_path, monkeypatch, capsys):
    """Ctrl-C while the second variant is judged: exit 130, no output folder, the first variant's result in the
    cache; the same command then judges the second variant only, and writes what a run without the interrupt
    writes."""
    spec = tiny
    real = design_mod.judge_task
    calls: list[str] = []

    def interrupting(task):
        calls.append(task.key)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(task)

    monkeypatch.setattr(design_mod, "judge_task", interrupting)
    monkeypatch.setattr(atomic, "_COMMITTED", [])  # (what earlier tests of this process wrote)
    assert design(spec, tmp_path / "out", tmp_path / "cache", "-j", "1") == 130
    err = " ".join(capsys.readouterr().err.split())
    assert "judges only the rest" in err and err.endswith("nothing written")  # the cache is not an output
    assert not (tmp_path / "out").exists()
    assert len(list((tmp_path / "cache" / "design").rglob("*.json"))) == 1
    monkeypatch.setattr(design_mod, "judge_task", real)
    assert design(spec, tmp_path / "out", tmp_path / "cache", "-j", "1") == 0
    timings = json.loads((tmp_path / "out" / "timings.json").read_text())
    assert timings["from_cache"] == 1 and list(timings["judged"]) == ["v0001"]
    shares = [v["result"]["gaps"][0]["share"] for v in json.loads((tmp_path / "out" / "design.json").read_text())[
        "variants"]]
    assert shares[0] is None and 0.3 < shares[1] < 0.4  # 18 N cannot cross 0.46 m; 23 N holds 0.346 of T there

    # a cache entry cut short (a full disk, an editor) is judged again, and the files do not change
    entry = sorted((tmp_path / "cache" / "design").rglob("*.json"))[0]
    entry.write_text(entry.read_text()[:100])
    assert design(spec, tmp_path / "again", tmp_path / "cache", "-j", "1") == 0
    assert len(json.loads((tmp_path / "again" / "timings.json").read_text())["judged"]) == 1
    for name in FILES[:2]:
        assert (tmp_path / "again" / name).read_bytes() == (tmp_path / "out" / name).read_bytes()


@pytest.mark.parametrize("n", [1, 2, 7, 26, 51])
def test_the_bisection_finds_each_widest_gap_exactly(n):
    """On shares that do not grow with the gap (random steps, plateaus at 1, an end where nothing balances), the
    widest index holding each level is the true one, each index is planned at most once, and no more than
    3·⌈log2(n + 1)⌉ plans are made."""
    rng = np.random.default_rng(n)
    for _ in range(200):
        full = int(rng.integers(-1, n + 1))
        end = int(rng.integers(max(full, 0), n + 1))
        falling = np.sort(rng.uniform(0, 1, n))[::-1]
        shares = [1.0 if k <= full else (float(falling[k]) if k <= end else None) for k in range(n)]
        calls: list[int] = []

        def evaluate(k, shares=shares, calls=calls):
            calls.append(k)
            return shares[k]

        planned = widest_gaps(n, evaluate)
        assert len(calls) == len(set(calls)) <= 3 * int(np.ceil(np.log2(n + 1)))
        for level in LEVELS.values():
            truth = max((k for k in range(n) if shares[k] is not None and shares[k] >= level), default=-1)
            found = max((k for k, s in planned.items() if s is not None and s >= level), default=-1)
            assert found == truth


def test_pareto_front():
    """Less mass and a wider ditch beat more mass and a narrower one; ties on both stay; missing values are on no
    front."""
    cost = [1.0, 2.0, 2.0, 0.5, 3.0, None]
    gain = [0.30, 0.40, 0.35, 0.30, 0.40, 0.6]
    assert pareto_front(cost, gain) == [1, 3]


def test_latin_hypercube_is_seeded_and_stratified(tmp_path):
    """40 points of a seeded Latin hypercube over thrust and a mount offset: each axis's 40 equal strata hold one
    point each; the same seed gives the same variants, another seed others."""
    text = ("name: lhs\nseed: 3\nsampling: {method: lhs, samples: 40}\naxes:\n  thrust_n: {range: [15.0, 40.0]}\n"
            "  outboard_m: {range: [0.06, 0.15]}\n" + FANS.replace("0.095, 0.035]", "$outboard_m, 0.035]")
            .replace("-0.095", "-$outboard_m"))
    path = tmp_path / "lhs.yaml"
    path.write_text(text)
    a = load_design(path).points()
    assert a == load_design(path).points()
    for name, (lo, hi) in (("thrust_n", (15.0, 40.0)), ("outboard_m", (0.06, 0.15))):
        strata = sorted(int((p[name] - lo) / (hi - lo) * 40) for p in a)
        assert strata == list(range(40))
    path.write_text(text.replace("seed: 3", "seed: 4"))
    assert load_design(path).points() != a
    v = load_design(path).variants()[5]
    assert v.design.fans[1].offset_m[1] == -v.values["outboard_m"]


@pytest.mark.parametrize("bad, key", [
    ("axes:\n  thrust_n: {values: [18.0]}\n" + FANS.replace("$thrust_n", "$thrust"), "fans[0].thrust_max_n"),
    ("axes:\n  thrust_n: {values: [18.0]}\n  spare: {values: [1.0]}\n" + FANS, "axes.spare"),
    ("sampling: {method: lhs, samples: 4}\naxes:\n  thrust_n: {range: [15.0, 40.0], count: 3}\n" + FANS,
     "axes.thrust_n.count"),
    ("axes:\n  thrust_n: {range: [15.0, 40.0]}\n" + FANS, "axes.thrust_n.count"),
    ("axes:\n  thrust_n: {values: [18.0]}\n" + FANS.replace("{kg_per_n: 0.0100869565217391}",
                                                           "{table: [[20, 0.2], [10, 0.1]]}"), "fan_mass.table"),
    ("axes:\n  thrust_n: {values: [50.0]}\n" + FANS.replace("{kg_per_n: 0.0100869565217391}",
                                                           "{table: [[10, 0.1], [40, 0.4]]}"), "fan_mass.table"),
    ("axes:\n  thrust_n: {values: [18.0]}\n" + FANS.replace("mount: left_foot", "mount: left_shank"),
     "variant 0"),
    ("axes:\n  thrust_n: {values: [18.0]}\n" + FANS + "judge: {gaps_m: [0.5, 0.3]}\n", "judge.gaps_m"),
    ("axes:\n  thrust_n: {values: [18.0]}\n" + FANS + "base_robot: nobody\n", "base_robot"),
])
def test_a_bad_design_file_is_one_line_and_exit_2(tmp_path, capsys, bad, key):
    path = tmp_path / "bad.yaml"
    path.write_text(bad)
    assert design(path, tmp_path / "out", tmp_path / "cache") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and key in err[0] and str(path) in err[0], err
    assert not (tmp_path / "out").exists() and not (tmp_path / "cache").exists()


ONE = "axes:\n  thrust_n: {values: [18.0]}\n"


@pytest.mark.parametrize("bad, key, problem", [
    # a value of the branch it was written for, named as such (not as the other branch's missing key)
    ("axes:\n  thrust_n: {values: []}\n" + FANS, "axes.thrust_n.values", "0 items: expected at least 1"),
    ("axes:\n  thrust_n: {values: [a, 23.0]}\n" + FANS, "axes.thrust_n.values[0]", "expected number, got 'a'"),
    ("axes:\n  thrust_n: {values: [1.0e+300]}\n" + FANS, "axes.thrust_n.values[0]", "above the largest allowed"),
    (ONE + FANS.replace("{kg_per_n: 0.0100869565217391}", "{table: [[23, 0.2]]}"), "fan_mass.table",
     "1 items: expected at least 2"),
    (ONE + FANS.replace("{kg_per_n: 0.0100869565217391}", "{table: [[10, -1], [30, 0.3]]}"),
     "fan_mass.table[0][1]", "-1 is below the smallest allowed, 0"),
    (ONE + FANS.replace("$thrust_n", "$$thrust_n", 1), "fans[0].thrust_max_n",
     "must be a number, or an axis by name"),
    (ONE + FANS.replace("$thrust_n", "-3", 1), "fans[0].thrust_max_n", "-3 is below the smallest allowed, 0"),
])
def test_a_bad_value_of_a_one_of_key_names_its_own_key(tmp_path, capsys, bad, key, problem):
    """A key that takes one of two shapes (an axis's values or range, fan_mass's line or table, a number or an axis
    reference) is refused for what is wrong in the shape it has, not for a key of the other shape it lacks."""
    path = tmp_path / "bad.yaml"
    path.write_text(bad)
    assert design(path, tmp_path / "out", tmp_path / "cache") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{path}: {key}: " in err[0] and problem in err[0], err
    assert not (tmp_path / "out").exists() and not (tmp_path / "cache").exists()


@pytest.fixture()
def no_judging(monkeypatch):
    """A judge that must not be reached: a refusal comes before any variant is judged."""
    def judge(task):
        raise RuntimeError("a variant was judged before the refusal")

    monkeypatch.setattr(design_mod, "judge_task", judge)


@pytest.mark.parametrize("prepare, named", [
    (lambda out: (out.mkdir(), (out / "design.csv").write_text("mine\n")), "out/design.csv"),
    (lambda out: (out.mkdir(), (out / "robots").write_text("mine\n")), "out/robots"),
    (lambda out: (out.mkdir(), (out / "scenarios").mkdir(), (out / "design.png").mkdir()), "out/design.png"),
])
def test_an_output_folder_holding_the_user_s_files_is_refused_before_any_work(tmp_path, capsys, no_judging,
                                                                               prepare, named):
    """-o naming a folder of the user's where design writes its files (a file of an output's name, a file where
    its robots/ folder goes): one line naming it, exit 2, before any variant is judged; the user's files as they
    were, no cache made."""
    spec = tmp_path / "two.yaml"
    spec.write_text(SPEC)
    out = tmp_path / "out"
    prepare(out)
    before = {p: p.read_bytes() if p.is_file() else None for p in out.rglob("*")}
    assert design(spec, out, tmp_path / "cache") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{tmp_path / named}: " in err[0] and "nothing written" in err[0], err
    assert {p: p.read_bytes() if p.is_file() else None for p in out.rglob("*")} == before
    assert not (tmp_path / "cache").exists()


@pytest.mark.parametrize("where", ["design_file", "env_file"])
def test_a_cache_that_cannot_be_a_folder_is_refused_before_any_work(tmp_path, capsys, monkeypatch, no_judging,
                                                                     where):
    """$JETHR1_CACHE naming a file, or a cache whose design/ is a file: one line naming the cache,
    exit 2, before any variant is judged; nothing written, the file as it was."""
    spec = tmp_path / "two.yaml"
    spec.write_text(SPEC)
    cache = tmp_path / "cache"
    if where == "design_file":
        cache.mkdir()
        (cache / "design").write_text("mine\n")
    else:
        cache.write_text("mine\n")
    if where == "env_file":
        monkeypatch.setenv("JETHR1_CACHE", str(cache))
        code = run(["design", str(spec), "-o", str(tmp_path / "out"), "--no-progress"])
    else:
        code = design(spec, tmp_path / "out", cache)
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{cache}: cannot keep the design cache here" in err[0], err
    assert not (tmp_path / "out").exists()
    assert (cache / "design" if where == "design_file" else cache).read_text() == "mine\n"


def test_variants_that_would_not_fit_in_memory_are_refused_before_any_work(tmp_path, capsys, monkeypatch, no_judging):
    """A design whose variants' robot files (held until the files are written, VARIANT_BYTES each) are more than
    the memory available: one line naming the design file and its axes, exit 2, before any variant is built or
    judged; nothing written, no cache made."""
    from jethr1_plan.cli import common

    spec = tmp_path / "two.yaml"
    spec.write_text(SPEC)
    monkeypatch.setattr(common, "memory_available", lambda: int(1.5 * design_mod.VARIANT_BYTES))
    monkeypatch.setattr(design_mod, "make_tasks", lambda *a, **k: pytest.fail("the variants were built"))
    assert design(spec, tmp_path / "out", tmp_path / "cache") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{spec}: axes: 2 variants' robot files need about" in err[0], err
    assert not (tmp_path / "out").exists() and not (tmp_path / "cache").exists()
