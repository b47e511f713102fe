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


#: Test modules that share a session fixture (its expensive run happens once per worker): one worker each.
SHARED_FIXTURE_GROUPS = {
    "tests/apps/test_recording.py": "kondor_orbit_run",   # and the main job: one Kondor orbit, recorded
    "tests/system/test_main_job.py": "kondor_orbit_run",
    "tests/system/test_colcon.py": "colcon_install",      # and the launch tests: one colcon build,
    "tests/system/test_launch.py": "colcon_install",      # one install of the vendored ROS tools
    "tests/system/test_tf_vendored.py": "colcon_install",
}

#: Test modules whose figures are rates of wall time (ticks a second, residuals a second, callback time):
#: marked ``serial``, and ``make test`` runs them after the two workers, alone on the machine.
SERIAL_MODULES = (
    "tests/nodes/test_load.py",
    "tests/system/test_adversarial.py",
    "tests/system/test_hostile_clock.py",
    "tests/system/test_soak.py",
)


def pytest_collection_modifyitems(config, items):
    """Mark the tests of the serial modules ``serial``."""
    for item in items:
        if Path(str(item.path)).resolve().relative_to(REPO).as_posix() in SERIAL_MODULES:
            item.add_marker(pytest.mark.serial)


@pytest.hookimpl(optionalhook=True)  # an xdist hook: unknown when the suite runs without it (-p no:xdist)
def pytest_xdist_make_scheduler(config, log):
    """Under ``pytest -n 2`` (``make test``): a test module runs whole on one worker (its module fixtures
    once), and modules that share a session fixture on the same one."""
    from xdist.scheduler import LoadScopeScheduling

    class ModuleGroups(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            module = nodeid.split("::", 1)[0]
            return SHARED_FIXTURE_GROUPS.get(module, module)

    return ModuleGroups(config, log)


def pytest_addoption(parser):
    parser.addoption("--run-long", action="store_true", default=False,
                     help="run the full-length soak/stress versions of tests marked 'long'")


@pytest.fixture
def run_long(request) -> bool:
    """True when the full-length soak/stress runs were asked for (--run-long)."""
    return bool(request.config.getoption("--run-long"))


@pytest.fixture(scope="session")
def kondor_orbit_run(tmp_path_factory):
    """The main job as a user runs it, once per test run, shared by the main-job and recording tests:
    ``pmv simulate --config config/kondor.yaml --orbits 1 --rate-hz 1 --record run.mcap --report report
    --json`` in a child process (one full orbit at 1 Hz: the 10 Hz of the preset takes ≈ 10× longer; the
    physics is the same). (simulate's JSON, the MCAP file, the report folder)."""
    import json
    from types import SimpleNamespace

    work = tmp_path_factory.mktemp("kondor_orbit")
    mcap, report = work / "run.mcap", work / "report"
    result = subprocess.run(
        [sys.executable, "-m", "pmv_ros.cli", "simulate", "--config", str(REPO / "config" / "kondor.yaml"),
         "--orbits", "1", "--rate-hz", "1", "--record", str(mcap), "--report", str(report), "--json", "--quiet"],
        capture_output=True, text=True, timeout=600, cwd=REPO,
        env=dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="OFF"))
    assert result.returncode == 0, result.stderr
    return SimpleNamespace(summary=json.loads(result.stdout), mcap=mcap, report=report)


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
