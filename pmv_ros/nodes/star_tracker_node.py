"""``star_tracker_node``: true attitude → star-tracker measurements (physics.md §6).

Subscribes to ``/attitude/truth`` and publishes ``/star_tracker/attitude``:
frames on a regular grid (``frame_period_s``; the true attitude slerped to
each frame time, the middle of the exposure), measured by
:class:`pmv_ros.physics.star_tracker.StarTracker` on the real sky of the
orbit the preset flies (smear, recognition, accuracy from the stars in the
field, proton hits, Sun/Moon/Earth exclusion, outage windows), stamped with
the frame time and published ``exposure_s/2 + processing_s`` later. Nothing
is published on it for a frame without attitude; ``/star_tracker/frame_status``
says for every frame, when it is measured, whether it has one and why not
(its reason, stars in the field, proton hits: the error monitor counts its
samples without truth by that reason), and ``/diagnostics`` counts them
(``frames_<reason>`` counters, the last frame's ``stars_in_field`` and
``proton_hits``).

Frames are driven by the truth stream, so the node runs the same on the wall
clock and on a fast-time ``/clock``. QoS: reliable, keep-last 100; the
release queue holds at most (``exposure_s/2 + processing_s``) / ``frame_period_s`` + 1 frames.

The node only wires (:data:`TOPICS`). It queues the truth messages of one executor wake-up and hands them to its
runtime (:class:`pmv_ros.runtime.tracker.runtime.TrackerRuntime`) as one batch when its wake-up guard is handled,
after that wake-up's messages: a message waits at most until the end of the next wake-up, never for a timer or
for simulated time, and what is published — and in which order — is what one message at a time gives. The
runtime checks each message, runs the frame loop and assembles ``/diagnostics``; what it does with bad input and
discontinuities: :mod:`pmv_ros.runtime.tracker.runtime`.
"""

from __future__ import annotations

import sys

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped
from nav_msgs.msg import Odometry

import pmv_msgs_shim as shim
from .base import PmvNode, Pub, Sub
from ..runtime.common.assembly import STAR_TRACKER_PARAMS as PARAMS
from ..runtime.common.records import HealthAt
from ..runtime.tracker.runtime import FrameStatus, ReleasedFrame, TrackerRuntime
from .launch import node_main
from .managed import ManagedNode
from .params import ParameterError, declare, install_validation

#: What the star tracker publishes and takes (relative names: in a namespace, this spacecraft's topics move under
#: it, interfaces.md "Topics").
TOPICS = (
    Pub("star_tracker/attitude", QuaternionStamped, ReleasedFrame, lambda m, frame, n: shim.write_attitude_quaternion(
        m, frame.frame_s, n.frames.orbital, frame.q_measured)),
    Pub("star_tracker/frame_status", DiagnosticArray, FrameStatus, lambda m, f, n: shim.write_frame_status(
        m, f.frame_s, f.reason, f.stars, f.hits, n.hardware_id("star_tracker"))),
    Pub("/diagnostics", DiagnosticArray, HealthAt, lambda m, h, n: shim.write_health(
        m, n.health_report(h.stamp_s, h.health, device="star_tracker"))),
    Sub("attitude/truth", QuaternionStamped, shim.quaternion_input, "receive_truth"),
    # orbit.source follow: the user's orbit, the one the frames are measured on (the sensor's, followed alike).
    Sub("orbit/odometry", Odometry, shim.odometry_input, "add_odometry", when=lambda n: n.follows_orbit),
)


class StarTrackerNode(PmvNode):
    """BOKZ-class star tracker fed with the true attitude."""

    BATCHED = True
    NODE_NAME = "star_tracker_node"

    def build(self) -> None:
        """Parameters, runtime, topics and the 1 Hz timer (see :class:`~pmv_ros.nodes.base.PmvNode`)."""
        self._values = declare(self, PARAMS)
        try:
            self._runtime = TrackerRuntime(self._values, self.now_s(),
                                           source_problems=self.input_source_problems,
                                           source_counters=self.input_source_counters)
        except ValueError as error:  # a combination the ranges cannot check
            raise ParameterError(str(error)) from None
        install_validation(self, PARAMS, self._values, self._rebuild)
        self.wire(TOPICS, self._values["input.source_timeout_s"])
        # Stale input: no truth for a while is reported even though no truth callback runs.
        self.make_timer(1.0, self._on_timer)
        self.get_logger().info(f"{self.get_fully_qualified_name()}: ready, a frame every "
                               f"{self._values['frame_period_s']:g} s, published {self.runtime.delay_s:g} s "
                               f"after its time, {self.clock_name()}")

    def _rebuild(self, values: dict) -> None:
        self.flush_inputs()  # what arrived before the change goes through the configuration it arrived under
        self._runtime.reconfigure(values)  # a combination it refuses (ValueError) changes nothing
        self.sources.set_timeout(values["input.source_timeout_s"])

    def _on_timer(self) -> None:
        """Report a stale input: no truth for longer than max_truth_gap_s (nothing else would say so)."""
        self.flush_inputs()
        now = self.input_clock(self.now_s())
        health = self._runtime.stale_health(now)
        if health is not None:
            self.emit(HealthAt, HealthAt(now, health))

    @property
    def follows_orbit(self) -> bool:
        """Whether the frames are measured on the user's orbit/odometry (``orbit.source: follow``)."""
        return self._values["orbit.source"] == "follow"

    @property
    def release_queue_length(self) -> int:
        """Measured frames waiting for their publication (at most the delay × the frame rate, plus one)."""
        self.flush_inputs()
        return len(self._runtime.queue)

    @property
    def counters(self) -> dict:
        """Frame outcomes and input counters (a copy), as on /diagnostics."""
        self.flush_inputs()
        return self._runtime.counters


class ManagedStarTrackerNode(ManagedNode, StarTrackerNode):
    """:class:`StarTrackerNode` as a managed (lifecycle) node (:mod:`pmv_ros.nodes.managed`)."""


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros star_tracker_node [--managed]``."""
    return node_main(StarTrackerNode, ManagedStarTrackerNode, args)


if __name__ == "__main__":
    sys.exit(main())
