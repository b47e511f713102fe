"""The package as ROS users get it: ``colcon build``, then what ``ros2 run`` executes (issue 4, item 8).

``ros2 run pmv_ros sensor_node`` looks the package up in the ament index and
executes ``<install>/pmv_ros/lib/pmv_ros/sensor_node`` with the environment
that ``source install/setup.bash`` gave the shell. ros2cli is not on the
package registries, so this module builds the package with colcon into a
temporary workspace and runs that executable directly, with the environment
``setup.bash`` would add (PYTHONPATH, AMENT_PREFIX_PATH) and nothing sourced.
The node runs in another process on its own ROS domain; this process
subscribes to ``/pmv/attitude`` and waits for messages.

The console script of the venv (``pip install -e .``) is checked too: a bad
parameter must end the process with one line on stderr, not a traceback.
"""

from __future__ import annotations

import math
import os
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
from children import PYTHON_LIB, child_env, domain_id, install_env, join_domain
from geometry_msgs.msg import Vector3Stamped
from rclpy.executors import SingleThreadedExecutor

from pmv_ros import LAYERS

pytestmark = [pytest.mark.multi_process, pytest.mark.xdist_group("ros_workspace")]

REPO = Path(__file__).resolve().parents[2]
VENV_BIN = Path(sys.executable).parent

#: A ROS domain of our own (the launch test joins it too).
DOMAIN_ID = domain_id(0)

#: sensor_node in real time at 10 Hz: messages to wait for, and how long at most
#: (the first start of a process with the ROS libraries is slow on a loaded machine).
MESSAGES_WANTED = 5
FIRST_MESSAGES_TIMEOUT_S = 60.0
SHUTDOWN_TIMEOUT_S = 15.0


@pytest.mark.colcon
def test_colcon_install_layout(colcon_install):
    """The install has what ``ros2 run`` and ``--params-file`` users look for, runnable by the venv's python."""
    prefix = colcon_install / "pmv_ros"
    assert (prefix / "share/ament_index/resource_index/packages/pmv_ros").is_file()
    assert (prefix / "share/pmv_ros/package.xml").is_file()
    for preset in sorted((REPO / "config").glob("*.yaml")):
        installed = prefix / "share/pmv_ros/config" / preset.name
        assert installed.is_file(), f"{installed} missing"
        assert installed.read_bytes() == preset.read_bytes()
    assert (prefix / "share/pmv_ros/config/kondor.yaml").is_file()
    for name in ("sensor_node", "star_tracker_node", "error_monitor_node", "attitude_controller_node"):
        executable = prefix / "lib/pmv_ros" / name
        assert executable.is_file() and os.access(executable, os.X_OK), f"{executable} missing or not executable"
        shebang = executable.read_text().splitlines()[0]
        assert shebang.startswith("#!"), shebang
        interpreter = Path(shebang[2:].split()[0])
        # The venv's python: its bootstrapper sets up the ROS libraries, its site-packages has rclpy.
        assert interpreter.parent.samefile(VENV_BIN), f"{name} runs {interpreter}, not the python of {VENV_BIN}"
    site = prefix / PYTHON_LIB
    # Every package of the source tree, the subpackages of a layer too (physics/chain, physics/environment).
    source_packages = {init.parent.relative_to(REPO).as_posix()
                       for root in ("pmv_ros", "pmv_msgs_shim") for init in (REPO / root).rglob("__init__.py")}
    for package in sorted({"pmv_ros", *(f"pmv_ros/{layer}" for layer in LAYERS), "pmv_msgs_shim", *source_packages}):
        assert (site / package / "__init__.py").is_file(), f"{package} not installed in {site}"
    data_files = [path for path in (REPO / "pmv_ros/data").glob("*") if path.is_file()]
    for data in data_files:
        assert (site / "pmv_ros/data" / data.name).is_file(), f"package data {data.name} not installed"


@pytest.mark.colcon
def test_install_env_imports_the_installed_package(colcon_install, tmp_path):
    """In the install's environment pmv_ros and pmv_msgs_shim come from the install, not the source tree."""
    probe = ("import importlib.metadata, pmv_ros, pmv_msgs_shim, rclpy\n"
             "print(pmv_ros.__file__); print(pmv_msgs_shim.__file__)\n"
             "print(importlib.metadata.distribution('pmv-ros')._path)")
    result = subprocess.run([sys.executable, "-c", probe], env=install_env(colcon_install, tmp_path, DOMAIN_ID),
                            cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    site = (colcon_install / "pmv_ros" / PYTHON_LIB).resolve()
    paths = [Path(line).resolve() for line in result.stdout.splitlines()]
    assert len(paths) == 3, result.stdout
    for path in paths:
        assert site in path.parents, f"{path} is not from the install ({site})"


@pytest.mark.colcon
def test_installed_sensor_node_publishes_attitude_to_another_process(colcon_install, tmp_path, monkeypatch):
    """``install/pmv_ros/lib/pmv_ros/sensor_node`` (what ``ros2 run`` executes) in real time: /pmv/attitude arrives."""
    executable = colcon_install / "pmv_ros/lib/pmv_ros/sensor_node"
    output = tmp_path / "sensor_node.log"
    with open(output, "wb") as sink:
        child = subprocess.Popen(
            [str(executable), "--ros-args", "--params-file", str(REPO / "config/kondor.yaml")],
            env=install_env(colcon_install, tmp_path / "child_ros_log", DOMAIN_ID), cwd=tmp_path,
            stdin=subprocess.DEVNULL, stdout=sink, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        received = _listen_for_attitude(child, output, monkeypatch)
        # Ctrl-C: the node shuts down cleanly, exit status 0, no traceback.
        child.send_signal(signal.SIGINT)
        try:
            child.wait(timeout=SHUTDOWN_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            pytest.fail(f"sensor_node ignored SIGINT for {SHUTDOWN_TIMEOUT_S:g} s:\n{output.read_text()}")
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    log = output.read_text(errors="replace")
    assert child.returncode == 0, f"sensor_node exited with {child.returncode}:\n{log}"
    assert "Traceback" not in log, log
    assert "500 km" in log and "on the wall clock" in log, log  # kondor.yaml was read; real time

    stamps = []
    for message in received:
        assert message.header.frame_id == "pmv_sensor"
        roll, pitch, z = message.vector.x, message.vector.y, message.vector.z
        assert math.isfinite(roll) and math.isfinite(pitch), (roll, pitch)
        assert z == 0.0
        # kondor.yaml: offsets and oscillations of a few arcmin plus the methodical error — far below 1°.
        assert abs(roll) < math.radians(1.0) and abs(pitch) < math.radians(1.0), (roll, pitch)
        stamps.append(message.header.stamp.sec + message.header.stamp.nanosec * 1e-9)
    # Real time on the system clock at 10 Hz (not a fast-time simulation clock from 0).
    assert all(later > earlier for earlier, later in zip(stamps, stamps[1:])), stamps
    assert abs(stamps[-1] - time.time()) < FIRST_MESSAGES_TIMEOUT_S + SHUTDOWN_TIMEOUT_S, stamps[-1]
    spacing = statistics.median(later - earlier for earlier, later in zip(stamps, stamps[1:]))
    assert 0.05 < spacing < 0.3, f"median spacing {spacing:.3f} s, expected 0.1 s at 10 Hz: {stamps}"


def _listen_for_attitude(child: subprocess.Popen, output: Path, monkeypatch) -> list:
    """/pmv/attitude messages received in this process on the child's domain (at least MESSAGES_WANTED)."""
    context = join_domain(monkeypatch, DOMAIN_ID)
    received = []
    try:
        listener = rclpy.create_node("colcon_test_listener", context=context)
        listener.create_subscription(Vector3Stamped, "/pmv/attitude", received.append, 100)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(listener)
        deadline = time.monotonic() + FIRST_MESSAGES_TIMEOUT_S
        while len(received) < MESSAGES_WANTED and time.monotonic() < deadline:
            if child.poll() is not None:
                pytest.fail(f"sensor_node exited with {child.returncode} before publishing:\n{output.read_text()}")
            executor.spin_once(timeout_sec=0.1)
        executor.shutdown()
        listener.destroy_node()
    finally:
        rclpy.shutdown(context=context)
    assert len(received) >= MESSAGES_WANTED, (
        f"{len(received)} /pmv/attitude messages in {FIRST_MESSAGES_TIMEOUT_S:g} s on domain {DOMAIN_ID}; "
        f"sensor_node said:\n{output.read_text()}")
    return received


def test_console_script_rejects_invalid_parameter_in_one_line(tmp_path):
    """``sensor_node`` (the venv console script) with altitude −5 km: exit ≠ 0, one line naming value and range."""
    script = VENV_BIN / "sensor_node"
    assert script.is_file(), f"{script} missing: the package is not installed in this venv (make venv)"
    result = subprocess.run([str(script), "--ros-args", "-p", "orbit.altitude_km:=-5.0"],
                            env=child_env(tmp_path, DOMAIN_ID, fresh_shell=True), cwd=tmp_path,
                            stdin=subprocess.DEVNULL,
                            capture_output=True, text=True, timeout=30)
    assert result.returncode != 0, result
    assert "Traceback" not in result.stderr, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    line = lines[0]
    assert "orbit.altitude_km" in line and "-5" in line, line
    assert "150" in line and "40000" in line, f"allowed range [150, 40000] km not named: {line}"
