"""io.record: the record of the files jethr1 wrote in a folder (each file's size and SHA-256) and the checks every
output passes before any work: only a file the record names, unchanged, may be replaced."""

from __future__ import annotations

import hashlib
import json
import os

import pytest

from jethr1_plan.errors import InputError
from jethr1_plan.io.record import (
    MAX_RECORD_BYTES,
    NAME_MAX,
    RECORD,
    check_names,
    check_targets,
    file_sha256,
    nearest_existing,
    read_record,
    record_text,
)


def _recorded(folder, **files: str) -> dict:
    """Write ``files`` and a record naming them as jethr1 would; the record."""
    entries = {}
    for name, text in files.items():
        (folder / name).write_text(text)
        entries[name] = {"sha256": hashlib.sha256(text.encode()).hexdigest(), "bytes": len(text.encode())}
    (folder / RECORD).write_text(record_text(entries))
    return entries


def test_the_sha256_is_the_files_bytes_digest(tmp_path) -> None:
    data = os.urandom(3 << 20)  # more than one read block
    (tmp_path / "f").write_bytes(data)
    assert file_sha256(tmp_path / "f") == hashlib.sha256(data).hexdigest()


def test_a_record_reads_back_as_written_and_only_its_well_formed_entries(tmp_path) -> None:
    entries = _recorded(tmp_path, **{"a.csv": "1,2\n", "summary.json": "{}\n"})
    assert read_record(tmp_path) == entries
    doc = json.loads((tmp_path / RECORD).read_text())
    doc["files"]["bad"] = {"sha256": 3, "bytes": "x"}  # not a record's entry: left out
    (tmp_path / RECORD).write_text(json.dumps(doc))
    assert read_record(tmp_path) == entries


def test_a_file_of_the_records_name_that_is_not_jethr1s_is_no_record(tmp_path) -> None:
    (tmp_path / RECORD).write_text(json.dumps({"files": {"a.csv": {"sha256": "0" * 64, "bytes": 1}}}))
    assert read_record(tmp_path) == {}  # no "written_by": "jethr1"
    with pytest.raises(InputError, match="not that record"):
        read_record(tmp_path, strict=True)
    (tmp_path / RECORD).write_bytes(b" " * (MAX_RECORD_BYTES + 1))
    assert read_record(tmp_path) == {}
    assert read_record(tmp_path / "nowhere") == {}


def test_only_files_the_record_names_unchanged_may_be_replaced(tmp_path) -> None:
    _recorded(tmp_path, **{"a.csv": "1\n"})
    check_targets(tmp_path, ["a.csv", "new.json"])  # recorded and unchanged; not there yet
    (tmp_path / "mine.txt").write_text("user's")
    with pytest.raises(InputError, match="did not write"):
        check_targets(tmp_path, ["mine.txt"])
    (tmp_path / "a.csv").write_text("2\n")  # same size, other bytes
    with pytest.raises(InputError, match="changed since jethr1 wrote it"):
        check_targets(tmp_path, ["a.csv"])
    # a digest already computed is trusted instead of the file's bytes
    check_targets(tmp_path, ["a.csv"], digests={"a.csv": hashlib.sha256(b"1\n").hexdigest()})


def test_a_name_longer_than_the_file_system_allows_is_refused(tmp_path) -> None:
    check_names(tmp_path, ["x" * NAME_MAX])
    with pytest.raises(InputError, match=f"allows {NAME_MAX}"):
        check_names(tmp_path, ["é" * (NAME_MAX // 2 + 1)])  # 2 bytes each in UTF-8


def test_the_nearest_existing_place_on_the_way(tmp_path) -> None:
    (tmp_path / "a").mkdir()
    assert nearest_existing(tmp_path / "a" / "b" / "c") == tmp_path / "a"
    assert nearest_existing(tmp_path / "a") == tmp_path / "a"
