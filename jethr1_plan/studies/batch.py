"""``jethr1 batch``: many scenarios, one subdirectory each, one summary, an exit status to gate on."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from jethr1_plan.errors import InfeasiblePlan, InputError, interrupt_behind

__all__ = ["batch_exit_code", "check_expectations", "read_manifest", "run_batch", "run_scenario"]


MAX_MANIFEST_BYTES = 1_000_000  # a manifest lists a few hundred paths at most
MAX_SCENARIOS = 1000  # scenarios in one batch


def read_manifest(path: Path) -> list[Path]:
    """Scenario paths listed in a manifest: a YAML list (or ``scenarios:`` list), relative to the manifest.

    Raises:
        InputError: not a regular file, too large, not YAML, not a list of paths (exit 2).
    """
    from jethr1_plan.io.input_file import read_input_text
    from jethr1_plan.io.yaml_input import count_values, load_yaml

    src = str(path)
    doc = load_yaml(read_input_text(path, MAX_MANIFEST_BYTES, "a manifest"), src)
    count_values(doc, src, 10 * MAX_SCENARIOS, "a manifest")
    key = "(top level)"
    if isinstance(doc, dict):
        unknown = sorted(set(doc) - {"scenarios"})
        if unknown:
            raise InputError(src, unknown[0], "unknown key (a manifest is a list of scenario paths, or scenarios: "
                             "that list)")
        doc, key = doc.get("scenarios"), "scenarios"
    if not isinstance(doc, list) or not doc:
        raise InputError(src, key, "expected a non-empty list of scenario paths")
    if len(doc) > MAX_SCENARIOS:
        raise InputError(src, key, f"{len(doc)} scenarios: at most {MAX_SCENARIOS} in one batch")
    for k, p in enumerate(doc):
        if not isinstance(p, str) or not p or len(p) > 4096:
            raise InputError(src, f"{key}[{k}]", "expected a scenario path (text)")
    return [(Path(path).parent / p) for p in doc]


def check_expectations(expect: dict, summary: dict) -> list[str]:
    """The expectations of a scenario's ``expect:`` block that do not hold, as sentences."""
    failed = []
    if "feasible" in expect and bool(summary.get("feasible")) != expect["feasible"]:
        failed.append(f"expected feasible={expect['feasible']}, got {summary.get('feasible')}")
    if "peak_thrust_n" in expect:
        got = summary.get("peak_thrust_n")
        if got is None or got > expect["peak_thrust_n"]:
            failed.append(f"expected max thrust <= {expect['peak_thrust_n']} N, got {got}")
    return failed


def run_scenario(path: str, outdir: str) -> dict:
    """Plan one scenario into OUTDIR/<stem>/ (as ``jethr1 plan`` does); return its batch record."""
    from jethr1_plan.errors import SelfCheckFailed
    from jethr1_plan.pipeline.plan import plan_to_folder
    from jethr1_plan.scenario import load_scenario

    record: dict[str, Any] = {"scenario": str(path), "name": Path(path).stem}
    try:
        scenario = load_scenario(path)
    except InputError as exc:
        return {**record, "status": "bad input", "error": str(exc), "exit_code": 2}
    infeasible: dict[str, Any] | None = None
    try:
        _, summary, _, _ = plan_to_folder(scenario, Path(outdir))
    except InfeasiblePlan as exc:
        summary = exc.summary or {}
        infeasible = {**record, "status": "infeasible", "error": str(exc), "summary": summary}
    except InputError as exc:  # its folder cannot be written (a file in the way, a full disk)
        return {**record, "status": "bad input", "error": str(exc), "exit_code": 2}
    except (Exception, SelfCheckFailed) as exc:  # a bug in one scenario must not lose every other scenario's result
        stop = interrupt_behind(exc)
        if stop is not None:  # Ctrl-C inside a compiled kernel: the user stopping the batch
            raise stop from None
        return {**record, "status": "error", "error": f"a bug: {type(exc).__name__}: {str(exc)[:200]}",
                "exit_code": 1}
    failed = check_expectations(scenario.expect, summary)
    out: dict[str, Any] = infeasible or {**record, "status": "feasible", "summary": summary}
    out["expect"] = scenario.expect
    out["expectations_failed"] = failed
    if failed:
        out["exit_code"] = 4
    elif infeasible is not None and scenario.expect.get("feasible") is not False:
        out["exit_code"] = 3
    else:
        out["exit_code"] = 0
    return out


def batch_exit_code(records: list[dict]) -> int:
    """1 if a scenario hit a bug, else 2 if any input was bad, else 4 if any expectation failed, else 3
    if any plan was unexpectedly infeasible, else 0."""
    codes = {r["exit_code"] for r in records}
    for code in (1, 2, 4, 3):
        if code in codes:
            return code
    return 0


def run_batch(paths: list[Path], outdir: Path, jobs: int = 1, executor: str = "loky", scheduler: str | None = None,
              progress=None) -> list[dict]:
    """Run every scenario (in parallel processes); records come back in the order given."""
    from joblib import Parallel, delayed, parallel_config

    from jethr1_plan.io.pool import parallel

    tasks = [delayed(run_scenario)(str(p), str(outdir)) for p in paths]
    if executor == "dask":
        from jethr1_plan.io.cluster import dask_client

        with dask_client(scheduler, jobs), parallel_config(backend="dask"):
            return list(Parallel()(tasks))
    records = []
    for k, rec in enumerate(parallel(jobs, return_as="generator")(tasks)):
        records.append(rec)
        if progress:
            progress(rec["name"], k + 1, len(tasks))
    return records
