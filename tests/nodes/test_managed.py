"""Managed (lifecycle) nodes: configure / activate / deactivate / cleanup through the lifecycle services,
what each state publishes, and a configure that fails (a bad correction file) with its reason."""

from __future__ import annotations

import gc
import time

import pytest
from geometry_msgs.msg import Vector3Stamped
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rcl_interfaces.msg import Log

from pmv_ros.nodes.managed import ManagedNode, managed_requested
from pmv_ros.nodes.error_monitor_node import ErrorMonitorNode
from pmv_ros.nodes.sensor_node import SensorNode
from pmv_ros.nodes.star_tracker_node import StarTrackerNode


def managed_sensor(**arguments):
    return ManagedNode(SensorNode, "sensor_node", **arguments)


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

    def spin(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.h.executor.spin_once(timeout_sec=0.02)


def test_each_lifecycle_state_publishes_what_it_should(harness):
    h = harness(managed_sensor, {"sensor.rate_hz": 20.0})
    attitude = h.record(Vector3Stamped, "/pmv/attitude")
    lifecycle = Lifecycle(h)
    assert lifecycle.state() == "unconfigured" and h.node.inner is None
    lifecycle.spin(0.4)
    assert attitude == []  # unconfigured: no models, no publishers

    assert lifecycle.transition(Transition.TRANSITION_CONFIGURE)
    assert lifecycle.state() == "inactive" and isinstance(h.node.inner, SensorNode)
    assert h.node.inner.get_parameter("sensor.rate_hz").value == 20.0  # the overrides reached the plain node
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
    assert lifecycle.state() == "unconfigured" and h.node.inner is None  # the plain node is gone
    lifecycle.spin(0.2)
    count = len(attitude)
    lifecycle.spin(0.4)
    assert len(attitude) == count
    assert h.tester.get_node_names().count("sensor_node") == 1  # the lifecycle node itself stays, for a new configure
    assert lifecycle.transition(Transition.TRANSITION_CONFIGURE) and lifecycle.state() == "inactive"


def test_a_bad_correction_file_leaves_the_node_unconfigured_with_the_reason(harness, tmp_path):
    table = tmp_path / "table.csv"
    table.write_text("del_arcmin;pop_arcmin\nsixty;one\n")
    # A sensor_node an earlier test of this process left to the garbage collector shares its /rosout publisher
    # with this one and, destroyed in the middle of this test, takes it away: destroy such nodes first.
    gc.collect()
    h = harness(managed_sensor, {"sensor.correction": str(table)})
    logs = h.record(Log, "/rosout")
    attitude = h.record(Vector3Stamped, "/pmv/attitude")
    lifecycle = Lifecycle(h)
    assert not lifecycle.transition(Transition.TRANSITION_CONFIGURE)
    assert lifecycle.state() == "unconfigured" and h.node.inner is None
    assert "sensor.correction" in h.node.configure_error
    lifecycle.spin(0.3)
    reasons = [log.msg for log in logs if log.name == "sensor_node" and log.level == Log.ERROR]
    assert len(reasons) == 1 and "configure failed" in reasons[0] and "sensor.correction" in reasons[0]
    assert not lifecycle.transition(Transition.TRANSITION_ACTIVATE)  # no activation from unconfigured: refused
    assert not lifecycle.transition(Transition.TRANSITION_DEACTIVATE)  # and the node keeps serving
    lifecycle.spin(0.3)
    assert attitude == [] and lifecycle.state() == "unconfigured"


def test_the_managed_switch_is_read_before_the_ros_arguments_only():
    assert managed_requested(["--managed"])
    assert managed_requested(["--managed", "--ros-args", "-p", "sensor.rate_hz:=5.0"])
    assert not managed_requested([])
    assert not managed_requested(["--ros-args", "-r", "__node:=--managed"])


@pytest.mark.parametrize("node_class, name", [(StarTrackerNode, "star_tracker_node"),
                                              (ErrorMonitorNode, "error_monitor_node")])
def test_the_other_nodes_go_through_the_lifecycle_too(harness, node_class, name):
    h = harness(lambda **arguments: ManagedNode(node_class, name, **arguments), {})
    lifecycle = Lifecycle(h, name)
    for transition, state in ((Transition.TRANSITION_CONFIGURE, "inactive"), (Transition.TRANSITION_ACTIVATE, "active"),
                              (Transition.TRANSITION_DEACTIVATE, "inactive"),
                              (Transition.TRANSITION_CLEANUP, "unconfigured")):
        assert lifecycle.transition(transition) and lifecycle.state() == state
        assert isinstance(h.node.inner, node_class) == (state != "unconfigured")
        lifecycle.spin(0.05)
    assert lifecycle.transition(Transition.TRANSITION_UNCONFIGURED_SHUTDOWN) and lifecycle.state() == "finalized"
