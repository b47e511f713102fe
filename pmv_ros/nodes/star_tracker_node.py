"""``star_tracker_node``: true attitude → star-tracker measurements (physics.md §6).

Subscribes to ``/attitude/truth`` and publishes ``/star_tracker/attitude``:
frames on a regular grid of its own rate (the true attitude slerped to each
frame time), measured by :class:`pmv_ros.physics.star_tracker.StarTracker`
(noise, 300″/s rate limit, outage windows, random failures), stamped with
the frame time and released ``latency_s`` later. Nothing is published for a
frame without attitude; ``/diagnostics`` says why.

Frames are driven by the truth stream, so the node runs the same on the wall
clock and on a fast-time ``/clock``. QoS: reliable, keep-last 100; the
release queue holds at most ``latency_s × rate_hz`` frames.

Bad input (issues 6, 15; the checks are :mod:`pmv_ros.runtime.validation`): a
truth message with a non-finite or far-from-unit quaternion, a zero, future
(beyond ``future_tolerance_s`` of the node clock), duplicate, backward or
too-fast (``input.max_rate_hz``) stamp, or stamped in another frame than the
orbital one (``rejected_truth_wrong_frame``: an inertial quaternion, say), is
dropped and counted per reason on ``/diagnostics``; a near-unit quaternion is normalised. None of them moves
the frame grid, so the frames published are those of the clean stream. Only
the first publisher of ``/attitude/truth`` heard is used; a second one is an
ERROR on ``/diagnostics`` and its messages are dropped.

Discontinuities: a truth gap longer than ``max_truth_gap_s`` (the sensor
stopped, or was restarted and continues on the same clock) restarts the frame
grid at the next truth sample — nothing is interpolated across it. A stamp
that goes back by more than ``clock_jump_s`` (the simulation or the sensor
restarted on a new clock), once the next stamp confirms it (a single stamp
that the next one contradicts is an outlier, counted ``clock_outliers``),
starts a new timeline: frames of the old one still
waiting for release are dropped (counted), the grid restarts. No truth
arriving for longer than ``max_truth_gap_s`` (by the node clock) is reported
on ``/diagnostics`` as a stale input.
"""

from __future__ import annotations

import math
import sys

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped

import pmv_msgs_shim as shim
from .base import PmvNode
from ..physics.star_tracker import Outcome
from ..runtime.assembly import STAR_TRACKER_PARAMS as PARAMS
from ..runtime.tracker import TrackerRuntime
from ..runtime.frames import Frames
from ..runtime.validation import TRUTH_REJECTIONS, Rejection, StampCheck, check_frame, check_quaternion_sample
from .launch import run_node
from .managed import managed_factory, managed_requested
from .params import ParameterError, declare, install_validation



#: Why a truth message is dropped here: the checks of the stream, and a frame other than the orbital one.
_REJECTIONS = TRUTH_REJECTIONS + (Rejection.WRONG_FRAME,)


class StarTrackerNode(PmvNode):
    """BOKZ-class star tracker fed with the true attitude."""

    def __init__(self, **kwargs):
        super().__init__("star_tracker_node", **kwargs)
        self._values = declare(self, PARAMS)
        self._start_s = self.get_clock().now().nanoseconds * 1e-9
        try:
            self._frames = Frames.from_values(self._values)
            self._runtime = TrackerRuntime(self._values, self._start_s)
            self._stamps = StampCheck(1.0, 1.0).reconfigured(self._values["clock_jump_s"],
                                                             self._values["future_tolerance_s"],
                                                             1.0 / self._values["input.max_rate_hz"])
        except ValueError as error:  # a combination the ranges cannot check
            raise ParameterError(str(error)) from None
        install_validation(self, PARAMS, self._values, self._rebuild)
        # Relative names: in a namespace, this spacecraft's topics move under it (interfaces.md "Topics").
        self._publisher = self.publisher(QuaternionStamped, "star_tracker/attitude")
        self._diagnostics = self.publisher(DiagnosticArray, "/diagnostics")
        self.watch_clock(self._diagnostics)
        self.input_subscription(QuaternionStamped, "attitude/truth", self._on_truth,
                                self._values["input.source_timeout_s"])
        # Filled in place for every publication (rclpy serialises at publish).
        self._out, self._out_diagnostics = QuaternionStamped(), DiagnosticArray()
        self._counters = {f"rejected_truth_{reason.value}": 0 for reason in _REJECTIONS}
        self._counters.update(truth_quaternions_normalised=0, clock_jumps=0, clock_outliers=0,
                              frames_dropped_at_clock_jump=0)
        self._rejected_reported = 0
        self._last_diagnostics_s = -math.inf
        # Stale input: no truth for a while is reported even though no truth callback runs.
        # Measured by arrival on the node clock, so a source whose stamps are on another clock is not "stale".
        self._last_arrival_s = None
        self.create_timer(1.0, self._on_timer)
        self.get_logger().info(f"star_tracker_node: ready, {self._values['rate_hz']:g} Hz frames, "
                               f"latency {self._values['latency_s']:g} s, {self.clock_name()}")

    def _rebuild(self, values: dict) -> None:
        # The stamp check first: it refuses a combination the ranges cannot (ValueError), and then nothing changed.
        stamps = self._stamps.reconfigured(values["clock_jump_s"], values["future_tolerance_s"],
                                           1.0 / values["input.max_rate_hz"])
        self._runtime.reconfigure(values)
        self._stamps = stamps
        for lock in self.source_locks.values():
            lock.timeout_s = values["input.source_timeout_s"]

    def _now_s(self) -> float | None:
        now = self.get_clock().now().nanoseconds * 1e-9
        return now if now > 0.0 else None  # sim time before the first /clock: unknown

    def _new_timeline(self) -> None:
        """The truth clock went back: forget the old timeline (frames not yet released are dropped)."""
        self._counters["clock_jumps"] += 1
        self._counters["frames_dropped_at_clock_jump"] += self._runtime.new_timeline()
        self._last_diagnostics_s = -math.inf

    def _on_truth(self, message: QuaternionStamped) -> None:
        rejection = check_frame(message.header.frame_id, self._frames.orbital)  # an inertial quaternion, say
        if rejection is not None:
            self._counters[f"rejected_truth_{rejection.value}"] += 1
            return
        try:
            t_s, q_xyzw = shim.read_attitude_quaternion(message)
        except ValueError:  # a negative or non-finite stamp
            self._counters[f"rejected_truth_{Rejection.ZERO_STAMP.value}"] += 1
            return
        now_s = self._last_arrival_s = self._now_s()
        sample = check_quaternion_sample(self._stamps, t_s, q_xyzw, now_s)
        self._counters["clock_outliers"] += sample.outliers
        if sample.jumped:
            self._new_timeline()
        if sample.rejection is not None:
            self._counters[f"rejected_truth_{sample.rejection.value}"] += 1
            return
        self._counters["truth_quaternions_normalised"] += sample.normalised
        self._runtime.add_truth(t_s, sample.q_xyzw)
        for frame_s, q_measured in self._runtime.release(t_s):
            self._publisher.publish(shim.write_attitude_quaternion(self._out, frame_s, self._frames.orbital,
                                                                     q_measured))
        self._maybe_publish_diagnostics(t_s)

    def _maybe_publish_diagnostics(self, t_s: float) -> None:
        if t_s - self._last_diagnostics_s < 1.0:
            return
        self._last_diagnostics_s = t_s
        problems = []
        last = self._runtime.last_outcome
        if last != Outcome.OK:
            problems.append(f"star-tracker outage: {last.name.lower().replace('_', ' ')}")
        self._publish_diagnostics(t_s, problems)

    def _on_timer(self) -> None:
        """Report a stale input: no truth for longer than max_truth_gap_s (nothing else would say so)."""
        now = self._now_s()
        if now is None:
            return
        last = self._start_s if self._last_arrival_s is None else self._last_arrival_s
        if now - last > self._values["max_truth_gap_s"]:
            what = "received" if self._last_arrival_s is None else f"for {now - last:.0f} s"
            self._publish_diagnostics(now, [f"no /attitude/truth {what} (stale input)"])

    def _publish_diagnostics(self, t_s: float, problems: list) -> None:
        values = {f"frames_{o.name.lower()}": n for o, n in self._runtime.outcomes.items()}
        values.update(self._counters)
        values.update(self.input_source_counters())
        values["release_queue"] = len(self._runtime.queue)
        rejected = sum(self._counters[f"rejected_truth_{reason.value}"] for reason in _REJECTIONS)
        if rejected > self._rejected_reported:
            problems = problems + ["rejected /attitude/truth messages"]
        self._rejected_reported = rejected
        source_errors = self.input_source_problems()
        problems = source_errors + problems
        level = shim.Level.ERROR if source_errors else shim.Level.WARN if problems else shim.Level.OK
        report = shim.HealthReport(stamp_s=t_s, statuses=(shim.HealthStatus(
            name=self.status_name(), level=level, message="; ".join(problems) or "attitude available",
            hardware_id=self.hardware_id("star_tracker"), values=values),))
        self._diagnostics.publish(shim.write_health(self._out_diagnostics, report))

    @property
    def release_queue_length(self) -> int:
        """Measured frames waiting for their release (at most latency × rate)."""
        return len(self._runtime.queue)

    @property
    def counters(self) -> dict:
        """Frame outcomes and input counters (a copy), as on /diagnostics."""
        values = {f"frames_{o.name.lower()}": n for o, n in self._runtime.outcomes.items()}
        values.update(self._counters)
        return values


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros star_tracker_node [--managed]``."""
    if managed_requested(args):  # --managed: a lifecycle node (pmv_ros/nodes/managed.py)
        return run_node(managed_factory(StarTrackerNode, "star_tracker_node"), "star_tracker_node", args)
    return run_node(StarTrackerNode, "star_tracker_node", args)


if __name__ == "__main__":
    sys.exit(main())
