"""star_tracker_node's work without ROS: frames on its grid, the tracker's draws, the latency queue.

One frame loop for the node (one truth message at a time) and the campaign's
flight (a whole truth stream): each truth sample adds the frames that fall
before it (the true attitude slerped to them, :class:`FrameGrid`), the tracker
measures them at the nadir-pointing inertial rate
(:meth:`StarTracker.measure_frames`), and the good ones wait ``latency_s`` in
the :class:`LatencyQueue`. Outcomes are counted as ``/diagnostics`` shows them.

The node's input side is here too (:meth:`TrackerRuntime.receive_truth`), and
its ``/diagnostics`` status (:meth:`TrackerRuntime.health`).

Bad input (the checks are :mod:`pmv_ros.runtime.validation`): a truth message
with a non-finite or far-from-unit quaternion, a zero, future (beyond
``future_tolerance_s`` of the node clock), duplicate, backward or too-fast
(``input.max_rate_hz``) stamp, or stamped in another frame than the orbital
one (``rejected_truth_wrong_frame``: an inertial quaternion, say), is dropped
and counted per reason on ``/diagnostics``; a near-unit quaternion is
normalised. None of them moves the frame grid, so the frames published are
those of the clean stream. The node uses only the first publisher of
``/attitude/truth`` heard; a second one is an ERROR on ``/diagnostics`` and
its messages are dropped.

Discontinuities: a truth gap longer than ``max_truth_gap_s`` (the sensor
stopped, or was restarted and continues on the same clock) restarts the frame
grid at the next truth sample — nothing is interpolated across it. A stamp
that goes back by more than ``clock_jump_s`` (the simulation or the sensor
restarted on a new clock), once the next stamp confirms it (a single stamp
that the next one contradicts is an outlier, counted ``clock_outliers``),
starts a new timeline: frames of the old one still waiting for release are
dropped (counted), the grid restarts. No truth arriving for longer than
``max_truth_gap_s`` (by the node clock) is a stale input
(:meth:`TrackerRuntime.stale_health`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..physics.orbit import circular_mean_motion_rad_s
from ..physics.star_tracker import FrameGrid, LatencyQueue, Outcome, inertial_rate_of_nadir_pointing
from .assembly import build_tracker
from .frames import Frames
from .records import HealthSummary, Level
from .validation import TRUTH_REJECTIONS, Rejection, StampCheck, check_frame, check_quaternion_sample

#: Why a truth message is dropped: the checks of the stream, and a frame other than the orbital one.
REJECTIONS = TRUTH_REJECTIONS + (Rejection.WRONG_FRAME,)


@dataclass
class TrackerOutput:
    """What one truth message makes the star tracker publish: released frames, maybe a /diagnostics status."""

    released: list = field(default_factory=list)  #: (frame time s, measured (x, y, z, w)) in frame order
    health: HealthSummary | None = None  #: stamped with the truth sample's time


class TrackerRuntime:
    """The star tracker fed with true attitude, one truth sample at a time.

    Args:
        values: star_tracker_node parameter values.
        start_s: the node clock at start (outage windows are relative to it), s.
        source_problems: ``() -> list`` of phrases about second sources of the truth (the node's graph):
            an ERROR on /diagnostics.
        source_counters: ``() -> dict`` of the node's input-source counters, for /diagnostics.

    Raises ValueError for a combination of values the parameter ranges cannot check.
    """

    def __init__(self, values: dict, start_s: float, *, source_problems: Callable[[], list] = list,
                 source_counters: Callable[[], dict] = dict) -> None:
        self.start_s = float(start_s)
        self.frames = Frames.from_values(values)
        self._source_problems, self._source_counters = source_problems, source_counters
        self.stamps = StampCheck(1.0, 1.0)
        self.grid = FrameGrid(1.0 / values["rate_hz"], values["max_truth_gap_s"])
        self.queue = LatencyQueue(values["latency_s"])  # bounded by latency × rate
        self.outcomes = {outcome: 0 for outcome in Outcome}
        self.last_outcome = Outcome.OK
        self.input_counts = {f"rejected_truth_{reason.value}": 0 for reason in REJECTIONS}
        self.input_counts.update(truth_quaternions_normalised=0, clock_jumps=0, clock_outliers=0,
                                 frames_dropped_at_clock_jump=0)
        self._rejected_reported = 0
        self._last_health_s = -math.inf
        # Stale input: measured by arrival on the node clock, so a source whose stamps are on another
        # clock is not "stale".
        self.last_arrival_s = None
        self.reconfigure(values)

    def reconfigure(self, values: dict) -> None:
        """New parameter values: a new tracker (its draws restart), the grid's period and the latency.

        The stamp check first: it refuses a combination the ranges cannot (ValueError), and then nothing changed.
        """
        stamps = self.stamps.reconfigured(values["clock_jump_s"], values["future_tolerance_s"],
                                          1.0 / values["input.max_rate_hz"])
        self.tracker = build_tracker(values, self.start_s)
        self.stamps, self.values = stamps, values
        self.grid.period_s, self.grid.max_gap_s = 1.0 / values["rate_hz"], values["max_truth_gap_s"]
        self.queue.latency_s = values["latency_s"]
        self.mean_motion_rad_s = circular_mean_motion_rad_s(values["orbit.altitude_km"] * 1e3)

    def new_timeline(self) -> int:
        """The truth clock went back: restart the grid and drop the frames not yet released; how many."""
        self.grid.restart()
        return self.queue.clear()

    def add_truth(self, t_s: float, q_xyzw) -> list[tuple[float, np.ndarray, Outcome]]:
        """Frames measured up to this truth sample: (frame time s, measured (x, y, z, w), outcome) each.

        A frame whose outcome is OK waits in the queue for :meth:`release`.
        """
        frames, attitudes, turn_rate = self.grid.add(t_s, q_xyzw)
        if not frames:
            return []
        rate = inertial_rate_of_nadir_pointing(self.mean_motion_rad_s, turn_rate)
        measured = []
        for frame_s, (q_measured, outcome) in zip(frames, self.tracker.measure_frames(frames, attitudes, rate)):
            self.outcomes[outcome] += 1
            self.last_outcome = outcome
            if outcome == Outcome.OK:
                self.queue.push(frame_s, q_measured)
            measured.append((frame_s, q_measured, outcome))
        return measured

    def release(self, t_s: float) -> list[tuple[float, np.ndarray]]:
        """Frames whose latency has passed at ``t_s``, in frame order: (frame time s, measured quaternion)."""
        return self.queue.release(t_s)

    # -- the node's input and health ------------------------------------------------------------

    @property
    def counters(self) -> dict:
        """Frame outcomes and input counters (a copy), as on /diagnostics."""
        values = {f"frames_{o.name.lower()}": n for o, n in self.outcomes.items()}
        values.update(self.input_counts)
        return values

    def receive_truth(self, frame_id: str, stamp_s: float | None, q_xyzw, now_s: float | None) -> TrackerOutput:
        """One /attitude/truth message (``stamp_s`` None: unreadable) at node clock ``now_s`` (None: unknown).

        A bad one is counted and changes nothing else; a good one adds frames and releases those due, and a
        /diagnostics status comes at most once a second of truth time.
        """
        counts = self.input_counts
        rejection = check_frame(frame_id, self.frames.orbital)  # an inertial quaternion, say
        if rejection is not None:
            counts[f"rejected_truth_{rejection.value}"] += 1
            return TrackerOutput()
        if stamp_s is None:  # a negative or non-finite stamp
            counts[f"rejected_truth_{Rejection.ZERO_STAMP.value}"] += 1
            return TrackerOutput()
        self.last_arrival_s = now_s
        sample = check_quaternion_sample(self.stamps, stamp_s, q_xyzw, now_s)
        counts["clock_outliers"] += sample.outliers
        if sample.jumped:  # the truth clock went back: frames of the old timeline not yet released are dropped
            counts["clock_jumps"] += 1
            counts["frames_dropped_at_clock_jump"] += self.new_timeline()
            self._last_health_s = -math.inf
        if sample.rejection is not None:
            counts[f"rejected_truth_{sample.rejection.value}"] += 1
            return TrackerOutput()
        counts["truth_quaternions_normalised"] += sample.normalised
        self.add_truth(stamp_s, sample.q_xyzw)
        output = TrackerOutput(released=self.release(stamp_s))
        if stamp_s - self._last_health_s >= 1.0:
            self._last_health_s = stamp_s
            last = self.last_outcome
            output.health = self.health(
                [] if last == Outcome.OK else [f"star-tracker outage: {last.name.lower().replace('_', ' ')}"])
        return output

    def stale_health(self, now_s: float | None) -> HealthSummary | None:
        """A status when no truth arrived for longer than max_truth_gap_s by node clock ``now_s`` (nothing
        else would say so), else None."""
        if now_s is None:
            return None
        last = self.start_s if self.last_arrival_s is None else self.last_arrival_s
        if now_s - last <= self.values["max_truth_gap_s"]:
            return None
        what = "received" if self.last_arrival_s is None else f"for {now_s - last:.0f} s"
        return self.health([f"no /attitude/truth {what} (stale input)"])

    def health(self, problems: list) -> HealthSummary:
        """The /diagnostics status with ``problems`` (phrases), the counters and the node's source problems."""
        values = self.counters
        values.update(self._source_counters())
        values["release_queue"] = len(self.queue)
        rejected = sum(self.input_counts[f"rejected_truth_{reason.value}"] for reason in REJECTIONS)
        if rejected > self._rejected_reported:
            problems = problems + ["rejected /attitude/truth messages"]
        self._rejected_reported = rejected
        source_errors = self._source_problems()
        problems = source_errors + problems
        level = Level.ERROR if source_errors else Level.WARN if problems else Level.OK
        return HealthSummary(level, "; ".join(problems) or "attitude available", values)


@dataclass(frozen=True)
class TrackerFrames:
    """Star-tracker frames of a truth stream, as star_tracker_node makes them.

    ``frame_s`` (M,) stamps, ``q_measured`` (4, M) (NaN without output),
    ``outcome`` (M,) :class:`~pmv_ros.physics.star_tracker.Outcome` codes, and
    ``released_at`` (M,) the index of the truth sample at which each frame
    is published (-1: not published by the end, or no output).
    """

    frame_s: np.ndarray
    q_measured: np.ndarray
    outcome: np.ndarray
    released_at: np.ndarray


def track_stream(runtime: TrackerRuntime, truth_s: np.ndarray, q_truth: np.ndarray) -> TrackerFrames:
    """Feed a clean truth stream to ``runtime`` sample by sample, as the node's callbacks would.

    Args:
        truth_s: ``(N,)`` increasing truth stamps, s.
        q_truth: ``(4, N)`` true attitude (x, y, z, w) at those stamps.
    """
    frame_s, measured, outcome, released_at = [], [], [], []
    index_of_frame = {}
    for k, (t_s, q) in enumerate(zip(np.asarray(truth_s, float).tolist(), np.asarray(q_truth, float).T.tolist())):
        for frame, q_measured, code in runtime.add_truth(t_s, q):
            index_of_frame[frame] = len(frame_s)
            frame_s.append(frame)
            measured.append(q_measured)
            outcome.append(int(code))
            released_at.append(-1)
        for frame, _ in runtime.release(t_s):
            released_at[index_of_frame.pop(frame)] = k
    return TrackerFrames(np.array(frame_s, float), np.array(measured, float).reshape(-1, 4).T,
                         np.array(outcome, np.int8), np.array(released_at, np.int64))
