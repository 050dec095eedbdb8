"""verify.common: a failure as one line naming its row, time and check; a CSV's header read without ever opening
what is not a regular file; a walk's files told from a plan's."""

from __future__ import annotations

import os

import pytest

from jethr1_plan.verify.common import Failure, csv_header, is_walk


def test_a_failure_reads_as_one_line() -> None:
    f = Failure(12, 0.24, "ZMP outside support", "3.1 mm outside edge 2")
    assert str(f) == "row 12 (t = 0.240 s): ZMP outside support: 3.1 mm outside edge 2"
    assert "\n" not in str(f)


def test_a_header_is_read_from_a_regular_text_file_only(tmp_path) -> None:
    (tmp_path / "a.csv").write_text("time_s,phase,yaw_ref_rad\n0,swing,0.1\n")
    assert csv_header(tmp_path / "a.csv") == ["time_s", "phase", "yaw_ref_rad"]
    (tmp_path / "b.csv").write_bytes(b"\xff\xfe\x00junk")
    assert csv_header(tmp_path / "b.csv") is None
    assert csv_header(tmp_path / "missing.csv") is None
    assert csv_header(tmp_path) is None


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs: POSIX")
def test_a_fifo_is_never_opened(tmp_path) -> None:
    os.mkfifo(tmp_path / "pipe.csv")
    assert csv_header(tmp_path / "pipe.csv") is None  # (opening it would block for a writer)


def test_a_walk_is_told_by_its_summary_or_else_its_header() -> None:
    assert is_walk({"kind": "walk"}) and not is_walk({"kind": "plan"}) and not is_walk({})
    assert is_walk(None, ["time_s", "yaw_ref_rad"]) and not is_walk(None, ["time_s"]) and not is_walk(None)
    assert not is_walk({"kind": "plan"}, ["yaw_ref_rad"])  # the summary decides where there is one
