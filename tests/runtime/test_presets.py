"""Every key in the presets is a parameter some node declares (rclpy ignores unknown keys silently)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from pmv_ros.nodes import error_monitor_node, sensor_node, star_tracker_node

REPO = Path(__file__).resolve().parents[2]
DECLARED = {
    "sensor_node": {spec.name for spec in sensor_node.PARAMS},
    "star_tracker_node": {spec.name for spec in star_tracker_node.PARAMS},
    "error_monitor_node": {spec.name for spec in error_monitor_node.PARAMS},
}
#: Parameters rclpy declares itself.
BUILT_IN = {"use_sim_time"}


def flatten(tree, prefix=""):
    for key, value in tree.items():
        if isinstance(value, dict):
            yield from flatten(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}"


@pytest.mark.parametrize("preset", sorted(p.name for p in (REPO / "config").glob("*.yaml")))
def test_preset_keys_are_declared(preset):
    document = yaml.safe_load((REPO / "config" / preset).read_text())
    assert set(document) <= {"/**", *DECLARED}, f"unknown node section in {preset}"
    for section, body in document.items():
        keys = set(flatten(body["ros__parameters"]))
        if section == "/**":
            known = set().union(*DECLARED.values()) | BUILT_IN
        else:
            known = DECLARED[section] | BUILT_IN
        assert not keys - known, f"{preset} [{section}]: keys no node declares: {sorted(keys - known)}"


@pytest.mark.parametrize("preset", ["kondor.yaml", "meteor_m2.yaml", "meteor_m2_2.yaml"])
def test_preset_values_without_ros_match_the_file(preset):
    """``preset_values`` merges ``/**`` and the node section as rclpy does, node section winning,
    defaults for the rest."""
    from pmv_ros.runtime.common.assembly import NODE_PARAMS
    from pmv_ros.runtime.common.parameters import flatten_parameters, preset_values

    document = yaml.safe_load((REPO / "config" / preset).read_text())
    for node, specs in NODE_PARAMS.items():
        values = preset_values(document, node, specs)
        assert set(values) == {spec.name for spec in specs}
        shared = flatten_parameters(document["/**"]["ros__parameters"])
        own = flatten_parameters(document.get(node, {}).get("ros__parameters", {}))
        for name, value in {**shared, **own}.items():
            if name in values:
                assert values[name] == value, (node, name)


def test_preset_values_refuse_a_bad_value_by_name():
    from pmv_ros.runtime.common.assembly import SENSOR_PARAMS
    from pmv_ros.runtime.common.parameters import ParameterError, preset_values

    with pytest.raises(ParameterError, match="sensor.rate_hz"):
        preset_values({"sensor_node": {"ros__parameters": {"sensor": {"rate_hz": 1e9}}}}, "sensor_node", SENSOR_PARAMS)

