"""The planner runs BLAS on one thread (a multi-threaded BLAS sums in another order, so a plan would depend
on the machine's cores and on ``-j``): both BLAS libraries it calls, numpy's and the one SciPy's SLSQP step
links, are loaded and limited to one thread inside :func:`one_blas_thread`."""

from __future__ import annotations

import json
import subprocess
import sys

PROBE = """
import json, os
from threadpoolctl import threadpool_info
from jethr1_plan.planning.plan import one_blas_thread
with one_blas_thread():
    inside = [(os.path.basename(i["filepath"]), i["num_threads"]) for i in threadpool_info()
              if i["user_api"] == "blas"]
print(json.dumps(inside))
"""


def test_both_blas_libraries_are_loaded_and_limited_to_one_thread() -> None:
    env_free = {"PATH": "/usr/bin:/bin", "OPENBLAS_NUM_THREADS": "4", "OMP_NUM_THREADS": "4"}
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, check=True, env=env_free)
    libs = dict(json.loads(out.stdout.strip().splitlines()[-1]))
    scipy_blas = [name for name in libs if "scipy_openblas" in name and "64_" not in name]
    numpy_blas = [name for name in libs if name not in scipy_blas]
    assert scipy_blas, f"SciPy's BLAS (which SLSQP calls) is not loaded, so it could not be limited: {libs}"
    assert numpy_blas, f"numpy's BLAS is not loaded: {libs}"
    assert all(n == 1 for n in libs.values()), libs
