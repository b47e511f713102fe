"""``error_monitor_node``: live methodical-error statistics of the sensor against star-tracker truth.

Subscribes to ``/pmv/attitude`` (sensor), ``/star_tracker/attitude`` (truth)
and ``/orbit/odometry`` (where the spacecraft is, for the oblateness model);
publishes ``/pmv/residual`` (sensed − true, REP-103) for every aligned sample,
``/pmv/error_statistics`` every ``1/statistics_rate_hz`` seconds of sample
time with the same numbers on ``/pmv/residual_mean``, ``_sigma`` and
``_limit`` (Vector3Stamped: x roll, y pitch, z meridional, rad; NaN where
the DiagnosticArray says "pending"), and ``/diagnostics``. The alignment and statistics are
:class:`pmv_ros.runtime.monitor.ErrorMonitor`; this node only converts and wires.

Statistics are driven by the sample stamps, so the node behaves the same on
the wall clock and on a fast-time ``/clock``; a 1 Hz node-clock timer times
out samples waiting for truth when nothing arrives at all and publishes
``/diagnostics``. Inputs are best-effort subscriptions (README "QoS");
memory is bounded by the monitor's caps.

Bad input is dropped before it touches any state and counted per reason
(``rejected_<stream>_<reason>``: the checks of :mod:`pmv_ros.runtime.validation`,
with the ``input.*`` plausibility bounds), messages the shim cannot read as
``rejected_<stream>_unreadable``, messages stamped in another frame than their
stream's (``frames.*``: angles in the sensor frame, truth in the orbital one,
odometry from ``eci`` to the orbital frame) as ``rejected_<stream>_wrong_frame``; only accepted sensor samples drive the
statistics schedule. Only the first publisher heard on each input is used; a
second one is an ERROR on ``/diagnostics`` with the publishers' count and its
messages are dropped (``other_source_<topic>``). Outages, restarts and clock
jumps: README "Truth outages and discontinuities" and the core monitor's
docstring — in short, nothing is interpolated across a gap, a confirmed jump
back resets the alignment once, a single forged jump is an outlier, a
parameter change starts the statistics over.
"""

from __future__ import annotations

import sys

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from nav_msgs.msg import Odometry

import pmv_msgs_shim as shim
from .base import PmvNode
from ..runtime.assembly import MONITOR_PARAMS as PARAMS, build_monitor
from ..runtime.monitor import ErrorMonitor
from ..runtime.frames import Frames
from ..runtime.monitor_records import SENSOR_REJECTIONS, Status
from ..runtime.validation import Rejection, check_frame
from ..analysis.statistics import CHANNELS
from .launch import run_node
from .managed import managed_factory, managed_requested
from .params import ParameterError, declare, install_validation


#: The numeric statistics topics (``pmv/residual_<name>``) and the channel statistic each carries, rad;
#: "limit" is the half-width 3σ of the bound mean ± 3σ (``three_sigma_arcmin`` on /pmv/error_statistics).
STATISTICS_VECTORS = {"mean": "mean_rad", "sigma": "sigma_rad", "limit": "three_sigma_rad"}


class ErrorMonitorNode(PmvNode):
    """Aligns the sensor with truth and publishes residuals and live statistics."""

    def __init__(self, **kwargs):
        super().__init__("error_monitor_node", **kwargs)
        self._values = declare(self, PARAMS)
        try:
            self._frames = Frames.from_values(self._values)
            self._monitor = build_monitor(self._values)
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
        # What the node refuses before the core sees it: messages the shim cannot read, and messages
        # stamped in another frame than their stream's (fixed keys: memory stays bounded).
        self._rejected_messages = {f"rejected_{stream}_{reason}": 0 for stream in ("sensor", "truth", "odometry")
                                   for reason in ("unreadable", Rejection.WRONG_FRAME.value)}
        self._next_statistics_s = None
        self._last_statistics = None
        self._rejected_reported = 0
        self.create_timer(1.0, self._on_timer)
        self.get_logger().info(f"error_monitor_node: ready, statistics at {self._values['statistics_rate_hz']:g} Hz, "
                               f"{self.clock_name()}")

    def _rebuild(self, values: dict) -> None:
        # A new configuration starts new statistics: mixing two configurations would mean nothing.
        self._monitor = build_monitor(values)
        self._next_statistics_s = None
        for lock in self.source_locks.values():
            lock.timeout_s = values["input.source_timeout_s"]

    def _now_s(self) -> float | None:
        now = self.get_clock().now().nanoseconds * 1e-9
        return now if now > 0.0 else None

    def _reject(self, stream: str, reason: str = "unreadable") -> None:
        """Count a message of ``stream`` the node refused before the core (fixed keys: memory stays bounded)."""
        self._rejected_messages[f"rejected_{stream}_{reason}"] += 1

    def _in_frame(self, stream: str, frame_id: str, expected: str) -> bool:
        """Whether a message of ``stream`` is stamped in ``expected``; counts it as rejected when not."""
        rejection = check_frame(frame_id, expected)
        if rejection is not None:
            self._reject(stream, rejection.value)
        return rejection is None

    # -- inputs ------------------------------------------------------------------------------------

    def _on_odometry(self, message: Odometry) -> None:
        # nav_msgs: the pose in header.frame_id (ECI), the twist in child_frame_id (orbital).
        if not (self._in_frame("odometry", message.header.frame_id, self._frames.eci)
                and self._in_frame("odometry", message.child_frame_id, self._frames.orbital)):
            return
        try:
            stamp_s, position, velocity = shim.read_orbit_state(message)
        except ValueError:
            self._reject("odometry")
            return
        # Validated (a bound Earth orbit, sane stamps) and kept in the core; a confirmed clock jump resets there.
        self._monitor.add_odometry(stamp_s, position, velocity, now_s=self._now_s())
        self._handle(self._monitor.take_settled())

    def _on_truth(self, message: QuaternionStamped) -> None:
        if not self._in_frame("truth", message.header.frame_id, self._frames.orbital):
            return
        try:
            stamp_s, q_xyzw = shim.read_attitude_quaternion(message)
        except ValueError:
            self._reject("truth")
            return
        self._handle(self._monitor.add_truth_quaternion(stamp_s, q_xyzw, now_s=self._now_s()))

    def _on_sensor(self, message: Vector3Stamped) -> None:
        if not self._in_frame("sensor", message.header.frame_id, self._frames.sensor):
            return
        try:
            stamp_s, roll_rad, pitch_rad = shim.read_attitude_angles(message)
        except ValueError:
            self._reject("sensor")
            return
        orbit = self._monitor.orbit_at(stamp_s, self._values["odometry_timeout_s"])
        if self._values["sensor.oblateness_compensation"]:
            # Removed on board already: the model left in the sensor's output is zero.
            orbit.update(oblateness_roll_rad=0.0, oblateness_pitch_rad=0.0)
        outcomes = self._monitor.add_sensor(stamp_s, roll_rad, pitch_rad, now_s=self._now_s(), **orbit)
        self._handle(outcomes)
        # A rejected sample (a zero or future stamp, say) must not move the statistics schedule.
        if not any(outcome.status in SENSOR_REJECTIONS for outcome in outcomes):
            self._maybe_publish_statistics(stamp_s)

    def _handle(self, outcomes) -> None:
        for outcome in outcomes:
            if outcome.status is Status.OK:
                # One message, filled in place for every residual (rclpy serialises at publish).
                self._pub_residual.publish(shim.write_attitude_angles(
                    self._out_residual, outcome.stamp_s, self._frames.sensor,
                    outcome.residual_roll_rad, outcome.residual_pitch_rad))

    # -- outputs -----------------------------------------------------------------------------------

    def _maybe_publish_statistics(self, stamp_s: float) -> None:
        period = 1.0 / self._values["statistics_rate_hz"]
        if self._next_statistics_s is None or stamp_s < self._next_statistics_s - period:
            self._next_statistics_s = stamp_s  # first sample, or the clock went back
        if stamp_s >= self._next_statistics_s:
            self.publish_statistics(stamp_s)
            self._next_statistics_s = stamp_s + period

    def publish_statistics(self, stamp_s: float) -> shim.ErrorStatistics:
        """Publish the current statistics on /pmv/error_statistics (and return them)."""
        statistics = shim.ErrorStatistics.from_summary(self._monitor.summary(), stamp_s)
        self._pub_statistics.publish(shim.write_error_statistics(self._out_statistics, statistics))
        for name, field in STATISTICS_VECTORS.items():
            publisher, message = self._pub_numbers[name]
            publisher.publish(shim.write_statistics_vector(message, stamp_s, self._frames.sensor, *(
                getattr(statistics.channel(channel), field) for channel in CHANNELS)))
        self._last_statistics = statistics
        return statistics

    @property
    def latest_orbit_stamp_s(self) -> float | None:
        """Stamp of the last /orbit/odometry taken, s (None before the first)."""
        return self._monitor.latest_orbit_stamp_s

    @property
    def monitor(self) -> ErrorMonitor:
        """The monitor core (read-only use: reports, tests)."""
        return self._monitor

    #: Relative difference between the orbital period of /orbit/odometry and the configured one
    #: above which /diagnostics warns: the harmonics are fitted on the configured period.
    PERIOD_MISMATCH = 0.01

    def _period_mismatch(self) -> str | None:
        """A warning when /orbit/odometry flies another orbit than the parameters describe, else None."""
        measured_s = self._monitor.odometry_period_s
        if measured_s is None:
            return None
        configured_s = self._monitor.config.orbital_period_s
        if abs(measured_s - configured_s) <= self.PERIOD_MISMATCH * configured_s:
            return None
        return (f"/orbit/odometry gives an orbital period of {measured_s:.0f} s, the parameters "
                f"{configured_s:.0f} s: harmonics are fitted on the parameters' period (set orbit.altitude_km)")

    def _on_timer(self) -> None:
        now = self._now_s()
        self._handle(self._monitor.poll(now))
        counters = self._monitor.counters
        skipped = {k: v for k, v in counters.items() if k.startswith("skipped_") and v}
        rejected = {k: v for k, v in counters.items() if k.startswith("rejected_") and v}
        rejected.update({k: v for k, v in self._rejected_messages.items() if v})
        problems = self.input_source_problems()  # a second publisher on an input: ERROR
        source_error = bool(problems)
        latest_truth = self._monitor.latest_truth_stamp_s
        if counters["truth_received"] == 0:
            problems.append("no star-tracker truth received yet")
        elif now is not None and latest_truth is not None and now - latest_truth > self._values["max_truth_wait_s"]:
            problems.append(f"no star-tracker truth for {now - latest_truth:.0f} s")
        # Samples waiting for truth are normal (the star tracker's latency); an outage shows as truth age above.
        mismatch = self._period_mismatch()
        if mismatch is not None:
            problems.append(mismatch)
        rejected_total = sum(rejected.values())
        if rejected_total > self._rejected_reported:
            problems.append("rejected input messages")
        self._rejected_reported = rejected_total
        level = shim.Level.ERROR if source_error else shim.Level.WARN if problems else shim.Level.OK
        values = {"used": counters["used"], **skipped, **rejected, **self.input_source_counters(),
                  **{k: counters[k] for k in ("truth_quaternions_normalised", "clock_jumps", "clock_outliers",
                                              "alignment_resets") if counters[k]},
                  "pending": self._monitor.pending_count, "truth_buffer": self._monitor.truth_buffer_length}
        self._pub_diagnostics.publish(shim.write_health(self._out_diagnostics, shim.HealthReport(
            stamp_s=now or 0.0, statuses=(shim.HealthStatus(
                name=self.status_name(), level=level,
                message="; ".join(problems) if problems else "aligned with truth",
                hardware_id=self.hardware_id("pmv"), values=values),))))


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros error_monitor_node [--managed]``."""
    if managed_requested(args):  # --managed: a lifecycle node (pmv_ros/nodes/managed.py)
        return run_node(managed_factory(ErrorMonitorNode, "error_monitor_node"), "error_monitor_node", args)
    return run_node(ErrorMonitorNode, "error_monitor_node", args)


if __name__ == "__main__":
    sys.exit(main())
