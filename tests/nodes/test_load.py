"""Load: the sensor at 50 Hz in real time drops no tick and the monitor keeps up (issue 6, item 6).

The three nodes as a user runs them — real time on the wall clock, with
parameter services, the Kondor preset (signal chain, radiance environment)
— share one single-threaded executor with a listener, spun for a few
seconds (a minute with ``--run-long``). Every sensor tick must be published
(the stamps, 20 ms apart, have no hole except possibly at the ends) and
received; the monitor's queue of samples waiting for truth stays bounded by
the star tracker's latency, and residuals come out a fraction of a second
after their sample. All topics are keep-last with a bounded depth
(pmv_ros.nodes.base.QOS_DEPTH), so no queue can grow without bound.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import Vector3Stamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, ReliabilityPolicy

import pmv_msgs_shim as shim
from pmv_ros.nodes.base import QOS, QOS_DEPTH
from pmv_ros.nodes.error_monitor_node import ErrorMonitorNode
from pmv_ros.nodes.pipeline import drain
from pmv_ros.nodes.sensor_node import SensorNode
from pmv_ros.nodes.star_tracker_node import StarTrackerNode

pytestmark = [pytest.mark.serial]

REPO = Path(__file__).resolve().parents[2]
RATE_HZ = 50.0
SHORT_S, FULL_S = 4.0, 60.0
INPUTS = ("/attitude/truth", "/star_tracker/attitude", "/pmv/attitude", "/orbit/odometry")


#: The real-time run uses at most this fraction of the CPU this process gets (what the rate is lowered to fit).
CPU_FRACTION = 0.5


def _sustainable_rate_hz(seconds: float = 1.5, start_timeout_s: float = 60.0) -> tuple[float, str]:
    """RATE_HZ, or lower where this process cannot get the CPU for it (a machine whose cores are busy with other
    work): (rate, how it was chosen). The CPU a tick costs is measured on the same three nodes in real time at
    RATE_HZ for ``seconds`` (process time of all threads per tick published: the machine's load does not stretch
    it), from the sensor's first tick on: the start-up before it pays one-off costs (the signal chain's response
    tables, now when the sensor is built; before, in its first tick and with scipy.signal's import, 0.5–1.5 s of
    CPU) that no later tick does — counted in a window that holds a few ticks on a loaded machine, they made the rate a
    fraction of a hertz and the run published nothing. The share of a core this process gets, by a busy loop."""
    began_wall, began_cpu = time.monotonic(), time.thread_time()
    while time.monotonic() - began_wall < 0.3:
        pass
    share = min(1.0, (time.thread_time() - began_cpu) / (time.monotonic() - began_wall))
    context = rclpy.Context()
    rclpy.init(args=["--ros-args", "--params-file", str(REPO / "config/kondor.yaml")], context=context)
    nodes, executor = [], SingleThreadedExecutor(context=context)
    try:
        nodes += [StarTrackerNode(context=context), ErrorMonitorNode(context=context)]
        nodes.append(SensorNode(context=context, parameter_overrides=[Parameter("sensor.rate_hz", value=RATE_HZ)]))
        for node in nodes:
            executor.add_node(node)
        sensor, deadline = nodes[-1], time.monotonic() + start_timeout_s
        while sensor.samples_published == 0:
            assert time.monotonic() < deadline, f"the sensor published no tick in {start_timeout_s:g} s"
            executor.spin_once(timeout_sec=0.1)
        began_wall, began_cpu, began_ticks = time.monotonic(), time.process_time(), sensor.samples_published
        while time.monotonic() - began_wall < seconds:
            executor.spin_once(timeout_sec=0.1)
        tick_cpu_s = (time.process_time() - began_cpu) / max(1, sensor.samples_published - began_ticks)
    finally:
        executor.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.shutdown(context=context)
    rate = min(RATE_HZ, CPU_FRACTION * share / tick_cpu_s)
    return rate, f"{tick_cpu_s * 1e3:.1f} ms of CPU a tick, {share:.0%} of a core to be had: {rate:.0f} Hz"


@pytest.mark.long
def test_sensor_at_50_hz_in_real_time_publishes_every_tick_and_the_monitor_keeps_up(run_long, capsys):
    """At RATE_HZ wherever this process gets the CPU for it (a quiet machine: well over twice what it needs); on a
    machine whose cores are taken by other work, at the rate half the CPU it gets sustains (printed): what is
    checked is that the real-time path drops nothing it has the CPU for, not the speed of the machine."""
    duration_s = FULL_S if run_long else SHORT_S
    rate_hz, chosen = _sustainable_rate_hz()
    context = rclpy.Context()
    rclpy.init(args=["--ros-args", "--params-file", str(REPO / "config/kondor.yaml")], context=context)
    nodes, executor = [], SingleThreadedExecutor(context=context)
    try:
        # The ideal star tracker (its timing, none of its gaps): the load is the subject, not the sky.
        nodes.append(StarTrackerNode(context=context, parameter_overrides=[Parameter("ideal", value=True)]))
        monitor = ErrorMonitorNode(context=context)
        nodes.append(monitor)
        listener = Node("load_listener", context=context)
        nodes.append(listener)
        attitude, residual_delays = [], []
        listener.create_subscription(Vector3Stamped, "/pmv/attitude", attitude.append, QOS)
        listener.create_subscription(Vector3Stamped, "/pmv/residual", lambda m: residual_delays.append(
            time.time() - shim.time_from_msg(m.header.stamp)), QOS)
        # The sensor last: its wall-clock timer starts with it.
        sensor = SensorNode(context=context, parameter_overrides=[Parameter("sensor.rate_hz", value=rate_hz)])
        nodes.append(sensor)
        for node in nodes:
            executor.add_node(node)

        pending_max = 0
        started = time.monotonic()
        while time.monotonic() - started < duration_s:
            executor.spin_once(timeout_sec=0.1)
            pending_max = max(pending_max, monitor.monitor.pending_count)
        sensor.timer.cancel()
        drain(executor)  # what was published is delivered
        published = sensor.samples_published
        counters = monitor.monitor.counters
        queues = [(entity.topic_name, entity.qos_profile) for node in nodes
                  for entity in list(node.publishers) + list(node.subscriptions)]
        ours = [node for node in nodes if node is not listener]
        publisher_qos = [(e.topic_name, e.qos_profile) for node in ours for e in node.publishers]
        input_qos = [(e.topic_name, e.qos_profile) for node in ours for e in node.subscriptions
                     if e.topic_name in INPUTS]
    finally:
        executor.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.shutdown(context=context)

    assert len(attitude) >= 2, (f"{len(attitude)} /pmv/attitude received in {duration_s:g} s at {rate_hz:.1f} Hz "
                                f"({chosen}); {published} ticks published")
    stamps = np.array([shim.time_from_msg(m.header.stamp) for m in attitude])
    gaps_ms = np.diff(stamps) * 1e3
    expected = int(round((stamps[-1] - stamps[0]) * rate_hz)) + 1
    delays = np.sort(residual_delays)
    figures = (f"load {rate_hz:.0f} Hz ({chosen}) for {duration_s:g} s real time: {published} ticks published, "
               f"{len(attitude)} received, {expected} expected from the stamps; gap between ticks "
               f"median {np.median(gaps_ms):.1f} ms, max {gaps_ms.max():.1f} ms; monitor pending max {pending_max}, "
               f"used {counters['used']}, residual delay median {np.median(delays) * 1e3:.0f} ms, "
               f"p99 {delays[int(0.99 * len(delays))] * 1e3:.0f} ms")
    print(figures)
    if run_long:
        with capsys.disabled():
            print("\n" + figures)

    assert published >= 0.9 * duration_s * rate_hz, figures  # the timer ran at its rate
    assert len(attitude) == published, figures  # every publish arrived
    assert len(attitude) >= expected - 1, figures  # no tick dropped (allowing for the first and last)
    assert np.all(np.diff(stamps) > 0), "stamps must increase"
    # The monitor kept up: samples wait only for the truth that covers them — the star tracker's delay
    # (0.375 s half exposure + 0.5 s processing) + one 1 s frame interval at 50 Hz is 94 samples — and none gave
    # up or overflowed.
    assert pending_max <= 110, figures
    assert counters["skipped_stale_truth"] == 0 and counters["skipped_pending_overflow"] == 0, counters
    assert counters["used"] >= published - 110, figures
    assert delays[int(0.99 * len(delays))] < 2.5, figures
    # Bounded queues everywhere: keep-last QOS_DEPTH on every pmv topic; reliable publishers,
    # best-effort subscriptions to inputs (README "QoS": they accept either kind of publisher).
    for topic, qos in queues:
        if topic.startswith(("/pmv/", "/star_tracker/", "/attitude/", "/orbit/", "/diagnostics")):
            assert qos.history == HistoryPolicy.KEEP_LAST and qos.depth == QOS_DEPTH, (topic, qos)
    for topic, qos in publisher_qos:
        if topic.startswith(("/pmv/", "/star_tracker/", "/attitude/", "/orbit/")):
            assert qos.reliability == ReliabilityPolicy.RELIABLE, topic
    assert len(input_qos) == 4  # truth for the tracker; sensor, truth and odometry for the monitor
    for topic, qos in input_qos:
        assert qos.reliability == ReliabilityPolicy.BEST_EFFORT, topic
