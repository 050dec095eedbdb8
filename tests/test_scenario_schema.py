"""scenario_schema: every key of a scenario known and every number bounded; the names its choices take are the
ones the loader and the planner act on."""

from __future__ import annotations

import dataclasses

from jethr1_plan.optimisers import METHODS
from jethr1_plan.physics.balance import Tolerance
from jethr1_plan.scenario import ROBUST_DEFAULT, BalanceConfig, BodyYaw, Timing
from jethr1_plan.scenario_schema import (
    MAX_SAMPLES,
    MIN_RATE_HZ,
    POLICIES,
    SCHEMA,
    TIMING_MODES,
    TOLERANCE_KEYS,
    YAW_MODES,
)


def _numbers(node, path=""):
    """(path, schema) of every number or integer in the schema."""
    if isinstance(node, dict):
        if node.get("type") in ("number", "integer"):
            yield path, node
        for k, v in node.items():
            yield from _numbers(v, f"{path}.{k}")
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _numbers(v, f"{path}[{i}]")


def test_every_number_is_bounded_on_both_sides() -> None:
    found = list(_numbers(SCHEMA))
    assert len(found) > 40
    for path, node in found:
        assert {"minimum", "exclusiveMinimum"} & set(node), path
        assert {"maximum", "exclusiveMaximum"} & set(node), path


def test_every_object_refuses_unknown_keys() -> None:
    def objects(node):
        if isinstance(node, dict):
            if node.get("type") == "object":
                yield node
            for v in node.values():
                yield from objects(v)
        elif isinstance(node, list):
            for v in node:
                yield from objects(v)

    assert all(o["additionalProperties"] is False for o in objects(SCHEMA))


def test_the_choices_are_the_ones_the_loader_acts_on() -> None:
    props = SCHEMA["properties"]
    assert props["optimiser"]["properties"]["method"]["enum"] == list(METHODS)
    assert props["balance"]["properties"]["policy"]["enum"] == list(POLICIES)
    assert props["body_yaw"]["properties"]["mode"]["enum"] == list(YAW_MODES)
    assert props["timing"]["properties"]["mode"]["enum"] == list(TIMING_MODES)
    assert props["timing"]["properties"]["rate_hz"]["minimum"] == MIN_RATE_HZ
    arc = props["steps"]["items"]["properties"]["path"]["oneOf"][0]["properties"]
    assert arc["samples"]["maximum"] == MAX_SAMPLES
    assert BalanceConfig().policy in POLICIES and BodyYaw().mode in YAW_MODES and Timing().mode in TIMING_MODES


def test_the_tolerance_keys_name_every_field_of_a_tolerance() -> None:
    assert sorted(TOLERANCE_KEYS.values()) == sorted(f.name for f in dataclasses.fields(Tolerance))
    robust = SCHEMA["properties"]["balance"]["properties"]["robust"]["properties"]
    assert set(TOLERANCE_KEYS) <= set(robust)
    assert all(getattr(ROBUST_DEFAULT, f) <= robust[k]["maximum"] for k, f in TOLERANCE_KEYS.items())
