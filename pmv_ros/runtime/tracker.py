"""star_tracker_node's work without ROS: frames on its grid, the tracker's draws, the latency queue.

One frame loop, array-first, for the node (one truth message: a batch of
one) and the campaign's flight (a whole truth stream: one batch): the truth
samples add the frames that fall before each (the true attitude slerped to
them, :meth:`FrameGrid.add_many`), the tracker measures the frames each
sample completes as one call would (:meth:`StarTracker.measure_groups`, at
the nadir-pointing inertial rate), and the good ones wait ``latency_s`` in the
:class:`LatencyQueue`. Outcomes are counted as ``/diagnostics`` shows them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..physics.orbit import circular_mean_motion_rad_s
from ..physics.star_tracker import FrameGrid, LatencyQueue, Outcome, inertial_rate_of_nadir_pointing
from .assembly import build_tracker


@dataclass(frozen=True)
class MeasuredFrames:
    """Frames measured from a batch of truth, in frame order.

    ``frame_s`` (M,) stamps, s; ``q_measured`` (4, M) (NaN without output);
    ``outcome`` (M,) :class:`~pmv_ros.physics.star_tracker.Outcome` codes (int8);
    ``truth_index`` (M,) the truth sample of the batch that completed each.
    """

    frame_s: np.ndarray
    q_measured: np.ndarray
    outcome: np.ndarray
    truth_index: np.ndarray


class TrackerRuntime:
    """The star tracker fed with true attitude: one truth message at a time, or a stream of them at once.

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

    def add_truth_batch(self, t_s, q_xyzw) -> MeasuredFrames:
        """Truth samples in arrival order (stamps ``(N,)`` s, increasing; ``(4, N)`` (x, y, z, w)): the frames
        they complete, measured — each sample's frames as one draw, as :meth:`add_truth` sample by sample.

        The frames whose outcome is OK wait in the queue for :meth:`release` / :meth:`release_batch`,
        each from the truth sample that completed it on.
        """
        grid = self.grid.add_many(t_s, q_xyzw)
        if not grid.frame_s.size:
            return MeasuredFrames(grid.frame_s, grid.attitude, np.empty(0, np.int8), grid.truth_index)
        rate = inertial_rate_of_nadir_pointing(self.mean_motion_rad_s, grid.turn_rate_rad_s)
        measured, outcome = self.tracker.measure_groups(grid.frame_s, grid.attitude, rate, grid.group_sizes)
        for code, count in enumerate(np.bincount(outcome).tolist()):
            if count:
                self.outcomes[Outcome(code)] += count
        self.last_outcome = Outcome(int(outcome[-1]))
        ok = outcome == Outcome.OK
        self.queue.push_many(grid.frame_s[ok], measured[:, ok], grid.truth_index[ok])
        return MeasuredFrames(grid.frame_s, measured, outcome, grid.truth_index)

    def add_truth(self, t_s: float, q_xyzw) -> list[tuple[float, np.ndarray, Outcome]]:
        """One truth sample (a batch of one): (frame time s, measured (x, y, z, w), outcome) per frame it completes.

        A frame whose outcome is OK waits in the queue for :meth:`release`.
        """
        frames = self.add_truth_batch(np.array([float(t_s)]), np.asarray(q_xyzw, float).reshape(4, 1))
        return [(frame_s, frames.q_measured[:, k], Outcome(code))
                for k, (frame_s, code) in enumerate(zip(frames.frame_s.tolist(), frames.outcome.tolist()))]

    def release(self, t_s: float) -> list[tuple[float, np.ndarray]]:
        """Frames whose latency has passed at ``t_s``, in frame order: (frame time s, measured quaternion)."""
        return self.queue.release(t_s)

    def release_batch(self, t_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`release` at each of the increasing stamps ``t_s`` ``(N,)``: (frame times ``(R,)``, measured
        quaternions ``(4, R)``, the index of the stamp each is released at ``(R,)``), in frame order."""
        return self.queue.release_many(t_s)


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
    """Feed a clean truth stream to ``runtime`` as the node's callbacks would (add each sample, then release at
    its stamp), as one batch.

    Args:
        truth_s: ``(N,)`` increasing truth stamps, s.
        q_truth: ``(4, N)`` true attitude (x, y, z, w) at those stamps.
    """
    truth_s = np.asarray(truth_s, float)
    queued = len(runtime.queue)  # frames of earlier truth go first
    frames = runtime.add_truth_batch(truth_s, q_truth)
    _, _, released_at = runtime.release_batch(truth_s)
    published = np.full(frames.frame_s.size, -1, np.int64)
    ours = released_at[queued:]
    published[np.flatnonzero(frames.outcome == Outcome.OK)[:ours.size]] = ours
    return TrackerFrames(frames.frame_s, frames.q_measured, frames.outcome.astype(np.int8), published)
