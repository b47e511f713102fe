"""Hostile recordings for ``pmv analyze``: well-formed files at and just past every bound of the readers.

Each case is a rosbag2 MCAP (or sqlite3) file built here, byte for byte
valid, that asks the most of one bound of :mod:`pmv_ros.storage.recording`
or :mod:`pmv_ros.apps.telemetry`: just under it the analysis runs to its
report within the figures stated below; just over it ``pmv analyze`` refuses
with one line naming the bound, exit status 2. The cases:

* the text rosbags parses when it opens a file (every channel's definition,
  parsed once a channel: 20 channels sharing one schema of 800 definitions,
  a 110 kB file, cost 4 s and 115 MB before, 15,000 per 1.4 MB as filed);
* the definitions the schemas hold (rosbags registers each: ≈ 45 kB);
* the channels of one file;
* the records of one chunk (1.9 million empty messages in a 35 MB file
  cost 23 s and 790 MB before, to say the topic was missing);
* chunks that overlap in log time, a chunk index that points at no chunk;
* a message of a topic read larger than 1 MiB in a sqlite3 file (one of
  200 MB took 0.7 GB before the refusal);
* a sensor's /diagnostics whose orbit period no orbit at its altitude has
  (it sets where every sample is on the orbit: 1 s made every sample an
  orbit of its own, the quadratic path of the harmonics);

and the orbit taken from the recording when the flags do not give it.
Every case runs ``pmv analyze`` as a child process, measured
(:mod:`bounded_run`): status, wall and CPU time, peak memory, printed.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from bounded_run import pmv, run_measured

pytestmark = [pytest.mark.adversarial, pytest.mark.multi_process]

#: What a refusal may cost: the bound of the other hostile-file tests (tests/system/test_hostile_files.py).
REFUSAL_CPU_S, REFUSAL_PEAK_MB = 10.0, 300.0

#: What a file just under the definitions bounds may cost to analyse: the worst text within them costs
#: ≈ 10 s to parse here (design/recording_bounds.py) and the analysis of a few hundred samples ≈ 2 s.
UNDER_CPU_S, UNDER_PEAK_MB = 60.0, 400.0

SAMPLES = 300  # sensor samples of the small recordings (30 s at 10 Hz): enough to analyse, quick to read

STANDARD_TOPICS = {"/diagnostics": "diagnostic_msgs/msg/DiagnosticArray",
                   "/star_tracker/attitude": "geometry_msgs/msg/QuaternionStamped",
                   "/pmv/attitude": "geometry_msgs/msg/Vector3Stamped"}


def _typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def _header(types, stamp_s: float, frame: str = "orbital"):
    sec = int(math.floor(stamp_s))
    nanosec = min(int(round((stamp_s - sec) * 1e9)), 999_999_999)
    return types["std_msgs/msg/Header"](stamp=types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec),
                                        frame_id=frame)


def _orbit_status(types, altitude_km: float, inclination_deg: float, period_s: float | None):
    """A /diagnostics message with the sensor's orbit status (its own writer: pmv_msgs_shim)."""
    import pmv_msgs_shim as shim
    from pmv_ros.physics.orbit.two_body import CircularOrbit

    period = CircularOrbit(altitude_km * 1e3, math.radians(inclination_deg)).period_s if period_s is None else period_s
    elements = shim.OrbitElements(epoch_utc="2016-11-11T00:00:00Z", epoch_stamp_s=0.0, altitude_km=altitude_km,
                                  inclination_deg=inclination_deg, raan_deg=0.0, arg_latitude_deg=0.0,
                                  period_s=period)
    status = shim.orbit_elements_status(elements)
    values = [types["diagnostic_msgs/msg/KeyValue"](key=k, value=v) for k, v in status.values]
    return types["diagnostic_msgs/msg/DiagnosticArray"](header=_header(types, 0.0, ""), status=[
        types["diagnostic_msgs/msg/DiagnosticStatus"](level=0, name=status.name, message=status.message,
                                                      hardware_id=status.hardware_id, values=values)])


def write_recording(path: Path, *, samples: int = SAMPLES, altitude_km: float = 500.0, inclination_deg: float = 74.5,
                    period_s: float | None = None, extra_schemas=(), extra_channels=(), junk_messages: int = 0,
                    chunk_size: int = 1 << 20, extra_qos: str = "") -> Path:
    """A rosbag2 MCAP of a sensor at 10 Hz with star-tracker truth and its orbit status on /diagnostics.

    ``extra_schemas``: ``(name, definition text)`` registered beside the standard ones; ``extra_channels``:
    ``(topic, index into extra_schemas)``, each with ``extra_qos`` as its QoS profiles; ``junk_messages``: empty
    messages on the first extra channel, written before the sensor's (in the first chunk).
    """
    from mcap.writer import Writer

    store = _typestore()
    types = store.types
    with open(path, "xb") as stream:
        writer = Writer(stream, chunk_size=chunk_size)
        writer.start(profile="ros2", library="pmv_ros tests")
        channels = {}
        for topic, type_name in STANDARD_TOPICS.items():
            definition, _ = store.generate_msgdef(type_name, ros_version=2)
            schema = writer.register_schema(type_name, "ros2msg", definition.encode())
            channels[topic] = writer.register_channel(topic, "cdr", schema)
        extra_ids = [writer.register_schema(name, "ros2msg", text.encode()) for name, text in extra_schemas]
        metadata = {"offered_qos_profiles": extra_qos} if extra_qos else {}
        extra = [writer.register_channel(topic, "cdr", extra_ids[index], metadata=metadata)
                 for topic, index in extra_channels]
        for i in range(junk_messages):
            writer.add_message(extra[0], log_time=i, data=b"\0\1\0\0", publish_time=i)
        status = _orbit_status(types, altitude_km, inclination_deg, period_s)
        writer.add_message(channels["/diagnostics"], log_time=junk_messages, publish_time=junk_messages,
                           data=bytes(store.serialize_cdr(status, STANDARD_TOPICS["/diagnostics"])))
        noise = np.random.default_rng(5).normal(0.0, 1e-3, size=(samples, 2))
        for i in range(samples):
            stamp_s = 1.0 + i / 10.0
            log_ns = junk_messages + int(round(stamp_s * 1e9))
            truth = types["geometry_msgs/msg/QuaternionStamped"](
                header=_header(types, stamp_s), quaternion=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0,
                                                                                                 w=1.0))
            sensor = types["geometry_msgs/msg/Vector3Stamped"](
                header=_header(types, stamp_s), vector=types["geometry_msgs/msg/Vector3"](
                    x=float(noise[i, 0]), y=float(noise[i, 1]), z=0.0))
            for topic, message in (("/star_tracker/attitude", truth), ("/pmv/attitude", sensor)):
                writer.add_message(channels[topic], log_time=log_ns, publish_time=log_ns,
                                   data=bytes(store.serialize_cdr(message, STANDARD_TOPICS[topic])))
        writer.finish()
    return path


def dense_definition(definitions: int) -> str:
    """A ros2msg schema text of ``definitions`` message definitions (the top one and its dependencies), dense:
    short names and fields, the dearest text per byte to parse (design/recording_bounds.py)."""
    top = "float64 x\n" + "".join(f"pkg/M{i} f{i}\n" for i in range(definitions - 1))
    parts = [top] + ["=" * 80 + f"\nMSG: pkg/M{i}\nfloat64 a\nint32 b\nstring c\n" for i in range(definitions - 1)]
    return "\n".join(parts)


#: The orbit of the recordings written here, given as the flags (the orbit test leaves them out).
ORBIT_FLAGS = ("--altitude-km", "500", "--inclination-deg", "74.5")


def _analyze(path: Path, *arguments, orbit_flags: bool = True, timeout_s: float = 240.0):
    run = run_measured(pmv("analyze", path, *(ORBIT_FLAGS if orbit_flags else ()), *arguments), timeout_s=timeout_s,
                       limit_mb=4096)
    print(f"{path.name} {' '.join(map(str, arguments))}: {run.summary()}")
    return run


def _refused(run, *phrases) -> str:
    """The one line of a refusal (status 2, nothing on stdout, no traceback), checked for ``phrases``."""
    assert run.status == 2, run
    lines = run.stderr.strip().splitlines()
    assert run.stdout == "" and len(lines) == 1 and "Traceback" not in run.stderr, run.stderr[-3000:]
    for phrase in phrases:
        assert phrase in lines[0], lines[0]
    assert run.cpu_s < REFUSAL_CPU_S and run.peak_mb <= REFUSAL_PEAK_MB, run
    return lines[0]


def _report(run) -> dict:
    assert run.status == 0, run.stderr[-3000:]
    return json.loads(run.stdout)


# ------------------------------------------------------------------------ definitions rosbags parses

def _definitions_file(tmp_path: Path, name: str, definitions: int, channels: int) -> Path:
    """The small recording plus ``channels`` channels sharing one dense schema of ``definitions`` definitions."""
    return write_recording(tmp_path / name, extra_schemas=[("pkg/msg/Top", dense_definition(definitions))],
                           extra_channels=[(f"/extra{i}", 0) for i in range(channels)])


def test_definition_text_just_under_the_bound_is_read_and_just_over_is_refused(tmp_path):
    from pmv_ros.storage.recording import MAX_DEFINITION_BYTES

    # 700 dense definitions are ≈ 95 kB: 9 channels of them are ≈ 0.86 MB of text, 11 ≈ 1.05 MB. The file as
    # filed: 20 channels of one 800-definition schema, 2.2 MB of text to parse in a 110 kB file.
    size = len(dense_definition(700).encode())
    under, over = MAX_DEFINITION_BYTES // size - 1, MAX_DEFINITION_BYTES // size + 1
    run = _analyze(_definitions_file(tmp_path, "under.mcap", 700, under), "--json")
    report = _report(run)
    assert report["per_sample"]["roll"]["count"] == SAMPLES
    assert run.cpu_s < UNDER_CPU_S and run.peak_mb <= UNDER_PEAK_MB, run
    line = _refused(_analyze(_definitions_file(tmp_path, "over.mcap", 700, over)),
                    "bytes to parse", f"more than the {MAX_DEFINITION_BYTES} allowed")
    print(f"{under} channels of {size} bytes read; {over} refused: {line}")
    _refused(_analyze(_definitions_file(tmp_path, "filed.mcap", 800, 20)), "bytes to parse")


def test_definitions_just_under_the_bound_are_read_and_just_over_are_refused(tmp_path):
    from pmv_ros.storage.recording import MAX_DEFINITIONS, _definitions

    store = _typestore()
    standard = sum(_definitions(store.generate_msgdef(type_name, ros_version=2)[0].encode())
                   for type_name in STANDARD_TOPICS.values())
    run = _analyze(_definitions_file(tmp_path, "under.mcap", MAX_DEFINITIONS - standard, 1), "--json")
    assert _report(run)["per_sample"]["roll"]["count"] == SAMPLES
    assert run.cpu_s < UNDER_CPU_S and run.peak_mb <= UNDER_PEAK_MB, run
    _refused(_analyze(_definitions_file(tmp_path, "over.mcap", MAX_DEFINITIONS - standard + 1, 1)),
             f"more than {MAX_DEFINITIONS} message definitions")


def test_fields_just_under_the_bound_are_read_and_just_over_are_refused(tmp_path):
    """One wide type: rosbags builds code for each field (≈ 8 kB each, design/recording_bounds.py)."""
    from pmv_ros.storage.recording import MAX_DEFINITION_FIELDS, _fields

    store = _typestore()
    standard = sum(_fields(store.generate_msgdef(type_name, ros_version=2)[0].encode())
                   for type_name in STANDARD_TOPICS.values())

    def made(name, fields):
        text = "".join(f"float64 a{k}\n" for k in range(fields))
        return write_recording(tmp_path / name, extra_schemas=[("pkg/msg/Wide", text)], extra_channels=[("/wide", 0)])

    run = _analyze(made("under.mcap", MAX_DEFINITION_FIELDS - standard), "--json")
    assert _report(run)["per_sample"]["roll"]["count"] == SAMPLES
    assert run.cpu_s < UNDER_CPU_S and run.peak_mb <= UNDER_PEAK_MB, run
    _refused(_analyze(made("over.mcap", MAX_DEFINITION_FIELDS - standard + 1)),
             f"more than {MAX_DEFINITION_FIELDS} fields")


def test_channels_just_under_the_bound_are_read_and_just_over_are_refused(tmp_path):
    from pmv_ros.storage.recording import MAX_CONNECTIONS

    def made(name, channels):
        return write_recording(tmp_path / name, extra_schemas=[("std_msgs/msg/Empty", "")],
                               extra_channels=[(f"/extra{i}", 0) for i in range(channels)])

    run = _analyze(made("under.mcap", MAX_CONNECTIONS - len(STANDARD_TOPICS)), "--json")
    assert _report(run)["per_sample"]["roll"]["count"] == SAMPLES
    assert run.cpu_s < UNDER_CPU_S and run.peak_mb <= UNDER_PEAK_MB, run
    _refused(_analyze(made("over.mcap", MAX_CONNECTIONS - len(STANDARD_TOPICS) + 1)),
             f"more than {MAX_CONNECTIONS} channels")


#: One publisher's QoS profile as rosbag2 writes it into a channel's metadata (YAML).
QOS_PROFILE = """- history: 3
  depth: 0
  reliability: 1
  durability: 2
  deadline:
    sec: 9223372036
    nsec: 854775807
  lifespan:
    sec: 9223372036
    nsec: 854775807
  liveliness: 1
  liveliness_lease_duration:
    sec: 9223372036
    nsec: 854775807
  avoid_ros_namespace_conventions: false
"""


def test_qos_profiles_just_under_the_bound_are_read_and_just_over_are_refused(tmp_path):
    """rosbags parses every channel's QoS profiles with a pure-Python YAML parser (≈ 16 µs a byte at worst)."""
    from pmv_ros.storage.recording import MAX_QOS_BYTES

    key = len("offered_qos_profiles")
    profiles = MAX_QOS_BYTES // 4 // len(QOS_PROFILE)  # on each of four channels
    qos = QOS_PROFILE * profiles
    room = MAX_QOS_BYTES // 4 - key - len(qos)
    under = qos + " " * room  # four channels of exactly a quarter of the bound
    run = _analyze(write_recording(tmp_path / "under.mcap", extra_schemas=[("std_msgs/msg/Empty", "")],
                                   extra_channels=[(f"/q{i}", 0) for i in range(4)], extra_qos=under), "--json")
    assert _report(run)["per_sample"]["roll"]["count"] == SAMPLES
    assert run.cpu_s < UNDER_CPU_S and run.peak_mb <= UNDER_PEAK_MB, run
    over = write_recording(tmp_path / "over.mcap", extra_schemas=[("std_msgs/msg/Empty", "")],
                           extra_channels=[(f"/q{i}", 0) for i in range(4)], extra_qos=under + " ")
    _refused(_analyze(over), "QoS profiles", f"more than the {MAX_QOS_BYTES} allowed")


def test_a_bag_metadata_file_past_its_bound_is_refused(tmp_path):
    """rosbags parses a directory's metadata.yaml again, with its pure-Python YAML parser."""
    from pmv_ros.storage.recording import MAX_BAG_METADATA_BYTES

    bag = tmp_path / "bag"
    bag.mkdir()
    write_recording(bag / "bag_0.mcap")
    head = ("rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n"
            "  relative_file_paths: [bag_0.mcap]\n")
    (bag / "metadata.yaml").write_text(head + "# " + "x" * (MAX_BAG_METADATA_BYTES - len(head) - 2) + "\n")
    _refused(_analyze(bag), "metadata.yaml", f"more than the {MAX_BAG_METADATA_BYTES} allowed")


# ------------------------------------------------------------------------ chunks

def test_records_of_a_chunk_just_under_the_bound_are_read_and_just_over_are_refused(tmp_path):
    from pmv_ros.storage.recording import MAX_CHUNK_RECORDS

    def made(name, junk):  # one chunk of 64 MiB holds them all: the junk, then the first sensor messages
        return write_recording(tmp_path / name, extra_schemas=[("std_msgs/msg/Empty", "")],
                               extra_channels=[("/junk", 0)], junk_messages=junk, chunk_size=64 << 20)

    # The chunk holds the four schemas and channels, the junk, the status and both topics' messages.
    junk = MAX_CHUNK_RECORDS - 2 * 4 - 1 - 2 * SAMPLES
    under = made("under.mcap", junk)
    assert _records_of_the_first_chunk(under) == MAX_CHUNK_RECORDS
    run = _analyze(under, "--json")
    assert _report(run)["per_sample"]["roll"]["count"] == SAMPLES
    assert run.cpu_s < UNDER_CPU_S and run.peak_mb <= UNDER_PEAK_MB, run
    _refused(_analyze(made("over.mcap", junk + 1)), f"more than {MAX_CHUNK_RECORDS} records")


def _records_of_the_first_chunk(path: Path) -> int:
    """Records of an MCAP file's first chunk, by the mcap library's own reader."""
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader, breakup_chunk

    with open(path, "rb") as stream:
        chunk = next(record for record in StreamReader(stream, emit_chunks=True).records if isinstance(record, Chunk))
    return len(breakup_chunk(chunk))


def _crafted_mcap(path: Path, chunks, indexes=None) -> Path:
    """A complete MCAP file: a schema and a channel, then ``chunks`` — ``(start_ns, end_ns, uncompressed bytes)``
    of empty messages of that channel, uncompressed — and a summary with their chunk indexes (``indexes``:
    ``(offset shift, chunk number)`` to point one elsewhere)."""
    from mcap.data_stream import RecordBuilder
    from mcap.records import Channel, Chunk, ChunkIndex, DataEnd, Footer, Header, Message, Schema
    from mcap.writer import MCAP0_MAGIC

    builder = RecordBuilder()
    Header(profile="ros2", library="crafted").write(builder)
    Schema(id=1, name="std_msgs/msg/Empty", encoding="ros2msg", data=b"").write(builder)
    Channel(id=1, topic="/junk", message_encoding="cdr", schema_id=1, metadata={}).write(builder)
    starts, written = [], []
    for start_ns, end_ns, size in chunks:
        inner = RecordBuilder()
        message_bytes = 9 + 22 + 4
        for i in range(max(1, size // message_bytes)):
            Message(channel_id=1, sequence=i, log_time=start_ns if i == 0 else end_ns, publish_time=0,
                    data=b"\0\1\0\0").write(inner)
        data = inner.end()
        starts.append(len(MCAP0_MAGIC) + builder.count)
        chunk = Chunk(compression="", data=data, message_start_time=start_ns, message_end_time=end_ns,
                      uncompressed_crc=0, uncompressed_size=len(data))
        chunk.write(builder)
        written.append(chunk)
    DataEnd(data_section_crc=0).write(builder)
    summary_start = len(MCAP0_MAGIC) + builder.count
    for shift, number in (indexes or [(0, n) for n in range(len(chunks))]):
        chunk = written[number]
        ChunkIndex(message_start_time=chunk.message_start_time, message_end_time=chunk.message_end_time,
                   chunk_start_offset=starts[number] + shift, chunk_length=9 + 40 + len(chunk.data),
                   message_index_offsets={}, message_index_length=0, compression="",
                   compressed_size=len(chunk.data), uncompressed_size=chunk.uncompressed_size).write(builder)
    Footer(summary_start=summary_start, summary_offset_start=0, summary_crc=0).write(builder)
    path.write_bytes(MCAP0_MAGIC + builder.end() + MCAP0_MAGIC)
    return path


def test_chunks_overlapping_in_log_time_beyond_the_bound_are_refused(tmp_path):
    from pmv_ros.storage.recording import MAX_OVERLAPPING_CHUNK_BYTES

    # 1 MiB chunks over one and the same second: a reader in log-time order holds them all at once.
    size = 1 << 20
    held = size + 220 * (size // 35)  # the chunk's bytes and its messages' objects, as the bound counts them
    count = MAX_OVERLAPPING_CHUNK_BYTES // held + 1
    path = _crafted_mcap(tmp_path / "overlap.mcap", [(0, 1_000_000_000, size)] * count)
    _refused(_analyze(path), "overlap in log time",
             f"more than the {MAX_OVERLAPPING_CHUNK_BYTES} allowed")
    # The same chunks one after another are read (to the refusal that the file has no sensor topic).
    sequential = _crafted_mcap(tmp_path / "sequential.mcap",
                               [(k * 10**9, k * 10**9 + 999_999_999, size) for k in range(count)])
    _refused(_analyze(sequential), "no topic /pmv/attitude")


def test_a_chunk_index_pointing_at_no_chunk_is_refused(tmp_path):
    path = _crafted_mcap(tmp_path / "index.mcap", [(0, 10, 4096), (20, 30, 4096)], indexes=[(0, 0), (7, 1)])
    _refused(_analyze(path), "a chunk index points at byte",
             "where no such chunk is")


# ------------------------------------------------------------------------ messages of sqlite3 files

def _sqlite_recording(folder: Path, size: int) -> Path:
    """A rosbag2 sqlite3 bag (written by rosbags) with truth, odometry and one /pmv/attitude message of ``size``
    bytes of CDR (a valid Vector3Stamped, padded)."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = _typestore()
    types = store.types
    with Writer(folder, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        sensor = writer.add_connection("/pmv/attitude", STANDARD_TOPICS["/pmv/attitude"], typestore=store)
        writer.add_connection("/star_tracker/attitude", STANDARD_TOPICS["/star_tracker/attitude"], typestore=store)
        diagnostics = writer.add_connection("/diagnostics", STANDARD_TOPICS["/diagnostics"], typestore=store)
        writer.write(diagnostics, 0, bytes(store.serialize_cdr(_orbit_status(types, 500.0, 74.5, None),
                                                               STANDARD_TOPICS["/diagnostics"])))
        message = types["geometry_msgs/msg/Vector3Stamped"](header=_header(types, 1.0), vector=types[
            "geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0))
        data = bytes(store.serialize_cdr(message, STANDARD_TOPICS["/pmv/attitude"]))
        writer.write(sensor, 1, data + bytes(size - len(data)))
    return next(folder.glob("*.db3"))


@pytest.mark.parametrize("size_mb", [1.01, 200.0])
def test_a_sqlite3_message_beyond_the_bound_is_refused_before_it_is_read(tmp_path, size_mb):
    from pmv_ros.storage.recording import MAX_MESSAGE_BYTES

    path = _sqlite_recording(tmp_path / "bag", int(size_mb * (1 << 20)))
    line = _refused(_analyze(path), f"more than the {MAX_MESSAGE_BYTES} allowed")
    assert f"{int(size_mb * (1 << 20))} bytes" in line


# ------------------------------------------------------------------------ the orbit on /diagnostics

def test_a_period_that_no_orbit_at_its_altitude_has_is_refused(tmp_path):
    """1 s at 500 km: every sample would be an orbit of its own (5,668 s is the orbit's period). Refused also
    where the flags give the orbit: the period places the samples."""
    path = write_recording(tmp_path / "period.mcap", samples=3000, period_s=1.0)
    _refused(_analyze(path), "period_s = 1 s is not the period of an orbit at 500 km")
    _refused(_analyze(path, orbit_flags=False), "period_s = 1 s is not the period of an orbit at 500 km")
    # Within the tolerance (a J2 or element-set period): read.
    from pmv_ros.physics.orbit.two_body import CircularOrbit

    period = CircularOrbit(500e3, math.radians(74.5)).period_s * 1.005
    assert _report(_analyze(write_recording(tmp_path / "j2.mcap", period_s=period), "--json"))["period_s"] > 0


def test_the_orbit_comes_from_the_recording_unless_the_flags_give_it(tmp_path):
    """Issue 51: the flags are no longer needed where the sensor's /diagnostics states its orbit."""
    path = write_recording(tmp_path / "meteor.mcap", altitude_km=830.0, inclination_deg=98.8)
    report = _report(_analyze(path, "--json", orbit_flags=False))
    assert (report["altitude_km"], report["inclination_deg"]) == pytest.approx((830.0, 98.8))
    assert report["orbit_source"] == {"altitude": "orbit elements on /diagnostics",
                                      "inclination": "orbit elements on /diagnostics"}
    both = _report(_analyze(path, "--json", "--altitude-km", "820", "--inclination-deg", "98", orbit_flags=False))
    assert (both["altitude_km"], both["inclination_deg"]) == pytest.approx((820.0, 98.0))
    assert both["orbit_source"] == {"altitude": "--altitude-km", "inclination": "--inclination-deg"}
    one = _report(_analyze(path, "--json", "--altitude-km", "820", orbit_flags=False))
    assert one["orbit_source"]["inclination"] == "orbit elements on /diagnostics"
    text = _analyze(path, orbit_flags=False)
    assert text.status == 0 and "(from orbit elements on /diagnostics)" in text.stdout.splitlines()[1], text.stdout
    # A CSV carries no orbit: the flags it needs are named.
    csv = tmp_path / "telemetry.csv"
    csv.write_text("orbit,u_deg,roll_arcmin,pitch_arcmin\n1,0,0,0\n1,90,0,0\n")
    _refused(_analyze(csv, orbit_flags=False), "carries no orbit", "--altitude-km and --inclination-deg")
    # An altitude the recording states that no orbit has: refused as the flag would be.
    low = write_recording(tmp_path / "low.mcap", altitude_km=100.0, inclination_deg=50.0, period_s=5200.0)
    _refused(_analyze(low, orbit_flags=False), "the orbit on /diagnostics", "altitude")
