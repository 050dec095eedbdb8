"""``jethr1 verify``: an independent re-check of a written plan before it goes on the robot.

Reads only what was written (``trajectory.csv``, ``trajectory.mcap``, ``summary.json``), the
scenario and the robot model, never the planner's state. Each row's pelvis pose and joints go into
a fresh PlaCo robot, and every row must hold against everything that can be known:

* **the file** (``summary.json``): as many rows as the plan wrote, at its rate from t = 0, strictly
  increasing; **the scenario**: transfers and swings in its order and lengths, each with its step,
  its samples counted from 0 and its support;
* **the pose**: a unit quaternion of a level trunk; joints within the URDF limits; both soles flat;
  every sole on the ground where the scenario puts it in that phase (the start, then each landing),
  the swing sole on the scenario's swing path and on its written sample;
* **the plan's own verdict**: every row marked feasible with no reason;
* **balance**: each fan's thrust within [0, F_max] of the fan and of the scenario; the ZMP from the
  written thrust (A-1, A-2) in the support sole (double support: the hull of both); the written
  thrust window and ZMP margin recomputed; under the plan's tolerance, the ZMP in the support for
  every error within the row's share of it (``balance.balance_slack``), the share column
  recomputed (``physics.share.row_shares``) and not below the plan's ``min_share``;
* **the analysis**: the written CoM and ZMP; the static torques recomputed (``statics``) and within
  the servo limits; κ of each leg; the command columns recomputed (``commands``);
* **CSV and MCAP together** (a folder with both): the same rows, the same numbers.

A failing row gives one line; a file that cannot be read as this format is bad input (exit 2).
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.folders.plan import PlanFolder
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.verify import analysis_checks, balance_checks, plan_checks, timing
from jethr1_plan.verify.checks import RowCheck
from jethr1_plan.verify.common import Failure, Failures
from jethr1_plan.verify.plan_rows import RowData

__all__ = ["CHECKS", "verify_plan", "verify_rows"]

#: every check of a plan's rows, in the order they run (a row's failures are listed in this order)
CHECKS: list[RowCheck] = [*plan_checks.CHECKS, *balance_checks.CHECKS, *analysis_checks.CHECKS, *timing.CHECKS]


def verify_plan(plan: PlanFolder) -> tuple[int, Failures]:
    """Every row of every trajectory file of ``plan`` (and, with both, the CSV against the MCAP);
    (rows, failures sorted by row). The checks are a function of what they read: a file whose rows,
    numbers and swing paths are those of a file already checked has that file's findings (the MCAP
    of a plan carries the CSV's very floats), and its rows are not checked a second time."""
    n, failures, rows = 0, [], set[int]()
    done: list[tuple[dict, list | None, tuple[int, list[Failure]]]] = []
    for f, table in plan.tables.items():
        paths = plan.swing_paths.get(f)
        # (the files' swing paths are read only without a scenario)
        seen = next((res for t, sp, res in done if _same_table(t, table)
                     and (plan.scenario is not None or _same_paths(sp, paths))), None)
        k, fails = seen if seen is not None else verify_rows(table, plan.robot, swing_paths=paths,
                                                             summary=plan.summary, scenario=plan.scenario)
        done.append((table, paths, (k, fails)))
        n = max(n, k)
        rows |= fails.rows if isinstance(fails, Failures) else {x.row for x in fails}
        failures += [Failure(x.row, x.time_s, x.check, f"{f.name}: {x.detail}" if len(plan.tables) > 1 else x.detail)
                     for x in fails]
    if len(plan.tables) == 2:
        (_, csv_rows), (_, mcap_rows) = sorted(plan.tables.items(), key=lambda kv: kv[0].suffix)
        failures += _compare_files(csv_rows, mcap_rows)
    failures.sort(key=lambda x: x.row)
    return n, Failures(failures, rows)


def _same_table(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> bool:
    """The same columns in the same order, with the same values (NaN where NaN; the CSV reads integers
    as floats: the same numbers are the same) and the same texts."""
    if list(a) != list(b):
        return False
    for k in a:
        x, y = np.asarray(a[k]), np.asarray(b[k])
        if x.shape != y.shape:
            return False
        if x.dtype.kind in "fiub" and y.dtype.kind in "fiub":
            if not np.array_equal(x.astype(float), y.astype(float), equal_nan=True):
                return False
        elif x.dtype.kind != y.dtype.kind or not np.array_equal(x, y):
            return False
    return True


def _same_paths(a: list | None, b: list | None) -> bool:
    if a is None or b is None:
        return a is b
    return len(a) == len(b) and all(np.shape(x) == np.shape(y) and np.array_equal(x, y)
                                    for x, y in zip(a, b, strict=True))


def _compare_files(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> list[Failure]:
    """Rows of the CSV (a) and the MCAP (b) that differ (the numbers written are the same floats): per
    row, the first column (in the CSV's order) that differs."""
    out = []
    n = min(len(a["time_s"]), len(b["time_s"]))
    if len(a["time_s"]) != len(b["time_s"]):
        out.append(Failure(n, float(a["time_s"][n - 1]) if n else 0.0, "CSV and MCAP differ",
                           f"{len(a['time_s'])} rows in the CSV, {len(b['time_s'])} in the MCAP"))
    keys = [k for k in a if k in b]
    differ = np.zeros((n, len(keys)), dtype=bool)
    for j, k in enumerate(keys):
        differ[:, j] = _differ(np.asarray(a[k])[:n], np.asarray(b[k])[:n])
    for i in np.flatnonzero(differ.any(axis=1)):
        k = keys[int(np.argmax(differ[i]))]
        x, y = a[k][i], b[k][i]
        if isinstance(x, float | np.floating):
            x, y = float(x), float(y)
        out.append(Failure(int(i), float(a["time_s"][i]), "CSV and MCAP differ", f"{k}: {x!r} against {y!r}"))
    return out


def _differ(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(n,) where two columns differ: floats beyond 1e-12 (relative above 1) unless both NaN; others unequal."""
    if x.dtype.kind == "f":
        yf = y.astype(float)
        with np.errstate(invalid="ignore"):
            same = (x == yf) | (np.isnan(x) & np.isnan(yf)) | (np.abs(x - yf) <= 1e-12 * np.maximum(1.0, np.abs(x)))
        return ~same
    return np.array([u != v for u, v in zip(x.tolist(), y.tolist(), strict=True)], dtype=bool)


def verify_rows(c: dict[str, np.ndarray], robot: RobotModel, swing_paths: list[np.ndarray] | None = None,
                start_feet: dict[str, np.ndarray] | None = None, max_failures: int = 50,
                balance: dict | None = None, summary: dict | None = None, scenario=None,
                torque_limits: bool = True) -> tuple[int, list[Failure]]:
    """Run every check of :data:`CHECKS` on the rows; return (rows
    checked, failures sorted by row, a row's in the checks' order).

    Args:
        summary: the plan's ``summary.json``: row count, rate, thrust limit, balance (policy,
            tolerance). ``balance`` alone may be given instead (the planner's self-check).
        scenario: the plan's scenario: the phases, the soles on the ground, the swing paths.
        start_feet: where the soles stand at the start (without a scenario).
        torque_limits: rows whose static torque exceeds a servo limit fail.
    """
    data = RowData(c, robot, swing_paths, start_feet, balance, summary, scenario, torque_limits)
    found: list[tuple[int, int, str, str]] = []  # (row, the check's place, check, detail)
    for order, chk in enumerate(CHECKS):
        if (data.n == 0 and not chk.on_empty) or any(k not in c for k in chk.needs):
            continue
        found += [(row, order, chk.name, detail) for row, detail in chk.test(data)]
    return data.n, _failures(found, c, max_failures)


def _failures(found: list, c: dict, max_failures: int) -> Failures:
    """The first ``max_failures`` failures in row order, and the first of every other kind of check; every
    failing row counted (``Failures.rows``)."""
    found.sort(key=lambda f: (f[0], f[1]))
    chosen = found[:max_failures]
    shown = {f[2] for f in chosen}
    for f in found[max_failures:]:
        if f[2] not in shown:
            chosen.append(f)
            shown.add(f[2])
    times = c["time_s"]
    out = []
    for i, _, check, detail in chosen:
        t = float(times[i]) if 0 <= i < len(times) and np.isfinite(times[i]) else float(len(times))
        out.append(Failure(i, t, check, detail))
    return Failures(out, {f[0] for f in found})
