"""Certificates of randomised rehearsals (sim/certificate.py): the Clopper–Pearson interval against
closed forms and the binomial tail, the per-trial draws, the inside-the-tolerance flags."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import binom

from jethr1_plan.sim.certificate import certificate, clopper_pearson, draws
from jethr1_plan.sim.rehearsal import Perturbation, held_tolerance

TOL = {"thrust_error": 0.1, "mass_error": 0.05, "com_error_m": 0.01, "source": "test"}


@pytest.mark.parametrize("n", [1, 10, 200])
def test_clopper_pearson_closed_forms(n):
    """All n survive: the lower end is (α/2)^(1/n) with α = 0.05 (0.98172 for n = 200); none survive:
    the upper end is 1 − (α/2)^(1/n)."""
    lo, hi = clopper_pearson(n, n)
    assert lo == pytest.approx(0.025 ** (1 / n), rel=1e-12) and hi == 1.0
    lo, hi = clopper_pearson(0, n)
    assert lo == 0.0 and hi == pytest.approx(1 - 0.025 ** (1 / n), rel=1e-12)
    if n == 200:
        assert clopper_pearson(200, 200)[0] == pytest.approx(0.98172, abs=1e-5)


@pytest.mark.parametrize(("k", "n"), [(9, 10), (190, 200), (1, 7), (57, 60)])
def test_clopper_pearson_is_where_the_binomial_tails_hold_2_5_percent(k, n):
    """The interval's ends, by definition: P(X ≥ k | p_lo) = 0.025 and P(X ≤ k | p_hi) = 0.025 (the
    binomial distribution itself, not the beta quantiles the code uses)."""
    lo, hi = clopper_pearson(k, n)
    assert binom.sf(k - 1, n, lo) == pytest.approx(0.025, rel=1e-8)
    assert binom.cdf(k, n, hi) == pytest.approx(0.025, rel=1e-8)
    assert lo < k / n < hi


def test_the_draws_are_per_trial_index():
    """Trial k's draw depends on (seed, k) alone: the first 3 of 8 are the 3 of 3; another seed differs."""
    assert draws(4, 8)[:3] == draws(4, 3)
    assert draws(4, 3) != draws(5, 3)
    assert draws(4, 3, "within_tolerance", TOL) == draws(4, 8, "within_tolerance", TOL)[:3]


def test_within_tolerance_draws_lie_inside_and_cover_it():
    ps = draws(0, 400, "within_tolerance", TOL)
    assert all(p.inside(TOL)["all"] for p in ps)
    gain = np.array([p.thrust_gain for p in ps])
    mass = np.array([p.mass_scale for p in ps])
    com = np.array([math.hypot(*p.com_offset_m) for p in ps])
    # uniform: near both ends of each range (400 draws leave a gap of 2 % at either end with p < 1e-3)
    assert gain.min() < 0.904 and gain.max() > 1.096 and mass.min() < 0.952 and mass.max() > 1.048
    assert com.max() > 0.0098 and np.mean(com < 0.005) == pytest.approx(0.25, abs=0.07)  # uniform over the disc
    # a minimal plan holds no tolerance: its draws are nominal in thrust, mass and CoM
    zero = {"thrust_error": 0.0, "mass_error": 0.0, "com_error_m": 0.0}
    assert all(p.thrust_gain == 1.0 and p.mass_scale == 1.0 and p.com_offset_m == (0.0, 0.0)
               for p in draws(0, 5, "within_tolerance", zero))


def test_the_inside_flags():
    assert Perturbation(1.05, (0.006, 0.008), 0.9, 0.07, 0.8).inside(TOL) == {
        "thrust": True, "mass": True, "com": True, "all": True}  # on the corner: inside
    flags = Perturbation(1.0, (0.0, 0.0), 0.85, 0.05, 1.0).inside(TOL)
    assert not flags["thrust"] and flags["mass"] and flags["com"] and not flags["all"]
    flags = Perturbation(0.94, (0.0, 0.0101), 1.0, 0.05, 1.0).inside(TOL)
    assert not flags["mass"] and not flags["com"] and flags["thrust"]
    # the default randomisation: thrust 0.8..1.1 reaches below the robust plans' −10 %
    ps = draws(0, 200)
    below = [p for p in ps if p.thrust_gain < 0.9]
    assert below and not any(p.inside(TOL)["all"] for p in below)


def test_the_held_tolerance():
    """A plan whose rows hold only a share of the scenario's tolerance holds the least share's."""
    summary = {"balance": {"tolerance": {"thrust_error": 0.1, "mass_error": 0.05, "com_error_m": 0.01}}}
    assert held_tolerance(summary)["thrust_error"] == 0.1
    summary["robustness"] = {"tolerance_share": {"least": 0.5, "tolerance": {
        "thrust_error": 0.05, "mass_error": 0.025, "com_error_m": 0.005}}}
    t = held_tolerance(summary)
    assert (t["thrust_error"], t["mass_error"], t["com_error_m"]) == (0.05, 0.025, 0.005)
    assert held_tolerance({})["thrust_error"] == 0.0


def test_the_certificate_counts_and_lists_the_failures():
    from jethr1_plan.sim.rehearsal import RunResult

    ps = [Perturbation(1.0, (0.0, 0.0), g, 0.05, 1.0) for g in (0.85, 0.95, 1.0, 1.05)]

    def run(p: Perturbation, ok: bool) -> RunResult:
        fell = None if ok else {"row": 3, "phase": "swing", "reason": "trunk tilted 10.2 deg"}
        return RunResult("feedback", True, p.__dict__ | {"com_offset_m": list(p.com_offset_m)}, ok, fell, 0.0, 0.0,
                         0.0, None, None, [], {}, 0.0, 0.0, 0.0)

    c = certificate([run(ps[0], False), run(ps[1], True), run(ps[2], False), run(ps[3], True)], ps, TOL, "default")
    assert (c["survived"], c["trials"]) == (2, 4) and c["lower_bound"] == pytest.approx(clopper_pearson(2, 4)[0])
    assert (c["inside_tolerance"]["survived"], c["inside_tolerance"]["trials"]) == (2, 3)
    assert [f["trial"] for f in c["failures"]] == [0, 2]
    assert not c["failures"][0]["inside_tolerance"]["all"] and c["failures"][1]["inside_tolerance"]["all"]
    assert c["failures"][0]["perturbation"]["thrust_gain"] == 0.85 and "Clopper" in c["method"]
