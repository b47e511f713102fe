"""``star_tracker_node``: true attitude → star-tracker measurements (physics.md §6).

Subscribes to ``/attitude/truth`` and publishes ``/star_tracker/attitude``:
frames on a regular grid of its own rate (the true attitude slerped to each
frame time), measured by :class:`pmv_ros.core.star_tracker.StarTracker`
(noise, 300″/s rate limit, outage windows, random failures), stamped with
the frame time and released ``latency_s`` later. Nothing is published for a
frame without attitude; ``/diagnostics`` says why.

Frames are driven by the truth stream, so the node runs the same on the wall
clock and on a fast-time ``/clock``. QoS: reliable, keep-last 100.
"""

from __future__ import annotations

import math
import sys
from collections import deque

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped
from scipy.spatial.transform import Rotation, Slerp

import pmv_msgs_shim as shim
from .base import PmvNode
from ..core.constants import ARCSEC_RAD, GM_EARTH_M3_S2, EARTH_MEAN_RADIUS_M
from ..core.star_tracker import Outcome, StarTracker, StarTrackerParameters, inertial_rate_of_nadir_pointing
from .launch import run_node
from .params import ParamSpec, declare, install_validation


PARAMS = (
    ParamSpec("orbit.altitude_km", 500.0, "orbit altitude (gives the orbital rate for the rate limit)",
              150.0, 40000.0, unit="km"),
    ParamSpec("rate_hz", 2.0, "frame rate of the star tracker", 0.01, 50.0, unit="Hz"),
    ParamSpec("latency_s", 0.25, "delay from frame time to publication", 0.0, 60.0, unit="s"),
    ParamSpec("noise_cross_arcsec", 3.0, "1-sigma noise across the boresight", 0.0, 3600.0, unit="arcsec"),
    ParamSpec("noise_boresight_arcsec", 20.0, "1-sigma noise about the boresight", 0.0, 3600.0, unit="arcsec"),
    ParamSpec("max_rate_arcsec_s", 300.0, "no attitude above this inertial angular rate", 1.0, 36000.0,
              unit="arcsec/s"),
    ParamSpec("random_failure_probability", 1e-3, "probability that a single frame fails", 0.0, 1.0),
    ParamSpec("outage_start_s", [-1.0], "start of each scheduled outage after node start (negative: none)",
              -1.0, 1e9, unit="s"),
    ParamSpec("outage_duration_s", [0.0], "duration of each scheduled outage", 0.0, 1e9, unit="s"),
    ParamSpec("max_truth_gap_s", 5.0, "no frame is interpolated across a truth gap longer than this",
              0.001, 3600.0, unit="s"),
    ParamSpec("seed", 0, "seed of the noise and failures", 0, 2**31 - 1),
)


def build_tracker(values: dict, start_s: float) -> StarTracker:
    """The star-tracker model from parameter values; ValueError if inconsistent."""
    starts, durations = list(values["outage_start_s"]), list(values["outage_duration_s"])
    if len(starts) != len(durations):
        raise ValueError(f"outage_start_s has {len(starts)} entries but outage_duration_s has {len(durations)}")
    outages = tuple((start_s + s, start_s + s + d) for s, d in zip(starts, durations) if s >= 0.0 and d > 0.0)
    return StarTracker(StarTrackerParameters(
        noise_cross_rad=values["noise_cross_arcsec"] * ARCSEC_RAD,
        noise_boresight_rad=values["noise_boresight_arcsec"] * ARCSEC_RAD,
        max_rate_rad_s=values["max_rate_arcsec_s"] * ARCSEC_RAD,
        random_failure_probability=values["random_failure_probability"],
        outages=outages), seed=values["seed"])


class StarTrackerNode(PmvNode):
    """BOKZ-class star tracker fed with the true attitude."""

    def __init__(self, **kwargs):
        super().__init__("star_tracker_node", **kwargs)
        self._values = declare(self, PARAMS)
        self._start_s = self.get_clock().now().nanoseconds * 1e-9
        self._tracker = build_tracker(self._values, self._start_s)
        install_validation(self, PARAMS, self._values, self._rebuild)
        self._publisher = self.publisher(QuaternionStamped, "/star_tracker/attitude")
        self._diagnostics = self.publisher(DiagnosticArray, "/diagnostics")
        self.subscription(QuaternionStamped, "/attitude/truth", self._on_truth)
        self._previous = None  # (stamp_s, q_xyzw)
        self._next_frame_s = None
        self._queue = deque()  # (release_s, record), bounded by latency × rate
        self._outcomes = {outcome: 0 for outcome in Outcome}
        self._rejected = {}
        self._last_outcome = Outcome.OK
        self._last_diagnostics_s = -math.inf

    def _rebuild(self, values: dict) -> None:
        self._tracker = build_tracker(values, self._start_s)

    def _mean_motion(self) -> float:
        return math.sqrt(GM_EARTH_M3_S2 / (EARTH_MEAN_RADIUS_M + self._values["orbit.altitude_km"] * 1e3) ** 3)

    def _on_truth(self, message: QuaternionStamped) -> None:
        try:
            truth = shim.attitude_quaternion_from_msg(message)
        except ValueError as error:
            self._rejected[str(error)] = self._rejected.get(str(error), 0) + 1
            return
        t_s = truth.stamp_s
        current = truth.q_xyzw  # a Rotation is built only when a frame falls due (1 truth sample in 5 at 10 Hz)
        previous = self._previous
        if previous is not None and t_s <= previous[0]:
            self._rejected["stamp not increasing"] = self._rejected.get("stamp not increasing", 0) + 1
            return
        self._previous = (t_s, current)
        period = 1.0 / self._values["rate_hz"]
        if previous is None or self._next_frame_s is None or t_s - previous[0] > self._values["max_truth_gap_s"]:
            # First sample, or a gap in the truth: restart the frame grid here, never interpolate across.
            self._next_frame_s = math.ceil(t_s / period) * period
            previous = None
        if previous is not None:
            frames = np.arange(self._next_frame_s, t_s + 1e-12, period)
            if frames.size:
                pair = Rotation.from_quat(np.stack([previous[1], current]))
                slerp = Slerp([previous[0], t_s], pair)
                relative = (pair[1] * pair[0].inv()).as_rotvec() / (t_s - previous[0])
                rate = inertial_rate_of_nadir_pointing(self._mean_motion(), relative)
                q_frames = slerp(frames).as_quat().T
                measured, outcomes = self._tracker.measure(frames, q_frames, np.full(frames.size, rate))
                for k, outcome in enumerate(outcomes):
                    self._outcomes[Outcome(int(outcome))] += 1
                    self._last_outcome = Outcome(int(outcome))
                    if outcome == Outcome.OK:
                        self._queue.append((frames[k] + self._values["latency_s"], shim.AttitudeQuaternion(
                            stamp_s=float(frames[k]), frame_id=shim.ORBITAL_FRAME,
                            q_xyzw=tuple(measured[:, k]))))
                self._next_frame_s = frames[-1] + period
        while self._queue and self._queue[0][0] <= t_s + 1e-9:
            self._publisher.publish(shim.attitude_quaternion_to_msg(self._queue.popleft()[1]))
        self._maybe_publish_diagnostics(t_s)

    def _maybe_publish_diagnostics(self, t_s: float) -> None:
        if t_s - self._last_diagnostics_s < 1.0:
            return
        self._last_diagnostics_s = t_s
        outage = self._last_outcome != Outcome.OK
        values = {f"frames_{o.name.lower()}": n for o, n in self._outcomes.items()}
        values.update({f"rejected: {reason}": n for reason, n in self._rejected.items()})
        message = (f"star-tracker outage: {self._last_outcome.name.lower().replace('_', ' ')}" if outage
                   else "attitude available")
        level = shim.Level.WARN if outage or self._rejected else shim.Level.OK
        self._diagnostics.publish(shim.health_to_msg(shim.HealthReport(stamp_s=t_s, statuses=(shim.HealthStatus(
            name="pmv_ros/star_tracker_node", level=level, message=message, hardware_id="star_tracker",
            values=values),))))


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros star_tracker_node``."""
    return run_node(StarTrackerNode, "star_tracker_node", args)


if __name__ == "__main__":
    sys.exit(main())
