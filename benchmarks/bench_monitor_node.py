"""What one message costs through error_monitor_node, as the main job feeds it: a sensor sample, and a truth
message that settles the 5 samples waiting for it.

The node is the pipeline's (lean, on a simulation time the benchmark sets, handed its queued inputs by the caller
as the pipeline's drain does, a subscriber on each of its outputs so that it writes them). The messages are real
ones, written by the shim as the sensor and the star tracker write them, and go in through the node's own
subscription callbacks — the source lock, the reader, the queue — then the hand-over to the runtime (the monitor:
validation, alignment, statistics) and the writing of the residuals. rclpy's take and publish are not counted
(``Publisher.publish`` is stubbed while timing): they are the floor every message pays whatever the node does
(``bench_main_job.py`` measures the main job against it).

The stream is the main job's: per 0.1 s tick an /orbit/odometry and a /pmv/attitude message handed over together
(one executor wake-up), and every 5th tick a /star_tracker/attitude frame 0.25 s late, handed over alone — it
covers the 5 samples waiting. Reported: µs per sensor or odometry message (a tick without truth ÷ 2) and µs per
truth message (with its 5 residuals written), medians of each round, the best round; rounds alternate with a
reference workload (a bare Vector3Stamped written and read back through the shim, 100 times) so that a machine
twice as slow this hour shows as such.

Beside them: a sensor or odometry message's taking alone (the node clock read, the source lock, the shim's reader,
the queue: what the node does before any monitor work), the best of the rounds' medians.

    .venv/bin/python benchmarks/bench_monitor_node.py [--rounds 5] [--ticks 2000]
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import tempfile
import time

os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="pmv_bench_log_"))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"

import rclpy  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.publisher import Publisher  # noqa: E402
from rclpy.time_source import TimeSource  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402

import pmv_msgs_shim as shim  # noqa: E402
from pmv_ros.nodes.error_monitor_node import ErrorMonitorNode  # noqa: E402
from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw  # noqa: E402
from pmv_ros.physics.orbit.two_body import CircularOrbit  # noqa: E402

TARGET_SAMPLE_US, TARGET_TRUTH_US = 8.0, 60.0


class Bench:
    def __init__(self):
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.time = TimeSource()
        self.time.ros_time_is_active = True
        options = dict(context=self.context, lean=True, time_source=self.time,
                       parameter_overrides=[Parameter("use_sim_time", value=True)])
        self.at_once = False
        try:
            self.node = ErrorMonitorNode(flushed_by_caller=True, **options)
        except TypeError:  # a tree whose monitor node hands every message over at once
            self.node = ErrorMonitorNode(**options)
            self.at_once = True
        self.listener = Node("bench_listener", context=self.context)
        for topic, kind in (("/pmv/residual", Vector3Stamped), ("/pmv/error_statistics", DiagnosticArray)):
            self.listener.create_subscription(kind, topic, lambda message: None, 10)
        self.callbacks = {s.topic_name: s.callback for s in self.node.subscriptions}
        self.flush = getattr(self.node, "flush_inputs", lambda: None)
        self.orbit = CircularOrbit(500e3, math.radians(74.5))
        self.clock, self.sequence = Clock(), 0
        self.t_s = 1000.0

    def close(self):
        self.node.destroy_node()
        self.listener.destroy_node()
        rclpy.shutdown(context=self.context)

    def _deliver(self, topic: str, message) -> None:
        self.sequence += 1  # one publisher per topic, as the source lock sees it
        self.callbacks[topic](message, {"publication_sequence_number": self.sequence})

    def stream(self, ticks: int):
        """Messages of ``ticks`` ticks, written beforehand (fresh objects: what a take gives)."""
        ticks_out = []
        for _ in range(ticks):
            self.t_s += 0.1
            t = self.t_s
            position, velocity = self.orbit.state_eci(t)
            odometry = shim.write_orbit_state(Odometry(), t, "eci", "orbital", position, velocity)
            angles = shim.write_attitude_angles(Vector3Stamped(), t, "pmv_sensor", 1e-3 * math.sin(t / 300.0), -5e-4)
            truth = None
            if round(t * 10) % 5 == 0:
                stamp = t - 0.25
                truth = shim.write_attitude_quaternion(QuaternionStamped(), stamp, "orbital",
                                                       quaternion_from_roll_pitch_yaw(
                                                           1e-3 * math.sin(stamp / 300.0), -5e-4, 0.0))
            ticks_out.append((t, odometry, angles, truth))
        return ticks_out

    def run(self, ticks: int) -> tuple[float, float, int, float]:
        """Median µs per sensor/odometry message and per truth message over ``ticks`` ticks; residuals written;
        and the median µs per sensor/odometry message of its taking alone (before the hand-over)."""
        messages = self.stream(ticks)
        written = [0]
        original = Publisher.publish
        Publisher.publish = lambda publisher, message: written.__setitem__(0, written[0] + 1)
        sample_us, truth_us, taking_us = [], [], []
        try:
            for t, odometry, angles, truth in messages:
                self.time.clock_callback(shim.write_clock(self.clock, t))
                started = time.perf_counter()
                self._deliver("/orbit/odometry", odometry)
                self._deliver("/pmv/attitude", angles)
                taken = time.perf_counter()
                self.flush()
                middle = time.perf_counter()
                if truth is not None:
                    self._deliver("/star_tracker/attitude", truth)
                    self.flush()
                    truth_us.append((time.perf_counter() - middle) * 1e6)
                sample_us.append((middle - started) * 1e6 / 2)
                taking_us.append((taken - started) * 1e6 / 2)
        finally:
            Publisher.publish = original
        return statistics.median(sample_us), statistics.median(truth_us), written[0], statistics.median(taking_us)


def reference_us(repeats: int = 100) -> float:
    """µs of a fixed Python/rclpy message workload (a machine-speed yardstick)."""
    message = Vector3Stamped()
    started = time.perf_counter()
    for k in range(repeats):
        shim.read_attitude_angles(shim.write_attitude_angles(message, 1.0 + k, "pmv_sensor", 1e-3, 2e-3))
    return (time.perf_counter() - started) * 1e6 / repeats


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--ticks", type=int, default=2000)
    args = parser.parse_args()
    bench = Bench()
    try:
        bench.run(200)  # warm-up: truth in the buffer, the first statistics
        rounds = []
        for number in range(1, args.rounds + 1):
            reference = statistics.median(reference_us() for _ in range(20))
            sample, truth, written, taking = bench.run(args.ticks)
            rounds.append((sample, truth, reference, taking))
            print(f"round {number}: sensor or odometry message {sample:.1f} µs (its taking alone {taking:.1f}), "
                  f"truth message settling 5 "
                  f"{truth:.1f} µs ({written} messages written); yardstick {reference:.2f} µs "
                  f"(load {os.getloadavg()[0]:.2f})")
        used, at_once = bench.node.monitor.counters["used"], bench.at_once
    finally:
        bench.close()
    sample, truth, reference, taking = (min(r[i] for r in rounds) for i in range(4))
    print(f"used by the monitor: {used} samples")
    print(f"best rounds: sensor or odometry message {sample:.1f} µs (target ≤ {TARGET_SAMPLE_US:g}), "
          f"truth message settling 5 {truth:.1f} µs (target ≤ {TARGET_TRUTH_US:g}); yardstick {reference:.2f} µs")
    print(f"of a sensor or odometry message, its taking alone (the node clock, the source lock, the reader, the "
          f"queue; before any monitor work) {taking:.1f} µs, best of the rounds"
          + (" — this tree hands each message to the monitor at once: its taking includes the monitor" if at_once
             else ""))
    from headline import headline
    headline("monitor_node", "error_monitor_node, one sensor or odometry message", sample, "µs", "lower", reference,
             "µs", "a Vector3Stamped written and read back through the shim, 100 times", ratio=sample / reference)


if __name__ == "__main__":
    main()
