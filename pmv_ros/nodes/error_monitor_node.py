"""``error_monitor_node``: live methodical-error statistics of the sensor against star-tracker truth.

Subscribes to ``/pmv/attitude`` (sensor), ``/star_tracker/attitude`` (truth)
and ``/orbit/odometry`` (where the spacecraft is, for the oblateness model);
publishes ``/pmv/residual`` (sensed − true, REP-103) for every aligned sample,
``/pmv/error_statistics`` every ``1/statistics_rate_hz`` seconds of sample
time with the same numbers on ``/pmv/residual_mean``, ``_sigma`` and
``_limit`` (Vector3Stamped: x roll, y pitch, z meridional, rad; NaN where
the DiagnosticArray says "pending"), and ``/diagnostics``. The alignment
and statistics are :class:`pmv_ros.runtime.monitor.core.ErrorMonitor`, fed,
scheduled and reported on by its runtime
(:class:`pmv_ros.runtime.monitor.runtime.MonitorRuntime`); this node only
converts and wires.

Statistics are driven by the sample stamps, so the node behaves the same on
the wall clock and on a fast-time ``/clock``; a 1 Hz node-clock timer times
out samples waiting for truth when nothing arrives at all and publishes
``/diagnostics``. Inputs are best-effort subscriptions (README "QoS");
memory is bounded by the monitor's caps.

Bad input, second sources, outages, restarts and clock jumps:
:mod:`pmv_ros.runtime.monitor.runtime`.
"""

from __future__ import annotations

import sys

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from nav_msgs.msg import Odometry

import pmv_msgs_shim as shim
from .base import PmvNode
from ..runtime.common.assembly import MONITOR_PARAMS as PARAMS
from ..runtime.monitor.core import ErrorMonitor
from ..runtime.monitor.runtime import STATISTICS_VECTORS, MonitorOutput, MonitorRuntime
from .launch import node_main
from .params import ParameterError, declare, install_validation


class ErrorMonitorNode(PmvNode):
    """Aligns the sensor with truth and publishes residuals and live statistics."""

    def __init__(self, **kwargs):
        super().__init__("error_monitor_node", **kwargs)
        self._values = declare(self, PARAMS)
        try:
            self._runtime = MonitorRuntime(self._values, source_problems=self.input_source_problems,
                                           source_counters=self.input_source_counters)
        except ValueError as error:  # a combination the ranges cannot check
            raise ParameterError(str(error)) from None
        install_validation(self, PARAMS, self._values, self._rebuild)
        # Relative names: in a namespace, this spacecraft's topics move under it (interfaces.md "Topics").
        self._pub_residual = self.publisher(Vector3Stamped, "pmv/residual")
        # Filled in place for every publication (rclpy serialises at publish).
        self._out_residual, self._out_statistics, self._out_diagnostics = (Vector3Stamped(), DiagnosticArray(),
                                                                           DiagnosticArray())
        self._pub_statistics = self.publisher(DiagnosticArray, "pmv/error_statistics")
        # The same statistics as numbers a plotter draws: x roll, y pitch, z meridional, rad.
        self._pub_numbers = {name: (self.publisher(Vector3Stamped, f"pmv/residual_{name}"), Vector3Stamped())
                             for name in STATISTICS_VECTORS}
        self._pub_diagnostics = self.publisher(DiagnosticArray, "/diagnostics")
        self.watch_clock(self._pub_diagnostics)
        timeout = self._values["input.source_timeout_s"]
        self.input_subscription(Vector3Stamped, "pmv/attitude", self._on_sensor, timeout)
        self._truth_subscription = self.input_subscription(QuaternionStamped, "star_tracker/attitude",
                                                           self._on_truth, timeout)
        self.input_subscription(Odometry, "orbit/odometry", self._on_odometry, timeout)
        self.create_timer(1.0, self._on_timer)
        self.get_logger().info(f"error_monitor_node: ready, statistics at {self._values['statistics_rate_hz']:g} Hz, "
                               f"{self.clock_name()}")

    def _rebuild(self, values: dict) -> None:
        self._runtime.reconfigure(values)  # a new configuration starts new statistics
        self.set_source_timeout(values["input.source_timeout_s"])

    def _now_s(self) -> float | None:
        now = self.get_clock().now().nanoseconds * 1e-9
        return now if now > 0.0 else None

    # -- inputs ------------------------------------------------------------------------------------

    def _on_odometry(self, message: Odometry) -> None:
        try:
            state = shim.read_orbit_state(message)
        except ValueError:
            state = None
        self._publish(self._runtime.add_odometry(message.header.frame_id, message.child_frame_id, state,
                                                 self._now_s()))

    def _on_truth(self, message: QuaternionStamped) -> None:
        try:
            stamp_s, q_xyzw = shim.read_attitude_quaternion(message)
        except ValueError:
            stamp_s = q_xyzw = None
        self._publish(self._runtime.add_truth(message.header.frame_id, stamp_s, q_xyzw, self._now_s()))

    def _on_sensor(self, message: Vector3Stamped) -> None:
        try:
            stamp_s, roll_rad, pitch_rad = shim.read_attitude_angles(message)
        except ValueError:
            stamp_s = roll_rad = pitch_rad = None
        self._publish(self._runtime.add_sensor(message.header.frame_id, stamp_s, roll_rad, pitch_rad,
                                               self._now_s()))

    def _on_timer(self) -> None:
        now = self._now_s()
        self._publish(self._runtime.poll(now))
        self._pub_diagnostics.publish(shim.write_health(self._out_diagnostics,
                                                        self.health_report(now or 0.0, self._runtime.health(now))))

    # -- outputs -----------------------------------------------------------------------------------

    def _publish(self, output: MonitorOutput) -> None:
        for outcome in output.residuals:  # one message, filled in place (rclpy serialises at publish)
            self._pub_residual.publish(shim.write_attitude_angles(
                self._out_residual, outcome.stamp_s, self._runtime.frames.sensor,
                outcome.residual_roll_rad, outcome.residual_pitch_rad))
        if output.statistics is not None:
            self._publish_statistics(output.statistics)

    def _publish_statistics(self, computed) -> shim.ErrorStatistics:
        statistics = shim.ErrorStatistics.from_summary(computed.summary, computed.stamp_s)
        self._pub_statistics.publish(shim.write_error_statistics(self._out_statistics, statistics))
        for name, (publisher, message) in self._pub_numbers.items():
            publisher.publish(shim.write_statistics_vector(message, computed.stamp_s, self._runtime.frames.sensor,
                                                           *computed.vectors[name]))
        return statistics

    def publish_statistics(self, stamp_s: float) -> shim.ErrorStatistics:
        """Publish the current statistics on /pmv/error_statistics (and return them)."""
        return self._publish_statistics(self._runtime.statistics(stamp_s))

    @property
    def latest_orbit_stamp_s(self) -> float | None:
        """Stamp of the last /orbit/odometry taken, s (None before the first)."""
        return self._runtime.monitor.latest_orbit_stamp_s

    @property
    def monitor(self) -> ErrorMonitor:
        """The monitor core (read-only use: reports, tests)."""
        return self._runtime.monitor


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros error_monitor_node [--managed]``."""
    return node_main(ErrorMonitorNode, "error_monitor_node", args)


if __name__ == "__main__":
    sys.exit(main())
