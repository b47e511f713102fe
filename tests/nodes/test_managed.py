"""Managed (lifecycle) nodes: configure / activate / deactivate / cleanup through the lifecycle services,
what each state publishes, and a configure that fails (a bad correction file) with its reason.

The contract is the behaviour table of :mod:`pmv_ros.nodes.managed`. One point follows rclpy 7.1 rather than the
table of earlier versions: a transition the current state does not have gets no answer (rclpy raises its
refusal out of the change_state service; the console script logs it and goes on), where it was answered
``success = false``."""

from __future__ import annotations

import statistics
import time

import pytest
from rclpy.impl.implementation_singleton import rclpy_implementation
from geometry_msgs.msg import Vector3Stamped
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import String
from rcl_interfaces.msg import Log
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.parameter import Parameter
from rclpy.parameter import parameter_value_to_python as parameter_value_from

import pmv_msgs_shim as shim
from pmv_ros.nodes.base import PmvNode
from pmv_ros.nodes.error_monitor_node import ErrorMonitorNode, ManagedErrorMonitorNode
from pmv_ros.nodes.launch import _refused_transition
from pmv_ros.nodes.managed import PARKED_S, ManagedNode, managed_requested
from pmv_ros.nodes.sensor_node import ManagedSensorNode, SensorNode
from pmv_ros.nodes.star_tracker_node import ManagedStarTrackerNode, StarTrackerNode

managed_sensor = ManagedSensorNode


def remote_parameter(h, node: str, name: str):
    """A parameter's value read through the node's own parameter service, as ``ros2 param get`` reads it."""
    client = h.tester.create_client(GetParameters, f"/{node}/get_parameters")
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(GetParameters.Request(names=[name]))
    h.executor.spin_until_future_complete(future, timeout_sec=5.0)
    assert future.done()
    return parameter_value_from(future.result().values[0])


class Lifecycle:
    """The lifecycle services of a node (/sensor_node), called from the harness's tester node."""

    def __init__(self, h, name: str = "sensor_node"):
        self.h = h
        self.change = h.tester.create_client(ChangeState, f"/{name}/change_state")
        self.get = h.tester.create_client(GetState, f"/{name}/get_state")
        assert self.change.wait_for_service(timeout_sec=5.0) and self.get.wait_for_service(timeout_sec=5.0)

    def _call(self, client, request):
        future = client.call_async(request)
        self.h.executor.spin_until_future_complete(future, timeout_sec=5.0)
        assert future.done()
        return future.result()

    def state(self) -> str:
        return self._call(self.get, GetState.Request()).current_state.label

    def transition(self, transition_id: int) -> bool:
        return self._call(self.change, ChangeState.Request(transition=Transition(id=transition_id))).success

    def transition_by_label(self, label: str) -> bool:
        return self._call(self.change, ChangeState.Request(transition=Transition(label=label))).success

    def refused_unanswered(self, transition_id: int) -> None:
        """A transition the state does not have: rclpy's state machine refuses it and raises the refusal out of
        the service (the executor passes it on, :func:`pmv_ros.nodes.launch.run_node` logs it); no answer."""
        future = self.change.call_async(ChangeState.Request(transition=Transition(id=transition_id)))
        with pytest.raises(rclpy_implementation.RCLError) as raised:
            self.h.executor.spin_until_future_complete(future, timeout_sec=5.0)
        assert _refused_transition(raised.value), raised.value
        self.spin(0.2)
        assert not future.done()
        future.cancel()

    def spin(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.h.executor.spin_once(timeout_sec=0.02)

    def spin_until(self, condition, seconds: float, what: str) -> None:
        deadline = time.monotonic() + seconds
        while not condition():
            assert time.monotonic() < deadline, f"{what}: not within {seconds:g} s"
            self.spin(0.02)


def test_each_lifecycle_state_publishes_what_it_should(harness):
    h = harness(managed_sensor, {"sensor.rate_hz": 20.0})
    attitude = h.record(Vector3Stamped, "/pmv/attitude")
    lifecycle = Lifecycle(h)
    assert lifecycle.state() == "unconfigured" and not h.node.configured
    assert not h.node.has_parameter("sensor.rate_hz")  # nothing declared, no file read before configure
    lifecycle.spin(0.4)
    assert attitude == []  # unconfigured: no models, no publishers

    assert lifecycle.transition(Transition.TRANSITION_CONFIGURE)
    assert lifecycle.state() == "inactive" and h.node.configured and isinstance(h.node, SensorNode)
    assert h.node.get_parameter("sensor.rate_hz").value == 20.0  # the overrides reached the node
    # One node of the name in the graph, with the lifecycle services and the parameters on its own services.
    assert h.tester.get_node_names().count("sensor_node") == 1
    services = dict(h.tester.get_service_names_and_types_by_node("sensor_node", "/"))
    assert "/sensor_node/change_state" in services and "/sensor_node/get_parameters" in services
    assert remote_parameter(h, "sensor_node", "sensor.rate_hz") == 20.0
    lifecycle.spin(0.5)
    assert attitude == []  # configured: models built, nothing published

    assert lifecycle.transition(Transition.TRANSITION_ACTIVATE)
    assert lifecycle.state() == "active"
    lifecycle.spin(0.6)
    assert len(attitude) >= 5  # 20 Hz for 0.6 s

    assert lifecycle.transition(Transition.TRANSITION_DEACTIVATE)
    assert lifecycle.state() == "inactive"
    lifecycle.spin(0.1)  # what was on the way before the transition
    count = len(attitude)
    lifecycle.spin(0.5)
    assert len(attitude) == count  # inactive: silent

    assert lifecycle.transition(Transition.TRANSITION_ACTIVATE)  # and back again
    lifecycle.spin(0.5)
    assert len(attitude) >= count + 4
    assert lifecycle.transition(Transition.TRANSITION_DEACTIVATE)

    assert lifecycle.transition(Transition.TRANSITION_CLEANUP)
    assert lifecycle.state() == "unconfigured" and not h.node.configured
    lifecycle.spin_until(lambda: all(  # what configure made is gone (its endpoints after PARKED_S)
        topic in ("/rosout", "/parameter_events", "/sensor_node/transition_event")
        for topic, _ in h.tester.get_publisher_names_and_types_by_node("sensor_node", "/")),
        PARKED_S + 10.0, "the configured publishers gone from the graph")
    lifecycle.spin(0.2)
    count = len(attitude)
    lifecycle.spin(0.4)
    assert len(attitude) == count
    assert h.tester.get_node_names().count("sensor_node") == 1  # the lifecycle node itself stays, for a new configure
    assert lifecycle.transition(Transition.TRANSITION_CONFIGURE) and lifecycle.state() == "inactive"


def test_a_bad_correction_file_leaves_the_node_unconfigured_with_the_reason(harness, tmp_path):
    table = tmp_path / "table.csv"
    table.write_text("del_arcmin;pop_arcmin\nsixty;one\n")
    # A name of its own: rcl keeps one /rosout publisher per logger name for the whole process, and a sensor_node
    # of an earlier test in this process can still hold that name's entry (the logs then go nowhere).
    h = harness(ManagedSensorNode, {"sensor.correction": str(table)}, node_name="bad_correction_sensor")
    logs = h.record(Log, "/rosout")
    attitude = h.record(Vector3Stamped, "/pmv/attitude")
    lifecycle = Lifecycle(h, "bad_correction_sensor")
    assert not lifecycle.transition(Transition.TRANSITION_CONFIGURE)
    assert lifecycle.state() == "unconfigured" and not h.node.configured
    assert "sensor.correction" in h.node.configure_error
    lifecycle.spin(0.3)
    reasons = [log.msg for log in logs if log.name == "bad_correction_sensor" and log.level == Log.ERROR]
    assert len(reasons) == 1 and "configure failed" in reasons[0] and "sensor.correction" in reasons[0]
    lifecycle.refused_unanswered(Transition.TRANSITION_ACTIVATE)  # no activation from unconfigured: refused
    lifecycle.refused_unanswered(Transition.TRANSITION_DEACTIVATE)
    assert not lifecycle.transition_by_label("activate")  # asked by its label, rclpy answers the refusal
    assert lifecycle.state() == "unconfigured"  # and the node keeps serving
    lifecycle.spin(0.3)
    assert attitude == [] and lifecycle.state() == "unconfigured"


def test_the_managed_switch_is_read_before_the_ros_arguments_only():
    assert managed_requested(["--managed"])
    assert managed_requested(["--managed", "--ros-args", "-p", "sensor.rate_hz:=5.0"])
    assert not managed_requested([])
    assert not managed_requested(["--ros-args", "-r", "__node:=--managed"])


@pytest.mark.parametrize("managed_class, node_class, name", [
    (ManagedStarTrackerNode, StarTrackerNode, "star_tracker_node"),
    (ManagedErrorMonitorNode, ErrorMonitorNode, "error_monitor_node")])
def test_the_other_nodes_go_through_the_lifecycle_too(harness, managed_class, node_class, name):
    h = harness(managed_class, {})
    lifecycle = Lifecycle(h, name)
    for transition, state in ((Transition.TRANSITION_CONFIGURE, "inactive"), (Transition.TRANSITION_ACTIVATE, "active"),
                              (Transition.TRANSITION_DEACTIVATE, "inactive"),
                              (Transition.TRANSITION_CLEANUP, "unconfigured")):
        assert lifecycle.transition(transition) and lifecycle.state() == state
        assert isinstance(h.node, node_class) and h.node.configured == (state != "unconfigured")
        assert h.tester.get_node_names().count(name) == 1
        lifecycle.spin(0.05)
    assert lifecycle.transition(Transition.TRANSITION_UNCONFIGURED_SHUTDOWN) and lifecycle.state() == "finalized"


class _Announcer(PmvNode):
    """A node that publishes as it is built: once latched (transient local, as /tf_static) and once volatile."""

    NODE_NAME = "announcer"

    def build(self) -> None:
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.make_publisher(String, "latched", latched).publish(String(data="mounting"))
        self.publisher(String, "volatile").publish(String(data="early"))


class _ManagedAnnouncer(ManagedNode, _Announcer):
    pass


def test_what_configure_publishes_waits_for_activation_and_a_latched_message_is_kept(harness):
    h = harness(_ManagedAnnouncer, {})
    latched = []
    h.tester.create_subscription(String, "/latched", latched.append,
                                 QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    volatile = h.record(String, "/volatile")
    lifecycle = Lifecycle(h, "announcer")
    assert lifecycle.transition(Transition.TRANSITION_CONFIGURE)
    lifecycle.spin(0.3)
    assert latched == [] and volatile == []  # inactive: nothing goes out
    assert lifecycle.transition(Transition.TRANSITION_ACTIVATE)
    lifecycle.spin(0.3)
    assert [m.data for m in latched] == ["mounting"]  # the latched message, at activation, once
    assert volatile == []  # a volatile one made while inactive is dropped


def test_a_rate_change_rebuilds_a_timer_the_lifecycle_still_holds(harness):
    """sensor.rate_hz changed on a managed node makes a new timer: it runs while active, stops at deactivate,
    waits while inactive, and cleanup destroys it with the rest.

    Which timer runs shows in the samples' stamps (a rate is 1 / their median spacing), not in a count per
    second of wall time, which a busy machine lowers."""
    h = harness(managed_sensor, {"sensor.rate_hz": 20.0})
    attitude = h.record(Vector3Stamped, "/pmv/attitude")
    lifecycle = Lifecycle(h)

    def rate_hz_of_the_next(count: int) -> float:
        first = len(attitude)
        deadline = time.monotonic() + 30.0
        while len(attitude) < first + count:
            assert time.monotonic() < deadline, f"{len(attitude) - first} of {count} samples in 30 s"
            lifecycle.spin(0.05)
        stamps = [shim.time_from_msg(m.header.stamp) for m in attitude[first + 1:first + count]]
        return 1.0 / statistics.median(b - a for a, b in zip(stamps, stamps[1:]))

    timers_unconfigured = len(list(h.node.timers))
    assert lifecycle.transition(Transition.TRANSITION_CONFIGURE)
    assert lifecycle.transition(Transition.TRANSITION_ACTIVATE)
    assert rate_hz_of_the_next(8) == pytest.approx(20.0, rel=0.05)
    assert h.node.set_parameters([Parameter("sensor.rate_hz", value=40.0)])[0].successful
    lifecycle.spin(0.1)
    assert rate_hz_of_the_next(12) == pytest.approx(40.0, rel=0.05)
    assert lifecycle.transition(Transition.TRANSITION_DEACTIVATE)
    assert h.node.set_parameters([Parameter("sensor.rate_hz", value=10.0)])[0].successful  # while inactive
    lifecycle.spin(0.1)
    count = len(attitude)
    lifecycle.spin(0.5)
    assert len(attitude) == count  # the timer made while inactive waits
    assert lifecycle.transition(Transition.TRANSITION_ACTIVATE)
    assert rate_hz_of_the_next(6) == pytest.approx(10.0, rel=0.05)
    assert lifecycle.transition(Transition.TRANSITION_DEACTIVATE)
    assert lifecycle.transition(Transition.TRANSITION_CLEANUP)
    assert len(list(h.node.timers)) == timers_unconfigured  # every timer configure and the rate changes made
    assert lifecycle.transition(Transition.TRANSITION_CONFIGURE)
    assert lifecycle.transition(Transition.TRANSITION_ACTIVATE)
    assert rate_hz_of_the_next(6) == pytest.approx(10.0, rel=0.05)


def test_an_unconfigured_node_answers_its_parameter_services_and_stops_cleanly(harness):
    h = harness(managed_sensor, {})
    client = h.tester.create_client(SetParameters, "/sensor_node/set_parameters")
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(SetParameters.Request(parameters=[
        Parameter("sensor.rate_hz", value=5.0).to_parameter_msg()]))
    h.executor.spin_until_future_complete(future, timeout_sec=5.0)
    assert future.done() and not future.result().results[0].successful  # not declared before configure
    assert Lifecycle(h).state() == "unconfigured"  # the node kept serving (the harness destroys it after)


def test_an_unexpected_error_in_configure_releases_what_it_made(harness, monkeypatch):
    def broken(self, *args, **kwargs):
        raise TypeError("a defect")

    monkeypatch.setattr(SensorNode, "_start_timer", broken)  # fails after the publishers and subscriptions exist
    h = harness(managed_sensor, {})
    lifecycle = Lifecycle(h)
    before = {kind: len(list(getattr(h.node, kind))) for kind in ("publishers", "subscriptions", "timers")}
    assert not lifecycle.transition(Transition.TRANSITION_CONFIGURE)
    assert lifecycle.state() == "unconfigured" and h.node.configure_error == "TypeError: a defect"
    assert {kind: len(list(getattr(h.node, kind))) for kind in before} == before


class _Echo(PmvNode):
    """A node that echoes what it hears on /echo_in to /echo_out and keeps it (a new list at each configure)."""

    NODE_NAME = "echo"

    def build(self) -> None:
        self.heard = []
        out = self.publisher(String, "echo_out")
        self.subscription(String, "echo_in", lambda message: (self.heard.append(message.data), out.publish(message)))


class _ManagedEcho(ManagedNode, _Echo):
    pass


def test_a_configure_soon_after_cleanup_takes_back_the_endpoints_which_go_after_a_while(harness):
    """A neighbour flapping cleanup and configure does not make the node destroy and create DDS endpoints at its
    rate (Fast DDS once crashed under that, README "Managed nodes"): cleanup parks the publishers and
    subscriptions, silent; a configure within PARKED_S takes them back and wires them to its own callbacks; after
    PARKED_S unconfigured they are destroyed, and shutdown destroys them at once."""
    h = harness(_ManagedEcho, {})
    echoed = h.record(String, "/echo_out")
    send = h.tester.create_publisher(String, "/echo_in", 10)
    lifecycle = Lifecycle(h, "echo")

    def made() -> list:
        return h.node.configuration_endpoints()

    def echo(text: str) -> None:
        send.publish(String(data=text))
        deadline = time.monotonic() + 5.0
        while text not in [m.data for m in echoed]:
            assert time.monotonic() < deadline, f"{text!r} not echoed within 5 s"
            lifecycle.spin(0.02)

    assert (lifecycle.transition(Transition.TRANSITION_CONFIGURE)
            and lifecycle.transition(Transition.TRANSITION_ACTIVATE))
    first = made()
    assert len(first) == 2
    echo("a")
    for _ in range(5):  # flapping: the same two endpoints throughout
        for transition in (Transition.TRANSITION_DEACTIVATE, Transition.TRANSITION_CLEANUP,
                           Transition.TRANSITION_CONFIGURE, Transition.TRANSITION_ACTIVATE):
            assert lifecycle.transition(transition), transition
            assert all(a is b for a, b in zip(made(), first)) and len(made()) == 2, transition
    assert h.node.heard == []  # the new configuration's list: the subscription calls the new callback
    echo("b")
    assert h.node.heard == ["b"]

    assert (lifecycle.transition(Transition.TRANSITION_DEACTIVATE)
            and lifecycle.transition(Transition.TRANSITION_CLEANUP))
    send.publish(String(data="c"))  # parked: silent, heard by nobody
    began = time.monotonic()
    lifecycle.spin_until(lambda: made() == [], PARKED_S + 10.0, "the parked endpoints destroyed")
    assert time.monotonic() - began > 0.8 * PARKED_S  # not before their time (less the spin's own step)
    lifecycle.spin_until(lambda: "/echo_out" not in dict(h.tester.get_publisher_names_and_types_by_node("echo", "/")),
                         10.0, "/echo_out gone from the graph")
    assert "c" not in [m.data for m in echoed] and h.node.heard == ["b"]
    assert lifecycle.transition(Transition.TRANSITION_CONFIGURE)  # after the park: new endpoints
    assert len(made()) == 2 and not any(a is b for a in made() for b in first)
    assert lifecycle.transition(Transition.TRANSITION_CLEANUP)
    assert len(made()) == 2  # parked
    assert lifecycle.transition(Transition.TRANSITION_UNCONFIGURED_SHUTDOWN) and made() == []  # gone at once
