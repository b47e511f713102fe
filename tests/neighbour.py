"""A hostile neighbour on the nodes' DDS domain: the three nodes as child processes, and the attacker's node.

Used by the adversarial tests (tests/system/test_adversarial.py, test_hostile_clock.py).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import rclpy
from children import child_env, domain_id
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock

import pmv_msgs_shim as shim

VENV_BIN = Path(sys.executable).parent
#: A domain of our own, apart from the other multi-process tests.
DOMAIN_ID = domain_id(1)
PARAMS = """\
/**:
  ros__parameters:
    orbit.altitude_km: 500.0
error_monitor_node:
  ros__parameters:
    use_sim_time: true
    remove_oblateness: false
star_tracker_node:
  ros__parameters:
    use_sim_time: true
sensor_node:
  ros__parameters:
    sim.fast_time: true
    sim.time_scale: 1.0
    sim.start_time_s: 100.0
    sensor.rate_hz: 10.0
    sensor.detector: ideal
    sensor.earth_model: sphere
"""


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    raise RuntimeError("no VmRSS")


class Neighbour:
    """The attacker: a node on the stack's domain in this process, with an executor to spin it."""

    def __init__(self):
        self.context = rclpy.Context()
        # This process's other tests keep discovery off; the neighbour must see the stack.
        saved = os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE")
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
        try:
            rclpy.init(context=self.context, domain_id=DOMAIN_ID)
        finally:
            if saved is None:
                os.environ.pop("ROS_AUTOMATIC_DISCOVERY_RANGE")
            else:
                os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = saved
        self.node = Node("neighbour", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.got = {"residual": [], "diagnostics": [], "statistics": []}
        self.sim_now_s = None
        qos = QoSProfile(depth=100)
        self.node.create_subscription(Vector3Stamped, "/pmv/residual", self.got["residual"].append, qos)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self.got["diagnostics"].append, qos)
        self.node.create_subscription(DiagnosticArray, "/pmv/error_statistics", self.got["statistics"].append, qos)
        self.node.create_subscription(Clock, "/clock", self._on_clock, qos)
        self.pub = {name: self.node.create_publisher(kind, topic, qos) for name, kind, topic in (
            ("attitude", Vector3Stamped, "/pmv/attitude"), ("odometry", Odometry, "/orbit/odometry"),
            ("tracker", QuaternionStamped, "/star_tracker/attitude"), ("clock", Clock, "/clock"))}

    def _on_clock(self, message) -> None:
        self.sim_now_s = shim.clock_from_msg(message)

    def spin(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.01)

    def wait_for(self, condition, seconds: float) -> bool:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if condition():
                return True
            self.executor.spin_once(timeout_sec=0.05)
        return False

    def set_parameter(self, node_name: str, name: str, value):
        client = AsyncParameterClient(self.node, node_name)
        assert client.wait_for_services(timeout_sec=10.0), node_name
        started = time.monotonic()
        future = client.set_parameters([Parameter(name, value=value)])
        self.executor.spin_until_future_complete(future, timeout_sec=10.0)
        return future.result().results[0], time.monotonic() - started

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


@contextmanager
def running_stack(tmp_path):
    """The three nodes as console scripts on the neighbour's domain with PARAMS; stopped with SIGINT at the end."""
    params = tmp_path / "stack.yaml"
    params.write_text(PARAMS)
    processes = {}
    for name in ("error_monitor_node", "star_tracker_node", "sensor_node"):
        processes[name] = subprocess.Popen(
            [str(VENV_BIN / name), "--ros-args", "--params-file", str(params)], env=child_env(tmp_path / "log", DOMAIN_ID),
            cwd=tmp_path, stdin=subprocess.DEVNULL, stdout=open(tmp_path / f"{name}.out", "w"),
            stderr=subprocess.STDOUT)
    yield processes
    for process in processes.values():
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
    for process in processes.values():
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def monitor_status(messages):
    statuses = [s for m in messages for s in shim.health_from_msg(m).statuses if s.name == "pmv_ros/error_monitor_node"]
    return statuses[-1] if statuses else None
