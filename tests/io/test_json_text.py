"""Reading jethr1's JSON documents back: bounded in depth and size, one line for every problem."""

from __future__ import annotations

import pytest

from jethr1_plan.errors import InputError
from jethr1_plan.io.json_text import MAX_JSON_DEPTH, json_text, read_json


def test_a_written_document_reads_back(tmp_path):
    doc = {"a": [1, 2.5, None], "b": {"c": "d"}, "nan": float("nan")}
    (tmp_path / "s.json").write_text(json_text(doc))
    assert read_json(tmp_path / "s.json") == {"a": [1, 2.5, None], "b": {"c": "d"}, "nan": None}


@pytest.mark.parametrize("text, words", [
    ("[" * 100_000 + "]" * 100_000, "nested more than"),  # json's own recursion limit: no RecursionError
    ('{"a": ' + "[" * (MAX_JSON_DEPTH + 1) + "]" * (MAX_JSON_DEPTH + 1) + "}", "nested more than"),
    ("[1, 2]", "expected a JSON object"),
    ("{not json", "cannot read"),
    ("\udce9", "cannot read"),
])
def test_a_malformed_document_is_one_line(tmp_path, text, words):
    (tmp_path / "s.json").write_bytes(text.encode("utf-8", "surrogateescape"))
    with pytest.raises(InputError, match=words) as err:
        read_json(tmp_path / "s.json")
    assert "\n" not in str(err.value)


def test_a_huge_document_is_refused_before_it_is_parsed(tmp_path):
    (tmp_path / "s.json").write_text('{"a": "' + "x" * 2000 + '"}')
    with pytest.raises(InputError, match="larger than a JSON document can be"):
        read_json(tmp_path / "s.json", max_bytes=1000)
