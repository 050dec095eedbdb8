"""CDR, as ROS 2 serialises messages, of many messages at once, driven by their ``.msg`` definitions.

The encoding is XCDR1 little-endian (encapsulation header ``00 01 00 00``), each primitive aligned to
its own size counted from the end of the header, strings as a uint32 byte count (the terminating NUL
included), the UTF-8 bytes and a NUL, sequences as a uint32 element count and the elements; no
padding after the last field (as ``rosbags`` and ``mcap_ros2`` write it).

Messages are given as one value tree for ``n`` messages (columns, not rows): a field's value is a
scalar or a string (the same in every message), a numpy array of ``n`` values (one per message), a
dict (a nested message), a list of dicts or a dict of columns (a sequence of messages, the same in
every message: :meth:`CdrEncoder.encode`) or, for
a sequence of numbers, an array of shape ``(k,)`` (the same) or ``(n, k)`` (per message) or a list of
``n`` arrays (per message, of any length); a string field may also take ``n`` strings. Fields left
out take their defaults (0, the ``.msg`` default value, empty). Messages whose strings and
sequences have the same lengths share one byte layout and are filled together by numpy, the bytes
those of ``rosbags`` and ``mcap_ros2`` (docs/benchmarks.md measures the speed).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from jethr1_plan.files.msg_schema import PRIMITIVES, Field, parse_schema, resolve_type

__all__ = ["PRIMITIVES", "CdrEncoder", "Field", "parse_schema", "resolve_type"]

_HEADER = np.array([0, 1, 0, 0], dtype=np.uint8)  # CDR little-endian, no options


# --- encoding ------------------------------------------------------------------------------------

_MISSING = object()


@dataclass
class _Leaf:
    """A run of bytes of the message: ``kind`` is "num" (numbers of ``dtype``), "str", "count" or
    "block" (a sequence of messages given by columns: ``value`` is ``(elements, k)``)."""

    kind: str
    dtype: np.dtype | None
    value: object
    per_row: bool  # one value per message (else the same in all)
    array: str = ""  # "num", "block": "" a single value, "fixed" an array T[k], "sized" a sequence (a count first)


@dataclass
class _Column:
    """A field of the elements of a block: per element ``width`` numbers of ``dtype`` (``values``: (k, width))."""

    dtype: np.dtype
    values: np.ndarray
    array: str  # "" a single number, "fixed" or "sized" as in _Leaf


class CdrEncoder:
    """Encodes messages of the types in ``types`` (from :func:`parse_schema`)."""

    def __init__(self, types: Mapping[str, list[Field]]):
        self.types = dict(types)

    def encode(self, type_name: str, value: Mapping, n: int = 1) -> list[bytes]:
        """The CDR bytes of ``n`` messages of ``type_name`` given as one value tree (module docstring).

        A sequence of messages may also be given by columns, as a dict (the same in every message):
        e.g. ``{"x": xs, "y": ys, "z": zs}`` for a ``geometry_msgs/Point[]`` of ``len(xs)`` points,
        ``{"positions": (k, J) array, ...}`` for k JointTrajectoryPoints; its elements' fields are
        numbers, sequences of numbers (as long in every element) or such messages.

        Raises:
            KeyError: a field the definition does not have, or a type not in ``types``.
            ValueError: a value of the wrong shape.
        """
        if n == 0:
            return []
        leaves = list(self._leaves(type_name, value, n))
        lengths = [np.fromiter((len(x) for x in leaf.value), dtype=np.int64, count=n)  # type: ignore[attr-defined]
                   for leaf in leaves if leaf.per_row and (leaf.kind == "str" or isinstance(leaf.value, list))]
        out: list[bytes] = [b""] * n
        groups = [np.arange(n)]
        if lengths:  # messages whose strings and sequences have the same lengths share one layout
            _, group_of = np.unique(np.stack(lengths, axis=1), axis=0, return_inverse=True)
            groups = [np.flatnonzero(group_of.ravel() == g) for g in range(int(group_of.max()) + 1)]
        for rows in groups:
            for i, data in zip(rows, self._fill(leaves, rows), strict=True):
                out[i] = data
        return out

    # the leaves of a value tree, in the order CDR writes them

    def _leaves(self, type_name: str, value: Mapping, n: int) -> Iterator[_Leaf]:
        fields = self.types[type_name]
        unknown = set(value) - {f.name for f in fields}
        if unknown:
            raise KeyError(f"{type_name} has no field {sorted(unknown)}")
        for f in fields:
            yield from self._field(f, value.get(f.name, _MISSING), n, type_name)

    def _field(self, f: Field, v, n: int, owner: str) -> Iterator[_Leaf]:
        where = f"{owner}.{f.name}"
        array = "" if f.array is None else ("sized" if f.array < 0 else "fixed")
        if f.type in PRIMITIVES:
            dt = PRIMITIVES[f.type]
            if not array:
                if v is _MISSING:
                    v = _default_number(f)
                per_row = isinstance(v, np.ndarray) and v.ndim == 1
                if per_row and len(v) != n:
                    raise ValueError(f"{where}: {len(v)} values for {n} messages")
                yield _Leaf("num", dt, v, per_row)
                return
            if v is _MISSING:
                v = np.zeros(max(f.array or 0, 0), dt)
            if isinstance(v, (bytes, bytearray)):
                v = np.frombuffer(v, np.uint8)
            if isinstance(v, list) and v and isinstance(v[0], (list, tuple, np.ndarray)):
                if len(v) != n:
                    raise ValueError(f"{where}: {len(v)} sequences for {n} messages")
                yield _Leaf("num", dt, [np.asarray(x, dt) for x in v], True, array)
                return
            arr = np.asarray(v, dt)
            if arr.ndim == 2 and len(arr) != n:
                raise ValueError(f"{where}: {len(arr)} rows for {n} messages")
            if array == "fixed" and arr.shape[-1] != f.array:
                raise ValueError(f"{where}: {arr.shape[-1]} values in an array of {f.array}")
            yield _Leaf("num", dt, arr, arr.ndim == 2, array)
            return
        if f.type == "string":
            if not array:
                if v is _MISSING:
                    v = ""
                if isinstance(v, str):
                    yield _Leaf("str", None, v.encode(), False)
                else:
                    if len(v) != n:
                        raise ValueError(f"{where}: {len(v)} strings for {n} messages")
                    yield _Leaf("str", None, [s.encode() for s in v], True)
                return
            items = [] if v is _MISSING else list(v)
            if array == "sized":
                yield _Leaf("count", None, len(items), False)
            for s in items:
                yield _Leaf("str", None, s.encode(), False)
            return
        if not array:
            yield from self._leaves(f.type, {} if v is _MISSING else v, n)
            return
        if isinstance(v, Mapping):
            k = _first_length(v)
            if array == "fixed" and k != f.array:
                raise ValueError(f"{where}: {k} messages in an array of {f.array}")
            yield _Leaf("block", None, (self._columns(f.type, v, k, where), k), False, array)
            return
        items = [] if v is _MISSING else list(v)
        if array == "sized":
            yield _Leaf("count", None, len(items), False)
        elif len(items) != f.array:
            raise ValueError(f"{where}: {len(items)} messages in an array of {f.array}")
        for item in items:
            yield from self._leaves(f.type, item, n)

    def _columns(self, type_name: str, value: Mapping, k: int, where: str) -> list[_Column]:
        """The fields of ``k`` messages of ``type_name`` given by columns, in CDR order."""
        fields = self.types[type_name]
        unknown = set(value) - {f.name for f in fields}
        if unknown:
            raise KeyError(f"{type_name} has no field {sorted(unknown)}")
        out = []
        for f in fields:
            v = value.get(f.name, _MISSING)
            if f.type not in PRIMITIVES:
                if f.type == "string" or f.array is not None:
                    raise ValueError(f"{where}.{f.name}: give the elements as a list of dicts (a string or a "
                                     f"sequence of messages in each)")
                out += self._columns(f.type, {} if v is _MISSING else v, k, f"{where}.{f.name}")
                continue
            dt = PRIMITIVES[f.type]
            if f.array is None:
                arr = np.full(k, _default_number(f), dt) if v is _MISSING else np.asarray(v, dt)
                if arr.shape != (k,):
                    raise ValueError(f"{where}.{f.name}: shape {arr.shape} for {k} elements")
                out.append(_Column(dt, arr.reshape(k, 1), ""))
            else:
                arr = np.zeros((k, max(f.array, 0)), dt) if v is _MISSING else np.asarray(v, dt)
                if arr.ndim != 2 or len(arr) != k or (f.array >= 0 and arr.shape[1] != f.array):
                    raise ValueError(f"{where}.{f.name}: shape {arr.shape} for {k} elements")
                out.append(_Column(dt, arr, "sized" if f.array < 0 else "fixed"))
        return out

    # the bytes of the messages ``rows``, which share one layout

    def _fill(self, leaves: list[_Leaf], rows: np.ndarray) -> list[bytes]:
        first = int(rows[0])
        m = len(rows)
        off = 0
        runs: list[tuple[int, np.dtype, int, object]] = []  # offset after the header, type, count, values
        # where each element's bytes go (after the header: per element, or first, stride, count), values
        scattered: list[tuple[np.ndarray | tuple[int, int, int], np.ndarray]] = []

        def put(dt: np.dtype, count: int, values) -> None:
            nonlocal off
            off += -off % dt.itemsize
            runs.append((off, dt, count, values))
            off += dt.itemsize * count

        u32, u8 = PRIMITIVES["uint32"], PRIMITIVES["uint8"]
        for leaf in leaves:
            if leaf.kind == "count":
                put(u32, 1, leaf.value)
            elif leaf.kind == "str":
                if leaf.per_row:
                    strings = [leaf.value[i] for i in rows]  # type: ignore[index]
                    k = len(strings[0]) + 1
                    put(u32, 1, k)
                    put(u8, k, np.frombuffer(b"\0".join(strings) + b"\0", np.uint8).reshape(m, k))
                else:
                    data = leaf.value + b"\0"  # type: ignore[operator]
                    put(u32, 1, len(data))
                    put(u8, len(data), np.frombuffer(data, np.uint8))
            elif leaf.kind == "block":
                columns: list[_Column]
                columns, k = leaf.value  # type: ignore[misc]
                if leaf.array == "sized":
                    put(u32, 1, k)
                if k:
                    off = _lay_block(columns, k, off, scattered)
            else:
                dt = leaf.dtype
                assert dt is not None
                v: Any = leaf.value
                if isinstance(v, list):  # one sequence per message, these of equal length
                    v = np.stack([v[i] for i in rows]) if len(v[first]) else np.zeros((m, 0), dt)
                elif leaf.per_row:
                    v = v[rows]
                if leaf.array:
                    count = v.shape[-1]
                    if leaf.array == "sized":
                        put(u32, 1, count)
                    if count:
                        put(dt, count, v)
                else:
                    put(dt, 1, v[:, None] if leaf.per_row else v)
        size = 4 + off
        buf = np.zeros((m, size), np.uint8)
        buf[:, :4] = _HEADER
        for at, dt, count, values in runs:
            buf[:, 4 + at:4 + at + dt.itemsize * count].view(dt)[...] = values
        for where, values in scattered:
            _scatter(buf, where, values, 4)
        raw = buf.tobytes()
        return [raw[i * size:(i + 1) * size] for i in range(m)]


def _first_length(value: Mapping) -> int:
    """The number of elements of a sequence of messages given by columns (its first column's length)."""
    for v in value.values():
        if isinstance(v, Mapping):
            if v:
                return _first_length(v)
        else:
            return len(v)
    raise ValueError("a sequence of messages given by columns needs at least one column")


def _element_layout(columns: list[_Column], start: int) -> tuple[list[tuple[int, int]], int]:
    """Where each column's count (-1: none) and numbers go in an element that starts at ``start``
    (relative to it), and the element's size with the padding before it ends."""
    o = start
    out = []
    for c in columns:
        at_count = -1
        if c.array == "sized":
            o += -o % 4
            at_count, o = o - start, o + 4
        width = c.values.shape[1]
        if width:
            o += -o % c.dtype.itemsize
        out.append((at_count, o - start))
        o += c.dtype.itemsize * width
    return out, o - start


def _lay_block(columns: list[_Column], k: int, off: int, scattered: list) -> int:
    """Lay out k elements from ``off`` (an element's layout depends only on where it starts modulo 8, so the
    layouts repeat with a period of at most 8 elements); add to ``scattered`` where each column's bytes go and
    its values (the bytes are placed when the message is built: :func:`_scatter`); the offset after them.
    Where every element has one layout (a ``geometry_msgs/Point[]``, a ``std_msgs/ColorRGBA[]``), where they go
    is a start and a stride; else, per element, the offset of its first byte."""
    layouts: dict[int, tuple[list[tuple[int, int]], int]] = {}
    phases: list[int] = []
    first_at: dict[int, int] = {}  # phase -> the first element that starts at it
    o = off
    while len(phases) < k and o % 8 not in first_at:
        p = o % 8
        first_at[p] = len(phases)
        layouts[p] = _element_layout(columns, p)
        phases.append(p)
        o += layouts[p][1]
    if len(layouts) == 1:  # one layout: element j at off + j·size
        (places, size), = layouts.values()
        for c, (at_count, at_value) in zip(columns, places, strict=True):
            width = c.values.shape[1]
            if c.array == "sized":
                scattered.append(((off + at_count, size, k), np.array([[width]], "<u4")))
            if width:
                scattered.append(((off + at_value, size, k), c.values))
        return off + size * k
    # elements first_at[o % 8], ... repeat from there on
    c0 = first_at.get(o % 8, k)
    phase = np.concatenate([np.array(phases[:c0], np.int64), np.resize(np.array(phases[c0:], np.int64), k - c0)])
    per_phase = [layouts.get(p, ([(0, 0)] * len(columns), 0)) for p in range(8)]
    sizes = np.array([size for _, size in per_phase], np.int64)[phase]
    starts = off + np.concatenate([np.zeros(1, np.int64), np.cumsum(sizes[:-1])])
    for i, c in enumerate(columns):
        counts_at = np.array([places[i][0] for places, _ in per_phase])[phase]
        values_at = np.array([places[i][1] for places, _ in per_phase])[phase]
        width = c.values.shape[1]
        if c.array == "sized":
            scattered.append((starts + counts_at, np.array([[width]], "<u4")))
        if width:
            scattered.append((starts + values_at, c.values))
    return int(off + sizes.sum())


def _scatter(buf: np.ndarray, where: np.ndarray | tuple[int, int, int], values: np.ndarray, base: int) -> None:
    """Put the bytes of ``values`` (k, width) (or one row, the same for every element) into every message of
    ``buf`` (messages, bytes), ``base`` bytes on from where :func:`_lay_block` put them: element j's first at
    column ``where[j]``, a byte position at a time so that no index is held per byte; or, ``where`` =
    (first, stride, k), at first + j·stride, through a strided view."""
    raw = np.ascontiguousarray(values).view(np.uint8)
    if isinstance(where, tuple):
        first, stride, k = where
        w = raw.shape[1]
        elements = buf[:, base + first:base + first + stride * (k - 1) + w]
        view = np.lib.stride_tricks.as_strided(elements, (buf.shape[0], k, w),
                                               (buf.strides[0], stride * buf.strides[1], buf.strides[1]))
        view[...] = raw
        return
    for b in range(raw.shape[1]):
        buf[:, base + where + b] = raw[:, b]


def _default_number(f: Field) -> float | int:
    if f.default is None:
        return 0
    if f.type == "bool":
        return int(f.default.lower() in ("true", "1"))
    return float(f.default) if f.type.startswith("float") else int(f.default, 0)
