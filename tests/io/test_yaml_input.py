"""Reading YAML input: a key given twice is refused (PyYAML alone keeps the last), and bounds read
as what they are."""

from __future__ import annotations

import pytest

from jethr1_plan.errors import InputError
from jethr1_plan.io.yaml_input import read_document

SCHEMA = {"type": "object", "properties": {"rate_hz": {"type": "number", "exclusiveMinimum": 0},
                                            "gain": {"type": "number", "exclusiveMaximum": 1}}}


@pytest.mark.parametrize("text, where", [("seed: 1\nseed: 2\n", "line 2"), ("a:\n  b: 1\n  c: 2\n  b: 3\n", "line 4"),
                                         ("{x: 1, x: 1}\n", "line 1")])
def test_a_key_given_twice_is_refused(text, where):
    with pytest.raises(InputError, match=rf"f.yaml: {where}: not valid YAML: the key '\w+' appears twice"):
        read_document(text, "f.yaml", {"type": "object"}, 100, "a test")


def test_merge_keys_and_lists_of_mappings_still_read():
    doc = read_document("base: &b {x: 1}\nmore:\n  <<: *b\n  x: 2\nitems: [{x: 1}, {x: 1}]\n", "f.yaml",
                        {"type": "object"}, 100, "a test")
    assert doc["more"] == {"x": 2} and doc["items"] == [{"x": 1}, {"x": 1}]


def test_exclusive_bounds_read_as_what_they_are():
    with pytest.raises(InputError, match=r"rate_hz: 0: must be more than 0$"):
        read_document("rate_hz: 0\n", "f.yaml", SCHEMA, 100, "a test")
    with pytest.raises(InputError, match=r"gain: 1: must be less than 1$"):
        read_document("gain: 1\n", "f.yaml", SCHEMA, 100, "a test")
