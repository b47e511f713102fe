"""The star tracker's frames on a truth stream: the frame grid and the queue that publishes them (physics.md §6 item 2).

Frames fall on a regular grid of the truth stream's clock (their time is the
middle of the exposure); each gets the true attitude slerped to it
(:class:`FrameGrid`). Measured frames wait in :class:`LatencyQueue` until
the truth stream's clock passes their publication time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .kernel import slerp_frames


def _grid_times(start: float, stop: float, step: float) -> list:
    """``np.arange(start, stop, step).tolist()`` in plain floats, value for value (numpy's length and fill
    rules: start, start + step, then start + i·((start + step) − start)); a frame grid calls it once per
    truth sample, where a numpy call would cost more than the arithmetic."""
    count = math.ceil((stop - start) / step)
    if count <= 0:
        return []
    if count == 1:
        return [start]
    second = start + step
    delta = second - start
    return [start, second] + [start + i * delta for i in range(2, count)]


@dataclass(frozen=True)
class GridFrames:
    """Frames that a stretch of truth completes (:meth:`FrameGrid.add_many`), in time order.

    ``frame_s`` (M,) frame times, s; ``attitude`` (4, M) the true attitude
    slerped to each; ``turn_rate_rad_s`` (3, M) the rate of the turn it was
    slerped on (orbital components); ``truth_index`` (M,) the truth sample
    that completed it (non-decreasing: the frames one sample completes are
    consecutive).
    """

    frame_s: np.ndarray
    attitude: np.ndarray
    turn_rate_rad_s: np.ndarray
    truth_index: np.ndarray

    @property
    def group_sizes(self) -> np.ndarray:
        """Frames completed by each truth sample that completed any, in order."""
        index = self.truth_index
        if not index.size or index[0] == index[-1]:  # none, or one group
            return np.array([index.size] if index.size else [], np.int64)
        ends = np.flatnonzero(index[1:] != index[:-1]) + 1
        return np.diff(np.concatenate([[0], ends, [index.size]]))


def read_only(array: np.ndarray) -> np.ndarray:
    """``array``, made read-only (an empty result shared by every call that has nothing to give)."""
    array.flags.writeable = False
    return array


#: What a batch that completes no frame gives (shared: its arrays are empty and read-only).
_NO_FRAMES = GridFrames(read_only(np.empty(0)), read_only(np.empty((4, 0))), read_only(np.empty((3, 0))),
                        read_only(np.empty(0, np.int64)))
#: The truth index of one frame completed by the batch's first sample (shared, read-only).
_FIRST_SAMPLE = read_only(np.zeros(1, np.int64))


class FrameGrid:
    """Star-tracker frame times on a regular grid, and the true attitude at each, from a stream of truth.

    Frames fall at multiples of ``period_s``; each frame between two truth
    samples gets the slerped attitude of the turn between them. A truth gap
    longer than ``max_gap_s`` (or the first sample, or :meth:`restart`)
    restarts the grid at the next sample: nothing is interpolated across a gap.
    """

    def __init__(self, period_s: float, max_gap_s: float):
        self.period_s = float(period_s)
        self.max_gap_s = float(max_gap_s)
        self.previous = None  # (stamp_s, (x, y, z, w)) of the last truth sample
        self._next_frame_s = None

    def restart(self) -> None:
        """Forget the timeline (a clock jump): the next truth sample starts the grid again."""
        self.previous = None
        self._next_frame_s = None

    def add_many(self, t_s, q_xyzw) -> GridFrames:
        """Take truth samples in arrival order (stamps ``(N,)`` s, unit quaternions ``(4, N)``; or one sample, a
        float stamp and its (x, y, z, w)): the frames they complete, each on the turn between the sample that
        completed it and the one before."""
        if type(t_s) is float:  # one sample (a node's)
            if self._completes_nothing(t_s):  # between two frames
                self.previous = (t_s, q_xyzw)
                return _NO_FRAMES
            times, _, previous = self._grid([t_s], q_xyzw)
            if not times:  # the first sample, or one after a gap: the grid starts again
                return _NO_FRAMES
            count = len(times)
            q0 = np.array(previous[1], float).reshape(4, 1)
            q1 = np.array(q_xyzw, float).reshape(4, 1)
            if count > 1:
                q0, q1 = np.repeat(q0, count, axis=1), np.repeat(q1, count, axis=1)
            frame_s = np.array(times)
            attitude, rate = slerp_frames(np.array([previous[0]] * count), q0, np.array([t_s] * count), q1, frame_s)
            return GridFrames(frame_s, attitude, rate, _FIRST_SAMPLE if count == 1 else np.zeros(count, np.int64))
        t = np.atleast_1d(np.asarray(t_s, float)).ravel()
        if not t.size:
            return _NO_FRAMES
        q = np.asarray(q_xyzw, float).reshape(4, t.size)
        times, completed_by, previous = self._grid(t.tolist(), q[:, -1].copy())
        if not times:
            return _NO_FRAMES
        earlier_t = np.concatenate([[np.nan if previous is None else previous[0]], t[:-1]])
        earlier_q = np.concatenate([np.full((4, 1), np.nan) if previous is None else np.reshape(previous[1], (4, 1)),
                                    q[:, :-1]], axis=1)
        frame_s, index = np.array(times), np.array(completed_by, np.int64)
        attitude, rate = slerp_frames(earlier_t[index], np.ascontiguousarray(earlier_q[:, index]), t[index],
                                      np.ascontiguousarray(q[:, index]), frame_s)
        return GridFrames(frame_s, attitude, rate, index)

    def _completes_nothing(self, stamp: float) -> bool:
        """Whether one sample at ``stamp`` neither completes a frame nor restarts the grid (:meth:`_grid`'s tests)."""
        previous, next_frame = self.previous, self._next_frame_s
        return (previous is not None and next_frame is not None and not stamp - previous[0] > self.max_gap_s
                and next_frame > stamp + 1e-12)

    def _grid(self, stamps: list, last_q) -> tuple[list, list, tuple | None]:
        """Advance the grid over ``stamps`` (floats, in order; ``last_q`` the last one's attitude): (the frame
        times they complete, the index of the stamp that completed each, the sample before the first)."""
        # Sample by sample in floats (a frame time is the previous one plus the period).
        period, max_gap, next_frame = self.period_s, self.max_gap_s, self._next_frame_s
        previous_s = None if self.previous is None else self.previous[0]
        times, completed_by = [], []
        for k, stamp in enumerate(stamps):
            before, previous_s = previous_s, stamp
            if before is None or next_frame is None or stamp - before > max_gap:
                next_frame = math.ceil(stamp / period) * period
                continue
            if next_frame > stamp + 1e-12:
                continue
            frames = _grid_times(next_frame, stamp + 1e-12, period)
            if not frames:
                continue
            times += frames
            completed_by += [k] * len(frames)
            next_frame = frames[-1] + period
        previous, self.previous = self.previous, (stamps[-1], last_q)
        self._next_frame_s = next_frame
        return times, completed_by, previous


#: A frame whose release time is within this of a truth stamp is released with it, s (stamp rounding).
RELEASE_TOLERANCE_S = 1e-9


class LatencyQueue:
    """Measured frames waiting for their publication, ``latency_s`` after the frame time (physics.md §6 item 2).

    Released by the truth stream's stamps (the tracker runs on its input's
    clock): :meth:`release_many` gives every frame due at each truth stamp, in
    frame order. Holds at most ``latency_s × rate`` frames.
    """

    def __init__(self, latency_s: float):
        self.latency_s = float(latency_s)
        self._release_s, self._frame_s = np.empty(0), np.empty(0)  # per frame, in frame order
        self._q, self._ready = np.empty((4, 0)), np.empty(0, np.int64)
        self._first_release_s = math.inf  # of the frame ahead (a stamp before it releases nothing)
        self._last_release_s = -math.inf  # the latest of the frames waiting (a stamp after it releases them all)
        self._held_back = False  # some frame of ``_ready`` waits for a later stamp of the next release_many

    def __len__(self) -> int:
        return int(self._release_s.size)

    def push_many(self, frame_s, q_xyzw, not_before=None) -> None:
        """Queue measured frames in frame order (stamps ``(K,)`` s, quaternions ``(4, K)``); ``not_before``
        ``(K,)``: the index of the first stamp of the next :meth:`release_many` that may release each
        (the truth sample that completed it; default 0)."""
        frame_s = np.asarray(frame_s, float).ravel()
        count = frame_s.size
        if not count:
            return
        ready = np.zeros(count, np.int64) if not_before is None else np.asarray(not_before, np.int64)
        release_s, q = frame_s + self.latency_s, np.asarray(q_xyzw, float).reshape(4, count)
        if self._release_s.size:
            self._release_s = np.concatenate([self._release_s, release_s])
            self._frame_s = np.concatenate([self._frame_s, frame_s])
            self._q = np.concatenate([self._q, q], axis=1)
            self._ready = np.concatenate([self._ready, ready])
        else:  # nothing waiting (a node's frame is most often released before the next is measured): copies
            self._release_s, self._frame_s, self._q, self._ready = release_s, frame_s.copy(), q.copy(), ready.copy()
        self._held_back = self._held_back or np.count_nonzero(ready) > 0
        self._first_release_s = float(self._release_s[0])
        # In frame order, the last frame pushed is the latest due of these (an earlier one may be later still: the
        # latency was longer when it was pushed).
        self._last_release_s = max(self._last_release_s, float(release_s[-1]))

    def release_many(self, stamps_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The frames due at each of increasing truth stamps ``(N,)``, as if released stamp by stamp.

        A frame is due at the first stamp it is no later than (within
        :data:`RELEASE_TOLERANCE_S`) and never before the one of a frame ahead of
        it. Returns (frame times ``(R,)``, quaternions ``(4, R)``, the index of the
        stamp each is released at ``(R,)``); the frames not due stay queued.
        """
        if type(stamps_s) is float and not self._held_back:  # one stamp (a node's)
            if stamps_s + RELEASE_TOLERANCE_S < self._first_release_s:
                return _NONE_RELEASED  # before the frame ahead is due
            if stamps_s + RELEASE_TOLERANCE_S >= self._last_release_s:  # every frame waiting is due: all go
                released = self._frame_s, self._q, np.zeros(self._frame_s.size, np.int64)
                self.clear()
                return released
        stamps = np.atleast_1d(np.asarray(stamps_s, float)).ravel()
        if not stamps.size or (stamps[-1] + RELEASE_TOLERANCE_S < self._first_release_s and not self._held_back):
            return _NONE_RELEASED  # nothing due yet (most truth stamps of a node)
        due = np.searchsorted(stamps + RELEASE_TOLERANCE_S, self._release_s, side="left")
        due = np.maximum.accumulate(np.maximum(due, self._ready)) if due.size else due
        count = int(np.searchsorted(due, stamps.size, side="left"))
        released = self._frame_s[:count], self._q[:, :count], due[:count]
        self._release_s, self._frame_s, self._q = self._release_s[count:], self._frame_s[count:], self._q[:, count:]
        self._ready, self._held_back = np.zeros(self._release_s.size, np.int64), False
        self._first_release_s = float(self._release_s[0]) if self._release_s.size else math.inf
        if not self._release_s.size:
            self._last_release_s = -math.inf
        return released

    def clear(self) -> int:
        """Drop every waiting frame (a new timeline); returns how many."""
        dropped = len(self)
        self._release_s, self._frame_s = self._release_s[:0], self._frame_s[:0]
        self._q, self._ready, self._held_back = self._q[:, :0], self._ready[:0], False
        self._first_release_s, self._last_release_s = math.inf, -math.inf
        return dropped


#: What a release of nothing gives (shared: its arrays are empty and read-only).
_NONE_RELEASED = (read_only(np.empty(0)), read_only(np.empty((4, 0))), read_only(np.empty(0, np.int64)))
