"""What a recording's definitions and chunks cost rosbags to open and read: the figures behind the bounds of
:mod:`pmv_ros.storage.recording` (MAX_DEFINITION_BYTES, MAX_DEFINITIONS, MAX_DEFINITION_FIELDS,
MAX_CHUNK_RECORDS, MAX_OVERLAPPING_CHUNK_BYTES, MAX_QOS_BYTES, MAX_BAG_METADATA_BYTES).

Each figure is measured in a fresh child process (``python design/recording_bounds.py``): the
time rosbags' ``AnyReader.open`` takes and the peak resident memory of the process, for MCAP files whose only
cost is one kind of text:

* ROS 2's own definitions with their comments (nav_msgs/Odometry and its dependencies, as ``ros2 bag record``
  stores them), on many channels: the time a byte of ordinary text costs;
* dense definitions (short names, few fields): the time a byte and the memory a registered type costs;
* definitions of many fields: the memory a field costs;
* one chunk of tiny messages read in log-time order: the memory a message costs in rosbags' chunk list;
* QoS profiles in the channels' metadata and a rosbag2 directory's ``metadata.yaml`` at their bounds, which rosbags
  parses with a pure-Python YAML parser (MAX_QOS_BYTES, MAX_BAG_METADATA_BYTES);
* 1800 definitions of 9 fields: a file near both the definitions' and the fields' bound.

Prints one line per case; the docstrings of the constants quote these.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

_CHILD = r"""
import json, resource, sys, time
from pathlib import Path
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
path, topic = Path(sys.argv[1]), sys.argv[2]
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
started = time.process_time()
reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_JAZZY))
count = 0
try:  # a dense flow list is no QoS profile: rosbags fails on it, after parsing it
    reader.open()
except Exception:
    topic = ""
opened = time.process_time() - started
if topic:
    for _ in reader.messages(connections=[c for c in reader.connections if c.topic == topic]):
        count += 1
    reader.close()
print(json.dumps({"open_s": opened, "read_s": time.process_time() - started - opened, "messages": count,
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "before_mb": before / 1024}))
"""


def _ros_definition(package: str, name: str) -> str:
    """A message's definition with its dependencies and comments, as rosbag2 stores it (from the .msg files)."""
    import re

    share = Path(sys.prefix) / "share"
    builtin = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32",
               "int64", "uint64", "string", "wstring"}

    def text(pkg, msg):
        return (share / pkg / "msg" / f"{msg}.msg").read_text()

    def needs(pkg, body):
        for line in body.splitlines():
            words = line.split("#")[0].split()
            if not words:
                continue
            kind = re.sub(r"<=\d+|\[.*\]", "", words[0])
            if kind not in builtin:
                parts = kind.split("/")
                yield (parts[0], parts[-1]) if len(parts) > 1 else (pkg, kind)

    order, pending = [], list(needs(package, text(package, name)))
    while pending:
        item = pending.pop(0)
        if item not in order:
            order.append(item)
            pending += needs(item[0], text(*item))
    return "\n".join([text(package, name)] + ["=" * 80 + f"\nMSG: {p}/{m}\n" + text(p, m) for p, m in order])


def _dense(definitions: int, fields: int) -> str:
    top = "float64 x\n" + "".join(f"pkg/M{i} f{i}\n" for i in range(definitions - 1))
    body = "".join(f"float64 a{k}\n" for k in range(fields))
    return "\n".join([top] + ["=" * 80 + f"\nMSG: pkg/M{i}\n" + body for i in range(definitions - 1)])


#: One publisher's QoS profile as rosbag2 writes it into a channel's metadata.
_QOS_PROFILE = """- history: 3
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


def _mcap(path: Path, schema_name: str, text: str, channels: int, messages: int = 0, chunk_size: int = 1 << 20,
          qos: str = ""):
    from mcap.writer import Writer

    with open(path, "wb") as stream:
        writer = Writer(stream, chunk_size=chunk_size)
        writer.start(profile="ros2", library="design")
        schema = writer.register_schema(schema_name, "ros2msg", text.encode())
        ids = [writer.register_channel(f"/t{i}", "cdr", schema, metadata={"offered_qos_profiles": qos} if qos else {})
               for i in range(channels)]
        for i in range(messages):
            writer.add_message(ids[0], log_time=i, data=b"\0\1\0\0", publish_time=i)
        writer.finish()
    return path


def _measure(path: Path, topic: str = "") -> dict:
    result = subprocess.run([sys.executable, "-c", _CHILD, str(path), topic], capture_output=True, text=True,
                            check=True)
    return json.loads(result.stdout)


def main() -> None:
    from pmv_ros.storage.recording import _definitions, _fields

    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        empty = _measure(_mcap(folder / "empty.mcap", "std_msgs/msg/Empty", "", 1))
        print(f"an empty recording: open {empty['open_s']:.2f} s, peak {empty['peak_mb']:.0f} MB (the baseline)")
        odometry = _ros_definition("nav_msgs", "Odometry")
        for channels in (100, 300):
            figures = _measure(_mcap(folder / f"odometry{channels}.mcap", "nav_msgs/msg/Odometry", odometry,
                                     channels))
            parsed = channels * len(odometry)
            print(f"{channels} channels of nav_msgs/Odometry with comments ({len(odometry)} B, "
                  f"{_definitions(odometry.encode())} definitions): {parsed} B parsed in {figures['open_s']:.2f} s "
                  f"= {figures['open_s'] / parsed * 1e6:.1f} µs a byte, peak {figures['peak_mb']:.0f} MB")
        for definitions, fields, channels in ((2000, 1, 1), (2000, 1, 4), (20, 3000, 1), (1800, 9, 1)):
            text = _dense(definitions, fields)
            figures = _measure(_mcap(folder / f"dense{definitions}_{fields}_{channels}.mcap", "pkg/msg/Top", text,
                                     channels))
            grown = figures["peak_mb"] - empty["peak_mb"]
            print(f"{definitions} definitions of {fields} field(s) ({len(text)} B, {_fields(text.encode())} fields) "
                  f"on {channels} channel(s): open {figures['open_s']:.2f} s "
                  f"= {figures['open_s'] / (len(text) * channels) * 1e6:.1f} µs a byte; "
                  f"+{grown:.0f} MB = {grown * 1024 / definitions:.1f} kB a definition, "
                  f"{grown * 1024 / _fields(text.encode()):.1f} kB a field")
        from pmv_ros.storage.recording import MAX_BAG_METADATA_BYTES, MAX_QOS_BYTES

        for label, qos in (("real profiles", _QOS_PROFILE * (MAX_QOS_BYTES // len(_QOS_PROFILE))),
                           ("a dense flow list", "[" + ",".join(["1"] * (MAX_QOS_BYTES // 2 - 1)) + "]")):
            figures = _measure(_mcap(folder / "qos.mcap", "std_msgs/msg/Empty", "", 1, qos=qos))
            grown = figures["peak_mb"] - empty["peak_mb"]
            print(f"QoS metadata of {len(qos)} B, {label}: open {figures['open_s']:.2f} s "
                  f"= {figures['open_s'] / len(qos) * 1e6:.1f} µs a byte, +{grown:.0f} MB "
                  f"= {grown * (1 << 20) / len(qos):.0f} B a byte")
        bag = folder / "bag"
        bag.mkdir()
        _mcap(bag / "bag_0.mcap", "std_msgs/msg/Empty", "", 1)
        flow = "[" + ",".join(["1"] * (MAX_BAG_METADATA_BYTES // 2 - 200)) + "]"
        (bag / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n"
                                           f"  relative_file_paths: [bag_0.mcap]\n  junk: {flow}\n")
        started = subprocess.run([sys.executable, "-c", "import resource, time\n"
                                  "from rosbags.rosbag2.metadata import *\nfrom ruamel.yaml import YAML\n"
                                  "t = time.process_time()\nYAML(typ='safe').load(open(__import__('sys').argv[1]))\n"
                                  "print(time.process_time() - t, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)",
                                  str(bag / "metadata.yaml")], capture_output=True, text=True, check=True)
        seconds, peak_kb = started.stdout.split()
        size = (bag / "metadata.yaml").stat().st_size
        print(f"metadata.yaml of {size} B, a dense flow list, through rosbags' YAML parser: {float(seconds):.2f} s "
              f"= {float(seconds) / size * 1e6:.1f} µs a byte, peak {int(peak_kb) / 1024:.0f} MB")
        messages = 250_000
        figures = _measure(_mcap(folder / "tiny.mcap", "std_msgs/msg/Empty", "", 1, messages, chunk_size=64 << 20),
                           "/t0")
        grown = figures["peak_mb"] - empty["peak_mb"]
        print(f"one chunk of {messages} empty messages read in log-time order: {figures['read_s']:.2f} s, "
              f"+{grown:.0f} MB = {grown * (1 << 20) / messages:.0f} B a message")


if __name__ == "__main__":
    main()
