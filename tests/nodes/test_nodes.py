"""In-process node tests: each node in an executor, fed by test publishers, outputs checked (issue 4).

No rosbag, no sleeps: publishers and subscribers share one executor, which is
drained after each publication (pmv_ros.nodes.pipeline explains the drain).
Every test has its own rclpy context and discovery is off (conftest.py), so
tests cannot hear each other.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped, QuaternionStamped, Vector3Stamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

import pmv_msgs_shim as shim
from pmv_ros.nodes.error_monitor_node import ErrorMonitorNode
from pmv_ros.nodes.pipeline import Pipeline, TakingQueued
from pmv_ros.nodes.sensor_node import SensorNode
from pmv_ros.nodes.star_tracker_node import StarTrackerNode
from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw, roll_pitch_yaw_from_quaternion
from pmv_ros.physics.constants import ARCMIN_RAD, ARCSEC_RAD, EARTH_MEAN_RADIUS_M

pytestmark = [pytest.mark.multi_process]

#: A star tracker that tells the exact truth: no noise, no random failures.
PERFECT_TRACKER = {"ideal": True}
#: Spherical Earth, uniform horizon: no methodical error at all.
IDEAL_EARTH = {"sensor.earth_model": "sphere", "remove_oblateness": False}


def test_no_node_imports_scipys_signal_processing_or_interpolation():
    # Each costs ≈ 0.1–0.3 s of CPU at every start of a node process (scipy.signal ≈ 0.3 s, scipy.interpolate
    # ≈ 0.1 s); the sensor's chain builds its tables without the one, and a real-time block never needs the other.
    # The sensor here is built and has measured (its chain's tables built, its first samples taken).
    code = ("import sys, time, rclpy\n"
            "from geometry_msgs.msg import Vector3Stamped\n"
            "from rclpy.executors import SingleThreadedExecutor\n"
            "from pmv_ros.nodes.error_monitor_node import ErrorMonitorNode\n"
            "from pmv_ros.nodes.sensor_node import SensorNode\n"
            "from pmv_ros.nodes.star_tracker_node import StarTrackerNode\n"
            "rclpy.init()\n"
            "nodes = [SensorNode(), ErrorMonitorNode(), StarTrackerNode()]\n"
            "executor = SingleThreadedExecutor()\n"
            "got = []\n"
            "probe = rclpy.create_node('probe')\n"
            "probe.create_subscription(Vector3Stamped, '/pmv/attitude', got.append, 10)\n"
            "[executor.add_node(node) for node in (*nodes, probe)]\n"
            "deadline = time.monotonic() + 60.0\n"
            "while len(got) < 3:\n"
            "    if time.monotonic() > deadline:\n"
            "        sys.exit(f'no 3 samples on /pmv/attitude within 60 s: {len(got)}')\n"
            "    executor.spin_once(timeout_sec=0.1)\n"
            "loaded = [name for name in ('scipy.signal', 'scipy.interpolate') if name in sys.modules]\n"
            "[node.destroy_node() for node in nodes]\n"
            "rclpy.shutdown()\n"
            "print(' '.join(loaded))\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                            env=dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="OFF"))
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.split() == [], f"imported by a node: {result.stdout}"


def test_sensor_reads_a_constant_body_roll_of_30_arcmin():
    # Issue 4: with a constant body roll of 30′ the sensor reports 30′ ± 0.5′
    # (here on the GRS80 Earth, so the ≈ 5′ oblateness error is compensated on
    # board with the closed-form model, which matches the rays to ≈ 0.06′).
    overrides = {"attitude.roll_offset_arcmin": 30.0, "sensor.oblateness_compensation": True, "sensor.rate_hz": 2.0}
    with Pipeline(None, overrides, collect=False) as pipeline:
        got = []
        pipeline.collector = None
        probe = Node("probe", context=pipeline.context)
        probe.create_subscription(Vector3Stamped, "/pmv/attitude", got.append, 100)
        pipeline.executor.add_node(probe)
        pipeline.nodes.append(probe)
        pipeline.step(600)  # five minutes, a twentieth of an orbit
        statistics = pipeline.monitor.monitor.summary()
    # The monitor knows the model was removed on board and does not subtract it again:
    # doing so would leave ≈ −2.5′ of pitch over u = 0…19° (the model rises to ≈ 5′ there).
    assert statistics.channel("pitch").count > 550
    assert abs(statistics.channel("pitch").mean_rad) / ARCMIN_RAD < 0.3
    assert abs(statistics.channel("roll").mean_rad) / ARCMIN_RAD < 0.3
    roll = np.array([m.vector.x for m in got]) / ARCMIN_RAD
    pitch = np.array([m.vector.y for m in got]) / ARCMIN_RAD
    assert len(got) == 600
    assert got[0].header.frame_id == shim.SENSOR_FRAME
    assert np.all(np.abs(roll - 30.0) < 0.5)
    assert np.all(np.abs(pitch) < 0.5)
    assert all(m.vector.z == 0.0 for m in got)


def test_the_in_process_pipelines_nodes_give_the_executor_no_service_to_wait_on():
    # Lean nodes: no parameter services and no ~/get_type_description (nothing in the private graph calls them;
    # each would be an entity of every executor wait); a plain node keeps rclpy's.
    with Pipeline(None, {"sensor.rate_hz": 5.0}, collect=False) as pipeline:
        assert [list(node.services) for node in pipeline.nodes] == [[]] * 3
        assert pipeline.sensor.get_parameter("start_type_description_service").value is False
        plain = Node("plain_probe", context=pipeline.context)
        try:
            assert "plain_probe/get_type_description" in [service.srv_name.lstrip("/") for service in plain.services]
        finally:
            plain.destroy_node()


def _collected(one_at_a_time: bool, ticks: int = 80) -> tuple[np.ndarray, int]:
    """The collector's residuals after ``ticks`` of the preset, and the executor waits it took."""
    with Pipeline("config/kondor.yaml") as pipeline:
        pipeline.by_takes = False  # rclpy's waits (the drain by takes: the tests after the next)
        collector = pipeline.collector
        if one_at_a_time:  # rclpy's own way: one message per subscription per wait
            for subscription in collector.subscriptions:
                if isinstance(subscription.callback, TakingQueued):
                    subscription.callback = subscription.callback.callback
        waits = _counted_waits(pipeline.executor)
        pipeline.step(ticks)
        return collector.residual_array(), waits[0]


def test_the_report_collector_takes_a_frames_residuals_in_one_wake_up():
    # A star-tracker frame (one a second) settles 10 samples: 10 residuals on one topic, which rclpy takes one
    # per executor wait (≈ 65 µs each). The collector takes the queued ones in the same wake-up: the same
    # residuals, in the same order, bit for bit, and 9 waits fewer per frame of 10; asserted as 3 per 5 samples,
    # with room to spare.
    one_by_one, waits_one_by_one = _collected(one_at_a_time=True)
    queued, waits_queued = _collected(one_at_a_time=False)
    assert one_by_one.shape[1] >= 50
    np.testing.assert_array_equal(queued, one_by_one)
    assert waits_one_by_one - waits_queued >= 3 * one_by_one.shape[1] // 5


def _counted_waits(executor) -> list:
    """[n]: the executor's zero-timeout waits from now on (each ends in one TimeoutException, whatever it found)."""
    from rclpy.executors import TimeoutException

    waits, wait = [0], executor.wait_for_ready_callbacks

    def counted(*args, **kwargs):
        try:
            return wait(*args, **kwargs)
        except TimeoutException:
            waits[0] += 1
            raise

    executor.wait_for_ready_callbacks = counted
    return waits


def test_the_drain_by_takes_leaves_every_output_as_it_was_and_waits_only_for_the_timers():
    # The pipeline's graph is subscriptions and timers: the drain asks the entities directly instead of waiting,
    # and the pipeline publishes the same residuals and statistics, bit for bit. A wait remains where a timer is
    # due (the monitor's and the star tracker's, once a second of simulated time: 20 of the 200 ticks).
    got = {}
    for by_takes in (False, True):
        with Pipeline("config/kondor.yaml") as pipeline:
            pipeline.by_takes = by_takes
            waits = _counted_waits(pipeline.executor)
            pipeline.step(200)
            statistics = pipeline.monitor.publish_statistics(pipeline.sensor.sim_time_s)
            got[by_takes] = (pipeline.collector.residual_array(), statistics, waits[0])
    (residuals, statistics, waits), (residuals_taken, statistics_taken, waits_taken) = got[False], got[True]
    assert residuals.shape[1] >= 150
    np.testing.assert_array_equal(residuals_taken, residuals)
    assert repr(statistics_taken) == repr(statistics)  # every float as its shortest exact repr (NaN harmonics too)
    assert waits >= 2 * 200 and waits_taken <= 2 * 20  # here 502 against 20: one wait at each tick of the timers


def _lean_graph(names):
    """Lean nodes of ``names`` on one executor (whose order of nodes is its own): (context, {name: node}, executor)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from pmv_ros.nodes.base import PmvNode

    context = rclpy.Context()
    rclpy.init(context=context)
    nodes = {name: PmvNode(name, lean=True, context=context) for name in names}
    executor = SingleThreadedExecutor(context=context)
    for node in nodes.values():
        executor.add_node(node)
    return context, nodes, executor


def _close_lean_graph(context, nodes, executor) -> None:
    import rclpy

    executor.shutdown()
    for node in nodes.values():
        node.destroy_node()
    rclpy.shutdown(context=context)


def test_the_drain_by_takes_hands_out_what_a_wait_would_in_its_order():
    # A callback publishes to three subscribers in two other nodes, two of them twice, after the look that
    # handed it out: the drain's next look finds them. By takes or by a wait, the callbacks run in the executor's
    # order (node by node in its own order, each node's subscriptions in theirs, one message per subscription per
    # look), and the drain ends only when all ran.
    from pmv_ros.nodes.pipeline import drain

    runs = {}
    for by_takes in (False, True):
        context, nodes, executor = _lean_graph(("early", "late", "source"))
        try:
            order = []
            source = nodes["source"]
            outputs = {topic: source.publisher(Vector3Stamped, topic) for topic in ("/a", "/b", "/c")}

            def fan_out(message) -> None:
                order.append("source")
                for topic, copies in (("/c", 2), ("/a", 2), ("/b", 1)):
                    for k in range(copies):
                        out = Vector3Stamped()
                        out.vector.x = float(k)
                        outputs[topic].publish(out)

            for name, topic in (("late", "/c"), ("early", "/b"), ("early", "/a")):
                nodes[name].subscription(Vector3Stamped, topic, lambda message, topic=topic: order.append(
                    f"{topic} {message.vector.x:g}"))
            source.subscription(Vector3Stamped, "/in", fan_out)
            source.publisher(Vector3Stamped, "/in").publish(Vector3Stamped())
            executor_order = [s.topic_name for node in executor.get_nodes() for s in node.subscriptions
                              if s.topic_name != "/in"]
            waits = _counted_waits(executor)
            assert drain(executor, by_takes=by_takes) == 6
            expected = ["source", *(f"{topic} 0" for topic in executor_order),
                        *(f"{topic} 1" for topic in executor_order if topic != "/b")]
            runs[by_takes] = order, expected, waits[0]
        finally:
            _close_lean_graph(context, nodes, executor)
    for order, expected, _ in runs.values():
        assert order == expected
    assert runs[True][2] < runs[False][2]


def _drained(by_takes: bool, setup, drains) -> list:
    """What happened — callbacks, idle hand-overs, each drain's count or exception — in a lean graph that
    ``setup(node, log)`` prepared, drained once per entry of ``drains`` (that drain's keyword arguments), by
    takes or by rclpy's waits."""
    from pmv_ros.nodes.pipeline import drain

    context, nodes, executor = _lean_graph(("node",))
    log = []
    try:
        setup(nodes["node"], log)
        for options in drains:
            try:
                log.append(drain(executor, on_idle=lambda: log.append("idle") or False, by_takes=by_takes,
                                 **options))
            except RuntimeError as error:
                log.append(f"raised {error}")
    finally:
        _close_lean_graph(context, nodes, executor)
    return log


def _published(node, topics) -> None:
    for topic in topics:
        node.publisher(Vector3Stamped, topic).publish(Vector3Stamped())


def _cut_by_the_limit(node, log):
    for topic in ("/a", "/b"):
        node.subscription(Vector3Stamped, topic, lambda message, topic=topic: log.append(topic))
    _published(node, ("/a", "/a", "/b"))


def _cut_by_an_exception(node, log):
    def on_a(message) -> None:
        log.append("/a")
        if log.count("/a") == 1:
            raise RuntimeError("once")

    node.subscription(Vector3Stamped, "/a", on_a)
    node.subscription(Vector3Stamped, "/b", lambda message: log.append("/b"))
    _published(node, ("/a", "/a", "/b"))


def _destroying_a_later_subscription(node, log):
    def on_a(message) -> None:
        log.append("/a")
        node.destroy_subscription(later)

    node.subscription(Vector3Stamped, "/a", on_a)
    later = node.subscription(Vector3Stamped, "/b", lambda message: log.append("/b"))
    _published(node, ("/a", "/b"))


@pytest.mark.parametrize("setup, drains, expected", [
    (_cut_by_the_limit, ({"max_callbacks": 1}, {"max_callbacks": 2}, {}),
     ["/a", 1, "/b", "idle", "/a", 2, "idle", "idle", 0]),
    (_cut_by_an_exception, ({}, {}), ["/a", "raised once", "/b", "idle", "/a", "idle", "idle", 2]),
    (_destroying_a_later_subscription, ({},), ["/a", "idle", "idle", 1]),
])
def test_the_drain_by_takes_stops_and_goes_on_as_a_wait_does(setup, drains, expected):
    # A drain cut by its callback limit or by a callback's exception leaves the rest of that look, and its
    # timeout (the idle hand-over), to the next drain, as a wait leaves the rest of its callbacks; a subscription
    # that an earlier callback of the look destroyed gets nothing. By takes as by rclpy's waits.
    assert _drained(False, setup, drains) == expected
    assert _drained(True, setup, drains) == expected


def _draining_inside_a_callback(node, log):
    from pmv_ros.nodes.pipeline import drain

    own = node.publisher(Vector3Stamped, "/a")

    def on_a(message) -> None:
        log.append("/a")
        if log.count("/a") == 1:
            own.publish(Vector3Stamped())
            log.append(f"inside {drain(node.executor, by_takes=True)}")

    node.subscription(Vector3Stamped, "/a", on_a)
    own.publish(Vector3Stamped())


def test_a_drain_inside_a_callback_does_not_run_that_callback_again():
    # The callback's group is held while it runs (rclpy's handler holds it; so does a callback handed out by
    # takes): a drain inside it cannot hand out the same subscription, which waits for the outer drain. (Where
    # the idle hand-over falls differs: rclpy's inner wait runs the outer wait's generator to its timeout.)
    for by_takes in (False, True):
        log = _drained(by_takes, _draining_inside_a_callback, ({},))
        assert log[:2] == ["/a", "inside 0"] and log.count("/a") == 2 and log[-1] == 2, log


def test_the_drain_by_takes_refuses_an_async_callback():
    # rclpy's handler awaits a coroutine callback; the takes do not: a TypeError that says so, not a dropped message.
    from pmv_ros.nodes.pipeline import drain

    async def on_message(message) -> None:
        return None

    context, nodes, executor = _lean_graph(("node",))
    try:
        nodes["node"].subscription(Vector3Stamped, "/a", on_message)
        _published(nodes["node"], ("/a",))
        with pytest.raises(TypeError, match="async callback"):
            drain(executor)
    finally:
        _close_lean_graph(context, nodes, executor)


def test_a_wait_a_drain_left_half_handed_out_goes_on_first():
    # A timer is due with messages on two subscriptions: a wait hands out the timer, then both. A drain stopped
    # after the timer leaves that wait's two callbacks for the next drain; they come before what the timer
    # published to a subscription made before them — by takes as by rclpy's waits.
    from pmv_ros.nodes.pipeline import drain

    orders = {}
    for by_takes in (False, True):
        context, nodes, executor = _lean_graph(("node",))
        try:
            node, order = nodes["node"], []
            for topic in ("/c", "/a", "/b"):
                node.subscription(Vector3Stamped, topic, lambda message, topic=topic: order.append(topic))
            publishers = {topic: node.publisher(Vector3Stamped, topic) for topic in ("/a", "/b", "/c")}
            timers = []

            def on_timer() -> None:
                order.append("timer")
                timers[0].cancel()
                publishers["/c"].publish(Vector3Stamped())

            timers.append(node.create_timer(0.001, on_timer))
            publishers["/a"].publish(Vector3Stamped())
            publishers["/b"].publish(Vector3Stamped())
            time.sleep(0.01)  # the timer is due
            assert drain(executor, max_callbacks=1, by_takes=by_takes) == 1
            assert drain(executor, by_takes=by_takes) == 3
            orders[by_takes] = order
        finally:
            _close_lean_graph(context, nodes, executor)
    assert orders[True] == orders[False] == ["timer", "/a", "/b", "/c"]


def test_the_drain_by_takes_leaves_to_a_wait_what_takes_cannot_see():
    # A timer that falls due during the drain, a guard condition a callback triggers, a task a callback makes:
    # the takes cannot hand them out, so a wait does, in the same drain.
    from pmv_ros.nodes.pipeline import drain

    context, nodes, executor = _lean_graph(("node",))
    node = nodes["node"]
    try:
        heard, timers = [], []

        def on_message(message) -> None:  # a timer made after the wait that handed this out, due before it ends
            heard.append("message")
            timers.append(node.create_timer(0.01, lambda: (heard.append("timer"), timers[0].cancel())))
            time.sleep(0.02)

        node.subscription(Vector3Stamped, "/in", on_message)
        node.publisher(Vector3Stamped, "/in").publish(Vector3Stamped())
        drain(executor)
        assert heard == ["message", "timer"]
        node.destroy_timer(timers[0])
        guard = node.create_guard_condition(lambda: heard.append("guard"))
        node.subscription(Vector3Stamped, "/poke", lambda message: guard.trigger())
        node.publisher(Vector3Stamped, "/poke").publish(Vector3Stamped())
        drain(executor)
        assert heard[2:] == ["guard"]
        node.destroy_guard_condition(guard)
        node.subscription(Vector3Stamped, "/later", lambda message: executor.create_task(lambda: heard.append("task")))
        node.publisher(Vector3Stamped, "/later").publish(Vector3Stamped())
        drain(executor)
        assert heard[3:] == ["task"]
    finally:
        _close_lean_graph(context, nodes, executor)


def _echo_graph():
    """A lean node publishing and subscribing to /echo on its own executor: (context, node, publisher, executor)."""
    context, nodes, executor = _lean_graph(("echo",))
    node = nodes["echo"]
    return context, node, node.publisher(Vector3Stamped, "/echo"), executor


def _close_echo_graph(context, node, executor) -> None:
    _close_lean_graph(context, {"echo": node}, executor)


def test_taking_the_queued_messages_is_bounded_by_the_queue_depth():
    # A callback that publishes on its own topic keeps the queue full (a publish in one process is delivered at
    # once, as the pipeline's drain relies on): one wake-up still ends, after the message the executor gave and
    # at most QOS_DEPTH more.
    from pmv_ros.nodes.base import QOS_DEPTH
    from pmv_ros.nodes.pipeline import drain

    context, node, publisher, executor = _echo_graph()
    try:
        heard = []

        def on_message(message) -> None:
            heard.append(message)
            publisher.publish(message)

        subscription = node.subscription(Vector3Stamped, "/echo", on_message)
        subscription.callback = TakingQueued(subscription, on_message)
        publisher.publish(Vector3Stamped())
        assert drain(executor, max_callbacks=1) == 1
        assert len(heard) == 1 + QOS_DEPTH
    finally:
        _close_echo_graph(context, node, executor)


def test_taking_the_queued_messages_stops_at_a_subscription_destroyed_by_its_callback():
    # rclpy's own take skips a destroyed subscription; so does the loop: the second message destroys it, and
    # neither the three queued behind it nor an error come out of the wake-up. A callback that wants the message
    # info too is refused at once (the loop passes the message only).
    from pmv_ros.nodes.pipeline import drain

    context, node, publisher, executor = _echo_graph()
    try:
        heard = []

        def on_message(message) -> None:
            heard.append(message.vector.x)
            if len(heard) == 2:
                node.destroy_subscription(subscription)

        subscription = node.subscription(Vector3Stamped, "/echo", on_message)
        subscription.callback = TakingQueued(subscription, on_message)
        for k in range(5):
            message = Vector3Stamped()
            message.vector.x = float(k)
            publisher.publish(message)
        drain(executor)
        assert heard == [0.0, 1.0]
        with pytest.raises(TypeError):
            TakingQueued(subscription, lambda message, info: None)
    finally:
        _close_echo_graph(context, node, executor)


def test_perfect_tracker_sphere_uniform_horizon_gives_zero_mean_residual():
    # Issue 4: noise-free truth, spherical Earth, uniform radiance → residual mean within 0.1′ of zero.
    overrides = {**PERFECT_TRACKER, **IDEAL_EARTH, "attitude.roll_offset_arcmin": 12.0,
                 "attitude.pitch_amplitude_arcmin": 20.0, "attitude.oscillation_period_s": 300.0}
    with Pipeline(None, overrides) as pipeline:
        messages = _statistics_probe(pipeline)
        pipeline.step(3000)
        statistics = pipeline.monitor.publish_statistics(pipeline.sensor.sim_time_s)
        pipeline.drain()
        residuals = pipeline.collector.residual_array()
    assert statistics.channel("roll").count > 2900
    for name in ("roll", "pitch"):
        assert abs(statistics.channel(name).mean_rad) / ARCMIN_RAD < 0.1
    assert np.max(np.abs(residuals[1:])) / ARCMIN_RAD < 0.1
    # the statistics message carried the same numbers to a subscriber
    assert shim.error_statistics_from_msg(messages[-1]).channel("pitch").count == statistics.channel("pitch").count


def _statistics_probe(pipeline) -> list:
    """The /pmv/error_statistics messages of ``pipeline`` from now on (a subscriber in its process)."""
    messages = []
    probe = Node("statistics_probe", context=pipeline.context)
    probe.create_subscription(DiagnosticArray, "/pmv/error_statistics", messages.append, 100)
    pipeline.executor.add_node(probe)
    pipeline.nodes.append(probe)
    return messages


def test_the_main_job_writes_no_statistics_message_nobody_reads_and_its_progress_asks_the_monitor(monkeypatch):
    # pmv simulate's report and progress line ask the monitor node in the process: a lean monitor writes
    # /pmv/error_statistics only for a subscriber (a recording, a probe). The statistics are computed on the same
    # schedule either way, and the probe's messages carry what the node's latest_statistics gives.
    written = []
    write = shim.write_error_statistics
    monkeypatch.setattr(shim, "write_error_statistics", lambda *arguments: written.append(1) or write(*arguments))
    with Pipeline("config/kondor.yaml") as pipeline:
        pipeline.step(35)  # 3.5 s at 10 Hz: statistics due three or four times
        assert written == []
        unread = pipeline.monitor.latest_statistics
        assert unread is not None and unread.channel("roll").count > 0
        messages = _statistics_probe(pipeline)
        pipeline.step(25)
        latest = pipeline.monitor.latest_statistics
    assert len(written) == len(messages) in (2, 3)
    assert latest.stamp_s - unread.stamp_s == pytest.approx(len(messages), abs=1e-6)  # one a second of samples
    carried = shim.error_statistics_from_msg(messages[-1])
    assert shim.time_from_msg(messages[-1].header.stamp) == pytest.approx(latest.stamp_s, abs=1e-9)
    assert carried.counters == latest.counters
    for name in ("roll", "pitch", "meridional"):
        assert carried.channel(name).count == latest.channel(name).count
        assert carried.channel(name).sigma_rad == pytest.approx(latest.channel(name).sigma_rad, rel=1e-6)


def test_sensor_topics_types_frames_and_units():
    with Pipeline("config/kondor.yaml", {"sensor.rate_hz": 5.0}, collect=False) as pipeline:
        got = {topic: [] for topic in ("/pmv/horizon_crossings", "/orbit/odometry", "/attitude/truth",
                                       "/pmv/attitude_uncorrected", "/diagnostics")}
        probe = Node("probe", context=pipeline.context)
        for topic, kind in (("/pmv/horizon_crossings", PolygonStamped), ("/orbit/odometry", Odometry),
                            ("/attitude/truth", QuaternionStamped), ("/pmv/attitude_uncorrected", Vector3Stamped),
                            ("/diagnostics", DiagnosticArray)):
            probe.create_subscription(kind, topic, got[topic].append, 100)
        pipeline.executor.add_node(probe)
        pipeline.nodes.append(probe)
        pipeline.step(50)
    crossings = [shim.horizon_crossings_from_msg(m) for m in got["/pmv/horizon_crossings"]]
    assert len(crossings) == 50 and all(c.frame_id == shim.SENSOR_FRAME for c in crossings)
    for c in crossings:
        assert np.all(c.valid)
        np.testing.assert_allclose(np.linalg.norm(c.line_of_sight, axis=1), 1.0, atol=1e-6)
        # chords +X, +Y, −X, −Y see the horizon ≈ 68° from the −Z boresight at 500 km
        nadir = np.degrees(np.arccos(-c.line_of_sight[:, 2]))
        assert np.all((nadir > 66.0) & (nadir < 70.0))
        assert c.line_of_sight[0, 0] > 0.9 and c.line_of_sight[1, 1] > 0.9 and c.line_of_sight[2, 0] < -0.9
    odometry = [shim.orbit_state_from_msg(m) for m in got["/orbit/odometry"]]
    assert odometry[0].frame_id == shim.ECI_FRAME
    radius = np.linalg.norm(odometry[0].position_m)
    assert radius == pytest.approx(EARTH_MEAN_RADIUS_M + 500e3, rel=1e-9)
    assert np.linalg.norm(odometry[0].velocity_m_s) == pytest.approx(7613.0, rel=1e-3)
    stamps = [shim.time_from_msg(m.header.stamp) for m in got["/attitude/truth"]]
    np.testing.assert_allclose(np.diff(stamps), 0.2, atol=1e-9)
    assert got["/attitude/truth"][0].header.frame_id == shim.ORBITAL_FRAME
    assert len(got["/pmv/attitude_uncorrected"]) == 50
    names = {status.name for m in got["/diagnostics"] for status in m.status}
    assert "pmv_ros/sensor_node: horizon" in names


def test_star_tracker_node_alone(harness):
    # On the simulation's clock (sim.fast_time: the orbit is at its epoch elements at sim.start_time_s, 0): the
    # stamps below are then the preset's first 200 s. On the wall clock the orbit's epoch is the node's start, and
    # stamps of 0…200 s lie decades before it, at an orbit phase and a Sun that change with the start time: over
    # a month of start times ≈ 1 % of them put these frames in the Earth's or the Sun's exclusion or in a field
    # without stars (47 frames with attitude, or none, instead of ≈ 370).
    h = harness(StarTrackerNode, {"frame_period_s": 0.5, "exposure_s": 0.5, "processing_s": 0.3,
                                  "sim.fast_time": True})
    h.record(QuaternionStamped, "/star_tracker/attitude")
    h.record(DiagnosticArray, "/diagnostics")
    truth = h.publisher(QuaternionStamped, "/attitude/truth")
    roll, pitch = 10 * ARCMIN_RAD, -4 * ARCMIN_RAD
    q = quaternion_from_roll_pitch_yaw(roll, pitch, 0.0)
    releases = {}
    for k in range(1, 2001):  # 200 s of truth at 10 Hz
        t = 0.1 * k
        truth.publish(shim.write_attitude_quaternion(QuaternionStamped(), t, shim.ORBITAL_FRAME, q))
        h.drain()
        for message in h.received["/star_tracker/attitude"][len(releases):]:
            releases[shim.time_from_msg(message.header.stamp)] = t
    measured = [shim.attitude_quaternion_from_msg(m) for m in h.received["/star_tracker/attitude"]]
    stamps = np.array([m.stamp_s for m in measured])
    # frames on the 0.5 s grid (some give no attitude), released no earlier than stamp + exposure/2 + processing
    assert len(stamps) > 200 and np.allclose(np.diff(stamps) / 0.5, np.round(np.diff(stamps) / 0.5), atol=1e-9)
    assert all(release >= stamp + 0.25 + 0.3 - 1e-9 for stamp, release in releases.items())
    angles = np.array([roll_pitch_yaw_from_quaternion(m.q_xyzw) for m in measured])
    # A few arcseconds across the boresight (+Z body: roll and pitch), many more about it (yaw): physics.md §6
    # item 5, from the stars of the two or three fields of 200 s (their biases dominate: loose bounds).
    across = np.hypot(angles[:, 0] - roll, angles[:, 1] - pitch) / ARCSEC_RAD
    assert 0.5 < np.sqrt(np.mean(across ** 2)) < 15.0
    assert np.sqrt(np.mean(angles[:, 2] ** 2)) / ARCSEC_RAD > 3.0 * np.sqrt(np.mean(across ** 2) / 2.0)
    values = dict(shim.health_from_msg(h.received["/diagnostics"][-1]).statuses[0].values)
    assert {"frames_ok", "frames_no_stars", "frames_recognition_failure", "frames_buffer_overflow",
            "frames_exclusion", "frames_rate_too_high", "frames_outage", "stars_in_field", "proton_hits"} <= set(values)


def _drain_until(h, condition, timeout_s: float = 10.0) -> None:
    """Drain until ``condition()`` holds (or ``timeout_s`` passes: the assertions after it then say what is missing)."""
    deadline = time.monotonic() + timeout_s
    h.drain()
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.01)
        h.drain()


def test_star_tracker_frames_between_sparse_truth_are_the_frame_loops(harness):
    # Truth at 1 Hz, frames at 2 Hz: two or three frames fall due per truth sample; the node publishes the
    # frames its runtime's frame loop makes of the stream (the campaign's path), with the same draws.
    from pmv_ros.runtime.flight import flight_values
    from pmv_ros.runtime.tracker.runtime import TrackerRuntime, track_stream

    # On the simulation's clock, as test_star_tracker_node_alone says why: on the wall clock the stamps 1…20 s
    # fall decades before the node's start, where the sky (and so how many frames fail) depends on the start time.
    options = {"frame_period_s": 0.5, "exposure_s": 0.02, "processing_s": 0.0, "seed": 7,
               "recognition.failure_at_3": 0.9, "recognition.failure_scale_stars": 8.0, "sim.fast_time": True}
    h = harness(StarTrackerNode, options)
    h.record(QuaternionStamped, "/star_tracker/attitude")
    truth = h.publisher(QuaternionStamped, "/attitude/truth")
    q = quaternion_from_roll_pitch_yaw(10 * ARCMIN_RAD, -4 * ARCMIN_RAD, 0.0)
    for k in range(1, 21):
        truth.publish(shim.write_attitude_quaternion(QuaternionStamped(), float(k), shim.ORBITAL_FRAME, q))
        h.drain()
    values = {**flight_values({}).star_tracker, **options}
    t = np.arange(1.0, 21.0)
    frames = track_stream(TrackerRuntime(values, h.node.runtime.start_s), t, np.tile(np.array(q)[:, None], 20))
    published = np.flatnonzero(frames.released_at >= 0)
    # A drain ends when the graph looks idle; a message still on its way between two nodes of the process (a
    # loaded machine) is not in any queue yet. So wait for what must come: the node has measured every frame of
    # the 20 truth messages, and the tester has received what it published.
    _drain_until(h, lambda: sum(v for k, v in h.node.counters.items() if k.startswith("frames_"))
                 >= frames.frame_s.size and len(h.received["/star_tracker/attitude"]) >= published.size)
    got = [shim.attitude_quaternion_from_msg(m) for m in h.received["/star_tracker/attitude"]]
    assert 10 < len(got) == published.size < 38  # some frames failed, and the same ones
    for record, k in zip(got, published):
        assert record.stamp_s == frames.frame_s[k]
        np.testing.assert_allclose(record.q_xyzw, frames.q_measured[:, k], atol=1e-14)


def test_star_tracker_follows_the_users_orbit_and_says_why_each_frame_has_no_attitude(harness):
    """orbit.source follow: the node takes orbit/odometry and measures its frames on that orbit; before the first
    state a frame has no orbit. Every frame's status goes out on /star_tracker/frame_status (its reason)."""
    from pmv_ros.physics.orbit.two_body import CircularOrbit

    h = harness(StarTrackerNode, {"frame_period_s": 0.5, "exposure_s": 0.02, "processing_s": 0.0,
                                  "orbit.source": "follow"})
    h.record(DiagnosticArray, "/star_tracker/frame_status")
    truth = h.publisher(QuaternionStamped, "/attitude/truth")
    odometry = h.publisher(Odometry, "/orbit/odometry")
    orbit = CircularOrbit(600e3, math.radians(60.0))
    q = quaternion_from_roll_pitch_yaw(0.0, 0.0, 0.0)
    for k in range(1, 41):
        stamp = 0.25 * k
        if stamp >= 5.0:  # the user's orbit from 5 s on
            position, velocity = orbit.state_eci(stamp)
            odometry.publish(shim.write_orbit_state(Odometry(), stamp, shim.ECI_FRAME, shim.ORBITAL_FRAME, position,
                                                    velocity))
            h.drain()
        truth.publish(shim.write_attitude_quaternion(QuaternionStamped(), stamp, shim.ORBITAL_FRAME, q))
        h.drain()
    _drain_until(h, lambda: len(h.received["/star_tracker/frame_status"]) >= 18)
    statuses = [shim.frame_status_input(m) for m in h.received["/star_tracker/frame_status"]]
    assert [t for t, _ in statuses] == [0.5 * k for k in range(1, len(statuses) + 1)]
    reasons = dict(statuses)
    assert {reasons[t] for t in reasons if t < 5.0} == {"no_orbit"}
    assert all(reasons[t] != "no_orbit" for t in reasons if t >= 5.0)
    counters = h.node.counters
    assert counters["frames_no_orbit"] == 9 and sum(v for k, v in counters.items() if k.startswith("frames_")) \
        == len(statuses)


def test_star_tracker_gives_nothing_above_its_rate_limit(harness):
    h = harness(StarTrackerNode, {"frame_period_s": 0.5, "exposure_s": 0.02, "processing_s": 0.0})
    h.record(QuaternionStamped, "/star_tracker/attitude")
    h.record(DiagnosticArray, "/diagnostics")
    truth = h.publisher(QuaternionStamped, "/attitude/truth")
    # a 0.5°/s roll (1800″/s) is far above the 600″/s ceiling
    for k in range(1, 101):
        q = quaternion_from_roll_pitch_yaw(math.radians(0.05 * k), 0.0, 0.0)
        truth.publish(shim.write_attitude_quaternion(QuaternionStamped(), 0.1 * k, shim.ORBITAL_FRAME, q))
        h.drain()
    assert h.received["/star_tracker/attitude"] == []
    report = shim.health_from_msg(h.received["/diagnostics"][-1])
    assert "rate too high" in report.statuses[0].message


def test_error_monitor_node_alone(harness):
    # On simulation time, as in a fast-time run: the node's clock is the test's /clock.
    h = harness(ErrorMonitorNode, {"remove_oblateness": False, "statistics_rate_hz": 1.0, "use_sim_time": True})
    h.record(Vector3Stamped, "/pmv/residual")
    h.record(DiagnosticArray, "/pmv/error_statistics")
    sensor = h.publisher(Vector3Stamped, "/pmv/attitude")
    truth = h.publisher(QuaternionStamped, "/star_tracker/attitude")
    clock = h.publisher(Clock, "/clock")
    for k in range(1, 301):
        t = 0.1 * k
        clock.publish(shim.write_clock(Clock(), t))
        if k % 5 == 0:  # truth at 2 Hz: roll 5′, pitch −2′
            q = quaternion_from_roll_pitch_yaw(5 * ARCMIN_RAD, -2 * ARCMIN_RAD, 0.0)
            truth.publish(shim.write_attitude_quaternion(QuaternionStamped(), t, shim.ORBITAL_FRAME, q))
        # the sensor reads 1.5′ more roll and 0.5′ less pitch than the truth
        sensor.publish(shim.write_attitude_angles(Vector3Stamped(), t, shim.SENSOR_FRAME, 6.5 * ARCMIN_RAD,
                                                  -2.5 * ARCMIN_RAD))
        h.drain()
    residuals = [shim.attitude_angles_from_msg(m) for m in h.received["/pmv/residual"]]
    assert len(residuals) >= 290
    np.testing.assert_allclose([r.roll_rad / ARCMIN_RAD for r in residuals], 1.5, atol=1e-6)
    np.testing.assert_allclose([r.pitch_rad / ARCMIN_RAD for r in residuals], -0.5, atol=1e-6)
    statistics = shim.error_statistics_from_msg(h.received["/pmv/error_statistics"][-1])
    assert statistics.channel("roll").mean_rad / ARCMIN_RAD == pytest.approx(1.5, abs=1e-6)
    assert statistics.channel("pitch").mean_rad / ARCMIN_RAD == pytest.approx(-0.5, abs=1e-6)
    assert statistics.channel("roll").sigma_rad < 1e-9


def test_monitor_warns_when_odometry_flies_another_orbit_than_its_parameters(harness):
    # The harmonic ring's period comes from orbit.altitude_km; odometry from an 835 km orbit
    # (period ≈ 6,080 s) against the default 500 km (≈ 5,677 s) must not pass silently.
    h = harness(ErrorMonitorNode, {"use_sim_time": True})
    h.record(DiagnosticArray, "/diagnostics")
    odometry, clock = h.publisher(Odometry, "/orbit/odometry"), h.publisher(Clock, "/clock")
    messages = []
    for altitude_m in (500e3, 835e3):
        radius = EARTH_MEAN_RADIUS_M + altitude_m
        speed = math.sqrt(3.986004418e14 / radius)
        for k in range(1, 31):
            t = 10.0 * k + (0.0 if altitude_m == 500e3 else 400.0)
            clock.publish(shim.write_clock(Clock(), t))
            odometry.publish(shim.write_orbit_state(Odometry(), t, "eci", "orbital", [radius, 0.0, 0.0],
                                                    [0.0, speed, 0.0]))
            h.drain()
        messages.append([status.message for m in h.received["/diagnostics"] for status in m.status])
        h.received["/diagnostics"].clear()
    assert messages[0] and not any("orbital period" in m for m in messages[0])
    assert messages[1] and all("orbital period of 60" in m and "orbit.altitude_km" in m for m in messages[1])


def test_star_tracker_outage_does_not_stop_the_monitor():
    # Issue 4: truth is gone for 60 s; the monitor counts the samples it skipped and resumes.
    overrides = {"outage_start_s": [60.0], "outage_duration_s": [60.0], "ideal": True,
                 "sensor.rate_hz": 2.0}
    with Pipeline("config/kondor.yaml", overrides) as pipeline:
        messages = _statistics_probe(pipeline)
        pipeline.step(360)  # 180 s
        statistics = pipeline.monitor.publish_statistics(pipeline.sensor.sim_time_s)
        pipeline.drain()
        stamps = pipeline.collector.residual_array()[0]
    counters = statistics.counters
    skipped = sum(v for k, v in counters.items() if k.startswith("skipped_"))
    # 60 s at 2 Hz = 120 samples without truth (± the edges of the window)
    assert 110 <= skipped <= 130
    assert counters["used"] + skipped + counters["used_without_oblateness_model"] >= 355
    assert stamps.min() < 60.0 and stamps.max() > 170.0  # before and after the outage
    assert not np.any((stamps > 61.0) & (stamps < 119.0))  # never invented across the gap
    # the published statistics carry the skip counts for people and scripts
    published = shim.error_statistics_from_msg(messages[-1]).counters
    assert sum(v for k, v in published.items() if k.startswith("skipped_")) == skipped


def test_bad_parameter_update_is_rejected_and_the_node_keeps_publishing():
    with Pipeline("config/kondor.yaml", {"sensor.rate_hz": 5.0}) as pipeline:
        pipeline.step(10)
        sensor = pipeline.sensor
        results = sensor.set_parameters([Parameter("sensor.rate_hz", value=1000.0)])
        assert not results[0].successful and "sensor.rate_hz" in results[0].reason and "100" in results[0].reason
        results = sensor.set_parameters([Parameter("attitude.source", value="bogus")])
        assert not results[0].successful and "profile" in results[0].reason
        results = sensor.set_parameters([Parameter("orbit.inclination_deg", value="high")])
        assert not results[0].successful
        assert sensor.get_parameter("sensor.rate_hz").value == 5.0
        before = pipeline.collector.residual_count
        pipeline.step(10)
        assert pipeline.collector.residual_count > before
        # a good update is taken
        assert sensor.set_parameters([Parameter("attitude.roll_offset_arcmin", value=7.0)])[0].successful


def test_pipeline_runs_blas_on_one_thread_and_restores_it():
    # On two cores, OpenBLAS threads contend with the executor and the DDS threads and slow a
    # block of sensor samples several-fold (nodes/base.py); the pipeline limits BLAS while it lives.
    from threadpoolctl import threadpool_info

    def blas_threads():
        return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]

    before = blas_threads()
    first = Pipeline(None, {"sensor.rate_hz": 10.0})
    try:
        assert blas_threads() and all(n == 1 for n in blas_threads())
        with Pipeline(None, {"sensor.rate_hz": 10.0}):
            pass
        assert all(n == 1 for n in blas_threads())  # the first pipeline still holds the limit
    finally:
        first.close()
    assert blas_threads() == before


def test_pipeline_nodes_follow_the_sensor_time_without_taking_clock():
    # In one process the tracker and the monitor follow the sensor's simulation time through the
    # pipeline's time source; /clock is still published for anything outside, but no pipeline node takes it.
    with Pipeline(None, {"sensor.rate_hz": 10.0, "sim.start_time_s": 1000.0}) as pipeline:
        followers = (pipeline.star_tracker, pipeline.monitor)
        pipeline.step(25)
        for node in followers:
            assert node.get_parameter("use_sim_time").value is True
            assert node.get_clock().now().nanoseconds == round(pipeline.sensor.sim_time_s * 1e9)
            assert all(sub.topic_name != "/clock" for sub in node.subscriptions)
        assert pipeline.sensor.count_subscribers("/clock") == 0
        # A restarted node starts on the simulation time, not the wall clock; the stopped one is let go.
        stopped_clock, stopped_at = pipeline.monitor.get_clock(), pipeline.sensor.sim_time_s
        pipeline.stop_node("monitor")
        monitor = pipeline.start_node("monitor")
        assert monitor.get_clock().now().nanoseconds == round(pipeline.sensor.sim_time_s * 1e9)
        pipeline.step(30)
        assert monitor.get_clock().now().nanoseconds == round(pipeline.sensor.sim_time_s * 1e9)
        assert stopped_clock.now().nanoseconds == round(stopped_at * 1e9)
        assert monitor.monitor.counters["used"] > 0


@pytest.mark.parametrize("rate_hz, time_scale, block", [(10.0, 0.0, 512), (10.0, 1.0, 512), (10.0, 20.0, 50),
                                                        (10.0, 1000.0, 16)])
def test_paced_fast_time_computes_blocks_no_longer_than_a_tick(harness, rate_hz, time_scale, block):
    # As fast as possible: blocks of 512 (cheapest per sample). Paced by the node's own timer: a
    # block must fit in one tick, or /clock would stop for the tens of ms a block of 512 takes.
    # 10 Hz × 20 = a 5 ms tick: 50 samples at the sizing cost of 100 µs each.
    h = harness(SensorNode, {"sensor.rate_hz": rate_hz, "sim.fast_time": True, "sim.time_scale": time_scale})
    assert h.node.fast_time_block == block
    h.node.step()
    assert h.node.samples_computed_ahead == block - 1
    # Stepped by the in-process pipeline nothing is paced: always the big block.
    with Pipeline(None, {"sensor.rate_hz": rate_hz, "sim.time_scale": time_scale}) as pipeline:
        assert pipeline.sensor.fast_time_block == 512


def test_a_wake_up_s_messages_reach_the_monitor_together_at_the_next_wake_up(harness):
    """error_monitor_node queues what the executor's wake-ups take and hands it to its runtime at once when its
    wake-up guard (triggered by the first queued message) is handled — after the messages of the next wake-up,
    never later; nothing is lost or reordered (a residual for every covered sample, in stamp order)."""
    h = harness(ErrorMonitorNode, {"use_sim_time": True, "remove_oblateness": False})
    residuals = h.record(Vector3Stamped, "/pmv/residual")
    sensor = h.publisher(Vector3Stamped, "/pmv/attitude")
    truth = h.publisher(QuaternionStamped, "/star_tracker/attitude")
    clock = h.publisher(Clock, "/clock")
    clock.publish(shim.write_clock(Clock(), 10.0))
    h.drain()
    batches = []
    add_inputs = h.node.runtime.add_inputs
    h.node.runtime.add_inputs = lambda events: batches.append(len(events)) or add_inputs(events)
    q = quaternion_from_roll_pitch_yaw(0.0, 0.0, 0.0)
    for k in range(1, 6):
        sensor.publish(shim.write_attitude_angles(Vector3Stamped(), 9.0 + 0.1 * k, shim.SENSOR_FRAME, 1e-4, 0.0))
    truth.publish(shim.write_attitude_quaternion(QuaternionStamped(), 9.0, shim.ORBITAL_FRAME, q))
    truth.publish(shim.write_attitude_quaternion(QuaternionStamped(), 9.6, shim.ORBITAL_FRAME, q))
    waits = 0
    while not h.node.queued_inputs and waits < 100:  # until a wake-up has taken the first message
        h.executor.spin_once(timeout_sec=0.1)
        waits += 1
    assert h.node.queued_inputs and batches == []  # queued, not handed over
    h.drain()
    assert not h.node.queued_inputs and sum(batches) == 7 and max(batches) >= 2  # several messages per hand-over
    counters = h.node.monitor.counters
    assert counters["sensor_received"] == 5 and counters["truth_received"] == 2 and counters["used"] == 5
    stamps = [shim.attitude_angles_from_msg(m).stamp_s for m in residuals]
    assert stamps == sorted(stamps) and len(stamps) == 5
