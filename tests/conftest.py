"""Test configuration: ROS isolation, the --run-long switch, shared fixtures.

The tests mirror the package's layers: ``physics/``, ``analysis/``,
``runtime/``, ``nodes/``, ``apps/`` (CLI and applications, in-process through
``main(argv)``) and ``system/`` (child processes, colcon, launch, soak, the
golden outputs, the layering). Support modules beside this file, imported by
the tests (never a test module by another): ``children`` (the environment of
child processes and their ROS domain), ``cli_runner`` (``pmv`` in-process),
``flights`` (a preset flown without ROS), ``neighbour`` (a hostile node on the
stack's domain), ``node_harness``, ``reference_chain``, ``tf_scenario`` (a
namespaced sensor and its transforms read back); and in ``system/``
``bounded_run``, ``cli_cases`` and ``record_child`` (children measured for
time and memory).
The published tables are :mod:`pmv_ros.physics.published`.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

# In-process node tests are isolated from other ROS graphs on this machine;
# rclpy.init() needs a writable log directory.
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF")
os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="pmv_ros_test_log_"))
os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")

REPO = Path(__file__).resolve().parents[1]


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


@pytest.fixture(scope="session")
def ros_tools(tmp_path_factory) -> Path:
    """A venv copy with ros2cli, launch, launch_ros and tf2_msgs (../shared/vendor/install-ros-tools.sh), once per run.

    Skips when the vendored snapshots are not there (users without them still get a green run).
    """
    from children import VENDOR, VENDOR_INSTALLER

    if not VENDOR_INSTALLER.is_file():
        pytest.skip(f"no {VENDOR} (vendored ROS 2 tool snapshots): not tested")
    work = tmp_path_factory.mktemp("ros_tools")
    base = Path(sys.executable).parent.parent
    result = subprocess.run(["bash", str(VENDOR_INSTALLER), str(base), str(work)], capture_output=True, text=True,
                            timeout=600)
    assert result.returncode == 0, f"install-ros-tools failed:\n{result.stdout}\n{result.stderr}"
    assert (work / "venv/bin/ros2").is_file()
    return work / "venv"


def _colcon_missing() -> str | None:
    for module in ("colcon_core", "colcon_ros", "colcon_python_setup_py"):
        if importlib.util.find_spec(module) is None:
            return (f"colcon is not installed for {sys.executable} ({module} is not importable): "
                    "`pip install -r requirements.txt` (colcon-common-extensions)")
    return None


@pytest.fixture(scope="session")
def colcon_install(tmp_path_factory) -> Path:
    """``colcon build`` of this repository into a temporary workspace, once per run; the install base."""
    reason = _colcon_missing()
    if reason:
        pytest.skip(reason)
    workspace = tmp_path_factory.mktemp("colcon_ws")
    leftovers = ("build", "install", "log", "pmv_ros.egg-info")
    present_before = {name for name in leftovers if (REPO / name).exists()}
    env = {name: value for name, value in os.environ.items() if name != "COLCON_DEFAULTS_FILE"}
    env["COLCON_HOME"] = str(workspace / "colcon_home")  # no user defaults or mixins
    command = [sys.executable, "-c", "import sys; from colcon_core.command import main; sys.exit(main())",
               "--log-base", str(workspace / "log"),
               "build", "--base-paths", str(REPO), "--packages-select", "pmv_ros",
               "--build-base", str(workspace / "build"), "--install-base", str(workspace / "install")]
    result = subprocess.run(command, cwd=workspace, env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, f"colcon build failed:\n{result.stdout}\n{result.stderr}"
    assert "1 package finished" in result.stdout, result.stdout
    left = {name for name in leftovers if (REPO / name).exists()} - present_before
    assert not left, f"colcon build left {sorted(left)} in the repository"
    return workspace / "install"
