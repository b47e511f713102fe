"""Managed nodes go only where they are told: an external lifecycle manager drives the launched nodes through
every transition.

The manager is this process's own clients of the nodes' ``change_state`` and ``get_state`` services — what a
lifecycle manager (nav2's, a team's own) calls, and what ``ros2 lifecycle set``/``get`` call — and the real
``ros2 lifecycle`` CLI for a few transitions and one read among them, so the CLI's path is taken too without a
CLI process spending its 5 s of discovery on every transition.

``ros2 launch pmv_ros pmv.launch.py managed:=true`` configures and activates each node once, at start-up
(``autostart``, default true); a later configure, after a cleanup, leaves the node inactive for the manager's own
``activate``. With ``autostart:=false`` the launch changes no state at all: the nodes wait unconfigured.

The package is built with colcon and the tools come from ``../shared/vendor`` (as for ``test_launch.py``); without
them the module is skipped.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
import rclpy
from children import VENDOR, VENDOR_INSTALLER, domain_id, install_env, join_domain
from geometry_msgs.msg import Vector3Stamped
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rclpy.executors import SingleThreadedExecutor

#: Block 0, as the other launch tests: modules sharing a worker run one after another, the other workers'
#: domains differ (this module's group is a part of its own: it may run beside the launch tests, on another one).
DOMAIN_ID = domain_id(0)

pytestmark = [
    pytest.mark.launch,
    pytest.mark.multi_process,
    # Two tests that mostly wait on the launch and on `ros2 lifecycle` (≈ 1.5 min): beside the other users of the
    # colcon build.
    pytest.mark.xdist_group("ros_workspace/lifecycle"),
    pytest.mark.skipif(not VENDOR_INSTALLER.is_file(),
                       reason=f"no {VENDOR} (vendored ros2 launch snapshots): not tested"),
]

#: First answers after a cold start of four Python processes on a busy 2-core machine, s.
START_TIMEOUT_S = 90.0
#: One `ros2 lifecycle` command (a Python process that discovers the graph), s.
CLI_TIMEOUT_S = 60.0
#: How long a node must stay where the manager left it to show the launch does not move it, s (the launch's
#: activate, were it sent, follows the transition event within a few hundred ms).
STAYS_S = 3.0
SHUTDOWN_TIMEOUT_S = 20.0


class Stack:
    """``ros2 launch pmv_ros pmv.launch.py managed:=true ARGS`` as a child process, and ``ros2 lifecycle`` beside it."""

    def __init__(self, install: Path, tools: Path, tmp_path: Path, *arguments: str):
        self.tools, self.output = tools, tmp_path / "launch.log"
        self.env = install_env(install, tmp_path / "ros_log", DOMAIN_ID)
        self.env.update(VIRTUAL_ENV=str(tools), PYTHONUNBUFFERED="1",
                        PATH=os.pathsep.join([str(tools / "bin"), self.env.get("PATH", "")]),
                        AMENT_PREFIX_PATH=os.pathsep.join([self.env["AMENT_PREFIX_PATH"], str(tools)]))
        with open(self.output, "wb") as sink:
            self.process = subprocess.Popen(
                [str(tools / "bin/ros2"), "launch", "pmv_ros", "pmv.launch.py", "managed:=true", *arguments],
                env=self.env, cwd=tmp_path, stdin=subprocess.DEVNULL, stdout=sink, stderr=subprocess.STDOUT,
                start_new_session=True)

    def log(self) -> str:
        return self.output.read_text(errors="replace")

    def lifecycle(self, *arguments: str) -> str:
        """``ros2 lifecycle ARGUMENTS`` (no daemon, 5 s of discovery); its output, or a failed test."""
        if self.process.poll() is not None:
            pytest.fail(f"ros2 launch exited with {self.process.returncode}:\n{self.log()}")
        done = subprocess.run([str(self.tools / "bin/ros2"), "lifecycle", arguments[0], "--no-daemon",
                               "--spin-time", "5", *arguments[1:]], env=self.env, capture_output=True, text=True,
                              timeout=CLI_TIMEOUT_S)
        return (done.stdout + done.stderr).strip()

    def cli_state(self, node: str) -> str:
        """The node's state label, as ``ros2 lifecycle get`` prints it (``inactive [2]``)."""
        return self.lifecycle("get", node).split(" [")[0]

    def set(self, node: str, transition: str) -> None:
        said = self.lifecycle("set", node, transition)
        assert said == "Transitioning successful", f"{node} {transition}: {said}\n{self.log()[-3000:]}"

    def interrupt(self) -> None:
        self.process.send_signal(signal.SIGINT)
        try:
            self.process.wait(timeout=SHUTDOWN_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            pytest.fail(f"ros2 launch ignored SIGINT for {SHUTDOWN_TIMEOUT_S:g} s:\n{self.log()}")

    def kill(self) -> None:
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait()


@pytest.fixture
def listener(monkeypatch):
    """A node of this process on the children's domain that counts /pmv/attitude and reads and changes the nodes'
    lifecycle states; yields (count, spin, state, change): ``state(node)`` is the label ``ros2 lifecycle get``
    prints (``inactive``), or "unknown" while the node's get_state service does not answer; ``change(node,
    transition)`` asks the node's change_state service for the transition of that label (``configure``) and
    fails the test unless it says it succeeded."""
    context = join_domain(monkeypatch, DOMAIN_ID)
    node = rclpy.create_node("lifecycle_test_listener", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    attitude, clients = [], {}
    node.create_subscription(Vector3Stamped, "/pmv/attitude", attitude.append, 100)

    def spin(seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)

    def call(service_type, name: str, request):
        """The response of the service ``name``, or None when it does not answer within CLI_TIMEOUT_S."""
        client = clients.setdefault(name, node.create_client(service_type, name))
        deadline = time.monotonic() + CLI_TIMEOUT_S
        while not client.service_is_ready():
            if time.monotonic() > deadline:
                return None
            spin(0.1)
        future = client.call_async(request)
        while not future.done():
            if time.monotonic() > deadline:
                return None
            executor.spin_once(timeout_sec=0.05)
        return future.result()

    def state(name: str) -> str:
        answer = call(GetState, f"{name}/get_state", GetState.Request())
        return "unknown" if answer is None else answer.current_state.label

    def change(name: str, transition: str) -> None:
        answer = call(ChangeState, f"{name}/change_state", ChangeState.Request(transition=Transition(label=transition)))
        assert answer is not None and answer.success, f"{name} {transition}: {answer}"

    try:
        yield (lambda: len(attitude)), spin, state, change
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)


def _wait_for_state(state, stack: Stack, node: str, wanted: str) -> None:
    deadline = time.monotonic() + START_TIMEOUT_S
    while (now := state(node)) != wanted:
        if time.monotonic() > deadline:
            pytest.fail(f"{node} is {now!r}, not {wanted} within {START_TIMEOUT_S:g} s:\n{stack.log()}")
        time.sleep(0.2)


def _publishes(count, spin, seconds: float = 2.0) -> bool:
    before = count()
    spin(seconds)
    return count() > before


def test_after_a_cleanup_the_managers_configure_leaves_the_node_inactive_for_its_own_activate(
        colcon_install, ros_tools, listener, tmp_path):
    count, spin, state, change = listener
    stack = Stack(colcon_install, ros_tools, tmp_path)
    try:
        _wait_for_state(state, stack, "/sensor_node", "active")  # the launch's own start-up: configure, activate
        assert _publishes(count, spin)
        change("/sensor_node", "deactivate")
        stack.set("/sensor_node", "cleanup")  # through the CLI
        assert stack.cli_state("/sensor_node") == "unconfigured"  # the CLI reads it too
        change("/sensor_node", "configure")
        spin(STAYS_S)
        assert state("/sensor_node") == "inactive"  # the launch does not activate it behind the manager
        assert not _publishes(count, spin)
        change("/sensor_node", "activate")  # the manager's own activate is not refused
        assert state("/sensor_node") == "active" and _publishes(count, spin)
        stack.interrupt()
    finally:
        stack.kill()
    assert stack.process.returncode == 0 and "Traceback" not in stack.log(), stack.log()


def test_without_autostart_the_manager_drives_every_transition(colcon_install, ros_tools, listener, tmp_path):
    count, spin, state, change = listener
    stack = Stack(colcon_install, ros_tools, tmp_path, "autostart:=false")
    nodes = ("/sensor_node", "/star_tracker_node", "/error_monitor_node")
    try:
        for node in nodes:  # started, and left unconfigured by the launch
            _wait_for_state(state, stack, node, "unconfigured")
        spin(STAYS_S)
        assert [state(node) for node in nodes] == ["unconfigured"] * 3 and not _publishes(count, spin, 0.5)
        for step, (transition, wanted, publishing) in enumerate((
                ("configure", "inactive", False), ("activate", "active", True), ("deactivate", "inactive", False),
                ("cleanup", "unconfigured", False), ("configure", "inactive", False), ("activate", "active", True))):
            if step == 0:
                stack.set("/sensor_node", transition)  # the first through the CLI
            else:
                change("/sensor_node", transition)
            spin(STAYS_S if transition == "configure" else 0.5)
            assert state("/sensor_node") == wanted, (transition, stack.log()[-3000:])
            spin(1.0)  # what was on its way before the transition
            assert _publishes(count, spin) == publishing, transition
        stack.set("/sensor_node", "shutdown")  # through the CLI: it picks the shutdown of the active state
        assert state("/sensor_node") == "finalized"
        stack.interrupt()
    finally:
        stack.kill()
    assert stack.process.returncode == 0 and "Traceback" not in stack.log(), stack.log()


def test_an_unusable_autostart_ends_the_launch_with_one_line(colcon_install, ros_tools, tmp_path):
    stack = Stack(colcon_install, ros_tools, tmp_path, "autostart:=maybe")
    try:
        stack.process.wait(timeout=START_TIMEOUT_S)
    finally:
        stack.kill()
    log = stack.log()
    errors = [line for line in log.splitlines() if "ERROR" in line]
    assert stack.process.returncode != 0 and len(errors) == 1 and "autostart" in errors[0], log
    assert "Traceback" not in log and "process started" not in log, log
