"""The ROS 2 MCAP files of every kind (plan, rehearsal, walk, balance space), read by tools that share
no code with the writer: ``rosbags`` decodes every message from the definitions stored in the file
alone and serialises each back to the very bytes written; ``mcap_ros2`` (our reader) agrees with it;
the channels are the declared topics with their QoS; no JSON channel is left, and a check of the
viewers' JSON-schema rules (the defects that dropped 7 of 29 channels in Lichtblick) would catch
one; the same input gives the same bytes; the docs print the declared topics."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from jethr1_plan.files.balance_space import BALANCE_SPACE_TOPICS
from jethr1_plan.files.mcap import Topic, read_mcap, topics_markdown
from jethr1_plan.files.messages import EPOCH_NS
from jethr1_plan.files.plan_mcap import PLAN_TOPICS
from jethr1_plan.files.ros2_msgs import schema_text
from jethr1_plan.files.route import ROUTE_TOPICS
from jethr1_plan.files.simulation import SIMULATION_TOPICS
from jethr1_plan.files.walk_folder import WALK_TOPICS
from tests.conftest import ROOT

rosbags_highlevel = pytest.importorskip("rosbags.highlevel")
from rosbags.typesys import Stores, get_typestore  # noqa: E402

DECLARED: dict[str, dict[str, Topic]] = {"trajectory": PLAN_TOPICS, "simulation": SIMULATION_TOPICS,
                                         "walk": WALK_TOPICS, "balance_space": BALANCE_SPACE_TOPICS,
                                         "route": ROUTE_TOPICS}
KINDS = tuple(DECLARED)
TRANSIENT_LOCAL, VOLATILE = 1, 2  # rmw's durability values


@pytest.fixture(scope="module")
def files(written, small_route) -> dict[str, Path]:
    return {"trajectory": written["plan"] / "trajectory.mcap", "simulation": written["plan"] / "simulation.mcap",
            "walk": written["walk"] / "trajectory.mcap",
            "balance_space": written["balance_space"] / "balance_space.mcap", "route": small_route / "route.mcap",
            "route_plan": small_route / "trajectory.mcap"}


@pytest.mark.parametrize("kind", KINDS)
def test_rosbags_decodes_every_message_and_writes_it_back_to_the_same_bytes(files, kind):
    """With an empty type store: only the definitions the file carries. rosbags also parses the QoS
    ``ros2 bag play`` would publish with."""
    n = 0
    with rosbags_highlevel.AnyReader([files[kind]], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        assert {c.topic: c.msgtype for c in reader.connections} == {k: t.type for k, t in DECLARED[kind].items()}
        for c in reader.connections:
            (qos,) = c.ext.offered_qos_profiles
            assert qos.durability.name == ("TRANSIENT_LOCAL" if DECLARED[kind][c.topic].latched else "VOLATILE")
            assert (qos.reliability.name, qos.history.name) == ("RELIABLE", "KEEP_LAST")
        store = reader.typestore
        counts: dict[str, int] = {}
        for conn, _, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            assert bytes(store.serialize_cdr(msg, conn.msgtype)) == bytes(raw), conn.topic
            counts[conn.topic] = counts.get(conn.topic, 0) + 1
            n += 1
    assert set(counts) == set(DECLARED[kind])  # every declared topic carries messages
    assert n == len(read_mcap(files[kind].read_bytes()))


@pytest.mark.parametrize("kind", KINDS)
def test_our_reader_agrees_with_rosbags(files, kind):
    ours = read_mcap(files[kind].read_bytes())
    with rosbags_highlevel.AnyReader([files[kind]], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        theirs = [(c.topic, c.msgtype, t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages()]
    assert all(a[3] <= b[3] for a, b in itertools.pairwise(ours))  # ours in log time
    # messages of one log time on several topics come in no order the format fixes (rosbags 0.11.0 interleaves
    # them otherwise than later releases): both compared in (log time, topic) order, each topic's own kept
    ours = sorted(ours, key=lambda m: (m[3], m[0]))
    theirs = sorted(theirs, key=lambda m: (m[2], m[0]))
    assert [(topic, name, t) for topic, name, _, t in ours] == [(topic, name, t) for topic, name, t, _ in theirs]
    for (topic, _, a, _), (_, _, _, b) in zip(ours, theirs, strict=True):
        if hasattr(a, "header"):
            assert (a.header.stamp.sec, a.header.stamp.nanosec, a.header.frame_id) == \
                   (b.header.stamp.sec, b.header.stamp.nanosec, b.header.frame_id), topic
        if hasattr(a, "pose"):
            assert (a.pose.position.x, a.pose.position.z, a.pose.orientation.w) == \
                   (b.pose.position.x, b.pose.position.z, b.pose.orientation.w), topic
        if hasattr(a, "position"):
            np.testing.assert_array_equal(a.position, b.position)


@pytest.mark.parametrize("kind", KINDS)
def test_ros2_profile_declared_channels_qos_and_no_json(files, kind):
    from mcap.reader import make_reader

    with files[kind].open("rb") as f:
        reader = make_reader(f)
        header, summary = reader.get_header(), reader.get_summary()
    assert (header.profile, header.library) == ("ros2", "jethr1-plan")  # no version: same input, same bytes
    assert summary is not None
    channels = sorted(summary.channels.values(), key=lambda c: c.id)
    assert [c.topic for c in channels] == list(DECLARED[kind])  # registered in the declared order
    for channel in channels:
        schema = summary.schemas[channel.schema_id]
        declared = DECLARED[kind][channel.topic]
        assert (channel.message_encoding, schema.encoding, schema.name) == ("cdr", "ros2msg", declared.type)
        assert schema.data.decode() == schema_text(schema.name)
        (qos,) = yaml.safe_load(channel.metadata["offered_qos_profiles"])
        assert qos["durability"] == (TRANSIENT_LOCAL if declared.latched else VOLATILE), channel.topic
        assert (qos["reliability"], qos["history"], qos["depth"]) == (1, 1, 1 if declared.latched else 10)
    assert json_channel_problems(files[kind]) == []
    messages = read_mcap(files[kind].read_bytes())
    assert min(t for *_, t in messages) == EPOCH_NS  # 2000-01-01T00:00:00Z


def test_what_a_subscriber_relies_on_is_declared_once():
    """The topics a ROS 2 user wires to: the URDF and static frames latched, the controller's trajectory
    and the states volatile, in each file that has them."""
    for topics in (PLAN_TOPICS, WALK_TOPICS):
        assert topics["/robot_description"] == Topic("std_msgs/msg/String", True, topics["/robot_description"].what)
        assert topics["/tf_static"].latched and not topics["/tf"].latched
        assert topics["/joint_trajectory"].type == "trajectory_msgs/msg/JointTrajectory"
        assert topics["/joint_states"].type == "sensor_msgs/msg/JointState"
    assert SIMULATION_TOPICS["/sim/robot_description"].latched
    assert all(t.latched for t in BALANCE_SPACE_TOPICS.values())


def test_the_docs_print_the_declared_topics():
    page = (ROOT / "docs" / "files_and_viewers.md").read_text(encoding="utf-8")
    for topics in DECLARED.values():
        assert topics_markdown(topics) in page


@pytest.mark.parametrize("layout, kinds, urdf_topics", [
    ("LAYOUT", ("trajectory", "simulation"), {"/robot_description", "/sim/robot_description"}),
    ("WALK_LAYOUT", ("walk",), {"/robot_description"}),
    ("BALANCE_SPACE_LAYOUT", ("balance_space",), set()),
    ("ROUTE_LAYOUT", ("route_plan", "route", "simulation"), {"/robot_description", "/sim/robot_description"})])
def test_the_shipped_layouts_read_what_the_files_have(files, layout, kinds, urdf_topics):
    """Every plot path of a layout (``/topic.field[index]``) resolves to a number on a message of its
    files; its URDF layers and 3D topics are topics the files carry."""
    from jethr1_plan.cli.plan import BALANCE_SPACE_LAYOUT, LAYOUT, ROUTE_LAYOUT, WALK_LAYOUT

    shipped = {"LAYOUT": LAYOUT, "WALK_LAYOUT": WALK_LAYOUT, "BALANCE_SPACE_LAYOUT": BALANCE_SPACE_LAYOUT,
               "ROUTE_LAYOUT": ROUTE_LAYOUT}
    first = {}
    for kind in kinds:
        for topic, _, msg, _ in read_mcap(files[kind].read_bytes()):
            first.setdefault(topic, msg)
    panels = json.loads(shipped[layout].read_text())["configById"]
    urdf = [v for p in panels.values() for v in p.get("layers", {}).values() if v["layerId"] == "foxglove.Urdf"]
    assert {layer["topic"] for layer in urdf} == urdf_topics
    paths = [p["value"] for name, panel in panels.items() if name.startswith("Plot!") for p in panel["paths"]]
    for path in paths:
        topic, _, field = path.partition(".")
        value = first[topic]
        for part in field.replace("]", "").split("."):
            name, _, index = part.partition("[")
            value = getattr(value, name)
            if index:
                value = value[int(index)]
        assert isinstance(value, float), path
    (scene,) = [p for k, p in panels.items() if k.startswith("3D!")]
    assert set(scene["topics"]) <= set(first) and scene["topics"]


# --- the viewers' JSON-schema subset -------------------------------------------------------------------

_JSON_TYPES = frozenset({"boolean", "string", "number", "integer", "object", "array"})


def json_schema_problems(schema: dict, where: str = "$") -> list[str]:
    """Where a JSON schema leaves the subset Foxglove's and Lichtblick's parser takes (a channel with
    any is dropped whole): every object ``"type": "object"``, every property one type or a ``oneOf`` of
    numeric ``const``s, every array ``items`` with a type."""
    if "oneOf" in schema:
        ok = all(isinstance(o, dict) and isinstance(o.get("const"), int | float) and not isinstance(o["const"], bool)
                 for o in schema["oneOf"])
        return [] if ok else [f"{where}: a oneOf of something else than numeric consts"]
    kind = schema.get("type")
    if isinstance(kind, list):
        return [f"{where}: a list of types {kind}"]
    if kind not in _JSON_TYPES:
        return [f"{where}: " + ("a bare enum" if "enum" in schema else f"type {kind!r}")]
    out = []
    if kind == "object":
        for key, sub in schema.get("properties", {}).items():
            out += json_schema_problems(sub, f"{where}.{key}")
    elif kind == "array":
        items = schema.get("items")
        if not isinstance(items, dict) or ("type" not in items and "oneOf" not in items):
            out.append(f"{where}: an array without typed items")
        else:
            out += json_schema_problems(items, f"{where}[]")
    return out


def json_channel_problems(path: Path) -> list[str]:
    """The problems of every JSON channel of an MCAP file (a message that is not an object is one)."""
    from mcap.reader import make_reader

    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    out = []
    for channel in summary.channels.values() if summary else []:
        if channel.message_encoding == "json":
            doc = json.loads(summary.schemas[channel.schema_id].data)  # type: ignore[union-attr]
            out += [f"{channel.topic}: {p}" for p in json_schema_problems(doc)]
            if doc.get("type") != "object":
                out.append(f"{channel.topic}: the message is not an object")
    return out


def test_the_json_rules_catch_the_defects_lichtblick_dropped(tmp_path):
    """The old thrust window's list of types, its bare support enum and a SceneUpdate's arrays without
    items are flagged, in a schema and in a file; a well-formed schema passes."""
    from mcap.writer import Writer

    bad = {"type": "object", "properties": {
        "window_lo_n": {"type": ["number", "null"]}, "support": {"enum": ["left", "right", "both"]},
        "entities": {"type": "array", "items": {"type": "object", "properties": {"arrows": {"type": "array"}}}}}}
    problems = json_schema_problems(bad)
    assert problems == ["$.window_lo_n: a list of types ['number', 'null']", "$.support: a bare enum",
                        "$.entities[].arrows: an array without typed items"]
    good = {"type": "object", "properties": {"kind": {"oneOf": [{"const": 0}, {"const": 1}]},
                                             "xs": {"type": "array", "items": {"type": "number"}}}}
    assert json_schema_problems(good) == []
    path = tmp_path / "old.mcap"
    with path.open("wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema("jethr1.Thrust", "jsonschema", json.dumps(bad).encode())
        w.register_channel("/thrust", "json", sid)
        w.finish()
    assert len(json_channel_problems(path)) == 3


# --- bytes ------------------------------------------------------------------------------------------------


def test_same_input_same_bytes(files, written):
    """The plan written again from what its MCAP says: the same bytes (the fixed epoch, no versions,
    messages in log-time then declared-topic order; the table read back is the table written)."""
    from jethr1_plan.files.plan_mcap import table_mcap
    from jethr1_plan.folders.plan import read_plan

    plan = read_plan(written["plan"])
    zmp_z = np.array([m.pose.position.z for topic, _, m, _ in read_mcap(files["trajectory"].read_bytes(), ["/zmp"])])
    f = files["trajectory"]
    again = table_mcap(plan.robot, plan.tables[f], plan.cartons, plan.swing_paths[f], zmp_z)
    assert again == files["trajectory"].read_bytes()
    times = [t for *_, t in read_mcap(again, ordered=False)]
    assert times == sorted(times)
