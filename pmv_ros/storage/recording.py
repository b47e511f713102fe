"""Recordings: rosbag2 MCAP files written with ``mcap``, and rosbag2 recordings of any stack read with ``rosbags``.

Writing (``pmv simulate --record FILE.mcap``)
    :class:`McapRecording` writes one MCAP file in the ``ros2`` profile — what
    ``ros2 bag record -s mcap`` stores (Jazzy's default storage) and what
    ``ros2 bag info/play FILE.mcap`` and Foxglove open: a schema per message
    type (``ros2msg``, the full definition with its dependencies, from
    ``rosbags``' Jazzy type store), a channel per topic (``cdr``), and the
    messages as the CDR bytes the subscription received, unchanged. The
    container is written by the ``mcap`` library; nothing here knows its byte
    layout.

Reading (``pmv analyze RECORDING``)
    :func:`read_recording` opens a rosbag2 directory (``metadata.yaml`` plus
    its storage files), a bare ``.mcap`` file or a bare ``.db3`` (sqlite3)
    file with ``rosbags`` and returns the messages of the topics asked for,
    deserialised from the definitions the recording carries (Jazzy's standard
    definitions where it carries none). Fields are read by name, so the
    shim's ``read_*`` functions take these messages as they take rclpy's.
    Every defect — no such file, not a recording, a missing topic, a topic of
    another type, an unreadable message — is a :class:`RecordingError` with
    one sentence naming it.

Bounds and recovery
    Before any library reads a recording, :func:`scan_mcap` walks an MCAP
    file record by record: every file of a recording must be a regular file
    (a FIFO or a device would block or never end), no record may be longer
    than :data:`MAX_RECORD_BYTES`, and each compressed chunk's declared size
    is checked against :data:`MAX_CHUNK_BYTES` before it is decompressed —
    and then decompressed with that bound, so a chunk that expands beyond
    what it declares is refused, not inflated. An MCAP file without its
    footer (the writer was killed, the disk filled up) is read the same way,
    as a stream, up to the last whole chunk; :func:`recording_status` says
    how much was recovered. The writer flushes a chunk at least every
    :data:`FLUSH_INTERVAL_S` of wall time, so ``kill -9`` loses at most that
    much of a recording.
"""

from __future__ import annotations

import functools
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


class _CappedStream:
    """A file's ``read`` that refuses any single read longer than ``cap`` (a forged length never allocates)."""

    def __init__(self, stream, cap: int, path):
        self._stream, self._cap, self._path = stream, cap, path
        self.position = 0
        self.short = False  # a read returned less than asked: the file ends inside a record

    def read(self, size: int = -1) -> bytes:
        if size is None or size < 0 or size > self._cap:
            raise RecordingError(f"{self._path}: a record declares {size} bytes, more than the "
                                 f"{self._cap} allowed")
        data = self._stream.read(size)
        self.position += len(data)
        self.short = self.short or len(data) < size
        return data


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


def _mcap_records(path: Path, state: dict):
    """Schema, Channel and Message records of an MCAP file in file order, chunks decompressed with bounds.

    Stops quietly at the end of what is readable (a cut file); ``state`` gets
    ``complete``, ``bytes_read`` (the end of the last whole record) and
    ``stopped`` (why it ended early). A record or chunk beyond the caps is a
    RecordingError.
    """
    from mcap.records import Chunk, Channel, Footer, Message, Schema
    from mcap.stream_reader import StreamReader, breakup_chunk

    from .files import open_regular_file

    try:
        raw = open_regular_file(path, "recording", MAX_RECORDING_BYTES)
    except ValueError as error:
        raise RecordingError(str(error)) from None
    state.update(complete=False, bytes_read=0, stopped=None)
    with raw:
        capped = _CappedStream(raw, MAX_RECORD_BYTES, path)
        records = StreamReader(capped, emit_chunks=True, record_size_limit=MAX_RECORD_BYTES).records
        while True:
            try:
                record = next(records)
                if capped.short:
                    raise EOFError("cut inside a record")
                if isinstance(record, Chunk):
                    inner = breakup_chunk(replace(record, compression="", data=_decompress_chunk(record, path)))
                else:
                    inner = [record]
            except RecordingError:
                raise
            except StopIteration:
                state["stopped"] = "no footer"
                return
            except Exception as error:  # a cut record: EndOfFile, a short read, struct errors of a partial header
                if capped.position == state["bytes_read"]:
                    reason = "no footer, the file ends after a whole record"
                else:
                    reason = "cut inside a record" if capped.short else _reason(error)
                state["stopped"] = reason if state["bytes_read"] else f"not an MCAP file ({reason})"
                return
            state["bytes_read"] = capped.position
            for item in inner:
                if isinstance(item, (Schema, Channel, Message)):
                    yield item
            if isinstance(record, Footer):
                state["complete"] = True
                return


@functools.lru_cache(maxsize=8)
def _scan_cached(path: str, size: int, mtime_ns: int) -> McapScan:
    from mcap.records import Message

    state = {}
    messages = sum(1 for record in _mcap_records(Path(path), state) if isinstance(record, Message))
    complete = state.get("complete", False)
    return McapScan(complete, messages, state.get("bytes_read", 0), size, None if complete else state.get("stopped"))


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
            document = read_yaml_file(metadata, "recording metadata")
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
    file, a record or chunk too large, a chunk that expands beyond what it declares).
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
        return None
    if _is_mcap(path):
        return scan_mcap(path)
    from .files import check_regular_file

    try:
        check_regular_file(path, "recording", MAX_RECORDING_BYTES)
    except ValueError as error:
        raise RecordingError(str(error)) from None
    return None


@contextmanager
def _open(path: Path):
    """An open rosbags ``AnyReader`` of ``path``, closed on leaving; RecordingError if it cannot be opened."""
    from rosbags.highlevel import AnyReader

    recording_status(path)  # every bound checked before rosbags reads anything
    try:
        reader = AnyReader([path], default_typestore=_jazzy_typestore())
        reader.open()
    except Exception as error:  # rosbags' reader, storage and type-system errors, struct errors of a cut file
        raise RecordingError(f"{path}: cannot read the recording ({_reason(error)})") from None
    try:
        yield reader
    finally:
        reader.close()


class _StreamConnection:
    """The topic and type of an MCAP channel, as rosbags' connections give them."""

    def __init__(self, topic: str, msgtype: str):
        self.topic, self.msgtype = topic, msgtype


def _stream_connections(path: Path):
    """Channels of a cut MCAP file as ``{channel id: _StreamConnection}`` (one bounded walk)."""
    from mcap.records import Channel, Schema

    schemas, channels = {}, {}
    for record in _mcap_records(path, {}):
        if isinstance(record, Schema):
            schemas[record.id] = record.name
        elif isinstance(record, Channel):
            channels[record.id] = _StreamConnection(record.topic, schemas.get(record.schema_id, ""))
    return channels


def _iter_stream(path: Path, wanted: dict[str, tuple[str, ...]]):
    """``(topic, RecordedMessage)`` of a cut MCAP file, in file order (the order this package writes in)."""
    from mcap.records import Channel, Message, Schema

    typestore = _jazzy_typestore()
    schemas, channels = {}, {}
    for record in _mcap_records(path, {}):
        if isinstance(record, Schema):
            schemas[record.id] = record.name
        elif isinstance(record, Channel):
            accepted = wanted.get(record.topic)
            msgtype = schemas.get(record.schema_id, "")
            if accepted is not None:
                if msgtype not in accepted:
                    raise RecordingError(f"{path}: {record.topic} is {msgtype}, expected " + " or ".join(accepted))
                channels[record.id] = (record.topic, msgtype)
        elif isinstance(record, Message) and record.channel_id in channels:
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
            raise RecordingError(f"{path}: {connection.topic} is {connection.msgtype}, expected " + " or ".join(accepted))
        connections.append(connection)
    return connections


def recorded_topics(path: str | Path, wanted: dict[str, tuple[str, ...]]) -> set[str]:
    """The topics of ``wanted`` (``{topic: accepted types}``) the recording has; RecordingError on a wrong type."""
    path = Path(path)
    status = recording_status(path)
    if status is not None and not status.complete:
        found = set()
        for connection in _stream_connections(path).values():
            accepted = wanted.get(connection.topic)
            if accepted is None:
                continue
            if connection.msgtype not in accepted:
                raise RecordingError(f"{path}: {connection.topic} is {connection.msgtype}, expected "
                                     + " or ".join(accepted))
            found.add(connection.topic)
        return found
    with _open(path) as reader:
        return {connection.topic for connection in _checked_connections(path, reader, wanted)}


def iter_recording(path: str | Path, wanted: dict[str, tuple[str, ...]]) -> Iterator[tuple[str, RecordedMessage]]:
    """``(topic, message)`` for every message of the topics in ``wanted``, in log-time order, one at a time.

    Memory does not grow with the recording. A topic whose type is not among
    the accepted ones or an unreadable message is a :class:`RecordingError`.
    An MCAP file cut short (no footer) is read as a stream up to its last
    whole chunk, in the order it was written.
    """
    path = Path(path)
    status = recording_status(path)
    if status is not None and not status.complete:
        yield from _iter_stream(path, wanted)
        return
    with _open(path) as reader:
        connections = _checked_connections(path, reader, wanted)
        if not connections:
            return
        try:
            for connection, log_time_ns, data in reader.messages(connections=connections):
                yield connection.topic, RecordedMessage(int(log_time_ns), reader.deserialize(data, connection.msgtype))
        except RecordingError:
            raise
        except Exception as error:
            raise RecordingError(f"{path}: cannot read the recording ({_reason(error)})") from None


def read_recording(path: str | Path, wanted: dict[str, tuple[str, ...]]) -> dict[str, list[RecordedMessage]]:
    """The messages of the topics in ``wanted`` (``{topic: accepted types}``) as lists, in log-time order.

    For small recordings and tests (:func:`iter_recording` streams). A topic of
    ``wanted`` that is not in the recording is left out of the result.
    """
    result: dict[str, list[RecordedMessage]] = {topic: [] for topic in recorded_topics(path, wanted)}
    for topic, message in iter_recording(path, wanted):
        result[topic].append(message)
    return result
