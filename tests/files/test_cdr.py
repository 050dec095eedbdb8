"""The columnar CDR encoder against an independent one (``rosbags``) on layouts that need care:
strings of varying length per message, ragged and empty sequences, bools and int8 between float64s
(alignment), sequences of messages given by columns and as lists, fixed arrays."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.files.cdr import CdrEncoder, parse_schema

typesys = pytest.importorskip("rosbags.typesys")

DEFINITION = """\
string label
bool flag
float64[] ragged
int8 small
float64 big
geometry_msgs/Point[] points
Pair[2] pairs
Pair[] listed
uint8[3] rgb
string[] names
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: test_msgs/Pair
uint8 a
float64 b
"""
NAME = "test_msgs/msg/Awkward"


def test_columnar_encoder_agrees_with_rosbags_byte_for_byte():
    encoder = CdrEncoder(parse_schema(NAME, DEFINITION))
    n = 5
    labels = ["", "a", "abc", "a", "abcdefgh"]
    flags = [True, False, True, True, False]
    ragged = [np.arange(k, dtype=float) for k in (0, 1, 3, 1, 2)]
    data = encoder.encode(NAME, {
        "label": labels, "flag": np.array(flags), "ragged": ragged,
        "small": np.arange(n, dtype=np.int8) - 2, "big": np.linspace(-1, 1, n),
        "points": {"x": np.array([1.0, 2.0]), "y": np.array([3.0, 4.0]), "z": np.array([5.0, 6.0])},
        "pairs": {"a": np.array([7, 8]), "b": np.array([0.5, 0.25])},
        "listed": [{"a": 1, "b": 2.0}], "rgb": np.array([1, 2, 3]), "names": ["x", "yz"]}, n)
    store = typesys.get_typestore(typesys.Stores.EMPTY)
    store.register({**typesys.get_types_from_msg("float64 x\nfloat64 y\nfloat64 z\n", "geometry_msgs/msg/Point"),
                    **typesys.get_types_from_msg("uint8 a\nfloat64 b\n", "test_msgs/msg/Pair"),
                    **typesys.get_types_from_msg(DEFINITION.split("=" * 80)[0], NAME)})
    for i in range(n):
        msg = store.deserialize_cdr(data[i], NAME)
        assert msg.label == labels[i] and bool(msg.flag) == flags[i]
        np.testing.assert_array_equal(msg.ragged, ragged[i])
        assert (msg.small, msg.big) == (i - 2, np.linspace(-1, 1, n)[i])
        assert [(p.x, p.y, p.z) for p in msg.points] == [(1, 3, 5), (2, 4, 6)]
        assert [(p.a, p.b) for p in msg.pairs] == [(7, 0.5), (8, 0.25)]
        assert [(p.a, p.b) for p in msg.listed] == [(1, 2.0)] and list(msg.rgb) == [1, 2, 3]
        assert list(msg.names) == ["x", "yz"]
        assert bytes(store.serialize_cdr(msg, NAME)) == data[i]


def test_wrong_fields_and_shapes_are_refused():
    encoder = CdrEncoder(parse_schema(NAME, DEFINITION))
    with pytest.raises(KeyError):
        encoder.encode(NAME, {"lable": "typo"})
    with pytest.raises(ValueError):
        encoder.encode(NAME, {"big": np.zeros(3)}, n=2)
    with pytest.raises(ValueError):
        encoder.encode(NAME, {"rgb": np.array([1, 2])})


def test_elements_whose_layout_alternates_and_long_sequences_agree_with_rosbags():
    """An element of a float64 then a float32 takes 12 bytes from an 8-aligned start and 16 from a 4-aligned
    one: its layouts alternate (laid out per element). 10,000 points share one layout (laid out with a stride)."""
    definition = "test_msgs/Odd[] odd\ngeometry_msgs/Point[] points\n" + "=" * 80 + \
        "\nMSG: test_msgs/Odd\nfloat64 b\nfloat32 a\n" + "=" * 80 + \
        "\nMSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n"
    name = "test_msgs/msg/Long"
    encoder = CdrEncoder(parse_schema(name, definition))
    rng = np.random.default_rng(0)
    b, a = rng.normal(size=7), rng.normal(size=7).astype(np.float32)
    x, y, z = rng.normal(size=(3, 10_000))
    data = encoder.encode(name, {"odd": {"b": b, "a": a}, "points": {"x": x, "y": y, "z": z}}, 2)
    store = typesys.get_typestore(typesys.Stores.EMPTY)
    store.register({**typesys.get_types_from_msg("float64 x\nfloat64 y\nfloat64 z\n", "geometry_msgs/msg/Point"),
                    **typesys.get_types_from_msg("float64 b\nfloat32 a\n", "test_msgs/msg/Odd"),
                    **typesys.get_types_from_msg(definition.split("=" * 80)[0], name)})
    for raw in data:
        msg = store.deserialize_cdr(raw, name)
        assert [(o.b, o.a) for o in msg.odd] == list(zip(b.tolist(), a.tolist(), strict=True))
        assert np.array_equal([p.x for p in msg.points], x) and np.array_equal([p.z for p in msg.points], z)
        assert bytes(store.serialize_cdr(msg, name)) == raw
