"""``ros2 launch pmv_ros pmv.launch.py`` refuses an argument it does not declare, with the real launch tools.

``bogus:=1`` or a misspelt ``namspace:=sat1`` used to be accepted silently (the nodes started on their defaults).
Now the launch ends before any node starts, non-zero, with one line naming the unknown argument and the known
ones. A launch file that includes ``pmv.launch.py`` keeps working with configurations of its own (the included
file sees them, and cannot tell them from a misspelt argument, so it leaves them alone). Run as
tests/system/test_launch.py runs the launch (colcon build, the vendored ros2cli and launch in a venv copy);
without ``../shared/vendor`` (or ``PMV_ROS_VENDOR``) the module is skipped.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
from children import VENDOR, VENDOR_INSTALLER, domain_id, install_env

pytestmark = [
    pytest.mark.launch,
    pytest.mark.skipif(not VENDOR_INSTALLER.is_file(),
                       reason=f"no {VENDOR} (vendored ros2 launch snapshots): not tested"),
    pytest.mark.multi_process,
    pytest.mark.xdist_group("ros_workspace"),
]

#: The colcon and launch tests' domain block: they share a worker, so they never run children at once.
DOMAIN_ID = domain_id(0)
#: A refusal comes before any node starts; a cold start of the launch tools on a busy 2-core machine takes seconds.
REFUSAL_TIMEOUT_S = 60.0
#: First "process started" of a node after a cold start, s.
START_TIMEOUT_S = 60.0

KNOWN = ("preset", "follow", "fast_time", "time_scale", "use_sim_time", "namespace", "rate_hz", "seed", "log_level",
         "respawn", "star_tracker", "monitor", "controller", "managed", "autostart")

#: A user's launch file that declares an argument of its own and includes pmv.launch.py (one node only).
INCLUDER = """
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration
from ament_index_python.packages import get_package_share_directory

def generate_launch_description():
    pmv = get_package_share_directory("pmv_ros") + "/launch/pmv.launch.py"
    return LaunchDescription([
        DeclareLaunchArgument("use_rviz", default_value="false"),
        IncludeLaunchDescription(PythonLaunchDescriptionSource(pmv), launch_arguments={
            "namespace": "sat1", "star_tracker": "false", "monitor": "false"}.items()),
    ])
"""


def launch(install: Path, tools: Path, work: Path, *arguments: str) -> tuple[subprocess.Popen, Path]:
    """``ros2 launch ARGUMENTS`` as a user runs it after sourcing the workspace and the tools; (process, log)."""
    work.mkdir(parents=True, exist_ok=True)
    env = install_env(install, work / "ros_log", DOMAIN_ID)
    env.update(VIRTUAL_ENV=str(tools), PATH=os.pathsep.join([str(tools / "bin"), env.get("PATH", "")]),
               AMENT_PREFIX_PATH=os.pathsep.join([env["AMENT_PREFIX_PATH"], str(tools)]), PYTHONUNBUFFERED="1",
               TMPDIR=str(work))
    log = work / "launch.log"
    with open(log, "wb") as sink:
        process = subprocess.Popen([str(tools / "bin/ros2"), "launch", *arguments], env=env, cwd=work,
                                   stdin=subprocess.DEVNULL, stdout=sink, stderr=subprocess.STDOUT,
                                   start_new_session=True)
    return process, log


def stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()


@pytest.mark.parametrize("arguments, named", [
    (("bogus:=1",), "unknown launch argument bogus:=1;"),
    (("namspace:=sat1",), "unknown launch argument namspace:=sat1 (did you mean namespace?);"),
    (("preset:=meteor_m2", "rate:=5", "seeed:=3"), "unknown launch arguments rate:=5 (did you mean rate_hz?), "
                                                   "seeed:=3 (did you mean seed?);"),
])
def test_an_unknown_launch_argument_is_refused_in_one_line(colcon_install, ros_tools, tmp_path, arguments, named):
    process, log = launch(colcon_install, ros_tools, tmp_path, "pmv_ros", "pmv.launch.py", *arguments)
    try:
        process.wait(timeout=REFUSAL_TIMEOUT_S)
    finally:
        stop(process)
    text = log.read_text(errors="replace")
    errors = [line for line in text.splitlines() if "ERROR" in line]
    assert process.returncode != 0, text
    assert len(errors) == 1 and "Traceback" not in text, text
    assert named in errors[0] and errors[0].endswith("the arguments are " + ", ".join(KNOWN)), errors[0]
    assert "process started" not in text, f"a node started:\n{text}"


def test_a_launch_file_including_pmv_keeps_its_own_arguments(colcon_install, ros_tools, tmp_path):
    includer = tmp_path / "user.launch.py"
    includer.write_text(INCLUDER)
    process, log = launch(colcon_install, ros_tools, tmp_path / "run", str(includer), "use_rviz:=true")
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while "process started" not in log.read_text(errors="replace"):
            assert process.poll() is None, f"ros2 launch exited with {process.returncode}:\n{log.read_text()}"
            assert time.monotonic() < deadline, f"no node started in {START_TIMEOUT_S:g} s:\n{log.read_text()}"
            time.sleep(0.2)
    finally:
        stop(process)
    assert "unknown launch argument" not in log.read_text(errors="replace")


def _wait(process: subprocess.Popen, timeout_s: float) -> float:
    started = time.monotonic()
    try:
        process.wait(timeout=timeout_s)
    finally:
        stop(process)
    return time.monotonic() - started


def test_what_the_nodes_would_refuse_is_refused_by_the_launch(colcon_install, ros_tools, tmp_path):
    """A namespace too long for the nodes' names, a preset that is a YAML list, a preset past the nodes' size
    bound (with a namespace, which made the launch read it whole): one line, non-zero, before any node starts."""
    (tmp_path / "list.yaml").write_text("- sensor_node\n- ros__parameters\n")
    big = tmp_path / "big.yaml"
    big.write_text("sensor_node:\n  ros__parameters:\n    seed: 1\n" + "# padding\n" * 200_000)  # 2 MiB > 1 MiB
    cases = {"namespace": ("namespace:=" + "n" * 225, "too long"),
             "list": (f"preset:={tmp_path / 'list.yaml'}", "not a list"),
             "big": (f"preset:={big}", "namespace:=sat1", "more than the 1048576 allowed")}
    started = {case: launch(colcon_install, ros_tools, tmp_path / case, "pmv_ros", "pmv.launch.py", *arguments)
               for case, (*arguments, _) in cases.items()}
    took = {case: _wait(process, REFUSAL_TIMEOUT_S) for case, (process, _) in started.items()}
    for case, (process, log) in started.items():
        text = log.read_text(errors="replace")
        errors = [line for line in text.splitlines() if "ERROR" in line]
        assert process.returncode not in (0, None), f"{case}: exit {process.returncode}\n{text}"
        assert len(errors) == 1 and cases[case][-1] in errors[0] and "Traceback" not in text, f"{case}:\n{text}"
        assert "process started" not in text, f"{case}: a node started\n{text}"
    print("refused by the launch: " + ", ".join(f"{case} exit {process.returncode} in {took[case]:.1f} s"
                                                for case, (process, _) in started.items()))


def test_a_node_dying_at_start_up_ends_the_launch_non_zero(colcon_install, ros_tools, tmp_path):
    """A preset the launch cannot judge (a value out of range: the node's own check) stops the sensor node at
    start-up; the launch used to run on and exit 0. Now it ends, non-zero, naming the node."""
    preset = tmp_path / "fast.yaml"
    preset.write_text("sensor_node:\n  ros__parameters:\n    sensor.rate_hz: 500.0\n")
    process, log = launch(colcon_install, ros_tools, tmp_path / "run", "pmv_ros", "pmv.launch.py",
                          f"preset:={preset}")
    took = _wait(process, START_TIMEOUT_S)
    text = log.read_text(errors="replace")
    assert process.returncode not in (0, None), f"exit {process.returncode}\n{text}"
    assert "sensor_node: invalid parameter: sensor.rate_hz" in text, text
    ended = [line for line in text.splitlines() if "exited with status 1 at start-up" in line]
    assert len(ended) == 1 and "sensor_node" in ended[0] and "Traceback" not in text, text
    print(f"a node dying at start-up: ros2 launch exit {process.returncode} after {took:.1f} s")


def _pids(text: str) -> list[int]:
    import re

    return [int(pid) for pid in re.findall(r"process started with pid \[(\d+)\]", text)]


def test_sigterm_to_the_launch_leaves_no_node_running(colcon_install, ros_tools, tmp_path):
    """``ros2 launch`` ends on SIGTERM without stopping its children (launch's own behaviour); the nodes it
    started stop by themselves when it is gone (``--stop-with-parent``), within seconds."""
    process, log = launch(colcon_install, ros_tools, tmp_path, "pmv_ros", "pmv.launch.py")
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while len(_pids(log.read_text(errors="replace"))) < 3 or "attitude from" not in log.read_text(errors="replace"):
            assert process.poll() is None, log.read_text()
            assert time.monotonic() < deadline, log.read_text()
            time.sleep(0.2)
        pids = _pids(log.read_text(errors="replace"))
        started = time.monotonic()
        process.send_signal(signal.SIGTERM)
        process.wait(timeout=REFUSAL_TIMEOUT_S)
        launch_s = time.monotonic() - started
        deadline = time.monotonic() + 10.0
        while any(Path(f"/proc/{pid}").exists() and "zombie" not in _state(pid) for pid in pids):
            if time.monotonic() > deadline:
                break
            time.sleep(0.1)
        left = [pid for pid in pids if Path(f"/proc/{pid}").exists() and "zombie" not in _state(pid)]
        nodes_s = time.monotonic() - started
    finally:
        stop(process)
        for pid in _pids(log.read_text(errors="replace")):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
    assert not left, f"nodes still running 10 s after SIGTERM to ros2 launch: {left}\n{log.read_text()}"
    print(f"SIGTERM: ros2 launch exit {process.returncode} in {launch_s:.1f} s, its {len(pids)} nodes gone "
          f"{nodes_s:.1f} s after the signal")


def _state(pid: int) -> str:
    try:
        return next(line for line in Path(f"/proc/{pid}/status").read_text().splitlines()
                    if line.startswith("State:")).lower()
    except (OSError, StopIteration):
        return "zombie"
