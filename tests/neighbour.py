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
from dataclasses import dataclass
from pathlib import Path

import numpy as np
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
from pmv_ros.physics.star_tracker.model import Outcome
from pmv_ros.runtime.common.assembly import MONITOR_PARAMS

VENV_BIN = Path(sys.executable).parent
#: The star tracker's frames without attitude for what it saw (physics.md §6: the sky, the Sun, the protons, an
#: operator's outage) — not for what it was given (invalid_truth, no_orbit, rate_too_high on a nadir stack):
#: a random share of any orbit (≈ 3 % of frames in a field of 8 stars fail recognition), whatever an attack does.
SKY_LOSSES = tuple(outcome.reason for outcome in (Outcome.OUTAGE, Outcome.NO_STARS, Outcome.RECOGNITION_FAILURE,
                                                 Outcome.BUFFER_OVERFLOW, Outcome.EXCLUSION))
#: The monitor's max_truth_gap_s (s), its default: a sample farther than this from every frame without attitude
#: has truth on both sides; one nearer may not (at 1 Hz two failed frames in a row leave 3 s without truth).
MAX_TRUTH_GAP_S = next(spec.default for spec in MONITOR_PARAMS if spec.name == "max_truth_gap_s")


@dataclass
class Alignment:
    """What became of a window of sensor samples at the monitor: stamps aligned (a residual came), left without
    truth by the tracker's sky (:data:`SKY_LOSSES` within :data:`MAX_TRUTH_GAP_S`), and neither."""

    taken: list
    sky: list
    other: list

    @property
    def samples(self) -> int:
        return len(self.taken) + len(self.sky) + len(self.other)

    @property
    def share(self) -> float:
        """The share of the window aligned or explained by the sky: what an attack must not lower."""
        return (len(self.taken) + len(self.sky)) / max(1, self.samples)

    def __str__(self) -> str:
        return (f"{len(self.taken) / max(1, self.samples):.1%} aligned, {len(self.sky)} left without truth by the "
                f"star tracker's sky, {len(self.other)} otherwise lost")


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

#: The three nodes on the wall clock (no /clock): a quick sensor (10 Hz, the geometric horizon on a sphere), the
#: monitor keeping the oblateness — for attacks that need the chain running, not its physics.
WALL_CLOCK_PARAMS = """\
/**:
  ros__parameters:
    orbit.altitude_km: 500.0
sensor_node:
  ros__parameters:
    sensor.rate_hz: 10.0
    sensor.detector: ideal
    sensor.earth_model: sphere
error_monitor_node:
  ros__parameters:
    remove_oblateness: false
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
        self.got = {"residual": [], "diagnostics": [], "statistics": [], "attitude": [], "frames": []}
        self.sim_now_s = None
        qos = QoSProfile(depth=100)
        self.node.create_subscription(Vector3Stamped, "/pmv/attitude", self.got["attitude"].append,
                                      QoSProfile(depth=1000))
        self.node.create_subscription(Vector3Stamped, "/pmv/residual", self.got["residual"].append, qos)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self.got["diagnostics"].append, qos)
        self.node.create_subscription(DiagnosticArray, "/pmv/error_statistics", self.got["statistics"].append, qos)
        self.node.create_subscription(Clock, "/clock", self._on_clock, qos)
        self.node.create_subscription(DiagnosticArray, "/star_tracker/frame_status",
                                      lambda m: self.got["frames"].append(shim.frame_status_input(m)), qos)
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
        return condition()

    def wait_until(self, condition, seconds: float, what: str) -> None:
        """Spin until ``condition()`` holds; fail naming ``what`` did not arrive within ``seconds``."""
        if not self.wait_for(condition, seconds):
            raise AssertionError(f"{what} did not arrive within {seconds:g} s (domain {DOMAIN_ID})")

    def wait_for_stack(self, residuals: int = 20, seconds: float = 90.0) -> None:
        """The stack is up as the attacks need it: more than ``residuals`` residuals *and* a /clock heard
        (a neighbour can hear residuals before its first /clock: the attacks stamp with the clock)."""
        self.wait_until(lambda: len(self.got["residual"]) > residuals, seconds, f"more than {residuals} residuals")
        self.wait_until(lambda: self.sim_now_s is not None, seconds, "a /clock message")

    @property
    def now_s(self) -> float:
        """The stack's simulation time as last heard on /clock (after :meth:`wait_for_stack`: never None)."""
        if self.sim_now_s is None:
            raise AssertionError("no /clock heard yet: wait_for_stack() first")
        return self.sim_now_s

    def wait_for_reports(self, *nodes: str, count: int = 2, seconds: float = 30.0) -> None:
        """Spin until each of ``nodes`` (``error_monitor_node``, …) has sent ``count`` more /diagnostics statuses
        from now on: the second one was made after everything sent before this call had been taken."""
        start = len(self.got["diagnostics"])

        def reported() -> bool:
            later = self.got["diagnostics"][start:]
            return all(len(node_statuses(later, node)) >= count for node in nodes)

        self.wait_until(reported, seconds, f"{count} /diagnostics reports of each of {', '.join(nodes)}")

    def wait_for_statistics(self, seconds: float = 30.0):
        """The newest /pmv/error_statistics message, waiting for one if none has come yet."""
        self.wait_until(lambda: self.got["statistics"], seconds, "a /pmv/error_statistics message")
        return self.got["statistics"][-1]

    def set_parameter(self, node_name: str, name: str, value):
        client = AsyncParameterClient(self.node, node_name)
        assert client.wait_for_services(timeout_sec=10.0), node_name
        started = time.monotonic()
        future = client.set_parameters([Parameter(name, value=value)])
        self.executor.spin_until_future_complete(future, timeout_sec=10.0)
        assert future.done(), f"no answer from /{node_name}/set_parameters within 10 s"
        return future.result().results[0], time.monotonic() - started

    def alignment(self, window) -> Alignment:
        """How the monitor took the sensor samples stamped ``window`` (s): :class:`Alignment`."""
        aligned = {round(shim.time_from_msg(m.header.stamp), 3) for m in self.got["residual"]}
        lost = np.array([t for t, reason in self.got["frames"] if reason in SKY_LOSSES])
        taken, sky, other = [], [], []
        for t in window:
            if round(t, 3) in aligned:
                taken.append(t)
            elif lost.size and np.abs(lost - t).min() <= MAX_TRUTH_GAP_S:
                sky.append(t)
            else:
                other.append(t)
        return Alignment(taken, sky, other)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


@contextmanager
def running_nodes(tmp_path, params: str = PARAMS, nodes=("error_monitor_node", "star_tracker_node", "sensor_node"),
                  arguments: dict | None = None, ros_arguments: dict | None = None, domain: int = DOMAIN_ID):
    """Node console scripts as children on ``domain`` with the params file ``params``, each node's extra
    command-line ``arguments`` (name → list) before ``--ros-args`` and ``ros_arguments`` after it; {name: Popen}.
    A name ``sensor_node:sat1`` is a second instance of ``sensor_node``. Stopped with SIGINT at the end (killed if
    one hangs); ``<name>.out`` in ``tmp_path`` holds what each printed."""
    path = tmp_path / "stack.yaml"
    path.write_text(params)
    processes = {}
    try:
        for name in nodes:
            executable = name.split(":")[0]  # "sensor_node:sat1": a second instance, told apart by the suffix
            processes[name] = subprocess.Popen(
                [str(VENV_BIN / executable), *(arguments or {}).get(name, ()), "--ros-args",
                 *(ros_arguments or {}).get(name, ()), "--params-file", str(path)],
                env=child_env(tmp_path / "log", domain), cwd=tmp_path, stdin=subprocess.DEVNULL,
                stdout=open(tmp_path / f"{name.replace(':', '_')}.out", "w"), stderr=subprocess.STDOUT)
        yield processes
    finally:
        for process in processes.values():
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        for process in processes.values():
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


@contextmanager
def running_stack(tmp_path):
    """The three nodes as console scripts on the neighbour's domain with PARAMS; stopped with SIGINT at the end."""
    with running_nodes(tmp_path) as processes:
        yield processes


def output_of(tmp_path, name: str) -> str:
    """What node process ``name`` of :func:`running_nodes` printed so far."""
    return (tmp_path / f"{name.replace(':', '_')}.out").read_text(errors="replace")


def proc_status(pid: int) -> dict:
    """Resident memory (MB) and thread count of a live process, from /proc."""
    fields = dict(line.split(":", 1) for line in Path(f"/proc/{pid}/status").read_text().splitlines() if ":" in line)
    return {"rss_mb": int(fields["VmRSS"].split()[0]) / 1024.0, "threads": int(fields["Threads"])}


def node_statuses(messages, node: str) -> list:
    """The /diagnostics statuses of node ``node`` (``pmv_ros/<node>``) in ``messages``, in order."""
    return [s for m in messages for s in shim.health_from_msg(m).statuses if s.name == f"pmv_ros/{node}"]


def monitor_status(messages):
    statuses = node_statuses(messages, "error_monitor_node")
    return statuses[-1] if statuses else None
