"""The three nodes in one process on one executor, stepped in fast time.

Used by ``pmv simulate`` (the main job), the node tests and the pipeline
benchmark. Each :class:`Pipeline` has its own rclpy context, so several can
live in one process one after another. Flow control is explicit: every
sensor tick is followed by :meth:`Pipeline.drain`, which runs ready callbacks
until none is left, so no queue grows and nothing is dropped however fast
the simulation runs.
"""

from __future__ import annotations

import inspect
import os
import weakref
from pathlib import Path

import numpy as np
import rclpy
from geometry_msgs.msg import Vector3Stamped
from rclpy.exceptions import InvalidHandle
from rclpy.executors import SingleThreadedExecutor, TimeoutException
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from rclpy.subscription import Subscription
from rclpy.time_source import TimeSource
from rosgraph_msgs.msg import Clock as ClockMsg

import pmv_msgs_shim as shim
from ..runtime.common.assembly import NODE_PARAMS
from .base import QOS_DEPTH, PmvNode
from .launch import hold_single_threaded_blas, release_single_threaded_blas
from .error_monitor_node import ErrorMonitorNode
from .params import check_params_files
from .sensor_node import SensorNode
from .star_tracker_node import StarTrackerNode
from .tf import tf_message_type


def drain(executor, max_callbacks: int = 100_000, on_idle=None, by_takes: bool = True) -> int:
    """Run an executor's ready callbacks until the graph is idle; returns how many ran.

    With a zero timeout, rclpy's executor ends every wait with a
    TimeoutException once it has handed out the callbacks that wait found (one
    message per subscription: a second message queued on a subscription needs
    another wait), so a timeout alone does not mean the graph is idle. Idle is
    two timeouts with no callback between them: a wait after the last
    callbacks that found nothing. ``on_idle()`` is called at every timeout;
    when it says it published something (handing queued inputs over), the
    graph is not idle yet.

    ``by_takes``: where the graph has nothing a wait could hand out but subscriptions' messages and timers
    — no services, clients, guard conditions or other waitables, as in the pipeline's lean nodes — each wait is
    asked of the entities directly (:func:`_take_ready`: no task pending, no timer ready, then a take from each
    subscription in the executor's order, one message each), and the messages go to their callbacks in that
    order, each holding its callback group as rclpy's handler does; then that wait's timeout. What a drain cut
    by ``max_callbacks`` or by an exception had not handed out goes first in the next drain, as the rest of a
    wait does. A wait costs the main job 50–70 µs of rclpy's Python (its wait set built anew), the takes a few.
    A ready timer, a pending task, a busy callback group (a drain inside a callback), any other entity, a
    shut-down executor: a wait. An async callback is refused (TypeError): the takes do not await it.

    One difference remains by construction: rclpy takes each message just before its callback, the takes
    here all before the first. A callback that itself takes from, floods or destroys a later subscription of
    the same look sees that look's messages already taken (none of the pipeline's callbacks does).
    """
    ran = empty = 0
    look = _OPEN_LOOKS.pop(executor, None)  # a look by takes a drain before left unfinished
    handing_out = look is None and _handing_out(executor)  # a wait's callbacks being handed out
    while empty < 2 and ran < max_callbacks:
        if look is None and by_takes and not handing_out:
            look = _take_ready(executor)
        if look is not None:  # a wait by takes: its callbacks, then its timeout
            found = bool(look)
            while look and ran < max_callbacks:
                subscription, taken = look.pop(0)
                try:
                    ran += _hand_over_taken(subscription, taken)
                except BaseException:
                    _OPEN_LOOKS[executor] = look
                    raise
            if ran >= max_callbacks:  # as a wait stopped at a callback: the rest, and its timeout, next time
                _OPEN_LOOKS[executor] = look
                break
            look = None
            empty = 0 if (on_idle is not None and on_idle()) else (1 if found else empty + 1)
            continue
        try:
            handler, _, _ = executor.wait_for_ready_callbacks(timeout_sec=0.0)
        except TimeoutException:
            handing_out = False
            empty = 0 if on_idle is not None and on_idle() else empty + 1
            continue
        handing_out, empty = True, 0
        handler()
        if handler.exception() is not None:
            raise handler.exception()
        ran += 1
    return ran


_WITH_INFO = Subscription.CallbackType.WithMessageInfo

#: Executor → what a look by takes had taken and not yet handed out when its drain stopped (possibly nothing:
#: then only its timeout is still to come).
_OPEN_LOOKS = weakref.WeakKeyDictionary()


def _hand_over_taken(subscription, taken) -> int:
    """One taken message to its subscription's callback, as rclpy's handler does it: not if the subscription was
    destroyed since (0), its callback group held while the callback runs (1). A coroutine a callback returns is
    not awaited here: TypeError."""
    try:
        with subscription.handle:
            pass
    except InvalidHandle:  # destroyed by an earlier callback of the look (or with its node)
        return 0
    group = subscription.callback_group
    group.beginning_execution(subscription)  # a drain inside the callback: its group is busy (_take_ready)
    try:
        result = subscription.callback(*(taken if subscription._callback_type is _WITH_INFO else taken[:1]))
    finally:
        group.ending_execution(subscription)
    if inspect.iscoroutine(result):
        result.close()
        raise TypeError(f"{subscription.topic_name}: an async callback; drain(by_takes=False) awaits it")
    return 1


def _handing_out(executor) -> bool:
    """Whether a wait of ``executor`` still holds callbacks it has not handed out (a drain stopped by its callback
    limit or an exception left it so): the executor's generator of them (rclpy's own attribute, pinned with
    Jazzy) is suspended."""
    waiting = getattr(executor, "_cb_iter", None)
    return waiting is not None and inspect.getgeneratorstate(waiting) == inspect.GEN_SUSPENDED


def _take_ready(executor) -> list | None:
    """What a zero-timeout wait of ``executor`` would hand out now, where that is only subscriptions' messages:
    ``(subscription, taken)`` in the executor's order (node by node; one message per subscription), [] when
    there is nothing; None where only a wait can tell — a shut-down executor, a timer ready (the executor runs a
    node's timers before its subscriptions), a task pending (it comes first), a callback group busy, or a node
    with an entity the takes cannot see. Each message is taken as rclpy's executor takes it (the subscription's
    handle and callback type, the executor's tasks: rclpy's own attributes, pinned with Jazzy)."""
    if executor._is_shutdown or not executor.context.ok():
        return None
    if any(not task.done() for task, _, _ in executor._tasks):  # the handlers it made keep a place till it waits
        return None
    nodes = executor.get_nodes()
    subscriptions = []
    for node in nodes:
        for entities in (node.services, node.clients, node.guards, node.waitables):  # generators: asked for one
            if next(entities, None) is not None:
                return None
        for timer in node.timers:
            if timer.handle.is_timer_ready():
                return None
        for subscription in node.subscriptions:
            if not subscription.callback_group.can_execute(subscription):
                return None
            subscriptions.append(subscription)
    ready = []
    for subscription in subscriptions:
        try:
            with subscription.handle:
                taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
        except InvalidHandle:  # destroyed: rclpy's wait would not list it
            continue
        if taken is not None:
            ready.append((subscription, taken))
    return ready


class TakingQueued:
    """A subscription's callback that, in the wake-up the executor hands it one message, also takes the messages
    queued behind it (at most :data:`~pmv_ros.nodes.base.QOS_DEPTH`), each to ``callback(message)`` in order.

    rclpy's executor takes one message per subscription per wait, and a wait costs ≈ 65 µs of rclpy's own Python
    (its wait set is built anew): the five residuals the monitor publishes when a star-tracker frame settles its
    samples would cost the main job five waits, ≈ 6 % of its time (README "Fast time"). Each further message is
    taken as rclpy's executor takes one (through the subscription's handle, rclpy's own; pinned with Jazzy) and
    handed over outside it: a subscription destroyed meanwhile ends the loop. For message-only callbacks (the
    message info is not passed on) in the node's default, mutually exclusive callback group. ``callback`` is an
    attribute (a benchmark counts the takes through it).
    """

    def __init__(self, subscription, callback):
        inspect.signature(callback).bind(None)  # a TypeError now for a callback that wants the message info too
        self.subscription, self.callback = subscription, callback

    def __call__(self, message) -> None:
        self.callback(message)
        subscription = self.subscription
        for _ in range(QOS_DEPTH):
            try:
                with subscription.handle:
                    taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
            except InvalidHandle:  # destroyed by a callback
                return
            if taken is None:
                return
            self.callback(taken[0])


class ReportCollector(PmvNode):
    """Keeps what a report needs from the graph: the residuals, decimated to a bounded count.

    The statistics are not taken from /pmv/error_statistics: the report asks the monitor node in the same process
    (:meth:`~pmv_ros.nodes.error_monitor_node.ErrorMonitorNode.publish_statistics` at the end,
    :attr:`~pmv_ros.nodes.error_monitor_node.ErrorMonitorNode.latest_statistics` for the progress line), so a
    lean monitor builds and publishes that message only when someone subscribes (a recording, a probe).
    """

    def __init__(self, max_points: int = 50_000, **kwargs):
        super().__init__("pmv_report_collector", **kwargs)
        self.max_points = max_points
        self.residuals = []  # (stamp_s, roll_rad, pitch_rad)
        self.residual_count = 0
        self._stride = 1
        residuals = self.subscription(Vector3Stamped, "pmv/residual", self._on_residual)
        residuals.callback = TakingQueued(residuals, self._on_residual)  # up to 5 at a time (a frame settles 5)

    def _on_residual(self, message) -> None:
        self.residual_count += 1
        if self.residual_count % self._stride:
            return
        record = shim.attitude_angles_from_msg(message)
        self.residuals.append((record.stamp_s, record.roll_rad, record.pitch_rad))
        if len(self.residuals) >= self.max_points:
            # Halve the resolution: memory stays bounded for any run length.
            self.residuals = self.residuals[::2]
            self._stride *= 2

    def residual_array(self) -> np.ndarray:
        """``(3, N)``: stamp (s), roll and pitch residual (rad)."""
        return np.array(self.residuals, float).T.reshape(3, -1)


class Pipeline:
    """sensor_node + star_tracker_node + error_monitor_node (+ a report collector) in fast time.

    Args:
        config: a ``ros__parameters`` preset (YAML) for all nodes, or None for defaults.
        overrides: parameters for every node, ``{name: value}`` (a node ignores the ones it does not declare).
        isolated: keep the graph to this process (no discovery beyond it), so parallel runs cannot cross-talk.
        collect: add the report collector.
        lean: nodes without parameter services and default QoS-event handlers
            (:class:`~pmv_ros.nodes.base.PmvNode`); the graph is private to the process.
        record: a file to record every topic of the run into, as a rosbag2 MCAP file
            (:class:`~pmv_ros.nodes.recorder.TopicRecorder`, logged at simulation time); None for none.
        publish_tf: the sensor publishes /tf and /tf_static (when tf2_msgs is there); None: only when
            recording and tf2_msgs is there — nothing else in the process's private graph reads them, and
            two more messages per tick would cost the main job time for nothing (benchmarks/bench_tf.py
            measures it).
    """

    def __init__(self, config: str | os.PathLike | None = None, overrides: dict | None = None,
                 isolated: bool = True, collect: bool = True, lean: bool = True,
                 record: str | os.PathLike | None = None, publish_tf: bool | None = None):
        if isolated:
            os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"
        args = ["--ros-args"]
        if config is not None:
            path = Path(config)
            if not path.exists():
                raise ValueError(f"config file {str(path)!r} does not exist")
            args += ["--params-file", str(path)]  # checked by check_params_files before rclpy reads it
            for node_name in NODE_PARAMS:  # a misspelled key in a node's section: ParameterError, as a bad value
                check_params_files(args, node_name)
        settings = {"sim.fast_time": True, **(overrides or {})}
        # Constructor overrides outrank the preset's node sections (a global -p would not).
        self.context = rclpy.Context()
        # No rclpy signal handlers: the caller decides what a signal means (`pmv simulate` stops the run
        # between two ticks and closes its recording); rclpy's would shut the context down under it.
        rclpy.init(args=args, context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self._settings, self._lean = settings, lean
        # Recording without tf2_msgs: the recording has no transforms, and no node warns about what nobody asked.
        self.publish_tf = (record is not None and tf_message_type() is not None) if publish_tf is None else publish_tf
        self.nodes = []
        self.executor = None
        hold_single_threaded_blas()  # released in close()
        self._holds_blas = True
        # The sensor is the clock: it stamps from its own simulation time and
        # publishes /clock for anything outside. The nodes it drives in this
        # process run with use_sim_time, their clocks set by time sources that
        # step() drives instead of a /clock subscription each (two fewer
        # messages taken per tick). The collector only records stamps and
        # needs no clock.
        self._time_sources = {}  # role → the rclpy TimeSource its node follows
        self._clock_msg = ClockMsg()  # the simulation time last set
        self.recording = self.recorder = None
        self.by_takes = True  # the drain asks the entities instead of waiting where it can (see drain)
        try:
            self.executor = SingleThreadedExecutor(context=self.context)
            self.sensor = self.start_node("sensor")
            self.star_tracker = self.start_node("star_tracker")
            self.monitor = self.start_node("monitor")
            self.collector = self._add(ReportCollector(**self._options(None))) if collect else None
            if record is not None:
                self._start_recorder(record)
        except BaseException:
            self.close()
            raise

    #: The pipeline's nodes by role: (class, on the simulation time, constructor arguments).
    ROLES = {"sensor": (SensorNode, False, {"external_drive": True}),
             "star_tracker": (StarTrackerNode, True, {"flushed_by_caller": True}),
             "monitor": (ErrorMonitorNode, True, {"flushed_by_caller": True})}

    def _start_recorder(self, path) -> None:
        """Record every topic the graph has now (all nodes are up) into ``path``, logged at simulation time."""
        from ..storage.recording import McapRecording
        from .recorder import TopicRecorder

        self.recording = McapRecording(path)
        source = self._time_source()
        self.recorder = self._add(TopicRecorder(self.recording, **self._options(source)))
        self._time_sources["recorder"] = source

    def _time_source(self) -> TimeSource:
        source = TimeSource()  # attached to no node: it never subscribes to /clock
        source.ros_time_is_active = True
        source.clock_callback(self._clock_msg)  # started mid-run: on the current simulation time
        return source

    def _options(self, time_source: TimeSource | None, overrides: dict | None = None) -> dict:
        values = {**self._settings, **(overrides or {}), "use_sim_time": time_source is not None}
        return dict(context=self.context, lean=self._lean, time_source=time_source,
                    parameter_overrides=[Parameter(name, value=value) for name, value in values.items()])

    def _add(self, node):
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def start_node(self, role: str, overrides: dict | None = None):
        """Create the node of ``role`` (see :attr:`ROLES`) as a freshly started process would be; returns it.

        With :meth:`stop_node`, this restarts a node in a running pipeline
        (fault tests): the new node has no memory of the old one; a new
        sensor starts its simulation clock again at ``sim.start_time_s``.
        ``overrides`` are added to the pipeline's parameters for this node.
        """
        node_class, sim_time, arguments = self.ROLES[role]
        if node_class is SensorNode:
            arguments = {**arguments, "publish_tf": self.publish_tf}
        source = self._time_source() if sim_time else None
        node = self._add(node_class(**arguments, **self._options(source, overrides)))
        if source is not None:
            self._time_sources[role] = source
        setattr(self, role, node)
        return node

    def stop_node(self, role: str) -> None:
        """Destroy the node of ``role``, as if its process ended; the others keep running."""
        node = getattr(self, role)
        self.executor.remove_node(node)
        self.nodes.remove(node)
        node.destroy_node()
        self._time_sources.pop(role, None)
        setattr(self, role, None)

    def drain(self, max_callbacks: int = 100_000) -> int:
        """Run ready callbacks until the graph is idle (see :func:`drain`); returns how many ran. Whenever the
        graph looks idle, the batching nodes (the star tracker, the monitor) hand over what they queued, in
        node order, and the drain goes on: a message waits at most until the graph is idle in the same tick."""
        return drain(self.executor, max_callbacks, self._hand_over, self.by_takes)

    def _hand_over(self) -> bool:
        """Every batching node's queued inputs to its runtime; whether that published anything."""
        handed = False
        for node in self.nodes:
            if getattr(node, "BATCHED", False):
                handed = node.flush_inputs() or handed
        return handed

    def step(self, ticks: int = 1) -> int:
        """Advance the simulation by ``ticks`` sensor periods, draining the graph after each; returns callbacks run."""
        ran = 0
        for _ in range(ticks):
            self.sensor.step()
            shim.write_clock(self._clock_msg, self.sensor.sim_time_s)
            for source in self._time_sources.values():
                source.clock_callback(self._clock_msg)
            ran += self.drain()
        return ran

    def close(self) -> None:
        """Destroy the nodes and shut the context down."""
        try:
            if getattr(self, "executor", None) is not None:
                self.executor.shutdown()
            for node in self.nodes:
                node.destroy_node()
            self.nodes = []
            if self.context.ok():
                rclpy.shutdown(context=self.context)
        finally:
            if getattr(self, "recording", None) is not None:
                self.recording.close()
            if getattr(self, "_holds_blas", False):
                self._holds_blas = False
                release_single_threaded_blas()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
