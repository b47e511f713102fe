"""The three nodes in one process on one executor, stepped in fast time — and with the loop closed, four.

Used by ``pmv simulate`` (the main job), the node tests and the pipeline
benchmark. With ``closed_loop``, the sensor follows ``attitude/truth`` and an
:class:`~pmv_ros.nodes.attitude_controller_node.AttitudeControllerNode` publishes it: a rigid body held
nadir-pointing by a PD loop on ``pmv/attitude`` (``pmv simulate --closed-loop``). Each :class:`Pipeline` has
its own rclpy context, so several can live in one process one after another. Flow control is explicit: every
sensor tick is followed by :meth:`Pipeline.drain`, which runs ready callbacks
until none is left, so no queue grows and nothing is dropped however fast
the simulation runs (:func:`~pmv_ros.nodes.rclpy_internals.drain`, also
importable from here, as :class:`~pmv_ros.nodes.rclpy_internals.TakingQueued`).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import rclpy
from geometry_msgs.msg import Vector3Stamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from rclpy.time_source import TimeSource
from rosgraph_msgs.msg import Clock as ClockMsg

import pmv_msgs_shim as shim
from ..runtime.common.assembly import NODE_PARAMS
from .base import QOS_DEPTH, PmvNode
from .launch import hold_single_threaded_blas, release_single_threaded_blas
from .attitude_controller_node import AttitudeControllerNode
from .error_monitor_node import ErrorMonitorNode
from .params import check_params_files
from .rclpy_internals import TakingQueued, drain, taking_queued
from .sensor_node import SensorNode
from .star_tracker_node import StarTrackerNode
from .tf import tf_message_type

__all__ = ["Pipeline", "ReportCollector", "TakingQueued", "drain"]


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
        # Up to 5 at a time (a frame settles 5): what is queued behind the first, in the same wake-up.
        taking_queued(lambda callback: self.subscription(Vector3Stamped, "pmv/residual", callback),
                      self._on_residual, QOS_DEPTH)

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
        closed_loop: close the loop: the sensor follows ``attitude/truth`` (``attitude.source`` follow) and the
            attitude controller publishes it, stepped before each sensor sample to that sample's time
            (:meth:`step`), so the sensor measures the plant's attitude at its own sample times exactly.
    """

    def __init__(self, config: str | os.PathLike | None = None, overrides: dict | None = None,
                 isolated: bool = True, collect: bool = True, lean: bool = True,
                 record: str | os.PathLike | None = None, publish_tf: bool | None = None,
                 closed_loop: bool = False):
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
        if closed_loop:
            settings["attitude.source"] = "follow"  # the plant's attitude, not the sensor's own profile
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
        self.recording = self.recorder = self.controller = None
        self.by_takes = True  # the drain asks the entities instead of waiting where it can (see drain)
        try:
            self.executor = SingleThreadedExecutor(context=self.context)
            self.sensor = self.start_node("sensor")
            self.star_tracker = self.start_node("star_tracker")
            self.monitor = self.start_node("monitor")
            if closed_loop:
                self.start_node("controller")
            self.collector = self._add(ReportCollector(**self._options(None))) if collect else None
            if record is not None:
                self._start_recorder(record)
        except BaseException:
            self.close()
            raise

    #: The pipeline's nodes by role: (class, on the simulation time, constructor arguments).
    ROLES = {"sensor": (SensorNode, False, {"external_drive": True}),
             "star_tracker": (StarTrackerNode, True, {"flushed_by_caller": True}),
             "monitor": (ErrorMonitorNode, True, {"flushed_by_caller": True}),
             "controller": (AttitudeControllerNode, True, {"external_drive": True})}

    def _start_recorder(self, path) -> None:
        """Record every topic the graph has now (all nodes are up) into ``path``, logged at simulation time."""
        from ..storage.recording import McapRecording
        from .recorder import TopicRecorder

        self.recording = McapRecording(path)
        source = self._new_time_source()
        self.recorder = self._add(TopicRecorder(self.recording, **self._options(source)))
        self._time_sources["recorder"] = source

    def _new_time_source(self) -> TimeSource:
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
        if node_class in (SensorNode, AttitudeControllerNode):
            arguments = {**arguments, "publish_tf": self.publish_tf}
        source = self._new_time_source() if sim_time else None
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
        """Advance the simulation by ``ticks`` sensor periods, draining the graph after each; returns callbacks run.

        With the loop closed, the controller's plant reaches each sample's time before the sensor measures it:
        after the sensor's sample the controller is told the next sample's time, and when the sample's
        ``pmv/attitude`` reaches it in the drain it steps there with that measurement and publishes
        ``attitude/truth``, which the same drain takes to the sensor and the star tracker. A plant still short
        of the coming sample (the first tick, or a tick whose sample was not published) is stepped there first,
        with its own drain."""
        ran = 0
        controller, sensor = self.controller, self.sensor.runtime
        for _ in range(ticks):
            if controller is not None:
                next_s = sensor.sim_time_s + 1.0 / sensor.values["sensor.rate_hz"]  # as the sensor's clock sums it
                if controller.runtime.time_s < next_s - 1e-9:
                    controller.step_to(next_s)
                    ran += self.drain()
            self.sensor.step()
            shim.write_clock(self._clock_msg, self.sensor.sim_time_s)
            for source in self._time_sources.values():
                source.clock_callback(self._clock_msg)
            if controller is not None:
                controller.step_at_next_measurement(sensor.sim_time_s + 1.0 / sensor.values["sensor.rate_hz"])
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
