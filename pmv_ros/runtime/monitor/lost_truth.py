"""What the samples without truth lost to: the star tracker's reason for the frames around them (physics.md §6).

The monitor skips a sensor sample for want of truth — none before it
(``no_truth``), a gap around it (``truth_gap``), none arriving in time
(``stale_truth``) — when the star tracker gave no attitude around its stamp.
:class:`LostTruth` keeps the tracker's recent frames without attitude (their
time and reason: ``/star_tracker/frame_status`` in the node graph, the
flight's :class:`~pmv_ros.runtime.tracker.runtime.TrackerFrames` in a
campaign) and counts each such sample under the reason of the failed frame
nearest to it (``truth_lost_<reason>``: ``no_stars``, ``recognition_failure``,
``buffer_overflow``, ``exclusion``, ``rate_too_high``, ``outage``,
``invalid_truth``), or ``truth_lost_no_status`` when no failed frame is
within ``window_s`` of it (the tracker silent, or its status not heard).
Memory is bounded: the last ``capacity`` failed frames.
"""

from __future__ import annotations

import numpy as np

from ...physics.star_tracker import Outcome
from .records import Status

#: The statuses of a sample that had no truth around its stamp.
WANT_OF_TRUTH = (Status.NO_TRUTH, Status.TRUTH_GAP, Status.STALE_TRUTH)
#: What a sample without truth is counted under: the tracker's reasons, then "no_status".
LOST_REASONS = tuple(outcome.reason for outcome in Outcome if outcome is not Outcome.OK) + ("no_status",)
#: The counters' names (/diagnostics keys), in :data:`LOST_REASONS` order.
LOST_KEYS = tuple(f"truth_lost_{reason}" for reason in LOST_REASONS)
_NO_STATUS = len(LOST_REASONS) - 1
#: Outcome code → index in LOST_REASONS (OK has none).
_INDEX = {outcome.value: LOST_REASONS.index(outcome.reason) for outcome in Outcome if outcome is not Outcome.OK}
_REASON_CODE = {outcome.reason: outcome.value for outcome in Outcome}


class LostTruth:
    """The star tracker's recent frames without attitude, and the samples without truth counted by their reason.

    Args:
        window_s: the farthest a failed frame may be from a sample to explain it, s (the monitor's
            ``max_truth_gap_s``: a gap no longer than that is interpolated across).
        capacity: failed frames kept (the newest).
    """

    def __init__(self, window_s: float, capacity: int = 4096) -> None:
        self.window_s = float(window_s)
        self.capacity = int(capacity)
        self.counts = dict.fromkeys(LOST_KEYS, 0)
        self.clear()

    def clear(self) -> None:
        """Forget the frames (a new timeline); the counts stay."""
        self._stamps, self._codes = np.empty(0), np.empty(0, np.int64)

    def add_frames(self, stamps_s, codes) -> None:
        """Frames of the tracker in time order (stamps ``(N,)`` s, :class:`~pmv_ros.physics.star_tracker.Outcome`
        codes ``(N,)``); those with an attitude are not kept. A frame earlier than the last one kept starts a new
        timeline."""
        stamps, codes = np.atleast_1d(np.asarray(stamps_s, float)), np.atleast_1d(np.asarray(codes, np.int64))
        failed = codes != Outcome.OK.value
        if not failed.any():
            return
        stamps, codes = stamps[failed], codes[failed]
        if self._stamps.size and stamps[0] < self._stamps[-1]:
            self.clear()
        self._stamps = np.concatenate((self._stamps, stamps))[-self.capacity:]
        self._codes = np.concatenate((self._codes, codes))[-self.capacity:]

    @property
    def frames(self) -> tuple[np.ndarray, np.ndarray]:
        """The failed frames kept (the newest ``capacity``): stamps ``(K,)`` s and Outcome codes ``(K,)`` (copies)."""
        return self._stamps.copy(), self._codes.copy()

    def add_status(self, stamp_s: float, reason: str) -> None:
        """One /star_tracker/frame_status: a frame's time and its reason (``"ok"`` or a reason code's name)."""
        if reason != "ok":
            self.add_frames(stamp_s, _REASON_CODE[reason])

    def reasons(self, stamps_s) -> np.ndarray:
        """Per stamp ``(N,)``, the index in :data:`LOST_REASONS` of the nearest failed frame's reason within the
        window (``no_status`` where there is none)."""
        t = np.atleast_1d(np.asarray(stamps_s, float))
        known = self._stamps
        if not known.size or not t.size:
            return np.full(t.shape, _NO_STATUS, np.int64)
        after = np.minimum(np.searchsorted(known, t), known.size - 1)
        before = np.maximum(after - 1, 0)
        nearest = np.where(np.abs(known[before] - t) <= np.abs(known[after] - t), before, after)
        near = np.abs(known[nearest] - t) <= self.window_s
        index = np.array([_INDEX[int(code)] for code in self._codes[nearest].tolist()], np.int64)
        return np.where(near, index, _NO_STATUS)

    def count(self, stamps_s) -> None:
        """Count samples without truth at ``stamps_s`` ``(N,)`` under the reason of the failed frame nearest each."""
        reasons = self.reasons(stamps_s)
        for index, count in enumerate(np.bincount(reasons, minlength=len(LOST_REASONS)).tolist()):
            if count:
                self.counts[LOST_KEYS[index]] += count
