"""One spacecraft of several in a ROS graph, in-process: namespaces, frames, statuses,
inputs checked against their frame.

interfaces.md "Topics" and "Frames": every topic but /clock, /diagnostics,
/tf and /tf_static is a relative name, so two spacecraft in namespaces run
side by side without mixing; their frames carry a prefix; /diagnostics
statuses carry the node's fully qualified name; an input stamped in another
frame than its stream's (an inertial quaternion on /attitude/truth) is
refused and counted.
"""

from __future__ import annotations

import math
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.time_source import TimeSource
from rosgraph_msgs.msg import Clock

import pmv_msgs_shim as shim
from pmv_ros.nodes.error_monitor_node import ErrorMonitorNode
from pmv_ros.nodes.pipeline import drain
from pmv_ros.nodes.sensor_node import SensorNode
from pmv_ros.nodes.star_tracker_node import StarTrackerNode
from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.orbit.two_body import CircularOrbit

#: Topics every spacecraft shares; everything else of ours is under its namespace.
SHARED = {"/clock", "/diagnostics", "/tf", "/tf_static"}
#: rclpy's own topics.
ROS_OWN = {"/parameter_events", "/rosout"}
#: A spacecraft's own topics, relative to its namespace.
OWN = {"pmv/horizon_crossings", "pmv/attitude", "pmv/attitude_uncorrected", "pmv/attitude_imu", "orbit/odometry",
       "attitude/truth", "star_tracker/attitude", "star_tracker/frame_status", "pmv/residual", "pmv/error_statistics",
       "pmv/residual_mean", "pmv/residual_sigma", "pmv/residual_limit"}

#: Quick sensors: the geometric horizon, one radiance everywhere.
QUICK = {"sensor.detector": "ideal", "radiance.source": "uniform", "sensor.bright_body_exclusion_deg": 0.0}


def _overrides(values: dict) -> list:
    return [Parameter(name, value=value) for name, value in values.items()]


def test_two_spacecraft_in_namespaces_share_only_clock_diagnostics_and_tf(capfd):
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    nodes, sensors = [], {}
    # As the in-process pipeline: the sensors step their own fast time; the others follow it through a time source.
    source = TimeSource()
    source.ros_time_is_active = True
    clock = Clock()
    try:
        for namespace, roll_arcmin in (("sat1", 6.0), ("sat2", -9.0)):
            frames = {"frames.prefix": f"{namespace}/"}
            sensors[namespace] = SensorNode(
                context=context, namespace=namespace, external_drive=True, publish_tf=False,
                parameter_overrides=_overrides({**QUICK, **frames, "sim.fast_time": True,
                                                "attitude.roll_offset_arcmin": roll_arcmin}))
            nodes += [sensors[namespace]]
            for node_class in (StarTrackerNode, ErrorMonitorNode):
                nodes.append(node_class(context=context, namespace=namespace, time_source=source,
                                        parameter_overrides=_overrides({**frames, "use_sim_time": True})))
        tester = Node("tester", context=context)
        nodes.append(tester)
        for node in nodes:
            executor.add_node(node)
        got = {}
        for topic, kind in (("/sat1/pmv/attitude", Vector3Stamped), ("/sat1/orbit/odometry", Odometry),
                            ("/sat1/pmv/residual", Vector3Stamped), ("/sat2/pmv/residual", Vector3Stamped),
                            ("/sat2/attitude/truth", QuaternionStamped), ("/diagnostics", DiagnosticArray),
                            ("/sat1/pmv/error_statistics", DiagnosticArray),
                            ("/sat1/pmv/residual_sigma", Vector3Stamped), ("/sat2/pmv/residual_mean", Vector3Stamped)):
            got[topic] = []
            tester.create_subscription(kind, topic, got[topic].append, 1000)
        drain(executor)
        for _ in range(120):  # 12 s of simulation time at 10 Hz: the monitors have aligned samples
            for sensor in sensors.values():
                sensor.step()
            source.clock_callback(shim.write_clock(clock, sensors["sat1"].sim_time_s))
            drain(executor)
        topics = {name for name, _ in tester.get_topic_names_and_types()}
    finally:
        executor.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.shutdown(context=context)

    expected = {f"/{namespace}/{topic}" for namespace in ("sat1", "sat2") for topic in OWN}
    assert expected <= topics, expected - topics
    assert topics - expected - ROS_OWN <= SHARED, topics - expected - ROS_OWN
    assert "/pmv/attitude" not in topics and "/attitude/truth" not in topics
    # Frames with the spacecraft's prefix; the inertial frame is shared.
    assert {m.header.frame_id for m in got["/sat1/pmv/attitude"]} == {"sat1/pmv_sensor"}
    assert {(m.header.frame_id, m.child_frame_id) for m in got["/sat1/orbit/odometry"]} == {("eci", "sat1/orbital")}
    assert {m.header.frame_id for m in got["/sat2/attitude/truth"]} == {"sat2/orbital"}
    for namespace, topic in (("sat1", "pmv/residual"), ("sat2", "pmv/residual"), ("sat1", "pmv/residual_sigma"),
                             ("sat2", "pmv/residual_mean")):
        frames = {m.header.frame_id for m in got[f"/{namespace}/{topic}"]}
        assert frames == {f"{namespace}/pmv_sensor"}, (namespace, topic, frames)
    # Each monitor measured its own spacecraft: the body roll cancels (sensor and star tracker both see it).
    for namespace in ("sat1", "sat2"):
        residual = np.array([m.vector.x for m in got[f"/{namespace}/pmv/residual"]]) / ARCMIN_RAD
        assert residual.size > 50 and np.all(np.abs(residual) < 2.0), (namespace, residual)
    statistics = shim.error_statistics_from_msg(got["/sat1/pmv/error_statistics"][-1])
    assert statistics.channels[0].count > 50 and not any(k.startswith("other_source") for k in statistics.counters)
    # /diagnostics: every status says whose it is; no source lock complains inside either namespace.
    statuses = [s for m in got["/diagnostics"] for s in shim.health_from_msg(m).statuses]
    names = {s.name for s in statuses}
    for namespace in ("sat1", "sat2"):
        assert {f"pmv_ros/{namespace}/sensor_node: horizon", f"pmv_ros/{namespace}/sensor_node: orbit",
                f"pmv_ros/{namespace}/star_tracker_node", f"pmv_ros/{namespace}/error_monitor_node"} <= names, names
    assert {s.hardware_id for s in statuses if s.name == "pmv_ros/sat2/star_tracker_node"} == \
        {"star_tracker:/sat2/star_tracker_node"}
    assert {s.hardware_id for s in statuses if s.name.startswith("pmv_ros/sat1/sensor_node")} == \
        {"pmv:/sat1/sensor_node"}
    errors = [(s.name, s.message) for s in statuses if s.level == shim.Level.ERROR]
    assert not errors, errors
    # Each orbit status is found by its sensor's name.
    orbit = [shim.find_orbit_elements(m, "pmv_ros/sat2/sensor_node: orbit") for m in got["/diagnostics"]]
    assert any(elements is not None for elements in orbit)
    assert "publishers of" not in capfd.readouterr().err


# ------------------------------------------------------------------------ inputs checked against their frame

def _inertial(message: QuaternionStamped) -> QuaternionStamped:
    """The same message stamped in the inertial frame, with an inertial attitude 40° away (a stack's mistake)."""
    q = quaternion_from_roll_pitch_yaw(math.radians(40.0), math.radians(-20.0), 0.0)
    return shim.write_attitude_quaternion(QuaternionStamped(), shim.time_from_msg(message.header.stamp),
                                          shim.ECI_FRAME, q)


def _statuses(messages, name):
    return [s for m in messages for s in shim.health_from_msg(m).statuses if s.name == name]


def test_an_inertial_quaternion_on_attitude_truth_is_refused_and_counted_by_the_star_tracker(harness, capfd):
    outputs = []
    for mistaken in (False, True):
        h = harness(StarTrackerNode, {"frame_period_s": 0.5, "processing_s": 0.25, "ideal": True})
        measured = h.record(QuaternionStamped, "/star_tracker/attitude")
        diagnostics = h.record(DiagnosticArray, "/diagnostics")
        truth = h.publisher(QuaternionStamped, "/attitude/truth")
        q = quaternion_from_roll_pitch_yaw(1e-3, -2e-3)
        start = h.node.get_clock().now().nanoseconds * 1e-9 - 60.0
        for k in range(1, 201):
            message = shim.write_attitude_quaternion(QuaternionStamped(), start + 0.1 * k, shim.ORBITAL_FRAME, q)
            truth.publish(_inertial(message) if mistaken and k % 10 == 3 else message)
            h.drain()
        outputs.append(np.array([[m.quaternion.x, m.quaternion.y, m.quaternion.z, m.quaternion.w] for m in measured]))
    clean, refused = outputs
    # The refused messages leave gaps of 0.2 s in a 10 Hz stream of one attitude: the frames measure that attitude
    # with the same noise draws. (The frame grid starts with the node clock: the two runs' last frame may differ.)
    frames = min(len(clean), len(refused))
    assert frames > 30
    np.testing.assert_array_equal(refused[:frames], clean[:frames])
    assert h.node.counters["rejected_truth_wrong_frame"] == 20
    report = _statuses(diagnostics, "pmv_ros/star_tracker_node")
    # /diagnostics goes out once per second of truth time: its last report has all but the very last refusal.
    assert report and int(dict(report[-1].values)["rejected_truth_wrong_frame"]) >= 19
    assert any("rejected /attitude/truth messages" in s.message for s in report)
    # Said once on the log (/diagnostics names it while every message is refused: tests/runtime).
    log = capfd.readouterr().err
    assert log.count("true attitude refused: expected orbital, got eci") == 1, log


def test_a_following_sensor_refuses_truth_in_another_frame(harness):
    outputs = []
    for mistaken in (False, True):
        h = harness(SensorNode, {**QUICK, "attitude.source": "follow", "sim.fast_time": False, "sensor.rate_hz": 1.0,
                                 "use_sim_time": True, "diagnostics_period_s": 0.1})
        attitude = h.record(Vector3Stamped, "/pmv/attitude")
        diagnostics = h.record(DiagnosticArray, "/diagnostics")
        clock, truth = h.publisher(Clock, "/clock"), h.publisher(QuaternionStamped, "/attitude/truth")
        q = quaternion_from_roll_pitch_yaw(10 * ARCMIN_RAD, -4 * ARCMIN_RAD, 0.0)
        for k in range(1, 41):
            t = 100.0 + 0.25 * k
            message = shim.write_attitude_quaternion(QuaternionStamped(), t, shim.ORBITAL_FRAME, q)
            truth.publish(message)
            if mistaken and k % 4 == 1:  # the inertial attitude 0.1 s later would be followed if taken
                inertial = _inertial(message)
                shim.write_stamp(inertial.header.stamp, t + 0.1)
                truth.publish(inertial)
            h.drain()
            clock.publish(shim.write_clock(Clock(), t))
            h.drain()
        outputs.append(np.array([[shim.time_from_msg(m.header.stamp), m.vector.x, m.vector.y] for m in attitude]))
    clean, refused = outputs
    assert clean.shape[0] >= 8
    np.testing.assert_array_equal(refused, clean)
    values = dict(_statuses(diagnostics, "pmv_ros/sensor_node: horizon")[-1].values)
    assert int(values["rejected_truth_wrong_frame"]) == 10, values


def test_the_monitor_refuses_odometry_truth_and_angles_in_other_frames(harness):
    runs = []
    for mistaken in (False, True):
        h = harness(ErrorMonitorNode, {"max_truth_wait_s": 3600.0})
        diagnostics = h.record(DiagnosticArray, "/diagnostics")
        sensor = h.publisher(Vector3Stamped, "/pmv/attitude")
        truth = h.publisher(QuaternionStamped, "/star_tracker/attitude")
        odometry = h.publisher(Odometry, "/orbit/odometry")
        orbit = CircularOrbit(500e3, math.radians(74.5))
        rng = np.random.default_rng(4)
        start = h.node.get_clock().now().nanoseconds * 1e-9 - 40.0
        q = quaternion_from_roll_pitch_yaw(2 * ARCMIN_RAD, -1 * ARCMIN_RAD)
        for k in range(1, 301):
            t = start + 0.1 * k
            r, v = orbit.state_eci(t - start)
            odometry.publish(shim.write_orbit_state(Odometry(), t, shim.ECI_FRAME, shim.ORBITAL_FRAME, r, v))
            if mistaken and k % 30 == 0:  # ECF-stamped odometry 1 km off, and one with an orbital pose frame
                odometry.publish(shim.write_orbit_state(Odometry(), t + 0.05, "ecef", shim.ORBITAL_FRAME,
                                                        np.asarray(r) + 1e3, v))
                odometry.publish(shim.write_orbit_state(Odometry(), t + 0.06, shim.ECI_FRAME, "orbital_2", r, v))
            if k % 5 == 0:
                truth.publish(shim.write_attitude_quaternion(QuaternionStamped(), t, shim.ORBITAL_FRAME, q))
                if mistaken:
                    truth.publish(_inertial(shim.write_attitude_quaternion(
                        QuaternionStamped(), t + 0.05, shim.ORBITAL_FRAME, q)))
            sensor.publish(shim.write_attitude_angles(
                Vector3Stamped(), t, shim.SENSOR_FRAME, (2 + 0.3 * rng.standard_normal()) * ARCMIN_RAD,
                (-1 + 0.3 * rng.standard_normal()) * ARCMIN_RAD))
            if mistaken and k % 50 == 0:  # angles of some other instrument's frame
                sensor.publish(shim.write_attitude_angles(Vector3Stamped(), t + 0.05, "base_link", 0.1, 0.1))
            h.drain()
        statistics = h.node.publish_statistics(start + 31.0)
        diagnostics.clear()  # a report from its 1 Hz timer after the whole stream (one may have come mid-stream)
        deadline = time.monotonic() + 3.0
        while time.monotonic() < deadline and not _statuses(diagnostics, "pmv_ros/error_monitor_node"):
            h.executor.spin_once(timeout_sec=0.1)
        runs.append((statistics, _statuses(diagnostics, "pmv_ros/error_monitor_node")))
    (clean, _), (refused, report) = runs
    for a, b in zip(clean.channels, refused.channels):
        assert (a.count, a.mean_rad, a.sigma_rad) == (b.count, b.mean_rad, b.sigma_rad)
        assert a.count > 250
    values = dict(report[-1].values)
    assert (values["rejected_odometry_wrong_frame"], values["rejected_truth_wrong_frame"],
            values["rejected_sensor_wrong_frame"]) == ("20", "60", "6"), values
    assert "rejected input messages" in report[-1].message


def test_frames_and_the_mounting_are_read_only_while_running(harness):
    h = harness(SensorNode, {**QUICK, "sim.fast_time": True, "sensor.mounting_roll_arcmin": 10.0})
    for name, value in (("sensor.mounting_roll_arcmin", 0.0), ("frames.base_link", "body"), ("frames.prefix", "x/")):
        result = h.node.set_parameters([Parameter(name, value=value)])[0]
        assert not result.successful and "read-only" in result.reason, (name, result.reason)
    assert h.node.get_parameter("sensor.mounting_roll_arcmin").value == 10.0
