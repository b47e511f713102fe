"""Without tf2_msgs (not on the package registries), the sensor says so once at start-up and runs as before.

The transforms themselves, with the vendored tf2_msgs, are checked in
tests/system/test_tf_vendored.py (a venv copy that has it).
"""

from __future__ import annotations

import pytest
from tf_scenario import run

from pmv_ros.nodes import sensor_node
from pmv_ros.nodes.tf import NO_TF2_MSGS


@pytest.fixture
def without_tf2_msgs(monkeypatch):
    """The sensor as where tf2_msgs cannot be imported (this venv has none; a ROS install would)."""
    monkeypatch.setattr(sensor_node, "tf_message_type", lambda: None)


def test_without_tf2_msgs_one_start_up_line_and_an_otherwise_identical_run(without_tf2_msgs, capfd):
    capfd.readouterr()
    missing = run(publish_tf=True)  # asked to publish transforms, but it cannot
    said = capfd.readouterr().err
    quiet = run(publish_tf=False)  # the in-process pipeline's choice: no transforms asked for
    assert said.count(NO_TF2_MSGS) == 1, said
    assert NO_TF2_MSGS not in capfd.readouterr().err
    assert "/tf" not in missing["topics"] and "/tf_static" not in missing["topics"]
    assert missing["topics"] == quiet["topics"] and "/sat1/pmv/attitude" in missing["topics"]
    assert len(missing["attitude"]) == 60 and missing["attitude"] == quiet["attitude"]
