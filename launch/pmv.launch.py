"""The three pmv_ros nodes on one preset: ``ros2 launch pmv_ros pmv.launch.py [argument:=value …]``.

Arguments (``ros2 launch pmv_ros pmv.launch.py --show-args`` lists them):

* ``preset`` — kondor (default), meteor_m2, meteor_m2_2, meteor_m2_tle (the package's
  ``share/pmv_ros/config/<preset>.yaml``), or the path of your own params file;
* ``follow`` — true: the sensor follows your ``/attitude/truth`` and the
  package starts no attitude model (nothing of it publishes ``/attitude/truth``).
  Passes ``config/follow.yaml`` as a second params file after the preset: a
  later file's node section wins over the preset's, where a ``-p`` would lose;
* ``fast_time`` — true: the sensor runs its own simulation clock and publishes
  ``/clock``, the other nodes run on it; ``time_scale`` — its multiple of real
  time (default 10; across processes keep rate × scale × 8 messages well below
  the ≈ 3000 msg/s the machine moves, see the README);
* ``use_sim_time`` — true: all three nodes take their time from a ``/clock``
  someone else publishes (a simulator of yours); ignored with fast_time;
* ``namespace`` — one spacecraft of several: the three nodes and every topic
  of theirs but ``/clock``, ``/diagnostics``, ``/tf`` and ``/tf_static`` move
  under it (``/sat1/pmv/attitude``), and their frames get it as a prefix
  (``sat1/orbital``, ``sat1/base_link``, ``sat1/pmv_sensor``; ``eci`` is shared);
  the preset's node sections are applied to the namespaced nodes;
* ``rate_hz`` — the sensor's output rate, Hz (default: the preset's);
* ``seed`` — the seed of the sensor's and the star tracker's random processes
  (default: the preset's);
* ``log_level`` — debug, info (default), warn, error or fatal, for the three nodes;
* ``respawn`` — true: a node that dies is started again after 2 s;
* ``star_tracker``, ``monitor`` — false: leave that node out (your stack has its
  own star tracker or monitor; they talk on the same topics);
* ``controller`` — true: close the loop: start ``attitude_controller_node`` (a rigid
  body held nadir-pointing by a PD loop on ``pmv/attitude``, publishing
  ``attitude/truth``) and make the sensor follow it (as ``follow:=true``);
* ``managed`` — true: the nodes start as managed (lifecycle) nodes (``--managed``,
  see the README);
* ``autostart`` — with ``managed:=true`` (default true): the launch configures each
  node when its process starts (each respawn too) and activates it once that
  configure succeeded — only then: a later configure (your lifecycle manager's,
  after a cleanup) leaves the node inactive for the manager's own activate; a
  failed configure leaves the node unconfigured, with the reason in its log.
  false: the launch changes no state; the nodes wait unconfigured for your
  lifecycle manager (``ros2 lifecycle set``, nav2's lifecycle manager, …).

``rate_hz`` and ``seed`` reach the nodes in a params file of node sections
passed after the preset's: a node section beats a ``-p``, so a plain override
would lose to the preset. A value that cannot be used ends the launch with
one line naming the argument and a non-zero exit, before any node starts;
so does an argument this file does not declare (``bogus:=1``, a misspelt
``namspace:=sat1``), named with the known ones — when ``ros2 launch`` was
asked for this file itself: included by another launch file, this file sees
the includer's own launch configurations too, which cannot be told from a
misspelt argument, and leaves them alone.
"""

from __future__ import annotations

import difflib
import sys
import tempfile
from pathlib import Path

import yaml
from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PACKAGE = "pmv_ros"
PRESETS = ("kondor", "meteor_m2", "meteor_m2_2", "meteor_m2_tle")
NODES = ("sensor_node", "star_tracker_node", "error_monitor_node", "attitude_controller_node")

ARGUMENTS = (
    ("preset", "kondor", f"one of {', '.join(PRESETS)}, or the path of a ros__parameters file"),
    ("follow", "false", "true: the sensor follows /attitude/truth from your stack (no attitude model of its own)"),
    ("fast_time", "false", "true: the sensor runs a simulation clock and publishes /clock; the others follow it"),
    ("time_scale", "10.0", "fast time: multiple of real time (0 = as fast as possible, not for several processes)"),
    ("use_sim_time", "false", "true: every node takes its time from a /clock published by someone else"),
    ("namespace", "", "one spacecraft of several: its nodes and topics move under this namespace, its frames "
                      "get it as a prefix (sat1 -> /sat1/pmv/attitude, sat1/base_link)"),
    ("rate_hz", "", "the sensor's output rate, Hz (empty: the preset's)"),
    ("seed", "", "seed of the sensor's and the star tracker's random processes (empty: the preset's)"),
    ("log_level", "info", "log level of the three nodes: debug, info, warn, error or fatal"),
    ("respawn", "false", "true: a node that dies is started again after 2 s"),
    ("star_tracker", "true", "false: no star_tracker_node (your stack publishes star_tracker/attitude)"),
    ("monitor", "true", "false: no error_monitor_node"),
    ("controller", "false", "true: close the loop: attitude_controller_node publishes attitude/truth from a PD loop "
                            "on pmv/attitude, and the sensor follows it"),
    ("managed", "false", "true: lifecycle nodes (configured and activated at start-up: see autostart)"),
    ("autostart", "true", "with managed:=true: true: the launch configures and activates each node once, when its "
                          "process starts; false: the nodes wait unconfigured for your lifecycle manager"),
)
LOG_LEVELS = ("debug", "info", "warn", "error", "fatal")
#: The longest names a node makes under its own name (rclpy's parameter and lifecycle services): a namespace too
#: long for one of them is refused before any node starts.
LONGEST_NAMES = ("get_available_transitions", "describe_parameters", "get_type_description")
#: A node that exits non-zero within this time of its start ends the launch, non-zero, s (a node that refuses its
#: configuration does so within seconds; a later death is left to ``respawn``).
START_UP_S = 30.0
#: Exit statuses the nodes give only at start-up for a refused configuration (1) or command line (2): a respawn
#: would be refused again, so these end the launch with respawn too.
REFUSED_STATUSES = (1, 2)
#: The nodes' own argument that stops them when ``ros2 launch`` is gone (pmv_ros.nodes.launch.STOP_WITH_PARENT_FLAG).
STOP_WITH_PARENT = "--stop-with-parent"
RESPAWN_DELAY_S = 2.0


class LaunchArgumentError(RuntimeError):
    """A launch argument that cannot be used; launch prints the message."""


def _flag(context, name: str) -> bool:
    value = LaunchConfiguration(name).perform(context).strip().lower()
    if value not in ("true", "false"):
        raise LaunchArgumentError(f"{name}:={value!r}: expected true or false")
    return value == "true"


def _checked(context, name: str, spec):
    """The launch argument ``name`` as the value of parameter ``spec`` (None when empty), or LaunchArgumentError."""
    text = LaunchConfiguration(name).perform(context).strip()
    if not text:
        return None
    try:
        value = int(text, 10) if isinstance(spec.default, int) else float(text)
    except ValueError:
        raise LaunchArgumentError(f"{name}:={text}: expected {spec.kind}") from None
    problem = spec.check(value)
    if problem:
        raise LaunchArgumentError(f"{name}:={text}: {problem}")
    return value


def _launched_directly() -> bool:
    """True when this process is the ``ros2 launch`` of this very file (``ros2 launch pmv_ros pmv.launch.py …`` or
    ``ros2 launch path/to/pmv.launch.py …``), not of a launch file that includes it."""
    words = sys.argv[1:]
    if "launch" not in words:
        return False
    named = [word for word in words[words.index("launch") + 1:] if not word.startswith("-") and ":=" not in word]
    return any(Path(word).name == Path(__file__).name for word in named[:2])


def _refuse_unknown_arguments(context):
    """End the launch with one line naming each argument given that this file does not declare, and the known ones
    (only when launched directly: module docstring)."""
    known = [name for name, _, _ in ARGUMENTS]
    unknown = sorted(set(context.launch_configurations) - set(known))
    if unknown and _launched_directly():
        guesses = {name: difflib.get_close_matches(name, known, n=1) for name in unknown}
        given = ", ".join(f"{name}:={context.launch_configurations[name]}"
                          + (f" (did you mean {guesses[name][0]}?)" if guesses[name] else "") for name in unknown)
        raise LaunchArgumentError(f"unknown launch argument{'s' if len(unknown) > 1 else ''} {given}; "
                                  f"the arguments are {', '.join(known)}")
    return []


def _check_params_file(path: Path, argument: str) -> None:
    """Refuse a params file as every node would refuse it at start-up, with the nodes' own check and bounds
    (:func:`pmv_ros.nodes.params.check_params_files`: the package's bounded reader, a mapping of node sections,
    no key a node does not have); one line naming the argument."""
    from pmv_ros.nodes.params import ParameterError, check_params_files

    for node in NODES:
        try:
            check_params_files(["--ros-args", "--params-file", str(path)], node)
        except (ParameterError, ValueError) as error:
            raise LaunchArgumentError(f"{argument}:={path}: {error}") from None


def _check_name_lengths(namespace: str) -> None:
    """Refuse a namespace under which rcl would refuse a node's longest name (a service of its node name, as a
    managed node has): the nodes would die at start-up."""
    from rclpy.validate_full_topic_name import validate_full_topic_name

    prefix = "/" + namespace.strip("/")
    for node in NODES:
        for suffix in LONGEST_NAMES:
            try:
                validate_full_topic_name(f"{prefix}/{node}/{suffix}", is_service=True)
            except Exception as error:  # rclpy's InvalidServiceNameException, with rcl's reason
                reason = str(error).splitlines()[0]
                raise LaunchArgumentError(f"namespace:={namespace}: too long for node {node} "
                                          f"({len(prefix)} characters): {reason}") from None


def _node_sections(values: dict, namespace: str, made: list) -> str:
    """A params file with one section per node (``values``: node → parameters), full names when namespaced;
    its path is added to ``made`` (removed when the launch ends)."""
    prefix = "/" + namespace.strip("/") if namespace else ""
    document = {(f"{prefix}/{node}" if prefix else node): {"ros__parameters": parameters}
                for node, parameters in values.items() if parameters}
    with tempfile.NamedTemporaryFile("w", prefix="pmv_launch_", suffix=".yaml", delete=False) as stream:
        yaml.safe_dump(document, stream)
    made.append(stream.name)
    return stream.name


def _namespaced(files: list[str], namespace: str, made: list) -> list[str]:
    """The params files with their node sections renamed for nodes in ``namespace`` (rcl matches full names);
    the renamed copies are added to ``made``."""
    if not namespace:
        return files
    prefix = "/" + namespace.strip("/")
    renamed = []
    for path in files:
        from pmv_ros.storage.files import read_yaml_file  # the nodes' bounded reader (checked already)

        document = read_yaml_file(path, "params file") or {}
        document = {(f"{prefix}/{key.lstrip('/')}" if key.lstrip("/") in NODES else key): value
                    for key, value in document.items()}
        with tempfile.NamedTemporaryFile("w", prefix="pmv_launch_", suffix=".yaml", delete=False) as stream:
            yaml.safe_dump(document, stream)
        made.append(stream.name)
        renamed.append(stream.name)
    return renamed


def _nodes(context):
    config = Path(get_package_share_directory(PACKAGE)) / "config"
    preset = LaunchConfiguration("preset").perform(context).strip()
    path = config / f"{preset}.yaml" if preset in PRESETS else Path(preset).expanduser()
    if not path.is_file():
        raise LaunchArgumentError(f"preset:={preset}: not one of {', '.join(PRESETS)} and no such file")
    _check_params_file(path, "preset")
    controller = _flag(context, "controller")
    follow, fast_time = _flag(context, "follow") or controller, _flag(context, "fast_time")
    use_sim_time = _flag(context, "use_sim_time")
    namespace = LaunchConfiguration("namespace").perform(context).strip()
    if namespace:
        from rclpy.validate_namespace import validate_namespace

        try:
            validate_namespace("/" + namespace.strip("/"))
        except Exception as error:  # rclpy's InvalidNamespaceException, with rcl's reason
            reason = str(error).splitlines()[0]
            raise LaunchArgumentError(f"namespace:={namespace}: {reason}") from None
        _check_name_lengths(namespace)
    log_level = LaunchConfiguration("log_level").perform(context).strip().lower()
    if log_level not in LOG_LEVELS:
        raise LaunchArgumentError(f"log_level:={log_level}: expected one of {', '.join(LOG_LEVELS)}")
    respawn = _flag(context, "respawn")
    wanted = {"sensor_node": True, "star_tracker_node": _flag(context, "star_tracker"),
              "error_monitor_node": _flag(context, "monitor"), "attitude_controller_node": controller}
    from pmv_ros.runtime.common.assembly import NODE_PARAMS  # here: --show-args needs no numerics
    from pmv_ros.runtime.common.frames import prefix_for_namespace

    def spec(node: str, parameter: str):
        return next(s for s in NODE_PARAMS[node] if s.name == parameter)

    time_scale = _checked(context, "time_scale", spec("sensor_node", "sim.time_scale"))
    rate_hz = _checked(context, "rate_hz", spec("sensor_node", "sensor.rate_hz"))
    seed = _checked(context, "seed", spec("sensor_node", "seed"))
    files = [str(path)] + ([str(config / "follow.yaml")] if follow else [])
    made = []  # the params files generated here: kept while the launch runs (a respawned node reads them again)
    files = _namespaced(files, namespace, made)
    frames = {"frames.prefix": prefix_for_namespace(namespace)}
    sensor = {"use_sim_time": use_sim_time and not fast_time, **frames}
    if fast_time:
        sensor.update({"sim.fast_time": True, "sim.time_scale": time_scale})
    others = {"use_sim_time": use_sim_time or fast_time, **frames}
    chosen = {"sensor_node": {}, "star_tracker_node": {}, "error_monitor_node": {}}
    if rate_hz is not None:
        chosen["sensor_node"]["sensor.rate_hz"] = rate_hz
    if seed is not None:
        chosen["sensor_node"]["seed"] = chosen["star_tracker_node"]["seed"] = seed
    if fast_time:  # the star tracker flies the sensor's orbit and sky on the same simulation clock
        chosen["star_tracker_node"]["sim.fast_time"] = True
    if any(chosen.values()):
        files.append(_node_sections(chosen, namespace, made))
    managed, autostart = _flag(context, "managed"), _flag(context, "autostart")
    if managed:
        nodes = [entity for name in NODES if wanted[name] for entity in _managed(
            name=name, namespace=namespace, parameters=[*files, sensor if name == "sensor_node" else others],
            log_level=log_level, respawn=respawn, autostart=autostart)]
    else:
        nodes = [Node(package=PACKAGE, executable=name, name=name, namespace=namespace, output="screen",
                      parameters=[*files, sensor if name == "sensor_node" else others],
                      arguments=[STOP_WITH_PARENT], ros_arguments=["--log-level", log_level], respawn=respawn,
                      respawn_delay=RESPAWN_DELAY_S)
                 for name in NODES if wanted[name]]
    return _ended_by_start_up_failure(respawn) + nodes + _removed_at_shutdown(made)


def _ended_by_start_up_failure(respawn: bool) -> list:
    """An action that ends the launch, non-zero and naming the node, when a node of it dies at start-up: exits
    non-zero within :data:`START_UP_S` of its start (without ``respawn``), or with a status of
    :data:`REFUSED_STATUSES` (also with ``respawn``: a restart would be refused the same way)."""
    import time

    from launch.actions import RegisterEventHandler
    from launch.event_handlers import OnProcessExit, OnProcessStart

    started = {}

    def on_start(event, context) -> None:
        started[event.pid] = time.monotonic()

    def on_exit(event, context):
        status, name = event.returncode, event.action.name
        if not status or context.is_shutdown:
            return None
        early = time.monotonic() - started.get(event.pid, 0.0) < START_UP_S
        if status in REFUSED_STATUSES or (early and not respawn):
            raise LaunchArgumentError(f"{name} exited with status {status} at start-up (its own line above says "
                                      "why): the launch ends")
        return None

    return [RegisterEventHandler(OnProcessStart(on_start=on_start)),
            RegisterEventHandler(OnProcessExit(on_exit=on_exit))]


def _removed_at_shutdown(paths: list) -> list:
    """An action that removes ``paths`` when the launch shuts down ([] when there are none)."""
    if not paths:
        return []
    from launch.actions import RegisterEventHandler
    from launch.event_handlers import OnShutdown

    def remove(event, context) -> None:
        for path in paths:
            Path(path).unlink(missing_ok=True)

    return [RegisterEventHandler(OnShutdown(on_shutdown=remove))]


def _managed(*, name: str, namespace: str, parameters: list, log_level: str, respawn: bool, autostart: bool) -> list:
    """A node started with ``--managed``. With ``autostart``: configured when its process starts (each respawn
    too) and activated after that configure if it succeeded — that configure only: after any other (a lifecycle
    manager's), the node stays where the manager puts it."""
    from launch.actions import EmitEvent, RegisterEventHandler
    from launch.event_handlers import OnProcessStart
    from launch.events import matches_action
    from launch_ros.actions import LifecycleNode
    from launch_ros.event_handlers import OnStateTransition
    from launch_ros.events.lifecycle import ChangeState
    from lifecycle_msgs.msg import Transition

    node = LifecycleNode(package=PACKAGE, executable=name, name=name, namespace=namespace, output="screen",
                         arguments=["--managed", STOP_WITH_PARENT], parameters=parameters,
                         ros_arguments=["--log-level", log_level], respawn=respawn, respawn_delay=RESPAWN_DELAY_S)
    if not autostart:
        return [node]

    def change(transition: int) -> EmitEvent:
        return EmitEvent(event=ChangeState(lifecycle_node_matcher=matches_action(node), transition_id=transition))

    start_up = {"configuring": False}  # the launch's own configure sent, its outcome not seen yet

    def configure(context):
        start_up["configuring"] = True
        return [change(Transition.TRANSITION_CONFIGURE)]

    def activate_after_start_up(context):
        if not start_up["configuring"]:
            return []
        start_up["configuring"] = False
        return [change(Transition.TRANSITION_ACTIVATE)] if context.locals.event.goal_state == "inactive" else []

    return [RegisterEventHandler(OnProcessStart(target_action=node, on_start=[OpaqueFunction(function=configure)])),
            RegisterEventHandler(OnStateTransition(target_lifecycle_node=node, start_state="configuring",
                                                   entities=[OpaqueFunction(function=activate_after_start_up)])),
            node]


def generate_launch_description() -> LaunchDescription:
    """Declare the arguments; the nodes are made once their values are known."""
    return LaunchDescription([DeclareLaunchArgument(name, default_value=default, description=description)
                              for name, default, description in ARGUMENTS]
                             + [OpaqueFunction(function=_refuse_unknown_arguments), OpaqueFunction(function=_nodes)])
