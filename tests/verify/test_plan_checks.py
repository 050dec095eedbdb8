"""verify's checks as a list of named functions: each name once, in the documented order, and the
verifier runs every one of them (a tampered row fails the named check, nothing else crashes)."""

from __future__ import annotations

import re

from jethr1_plan.verify.plan import CHECKS
from tests.conftest import ROOT


def test_every_check_is_named_once_and_documented_in_order():
    names = [c.name for c in CHECKS]
    assert len(names) == len(set(names)) == 36
    doc = (ROOT / "docs" / "safety.md").read_text()
    table = doc.split("### The checks of `verify`")[1].split("\n## ")[0]
    rows = re.findall(r"^\| ([^|]+?) \| ([^|]+?) \|$", table, re.M)[1:]
    assert [(n, w) for n, w in rows] == [(c.name, c.what) for c in CHECKS]


def test_every_check_says_what_it_holds_and_reads_what_it_needs():
    from jethr1_plan.files.plan_table import columns
    from jethr1_plan.robot.load import load_robot

    every = set(columns(load_robot("jethr1")))
    for c in CHECKS:
        assert c.what and c.name == c.name.strip() and callable(c.test)
        assert set(c.needs) <= every, c.name
