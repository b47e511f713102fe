"""Test configuration: ROS isolation, the --run-long switch, shared fixtures."""

from __future__ import annotations

import os
import tempfile

import pytest

# In-process node tests are isolated from other ROS graphs on this machine;
# rclpy.init() needs a writable log directory.
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF")
os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="pmv_ros_test_log_"))
os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")


def pytest_addoption(parser):
    parser.addoption("--run-long", action="store_true", default=False,
                     help="run the full-length soak/stress versions of tests marked 'long'")


@pytest.fixture
def run_long(request) -> bool:
    """True when the full-length soak/stress runs were asked for (--run-long)."""
    return bool(request.config.getoption("--run-long"))


@pytest.fixture
def harness():
    """Make ``Harness(node_class, overrides, **node_arguments)`` objects; all are closed after the test."""
    from node_harness import Harness

    made = []

    def make(node_class, overrides, **node_arguments):
        made.append(Harness(node_class, overrides, **node_arguments))
        return made[-1]

    yield make
    for item in made:
        item.close()
