"""A recorder node: every topic of the graph as received, into a rosbag2 MCAP file (:mod:`pmv_ros.storage.recording`).

What ``ros2 bag record -a -s mcap --use-sim-time`` does, for ``pmv simulate
--record``: one raw subscription per topic (the CDR bytes the publisher sent,
never deserialised), each message logged at the node clock's time of
reception — the simulation time when the node runs on it.
"""

from __future__ import annotations

import importlib

from .base import QOS, PmvNode


def message_class(type_name: str):
    """The rclpy message class of ``pkg/msg/Type``."""
    package, kind, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), name)


class TopicRecorder(PmvNode):
    """Records the topics it is given (or every topic the graph has) into ``recording``.

    Args:
        recording: an open :class:`pmv_ros.storage.recording.McapRecording`.
        topics: ``{topic: pkg/msg/Type}``; None for every topic the graph lists now.
    """

    def __init__(self, recording, topics: dict | None = None, **kwargs):
        super().__init__("pmv_recorder", **kwargs)
        self.recording = recording
        if topics is None:
            topics = {name: types[0] for name, types in self.get_topic_names_and_types() if types}
        for topic, type_name in sorted(topics.items()):
            recording.add_topic(topic, type_name)
            # The project QoS (reliable, keep-last 100), as every node's publishers.
            self.create_subscription(message_class(type_name), topic, self._writer(topic), QOS, raw=True)

    def _writer(self, topic: str):
        recording, clock = self.recording, self.get_clock()

        def write(data: bytes) -> None:
            recording.write(topic, clock.now().nanoseconds, data)

        return write
