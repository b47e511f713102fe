"""Test configuration: ROS isolation, how tests group themselves, the --run-long switch, shared fixtures.

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
# One cache of compiled kernels for every process of the run (pmv_ros.physics.compiled): the xdist workers, the nodes
# they start, and the colcon-installed copy of the package that ros2 launch starts (the same sources: the same
# cache files). In the venv, whose numba compiled them.
os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(sys.prefix) / "numba_cache"))
# A run started in the background by a non-interactive shell (`make test &`) has SIGINT ignored, and an ignored
# signal stays ignored across exec: every child (ros2 launch, the nodes) would ignore the SIGINT the tests send
# it. With a handler here, the children start with the default action.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

REPO = Path(__file__).resolve().parents[1]


# ------------------------------------------------------------------------------------------- grouping
# Every test module says what it is in its own ``pytestmark``: ``serial`` (its figures are rates of wall time:
# ``make test`` runs it after the parallel part, alone), ``multi_process`` (its tests start child processes:
# nodes on a DDS domain, ros2 launch, a Dask cluster, pmv in a child — tools/flake_hunt.py repeats these under
# load) and ``xdist_group(NAME)`` when it uses a session fixture that runs a long command once per run
# (SESSION_RUNS): under ``pytest -n 3 --dist loadgroup`` every test of a group runs on one worker, so the command
# runs once. A group ``NAME/PART`` shares the fixture's command too (it runs once, early, for the whole run, and
# each worker reads its result): a module whose tests mostly wait — on `ros2 lifecycle` processes, say — takes a
# part of its own and runs beside the group on another worker. A test module without an explicit group is a group
# of its own (its module fixtures run once).
# Two checks keep the marks true when files are renamed or tests added: a test that uses a SESSION_RUNS fixture
# outside its group fails the collection, and a test that starts a process in a module not marked
# ``multi_process`` fails (the audit hook below sees every subprocess, fork and exec of the test process).

#: Session fixtures that run one long command a run (started early, below), and the xdist group of their users.
#: The vendored ROS tools and the colcon build share one: the launch tests use both.
SESSION_RUNS = {"ros_tools": "ros_workspace", "colcon_install": "ros_workspace", "kondor_orbit_run": "kondor_orbit_run"}

#: The mark of a module whose tests start processes (pyproject.toml declares the marks).
MULTI_PROCESS = "multi_process"

#: pytest-timeout's limit (pyproject.toml has the default, 600 s: ≈ 4× the slowest test on a loaded machine) for a
#: test that uses a SESSION_RUNS fixture (it may wait for its command: the colcon build, the vendored tools, the
#: Kondor orbit), and for the full-length runs of tests marked ``long`` (--run-long: the 24 h soak takes ≈ 20 min).
EARLY_USER_TIMEOUT_S, LONG_RUN_TIMEOUT_S = 900, 3600


def _module(item) -> str:
    return Path(str(item.path)).resolve().relative_to(REPO).as_posix()


def _group(item) -> str | None:
    mark = item.get_closest_marker("xdist_group")
    if mark is None:
        return None
    return str(mark.args[0] if mark.args else mark.kwargs.get("name", "default"))


def _session_group(item) -> str | None:
    """The xdist group a test must be in for the SESSION_RUNS fixtures it uses; UsageError for two of them."""
    groups = {SESSION_RUNS[name] for name in item.fixturenames if name in SESSION_RUNS}
    if len(groups) > 1:
        raise pytest.UsageError(f"{item.nodeid} uses session fixtures of groups {sorted(groups)}: one test can "
                                "share a worker with one group only (tests/conftest.py, SESSION_RUNS)")
    return groups.pop() if groups else None


def _order(items) -> list:
    """The tests in the order ``--dist loadgroup --no-loadscope-reorder`` hands their groups out, each group's tests
    together and in collection order: first the parts of SESSION_RUNS groups (``NAME/PART``: modules that mostly
    wait; a worker waiting on them, for the fixture's command and then on their children, leaves the cores to the
    other workers), then the groups that start processes (much of their time is waiting on children, and the longest
    tests are among them), then the other users of SESSION_RUNS fixtures (their commands run in the background
    meanwhile), then the rest, whose many short modules let the workers finish together. A part handed out late
    is the last to end, the other workers idle."""
    first, session_users, multi_process = {}, set(), set()
    for index, item in enumerate(items):
        group = _group(item)
        first.setdefault(group, index)
        if any(name in SESSION_RUNS for name in item.fixturenames):
            session_users.add(group)
        if item.get_closest_marker(MULTI_PROCESS) is not None:
            multi_process.add(group)

    def rank(group):
        if group in session_users:
            return 0 if group not in SESSION_RUNS.values() else 2  # NAME/PART, or NAME itself
        return 1 if group in multi_process else 3

    return sorted(items, key=lambda item: (rank(_group(item)), first[_group(item)]))


@pytest.hookimpl(tryfirst=True)  # before xdist's own, which reads the groups
def pytest_collection_modifyitems(config, items):
    """Check the groups of the SESSION_RUNS users, give every other module a group of its own, order the groups
    (:func:`_order`), and give longer timeouts where the wait is known to be long."""
    run_long = config.getoption("--run-long")
    for item in items:
        needed, group = _session_group(item), _group(item)
        if needed is not None and group != needed and not (group or "").startswith(needed + "/"):
            raise pytest.UsageError(
                f"{_module(item)} uses a session fixture of group {needed!r} "
                f"({', '.join(sorted(name for name in item.fixturenames if name in SESSION_RUNS))}) but is "
                f"{'in group ' + repr(group) if group else 'in no group'}: add pytest.mark.xdist_group({needed!r}) "
                "to its pytestmark, so that its tests share the worker that runs the fixture's command")
        if group is None:  # a group of its own, named by its path without tests/ and .py
            item.add_marker(pytest.mark.xdist_group(_module(item).removeprefix("tests/").removesuffix(".py")))
        if item.get_closest_marker("timeout") is None:
            if run_long and item.get_closest_marker("long") is not None:
                item.add_marker(pytest.mark.timeout(LONG_RUN_TIMEOUT_S))
            elif needed is not None:
                item.add_marker(pytest.mark.timeout(EARLY_USER_TIMEOUT_S))
    items[:] = _order(items)


def pytest_ignore_collect(collection_path, config):
    """``-m serial`` (the second half of ``make test``) and ``-m "serial or multi_process"`` (tools/flake_hunt.py)
    import only the test modules whose text carries one of the marks: importing and collecting the other thousand
    tests to deselect them took ≈ 20 s of a loaded 2-core machine. Any other expression collects everything."""
    names = _marks_selected_alone(config.getoption("markexpr", ""))
    if not names or collection_path.suffix != ".py" or not collection_path.name.startswith("test_"):
        return None
    try:
        text = collection_path.read_text(errors="replace")
    except OSError:
        return None
    return None if any(f"mark.{name}" in text for name in names) else True


def _marks_selected_alone(expression: str) -> tuple[str, ...]:
    """The mark names of an expression ``a``, ``a or b`` … (nothing else), or () for any other expression."""
    words = expression.split()
    names, operators = words[::2], words[1::2]
    if not words or len(words) % 2 == 0 or any(word != "or" for word in operators):
        return ()
    return tuple(names) if all(name.isidentifier() and name not in ("or", "and", "not") for name in names) else ()


@pytest.hookimpl(optionalhook=True)  # an xdist hook: unknown when the suite runs without it (-p no:xdist)
def pytest_xdist_node_collection_finished(node, ids):
    """Under ``--dist loadgroup`` every test's id carries its group; an id without one means this pytest-xdist
    cannot group with this pytest (pytest-dev/pytest-xdist#1386: pytest 9.2's ids): stop rather than run the
    groups' tests apart (the pins in requirements.txt go together)."""
    if node.config.getvalue("dist") == "loadgroup" and ids and not all("@" in nodeid for nodeid in ids):
        pytest.exit("--dist loadgroup: pytest-xdist left tests without their group (pytest "
                    f"{pytest.__version__}; see requirements.txt)", returncode=pytest.ExitCode.USAGE_ERROR)


# ------------------------------------------------------------------------------------------- processes
#: Audit events of a process being started (the stdlib raises them; multiprocessing's spawn and forkserver start
#: methods raise none, and no test starts processes that way).
PROCESS_EVENTS = frozenset({"subprocess.Popen", "os.fork", "os.forkpty", "os.posix_spawn", "os.spawn", "os.system",
                            "os.exec"})
_running = {"item": None, "started": None}


def _audit(event, arguments):
    if event in PROCESS_EVENTS and _running["item"] is not None and _running["started"] is None:
        _running["started"] = f"{event} {str(arguments[0])[:80]}"


sys.addaudithook(_audit)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item, nextitem):
    _running["item"], _running["started"] = item, None
    try:
        return (yield)
    finally:
        _running["item"] = _running["started"] = None


@pytest.hookimpl(wrapper=True)
def pytest_runtest_teardown(item, nextitem):
    """A test that started a process (in its set-up, call or tear-down) must be in a module marked multi_process."""
    result = yield
    if _running["started"] is not None and item.get_closest_marker(MULTI_PROCESS) is None:
        pytest.fail(f"{item.nodeid} started a process ({_running['started']}) but {_module(item)} is not marked "
                    f"{MULTI_PROCESS}: add pytest.mark.{MULTI_PROCESS} to its pytestmark", pytrace=False)
    return result


# ------------------------------------------------------------------------------------------- early work
# The SESSION_RUNS fixtures are a child process each (the vendored ROS tools' install, the colcon build, the
# Kondor orbit of the main job). The first process of a run to collect a test that uses one (an xdist worker, or
# the only process without xdist) starts it in the background, at a lower priority; the fixture then waits for
# the result instead of starting the same command itself. The commands, their environments and every check on
# their output are the fixtures' own.

#: Where the early work runs (set by the process that hands out the tests; the xdist workers inherit it).
EARLY_ENV = "PMV_ROS_TEST_EARLY_DIR"
#: The run that started a piece of early work: a folder kept across runs, or a pytest run inside a test, must not
#: stop or remove work another run started.
RUN_ENV = "PMV_ROS_TEST_RUN"
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


#: The early work's runner: the command, its output in files, and a status file that appears, whole, when the
#: command has ended (its exit status, or "timeout").
_RUNNER = ("import subprocess, sys, os\n"
           "work, timeout, command = sys.argv[1], float(sys.argv[2]), sys.argv[3:]\n"
           "with open(os.path.join(work, 'stdout'), 'w') as out, open(os.path.join(work, 'stderr'), 'w') as err:\n"
           "    try:\n"
           "        status = str(subprocess.run(command, stdout=out, stderr=err, timeout=timeout).returncode)\n"
           "    except subprocess.TimeoutExpired:\n"
           "        status = 'timeout'\n"
           "with open(os.path.join(work, 'status.part'), 'w') as done:\n"
           "    done.write(status)\n"
           "os.replace(os.path.join(work, 'status.part'), os.path.join(work, 'status'))\n")


def _start_early(items) -> None:
    """Start the early work of the SESSION_RUNS fixtures that ``items`` use, unless another process of the run has.

    The work's folder is prepared under a name of this process's own and renamed into place: a rename onto a
    folder that is there fails, so one process starts each command, and a fixture sees the folder whole or not
    at all.
    """
    directory = os.environ.get(EARLY_ENV)
    if not directory:
        return
    wanted = {name for item in items for name in item.fixturenames if name in SESSION_RUNS}
    for name in sorted(wanted):
        work = Path(directory) / name
        if work.exists():  # started by another process of this run, or done in an earlier run of a kept folder
            continue
        draft = Path(directory) / f".{name}.{os.getpid()}"
        (draft / "out").mkdir(parents=True)
        planned = _early_commands(name, work / "out")
        if planned is None:  # the fixture skips, as without early work
            shutil.rmtree(draft)
            continue
        (draft / "repo_before").write_text("\n".join(sorted(path.name for path in REPO.iterdir())))
        (draft / "run").write_text(os.environ.get(RUN_ENV, ""))
        (draft / "maker").write_text(str(os.getpid()))
        try:
            draft.rename(work)
        except OSError:  # another process was first
            shutil.rmtree(draft, ignore_errors=True)
            continue
        command, env, cwd, timeout = planned
        process = subprocess.Popen([*EARLY_PRIORITY, sys.executable, "-c", _RUNNER, str(work), str(timeout),
                                    *map(str, command)],
                                   env=env, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                   stderr=subprocess.DEVNULL, start_new_session=True)
        (work / "pid").write_text(str(process.pid))


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


def _unfinished_early_work(directory: Path):
    """The folders of early work in ``directory`` whose command has not ended (drafts included)."""
    return [work for work in directory.iterdir() if work.is_dir() and not (work / "status").exists()]


def _alive(pid_text: str) -> bool:
    """Whether the process of a pid (text) is alive."""
    try:
        os.kill(int(pid_text), 0)
    except (ValueError, ProcessLookupError):
        return False
    except PermissionError:
        return True
    return True


def _abandoned(work: Path) -> bool:
    """Early work that no live process will finish: its runner and the process that made it have gone."""
    if work.name.startswith("."):  # a draft: .NAME.PID
        return not _alive(work.name.rsplit(".", 1)[-1])
    return not any(path.exists() and _alive(path.read_text()) for path in (work / "pid", work / "maker"))


#: Presets flown for a few ticks before the tests (:func:`_warm_kernels`): between them every compiled kernel of the
#: sensor and the star tracker, with the argument types the nodes give them.
WARM_PRESETS = ("config/kondor.yaml", "config/meteor_m2_tle.yaml")
_WARM = ("import contextlib, io, sys\n"
         "from pmv_ros.cli import main\n"
         "for config in sys.argv[1:]:\n"
         "    with contextlib.redirect_stdout(io.StringIO()):\n"
         "        status = main(['simulate', '--config', config, '--orbits', '0.0005', '--quiet', '--json'])\n"
         "    if status:\n"
         "        sys.exit(f'pmv simulate --config {config}: status {status}')\n")


def _warm_kernels() -> None:
    """Compile the kernels into the run's cache once, in one process, before any test: otherwise each xdist
    worker and each node process a test starts before a first one has written the cache compiles them itself
    (≈ 15 s of CPU each, a node meanwhile deaf to SIGINT). Once per source tree and numba: a file in the cache
    folder says it was done. A failure here is left to the tests that fly the presets to show."""
    from pmv_ros.physics.compiled import cache_folder

    done = cache_folder() / "warm"
    if done.exists():
        return
    result = subprocess.run([sys.executable, "-c", _WARM, *WARM_PRESETS], cwd=REPO, stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, timeout=600)
    if result.returncode == 0:
        done.touch()


@pytest.hookimpl(trylast=True)  # after the tmp_path plugin's
def pytest_configure(config):
    """The process that hands out the tests gets a folder for early work in the run's base temporary folder
    (kept and cleaned up as ``tmp_path_factory`` keeps its own); xdist workers inherit it. A folder given from
    outside (tools/flake_hunt.py) is kept across runs: its finished work is reused, the rest started again."""
    if hasattr(config, "workerinput"):
        return
    if not config.option.collectonly:
        _warm_kernels()
    config._pmv_run = f"{os.getpid()}-{time.time_ns()}"
    os.environ[RUN_ENV] = config._pmv_run
    if os.environ.get(EARLY_ENV):
        config._pmv_early_dir, config._pmv_early_kept = Path(os.environ[EARLY_ENV]), True
        for work in _unfinished_early_work(config._pmv_early_dir):
            if _abandoned(work):
                shutil.rmtree(work, ignore_errors=True)
        return
    directory = config._tmp_path_factory.getbasetemp() / "early"
    directory.mkdir()
    config._pmv_early_dir, config._pmv_early_kept = directory, False
    os.environ[EARLY_ENV] = str(directory)


def pytest_unconfigure(config):
    """The process that handed out the tests stops the early work of its run still running when the run ends (its
    tests deselected or failed), whichever of its processes started it."""
    directory = getattr(config, "_pmv_early_dir", None)
    if directory is None:
        return
    for work in _unfinished_early_work(directory) if directory.is_dir() else ():
        try:
            if (work / "run").read_text() == config._pmv_run:
                os.killpg(int((work / "pid").read_text()), signal.SIGKILL)
        except (OSError, ValueError):  # ended meanwhile, or never started
            pass
    if not config._pmv_early_kept:
        os.environ.pop(EARLY_ENV, None)


@pytest.hookimpl(tryfirst=True)
def pytest_collection_finish(session):
    """Start the early work once the tests are known (the first ones run meanwhile); not for ``--collect-only``."""
    if not session.config.option.collectonly:
        _start_early(session.items)


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
