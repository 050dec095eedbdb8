"""The message definitions the files carry: the standard ones are ROS 2 Jazzy's (as ``rosbags``
ships them), each schema appends every dependency once as rosbag2 does, the project's own types
name the unit of every number."""

from __future__ import annotations

import pytest

from jethr1_plan.files.cdr import parse_schema
from jethr1_plan.files.ros2_msgs import JETHR1_MSGS, MSGDEFS, STANDARD_MSGDEFS, dependencies, schema_text

typesys = pytest.importorskip("rosbags.typesys")


def test_standard_definitions_are_ros2_jazzy_ones():
    """Field names, types, array kinds and constants as rosbags' copy of ROS 2 Jazzy has them."""
    from rosbags.interfaces import Nodetype

    jazzy = typesys.get_typestore(typesys.Stores.ROS2_JAZZY).fielddefs
    for name, text in STANDARD_MSGDEFS.items():
        consts, fields = jazzy[name]
        ours = parse_schema(name, text)[name]
        assert [f.name for f in ours] == [fname for fname, _ in fields], name
        for f, (_, (node, desc)) in zip(ours, fields, strict=True):
            if node == Nodetype.SEQUENCE:
                assert f.array == -1, (name, f.name)
                node, desc = desc[0]
            else:
                assert f.array is None, (name, f.name)
            assert f.type == (desc if node == Nodetype.NAME else desc[0]), (name, f.name)
        constants = {line.split("=")[0].split()[-1]: int(line.split("=")[1])
                     for line in text.splitlines() if "=" in line}
        assert constants == {c: v for c, _, v in consts}, name


def test_schema_text_appends_each_dependency_once_as_rosbag2_does():
    text = schema_text("visualization_msgs/msg/MarkerArray")
    sections = text.split("\n" + "=" * 80 + "\n")
    assert sections[0] == MSGDEFS["visualization_msgs/msg/MarkerArray"]
    names = [s.split("\n", 1)[0] for s in sections[1:]]
    assert all(n.startswith("MSG: ") and n.count("/") == 1 for n in names)  # pkg/Type, as rosbag2 writes it
    assert len(names) == len(set(names)) == len(dependencies("visualization_msgs/msg/MarkerArray")) == 12
    assert "MSG: sensor_msgs/CompressedImage" in names  # Jazzy's Marker carries a texture


def test_own_types_resolve_and_name_their_units():
    for name in JETHR1_MSGS:
        types = parse_schema(name, schema_text(name))
        assert set(types) == {name, *dependencies(name)}
        numbers = [f for f in types[name] if f.type.startswith("float")]
        # a unit in the name, or a ratio named as one (a condition number, a share of the tolerance)
        assert numbers and all(f.name.endswith(("_n", "_m", "_nms", "_rad", "_s", "_rad_s")) or
                               f.name.startswith("kappa") or f.name.endswith("_share") for f in numbers), name
