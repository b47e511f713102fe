"""Every node parameter is described and validated, at start-up and at run time (issue 6, item 1).

* Descriptors: every declared parameter has a description and a type; a
  number has a range, an enumeration its choices, a free-form string what it
  must look like — as ``ros2 param describe`` shows them.
* Run time: for every parameter of every node, a value out of range, of the
  wrong type or not among the choices is refused with a reason that names the
  parameter, the value and what is allowed; the node keeps its old value and
  keeps publishing. The same through the parameter services.
* Start-up: a bad value (params file or override) stops the node before it
  does anything — in-process a ParameterError, from the console scripts one
  line on stderr and exit status 1, no traceback.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import rclpy
from children import child_env, domain_id
from rcl_interfaces.msg import ParameterType
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient

from pmv_ros.nodes import error_monitor_node, sensor_node, star_tracker_node
from pmv_ros.nodes.params import ParameterError, ParamSpec
from pmv_ros.nodes.pipeline import Pipeline, drain

pytestmark = [pytest.mark.multi_process]

NODES = {
    "sensor_node": (sensor_node.SensorNode, sensor_node.PARAMS),
    "star_tracker_node": (star_tracker_node.StarTrackerNode, star_tracker_node.PARAMS),
    "error_monitor_node": (error_monitor_node.ErrorMonitorNode, error_monitor_node.PARAMS),
}
ROLES = {"sensor_node": "sensor", "star_tracker_node": "star_tracker", "error_monitor_node": "monitor"}
VENV_BIN = Path(sys.executable).parent


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def out_of_range(spec: ParamSpec):
    """A value of the right type outside the spec's range or choices (None if it has neither)."""
    if spec.choices is not None:
        return "bogus"
    if spec.low is None:
        return None
    if isinstance(spec.default, list):
        return [float(spec.high) + 1.0]
    if isinstance(spec.default, int):
        return int(spec.high) + 1
    return float(spec.high) * 2.0 + 1.0


def wrong_type(spec: ParamSpec):
    """A value of another type than the spec's."""
    if isinstance(spec.default, bool) or _number(spec.default) or isinstance(spec.default, list):
        return "fast"
    return 3  # for a string


def cases():
    for node_name, (_, specs) in NODES.items():
        for spec in specs:
            yield pytest.param(node_name, spec, id=f"{node_name}:{spec.name}")


# ---------------------------------------------------------------------------------------------- descriptors

@pytest.fixture
def context():
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.shutdown(context=ctx)


@pytest.mark.parametrize("node_name", list(NODES))
def test_every_parameter_has_a_descriptor_with_type_range_and_description(node_name, context):
    node_class, specs = NODES[node_name]
    node = node_class(context=context)
    try:
        names = [spec.name for spec in specs]
        declared = set(node.list_parameters([], 0).names) - {"use_sim_time", "start_type_description_service"}
        assert declared == set(names), "every declared parameter comes from a spec (and only from one)"
        for spec, descriptor in zip(specs, node.describe_parameters(names)):
            assert len(spec.description) > 10 and descriptor.description.startswith(spec.description), spec.name
            assert descriptor.type != ParameterType.PARAMETER_NOT_SET, spec.name
            if spec.unit:
                assert f"[{spec.unit}]" in descriptor.description, spec.name
            if isinstance(spec.default, bool):
                assert descriptor.type == ParameterType.PARAMETER_BOOL
            elif isinstance(spec.default, int):
                assert descriptor.type == ParameterType.PARAMETER_INTEGER and descriptor.integer_range, spec.name
                assert descriptor.integer_range[0].from_value <= spec.default <= descriptor.integer_range[0].to_value
            elif isinstance(spec.default, float):
                assert descriptor.type == ParameterType.PARAMETER_DOUBLE and descriptor.floating_point_range, spec.name
                span = descriptor.floating_point_range[0]
                assert span.from_value <= spec.default <= span.to_value, spec.name
            elif isinstance(spec.default, str):
                # an enumeration lists its choices; a free-form string says what it must look like
                assert descriptor.type == ParameterType.PARAMETER_STRING
                assert descriptor.additional_constraints, f"{spec.name}: no choices or format in the descriptor"
                if spec.choices:
                    assert spec.default in spec.choices
                    assert all(str(choice) in descriptor.additional_constraints for choice in spec.choices)
            else:
                assert descriptor.type == ParameterType.PARAMETER_DOUBLE_ARRAY, spec.name
                assert f"[{spec.low}, {spec.high}]" in descriptor.additional_constraints, spec.name
                assert all(spec.low <= element <= spec.high for element in spec.default)
            assert node.get_parameter(spec.name).value == spec.default
    finally:
        node.destroy_node()


# ---------------------------------------------------------------------------------------------- start-up

@pytest.mark.parametrize("node_name,spec", list(cases()))
def test_start_up_refuses_a_bad_value_naming_it_and_the_allowed_range(node_name, spec, context):
    node_class, _ = NODES[node_name]
    for bad in (out_of_range(spec), wrong_type(spec)):
        if bad is None:
            continue
        with pytest.raises(ParameterError) as caught:
            node_class(context=context, parameter_overrides=[Parameter(spec.name, value=bad)])
        reason = str(caught.value)
        assert spec.name in reason, reason
        shown = bad[0] if isinstance(bad, list) else bad
        assert str(shown) in reason, reason
        if spec.choices:
            assert all(str(choice) in reason for choice in spec.choices), reason
        elif spec.low is not None:
            assert f"[{spec.low}, {spec.high}]" in reason, reason


def test_an_integer_for_a_floating_point_parameter_is_taken_as_that_number(context):
    # `rate_hz: 20` in YAML means 20.0: rclpy's static typing would refuse it, the nodes do not.
    node = sensor_node.SensorNode(context=context, parameter_overrides=[
        Parameter("sensor.rate_hz", value=20), Parameter("orbit.altitude_km", value=835)])
    try:
        assert node.get_parameter("sensor.rate_hz").value == 20.0
        assert node.get_parameter("orbit.altitude_km").type_ == Parameter.Type.DOUBLE
        result = node.set_parameters([Parameter("sensor.rate_hz", value=5)])[0]
        assert result.successful, result.reason
        assert node.get_parameter("sensor.rate_hz").value == 5.0
    finally:
        node.destroy_node()
    tracker = star_tracker_node.StarTrackerNode(context=context, parameter_overrides=[
        Parameter("outage_start_s", value=[100, 200]), Parameter("outage_duration_s", value=[10, 20])])
    try:
        assert tracker.get_parameter("outage_start_s").value == [100.0, 200.0]
    finally:
        tracker.destroy_node()


def test_start_up_refuses_an_inconsistent_combination(context):
    with pytest.raises(ParameterError, match="outage_start_s has 2 entries but outage_duration_s has 1"):
        star_tracker_node.StarTrackerNode(context=context, parameter_overrides=[
            Parameter("outage_start_s", value=[1.0, 2.0]), Parameter("outage_duration_s", value=[5.0])])
    with pytest.raises(ParameterError, match="'yesterday' is not an ISO 8601 date-time"):
        sensor_node.SensorNode(context=context, parameter_overrides=[Parameter("sim.epoch_utc", value="yesterday")])
    with pytest.raises(ParameterError, match="cannot read correction table /no/such/table.csv"):
        sensor_node.SensorNode(context=context, parameter_overrides=[
            Parameter("sensor.correction", value="/no/such/table.csv")])


#: Invalid presets: (node, YAML under ros__parameters, words the one-line reason must contain).
BAD_PRESETS = [
    ("sensor_node", "sensor:\n      rate_hz: 500.0", ["sensor.rate_hz", "500.0", "[0.1, 100.0]"]),
    ("sensor_node", "sensor:\n      rate_hz: fast", ["sensor.rate_hz", "'fast'", "[0.1, 100.0]"]),
    ("sensor_node", "sim:\n      epoch_utc: yesterday", ["'yesterday'", "ISO 8601"]),
    ("sensor_node", "attitude:\n      source: manual", ["attitude.source", "'manual'", "['profile', 'follow']"]),
    ("star_tracker_node", "frame_period_s: -2.0", ["frame_period_s", "-2.0", "[0.02, 100.0]"]),
    ("star_tracker_node", "outage_start_s: [10.0, 20.0]", ["outage_start_s has 2 entries"]),
    ("error_monitor_node", "remove_oblateness: 3", ["remove_oblateness", "3", "true or false"]),
    ("error_monitor_node", "max_truth_gap_s: 1.0e9", ["max_truth_gap_s", "1000000000.0", "[0.001, 3600.0]"]),
]


def _child_env(log_dir: Path) -> dict:
    return child_env(log_dir, domain_id(0), discovery="OFF")  # they exit before they talk, but stay apart


def test_console_scripts_with_an_invalid_preset_exit_non_zero_with_the_reason_and_no_traceback(tmp_path):
    children = []
    for index, (node_name, body, words) in enumerate(BAD_PRESETS):
        preset = tmp_path / f"bad_{index}.yaml"
        preset.write_text(f"{node_name}:\n  ros__parameters:\n    {body}\n")
        script = VENV_BIN / node_name
        assert script.is_file(), f"{script} missing: the package is not installed in this venv (make venv)"
        children.append((subprocess.Popen([str(script), "--ros-args", "--params-file", str(preset)],
                                          env=_child_env(tmp_path / "log"), cwd=tmp_path, stdin=subprocess.DEVNULL,
                                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True), node_name, words))
    # a file that is not YAML at all: rcl refuses it before the node exists
    broken = tmp_path / "broken.yaml"
    broken.write_text("sensor_node:\n  ros__parameters:\n    sensor: [rate_hz: 5\n")
    broken_child = subprocess.Popen([str(VENV_BIN / "sensor_node"), "--ros-args", "--params-file", str(broken)],
                                    env=_child_env(tmp_path / "log"), cwd=tmp_path, stdin=subprocess.DEVNULL,
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for child, node_name, words in children:
            _, stderr = child.communicate(timeout=60)
            assert child.returncode == 1, (node_name, child.returncode, stderr)
            assert "Traceback" not in stderr, stderr
            lines = stderr.strip().splitlines()
            assert len(lines) == 1, stderr
            assert lines[0].startswith(f"{node_name}: invalid parameter: "), lines[0]
            for word in words:
                assert word in lines[0], (word, lines[0])
        _, stderr = broken_child.communicate(timeout=60)
        assert broken_child.returncode == 1 and "Traceback" not in stderr, stderr
        assert stderr.strip().splitlines()[-1].startswith("sensor_node: cannot start:"), stderr
        assert "broken.yaml" in stderr
    finally:
        for child in [c for c, _, _ in children] + [broken_child]:
            if child.poll() is None:
                child.kill()
                child.communicate()


# ---------------------------------------------------------------------------------------------- run time

def test_run_time_refuses_bad_values_of_every_parameter_and_the_nodes_keep_publishing():
    overrides = {"sensor.rate_hz": 2.0, "ideal": True, "frame_period_s": 0.5}
    with Pipeline(None, overrides) as pipeline:
        pipeline.step(20)
        refused = 0
        for node_name, (_, specs) in NODES.items():
            node = getattr(pipeline, ROLES[node_name])
            for spec in specs:
                before = node.get_parameter(spec.name).value
                for bad in (out_of_range(spec), wrong_type(spec)):
                    if bad is None:
                        continue
                    result = node.set_parameters([Parameter(spec.name, value=bad)])[0]
                    assert not result.successful, (node_name, spec.name, bad)
                    shown = bad[0] if isinstance(bad, list) else bad
                    assert spec.name in result.reason and str(shown) in result.reason, result.reason
                    if spec.choices:
                        assert str(list(spec.choices)) in result.reason, result.reason
                    elif spec.low is not None:
                        assert f"[{spec.low}, {spec.high}]" in result.reason, result.reason
                    # an all-or-nothing update with one bad value changes nothing either
                    atomic = node.set_parameters_atomically([Parameter(spec.name, value=bad)])
                    assert not atomic.successful and atomic.reason == result.reason
                    refused += 2
                assert node.get_parameter(spec.name).value == before, spec.name
        assert refused > 100
        # The nodes kept their configuration and keep working: samples, truth frames, residuals.
        samples = pipeline.sensor.samples_published
        residuals = pipeline.collector.residual_count
        frames = pipeline.star_tracker.counters["frames_ok"]
        pipeline.step(20)
        assert pipeline.sensor.samples_published == samples + 20
        assert pipeline.star_tracker.counters["frames_ok"] >= frames + 18
        assert pipeline.collector.residual_count >= residuals + 18
        # and a good update is still taken
        assert pipeline.monitor.set_parameters([Parameter("statistics_rate_hz", value=0.5)])[0].successful


def test_parameter_service_refuses_a_bad_value_with_the_same_reason(context):
    # What `ros2 param set /sensor_node sensor.rate_hz fast` does: the set_parameters service.
    node = sensor_node.SensorNode(context=context)  # not lean: with parameter services
    client_node = Node("param_client", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    executor.add_node(client_node)
    try:
        client = AsyncParameterClient(client_node, "sensor_node")
        assert client.wait_for_services(timeout_sec=10.0)
        for bad, words in (("fast", ["sensor.rate_hz", "'fast'", "[0.1, 100.0]"]),
                           (1000.0, ["sensor.rate_hz", "1000.0", "[0.1, 100.0]"])):
            future = client.set_parameters([Parameter("sensor.rate_hz", value=bad)])
            executor.spin_until_future_complete(future, timeout_sec=10.0)
            result = future.result().results[0]
            assert not result.successful
            assert all(word in result.reason for word in words), result.reason
        future = client.set_parameters([Parameter("sensor.rate_hz", value=4)])  # an integer: taken as 4.0
        executor.spin_until_future_complete(future, timeout_sec=10.0)
        assert future.result().results[0].successful
        assert node.get_parameter("sensor.rate_hz").value == 4.0
        drain(executor)
    finally:
        executor.shutdown()
        client_node.destroy_node()
        node.destroy_node()
