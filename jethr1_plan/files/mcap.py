"""MCAP files in the ROS 2 profile, written and read: what Foxglove/Lichtblick, Rerun, ``rosbags``,
``mcap_ros2`` and ``ros2 bag play`` all read.

Profile ``ros2``; messages CDR-encoded (:mod:`.cdr`); each channel's schema the ``ros2msg``
definition of its type with its dependencies appended (:mod:`.ros2_msgs`); each channel's metadata
the ``offered_qos_profiles`` ``ros2 bag play`` publishes it with (reliable, keep last; transient
local for what is published once: the URDF, ``/tf_static``, the scenery).

Every kind of file declares its topics once, as data (a :class:`Topic` per topic name):
``plan_mcap.PLAN_TOPICS``, ``simulation.SIMULATION_TOPICS``, ``walk_folder.WALK_TOPICS``,
``balance_space.BALANCE_SPACE_TOPICS``; the writer registers exactly these channels, in that order.

Times: every message is logged at :data:`EPOCH_NS` + its time from the start of the scenario, the
epoch being 2000-01-01T00:00:00Z (a fixed date: the same input gives the same bytes; viewers show
the plan starting at midnight on 1 January 2000), and its header stamp is the same time. Messages
are written in log-time order (at equal times in the order of the file's topics). The header
records no library version.
"""

from __future__ import annotations

import io
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from jethr1_plan.files.cdr import CdrEncoder, parse_schema
from jethr1_plan.files.messages import (
    log_times,
)
from jethr1_plan.files.ros2_msgs import MSGDEFS, schema_text
from jethr1_plan.records.topics import MARKERS, POSE, STRING, TF, Topic

__all__ = [
    "MARKERS",
    "MCAP_MAGIC",
    "POSE",
    "STRING",
    "TF",
    "McapTooLarge",
    "Ros2Mcap",
    "Topic",
    "mcap_expanded_bytes",
    "qos_profile",
    "read_mcap",
    "topics_markdown",
]


def qos_profile(transient_local: bool) -> str:
    """``offered_qos_profiles`` as rosbag2 stores it (its integer form, which Humble and later read):
    reliable, keep last (depth 1 when transient local, else 10), durations left at the default."""
    zero = "\n    sec: 0\n    nsec: 0"
    return (f"- history: 1\n  depth: {1 if transient_local else 10}\n  reliability: 1\n"
            f"  durability: {1 if transient_local else 2}\n  deadline:{zero}\n  lifespan:{zero}\n  liveliness: 1\n"
            f"  liveliness_lease_duration:{zero}\n  avoid_ros_namespace_conventions: false\n")


def topics_markdown(topics: Mapping[str, Topic]) -> str:
    """A Markdown table of a file's topics (the docs print it; a test holds it to the declaration)."""
    lines = ["| topic | type | QoS durability | carries |", "| --- | --- | --- | --- |"]
    lines += [f"| `{name}` | `{t.type}` | {'transient local' if t.latched else 'volatile'} | {t.what} |"
              for name, t in topics.items()]
    return "\n".join(lines) + "\n"


class Ros2Mcap:
    """An MCAP in the ROS 2 profile being written: one channel per declared topic, registered in
    order; messages kept until :meth:`finish` writes them in log-time order (zstd-compressed
    chunks, one sequence number per message)."""

    def __init__(self, topics: Mapping[str, Topic], msgdefs: Mapping[str, str] = MSGDEFS):
        from mcap.writer import CompressionType, Writer

        self._buf = io.BytesIO()
        self._w = Writer(self._buf, compression=CompressionType.ZSTD)
        self._w.start(profile="ros2", library="jethr1-plan")
        self.types = {name: t.type for name, t in topics.items()}
        schemas: dict[str, int] = {}
        types: dict = {}
        for name in dict.fromkeys(self.types.values()):
            text = schema_text(name, msgdefs)
            types.update(parse_schema(name, text))
            schemas[name] = self._w.register_schema(name=name, encoding="ros2msg", data=text.encode())
        self._encoder = CdrEncoder(types)
        self._channels = {name: self._w.register_channel(
            topic=name, message_encoding="cdr", schema_id=schemas[t.type],
            metadata={"offered_qos_profiles": qos_profile(t.latched)}) for name, t in topics.items()}
        self._rank = {name: k for k, name in enumerate(topics)}
        self._pending: list[tuple[np.ndarray, str, list[bytes]]] = []  # log times [ns], topic, messages

    def write(self, topic: str, t_s: float, msg: Mapping) -> None:
        """Log one message on ``topic`` at ``t_s`` [s] from the start."""
        self.write_rows(topic, np.array([t_s]), msg)

    def write_rows(self, topic: str, t_s: Sequence[float] | np.ndarray, msg: Mapping) -> None:
        """Log ``len(t_s)`` messages on ``topic``, message i at ``t_s[i]`` [s], given as one value tree
        whose per-message fields have one value per message (:mod:`.cdr`)."""
        t = np.asarray(t_s, dtype=float)
        if len(t) == 0:
            return
        data = self._encoder.encode(self.types[topic], msg, len(t))
        self._pending.append((log_times(t), topic, data))

    def finish(self) -> bytes:
        """Write every message, in log-time order, and return the file's bytes."""
        if self._pending:
            times = np.concatenate([t for t, _, _ in self._pending])
            ranks = np.concatenate([np.full(len(t), self._rank[topic]) for t, topic, _ in self._pending])
            channels = [self._channels[topic] for t, topic, _ in self._pending for _ in range(len(t))]
            data: list[bytes | None] = [d for _, _, messages in self._pending for d in messages]
            self._pending = []
            add = self._w.add_message
            # by log time, then topic order; np.lexsort is stable, so a topic's messages keep their order
            for seq, k in enumerate(np.lexsort((ranks, times)).tolist()):
                ns = int(times[k])
                message, data[k] = data[k], None  # (each message's bytes let go once in its chunk)
                add(channel_id=channels[k], log_time=ns, publish_time=ns, sequence=seq, data=message)
        self._w.finish()
        return self._buf.getvalue()


MCAP_MAGIC = b"\x89MCAP0\r\n"
MAX_MCAP_EXPANSION = 50  # the chunks of jethr1's files expand 3 to 12 times; no more than this many
MCAP_SLACK_BYTES = 20_000_000  # ... plus this (a small file's URDF, schemas)


class McapTooLarge(ValueError):
    """An MCAP whose chunks would expand beyond the bound its reader gives (a bomb, or not jethr1's)."""


def mcap_expanded_bytes(data: bytes, max_bytes: int | None = None) -> int:
    """The bytes the chunks of MCAP ``data`` decompress to, read from the chunk records and their zstd frame
    headers before anything is decompressed; at most ``max_bytes`` (default: :data:`MAX_MCAP_EXPANSION` times
    the file plus :data:`MCAP_SLACK_BYTES`).

    Raises:
        McapTooLarge: more than ``max_bytes``; a chunk whose compression jethr1 does not read (not zstd, not
            none), or whose zstd frame says it holds more than its chunk record says.
        ValueError: not an MCAP file (its records do not parse).
    """
    import struct

    import zstandard

    limit = len(data) * MAX_MCAP_EXPANSION + MCAP_SLACK_BYTES if max_bytes is None else max_bytes
    if not data.startswith(MCAP_MAGIC):
        raise ValueError("not an MCAP file (no MCAP magic at its start)")
    pos, total = len(MCAP_MAGIC), 0
    while pos + 9 <= len(data):
        op = data[pos]
        (length,) = struct.unpack_from("<Q", data, pos + 1)
        body = pos + 9
        if body + length > len(data):
            raise ValueError(f"a record at byte {pos} runs past the end of the file (cut?)")
        if op == 0x06:  # Chunk: start, end, uncompressed size, CRC, compression, records
            if length < 32:
                raise ValueError(f"a chunk record at byte {pos} is too short")
            size = struct.unpack_from("<Q", data, body + 16)[0]
            (n,) = struct.unpack_from("<I", data, body + 28)
            compression = data[body + 32:body + 32 + n].decode("utf-8", "replace")
            records = body + 32 + n + 8
            if compression not in ("", "zstd"):
                raise McapTooLarge(f"a chunk compressed with {compression[:20]!r}: jethr1 reads zstd chunks (what "
                                   "it writes)")
            if compression == "zstd" and records < body + length:
                frame = zstandard.get_frame_parameters(data[records:body + length]).content_size
                if frame not in (0, zstandard.CONTENTSIZE_UNKNOWN) and frame > size:
                    raise McapTooLarge(f"a chunk at byte {pos} expands to {frame:,} bytes, though it says {size:,}")
            total += size
            if total > limit:
                raise McapTooLarge(f"its chunks expand to more than {limit:,} bytes: more than this kind of file "
                                   "holds")
        elif op == 0x02:  # Footer: the end
            break
        pos = body + length
    return total


def read_mcap(data: bytes, topics: Iterable[str] | None = None,
              ordered: bool = True, max_expanded_bytes: int | None = None) -> list[tuple[str, str, Any, int]]:
    """The messages of a ROS 2 MCAP (of ``topics``, else all), in log-time order (``ordered``; else in
    the file's order, which the writer makes the same, and a third faster): (topic, type name,
    the message decoded by ``mcap_ros2`` from the definitions stored in the file, log time [ns]);
    the chunks' CRCs checked. Fields are attributes (``msg.header.stamp.sec``), sequences lists. The
    chunks' sizes are checked before any is decompressed (:func:`mcap_expanded_bytes`, with
    ``max_expanded_bytes``).

    Raises:
        Exception: of many kinds on a corrupt file or one not in the ROS 2 profile (the callers turn
            them into bad input); :class:`McapTooLarge` for chunks that would expand beyond the bound.
    """
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    mcap_expanded_bytes(data, max_expanded_bytes)

    reader = make_reader(io.BytesIO(data), validate_crcs=True, decoder_factories=[DecoderFactory()])
    profile = reader.get_header().profile
    if profile != "ros2":
        raise ValueError(f"profile {profile!r}, not 'ros2' (written by an older jethr1? write it again)")
    wanted = None if topics is None else list(topics)
    return [(channel.topic, schema.name if schema is not None else "", msg, message.log_time)
            for schema, channel, message, msg in reader.iter_decoded_messages(topics=wanted, log_time_order=ordered)]


# --- message builders (value trees, one value per message where they vary) -----------------------------
