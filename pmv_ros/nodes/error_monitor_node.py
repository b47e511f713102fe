"""``error_monitor_node``: live methodical-error statistics of the sensor against star-tracker truth.

Subscribes to ``/pmv/attitude`` (sensor), ``/star_tracker/attitude`` (truth),
``/orbit/odometry`` (where the spacecraft is, for the oblateness model) and
``/star_tracker/frame_status`` (why a frame has no attitude: the samples
without truth are counted by that reason, ``truth_lost_<reason>`` on
``/diagnostics``);
publishes ``/pmv/residual`` (sensed − true, REP-103) for every aligned sample,
``/pmv/error_statistics`` every ``1/statistics_rate_hz`` seconds of sample
time with the same numbers on ``/pmv/residual_mean``, ``_sigma`` and
``_limit`` (Vector3Stamped: x roll, y pitch, z meridional, rad; NaN where
the DiagnosticArray says "pending"), and ``/diagnostics``. The alignment
and statistics are :class:`pmv_ros.runtime.monitor.core.ErrorMonitor`, fed,
scheduled and reported on by its runtime
(:class:`pmv_ros.runtime.monitor.runtime.MonitorRuntime`); this node only
wires (:data:`TOPICS`).

Batched per executor wake-up: the node queues the messages that arrive and
hands them to the runtime as one input when its wake-up guard is handled —
at the next wait, after that wake-up's messages of this node — so the
monitor's fixed cost is paid once per wake-up, not per message. A message
waits at most until the end of the next executor wake-up (never for a timer
or for simulated time; at most 1000 wait, then they go at once); the timer,
a parameter change and a read of the monitor hand over what waits first.
What is published, and in which order, is what one message at a time gives.

Statistics are driven by the sample stamps, so the node behaves the same on
the wall clock and on a fast-time ``/clock``; a 1 Hz node-clock timer times
out samples waiting for truth when nothing arrives at all and publishes
``/diagnostics``. Inputs are best-effort subscriptions (README "QoS");
memory is bounded by the monitor's caps. Bad input, second sources,
outages, restarts and clock jumps: :mod:`pmv_ros.runtime.monitor.runtime`.
"""

from __future__ import annotations

import sys

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from nav_msgs.msg import Odometry

import pmv_msgs_shim as shim
from .base import PmvNode, Pub, Sub
from ..runtime.common.assembly import MONITOR_PARAMS as PARAMS
from ..runtime.common.records import HealthAt
from ..runtime.monitor.core import ErrorMonitor
from ..runtime.monitor.records import Outcome
from ..runtime.monitor.runtime import STATISTICS_VECTORS, MonitorRuntime, MonitorStatistics
from .launch import node_main
from .managed import ManagedNode
from .params import ParameterError, declare, install_validation


def _statistics_vector(name: str) -> Pub:
    """``pmv/residual_<name>``: the statistic as numbers a plotter draws (x roll, y pitch, z meridional, rad)."""
    return Pub(f"pmv/residual_{name}", Vector3Stamped, MonitorStatistics, lambda m, s, n: shim.write_statistics_vector(
        m, s.stamp_s, n.frames.sensor, *s.vectors[name]))


#: What the monitor publishes and takes (relative names: in a namespace, this spacecraft's topics move under it,
#: interfaces.md "Topics"); inputs in this order (the order of callbacks within a wake-up).
TOPICS = (
    Pub("pmv/residual", Vector3Stamped, Outcome, lambda m, o, n: shim.write_attitude_angles(
        m, o.stamp_s, n.frames.sensor, o.residual_roll_rad, o.residual_pitch_rad)),
    Pub("pmv/error_statistics", DiagnosticArray, MonitorStatistics, lambda m, s, n: shim.write_error_statistics(
        m, shim.ErrorStatistics.from_summary(s.summary, s.stamp_s))),
    *(_statistics_vector(name) for name in STATISTICS_VECTORS),
    Pub("/diagnostics", DiagnosticArray, HealthAt, lambda m, h, n: shim.write_health(m, n.health_report(*h))),
    Sub("pmv/attitude", Vector3Stamped, shim.angles_input, "add_sensor"),
    Sub("star_tracker/attitude", QuaternionStamped, shim.quaternion_input, "add_truth"),
    Sub("orbit/odometry", Odometry, shim.odometry_input, "add_odometry"),
    Sub("star_tracker/frame_status", DiagnosticArray, shim.frame_status_input, "add_frame_status"),
)


class ErrorMonitorNode(PmvNode):
    """Aligns the sensor with truth and publishes residuals and live statistics."""

    BATCHED = True
    NODE_NAME = "error_monitor_node"

    def build(self) -> None:
        """Parameters, runtime, topics and the 1 Hz timer (see :class:`~pmv_ros.nodes.base.PmvNode`)."""
        self._values = declare(self, PARAMS)
        try:
            self._runtime = MonitorRuntime(self._values, source_problems=self.input_source_problems,
                                           source_counters=self.input_source_counters)
        except ValueError as error:  # a combination the ranges cannot check
            raise ParameterError(str(error)) from None
        install_validation(self, PARAMS, self._values, self._rebuild)
        self.wire(TOPICS, self._values["input.source_timeout_s"])
        self._sensor_topic = self.resolve_topic_name("pmv/attitude")  # as the lock names it (namespace, remapping)
        self.make_timer(1.0, self._on_timer)
        self.get_logger().info(f"{self.get_fully_qualified_name()}: ready, statistics at "
                               f"{self._values['statistics_rate_hz']:g} Hz, {self.clock_name()}")

    def _rebuild(self, values: dict) -> None:
        self.flush_inputs()  # what arrived before the change counts in the statistics it arrived under
        self._runtime.reconfigure(values)  # a new configuration starts new statistics
        self.sources.set_timeout(values["input.source_timeout_s"])

    def on_new_source(self, topic: str) -> None:
        """A new sensor source (a restarted sensor starts its orbit and timeline again): a new statistics epoch;
        what the old one sent is handed over first, to the old epoch."""
        if topic == self._sensor_topic:
            self.flush_inputs()
            self._runtime.new_epoch(topic)
            self.get_logger().warning(f"{topic}: a new source; statistics epoch {self._runtime.statistics_epochs + 1}")

    def _on_timer(self) -> None:
        self.flush_inputs()
        now = self.input_clock(self.now_s())
        self.take_output(self._runtime.poll(now))
        self.emit(HealthAt, HealthAt(now or 0.0, self._runtime.health(now)))

    def publish_statistics(self, stamp_s: float) -> shim.ErrorStatistics:
        """Publish the current statistics on /pmv/error_statistics (and the vectors), and return them."""
        self.flush_inputs()
        self.emit(MonitorStatistics, self._runtime.statistics(stamp_s))
        return self.latest_statistics

    @property
    def latest_statistics(self) -> shim.ErrorStatistics | None:
        """The statistics last computed (on schedule, or by :meth:`publish_statistics`), as /pmv/error_statistics
        carries them, whether or not anyone subscribes; None before the first (an in-process reader: a progress
        line)."""
        latest = self._runtime.latest_statistics
        return None if latest is None else shim.ErrorStatistics.from_summary(latest.summary, latest.stamp_s)

    @property
    def truth_lost(self) -> dict:
        """Samples skipped for want of truth, by the star tracker's reason (``truth_lost_<reason>``; a copy)."""
        self.flush_inputs()
        return self._runtime.truth_lost

    @property
    def truth_lost_frames(self) -> tuple:
        """The star tracker's recent frames without attitude the monitor heard of: stamps (s) and Outcome codes."""
        self.flush_inputs()
        return self._runtime.lost_truth.frames

    @property
    def latest_orbit_stamp_s(self) -> float | None:
        """Stamp of the last /orbit/odometry taken, s (None before the first)."""
        return self.monitor.latest_orbit_stamp_s

    @property
    def monitor(self) -> ErrorMonitor:
        """The monitor core, with every message that arrived handed over (read-only use: reports, tests)."""
        self.flush_inputs()
        return self._runtime.monitor


class ManagedErrorMonitorNode(ManagedNode, ErrorMonitorNode):
    """:class:`ErrorMonitorNode` as a managed (lifecycle) node (:mod:`pmv_ros.nodes.managed`)."""


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros error_monitor_node [--managed]``."""
    return node_main(ErrorMonitorNode, ManagedErrorMonitorNode, args)


if __name__ == "__main__":
    sys.exit(main())
