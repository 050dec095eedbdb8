"""The thrust limit has one spelling, ``thrust_max_n``; the largest thrust a plan uses is ``peak_thrust_n``. A file
that still spells a key the earlier way gets one line naming the key and its new spelling (exit 2, nothing
written), whichever file it is: a robot's fans, a scenario's expectations, a design's fans."""

from __future__ import annotations

import pytest
import yaml

from jethr1_plan.cli import run
from jethr1_plan.io.yaml_input import RENAMED_KEYS
from tests.conftest import ROOT
from tests.oracles.robot_copies import tampered_jethr1


def _robot(tmp_path):
    def edit(d):
        d["fans"][1]["max_thrust_n"] = d["fans"][1].pop("thrust_max_n")
    return ["robot", "show", str(tampered_jethr1(tmp_path / "bot", edit))], "fans[1].max_thrust_n", "thrust_max_n"


def _scenario(tmp_path):
    doc = yaml.safe_load((ROOT / "configs" / "side_step.yaml").read_text())
    doc["expect"]["max_thrust_n"] = doc["expect"].pop("peak_thrust_n")
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(doc))
    return ["plan", str(path), "-o", str(tmp_path / "out")], "expect.max_thrust_n", "peak_thrust_n"


def _design(tmp_path):
    text = (ROOT / "configs" / "designs" / "jethr1_fans.yaml").read_text().replace("thrust_max_n:", "max_thrust_n:", 1)
    path = tmp_path / "d.yaml"
    path.write_text(text)
    return (["design", str(path), "-o", str(tmp_path / "out"), "--cache", str(tmp_path / "cache")],
            "fans[0].max_thrust_n", "thrust_max_n")


@pytest.mark.parametrize("case", [_robot, _scenario, _design])
def test_an_old_spelling_is_named_with_its_new_one(tmp_path, capsys, case):
    args, key, new = case(tmp_path)
    assert run(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].endswith(f"{key}: renamed: write {new} instead"), err
    assert not (tmp_path / "out").exists()


def test_the_shipped_files_use_the_new_spellings():
    """Every shipped robot's fans and every shipped scenario's expectations read with the new keys."""
    fans = [f for p in sorted((ROOT / "robots").glob("*/*.yaml"))
            for f in (yaml.safe_load(p.read_text()) or {}).get("fans", [])]
    assert fans and all("thrust_max_n" in f and not set(f) & set(RENAMED_KEYS) for f in fans)
    expects = [yaml.safe_load(p.read_text()).get("expect") or {} for p in sorted((ROOT / "configs").glob("*.yaml"))]
    assert any("peak_thrust_n" in e for e in expects) and not any(set(e) & set(RENAMED_KEYS) for e in expects)
