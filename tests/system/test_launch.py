"""``ros2 launch pmv_ros pmv.launch.py`` with the real launch tools (issue 13, points 1–2).

ros2cli, launch and launch_ros are not on the package registries; snapshots of
their Jazzy branches are in ``../shared/vendor`` with a recipe that installs
them into a copy of the venv (its README). This module builds the package
with colcon (the fixture of ``test_colcon.py``), installs the tools into a
copy of the venv, and runs ``ros2 launch`` as a user would after
``source install/setup.bash``: the three nodes start on the Kondor preset,
``/pmv/error_statistics`` arrives in this process on a ROS domain of the
test's own, and one SIGINT to the launch process (not its group: launch
forwards it) stops everything cleanly. With ``follow:=true`` nothing of the
package publishes ``/attitude/truth``; the sensor follows the truth this
test publishes. Without ``../shared/vendor`` (or ``PMV_ROS_VENDOR``) the module is skipped.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
import rclpy
import yaml
from children import VENDOR, VENDOR_INSTALLER, domain_id, install_env, join_domain
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from rclpy.executors import SingleThreadedExecutor
from rosgraph_msgs.msg import Clock

import pmv_msgs_shim as shim
from pmv_ros.physics.constants import ARCMIN_RAD

REPO = Path(__file__).resolve().parents[2]
#: The colcon test's domain (the same block): the two never run children at once.
DOMAIN_ID = domain_id(0)

pytestmark = [
    pytest.mark.launch,
    pytest.mark.skipif(not VENDOR_INSTALLER.is_file(),
                       reason=f"no {VENDOR} (vendored ros2 launch snapshots): not tested"),
    pytest.mark.multi_process,
    pytest.mark.xdist_group("ros_workspace"),
]

#: First messages after a cold start of four Python processes on a busy 2-core machine.
FIRST_MESSAGE_TIMEOUT_S = 60.0
SHUTDOWN_TIMEOUT_S = 20.0


def _launch_env(install: Path, tools: Path, log_dir: Path) -> dict:
    """What `source env.sh; source install/setup.bash; source env.sh` gives: the workspace, then the tools."""
    env = install_env(install, log_dir, DOMAIN_ID)
    env["VIRTUAL_ENV"] = str(tools)
    env["PATH"] = os.pathsep.join([str(tools / "bin"), env.get("PATH", "")])
    env["AMENT_PREFIX_PATH"] = os.pathsep.join([env["AMENT_PREFIX_PATH"], str(tools)])
    env["PYTHONUNBUFFERED"] = "1"
    env["TMPDIR"] = str(log_dir.parent / "tmp")  # where the launch writes its generated params files
    Path(env["TMPDIR"]).mkdir(exist_ok=True)
    return env


class Launched:
    """``ros2 launch pmv_ros pmv.launch.py ARGS`` as a child process, its output in a file."""

    def __init__(self, install: Path, tools: Path, tmp_path: Path, *arguments: str):
        self.output = tmp_path / "launch.log"
        with open(self.output, "wb") as sink:
            self.process = subprocess.Popen(
                [str(tools / "bin/ros2"), "launch", "pmv_ros", "pmv.launch.py", *arguments],
                env=_launch_env(install, tools, tmp_path / "ros_log"), cwd=tmp_path, stdin=subprocess.DEVNULL,
                stdout=sink, stderr=subprocess.STDOUT, start_new_session=True)

    def log(self) -> str:
        return self.output.read_text(errors="replace")

    def check_running(self) -> None:
        if self.process.poll() is not None:
            pytest.fail(f"ros2 launch exited with {self.process.returncode}:\n{self.log()}")

    def interrupt(self) -> float:
        """One SIGINT to the launch process; returns how long the shutdown took, s."""
        started = time.monotonic()
        self.process.send_signal(signal.SIGINT)
        try:
            self.process.wait(timeout=SHUTDOWN_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            pytest.fail(f"ros2 launch ignored SIGINT for {SHUTDOWN_TIMEOUT_S:g} s:\n{self.log()}")
        return time.monotonic() - started

    def kill(self) -> None:
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait()


@pytest.fixture
def graph(monkeypatch):
    """A node of this process on the children's domain (discovery on localhost); yields (node, executor)."""
    context = join_domain(monkeypatch, DOMAIN_ID)
    node = rclpy.create_node("launch_test_listener", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        yield node, executor
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)


def _spin_until(executor, launched: Launched, done, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not done():
        launched.check_running()
        if time.monotonic() > deadline:
            pytest.fail(f"{what} within {timeout_s:g} s on domain {DOMAIN_ID}; ros2 launch said:\n{launched.log()}")
        executor.spin_once(timeout_sec=0.1)


def _assert_clean_exit(launched: Launched) -> None:
    log = launched.log()
    assert launched.process.returncode == 0, f"ros2 launch exited with {launched.process.returncode}:\n{log}"
    assert "Traceback" not in log, log
    for name in ("sensor_node", "star_tracker_node", "error_monitor_node"):
        finished = [line for line in log.splitlines() if f"[{name}-" in line and "process has finished cleanly" in line]
        assert len(finished) == 1, f"{name} did not finish cleanly:\n{log}"
    assert "process has died" not in log, log


def test_launch_kondor_publishes_statistics_and_stops_on_sigint(colcon_install, ros_tools, graph, tmp_path):
    node, executor = graph
    assert (colcon_install / "pmv_ros/share/pmv_ros/launch/pmv.launch.py").is_file()
    statistics = []
    node.create_subscription(DiagnosticArray, "/pmv/error_statistics", statistics.append, 10)
    started = time.monotonic()
    launched = Launched(colcon_install, ros_tools, tmp_path)
    try:
        _spin_until(executor, launched, lambda: len(statistics) >= 2, FIRST_MESSAGE_TIMEOUT_S,
                    "no /pmv/error_statistics")
        first_s = time.monotonic() - started
        shutdown_s = launched.interrupt()
    finally:
        launched.kill()
    _assert_clean_exit(launched)
    log = launched.log()
    assert "500 km" in log and "attitude from profile" in log and "on the wall clock" in log, log
    names = {status.name for status in statistics[-1].status}
    assert {"pmv_error_monitor: roll", "pmv_error_monitor: pitch", "pmv_error_monitor: meridional"} <= names
    print(f"ros2 launch: first /pmv/error_statistics after {first_s:.1f} s, SIGINT to exit {shutdown_s:.1f} s")


def test_launch_follow_starts_no_attitude_source(colcon_install, ros_tools, graph, tmp_path):
    node, executor = graph
    attitude = []
    node.create_subscription(Vector3Stamped, "/pmv/attitude", attitude.append, 10)
    launched = Launched(colcon_install, ros_tools, tmp_path, "preset:=meteor_m2", "follow:=true")
    try:
        # The sensor and the star tracker subscribe to /attitude/truth; nobody of the package publishes it.
        _spin_until(executor, launched, lambda: len(node.get_subscriptions_info_by_topic("/attitude/truth")) >= 2
                    and node.get_publishers_info_by_topic("/pmv/attitude"), FIRST_MESSAGE_TIMEOUT_S,
                    "the sensor and the star tracker did not subscribe to /attitude/truth")
        for _ in range(20):  # a few more spins: a publisher would have been discovered with its node
            executor.spin_once(timeout_sec=0.05)
        assert node.get_publishers_info_by_topic("/attitude/truth") == [], launched.log()
        assert not attitude  # nothing to follow yet: no sample
        # This process is the user's attitude stack: the sensor follows it.
        truth = node.create_publisher(QuaternionStamped, "/attitude/truth", 10)
        message = QuaternionStamped()
        message.header.frame_id = "orbital"
        message.quaternion.x, message.quaternion.w = (math.sin(0.5 * math.radians(0.1)),
                                                      math.cos(0.5 * math.radians(0.1)))

        def publish():
            message.header.stamp = node.get_clock().now().to_msg()
            truth.publish(message)

        timer = node.create_timer(0.1, publish)
        _spin_until(executor, launched, lambda: len(attitude) >= 5, FIRST_MESSAGE_TIMEOUT_S,
                    "no /pmv/attitude while following the published truth")
        node.destroy_timer(timer)
        publishers = node.get_publishers_info_by_topic("/attitude/truth")
        assert [info.node_name for info in publishers] == ["launch_test_listener"]
        launched.interrupt()
    finally:
        launched.kill()
    _assert_clean_exit(launched)
    log = launched.log()
    assert "835 km" in log and "attitude from follow" in log, log
    # A body rolled by 0.1° about the orbital +X: the sensor reads it (± the methodical error, a few ′).
    roll = [abs(m.vector.x) for m in attitude if math.isfinite(m.vector.x)]
    assert roll and all(abs(r - math.radians(0.1)) < math.radians(0.25) for r in roll), roll


def test_launch_controller_closes_the_loop(colcon_install, ros_tools, graph, tmp_path):
    # controller:=true: attitude_controller_node publishes /attitude/truth, the sensor follows it (follow mode
    # without follow:=true) and the loop runs on the wall clock across processes.
    node, executor = graph
    attitude, truth = [], []
    node.create_subscription(Vector3Stamped, "/pmv/attitude", attitude.append, 10)
    node.create_subscription(QuaternionStamped, "/attitude/truth", truth.append, 10)
    launched = Launched(colcon_install, ros_tools, tmp_path, "controller:=true")
    try:
        _spin_until(executor, launched, lambda: len(attitude) >= 5 and len(truth) >= 5, FIRST_MESSAGE_TIMEOUT_S,
                    "no /pmv/attitude measured on the controller's /attitude/truth")
        publishers = node.get_publishers_info_by_topic("/attitude/truth")
        assert [info.node_name for info in publishers] == ["attitude_controller_node"], launched.log()
        launched.interrupt()
    finally:
        launched.kill()
    _assert_clean_exit(launched)
    log = launched.log()
    assert "attitude from follow" in log and "PD loop on pmv/attitude" in log, log
    assert [m.header.frame_id for m in truth] == ["orbital"] * len(truth)


#: Launch arguments that cannot be used, and a word the refusal must name.
BAD_ARGUMENTS = (("preset:=kondr", "preset"), ("follow:=yes", "follow"), ("rate_hz:=-1", "sensor.rate_hz"),
                 ("rate_hz:=fast", "rate_hz"), ("seed:=1e9", "seed"), ("log_level:=loud", "log_level"),
                 ("star_tracker:=maybe", "star_tracker"), ("fast_time:=true", "time_scale:=-1", "sim.time_scale"),
                 ("namespace:=sat 1", "namespace"), ("managed:=maybe", "managed"))


def test_an_unusable_launch_argument_ends_the_launch_non_zero_with_one_line(colcon_install, ros_tools, tmp_path):
    started = []
    for k, (*arguments, _) in enumerate(BAD_ARGUMENTS):  # all at once: each refusal comes before any node starts
        (tmp_path / str(k)).mkdir()
        started.append(Launched(colcon_install, ros_tools, tmp_path / str(k), *arguments))
    try:
        for launched, (*arguments, word) in zip(started, BAD_ARGUMENTS):
            argument = " ".join(arguments)
            launched.process.wait(timeout=FIRST_MESSAGE_TIMEOUT_S)
            log = launched.log()
            errors = [line for line in log.splitlines() if "ERROR" in line]
            assert launched.process.returncode != 0, f"{argument}: exit 0\n{log}"
            assert len(errors) == 1 and word in errors[0] and "Traceback" not in log, f"{argument}:\n{log}"
            assert "process started" not in log, f"{argument}: a node started\n{log}"
    finally:
        for launched in started:
            launched.kill()


def test_launch_arguments_reach_the_nodes(colcon_install, ros_tools, graph, tmp_path):
    """rate_hz, seed and log_level reach the sensor over the preset's node section; star_tracker:=false and
    monitor:=false leave those nodes out."""
    node, executor = graph
    attitude = []
    node.create_subscription(Vector3Stamped, "/pmv/attitude", attitude.append, 10)
    launched = Launched(colcon_install, ros_tools, tmp_path, "rate_hz:=4", "seed:=3", "log_level:=warn",
                        "star_tracker:=false", "monitor:=false")
    try:
        _spin_until(executor, launched, lambda: len(attitude) >= 6, FIRST_MESSAGE_TIMEOUT_S, "no /pmv/attitude")
        names = set(node.get_node_names())
        parameters = _parameters(node, executor, launched, "/sensor_node", ["sensor.rate_hz", "seed"])
        generated = list((tmp_path / "tmp").glob("pmv_launch_*.yaml"))
        launched.interrupt()
    finally:
        launched.kill()
    log = launched.log()
    # The launch wrote the node sections of rate_hz and seed to a params file, and removed it when it ended.
    assert generated and not list((tmp_path / "tmp").glob("pmv_launch_*.yaml")), generated
    assert parameters == [4.0, 3], parameters  # kondor.yaml's section says 10 Hz and seed 1
    stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in attitude]
    assert all(abs(b - a - 0.25) < 0.01 for a, b in zip(stamps, stamps[1:])), stamps  # 4 Hz (± timer jitter)
    assert "sensor_node" in names and not {"star_tracker_node", "error_monitor_node"} & names, names
    assert "star_tracker_node" not in log and "error_monitor_node" not in log, log
    assert "sensor_node: H =" not in log, log  # its INFO start-up line, below log_level warn


def _parameters(node, executor, launched, target: str, names: list) -> list:
    """The values of ``names`` on node ``target``, through its get_parameters service."""
    from rcl_interfaces.srv import GetParameters

    client = node.create_client(GetParameters, f"{target}/get_parameters")
    _spin_until(executor, launched, client.service_is_ready, FIRST_MESSAGE_TIMEOUT_S, f"no {target}/get_parameters")
    future = client.call_async(GetParameters.Request(names=names))
    _spin_until(executor, launched, future.done, FIRST_MESSAGE_TIMEOUT_S, f"no answer from {target}")
    values = future.result().values
    return [value.double_value if value.type == 3 else value.integer_value for value in values]


def test_launch_namespace_fast_time_keeps_the_preset_sections(colcon_install, ros_tools, graph, tmp_path):
    """namespace:=sat1: the preset's and follow.yaml's node sections still reach the renamed nodes, the topics and
    frames move under sat1; fast time runs."""
    node, executor = graph
    launched = Launched(colcon_install, ros_tools, tmp_path, "namespace:=sat1", "follow:=true", "fast_time:=true",
                        "time_scale:=2")
    try:
        clock = []
        node.create_subscription(Clock, "/clock", clock.append, 10)
        # The nodes are on the graph before they have finished starting: wait for the sensor's start line too.
        _spin_until(executor, launched, lambda: {("sensor_node", "/sat1"), ("error_monitor_node", "/sat1")}
                    <= set(node.get_node_names_and_namespaces()) and len(clock) >= 5
                    and "sensor_node: H =" in launched.log()
                    and len(node.get_subscriptions_info_by_topic("/sat1/attitude/truth")) >= 2,
                    FIRST_MESSAGE_TIMEOUT_S, "no /sat1 nodes, no /clock, no start line of the sensor or no "
                    "subscriptions to /sat1/attitude/truth")
        # The spacecraft's topics moved under the namespace; /clock stays shared.
        assert node.get_publishers_info_by_topic("/sat1/attitude/truth") == []
        assert node.get_publishers_info_by_topic("/sat1/pmv/attitude")
        assert node.get_subscriptions_info_by_topic("/attitude/truth") == []
        generated = list((tmp_path / "tmp").glob("pmv_launch_*.yaml"))  # the presets' sections renamed for sat1
        launched.interrupt()
    finally:
        launched.kill()
    _assert_clean_exit(launched)
    # the preset and follow.yaml renamed for sat1, and the launch's own sections (the star tracker's fast time)
    assert len(generated) == 3 and not list((tmp_path / "tmp").glob("pmv_launch_*.yaml")), generated
    # follow.yaml's sensor_node section and kondor.yaml's reached /sat1/sensor_node; the sensor runs the clock.
    assert "attitude from follow" in launched.log() and "fast time" in launched.log(), launched.log()
    # The launch namespace prefixed the frames (the inertial frame is shared by every spacecraft).
    assert "frames eci → sat1/orbital → sat1/base_link → sat1/pmv_sensor" in launched.log(), launched.log()


# ------------------------------------------------------------------------- two spacecraft in one graph

#: Samples each spacecraft takes in the two-spacecraft run (10 s of simulation time at 10 Hz): ten star-tracker
#: frames and ten statistics messages each, enough for a topic of one spacecraft reaching the other, or a sample of
#: one aligned with the other's truth, to change residuals that must be bit-identical to the run alone.
LOCKSTEP_SAMPLES = 100
#: Wall time for the launched nodes to discover one another once this process sees them all, s (3 s lost the
#: first samples of a run once at load 10).
DISCOVERY_SETTLE_S = 10.0
#: The spacecraft of the two-spacecraft run: namespace → preset.
FLEET = {"sat1": "kondor", "sat2": "meteor_m2"}


def _fleet_presets(folder: Path) -> dict:
    """The fleet's params files: kondor's as shipped; meteor_m2's started 20° of argument of latitude later. At
    u = 0° its star tracker's field holds two catalogue stars for the first ≈ 26 s (no attitude: the monitor forms
    no residual, and the lockstep's monitors fall behind; over the South Atlantic Anomaly the trapped protons
    crowd out even those for ≈ 70 s, physics.md §6); from u = 20° every frame of the first 20 s has its stars."""
    presets = {}
    for name, preset in FLEET.items():
        document = yaml.safe_load((REPO / "config" / f"{preset}.yaml").read_text())
        if preset == "meteor_m2":
            document["/**"]["ros__parameters"]["orbit"]["u0_deg"] = 20.0
        presets[name] = folder / f"{preset}.yaml"
        presets[name].write_text(yaml.safe_dump(document))
    return presets


#: How far a monitor's residuals may trail its sensor's samples in the lockstep: the truth that aligns a sample
#: comes with the next 1 Hz star-tracker frame, published ≈ 0.9 s after its time (≤ 19 samples at 10 Hz), and the
#: samples before the first frame never get a residual (≤ 10), with room to spare.
RESIDUAL_LAG = 40
#: Wall time the lockstep lets pass without a new star-tracker frame before a whole second of /clock, s.
BOUNDARY_QUIET_S = 0.2


def _caught_up(got: dict) -> bool:
    """Whether a monitor has formed the residual of the newest sample the star-tracker frames seen here cover (the
    residuals a statistics message counts then no longer depend on how busy the monitor's process is; a sample
    before the second frame may never have one)."""
    truth = sorted(_stamp_s(m) for m in got["truth"])
    if len(truth) < 2:
        return True
    covered = [t for t in map(_stamp_s, got["attitude"]) if truth[1] - 1e-6 <= t <= truth[-1] + 1e-6]
    return not covered or any(_stamp_s(m) >= covered[-1] - 1e-6 for m in got["residual"][-20:])


def _stamp_s(message) -> float:
    return message.header.stamp.sec + message.header.stamp.nanosec * 1e-9


def _lockstep(spin, clock_publisher, counts, ticks: int, timeout_s: float, runs=()) -> None:
    """Advance /clock by one sensor period (0.1 s) at a time, each step once every sensor has published its sample.

    One step per sample: a sensor paced by its clock computes exactly one sample per step, so the runs compare
    sample for sample (a step of several periods would let a busy process skip one). Before each whole second,
    when the monitors publish their statistics, every monitor of ``runs`` must have caught up with the truth
    frames seen so far (`_caught_up`), so that a statistics message covers the same residuals in every run.
    """
    message = Clock()
    for k in range(1, ticks + 1):
        deadline = time.monotonic() + timeout_s
        if k % 10 == 0:
            seen, quiet_until = None, 0.0
            while True:
                frames = sum(len(got["truth"]) for got in runs)
                if frames != seen:
                    seen, quiet_until = frames, time.monotonic() + BOUNDARY_QUIET_S
                if time.monotonic() >= quiet_until and all(_caught_up(got) for got in runs):
                    break
                if time.monotonic() > deadline:
                    pytest.fail(f"step {k}: a monitor did not catch up with its truth frames: "
                                + repr([{key: [_stamp_s(m) for m in got[key][-5:]] for key in ("truth", "residual")}
                                        for got in runs]))
                spin()
        message.clock.sec, message.clock.nanosec = divmod(k * 100_000_000, 1_000_000_000)
        clock_publisher.publish(message)
        while min(count() for count in counts) < k:
            if time.monotonic() > deadline:
                pytest.fail(f"step {k}: the counts were {[count() for count in counts]}")
            spin()


def _one_spacecraft(preset_path: Path, ticks: int, domain: int) -> dict:
    """The same preset and seeds alone, in this process on a domain of its own, stepped as the launched ones."""
    from pmv_ros.nodes.error_monitor_node import ErrorMonitorNode
    from pmv_ros.nodes.sensor_node import SensorNode
    from pmv_ros.nodes.star_tracker_node import StarTrackerNode
    from rclpy.parameter import Parameter

    context = rclpy.Context()
    rclpy.init(args=["--ros-args", "--params-file", str(preset_path)], context=context, domain_id=domain)
    executor = SingleThreadedExecutor(context=context)
    nodes, got = [], {"residual": [], "statistics": [], "attitude": [], "truth": []}
    try:
        for node_class in (SensorNode, StarTrackerNode, ErrorMonitorNode):
            nodes.append(node_class(context=context, parameter_overrides=[Parameter("use_sim_time", value=True)]))
        tester = rclpy.create_node("one_spacecraft", context=context)
        nodes.append(tester)
        for node in nodes:
            executor.add_node(node)
        tester.create_subscription(Vector3Stamped, "/pmv/residual", got["residual"].append, 1000)
        tester.create_subscription(DiagnosticArray, "/pmv/error_statistics", got["statistics"].append, 1000)
        tester.create_subscription(Vector3Stamped, "/pmv/attitude", got["attitude"].append, 1000)
        tester.create_subscription(QuaternionStamped, "/star_tracker/attitude", got["truth"].append, 1000)
        clock = tester.create_publisher(Clock, "/clock", 10)
        for _ in range(20):
            executor.spin_once(timeout_sec=0.01)
        _lockstep(lambda: executor.spin_once(timeout_sec=0.01), clock, [lambda: len(got["attitude"])], ticks, 10.0,
                  [got])
        for _ in range(50):  # the last residuals and statistics of the last step
            executor.spin_once(timeout_sec=0.01)
    finally:
        executor.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.shutdown(context=context)
    return got


def _residuals(messages) -> list:
    return [(m.header.stamp.sec, m.header.stamp.nanosec, m.vector.x, m.vector.y) for m in messages]


def _statistics_by_count(messages) -> dict:
    """The statistics messages by how many samples they cover (the roll channel's count; the last of equal ones)."""
    by_count = {}
    for message in messages:
        statistics = shim.error_statistics_from_msg(message)
        by_count[statistics.channels[0].count] = statistics
    return by_count


def test_two_spacecraft_share_only_clock_diagnostics_and_tf_and_fly_as_alone(colcon_install, ros_tools, graph,
                                                                             tmp_path):
    """kondor under sat1 and meteor_m2 under sat2, two `ros2 launch` on one domain, on one /clock this test steps:
    no topic of one reaches the other, no source lock complains, and each one's residuals and statistics after
    LOCKSTEP_SAMPLES samples equal those of the same preset and seeds flown alone."""
    node, executor = graph
    got = {name: {"residual": [], "statistics": [], "attitude": [], "truth": []} for name in FLEET}
    for name in FLEET:
        node.create_subscription(Vector3Stamped, f"/{name}/pmv/residual", got[name]["residual"].append, 1000)
        node.create_subscription(DiagnosticArray, f"/{name}/pmv/error_statistics", got[name]["statistics"].append,
                                 1000)
        node.create_subscription(Vector3Stamped, f"/{name}/pmv/attitude", got[name]["attitude"].append, 1000)
        node.create_subscription(QuaternionStamped, f"/{name}/star_tracker/attitude", got[name]["truth"].append,
                                 1000)
    diagnostics = []
    node.create_subscription(DiagnosticArray, "/diagnostics", diagnostics.append, 1000)
    clock = node.create_publisher(Clock, "/clock", 10)
    launches = {}
    presets = _fleet_presets(tmp_path)
    for name, preset in presets.items():
        (tmp_path / name).mkdir()
        launches[name] = Launched(colcon_install, ros_tools, tmp_path / name, f"namespace:={name}",
                                  f"preset:={preset}", "use_sim_time:=true")
    try:
        def ready() -> bool:
            return all(launched.log().count("ready,") == 2 and "sensor_node: H =" in launched.log()
                       and len(node.get_subscriptions_info_by_topic(f"/{name}/attitude/truth")) >= 1
                       and len(node.get_subscriptions_info_by_topic(f"/{name}/pmv/attitude")) >= 2
                       for name, launched in launches.items())

        for name, launched in launches.items():
            _spin_until(executor, launched, ready, FIRST_MESSAGE_TIMEOUT_S, f"{name} not up")
        # The launched nodes must have matched each other's endpoints before the first sample (a sample sent
        # earlier is lost, and the run no longer compares with the one alone); the graph this process sees
        # does not tell, so wait as long as discovery of seven processes takes on a busy 2-core machine.
        settle = time.monotonic() + DISCOVERY_SETTLE_S
        while time.monotonic() < settle:
            executor.spin_once(timeout_sec=0.1)
        # Each step also waits for each monitor to keep within RESIDUAL_LAG samples of its sensor: a monitor
        # process starved by a busy machine would otherwise fall more than its input queue behind and lose
        # samples the run alone has (what is compared here is the figures, not the speed).
        _lockstep(lambda: executor.spin_once(timeout_sec=0.01), clock,
                  [lambda name=name: len(got[name]["attitude"]) for name in FLEET]
                  + [lambda name=name: len(got[name]["residual"]) + RESIDUAL_LAG for name in FLEET],
                  LOCKSTEP_SAMPLES, 20.0, list(got.values()))
        for _ in range(30):
            executor.spin_once(timeout_sec=0.05)
        topics = {topic for topic, _ in node.get_topic_names_and_types()}
        for launched in launches.values():
            launched.interrupt()
    finally:
        for launched in launches.values():
            launched.kill()
    for launched in launches.values():
        _assert_clean_exit(launched)
        assert "publishers of" not in launched.log(), launched.log()
    shared = {topic for topic in topics if not topic.startswith(("/sat1/", "/sat2/"))}
    assert shared - {"/parameter_events", "/rosout"} <= {"/clock", "/diagnostics", "/tf", "/tf_static"}, shared
    statuses = [s for m in diagnostics for s in shim.health_from_msg(m).statuses]
    errors = [(s.name, s.message) for s in statuses if s.level == shim.Level.ERROR]
    assert not errors, errors
    for name in FLEET:
        assert {f"pmv_ros/{name}/sensor_node: horizon", f"pmv_ros/{name}/star_tracker_node"} \
            <= {s.name for s in statuses}
    for offset, (name, preset) in enumerate(FLEET.items()):
        alone = _one_spacecraft(presets[name], LOCKSTEP_SAMPLES, DOMAIN_ID + 120 + offset)
        fleet, single = _residuals(got[name]["residual"]), _residuals(alone["residual"])
        common = min(len(fleet), len(single))
        assert common >= LOCKSTEP_SAMPLES - 20, (name, len(fleet), len(single))  # truth lags by the latency
        assert fleet[:common] == single[:common], name
        # Statistics after the same number of samples: a statistics message (1 Hz of the clock) covers the
        # residuals its monitor had taken by then, which under load is not the same number in both runs at a
        # given stamp; the largest count both runs published is compared.
        in_fleet, by_itself = _statistics_by_count(got[name]["statistics"]), _statistics_by_count(alone["statistics"])
        count = max(set(in_fleet) & set(by_itself), default=0)
        assert count >= LOCKSTEP_SAMPLES - 40, (name, sorted(in_fleet), sorted(by_itself))
        for a, b in zip(in_fleet[count].channels, by_itself[count].channels):
            # The residuals are bit-identical; the running sums take them in arrival order, which across
            # processes can group them otherwise: the last bit may differ (seen: 2e-19 rad), so 1e-9′ as golden.
            assert (a.channel, a.count) == (b.channel, b.count)
            assert abs(a.mean_rad - b.mean_rad) < 1e-9 * ARCMIN_RAD
            assert abs(a.sigma_rad - b.sigma_rad) < 1e-9 * ARCMIN_RAD
        roll = in_fleet[count].channels[0]
        print(f"{name} ({preset}) in the fleet and alone, statistics after {count} samples: "
              f"N = {roll.count}, roll mean {roll.mean_rad / ARCMIN_RAD:+.4f}′, σ {roll.sigma_rad / ARCMIN_RAD:.4f}′ "
              f"(equal to 1e-9′); {common} residuals bit-identical")


def test_launch_managed_configures_and_activates_and_a_deactivated_node_stays_quiet(colcon_install, ros_tools,
                                                                                    graph, tmp_path):
    from lifecycle_msgs.msg import Transition
    from lifecycle_msgs.srv import ChangeState, GetState

    node, executor = graph
    statistics, attitude = [], []
    node.create_subscription(DiagnosticArray, "/pmv/error_statistics", statistics.append, 10)
    node.create_subscription(Vector3Stamped, "/pmv/attitude", attitude.append, 100)
    change = node.create_client(ChangeState, "/sensor_node/change_state")
    get = node.create_client(GetState, "/sensor_node/get_state")
    launched = Launched(colcon_install, ros_tools, tmp_path, "managed:=true")

    def call(client, request):
        # Topics matched says nothing of the service's endpoints: a request sent before they match is lost.
        _spin_until(executor, launched, client.service_is_ready, FIRST_MESSAGE_TIMEOUT_S, f"no {client.srv_name}")
        future = client.call_async(request)
        _spin_until(executor, launched, future.done, 10.0, f"no answer from {client.srv_name}")
        return future.result()

    try:  # the whole chain publishing: all three configured and activated by the launch
        _spin_until(executor, launched, lambda: len(statistics) >= 2, FIRST_MESSAGE_TIMEOUT_S,
                    "no /pmv/error_statistics")
        assert call(get, GetState.Request()).current_state.label == "active"
        # Each managed node is one node in the graph, as the real `ros2 node list` shows it.
        # --spin-time: its default 0.5 s of discovery missed nodes under load.
        listed = subprocess.run([str(ros_tools / "bin/ros2"), "node", "list", "--no-daemon", "--spin-time", "5"],
                                capture_output=True, text=True, timeout=60,
                                env=_launch_env(colcon_install, ros_tools, tmp_path / "ros_log"))
        names = listed.stdout.split()
        nodes = ("sensor_node", "star_tracker_node", "error_monitor_node")
        assert all(names.count(f"/{name}") == 1 for name in nodes), listed.stdout + listed.stderr
        assert call(change, ChangeState.Request(transition=Transition(id=Transition.TRANSITION_DEACTIVATE))).success
        deadline = time.monotonic() + 1.0
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        count = len(attitude)
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        assert len(attitude) == count > 0  # deactivated: silent, and the launch does not activate it again
        assert call(get, GetState.Request()).current_state.label == "inactive"
        launched.interrupt()
    finally:
        launched.kill()
    _assert_clean_exit(launched)
