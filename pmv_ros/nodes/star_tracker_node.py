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

The node only wires: its runtime (:class:`pmv_ros.runtime.tracker.runtime.TrackerRuntime`)
checks each truth message, runs the frame loop and assembles ``/diagnostics``;
what it does with bad input and discontinuities: :mod:`pmv_ros.runtime.tracker.runtime`.
"""

from __future__ import annotations

import sys

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped

import pmv_msgs_shim as shim
from .base import PmvNode
from ..runtime.common.assembly import STAR_TRACKER_PARAMS as PARAMS
from ..runtime.common.records import HealthSummary
from ..runtime.tracker.runtime import TrackerRuntime
from .launch import node_main
from .params import ParameterError, declare, install_validation


class StarTrackerNode(PmvNode):
    """BOKZ-class star tracker fed with the true attitude."""

    def __init__(self, **kwargs):
        super().__init__("star_tracker_node", **kwargs)
        self._values = declare(self, PARAMS)
        try:
            self._runtime = TrackerRuntime(self._values, self.get_clock().now().nanoseconds * 1e-9,
                                           source_problems=self.input_source_problems,
                                           source_counters=self.input_source_counters)
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
        # Stale input: no truth for a while is reported even though no truth callback runs.
        self.create_timer(1.0, self._on_timer)
        self.get_logger().info(f"star_tracker_node: ready, {self._values['rate_hz']:g} Hz frames, "
                               f"latency {self._values['latency_s']:g} s, {self.clock_name()}")

    def _rebuild(self, values: dict) -> None:
        self._runtime.reconfigure(values)  # a combination it refuses (ValueError) changes nothing
        self.set_source_timeout(values["input.source_timeout_s"])

    def _now_s(self) -> float | None:
        now = self.get_clock().now().nanoseconds * 1e-9
        return now if now > 0.0 else None  # sim time before the first /clock: unknown

    def _on_truth(self, message: QuaternionStamped) -> None:
        try:
            t_s, q_xyzw = shim.read_attitude_quaternion(message)
        except ValueError:  # a negative or non-finite stamp
            t_s = q_xyzw = None
        output = self._runtime.receive_truth(message.header.frame_id, t_s, q_xyzw, self._now_s())
        for frame_s, q_measured in output.released:
            self._publisher.publish(shim.write_attitude_quaternion(self._out, frame_s, self._runtime.frames.orbital,
                                                                     q_measured))
        if output.health is not None:
            self._publish_health(t_s, output.health)

    def _on_timer(self) -> None:
        """Report a stale input: no truth for longer than max_truth_gap_s (nothing else would say so)."""
        now = self._now_s()
        health = self._runtime.stale_health(now)
        if health is not None:
            self._publish_health(now, health)

    def _publish_health(self, t_s: float, health: HealthSummary) -> None:
        self._diagnostics.publish(shim.write_health(self._out_diagnostics,
                                                    self.health_report(t_s, health, device="star_tracker")))

    @property
    def release_queue_length(self) -> int:
        """Measured frames waiting for their release (at most latency × rate)."""
        return len(self._runtime.queue)

    @property
    def counters(self) -> dict:
        """Frame outcomes and input counters (a copy), as on /diagnostics."""
        return self._runtime.counters


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros star_tracker_node [--managed]``."""
    return node_main(StarTrackerNode, "star_tracker_node", args)


if __name__ == "__main__":
    sys.exit(main())
