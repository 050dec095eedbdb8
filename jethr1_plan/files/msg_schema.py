"""ROS 2 message definitions (``.msg`` text, and the ``ros2msg`` schemas MCAP files carry) parsed into
their fields, for :mod:`.cdr`'s encoder."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PRIMITIVES", "SEPARATOR", "Field", "parse_schema", "resolve_type"]

#: ROS 2 primitive types and their little-endian numpy types (``string`` is handled apart)
PRIMITIVES: dict[str, np.dtype] = {name: np.dtype(code) for name, code in (
    ("bool", "u1"), ("byte", "u1"), ("char", "u1"), ("int8", "i1"), ("uint8", "u1"), ("int16", "<i2"),
    ("uint16", "<u2"), ("int32", "<i4"), ("uint32", "<u4"), ("int64", "<i8"), ("uint64", "<u8"),
    ("float32", "<f4"), ("float64", "<f8"))}
SEPARATOR = "=" * 80


@dataclass(frozen=True)
class Field:
    """One field of a message definition.

    ``array``: None for a single value, -1 for a sequence (``T[]``, ``T[<=N]``), k for a fixed array ``T[k]``.
    """

    name: str
    type: str  # a primitive, "string", or a message type "pkg/msg/Name"
    array: int | None = None
    default: str | None = None


def resolve_type(name: str, package: str) -> str:
    """The full name of a field type written ``name`` in a definition of ``package``."""
    base = name.split("<=")[0] if name.startswith(("string<=", "wstring<=")) else name
    if base in PRIMITIVES or base in ("string", "wstring"):
        return "string" if base == "wstring" else base
    parts = base.split("/")
    if len(parts) == 3:
        return base
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return "std_msgs/msg/Header" if base == "Header" else f"{package}/msg/{base}"


def _parse_fields(text: str, package: str) -> list[Field]:
    fields = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        tokens = line.split(maxsplit=2)
        if "=" in line.split(maxsplit=1)[1]:
            continue  # a constant (``int32 CUBE=1``, ``uint8 INT8 = 1``): not part of the data
        kind, name = tokens[0], tokens[1]
        array = None
        if kind.endswith("]"):
            kind, _, size = kind[:-1].partition("[")
            array = -1 if size == "" or size.startswith("<=") else int(size)
        fields.append(Field(name, resolve_type(kind, package), array, tokens[2] if len(tokens) > 2 else None))
    return fields


def parse_schema(name: str, text: str) -> dict[str, list[Field]]:
    """Every message type in a ``ros2msg`` schema: ``name``'s own text first, then each dependency
    after a line of 80 ``=`` and a ``MSG: pkg/msg/Type`` line."""
    out = {}
    for k, section in enumerate(text.split(SEPARATOR)):
        body = section.strip("\n")
        if k == 0:
            full = name
        else:
            head, _, body = body.partition("\n")
            if not head.startswith("MSG: "):
                raise ValueError(f"schema of {name}: section {k} does not start with 'MSG: '")
            full = resolve_type(head[5:].strip(), "")
        out[full] = _parse_fields(body, full.split("/")[0])
    return out
