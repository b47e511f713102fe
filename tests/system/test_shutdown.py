"""Clean shutdown: SIGINT and SIGTERM end every node with status 0, no traceback, no hang (issue 12, item 7).

Each node runs as its own process (``python -m pmv_ros.nodes.<node>``, what
the console scripts run) on a ROS domain of this test's own, busy: the
sensor in fast time publishes as fast as it can, and the star tracker and
the monitor are fed by such a sensor in another process, so a signal lands
in the middle of a callback or a publish. Every other stop sends a second
signal shortly after the first — what a process-group Ctrl-C under
``ros2 launch`` does — so it arrives during the teardown.

Two SIGINT and two SIGTERM stops per node in the default run (one of each with a second signal), 20 + 20
with ``--run-long``. Each must end within 5 s with status 0 and nothing that
looks like a traceback on stderr.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import threading
import time

import pytest
from children import child_env, domain_id

pytestmark = [pytest.mark.multi_process]

#: A ROS domain of this test's own, apart from the colcon and launch tests.
DOMAIN_ID = domain_id(1)
#: Longest a stop may take, s (issue 12).
STOP_LIMIT_S = 5.0
#: Longest a node may take to start (imports, rclpy, the models) on a busy 2-core machine, s.
START_LIMIT_S = 60.0
NODES = ("sensor_node", "star_tracker_node", "error_monitor_node")
#: Fast-time sensor as fast as it goes: busy publishing when the signal comes.
BUSY_SENSOR = ["-p", "sim.fast_time:=true", "-p", "sensor.detector:=ideal", "-p", "sensor.rate_hz:=100.0"]


def _env(tmp_path) -> dict:
    return child_env(tmp_path / "log", DOMAIN_ID, PYTHONUNBUFFERED="1")


class Child:
    """A node process whose stderr is read on a thread (so a full pipe can never block it)."""

    def __init__(self, node: str, arguments: list, env: dict):
        self.process = subprocess.Popen([sys.executable, "-m", f"pmv_ros.nodes.{node}", "--ros-args", *arguments],
                                        env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                        stderr=subprocess.PIPE, text=True, start_new_session=True)
        self.lines = []
        self.ready = threading.Event()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.process.stderr:
            self.lines.append(line)
            if "ready" in line or "sensor_node: H =" in line:
                self.ready.set()

    @property
    def stderr(self) -> str:
        self._reader.join(timeout=2.0)
        return "".join(self.lines)

    def kill(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()


def _stop(child: Child, first: int, second: int | None) -> tuple[int, float]:
    """Send ``first`` (and ``second`` 20 ms later); (exit status, seconds to exit)."""
    started = time.monotonic()
    child.process.send_signal(first)
    if second is not None:
        time.sleep(0.02)
        if child.process.poll() is None:
            child.process.send_signal(second)
    try:
        status = child.process.wait(timeout=STOP_LIMIT_S + 5.0)
    except subprocess.TimeoutExpired:
        child.kill()
        status = None
    return status, time.monotonic() - started


def _stops(repeats: int):
    """(first signal, second signal or None) for ``repeats`` SIGINT stops and as many SIGTERM stops."""
    for first in (signal.SIGINT, signal.SIGTERM):
        for k in range(repeats):
            yield first, (signal.SIGINT if k % 2 else None)


@pytest.fixture(scope="module")
def feeder(tmp_path_factory):
    """The busy sensor that feeds the star tracker and the monitor: one process for every stop of both (started
    when the first of them needs it, after the sensor's own stops, which run without it)."""
    child = Child("sensor_node", BUSY_SENSOR, _env(tmp_path_factory.mktemp("feeder")))
    try:
        assert child.ready.wait(START_LIMIT_S), child.stderr
        yield child
    finally:
        child.kill()


def _fed(node: str, request) -> None:
    """A star tracker or a monitor is stopped while a busy sensor feeds it: the module's feeder, still running."""
    if node != "sensor_node":
        child = request.getfixturevalue("feeder")
        assert child.process.poll() is None, f"the feeding sensor ended: {child.stderr}"


@pytest.mark.parametrize("node", NODES)
def test_signals_stop_every_node_cleanly(node, tmp_path, run_long, request):
    _fed(node, request)
    _run_stops(node, tmp_path, 2)


@pytest.mark.long
@pytest.mark.parametrize("node", NODES)
def test_signals_stop_every_node_cleanly_twenty_times(node, tmp_path, run_long, request):
    if not run_long:
        pytest.skip("the 20 + 20 loop runs with --run-long (the default run does 2 + 2)")
    _fed(node, request)
    _run_stops(node, tmp_path, 20)


def _run_stops(node: str, tmp_path, repeats: int) -> None:
    env = _env(tmp_path)
    arguments = BUSY_SENSOR if node == "sensor_node" else []
    results = []
    for first, second in _stops(repeats):
        child = Child(node, arguments, env)
        try:
            assert child.ready.wait(START_LIMIT_S), f"{node} did not start: {child.stderr}"
            time.sleep(0.3)  # spinning, in the middle of its work
            status, took_s = _stop(child, first, second)
        finally:
            child.kill()
        text = child.stderr
        what = f"{node} {signal.Signals(first).name}{' + SIGINT' if second else ''}"
        results.append((what, status, took_s))
        assert status == 0, f"{what}: exit status {status}\n{text}"
        assert "Traceback" not in text and "RCLError" not in text, f"{what}:\n{text}"
        assert took_s < STOP_LIMIT_S, f"{what}: took {took_s:.1f} s"
    print(f"{node}: {len(results)} stops, slowest {max(r[2] for r in results):.2f} s")
