"""A node in a namespace says so in its log: rclpy names its logger after the namespace (``sat1.sensor_node``),
and the lines themselves name the node and its topics as the graph does (``/sat1/sensor_node``,
``/sat1/attitude/truth``), not as they would be without the namespace.

Read back from /rosout, as ``ros2 topic echo /rosout`` or rqt_console shows them.
"""

from __future__ import annotations

import time

from geometry_msgs.msg import QuaternionStamped
from rcl_interfaces.msg import Log
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rosgraph_msgs.msg import Clock

import pmv_msgs_shim as shim
from pmv_ros.nodes.error_monitor_node import ErrorMonitorNode
from pmv_ros.nodes.sensor_node import SensorNode
from pmv_ros.nodes.star_tracker_node import StarTrackerNode
from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw

#: A namespace no other in-process test uses: rcl keeps one /rosout publisher per logger name for the process.
NAMESPACE = "/logsat"
FOLLOW = {"attitude.source": "follow", "use_sim_time": True, "sensor.rate_hz": 10.0, "sensor.detector": "ideal",
          "sensor.earth_model": "sphere", "sensor.bright_body_exclusion_deg": 0.0}


def _rosout(h) -> list:
    """/rosout as read back from now on, with what was logged before (rcl keeps it: transient local)."""
    logs = []
    h.tester.create_subscription(Log, "/rosout", logs.append, QoSProfile(
        depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    return logs


def _lines(logs, logger: str) -> list[str]:
    return [log.msg for log in logs if log.name == logger]


def test_a_namespaced_sensor_names_itself_and_its_stale_truth_with_the_namespace(harness):
    h = harness(SensorNode, FOLLOW, namespace=NAMESPACE)
    logs = _rosout(h)
    clock = h.publisher(Clock, "/clock")
    truth = h.tester.create_publisher(QuaternionStamped, f"{NAMESPACE}/attitude/truth", qos_profile_sensor_data)
    message = QuaternionStamped()
    for step in range(1, 101):  # 2 s of 50 Hz truth, then the clock runs on 10 s without any
        t_s = step * 0.02
        truth.publish(shim.write_attitude_quaternion(message, t_s, shim.ORBITAL_FRAME,
                                                     quaternion_from_roll_pitch_yaw(0.0, 0.0)))
        h.drain()
        clock.publish(shim.write_clock(Clock(), t_s))
        h.drain()
    for step in range(1, 101):
        clock.publish(shim.write_clock(Clock(), 2.0 + 0.1 * step))
        h.drain()
    h.drain()
    said = _lines(logs, "logsat.sensor_node")
    assert any(line.startswith("/logsat/sensor_node: H = ") for line in said), said
    stale = [line for line in said if "is stale" in line]
    assert stale and stale[0].startswith("/logsat/attitude/truth is stale at t = "), said
    assert not [log.msg for log in logs if log.name == "sensor_node"]  # nothing under the bare name


def test_the_other_nodes_start_up_lines_name_them_with_the_namespace(harness):
    for node_class, name in ((StarTrackerNode, "star_tracker_node"), (ErrorMonitorNode, "error_monitor_node")):
        h = harness(node_class, {}, namespace=NAMESPACE)
        logs = _rosout(h)
        deadline = time.monotonic() + 10.0
        while not _lines(logs, f"logsat.{name}") and time.monotonic() < deadline:
            h.executor.spin_once(timeout_sec=0.05)
        assert any(line.startswith(f"{NAMESPACE}/{name}: ready, ") for line in _lines(logs, f"logsat.{name}")), \
            [(log.name, log.msg) for log in logs]
