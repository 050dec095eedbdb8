"""viewer.files: what a path given to ``jethr1 view`` holds, from the topics of the MCAP files written there (no
Rerun needed): a plan with its rehearsal, a walk, a balance space, or one of their files; anything else refused."""

from __future__ import annotations

import pytest

from jethr1_plan.errors import InputError
from jethr1_plan.viewer.files import kind_of, view_files


def test_each_folder_is_the_kind_its_files_say(written) -> None:
    plan = view_files(written["plan"])
    assert plan.kind == "plan"
    assert [(f.name, prefix) for f, prefix in plan.files] == [("trajectory.mcap", "plan"),
                                                              ("simulation.mcap", "rehearsal")]
    walk = view_files(written["walk"])
    assert walk.kind == "walk" and [f.name for f, _ in walk.files] == ["trajectory.mcap"]
    space = view_files(written["balance_space"])
    assert space.kind == "balance space" and space.files[0][1] == "balance_space"


def test_a_single_file_is_shown_as_what_it_holds(written) -> None:
    assert kind_of(written["plan"] / "simulation.mcap") == "rehearsal"
    found = view_files(written["plan"] / "simulation.mcap")
    assert found.kind == "rehearsal" and found.files[0][1] == "rehearsal"


def test_what_jethr1_did_not_write_is_refused(tmp_path) -> None:
    with pytest.raises(InputError, match=r"no trajectory\.mcap"):
        view_files(tmp_path)
    (tmp_path / "x.mcap").write_bytes(b"not an mcap file")
    with pytest.raises(InputError, match=r"not a valid MCAP file"):
        view_files(tmp_path / "x.mcap")
