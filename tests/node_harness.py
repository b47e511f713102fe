"""A node under test in its own rclpy context, with a tester node that publishes and records.

Shared by the in-process node tests; the ``harness`` fixture in conftest.py makes them.
"""

from __future__ import annotations

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from pmv_ros.nodes.pipeline import drain


class Harness:
    """One node under test, a tester node with publishers and recorders, one executor, one context."""

    def __init__(self, node_class, overrides: dict, **node_arguments):
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = node_class(context=self.context, **node_arguments, parameter_overrides=[
            Parameter(name, value=value) for name, value in overrides.items()])
        self.tester = Node("tester", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.tester)
        self.received = {}

    def record(self, message_type, topic):
        self.received[topic] = []
        self.tester.create_subscription(message_type, topic, self.received[topic].append, 100)
        return self.received[topic]

    def publisher(self, message_type, topic):
        return self.tester.create_publisher(message_type, topic, 100)

    def drain(self):
        drain(self.executor)

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        self.tester.destroy_node()
        rclpy.shutdown(context=self.context)


def probe(pipeline, topics: dict) -> dict:
    """Record ``{topic: message type}`` of an in-process :class:`~pmv_ros.nodes.pipeline.Pipeline` into lists;
    returns ``{topic: list}`` (the probe node is closed with the pipeline)."""
    node = Node("probe", context=pipeline.context)
    got = {}
    for topic, kind in topics.items():
        got[topic] = []
        node.create_subscription(kind, topic, got[topic].append, 100)
    pipeline.executor.add_node(node)
    pipeline.nodes.append(node)
    return got
