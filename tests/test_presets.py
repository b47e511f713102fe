"""Every key in the presets is a parameter some node declares (rclpy ignores unknown keys silently)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from pmv_ros.nodes import error_monitor_node, sensor_node, star_tracker_node

REPO = Path(__file__).resolve().parents[1]
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
