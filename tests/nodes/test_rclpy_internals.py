"""The one module that touches rclpy's internals (:mod:`pmv_ros.nodes.rclpy_internals`): pinned to the rclpy
version it was written for, and each internal path run against its public fallback.

The only test module besides the fenced one that may name rclpy's private attributes (none is needed here: the
comparisons go through the module's own switch, :func:`~pmv_ros.nodes.rclpy_internals.use_internals`).
"""

from __future__ import annotations

import importlib.metadata
from contextlib import contextmanager

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import Vector3, Vector3Stamped
from rclpy.executors import SingleThreadedExecutor, TimeoutException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.time_source import TimeSource
from rosgraph_msgs.msg import Clock

import pmv_msgs_shim as shim
from pmv_ros.nodes import rclpy_internals
from pmv_ros.nodes.base import PmvNode
from pmv_ros.nodes.params import ParameterError
from pmv_ros.nodes.pipeline import Pipeline
from pmv_ros.nodes.rclpy_internals import (INTERNALS_USED, WRITTEN_FOR, TakingQueued, clock_now_s, drain,
                                           taking_queued, use_internals)
from pmv_ros.nodes.star_tracker_node import StarTrackerNode


@contextmanager
def internals(on: bool):
    """The internal paths on or off for the block; as they were after it."""
    before = rclpy_internals.internals_in_use()
    use_internals(on)
    try:
        yield
    finally:
        use_internals(before)


def test_rclpy_is_the_version_the_fenced_module_was_written_for():
    installed = importlib.metadata.version("rclpy")
    assert installed == WRITTEN_FOR, (
        f"rclpy is {installed}; pmv_ros/nodes/rclpy_internals.py was written for rclpy {WRITTEN_FOR} and now runs "
        "only its public fallbacks (pmv simulate slower, /clock unchecked, integer overrides of floating-point "
        "parameters refused). Re-check each internal it uses against the new rclpy, then set WRITTEN_FOR and run "
        "this module (every fallback is compared with its internal path):\n  " + "\n  ".join(INTERNALS_USED))
    assert rclpy_internals.VERSION_MATCHES and rclpy_internals.internals_in_use()


def test_the_internals_cannot_be_switched_on_for_another_rclpy(monkeypatch):
    monkeypatch.setattr(rclpy_internals, "VERSION_MATCHES", False)
    with pytest.raises(RuntimeError, match=WRITTEN_FOR):
        use_internals(True)


def _main_job(on: bool, ticks: int = 200) -> dict:
    """The main job's pipeline on the Kondor preset for ``ticks`` with the internals on or off: what a probe
    heard (topic by topic, in order), the collector's residuals, the statistics, and the executor's waits."""
    with internals(on), Pipeline("config/kondor.yaml") as pipeline:
        listener = PmvNode("probe", lean=True, context=pipeline.context)  # lean: nothing the takes cannot see
        heard = {topic: [] for topic in ("/pmv/residual", "/pmv/attitude")}
        for topic, messages in heard.items():
            listener.subscription(Vector3Stamped, topic, messages.append)
        pipeline.executor.add_node(listener)
        pipeline.nodes.append(listener)
        waits, wait = [0], pipeline.executor.wait_for_ready_callbacks

        def counted(*args, **kwargs):
            try:
                return wait(*args, **kwargs)
            except TimeoutException:
                waits[0] += 1
                raise

        pipeline.executor.wait_for_ready_callbacks = counted
        pipeline.step(ticks)
        statistics = pipeline.monitor.publish_statistics(pipeline.sensor.sim_time_s)
        return {"heard": {topic: [(m.header.stamp.sec, m.header.stamp.nanosec, m.vector.x, m.vector.y)
                                  for m in messages] for topic, messages in heard.items()},
                "residuals": pipeline.collector.residual_array(), "statistics": statistics, "waits": waits[0]}


def test_the_main_job_gives_the_same_messages_in_the_same_order_and_statistics_either_way():
    # The drain by takes and the collector's queued takes against the public fallback (rclpy's waits, one message
    # per subscription per wait): the same messages on each topic in the same order, the same residuals and
    # statistics bit for bit; the fallback only waits more.
    fenced, public = _main_job(True), _main_job(False)
    assert len(fenced["heard"]["/pmv/residual"]) >= 150 and len(fenced["heard"]["/pmv/attitude"]) == 200
    assert fenced["heard"] == public["heard"]
    np.testing.assert_array_equal(fenced["residuals"], public["residuals"])
    assert repr(fenced["statistics"]) == repr(public["statistics"])  # every float as its shortest exact repr
    assert public["waits"] >= 2 * 200 > fenced["waits"]


def _lean_graph(*names):
    context = rclpy.Context()
    rclpy.init(context=context)
    nodes = [PmvNode(name, lean=True, context=context) for name in names]
    executor = SingleThreadedExecutor(context=context)
    for node in nodes:
        executor.add_node(node)
    return context, nodes, executor


def _close(context, nodes, executor) -> None:
    executor.shutdown()
    for node in nodes:
        node.destroy_node()
    rclpy.shutdown(context=context)


def _fan_out(on: bool) -> tuple[list, list]:
    """Callbacks in the order a drain ran them, and the order of a wait (the executor's order of nodes is its
    own, run to run): one message fans out to three subscribers of two nodes."""
    context, (source, late, early), executor = _lean_graph("source", "late", "early")
    order = []
    try:
        outputs = {topic: source.publisher(Vector3Stamped, topic) for topic in ("/a", "/b", "/c")}

        def fan_out(message) -> None:
            order.append("source")
            for topic, copies in (("/c", 2), ("/a", 3), ("/b", 1)):
                for k in range(copies):
                    outputs[topic].publish(Vector3Stamped(vector=_vector(k)))

        for node, topic in ((late, "/c"), (early, "/b"), (early, "/a")):
            node.subscription(Vector3Stamped, topic, lambda m, topic=topic: order.append(f"{topic} {m.vector.x:g}"))
        source.subscription(Vector3Stamped, "/in", fan_out)
        source.publisher(Vector3Stamped, "/in").publish(Vector3Stamped())
        topics = [s.topic_name for node in executor.get_nodes() for s in node.subscriptions if s.topic_name != "/in"]
        copies = {"/a": 3, "/b": 1, "/c": 2}
        waits = [[f"{topic} {k}" for topic in topics if k < copies[topic]] for k in range(3)]  # one each a look
        with internals(on):
            assert drain(executor) == 7
    finally:
        _close(context, [source, late, early], executor)
    return order, ["source", *(entry for look in waits for entry in look)]


def _vector(x: float) -> Vector3:
    return Vector3(x=float(x))


def test_the_drain_runs_the_callbacks_in_the_executors_order_either_way():
    # rclpy defines the order: node by node in the executor's order, each node's subscriptions in theirs, one
    # message per subscription a look, each subscription's messages in publication order.
    for on in (True, False):
        order, expected = _fan_out(on)
        assert order == expected, on


def _taken_queued(on: bool) -> list:
    """Five messages queued on a TakingQueued subscription, drained by rclpy's waits: what it handed over."""
    context, (node,), executor = _lean_graph("taker")
    got = []
    try:
        subscription = taking_queued(lambda callback: node.subscription(Vector3Stamped, "/queued", callback),
                                     lambda message: got.append(message.vector.x), depth=100)
        assert isinstance(subscription.callback, TakingQueued) and subscription.callback.subscription is subscription
        out = node.publisher(Vector3Stamped, "/queued")
        for k in range(5):
            out.publish(Vector3Stamped(vector=_vector(k)))
        with internals(on):
            drain(executor, by_takes=False)  # a wait hands the first message out either way
    finally:
        _close(context, [node], executor)
    return got


def test_a_subscription_taking_what_is_queued_hands_over_the_same_messages_either_way():
    assert _taken_queued(True) == _taken_queued(False) == [0.0, 1.0, 2.0, 3.0, 4.0]


def test_a_clock_reading_is_rclpys_now_either_way():
    """On simulation time (a time source the test drives through rclpy's public TimeSource, 0 before the
    first /clock) and on the wall clock (between two ``now()`` readings): the same nanoseconds."""
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        source = TimeSource()
        source.ros_time_is_active = True
        simulated = PmvNode("simulated", context=context, time_source=source,
                            parameter_overrides=[Parameter("use_sim_time", value=True)])
        wall = PmvNode("wall", context=context)
        assert clock_now_s(simulated.get_clock()) == 0.0 == simulated.now_s()  # before the first /clock
        for on in (True, False):
            with internals(on):
                for t_s in (1.5, 1796421529.189710442, 7.0):
                    source.clock_callback(shim.write_clock(Clock(), t_s))
                    assert clock_now_s(simulated.get_clock()) == simulated.get_clock().now().nanoseconds * 1e-9
                before = wall.get_clock().now().nanoseconds * 1e-9
                reading = clock_now_s(wall.get_clock())
                after = wall.get_clock().now().nanoseconds * 1e-9
                assert before <= reading <= after and after - before < 1.0
        for node in (simulated, wall):
            node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def _star_tracker(context, overrides: dict):
    return StarTrackerNode(context=context, parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()])


def test_parameter_overrides_are_checked_before_rclpy_declares_them_and_by_rclpy_in_the_fallback():
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        with internals(True):  # an integer for a floating-point parameter is that number
            node = _star_tracker(context, {"frame_period_s": 2})
            assert node.get_parameter("frame_period_s").value == 2.0
            node.destroy_node()
            with pytest.raises(ParameterError, match="frame_period_s"):  # out of range: the parameter's own reason
                _star_tracker(context, {"frame_period_s": -1.0})
        with internals(False):
            node = _star_tracker(context, {"frame_period_s": 2.0})  # a good value goes through the same
            assert node.get_parameter("frame_period_s").value == 2.0
            node.destroy_node()
            for refused in (-1.0, 2):  # rclpy's own check: out of range, and the integer, refused with a reason
                with pytest.raises(ParameterError, match="frame_period_s"):
                    _star_tracker(context, {"frame_period_s": refused})
    finally:
        rclpy.shutdown(context=context)


def test_clock_messages_are_checked_before_rclpys_time_source_and_the_fallback_says_it_cannot(capfd):
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        nodes = {}
        for on in (True, False):
            with internals(on):
                nodes[on] = StarTrackerNode(context=context, namespace=f"/internals_{on}".lower(),
                                            parameter_overrides=[Parameter("use_sim_time", value=True)])
        tester = Node("clock_tester", context=context)
        executor = SingleThreadedExecutor(context=context)
        for node in (*nodes.values(), tester):
            executor.add_node(node)
        clock = tester.create_publisher(Clock, "/clock", 10)
        for t_s in (5.0, 100_000.0):  # a forged jump ahead after a good time
            message = Clock()
            message.clock.sec, message.clock.nanosec = divmod(int(round(t_s * 1e9)), 1_000_000_000)
            clock.publish(message)
            for _ in range(20):
                executor.spin_once(timeout_sec=0.02)
        checked, unchecked = nodes[True], nodes[False]
        assert checked.now_s() == 5.0 and any(key.startswith("rejected_clock_")
                                              for key in checked.input_source_counters())
        assert unchecked.now_s() == 100_000.0  # rclpy's time source took the forged time
        assert not any(key.startswith("rejected_clock_") for key in unchecked.input_source_counters())
        executor.shutdown()
        for node in (*nodes.values(), tester):
            node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
    said = capfd.readouterr().err
    assert said.count("/clock is not checked") == 1 and f"written for rclpy {WRITTEN_FOR}" in said, said
