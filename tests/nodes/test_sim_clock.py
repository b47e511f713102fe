"""The three nodes on a /clock of the user's own (interfaces.md "Time"; README "Simulation time from your /clock").

A simulator's /clock steps as it likes — by a second, by half a second at 100 Hz — and the sensor still
samples on its own grid: every sample due in a step is computed and published, stamped with its own time,
and the star tracker and the monitor follow its stream. A /clock that stops is a WARN on /diagnostics,
said on the wall clock, and OK again when it moves.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

import pmv_msgs_shim as shim
from pmv_ros.nodes.error_monitor_node import ErrorMonitorNode
from pmv_ros.nodes.pipeline import Pipeline, drain
from pmv_ros.nodes.sensor_node import SensorNode
from pmv_ros.nodes.star_tracker_node import StarTrackerNode
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.runtime.common.clock_watch import CLOCK_STALL_S

KONDOR = Path(__file__).resolve().parents[2] / "config" / "kondor.yaml"
RATE_HZ = 10.0  # the preset's sensor rate


class SimClockGraph:
    """The three nodes as separate processes would run them (full nodes, use_sim_time), a tester publishing
    /clock and recording, all in one context and executor of this process."""

    def __init__(self, overrides: dict | None = None):
        self.context = rclpy.Context()
        rclpy.init(args=["--ros-args", "--params-file", str(KONDOR)], context=self.context)
        parameters = [Parameter(name, value=value)
                      for name, value in {"use_sim_time": True, **(overrides or {})}.items()]
        self.nodes = [cls(context=self.context, parameter_overrides=parameters)
                      for cls in (SensorNode, StarTrackerNode, ErrorMonitorNode)]
        self.sensor, self.star_tracker, self.monitor = self.nodes
        self.tester = Node("tester", context=self.context)
        self.clock = self.tester.create_publisher(Clock, "/clock", 100)
        self.received = {}
        self.executor = SingleThreadedExecutor(context=self.context)
        for node in self.nodes + [self.tester]:
            self.executor.add_node(node)

    def record(self, message_type, topic: str, with_wall_time: bool = False) -> list:
        self.received[topic] = received = []
        self.tester.create_subscription(message_type, topic, (lambda m: received.append((time.monotonic(), m)))
                                        if with_wall_time else received.append, 1000)
        return received

    def tick(self, t_s: float) -> None:
        self.clock.publish(shim.write_clock(Clock(), t_s))
        drain(self.executor)

    def run_clock(self, first_s: float, step_s: float, last_s: float, rate_hz: float) -> float:
        """Publish /clock from ``first_s`` to ``last_s`` in steps of ``step_s`` at ``rate_hz`` of wall time (at most);
        returns the last time published."""
        t_s, wall = first_s, time.monotonic()
        while t_s <= last_s + 1e-9:
            self.tick(t_s)
            wall += 1.0 / rate_hz
            time.sleep(max(0.0, wall - time.monotonic()))
            t_s = round(t_s + step_s, 9)
        return round(t_s - step_s, 9)

    def spin_for(self, wall_s: float) -> None:
        finish = time.monotonic() + wall_s
        while time.monotonic() < finish:
            self.executor.spin_once(timeout_sec=0.05)

    def close(self) -> None:
        self.executor.shutdown()
        for node in self.nodes + [self.tester]:
            node.destroy_node()
        rclpy.shutdown(context=self.context)


def stamps_of(messages) -> np.ndarray:
    return np.array([shim.time_from_msg(m.header.stamp) for m in messages])


def test_every_sample_of_the_grid_under_a_coarse_clock_and_the_statistics_of_a_fast_time_run():
    graph = SimClockGraph()
    try:
        attitude = graph.record(Vector3Stamped, "/pmv/attitude")
        statistics = graph.record(DiagnosticArray, "/pmv/error_statistics")
        # 30 s of a clock stepping by 1 s (at 20 steps per wall second), then 30 s of a 100 Hz clock at
        # 50× real time (0.5 s steps). The first reading, 0.1 s, is a sample of the grid (0.1·k from the
        # clock's zero, the orbit's epoch): the stamps are those of a fast-time run from 0.
        middle = graph.run_clock(0.1, 1.0, 30.1, rate_hz=20.0)
        end = graph.run_clock(middle + 0.5, 0.5, middle + 30.0, rate_hz=100.0)
        stamps = stamps_of(attitude)
        sensor_summary = graph.monitor.monitor.summary()
    finally:
        graph.close()
    # Every sample, in order, 0.1 s apart (stamps are whole nanoseconds).
    np.testing.assert_allclose(np.diff(stamps), 1.0 / RATE_HZ, atol=2e-9)
    assert stamps[0] == 0.1 and abs(stamps[-1] - end) < 1e-6
    for first, last in ((0.1, middle), (middle, end)):  # each phase: samples per simulated second
        inside = np.count_nonzero((stamps > first + 1e-6) & (stamps <= last + 1e-6))
        rate = inside / (last - first)
        print(f"clock phase {first:.1f} … {last:.1f} s: {rate:.4f} samples per simulated second")
        assert abs(rate - RATE_HZ) <= 0.01 * RATE_HZ, rate
    # The statistics of the same preset and seed in fast time, over the same samples: step the pipeline
    # until its monitor has used as many samples as the monitor on the coarse clock.
    used = sensor_summary.counters["used"]
    assert used > 400, sensor_summary.counters
    with Pipeline(KONDOR, {}, collect=False) as pipeline:
        while pipeline.monitor.monitor.counters["used"] < used:
            pipeline.step()
        fast_summary = pipeline.monitor.monitor.summary()
    assert fast_summary.counters["used"] == used
    largest = 0.0
    for ours, theirs in zip(sensor_summary.channels, fast_summary.channels):
        assert ours.count == theirs.count
        for field in ("mean_rad", "sigma_rad", "max_abs_rad"):
            difference = abs(getattr(ours, field) - getattr(theirs, field)) / ARCMIN_RAD
            largest = max(largest, difference)
            assert difference < 1e-6, (ours.channel, field, difference)
    print(f"{used} samples used: statistics equal the fast-time run's to {largest:.1e}′")
    # The statistics ticks followed the sample stamps: one a simulated second.
    ticks = stamps_of(statistics)
    assert len(ticks) >= 55 and np.all(np.diff(ticks) >= 1.0 - 1e-6) and np.all(np.diff(ticks) < 1.0 + 0.1 + 1e-6)


def test_a_stopped_clock_is_a_warn_within_three_wall_seconds_and_ok_when_it_moves_again():
    graph = SimClockGraph()
    try:
        diagnostics = graph.record(DiagnosticArray, "/diagnostics", with_wall_time=True)
        attitude = graph.record(Vector3Stamped, "/pmv/attitude")
        last = graph.run_clock(0.1, 0.5, 5.1, rate_hz=100.0)
        stopped_wall = time.monotonic()
        graph.spin_for(5.0)  # the clock stands for 5 s
        published_while_stopped = len(attitude)
        resumed_wall = time.monotonic()
        graph.run_clock(last + 0.5, 0.5, last + 3.0, rate_hz=100.0)
        graph.spin_for(1.0)  # a few watch periods
    finally:
        graph.close()
    clock_reports = [(wall, status) for wall, message in diagnostics for status in message.status
                     if status.name.endswith(": clock")]
    for node in ("sensor_node", "star_tracker_node", "error_monitor_node"):
        mine = [(wall, shim.Level(ord(status.level)), status.message) for wall, status in clock_reports
                if status.name == f"pmv_ros/{node}: clock"]
        warns = [wall for wall, level, _ in mine if level == shim.Level.WARN and wall >= stopped_wall]
        assert warns, (node, mine)
        print(f"{node}: WARN {warns[0] - stopped_wall:.2f} s of wall time after the clock stopped")
        assert CLOCK_STALL_S - 0.1 <= warns[0] - stopped_wall <= 3.0
        assert all(level == shim.Level.WARN for wall, level, _ in mine if stopped_wall + 3.0 <= wall < resumed_wall)
        after = [(level, text) for wall, level, text in mine if wall > resumed_wall]
        assert after and after[-1][0] == shim.Level.OK and "moves again" in after[-1][1], (node, after)
    assert len(attitude) > published_while_stopped  # the samples of the resumed clock
