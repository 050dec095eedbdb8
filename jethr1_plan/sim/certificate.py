"""Certificates of randomised rehearsals (``jethr1 simulate --trials N``): how many of N randomised
runs survived, what that says about the survival probability, which runs failed and with what model
errors, and whether each draw lay inside the plan's tolerance.

The draws (:func:`draws`): trial k draws from its own generator, ``numpy.random.default_rng([seed,
k])``, so a trial's draw and verdict depend on the seed and k only, never on how many processes run
them. Two randomisations: the default (:meth:`~.rehearsal.Perturbation.draw`, wider than the robust
plans' tolerance on the thrust side) and ``within_tolerance``
(:meth:`~.rehearsal.Perturbation.draw_within`, only inside the tolerance the plan holds).

The bound: the runs are independent Bernoulli trials with the same survival probability p. With k
survivors of n, the Clopper–Pearson interval at confidence 1 − α is the exact binomial interval

    p_lo = B⁻¹(α/2; k, n − k + 1)   (0 when k = 0),    p_hi = B⁻¹(1 − α/2; k + 1, n − k)   (1 when k = n)

with B⁻¹ the beta distribution's quantile function. ``lower_bound`` is p_lo at 95 % (α = 0.05): the
lower end of the two-sided exact 95 % interval, so a one-sided bound at 97.5 %. When every run
survives, p_lo = (α/2)^(1/n): 0.9817 for n = 200, 0.6915 for n = 10.
"""

from __future__ import annotations

import math

import numpy as np

from jethr1_plan.robot.model import RobotModel
from jethr1_plan.sim.rehearsal import Perturbation, RunResult

__all__ = ["CONFIDENCE", "METHOD", "certificate", "clopper_pearson", "describe", "draws"]

CONFIDENCE = 0.95  # the interval's confidence (two-sided)
METHOD = ("Clopper–Pearson exact binomial interval, two-sided 95 % (its lower end is a one-sided 97.5 % "
          "lower bound on the survival probability)")
RANDOMISATIONS = ("default", "within_tolerance")


def clopper_pearson(k: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The exact (Clopper–Pearson) two-sided interval of a binomial probability from ``k`` successes
    in ``n`` trials, at ``confidence``."""
    from scipy.stats import beta

    if not (0 <= k <= n and n >= 1 and 0.0 < confidence < 1.0):
        raise ValueError(f"need 0 <= k <= n, n >= 1 and 0 < confidence < 1 (k={k}, n={n}, confidence={confidence})")
    a = (1.0 - confidence) / 2.0
    lo = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1.0 - a, k + 1, n - k))
    return lo, hi


def draws(seed: int, n: int, randomisation: str = "default", tolerance: dict | None = None,
          robot: RobotModel | None = None) -> list[Perturbation]:
    """The ``n`` trials' model errors: trial k from ``default_rng([seed, k])``; with the ``robot``, each
    trial's sensor errors too (after the model's, from the same generator: the model errors do not depend
    on whether the sensors are drawn)."""
    if randomisation not in RANDOMISATIONS:
        raise ValueError(f"randomisation {randomisation!r} is not one of {RANDOMISATIONS}")
    sensors, joints = (robot.sensors, len(robot.joint_names)) if robot is not None else (None, 0)
    if randomisation == "within_tolerance":
        if tolerance is None:
            raise ValueError("within_tolerance needs the plan's tolerance")
        return [Perturbation.draw_within(np.random.default_rng([seed, k]), tolerance, sensors, joints)
                for k in range(n)]
    return [Perturbation.draw(np.random.default_rng([seed, k]), sensors, joints) for k in range(n)]


def _bound(k: int, n: int) -> dict:
    if n == 0:
        return {"survived": 0, "trials": 0, "rate": None, "lower_bound": None, "upper_bound": None}
    lo, hi = clopper_pearson(k, n)
    return {"survived": k, "trials": n, "rate": k / n, "lower_bound": lo, "upper_bound": hi}


def _why(r: RunResult) -> str:
    if r.fell:
        return f"fell: {r.fell['reason']} at {r.fell['phase']} row {r.fell['row']}" + (
            f" of step {r.fell['step']}" if "run_time_s" in r.fell else "")
    if r.stopped:
        return f"stopped: {r.stopped}"
    return "off the cartons at the end"


def certificate(runs: list[RunResult], perturbations: list[Perturbation], tolerance: dict, randomisation: str
                ) -> dict:
    """The certificate of ``runs`` (in trial order, drawn as ``perturbations``) for ``simulation.json``:
    the survival count and its 95 % Clopper–Pearson interval, the same over the draws inside the plan's
    ``tolerance``, each trial's inside flags, and every failure with its drawn model errors."""
    inside = [p.inside(tolerance) for p in perturbations]
    ok = [r.survived for r in runs]
    k_in = [s for s, f in zip(ok, inside, strict=True) if f["all"]]
    failures = [{"trial": i, "perturbation": r.perturbation, "inside_tolerance": inside[i], "why": _why(r)}
                for i, r in enumerate(runs) if not r.survived]
    return {
        "method": METHOD,
        "confidence": CONFIDENCE,
        "randomisation": randomisation,
        "tolerance": dict(tolerance),
        **_bound(sum(ok), len(ok)),
        "inside_tolerance": _bound(sum(k_in), len(k_in)),
        "inside": inside,
        "failures": failures,
    }


def describe(cert: dict) -> list[str]:
    """The certificate in a few lines for the terminal."""
    t = cert["tolerance"]
    tol = (f"±{100 * t['thrust_error']:.1f} % thrust, ±{100 * t['mass_error']:.1f} % mass, "
           f"{1000 * t['com_error_m']:.1f} mm CoM")

    def line(b: dict, what: str) -> str:
        if not b["trials"]:
            return f"{what}: no draw"
        return (f"{what}: {b['survived']}/{b['trials']} survived; survival probability ≥ {b['lower_bound']:.4f} "
                f"(95 % Clopper–Pearson interval [{b['lower_bound']:.4f}, {b['upper_bound']:.4f}])")

    out = [line(cert, f"certificate ({cert['randomisation'].replace('_', ' ')} randomisation)"),
           line(cert["inside_tolerance"], f"  draws inside the plan's tolerance ({tol})")]
    for f in cert["failures"]:
        p, flags = f["perturbation"], f["inside_tolerance"]
        outside = ", ".join(k for k in ("thrust", "mass", "com") if not flags[k])
        out.append(f"  failed trial {f['trial']}: {f['why']}; thrust x{p['thrust_gain']:.4f}, "
                   f"mass x{p['mass_scale']:.4f}, CoM {1000 * math.hypot(*p['com_offset_m']):.1f} mm, "
                   f"lag {1000 * p['fan_lag_s']:.0f} ms, stiffness x{p['servo_stiffness_scale']:.3f}; "
                   f"inside the tolerance: {'yes' if flags['all'] else f'no ({outside})'}")
    return out
