"""Recordings: rosbag2 MCAP files written with ``mcap``, and rosbag2 recordings of any stack read with ``rosbags``.

Writing (``pmv simulate --record FILE.mcap``)
    :class:`McapRecording` writes one MCAP file in the ``ros2`` profile — what
    ``ros2 bag record -s mcap`` stores (Jazzy's default storage) and what
    ``ros2 bag info/play FILE.mcap`` and Foxglove open: a schema per message
    type (``ros2msg``, the full definition with its dependencies, from
    ``rosbags``' Jazzy type store), a channel per topic (``cdr``), and the
    messages as the CDR bytes the subscription received, unchanged. The
    container is written by the ``mcap`` library; the reader's walk below knows
    only its record framing (opcode, length) and the message record's header.

Reading (``pmv analyze RECORDING``)
    :func:`open_recording` (or :func:`read_recording`) opens a rosbag2
    directory (``metadata.yaml`` plus its storage files), a bare ``.mcap``
    file or a bare ``.db3`` (sqlite3) file with ``rosbags`` — once, however
    often it is read — and returns the messages of the topics asked for,
    deserialised from the definitions the recording carries (Jazzy's standard
    definitions where it carries none). Fields are read by name, so the
    shim's ``read_*`` functions take these messages as they take rclpy's.
    Every defect — no such file, not a recording, a missing topic, a topic of
    another type, an unreadable message — is a :class:`RecordingError` with
    one sentence naming it.

Bounds and recovery
    Before any library reads a recording, :func:`scan_mcap` walks an MCAP
    file record by record (its own walk: records no reader needs are skipped
    unread): every file of a recording must be a regular file (a FIFO or a
    device would block or never end), no record may be longer than its
    kind's cap (:data:`MAX_RECORD_BYTES` for a chunk), and each compressed
    chunk's declared size is checked against :data:`MAX_CHUNK_BYTES` before
    it is decompressed — and then decompressed with that bound, so a chunk
    that expands beyond what it declares is refused, not inflated. What
    rosbags will do with the file is bounded there too, since its cost does
    not follow the file's size: the channels (:data:`MAX_CONNECTIONS`), the
    definition text it parses once per channel (:data:`MAX_DEFINITION_BYTES`),
    the types and fields it registers (:data:`MAX_DEFINITIONS`,
    :data:`MAX_DEFINITION_FIELDS`), the records of a chunk
    (:data:`MAX_CHUNK_RECORDS`), the channels' QoS profiles it parses as YAML
    (:data:`MAX_QOS_BYTES`), the chunk indexes (each must point at a
    chunk the walk saw, :data:`MAX_CHUNK_INDEXES`), the footer's summary
    offset, and the chunks a log-time reader holds at once
    (:data:`MAX_OVERLAPPING_CHUNK_BYTES`). A sqlite3 file is checked through
    SQLite the same way (:func:`check_sqlite`), and no message of a topic
    read may be larger than :data:`MAX_MESSAGE_BYTES` (asked of SQLite
    before a row is read). Each walk and check is linear in the file.
    An MCAP file without its
    footer (the writer was killed, the disk filled up) is read the same way,
    as a stream, up to the last whole chunk; :func:`recording_status` says
    how much was recovered. The writer flushes a chunk at least every
    :data:`FLUSH_INTERVAL_S` of wall time, so ``kill -9`` loses at most that
    much of a recording.
"""

from __future__ import annotations

import functools
import re
import struct
import time
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Iterator

#: Library name written in the MCAP header (with the mcap library's own).
LIBRARY = "pmv_ros"

#: Largest uncompressed size a chunk of a recording may declare (and have), bytes; this package writes ≤ 1 MiB.
MAX_CHUNK_BYTES = 64 << 20

#: Largest record of an MCAP file read, bytes (a chunk's compressed data is one record).
MAX_RECORD_BYTES = MAX_CHUNK_BYTES + (1 << 20)

#: Largest recording file, bytes (any regular file below it is read as a stream; this only refuses absurd ones).
MAX_RECORDING_BYTES = 1 << 40

#: Most files a rosbag2 recording directory may hold.
MAX_BAG_FILES = 1024

#: Largest ``metadata.yaml`` of a rosbag2 directory, bytes: rosbags parses it again with a pure-Python YAML
#: parser (≈ 4 µs a byte of ordinary YAML, ≈ 15 µs and ≈ 0.4 kB of memory a byte of a dense flow list,
#: design/recording_bounds.py): ≤ 8 s and ≤ 0.23 GB here. A topic takes ≈ 0.6–0.9 kB of it: ≈ 600 topics.
MAX_BAG_METADATA_BYTES = 512 << 10

#: Wall time between two flushes of the recording being written, s: what ``kill -9`` can cost at most.
FLUSH_INTERVAL_S = 0.1

#: Chunk size of the written recording, bytes uncompressed (the mcap library's default).
CHUNK_BYTES = 1 << 20


class RecordingError(ValueError):
    """A recording that cannot be written or read as asked; the message names the problem in one line."""


def _jazzy_typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


class McapRecording:
    """A rosbag2 MCAP file being written: :meth:`add_topic`, then :meth:`write` raw CDR messages, :meth:`close`.

    Args:
        path: the file to create; refused if it exists (as ``ros2 bag record`` refuses).
    """

    def __init__(self, path: str | Path):
        from mcap.well_known import MessageEncoding, Profile
        from mcap.writer import CompressionType, Writer

        self.path = Path(path)
        try:
            self._stream = open(self.path, "xb")
        except FileExistsError:
            raise RecordingError(f"{self.path}: exists already, not overwriting it") from None
        except OSError as error:
            raise RecordingError(f"{self.path}: cannot create the file ({error.strerror})") from None
        self._encoding = MessageEncoding.CDR
        self._writer = Writer(self._stream, compression=CompressionType.ZSTD, chunk_size=CHUNK_BYTES)
        self._flushed_at = time.monotonic()
        self._closed = False
        self._failed = None
        self._guard(lambda: self._writer.start(profile=Profile.ROS2, library=LIBRARY))
        self._typestore = _jazzy_typestore()
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self.counts: dict[str, int] = {}
        self.types: dict[str, str] = {}

    def _guard(self, action):
        """Run a write; a failing disk (full, a file-size limit, an I/O error) is one RecordingError line."""
        if self._failed is not None:
            raise RecordingError(self._failed)
        try:
            return action()
        except OSError as error:
            written = sum(self.counts.values()) if hasattr(self, "counts") else 0
            self._failed = (f"{self.path}: cannot write the recording ({error.strerror or error}); "
                            f"{written} messages were given to it — `pmv analyze` reads what reached the disk")
            raise RecordingError(self._failed) from None

    def add_topic(self, topic: str, type_name: str) -> int:
        """Register ``topic`` of ``type_name`` (``pkg/msg/Type``); returns its channel id."""
        from mcap.well_known import SchemaEncoding

        if topic in self._channels:
            raise RecordingError(f"{topic}: already recorded")
        if type_name not in self._schemas:
            try:
                definition, _ = self._typestore.generate_msgdef(type_name, ros_version=2)
            except Exception:  # rosbags raises its own error types for unknown messages
                raise RecordingError(f"{topic}: no message definition known for {type_name}") from None
            self._schemas[type_name] = self._guard(lambda: self._writer.register_schema(
                type_name, SchemaEncoding.ROS2, definition.encode()))
        channel = self._guard(lambda: self._writer.register_channel(topic, self._encoding, self._schemas[type_name]))
        self._channels[topic] = channel
        self.counts[topic] = 0
        self.types[topic] = type_name
        return channel

    def write(self, topic: str, log_time_ns: int, data: bytes) -> None:
        """Add one serialised (CDR) message of a registered topic, received at ``log_time_ns``.

        At least every :data:`FLUSH_INTERVAL_S` the chunk in progress is
        written out and the file flushed, so a killed process leaves a file
        that :func:`iter_recording` reads up to that point.
        """
        self._guard(lambda: self._writer.add_message(self._channels[topic], log_time=int(log_time_ns), data=data,
                                                     publish_time=int(log_time_ns), sequence=self.counts[topic]))
        self.counts[topic] += 1
        now = time.monotonic()
        if now - self._flushed_at >= FLUSH_INTERVAL_S:
            self._flushed_at = now
            self._guard(self._writer.flush)

    @property
    def failed(self) -> str | None:
        """The one-line reason the file could not be written, or None."""
        return self._failed

    def close(self) -> None:
        """Write the summary and close the file (idempotent); RecordingError (one line) if the disk fails.

        After a failed write the file is only closed: what reached the disk is
        readable without a summary.
        """
        if self._closed:
            return
        self._closed = True
        try:
            if self._failed is None:
                self._guard(self._writer.finish)
        finally:
            try:
                self._stream.close()
            except OSError as error:  # the last buffered bytes did not fit either
                if self._failed is None:
                    self._failed = f"{self.path}: cannot write the recording ({error.strerror or error})"
                    raise RecordingError(self._failed) from None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


@dataclass(frozen=True)
class RecordedMessage:
    """One message of a recording: the time it was logged (ns) and the message (fields by name)."""

    log_time_ns: int
    message: object


# ----------------------------------------------------------------------------------- bounded reading

@dataclass(frozen=True)
class McapScan:
    """What a record-by-record walk of an MCAP file found.

    ``complete``: the footer and the closing magic are there; ``messages``:
    messages in whole chunks (and outside chunks); ``bytes_read`` of
    ``file_bytes``: where the readable part ends; ``stopped``: why the walk
    ended early (None for a complete file).
    """

    complete: bool
    messages: int
    bytes_read: int
    file_bytes: int
    stopped: str | None = None


#: Most connections (MCAP channels, sqlite3 topics) a recording file may have: rosbags reads the message
#: definition and the QoS profiles of each when it opens the file.
MAX_CONNECTIONS = 1024

#: Most text rosbags parses when it opens a recording file, bytes: each connection's message definition (with
#: its dependencies), its QoS profiles and its names, summed over the connections — rosbags parses a definition
#: once per connection, however many share it. Parsing costs ≈ 1 µs of CPU a byte of ROS 2's own commented
#: definitions and up to ≈ 7 µs a byte of dense field lists (design/recording_bounds.py): ≤ 7 s at this bound.
#: A rosbag2 recording holds ≈ 2–4 kB a topic (nav_msgs/Odometry with its comments: 3.7 kB): ≈ 280 such topics.
MAX_DEFINITION_BYTES = 1 << 20

#: Most message definitions the distinct schemas of a recording file may hold together: each is a type rosbags
#: registers, ≈ 31 kB of memory (design/recording_bounds.py), ≤ 62 MB at this bound. ROS 2's own messages
#: bring 1 to 16 definitions each.
MAX_DEFINITIONS = 2000

#: Most fields (and constants) the distinct schemas of a recording file may declare together: rosbags builds
#: code for each, ≈ 8–11 kB of memory a field (design/recording_bounds.py), ≤ 220 MB at this bound. ROS 2's own
#: messages declare 1 to ≈ 100 with their dependencies.
MAX_DEFINITION_FIELDS = 20_000

#: Most records a chunk may hold: a reader keeps the messages of a chunk it reads as objects (≈ 220 bytes each
#: beyond their data, design/recording_bounds.py), so a chunk of tiny messages weighs ≈ 55 MB at this bound
#: whatever its size in bytes (a 64 MiB chunk can hold 1.9 million empty messages).
MAX_CHUNK_RECORDS = 250_000

#: Most chunk indexes in a recording's summary (rosbags holds one object and, for each chunk of a topic read,
#: one pending reader per index: ≈ 1 kB each): 100 GB of chunks of 1 MiB.
MAX_CHUNK_INDEXES = 100_000

#: Most bytes of chunks whose log-time ranges overlap, uncompressed, plus 220 bytes a message: a reader in
#: log-time order holds every chunk it has begun until its last message is read. Recordings are written in
#: log-time order, so their chunks follow each other (two at a time at most where one ends as the next begins).
MAX_OVERLAPPING_CHUNK_BYTES = 256 << 20

#: Most QoS-profile text of a recording file's connections, bytes, summed: rosbags parses each with a pure-Python
#: YAML parser (≈ 4 µs and 0.1 kB of memory a byte of real profiles, ≈ 16 µs and ≈ 0.5 kB a byte of a dense flow
#: list, design/recording_bounds.py): ≤ 4.2 s and ≤ 0.13 GB. A publisher's profile is ≈ 0.3 kB.
MAX_QOS_BYTES = 256 << 10

#: Largest message of a topic a reader asks for, bytes (deserialised, a message weighs several times its bytes):
#: the topics ``pmv analyze`` reads carry tens to thousands of bytes a message.
MAX_MESSAGE_BYTES = 1 << 20

#: Bytes a message's object weighs beyond its data in a reader's hands (design/recording_bounds.py).
_MESSAGE_OBJECT_BYTES = 220

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_MESSAGE_HEADER = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time
_SMALL_RECORD_BYTES = (64 << 10) + 10 * MAX_CONNECTIONS  # an index or statistics: ≤ 10 bytes a channel
_DEFINITION_SEPARATOR = b"=" * 80


def _record_caps() -> dict:
    """Largest body of each MCAP record kind, bytes (any other kind: :data:`MAX_RECORD_BYTES`)."""
    from mcap.opcode import Opcode

    definition = MAX_DEFINITION_BYTES + (64 << 10)
    return {Opcode.HEADER: 64 << 10, Opcode.FOOTER: 64 << 10, Opcode.DATA_END: 64 << 10,
            Opcode.SCHEMA: definition, Opcode.CHANNEL: definition, Opcode.CHUNK_INDEX: _SMALL_RECORD_BYTES,
            Opcode.STATISTICS: _SMALL_RECORD_BYTES}


def _definitions(data: bytes) -> int:
    """How many message definitions (types) a schema's text holds, counted from above.

    One, plus one per separator line or ``MSG:`` header of the ros2msg format,
    or per ``struct`` of IDL: the larger count.
    """
    return 1 + max(data.count(_DEFINITION_SEPARATOR), data.count(b"\nMSG: "), len(re.findall(rb"\bstruct\b", data)))


def _fields(data: bytes) -> int:
    """How many fields and constants a schema's text declares, counted from above.

    A line of the ros2msg format with something before its comment (not a
    separator or a ``MSG:`` header), or a ``;`` of IDL: the larger count.
    """
    lines = 0
    for line in data.split(b"\n"):
        content = line.split(b"#", 1)[0].strip()
        if content and not content.startswith(b"MSG:") and content != _DEFINITION_SEPARATOR:
            lines += 1
    return max(lines, data.count(b";"))


def _decompress_chunk(chunk, path) -> bytes:
    """A chunk's records, decompressed with its declared size as the bound; RecordingError beyond the caps."""
    declared = chunk.uncompressed_size
    if declared > MAX_CHUNK_BYTES:
        raise RecordingError(f"{path}: a chunk declares {declared} bytes uncompressed, more than the "
                             f"{MAX_CHUNK_BYTES} allowed")
    if chunk.compression == "zstd":
        import zstandard

        framed = zstandard.frame_content_size(chunk.data)
        if framed > declared:
            raise RecordingError(f"{path}: a chunk's zstd frame declares {framed} bytes, more than the chunk's "
                                 f"{declared}")
        with zstandard.ZstdDecompressor().stream_reader(chunk.data) as reader:
            parts, size = [], 0
            while size <= declared:
                part = reader.read(declared + 1 - size)
                if not part:
                    break
                parts.append(part)
                size += len(part)
        data = b"".join(parts)
    elif chunk.compression == "lz4":
        import lz4.frame

        data = lz4.frame.LZ4FrameDecompressor().decompress(chunk.data, max_length=declared + 1)
    elif chunk.compression == "":
        data = chunk.data
    else:
        raise RecordingError(f"{path}: a chunk is compressed with {chunk.compression!r}, not zstd or lz4")
    if len(data) > declared:
        raise RecordingError(f"{path}: a chunk expands beyond the {declared} bytes it declares")
    if len(data) < declared:
        raise RecordingError(f"{path}: a chunk holds {len(data)} bytes uncompressed, it declares {declared}")
    return data


def _parse(kind, body: bytes, path, start: int):
    """An MCAP record of ``kind`` (an mcap.records class) from its body; RecordingError if malformed."""
    from io import BytesIO

    from mcap.data_stream import ReadDataStream

    try:
        return kind.read(ReadDataStream(BytesIO(body)))
    except Exception as error:  # the library's EndOfFile, struct and decode errors of a malformed body
        raise RecordingError(f"{path}: a malformed {kind.__name__} record at byte {start} ({_reason(error)})") from None


def _message(body, path, where: str, wants_channel):
    """``("message", Message)`` of a message record's body if its channel is wanted, else ``("skipped", None)``."""
    from mcap.records import Message

    if len(body) < _MESSAGE_HEADER.size:
        raise RecordingError(f"{path}: a malformed message record {where}")
    channel_id, sequence, log_time, publish_time = _MESSAGE_HEADER.unpack_from(body)
    if not wants_channel(channel_id):
        return "skipped", None
    size = len(body) - _MESSAGE_HEADER.size
    if size > MAX_MESSAGE_BYTES:
        raise RecordingError(f"{path}: a message {where} is {size} bytes, more than the {MAX_MESSAGE_BYTES} allowed "
                             "for the topics read")
    return "message", Message(channel_id=channel_id, sequence=sequence, log_time=log_time,
                              publish_time=publish_time, data=bytes(body[_MESSAGE_HEADER.size:]))


def _chunk_records(data: bytes, path, start: int, wants_channel, caps: dict):
    """``(kind, record)`` of the records of a decompressed chunk: schemas, channels, wanted messages; and
    ``("skipped", None)`` for every other message. At most :data:`MAX_CHUNK_RECORDS` records, each checked
    against its cap; RecordingError if the chunk's records do not fill it exactly."""
    from mcap.opcode import Opcode
    from mcap.records import Channel, Schema

    view, offset, records = memoryview(data), 0, 0
    where = f"in the chunk at byte {start}"
    while offset < len(data):
        records += 1
        if records > MAX_CHUNK_RECORDS:
            raise RecordingError(f"{path}: the chunk at byte {start} holds more than {MAX_CHUNK_RECORDS} records")
        if len(data) - offset < 9:
            raise RecordingError(f"{path}: the records {where} are cut")
        opcode, length = data[offset], int.from_bytes(view[offset + 1:offset + 9], "little")
        body_start = offset + 9
        offset = body_start + length
        if offset > len(data) or length > caps.get(opcode, MAX_RECORD_BYTES):
            raise RecordingError(f"{path}: a record {where} declares {length} bytes, more than it can hold")
        if opcode == Opcode.MESSAGE:
            yield _message(view[body_start:offset], path, where, wants_channel)
        elif opcode in (Opcode.SCHEMA, Opcode.CHANNEL):
            kind = Schema if opcode == Opcode.SCHEMA else Channel
            yield kind.__name__.lower(), _parse(kind, bytes(view[body_start:offset]), path, start)


def _mcap_records(path: Path, state: dict, wants_channel=lambda channel_id: False):
    """``(kind, record)`` of an MCAP file in file order, every bound of this module checked as the records come.

    Kinds: ``"schema"``, ``"channel"``, ``"message"`` (a message of a channel
    ``wants_channel`` accepts, with its data), ``"skipped"`` (any other
    message: counted, not read), ``"chunk"`` (``(start offset, Chunk,
    messages)`` once its records are through), ``"chunk_index"``,
    ``"data_end"`` (the offset after it), ``"footer"`` (``(start offset, Footer)``).
    Records other readers do not need are skipped unread. Stops quietly at
    the end of what is readable (a cut file); ``state`` gets ``complete``,
    ``bytes_read`` (the end of the last whole record) and ``stopped`` (why it
    ended early). A record beyond its cap, a chunk beyond the chunk bounds or
    a malformed record is a RecordingError.
    """
    import os

    from mcap.opcode import Opcode
    from mcap.records import Channel, Chunk, ChunkIndex, Footer, Schema

    from .files import open_regular_file

    try:
        raw = open_regular_file(path, "recording", MAX_RECORDING_BYTES)
    except ValueError as error:
        raise RecordingError(str(error)) from None
    caps = _record_caps()
    parsed = {Opcode.SCHEMA: (Schema, "schema"), Opcode.CHANNEL: (Channel, "channel"),
              Opcode.CHUNK_INDEX: (ChunkIndex, "chunk_index"), Opcode.FOOTER: (Footer, "footer")}
    state.update(complete=False, bytes_read=0, stopped=None)

    def stop(reason: str) -> None:
        state["stopped"] = reason if state["bytes_read"] else f"not an MCAP file ({reason})"

    with raw:
        size = os.fstat(raw.fileno()).st_size
        if raw.read(len(_MCAP_MAGIC)) != _MCAP_MAGIC:
            stop("no MCAP magic at its start")
            return
        position = len(_MCAP_MAGIC)
        while True:
            head = raw.read(9)
            if len(head) < 9:
                stop("no footer, the file ends after a whole record" if not head else "cut inside a record")
                return
            opcode, length = head[0], int.from_bytes(head[1:], "little")
            cap = caps.get(opcode, MAX_RECORD_BYTES)
            if length > cap:
                raise RecordingError(f"{path}: a record declares {length} bytes, more than the {cap} allowed")
            start, end = position, position + 9 + length
            if end > size:
                stop("cut inside a record")
                return
            if opcode in parsed or opcode in (Opcode.CHUNK, Opcode.MESSAGE):
                body = raw.read(length)
                if len(body) < length:
                    stop("cut inside a record")
                    return
            else:
                raw.seek(length, os.SEEK_CUR)  # not needed by any reader here: not read
            position = state["bytes_read"] = end
            if opcode == Opcode.CHUNK:
                chunk = _parse(Chunk, body, path, start)
                del body
                messages = 0
                for kind, record in _chunk_records(_decompress_chunk(chunk, path), path, start, wants_channel, caps):
                    messages += kind in ("message", "skipped")
                    yield kind, record
                yield "chunk", (start, replace(chunk, data=b""), messages)
            elif opcode == Opcode.MESSAGE:
                yield _message(memoryview(body), path, f"at byte {start}", wants_channel)
            elif opcode in parsed:
                kind, name = parsed[opcode]
                record = _parse(kind, body, path, start)
                if opcode == Opcode.FOOTER:
                    yield name, (start, record)
                    state["complete"] = True
                    return
                yield name, record
            elif opcode == Opcode.DATA_END:
                yield "data_end", end


class _Layout:
    """What one walk of an MCAP file found that rosbags' reading of it depends on, checked against the bounds."""

    def __init__(self, path):
        self.path = path
        self.schemas = {}  # id → (bytes rosbags parses, definitions, fields)
        self.channels = {}  # id → (schema id, bytes of its names and metadata, bytes of its metadata)
        self.chunks = {}  # start offset → (Chunk without data, messages)
        self.indexes = []
        self.summary_start = None  # where a summary may start: after the DataEnd record
        self.footer = None
        self.messages = 0
        self.definitions = self.fields = self.qos = 0  # summed over the schemas and channels: running totals

    def add(self, kind: str, record) -> None:
        path = self.path
        if kind in ("message", "skipped"):
            self.messages += 1
        elif kind == "schema":  # a schema seen again (the summary repeats them) counts its largest version
            cost = len(record.data) + len(record.name) + len(record.encoding)
            old = self.schemas.get(record.id, (0, 0, 0))
            new = (max(old[0], cost), max(old[1], _definitions(record.data)), max(old[2], _fields(record.data)))
            self.schemas[record.id] = new
            self.definitions += new[1] - old[1]
            self.fields += new[2] - old[2]
            _check_definitions(path, self.definitions, self.fields)
        elif kind == "channel":
            metadata = sum(len(key) + len(value) for key, value in record.metadata.items())
            old = self.channels.get(record.id, (record.schema_id, 0, 0))
            new = (record.schema_id, max(old[1], len(record.topic) + len(record.message_encoding) + metadata),
                   max(old[2], metadata))
            self.channels[record.id] = new
            self.qos += new[2] - old[2]
            if len(self.channels) > MAX_CONNECTIONS:
                raise RecordingError(f"{path}: more than {MAX_CONNECTIONS} channels")
            if self.qos > MAX_QOS_BYTES:
                raise RecordingError(f"{path}: its channels' metadata (QoS profiles) is {self.qos} bytes, more than "
                                     f"the {MAX_QOS_BYTES} allowed")
        elif kind == "chunk":
            start, chunk, messages = record
            self.chunks[start] = (chunk, messages)
        elif kind == "chunk_index":
            self.indexes.append(record)
            if len(self.indexes) > MAX_CHUNK_INDEXES:
                raise RecordingError(f"{path}: more than {MAX_CHUNK_INDEXES} chunk indexes")
        elif kind == "data_end":
            self.summary_start = record
        elif kind == "footer":
            self.footer = record

    def check(self) -> None:
        """The bounds that need the whole walk; RecordingError naming the first one broken."""
        path = self.path
        parsed = sum(self.schemas.get(schema_id, (0, 0, 0))[0] + cost for schema_id, cost, _ in self.channels.values())
        if parsed > MAX_DEFINITION_BYTES:
            raise RecordingError(f"{path}: its channels' definitions and metadata are {parsed} bytes to parse, more "
                                 f"than the {MAX_DEFINITION_BYTES} allowed")
        if self.footer is None:
            return
        footer_start, footer = self.footer
        if footer.summary_start not in (0, self.summary_start, footer_start):
            raise RecordingError(f"{path}: its footer puts the summary at byte {footer.summary_start}, where no "
                                 "record starts")
        held = []
        for index in self.indexes:
            chunk, messages = self.chunks.get(index.chunk_start_offset, (None, 0))
            if chunk is None or (index.compression, index.uncompressed_size, index.message_start_time,
                                 index.message_end_time) != (chunk.compression, chunk.uncompressed_size,
                                                             chunk.message_start_time, chunk.message_end_time):
                raise RecordingError(f"{path}: a chunk index points at byte {index.chunk_start_offset}, where no "
                                     "such chunk is")
            held.append((index.message_start_time, index.message_end_time,
                         chunk.uncompressed_size + _MESSAGE_OBJECT_BYTES * messages))
        peak = _peak_overlap(held)
        if peak > MAX_OVERLAPPING_CHUNK_BYTES:
            raise RecordingError(f"{path}: its chunks overlap in log time: {peak} bytes would be held at once, more "
                                 f"than the {MAX_OVERLAPPING_CHUNK_BYTES} allowed")


def _check_definitions(path, definitions: int, fields: int) -> None:
    """RecordingError if the distinct schemas of a file hold more ``definitions`` than :data:`MAX_DEFINITIONS` or
    declare more ``fields`` than :data:`MAX_DEFINITION_FIELDS` (each summed over the schemas)."""
    if definitions > MAX_DEFINITIONS:
        raise RecordingError(f"{path}: its schemas hold more than {MAX_DEFINITIONS} message definitions")
    if fields > MAX_DEFINITION_FIELDS:
        raise RecordingError(f"{path}: its schemas declare more than {MAX_DEFINITION_FIELDS} fields")


def _peak_overlap(intervals) -> int:
    """The largest sum of ``weight`` over ``(start, end, weight)`` intervals that share an instant (ends included)."""
    events = sorted([(start, 0, weight) for start, _, weight in intervals]
                    + [(end, 1, -weight) for _, end, weight in intervals])
    held = peak = 0
    for _, _, weight in events:
        held += weight
        peak = max(peak, held)
    return peak


@functools.lru_cache(maxsize=8)
def _scan_cached(path: str, size: int, mtime_ns: int) -> McapScan:
    state = {}
    layout = _Layout(path)
    for kind, record in _mcap_records(Path(path), state):
        layout.add(kind, record)
    layout.check()
    complete = state.get("complete", False)
    return McapScan(complete, layout.messages, state.get("bytes_read", 0), size,
                    None if complete else state.get("stopped"))


def scan_mcap(path: str | Path) -> McapScan:
    """Walk an MCAP file once, record by record, with every bound of this module; RecordingError past a bound."""
    from .files import check_regular_file

    try:
        info = check_regular_file(path, "recording", MAX_RECORDING_BYTES)
    except ValueError as error:
        raise RecordingError(str(error)) from None
    return _scan_cached(str(path), info.st_size, info.st_mtime_ns)


def _is_mcap(path: Path) -> bool:
    from .files import open_regular_file

    try:
        with open_regular_file(path, "recording", MAX_RECORDING_BYTES) as stream:
            return stream.read(5) == b"\x89MCAP"
    except ValueError:
        return False


def _is_sqlite(path: Path) -> bool:
    from .files import open_regular_file

    try:
        with open_regular_file(path, "recording", MAX_RECORDING_BYTES) as stream:
            return stream.read(16) == b"SQLite format 3\x00"
    except ValueError:
        return False


def _sqlite(path: Path):
    """A read-only connection to a sqlite3 recording file, as rosbags opens it (the same SQLite library)."""
    import apsw

    try:
        return apsw.Connection(f"file:{path}?immutable=1", flags=apsw.SQLITE_OPEN_READONLY | apsw.SQLITE_OPEN_URI)
    except apsw.Error as error:
        raise RecordingError(f"{path}: cannot read the recording ({_reason(error)})") from None


@functools.lru_cache(maxsize=8)
def _check_sqlite_cached(path: str, size: int, mtime_ns: int) -> None:
    """:func:`check_sqlite` once per file version."""
    import apsw

    connection = _sqlite(Path(path))
    try:
        tables = {name for (name,) in connection.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if not {"messages", "topics"} <= tables:
            return  # not a rosbag2 file: rosbags says so
        columns = {row[1] for row in connection.execute("PRAGMA table_info(topics)")}
        (topics,) = connection.execute("SELECT count(*) FROM topics").fetchone()
        if topics > MAX_CONNECTIONS:
            raise RecordingError(f"{path}: more than {MAX_CONNECTIONS} topics")
        # What rosbags reads for each topic, in bytes (octet_length reads no text: the size is in the record).
        cost = " + ".join(f"coalesce(octet_length(t.{name}), 0)" for name in
                          ("name", "type", "serialization_format", "offered_qos_profiles", "type_description_hash")
                          if name in columns)
        definitions = []
        if "message_definitions" in tables:
            (rows, stored) = connection.execute(
                "SELECT count(*), coalesce(sum(octet_length(encoded_message_definition) + octet_length(topic_type)), 0)"
                " FROM message_definitions").fetchone()
            if rows > MAX_CONNECTIONS or stored > MAX_DEFINITION_BYTES:
                raise RecordingError(f"{path}: {rows} message definitions of {stored} bytes, more than the "
                                     f"{MAX_CONNECTIONS} and {MAX_DEFINITION_BYTES} bytes allowed")
            cost += (" + coalesce((SELECT octet_length(d.encoded_message_definition) FROM message_definitions d "
                     "WHERE d.topic_type = t.type ORDER BY d.id LIMIT 1), 0)")
            definitions = [text for (text,) in connection.execute(
                "SELECT encoded_message_definition FROM message_definitions")]
        if "offered_qos_profiles" in columns:
            (qos,) = connection.execute("SELECT coalesce(sum(octet_length(offered_qos_profiles)), 0) FROM topics")\
                .fetchone()
            if qos > MAX_QOS_BYTES:
                raise RecordingError(f"{path}: its topics' QoS profiles are {qos} bytes, more than the "
                                     f"{MAX_QOS_BYTES} allowed")
        (parsed,) = connection.execute(f"SELECT coalesce(sum({cost}), 0) FROM topics t").fetchone()
        if parsed > MAX_DEFINITION_BYTES:
            raise RecordingError(f"{path}: its topics' definitions and QoS profiles are {parsed} bytes to parse, "
                                 f"more than the {MAX_DEFINITION_BYTES} allowed")
        texts = [str(text).encode("utf-8", "replace") for text in definitions]
        _check_definitions(path, sum(map(_definitions, texts)), sum(map(_fields, texts)))
    except apsw.Error as error:
        raise RecordingError(f"{path}: cannot read the recording ({_reason(error)})") from None
    finally:
        connection.close()


def check_sqlite(path: str | Path) -> None:
    """Check a sqlite3 (.db3) recording file against the bounds rosbags' opening of it needs.

    At most :data:`MAX_CONNECTIONS` topics; their QoS profiles at most
    :data:`MAX_QOS_BYTES`; the text rosbags parses (each topic's definition,
    QoS profiles and names) at most :data:`MAX_DEFINITION_BYTES`; the definitions at most
    :data:`MAX_DEFINITIONS` and their fields :data:`MAX_DEFINITION_FIELDS`.
    Sizes are asked of SQLite, which keeps them beside the values: no text is
    read before it is known to be small.
    RecordingError naming the bound.
    """
    from .files import check_regular_file

    try:
        info = check_regular_file(path, "recording", MAX_RECORDING_BYTES)
    except ValueError as error:
        raise RecordingError(str(error)) from None
    _check_sqlite_cached(str(path), info.st_size, info.st_mtime_ns)


def _check_sqlite_messages(path: Path, topics) -> None:
    """No message of ``topics`` in a sqlite3 recording file is larger than :data:`MAX_MESSAGE_BYTES`.

    Asked before any message is read: rosbags reads a message whole, and a
    single row can hold gigabytes. One pass over the messages' sizes (not
    their data).
    """
    import apsw

    topics = sorted(topics)
    if not topics:
        return
    connection = _sqlite(path)
    try:
        marks = ", ".join("?" for _ in topics)
        (largest,) = connection.execute(
            "SELECT max(octet_length(m.data)) FROM messages m JOIN topics t ON m.topic_id = t.id "
            f"WHERE t.name IN ({marks})", topics).fetchone()
    except apsw.Error as error:
        raise RecordingError(f"{path}: cannot read the recording ({_reason(error)})") from None
    finally:
        connection.close()
    if largest is not None and largest > MAX_MESSAGE_BYTES:
        raise RecordingError(f"{path}: a message of the topics read is {largest} bytes, more than the "
                             f"{MAX_MESSAGE_BYTES} allowed")


def _storage_files(path: Path) -> list[Path]:
    """The files of a recording that hold messages: the file itself, or a directory's MCAP and sqlite3 files."""
    if not path.is_dir():
        return [path]
    return [entry for entry in sorted(path.iterdir()) if _is_mcap(entry) or _is_sqlite(entry)]


def _check_bag_directory(path: Path) -> list[Path]:
    """Every entry of a rosbag2 directory a regular file, metadata.yaml bounded; returns its MCAP files."""
    from .files import check_regular_file, read_yaml_file

    try:
        entries = sorted(path.iterdir())
    except OSError as error:
        raise RecordingError(f"{path}: cannot list the recording ({error.strerror})") from None
    if len(entries) > MAX_BAG_FILES:
        raise RecordingError(f"{path}: more than {MAX_BAG_FILES} files in the recording directory")
    try:
        for entry in entries:
            check_regular_file(entry, "recording file", MAX_RECORDING_BYTES)
        metadata = path / "metadata.yaml"
        if metadata.exists():
            document = read_yaml_file(metadata, "recording metadata", MAX_BAG_METADATA_BYTES)
            info = document.get("rosbag2_bagfile_information") if isinstance(document, dict) else None
            mode = str((info or {}).get("compression_mode") or "").lower()
            if mode not in ("", "none"):
                raise RecordingError(f"{path}: rosbag2 compression mode {mode!r} is not read (its sizes cannot "
                                     "be bounded before decompression); `ros2 bag convert` it uncompressed")
    except RecordingError:
        raise
    except ValueError as error:
        raise RecordingError(str(error)) from None
    return [entry for entry in entries if _is_mcap(entry)]


def recording_status(path: str | Path) -> McapScan | None:
    """How much of a bare MCAP recording is readable (None for a directory or another format).

    RecordingError if any file of the recording breaks a bound (not a regular
    file, a record or chunk too large, a chunk that expands beyond what it
    declares, more definitions or connections than rosbags may parse: see
    :func:`scan_mcap` and :func:`check_sqlite`).
    """
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        raise RecordingError(f"{path}: no such file or directory")
    if path.is_dir():
        for storage in _check_bag_directory(path):
            scan = scan_mcap(storage)
            if not scan.complete:
                raise RecordingError(f"{storage}: the recording is cut short ({scan.stopped}); give the .mcap "
                                     "file itself to read what it holds")
        for storage in _storage_files(path):
            if _is_sqlite(storage):
                check_sqlite(storage)
        return None
    if _is_mcap(path):
        return scan_mcap(path)
    if _is_sqlite(path):
        check_sqlite(path)
        return None
    from .files import check_regular_file

    try:
        check_regular_file(path, "recording", MAX_RECORDING_BYTES)
    except ValueError as error:
        raise RecordingError(str(error)) from None
    return None


class _StreamConnection:
    """The topic and type of an MCAP channel, as rosbags' connections give them."""

    def __init__(self, topic: str, msgtype: str):
        self.topic, self.msgtype = topic, msgtype


def _stream_connections(path: Path):
    """Channels of a cut MCAP file as ``{channel id: _StreamConnection}`` (one bounded walk)."""
    schemas, channels = {}, {}
    for kind, record in _mcap_records(path, {}):
        if kind == "schema":
            schemas[record.id] = record.name
        elif kind == "channel":
            channels[record.id] = _StreamConnection(record.topic, schemas.get(record.schema_id, ""))
    return channels


def _iter_stream(path: Path, wanted: dict[str, tuple[str, ...]]):
    """``(topic, RecordedMessage)`` of a cut MCAP file, in file order (the order this package writes in)."""
    typestore = _jazzy_typestore()
    schemas, channels = {}, {}
    for kind, record in _mcap_records(path, {}, wants_channel=channels.__contains__):
        if kind == "schema":
            schemas[record.id] = record.name
        elif kind == "channel":
            accepted = wanted.get(record.topic)
            msgtype = schemas.get(record.schema_id, "")
            if accepted is not None:
                if msgtype not in accepted:
                    raise RecordingError(f"{path}: {record.topic} is {msgtype}, expected " + " or ".join(accepted))
                channels[record.id] = (record.topic, msgtype)
        elif kind == "message":
            topic, msgtype = channels[record.channel_id]
            try:
                message = typestore.deserialize_cdr(record.data, msgtype)
            except Exception as error:
                raise RecordingError(f"{path}: cannot read a {topic} message ({_reason(error)})") from None
            yield topic, RecordedMessage(int(record.log_time), message)


def _reason(error: Exception) -> str:
    text = " ".join(str(error).split()) or type(error).__name__
    return text if len(text) <= 200 else text[:197] + "..."


def _checked_connections(path: Path, reader, wanted: dict[str, tuple[str, ...]]) -> list:
    connections = []
    for connection in reader.connections:
        accepted = wanted.get(connection.topic)
        if accepted is None:
            continue
        if connection.msgtype not in accepted:
            raise RecordingError(f"{path}: {connection.topic} is {connection.msgtype}, expected "
                                 + " or ".join(accepted))
        connections.append(connection)
    return connections


class Recording:
    """An open recording: its topics and their messages, every bound checked before rosbags reads anything.

    Use :func:`open_recording`. A complete recording is opened once with
    rosbags' ``AnyReader`` (which parses every connection's definition:
    :data:`MAX_DEFINITION_BYTES` bounds that) and read as often as asked; an
    MCAP file cut short (no footer) is read as a stream, each time.
    """

    def __init__(self, path: Path, status: McapScan | None, reader=None):
        self.path, self.status, self._reader = path, status, reader

    def topics(self, wanted: dict[str, tuple[str, ...]]) -> set[str]:
        """The topics of ``wanted`` (``{topic: accepted types}``) the recording has; RecordingError on a wrong type."""
        if self._reader is None:
            found = set()
            for connection in _stream_connections(self.path).values():
                accepted = wanted.get(connection.topic)
                if accepted is None:
                    continue
                if connection.msgtype not in accepted:
                    raise RecordingError(f"{self.path}: {connection.topic} is {connection.msgtype}, expected "
                                         + " or ".join(accepted))
                found.add(connection.topic)
            return found
        return {connection.topic for connection in _checked_connections(self.path, self._reader, wanted)}

    def messages(self, wanted: dict[str, tuple[str, ...]]) -> Iterator[tuple[str, RecordedMessage]]:
        """``(topic, message)`` of the topics in ``wanted``, in log-time order (a cut file: in file order)."""
        path = self.path
        if self._reader is None:
            yield from _iter_stream(path, wanted)
            return
        connections = _checked_connections(path, self._reader, wanted)
        if not connections:
            return
        for storage in _storage_files(path):
            if _is_sqlite(storage):
                _check_sqlite_messages(storage, {connection.topic for connection in connections})
        try:
            for connection, log_time_ns, data in self._reader.messages(connections=connections):
                if len(data) > MAX_MESSAGE_BYTES:
                    raise RecordingError(f"{path}: a {connection.topic} message is {len(data)} bytes, more than the "
                                         f"{MAX_MESSAGE_BYTES} allowed for the topics read")
                yield connection.topic, RecordedMessage(int(log_time_ns),
                                                        self._reader.deserialize(data, connection.msgtype))
        except RecordingError:
            raise
        except Exception as error:
            raise RecordingError(f"{path}: cannot read the recording ({_reason(error)})") from None


@contextmanager
def open_recording(path: str | Path):
    """A :class:`Recording` of ``path`` (a rosbag2 directory, an MCAP or a sqlite3 file), closed on leaving.

    Every bound is checked first (:func:`recording_status`); RecordingError
    (one line) if the recording breaks one or cannot be opened.
    """
    from rosbags.highlevel import AnyReader

    path = Path(path)
    status = recording_status(path)
    if status is not None and not status.complete:
        yield Recording(path, status)
        return
    try:
        reader = AnyReader([path], default_typestore=_jazzy_typestore())
        reader.open()
    except Exception as error:  # rosbags' reader, storage and type-system errors, struct errors of a cut file
        raise RecordingError(f"{path}: cannot read the recording ({_reason(error)})") from None
    try:
        yield Recording(path, status, reader)
    finally:
        reader.close()


def recorded_topics(path: str | Path, wanted: dict[str, tuple[str, ...]]) -> set[str]:
    """The topics of ``wanted`` (``{topic: accepted types}``) the recording has; RecordingError on a wrong type."""
    with open_recording(path) as recording:
        return recording.topics(wanted)


def iter_recording(path: str | Path, wanted: dict[str, tuple[str, ...]]) -> Iterator[tuple[str, RecordedMessage]]:
    """``(topic, message)`` for every message of the topics in ``wanted``, in log-time order, one at a time.

    Memory does not grow with the recording. A topic whose type is not among
    the accepted ones, an unreadable message or one larger than
    :data:`MAX_MESSAGE_BYTES` is a :class:`RecordingError`. An MCAP file cut
    short (no footer) is read as a stream up to its last whole chunk, in the
    order it was written.
    """
    with open_recording(path) as recording:
        yield from recording.messages(wanted)


def read_recording(path: str | Path, wanted: dict[str, tuple[str, ...]]) -> dict[str, list[RecordedMessage]]:
    """The messages of the topics in ``wanted`` (``{topic: accepted types}``) as lists, in log-time order.

    For small recordings and tests (:func:`iter_recording` streams). A topic of
    ``wanted`` that is not in the recording is left out of the result.
    """
    with open_recording(path) as recording:
        result: dict[str, list[RecordedMessage]] = {topic: [] for topic in recording.topics(wanted)}
        for topic, message in recording.messages(wanted):
            result[topic].append(message)
    return result
