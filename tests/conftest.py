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
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

# In-process node tests are isolated from other ROS graphs on this machine;
# rclpy.init() needs a writable log directory.
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF")
os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="pmv_ros_test_log_"))
os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
# A run started in the background by a non-interactive shell (`make test &`) has SIGINT ignored, and an ignored
# signal stays ignored across exec: every child (ros2 launch, the nodes) would ignore the SIGINT the tests send
# it. With a handler here, the children start with the default action.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

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


#: Test modules whose tests run processes that talk to each other or to the test (a DDS domain, ros2 launch, a
#: Dask cluster, signals to a recording child): where a wait on the wrong condition is a race.
#: ``tools/flake_hunt.py`` repeats these and the serial modules under load.
MULTI_PROCESS_MODULES = (
    "tests/system/test_adversarial.py",
    "tests/system/test_hostile_clock.py",
    "tests/system/test_hostile_inputs.py",
    "tests/system/test_hostile_lifecycle.py",
    "tests/system/test_parameter_storm.py",
    "tests/system/test_fleet.py",
    "tests/system/test_shutdown.py",
    "tests/system/test_recording_survives.py",
    "tests/system/test_colcon.py",
    "tests/system/test_launch.py",
    "tests/system/test_tf_vendored.py",
    "tests/system/test_campaign_dask.py",
)


#: pytest-timeout's limit (pyproject.toml has the default, 600 s: ≈ 4× the slowest test on a loaded machine) for a test of a module that uses a session
#: fixture built early (it may wait for the build: the colcon build, the vendored tools, the Kondor orbit), and for
#: the full-length runs of tests marked ``long`` (--run-long: the 24 h soak takes ≈ 20 min).
EARLY_USER_TIMEOUT_S, LONG_RUN_TIMEOUT_S = 900, 3600


def pytest_collection_modifyitems(config, items):
    """Mark the tests of the serial modules ``serial``; give longer timeouts where the wait is known to be long."""
    early_users = {module for users in EARLY_USERS.values() for module in users}
    run_long = config.getoption("--run-long")
    for item in items:
        module = Path(str(item.path)).resolve().relative_to(REPO).as_posix()
        if module in SERIAL_MODULES:
            item.add_marker(pytest.mark.serial)
        if item.get_closest_marker("timeout") is None:
            if run_long and item.get_closest_marker("long") is not None:
                item.add_marker(pytest.mark.timeout(LONG_RUN_TIMEOUT_S))
            elif module in early_users:
                item.add_marker(pytest.mark.timeout(EARLY_USER_TIMEOUT_S))


def pytest_ignore_collect(collection_path, config):
    """``-m serial`` (the second half of ``make test``) collects only the serial modules: importing and collecting
    the other thousand tests to deselect them took ≈ 20 s of a loaded 2-core machine."""
    if config.getoption("markexpr", "") != "serial" or collection_path.suffix != ".py":
        return None
    if not collection_path.name.startswith("test_"):
        return None
    try:
        module = collection_path.resolve().relative_to(REPO).as_posix()
    except ValueError:
        return None
    return True if module not in SERIAL_MODULES else None


#: What a group costs on one worker of ``make test`` (2 cores, the rest of the suite beside it), s, measured
#: with ``--durations``; the longest groups start first, so that the two workers finish together. A group not
#: listed counts a quarter second a test. The early work below is not in these figures.
GROUP_COST_S = {
    "colcon_install": 100.0,  # the colcon test, ros2 launch (seven launches), tf with the vendored tf2_msgs
    "tests/system/test_campaign_dask.py": 45.0,
    "tests/apps/test_campaign_trust.py": 35.0,
    "tests/system/test_recording_survives.py": 65.0,
    "kondor_orbit_run": 45.0,  # the recording and main-job tests beside the shared orbit
    "tests/nodes/test_faults.py": 28.0,
    "tests/system/test_shutdown.py": 35.0,
    "tests/system/test_golden.py": 32.0,
    "tests/runtime/test_flight_environment.py": 31.0,
    "tests/physics/test_environment.py": 28.0,
    "tests/hosts/test_basilisk.py": 25.0,
    "tests/physics/test_flight_records.py": 24.0,
    "tests/runtime/test_validation.py": 24.0,
    "tests/runtime/test_parameters.py": 23.0,
    "tests/system/test_hostile_files.py": 22.0,
    "tests/nodes/test_follow_hiccups.py": 21.0,
    "tests/nodes/test_statistics_topics.py": 19.0,
    "tests/apps/test_simulate_flight.py": 17.0,
    "tests/apps/test_campaign.py": 10.0,
    "tests/nodes/test_input_guards.py": 15.0,
    "tests/nodes/test_sim_clock.py": 12.0,
    "tests/system/test_tle_flight.py": 12.0,
    "tests/nodes/test_follow_orbit.py": 11.0,
    "tests/system/test_hostile_inputs.py": 45.0,    # round three (issue 29): child processes on a domain
    "tests/system/test_hostile_lifecycle.py": 40.0,
    "tests/system/test_fleet.py": 35.0,
    "tests/system/test_hostile_tle.py": 30.0,
    "tests/system/test_parameter_storm.py": 28.0,
}


@pytest.hookimpl(optionalhook=True)  # an xdist hook: unknown when the suite runs without it (-p no:xdist)
def pytest_xdist_make_scheduler(config, log):
    """Under ``pytest -n 2`` (``make test``): a test module runs whole on one worker (its module fixtures
    once), and modules that share a session fixture on the same one. The longest groups go first; a group
    whose session fixture is still being prepared early (below) waits while other groups are left."""
    from xdist.scheduler import LoadScopeScheduling

    class ModuleGroups(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            module = nodeid.split("::", 1)[0]
            return SHARED_FIXTURE_GROUPS.get(module, module)

        def _assign_work_unit(self, node) -> None:
            units = sorted(self.workqueue.items(), key=lambda unit: (
                not _early_ready(config, unit[0]), -GROUP_COST_S.get(unit[0], 0.25 * len(unit[1]))))
            self.workqueue.clear()
            self.workqueue.update(units)
            super()._assign_work_unit(node)

    return ModuleGroups(config, log)


# ------------------------------------------------------------------------------------------- early work
# Three session fixtures are a child process each (the vendored ROS tools' install, the colcon build, the
# Kondor orbit of the main job). The process that hands out the tests (the xdist controller, or the only
# process without xdist) starts them in the background, at a lower priority, as soon as the collection
# shows a test that needs them; the fixture then waits for the result instead of starting the same command
# itself. The commands, their environments and every check on their output are the fixtures' own.

#: Each early fixture: the test modules that use it.
EARLY_USERS = {
    "ros_tools": ("tests/system/test_launch.py", "tests/system/test_tf_vendored.py"),
    "colcon_install": ("tests/system/test_colcon.py", "tests/system/test_launch.py"),
    "kondor_orbit_run": ("tests/apps/test_recording.py", "tests/system/test_main_job.py"),
}
#: Where the early work runs (set by the process that starts it; the xdist workers inherit it).
EARLY_ENV = "PMV_ROS_TEST_EARLY_DIR"
#: ``nice`` increment of the early work, and ``ionice`` idle class where there is one (the tool install copies the
#: venv): the tests running meanwhile keep their share of the cores and the disk.
EARLY_NICE = 10
EARLY_PRIORITY = ["nice", "-n", str(EARLY_NICE), *(["ionice", "-c", "3"] if shutil.which("ionice") else [])]


def _early_commands(name: str, work: Path) -> tuple[list, dict, Path, int] | None:
    """(command, environment, working directory, timeout s) of early fixture ``name`` in folder ``work``,
    or None when the fixture would skip."""
    if name == "ros_tools":
        from children import VENDOR_INSTALLER

        if not VENDOR_INSTALLER.is_file():
            return None
        base = Path(sys.executable).parent.parent
        return ["bash", str(VENDOR_INSTALLER), str(base), str(work)], dict(os.environ), work, 600
    if name == "colcon_install":
        if _colcon_missing():
            return None
        env = {name: value for name, value in os.environ.items() if name != "COLCON_DEFAULTS_FILE"}
        env["COLCON_HOME"] = str(work / "colcon_home")  # no user defaults or mixins
        command = [sys.executable, "-c", "import sys; from colcon_core.command import main; sys.exit(main())",
                   "--log-base", str(work / "log"),
                   "build", "--base-paths", str(REPO), "--packages-select", "pmv_ros",
                   "--build-base", str(work / "build"), "--install-base", str(work / "install")]
        return command, env, work, 300
    if name == "kondor_orbit_run":
        command = [sys.executable, "-m", "pmv_ros.cli", "simulate", "--config", str(REPO / "config" / "kondor.yaml"),
                   "--orbits", "1", "--rate-hz", "1", "--record", str(work / "run.mcap"), "--report",
                   str(work / "report"), "--json", "--quiet"]
        return command, dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="OFF"), REPO, 600
    raise KeyError(name)


def _early_dir(config) -> Path | None:
    directory = getattr(config, "_pmv_early_dir", None) or os.environ.get(EARLY_ENV)
    return Path(directory) if directory else None


def _early_ready(config, scope: str) -> bool:
    """False while early work that the tests of group ``scope`` need is still running (the controller's view)."""
    directory = _early_dir(config)
    if directory is None:
        return True
    modules = [module for module, group in SHARED_FIXTURE_GROUPS.items() if group == scope] or [scope]
    return all((directory / name / "status").exists() or not (directory / name).exists()
               for name, users in EARLY_USERS.items() if set(users) & set(modules))


def _start_early(config, nodeids) -> None:
    """Start the early fixtures that the collected tests ``nodeids`` use (once a run)."""
    directory = _early_dir(config)
    if directory is None or getattr(config, "_pmv_early_started", False):
        return
    config._pmv_early_started = True
    modules = {nodeid.split("::", 1)[0] for nodeid in nodeids}
    for name, users in EARLY_USERS.items():
        if not modules & set(users):
            continue
        work = directory / name
        if (work / "status").exists():  # a folder kept across runs (tools/flake_hunt.py): done, reused
            continue
        shutil.rmtree(work, ignore_errors=True)  # a kept folder's work that never ended: started again
        (work / "out").mkdir(parents=True)
        planned = _early_commands(name, work / "out")
        if planned is None:
            (work / "out").rmdir()  # the fixture skips, as without early work
            continue
        command, env, cwd, timeout = planned
        (work / "repo_before").write_text("\n".join(sorted(path.name for path in REPO.iterdir())))
        # The status file appears, whole, when the command has ended: its exit status, or "timeout".
        runner = ("import subprocess, sys, os\n"
                  "work, timeout, command = sys.argv[1], float(sys.argv[2]), sys.argv[3:]\n"
                  "with open(os.path.join(work, 'stdout'), 'w') as out, open(os.path.join(work, 'stderr'), 'w') as err:\n"
                  "    try:\n"
                  "        status = str(subprocess.run(command, stdout=out, stderr=err, timeout=timeout).returncode)\n"
                  "    except subprocess.TimeoutExpired:\n"
                  "        status = 'timeout'\n"
                  "with open(os.path.join(work, 'status.part'), 'w') as done:\n"
                  "    done.write(status)\n"
                  "os.replace(os.path.join(work, 'status.part'), os.path.join(work, 'status'))\n")
        process = subprocess.Popen([*EARLY_PRIORITY, sys.executable, "-c", runner, str(work), str(timeout),
                                    *map(str, command)],
                                   env=env, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                   stderr=subprocess.DEVNULL, start_new_session=True)
        config._pmv_early_processes.append(process)


def _early_result(name: str, timeout_s: float) -> tuple[Path, subprocess.CompletedProcess, set] | None:
    """In a fixture: (the output folder, the finished command's status and output, the repository's top-level
    names when it started) of early work ``name``, once it has ended; None when it was not started early
    (the fixture runs the command itself)."""
    directory = os.environ.get(EARLY_ENV)
    work = Path(directory) / name if directory else None
    if work is None or not (work / "out").is_dir():
        return None
    deadline = time.monotonic() + timeout_s
    while not (work / "status").exists():
        if time.monotonic() > deadline:
            pytest.fail(f"the early {name} did not end within {timeout_s:g} s")
        time.sleep(0.2)
    status = (work / "status").read_text()
    if status == "timeout":
        pytest.fail(f"the early {name} timed out")
    return (work / "out",
            subprocess.CompletedProcess(name, int(status), (work / "stdout").read_text(errors="replace"),
                                        (work / "stderr").read_text(errors="replace")),
            set((work / "repo_before").read_text().split("\n")))


def _run_session_command(name: str, tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess, set]:
    """Early fixture ``name``'s command: its early run's result, or run here now; as ``_early_result``."""
    early = _early_result(name, 900.0)
    if early is not None:
        return early
    work = tmp_path_factory.mktemp(name)
    command, env, cwd, timeout = _early_commands(name, work)
    before = {path.name for path in REPO.iterdir()}
    result = subprocess.run(command, env=env, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    return work, result, before


@pytest.hookimpl(trylast=True)  # after the tmp_path plugin's
def pytest_configure(config):
    """The process that hands out the tests gets a folder for early work in the run's base temporary folder
    (kept and cleaned up as ``tmp_path_factory`` keeps its own); xdist workers inherit it."""
    config._pmv_early_processes = []
    if hasattr(config, "workerinput"):
        return
    if os.environ.get(EARLY_ENV):  # given from outside (tools/flake_hunt.py): kept across runs
        config._pmv_early_dir, config._pmv_early_kept = os.environ[EARLY_ENV], True
        return
    directory = config._tmp_path_factory.getbasetemp() / "early"
    directory.mkdir()
    config._pmv_early_dir = str(directory)
    os.environ[EARLY_ENV] = config._pmv_early_dir


def pytest_unconfigure(config):
    """Early work still running when the run ends (its tests deselected or failed) is stopped."""
    for process in getattr(config, "_pmv_early_processes", ()):
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    if getattr(config, "_pmv_early_dir", None) and not getattr(config, "_pmv_early_kept", False):
        os.environ.pop(EARLY_ENV, None)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_node_collection_finished(node, ids):
    """The xdist controller: a worker has collected; start what its tests need early."""
    _start_early(node.config, ids)


def pytest_collection_finish(session):
    """Without xdist: start the early work once the tests are known (the first ones run meanwhile)."""
    if not hasattr(session.config, "workerinput") and getattr(session.config, "_pmv_early_dir", None):
        _start_early(session.config, [item.nodeid for item in session.items])


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
    physics is the same), started early (above). (simulate's JSON, the MCAP file, the report folder)."""
    import json
    from types import SimpleNamespace

    work, result, _ = _run_session_command("kondor_orbit_run", tmp_path_factory)
    assert result.returncode == 0, result.stderr
    return SimpleNamespace(summary=json.loads(result.stdout), mcap=work / "run.mcap", report=work / "report")


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
    """A venv copy with ros2cli, launch, launch_ros and tf2_msgs (../shared/vendor/install-ros-tools.sh), once per
    run, started early (above).

    Skips when the vendored snapshots are not there (users without them still get a green run).
    """
    from children import VENDOR, VENDOR_INSTALLER

    if not VENDOR_INSTALLER.is_file():
        pytest.skip(f"no {VENDOR} (vendored ROS 2 tool snapshots): not tested")
    work, result, _ = _run_session_command("ros_tools", tmp_path_factory)
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
    """``colcon build`` of this repository into a temporary workspace, once per run, started early (above);
    the install base."""
    reason = _colcon_missing()
    if reason:
        pytest.skip(reason)
    leftovers = ("build", "install", "log", "pmv_ros.egg-info")
    workspace, result, present_before = _run_session_command("colcon_install", tmp_path_factory)
    assert result.returncode == 0, f"colcon build failed:\n{result.stdout}\n{result.stderr}"
    assert "1 package finished" in result.stdout, result.stdout
    left = {name for name in leftovers if (REPO / name).exists()} - present_before
    assert not left, f"colcon build left {sorted(left)} in the repository"
    return workspace / "install"
