"""star_tracker_node's work without ROS: frames on its grid, the tracker's draws, the latency queue.

One frame loop for the node (one truth message at a time) and the campaign's
flight (a whole truth stream): each truth sample adds the frames that fall
before it (the true attitude slerped to them, :class:`FrameGrid`), the tracker
measures them at the nadir-pointing inertial rate
(:meth:`StarTracker.measure_frames`), and the good ones wait ``latency_s`` in
the :class:`LatencyQueue`. Outcomes are counted as ``/diagnostics`` shows them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..physics.orbit import circular_mean_motion_rad_s
from ..physics.star_tracker import FrameGrid, LatencyQueue, Outcome, inertial_rate_of_nadir_pointing
from .assembly import build_tracker


class TrackerRuntime:
    """The star tracker fed with true attitude, one truth sample at a time.

    Args:
        values: star_tracker_node parameter values.
        start_s: the node clock at start (outage windows are relative to it), s.
    """

    def __init__(self, values: dict, start_s: float) -> None:
        self.start_s = float(start_s)
        self.grid = FrameGrid(1.0 / values["rate_hz"], values["max_truth_gap_s"])
        self.queue = LatencyQueue(values["latency_s"])  # bounded by latency × rate
        self.outcomes = {outcome: 0 for outcome in Outcome}
        self.last_outcome = Outcome.OK
        self.reconfigure(values)

    def reconfigure(self, values: dict) -> None:
        """New parameter values: a new tracker (its draws restart), the grid's period and the latency."""
        self.tracker = build_tracker(values, self.start_s)
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
