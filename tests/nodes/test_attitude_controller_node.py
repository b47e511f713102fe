"""attitude_controller_node in-process: the loop closed through the topics, its inputs, parameters and health."""

from __future__ import annotations

import math
from pathlib import Path
import time

import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from rclpy.parameter import Parameter

import pmv_msgs_shim as shim
from pmv_ros.nodes.attitude_controller_node import AttitudeControllerNode
from pmv_ros.nodes.pipeline import Pipeline
from pmv_ros.physics.attitude import true_roll_pitch
from pmv_ros.physics.constants import ARCMIN_RAD

from node_harness import probe

REPO = Path(__file__).resolve().parents[2]

#: The geometric instrument: cheap, and its error is the oblateness alone.
GEOMETRIC = {"sensor.detector": "ideal", "sensor.bright_body_exclusion_deg": 0.0}


def test_the_loop_closes_through_the_topics():
    with Pipeline(None, GEOMETRIC, closed_loop=True) as pipeline:
        got = probe(pipeline, {"attitude/truth": QuaternionStamped, "pmv/attitude": Vector3Stamped})
        pipeline.step(300)
        sensor, controller = pipeline.sensor, pipeline.controller
        assert sensor.follows_attitude and sensor.samples_published == 300
        truth = [shim.read_attitude_quaternion(m) for m in got["attitude/truth"]]
        angles = [shim.read_attitude_angles(m) for m in got["pmv/attitude"]]
        # The plant reaches each sample's time before the sensor measures it: a truth message at every sample's
        # stamp (and one ahead, for the next sample), each sample measured at that very attitude.
        truth_at = dict(truth)
        assert len(truth) == 301
        assert all(any(abs(t - stamp) < 1e-8 for t in truth_at) for stamp, _, _ in angles)
        assert controller.runtime.counters["measurements"] == 300
        counters = sensor.runtime.health.counters  # no sample went without truth
        assert not any(key.startswith("skipped_") or key == "truth_bridged" for key in counters), counters
        # The loop holds the body within the oblateness error of nadir (< 10′) and the star tracker and the
        # monitor run on the plant's truth.
        roll, pitch = true_roll_pitch(truth[-1][1])
        assert abs(roll) < 10 * ARCMIN_RAD and abs(pitch) < 10 * ARCMIN_RAD
        assert pipeline.monitor.monitor.counters["used"] > 200
        roll_stats, _ = controller.pointing.channels()
        assert roll_stats.count + controller.pointing.skipped == 301


def test_measurements_in_another_frame_are_refused_and_said_on_diagnostics(harness):
    h = harness(AttitudeControllerNode, {"diagnostics_period_s": 0.1}, external_drive=True)
    diagnostics = h.record(DiagnosticArray, "/diagnostics")
    truth = h.record(QuaternionStamped, "/attitude/truth")
    sensor = h.publisher(Vector3Stamped, "/pmv/attitude")
    start = h.node.runtime.time_s
    message = Vector3Stamped()
    shim.write_attitude_angles(message, start + 0.05, "base_link", 1e-3, 2e-3)
    sensor.publish(message)
    h.drain()
    shim.write_attitude_angles(message, start + 0.06, "pmv_sensor", 1e-3, 2e-3)
    sensor.publish(message)
    h.drain()
    h.node.step_to(start + 0.3)
    h.drain()
    assert [m.header.frame_id for m in truth] == ["orbital"] * 3
    status = shim.health_from_msg(diagnostics[-1]).statuses[0]
    values = dict(status.values)
    assert status.name == "pmv_ros/attitude_controller_node"
    assert status.hardware_id == "attitude_control:/attitude_controller_node"
    assert values["rejected_measurement_wrong_frame"] == "1" and values["measurements"] == "1"


def test_a_bad_parameter_update_is_refused_and_the_old_value_kept(harness):
    node = harness(AttitudeControllerNode, {}, external_drive=True).node
    [result] = node.set_parameters([Parameter("control.bandwidth_hz", value=0.9)])  # above control.rate_hz / 20
    assert not result.successful and "control.bandwidth_hz" in result.reason
    assert node.get_parameter("control.bandwidth_hz").value == 0.02
    assert node.runtime.settings.gains.bandwidth_hz == 0.02
    [result] = node.set_parameters([Parameter("control.bandwidth_hz", value=0.05)])
    assert result.successful and node.runtime.settings.gains.bandwidth_hz == 0.05
    [result] = node.set_parameters([Parameter("body.inertia_kg_m2", value=[1.0, 1.0, 1.0])])
    assert not result.successful and "read-only" in result.reason


def test_on_its_own_clock_the_timer_moves_the_plant(harness):
    h = harness(AttitudeControllerNode, {"control.rate_hz": 20.0})
    truth = h.record(QuaternionStamped, "/attitude/truth")
    deadline = time.monotonic() + 20.0
    while len(truth) < 5 and time.monotonic() < deadline:
        h.executor.spin_once(timeout_sec=0.05)
    stamps = [shim.read_attitude_quaternion(m)[0] for m in truth]
    assert len(stamps) >= 5
    steps = [b - a for a, b in zip(stamps, stamps[1:])]
    assert all(step == pytest.approx(0.05, abs=1e-6) for step in steps)  # on the grid, whatever the wake-ups
    assert all(math.isfinite(s) for s in stamps)


def test_the_minimal_example_closes_a_loop_too(harness):
    # examples/minimal_controller.py: a measured roll of +10′ turns the body towards −10′ (physics.md §2.1).
    import importlib.util

    spec = importlib.util.spec_from_file_location("minimal_controller", REPO / "examples" / "minimal_controller.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    h = harness(AttitudeControllerNode, {}, external_drive=True)  # a context and a tester to borrow
    node = example.MinimalController(0.5, 500.0, context=h.context)  # 0.5 Hz: within a second it shows
    h.executor.add_node(node)
    truth = h.record(QuaternionStamped, "/attitude/truth")
    sensor = h.publisher(Vector3Stamped, "/pmv/attitude")
    message = Vector3Stamped()
    shim.write_attitude_angles(message, 1.0, "pmv_sensor", 10 * ARCMIN_RAD, 0.0)
    deadline = time.monotonic() + 20.0
    while len(truth) < 8 and time.monotonic() < deadline:
        sensor.publish(message)
        h.executor.spin_once(timeout_sec=0.05)
    node.destroy_node()
    assert len(truth) >= 8
    roll, _ = true_roll_pitch(shim.read_attitude_quaternion(truth[-1])[1])
    assert roll < 0.0
