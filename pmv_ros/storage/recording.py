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
    Every defect — no such file, not a recording, a truncated file, a missing
    topic, a topic of another type, an unreadable message — is a
    :class:`RecordingError` with one sentence naming it.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

#: Library name written in the MCAP header (with the mcap library's own).
LIBRARY = "pmv_ros"


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
        self._writer = Writer(self._stream, compression=CompressionType.ZSTD)
        self._writer.start(profile=Profile.ROS2, library=LIBRARY)
        self._typestore = _jazzy_typestore()
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self.counts: dict[str, int] = {}
        self.types: dict[str, str] = {}
        self._closed = False

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
            self._schemas[type_name] = self._writer.register_schema(type_name, SchemaEncoding.ROS2,
                                                                    definition.encode())
        channel = self._writer.register_channel(topic, self._encoding, self._schemas[type_name])
        self._channels[topic] = channel
        self.counts[topic] = 0
        self.types[topic] = type_name
        return channel

    def write(self, topic: str, log_time_ns: int, data: bytes) -> None:
        """Add one serialised (CDR) message of a registered topic, received at ``log_time_ns``."""
        self._writer.add_message(self._channels[topic], log_time=int(log_time_ns), data=data,
                                 publish_time=int(log_time_ns), sequence=self.counts[topic])
        self.counts[topic] += 1

    def close(self) -> None:
        """Write the summary and close the file (idempotent)."""
        if self._closed:
            return
        self._closed = True
        try:
            self._writer.finish()
        finally:
            self._stream.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


@dataclass(frozen=True)
class RecordedMessage:
    """One message of a recording: the time it was logged (ns) and the message (fields by name)."""

    log_time_ns: int
    message: object


@contextmanager
def _open(path: Path):
    """An open rosbags ``AnyReader`` of ``path``, closed on leaving; RecordingError if it cannot be opened."""
    from rosbags.highlevel import AnyReader

    if not path.exists():
        raise RecordingError(f"{path}: no such file or directory")
    try:
        reader = AnyReader([path], default_typestore=_jazzy_typestore())
        reader.open()
    except Exception as error:  # rosbags' reader, storage and type-system errors, struct errors of a cut file
        raise RecordingError(f"{path}: cannot read the recording ({_reason(error)})") from None
    try:
        yield reader
    finally:
        reader.close()


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
    with _open(path) as reader:
        return {connection.topic for connection in _checked_connections(path, reader, wanted)}


def iter_recording(path: str | Path, wanted: dict[str, tuple[str, ...]]) -> Iterator[tuple[str, RecordedMessage]]:
    """``(topic, message)`` for every message of the topics in ``wanted``, in log-time order, one at a time.

    Memory does not grow with the recording. A topic whose type is not among
    the accepted ones, an unreadable message or a cut file is a
    :class:`RecordingError`.
    """
    path = Path(path)
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
