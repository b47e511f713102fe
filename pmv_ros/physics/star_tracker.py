"""Star-tracker measurement model: the truth source, with its noise, limits and gaps (physics.md §6).

A BOKZ-class tracker outputs the attitude quaternion to a few arcseconds
across its boresight and several times worse about it; it gives nothing above
≈ 300″/s of inertial angular rate (too few stars are registered), nothing
during scheduled outages (e.g. hours after a solar flare, when proton tracks
flood the video buffer), and rare single frames fail at random.

Array code does not raise for bad samples: a frame without output gets a
reason code (see :class:`Outcome`) and a NaN quaternion.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from .attitude import quaternion_from_rotation_vector, quaternion_product, slerp, slerp_each
from .constants import ARCSEC_RAD


class Outcome(enum.IntEnum):
    """Why a star-tracker frame has, or has not, an attitude."""

    OK = 0
    RATE_TOO_HIGH = 1  #: inertial angular rate above the limit
    SCHEDULED_OUTAGE = 2  #: inside a configured outage window (e.g. a solar-flare period)
    RANDOM_FAILURE = 3  #: a rare single recognition failure
    INVALID_TRUTH = 4  #: the true attitude given to the model was not a finite quaternion


@dataclass(frozen=True)
class StarTrackerParameters:
    """Configuration of the star-tracker model; angles in rad, times in s.

    Defaults: 3″ (1σ) across the boresight and 20″ about it, 300″/s rate
    limit (physics.md §6), boresight along +Z of the body (looking away from
    the Earth on a nadir-pointing spacecraft), one failed frame in a thousand.
    """

    noise_cross_rad: float = 3.0 * ARCSEC_RAD
    noise_boresight_rad: float = 20.0 * ARCSEC_RAD
    max_rate_rad_s: float = 300.0 * ARCSEC_RAD
    boresight_body: tuple = (0.0, 0.0, 1.0)
    random_failure_probability: float = 1e-3
    #: (start_s, end_s) windows of simulation time with no output.
    outages: tuple = field(default_factory=tuple)

    def __post_init__(self) -> None:
        for name in ("noise_cross_rad", "noise_boresight_rad"):
            value = getattr(self, name)
            if not (0.0 <= value <= math.radians(1.0)):
                raise ValueError(f"{name} = {value} is outside the allowed range 0 … {math.radians(1.0):.6f} rad")
        if not (0.0 < self.max_rate_rad_s <= math.radians(10.0)):
            raise ValueError(f"max_rate_rad_s = {self.max_rate_rad_s} is outside the allowed range (0, 0.1745] rad/s")
        if not (0.0 <= self.random_failure_probability <= 1.0):
            raise ValueError(f"random_failure_probability = {self.random_failure_probability} "
                             "is outside the allowed range 0 … 1")
        axis = np.asarray(self.boresight_body, float)
        if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) < 1e-9:
            raise ValueError(f"boresight_body = {self.boresight_body} must be a finite, non-zero 3-vector")
        for window in self.outages:
            if len(window) != 2 or not (math.isfinite(window[0]) and math.isfinite(window[1])) or window[1] < window[0]:
                raise ValueError(f"outage window {window} must be (start_s, end_s) with start ≤ end")


def _frame_about(boresight) -> np.ndarray:
    """Rotation matrix whose third column is the unit boresight (columns: cross, cross, boresight)."""
    z = np.asarray(boresight, float) / np.linalg.norm(boresight)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


class StarTracker:
    """Turns true attitudes into star-tracker measurements (seeded, reproducible).

    Args:
        parameters: the model configuration.
        seed: seed of the noise and random-failure generator.
    """

    def __init__(self, parameters: StarTrackerParameters | None = None, seed: int = 0):
        self.parameters = parameters or StarTrackerParameters()
        self._rng = np.random.default_rng(seed)
        self._tracker_axes = _frame_about(self.parameters.boresight_body)
        self._tracker_axes_rows = tuple(map(tuple, self._tracker_axes.tolist()))
        #: 1σ of the noise rotation about the tracker's axes (cross, cross, boresight), rad.
        p = self.parameters
        self._noise_sigma_rad = np.array([p.noise_cross_rad, p.noise_cross_rad, p.noise_boresight_rad])
        self._noise_sigma = tuple(self._noise_sigma_rad.tolist())

    def in_outage(self, t_s):
        """True where ``t_s`` lies inside a scheduled outage window (a float gives a bool)."""
        if isinstance(t_s, float):
            return any(start <= t_s < end for start, end in self.parameters.outages)
        t = np.asarray(t_s, float)
        inside = np.zeros(t.shape, bool)
        for start, end in self.parameters.outages:
            inside |= (t >= start) & (t < end)
        return inside

    def measure(self, t_s, q_orbital_to_body, inertial_rate_rad_s):
        """Measured attitude for frames at ``t_s``, measured together (one draw of noise and failures).

        Args:
            t_s: frame times, s, ``(N,)`` or scalar.
            q_orbital_to_body: true attitude (x, y, z, w), ``(4,)`` or ``(4, N)``.
            inertial_rate_rad_s: magnitude of the body's inertial angular rate, rad/s, like ``t_s``.

        Returns:
            (q_measured, outcome): quaternions ``(4[, N])`` (NaN where there is no
            output) and :class:`Outcome` codes shaped like ``t_s`` (an :class:`Outcome` for a scalar).
        """
        one = np.ndim(t_s) == 0
        t = np.atleast_1d(np.asarray(t_s, float))
        q_true = np.broadcast_to(np.asarray(q_orbital_to_body, float).reshape(4, -1), (4, t.size))
        rate = np.broadcast_to(np.atleast_1d(np.asarray(inertial_rate_rad_s, float)), t.shape)
        measured, outcome = self.measure_groups(t, q_true, rate, (t.size,))
        if one:
            return measured[:, 0], Outcome(int(outcome[0]))
        return measured, outcome

    def measure_groups(self, t_s, q_orbital_to_body, inertial_rate_rad_s, group_sizes):
        """Frames measured in consecutive groups, as one :meth:`measure` call per group would measure them.

        Each group draws its noise and failure dice as one :meth:`measure` call
        does (3 × n normals, then n uniforms), in group order, so the random
        stream is the one of the calls made one after the other; the rest is
        computed on the whole stream at once.

        Args:
            t_s: ``(M,)`` frame times, s.
            q_orbital_to_body: ``(4, M)`` true attitudes (x, y, z, w).
            inertial_rate_rad_s: ``(M,)`` inertial rate magnitudes, rad/s.
            group_sizes: frames per call, in order (they sum to M).

        Returns:
            (q_measured ``(4, M)``, NaN where there is no output; outcome ``(M,)`` int8 :class:`Outcome` codes).
        """
        t = np.asarray(t_s, float)
        q_true = np.asarray(q_orbital_to_body, float)
        rate = np.asarray(inertial_rate_rad_s, float)
        if t.size == 1 and list(group_sizes) == [1]:  # a node's one frame: the same operations in plain floats
            measured, code = self.measure_one(float(t[0]), tuple(q_true.ravel().tolist()), float(rate.ravel()[0]))
            return np.array(measured).reshape(4, 1), np.array([code], np.int8)
        p = self.parameters
        # Draw every frame's noise and failure dice, used or not, so that one
        # frame's fate does not shift the random stream of the frames after it.
        sizes = np.asarray(group_sizes, np.int64)
        if int(sizes.sum()) != t.size:
            raise ValueError(f"group sizes add up to {int(sizes.sum())}, not to the {t.size} frames")
        # Group by group, straight into buffers: 3 × n normals (a (3, n) block, row by row), then n uniforms.
        normals, dice = np.empty(3 * t.size), np.empty(t.size)
        normal, uniform = self._rng.standard_normal, self._rng.random
        lo = 0
        for size in sizes.tolist():
            normal(out=normals[3 * lo:3 * (lo + size)])
            uniform(out=dice[lo:lo + size])
            lo += size
        # Frame j, k-th of a group of n starting at frame lo: its row r is normal 3·lo + r·n + k
        # (one group, a node's frames: normal r·n + k, the buffer read as (3, n)).
        if sizes.size == 1:
            noise = normals.reshape(3, t.size)
        else:
            first = np.repeat(np.cumsum(sizes) - sizes, sizes)
            within = np.arange(t.size) - first
            noise = normals[3 * first + within + np.arange(3)[:, None] * np.repeat(sizes, sizes)]
        noise *= self._noise_sigma_rad[:, None]

        norm = np.linalg.norm(q_true, axis=0)
        finite = np.isfinite(q_true).all(axis=0) & (norm > 0.5)
        # The codes as plain ints (``.value``): numpy takes an IntEnum member several times more slowly,
        # a good part of the cost of the one frame a node measures at a time.
        outcome = np.full(t.shape, Outcome.OK.value, dtype=np.int8)
        outcome[dice < p.random_failure_probability] = Outcome.RANDOM_FAILURE.value
        outcome[rate > p.max_rate_rad_s] = Outcome.RATE_TOO_HIGH.value
        outcome[self.in_outage(t)] = Outcome.SCHEDULED_OUTAGE.value
        outcome[~finite] = Outcome.INVALID_TRUTH.value

        q_safe = np.where(finite, q_true / np.where(finite, norm, 1.0), np.array([[0.0], [0.0], [0.0], [1.0]]))
        # Noise is a small rotation in the tracker frame, applied on the body side (the tracker's axes
        # in the body, column by column: the same sums, in the same order, for any number of frames).
        axes = self._tracker_axes
        error_tracker = axes[:, 0:1] * noise[0] + axes[:, 1:2] * noise[1] + axes[:, 2:3] * noise[2]
        measured = quaternion_product(q_safe, quaternion_from_rotation_vector(error_tracker))
        # Keep the sign of the true quaternion (q and −q are the same attitude).
        measured *= np.where((measured * q_safe).sum(axis=0) < 0.0, -1.0, 1.0)
        measured[:, outcome != Outcome.OK.value] = np.nan
        return measured, outcome

    def measure_one(self, t_s: float, q_true: tuple, rate_rad_s: float) -> tuple[tuple, int]:
        """:meth:`measure_groups` of one frame, operation for operation in plain floats (the same draws, the
        same products, sums in the same order): a node measures a frame at a time, where ≈ 30 numpy calls cost
        far more than the arithmetic. Returns (the measured (x, y, z, w), NaN without output; the
        :class:`Outcome` code)."""
        p = self.parameters
        normals = self._rng.standard_normal(3).tolist()
        dice = self._rng.random()  # the draw random(1) makes
        n0, n1, n2 = (normal * sigma for normal, sigma in zip(normals, self._noise_sigma))
        x, y, z, w = q_true
        norm = math.sqrt(x * x + y * y + z * z + w * w)
        finite = all(map(math.isfinite, q_true)) and norm > 0.5
        outcome = Outcome.OK.value
        if dice < p.random_failure_probability:
            outcome = Outcome.RANDOM_FAILURE.value
        if rate_rad_s > p.max_rate_rad_s:
            outcome = Outcome.RATE_TOO_HIGH.value
        if self.in_outage(t_s):
            outcome = Outcome.SCHEDULED_OUTAGE.value
        if not finite:
            return (math.nan,) * 4, Outcome.INVALID_TRUTH.value
        q_safe = (x / norm, y / norm, z / norm, w / norm)
        a = self._tracker_axes_rows
        error = tuple(row[0] * n0 + row[1] * n1 + row[2] * n2 for row in a)
        measured = quaternion_product(q_safe, quaternion_from_rotation_vector(error))
        mx, my, mz, mw = measured
        if mx * q_safe[0] + my * q_safe[1] + mz * q_safe[2] + mw * q_safe[3] < 0.0:
            measured = (mx * -1.0, my * -1.0, mz * -1.0, mw * -1.0)
        if outcome != Outcome.OK.value:
            measured = (math.nan,) * 4
        return measured, outcome


def inertial_rate_of_nadir_pointing(mean_motion_rad_s: float, relative_rate_rad_s=None):
    """Inertial angular rate magnitude, rad/s, of a body that follows the orbital frame.

    The orbital frame turns at the mean motion n about its Y axis; a body
    rotating relative to it at ``relative_rate_rad_s`` ``(3[, N])`` (orbital
    components) adds to that vectorially. A tuple of three floats gives a float.
    """
    if relative_rate_rad_s is None:
        return float(mean_motion_rad_s)
    if isinstance(relative_rate_rad_s, tuple):  # one rate, plain floats: numpy's sums, in numpy's order
        x, y, z = relative_rate_rad_s
        y = y + mean_motion_rad_s
        return math.sqrt(x * x + y * y + z * z)
    w = np.asarray(relative_rate_rad_s, float).copy()
    # The radial unit vector Z turns towards the velocity X at the rate n:
    # dZ/dt = n·X = ω × Z with ω = n·Y (Y = Z × X, the orbit normal).
    w[1] = w[1] + mean_motion_rad_s
    return np.linalg.norm(w, axis=0)


def _four_floats(q_xyzw) -> tuple:
    """A quaternion (a tuple, or an array of 4) as a tuple of 4 floats."""
    if type(q_xyzw) is tuple and len(q_xyzw) == 4:
        return tuple(map(float, q_xyzw))
    return tuple(np.asarray(q_xyzw, float).reshape(4).tolist())


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

    @classmethod
    def of_one_turn(cls, times: list, attitude: list, rate: tuple) -> "GridFrames":
        """The frames one truth sample completed (:meth:`FrameGrid.add`: floats) as arrays."""
        if not times:
            return _NO_FRAMES
        return cls(np.array(times), np.array(attitude).T, np.array([rate] * len(times)).T,
                   np.zeros(len(times), np.int64))

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

    def add(self, t_s: float, q_xyzw) -> tuple[list, list, tuple]:
        """Take one truth sample (stamp s, unit quaternion); return the frames it completes, in plain floats (a
        node's message: kept as the grid loop takes it, no array built — most complete no frame, truth comes
        faster than frames). The same frames as :meth:`add_many`.

        Returns:
            (frame times, true attitudes as (x, y, z, w) tuples, rate of the turn
            (3-tuple rad/s, orbital components; zeros when no frame)).
        """
        t_s, q = float(t_s), _four_floats(q_xyzw)
        times, _, previous = self._grid([t_s], q)
        if not times:
            return [], [], (0.0, 0.0, 0.0)
        # Its frames on the one turn from the sample before.
        attitude, rate = slerp(previous[0], previous[1], t_s, q, times)
        return times, attitude, rate

    def add_many(self, t_s, q_xyzw) -> GridFrames:
        """Take truth samples in arrival order (stamps ``(N,)`` s, unit quaternions ``(4, N)``; or one sample,
        a float stamp and its (x, y, z, w)): the frames they complete, as :meth:`add` called sample by sample
        gives them."""
        if isinstance(t_s, float):
            return GridFrames.of_one_turn(*self.add(t_s, q_xyzw))
        t = np.asarray(t_s, float).ravel()
        q = np.asarray(q_xyzw, float).reshape(4, t.size)
        if not t.size:
            return _NO_FRAMES
        times, completed_by, previous = self._grid(t.tolist(), tuple(q[:, -1].tolist()))
        if not times:
            return _NO_FRAMES
        # Each frame on the turn from the truth sample before the one that completed it.
        earlier_t = np.concatenate([[np.nan if previous is None else previous[0]], t[:-1]])
        earlier_q = np.concatenate([np.full((4, 1), np.nan) if previous is None else np.reshape(previous[1], (4, 1)),
                                    q[:, :-1]], axis=1)
        frame_s, index = np.array(times), np.array(completed_by, np.int64)
        attitude, rate = slerp_each(earlier_t[index], earlier_q[:, index], t[index], q[:, index], frame_s)
        return GridFrames(frame_s, attitude, rate, index)

    def _grid(self, stamps: list, last_q: tuple) -> tuple[list, list, tuple | None]:
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
    """Measured frames waiting for their release, ``latency_s`` after the frame time (physics.md §6: latency).

    Released by the truth stream's stamps (the tracker runs on its input's
    clock): :meth:`release` gives every frame due at a truth stamp, in
    frame order. Holds at most ``latency_s × rate`` frames.
    """

    def __init__(self, latency_s: float):
        self.latency_s = float(latency_s)
        self._release_s, self._frame_s = np.empty(0), np.empty(0)  # per frame, in frame order
        self._q, self._ready = np.empty((4, 0)), np.empty(0, np.int64)
        self._held_back = False  # some frame of ``_ready`` waits for a later stamp of the next release_many
        # Frames pushed one at a time, after those of the arrays, in plain floats (a node's frame at a time: no
        # array built) until a batch method needs them there: (release s, frame s, (x, y, z, w)).
        self._single = []

    def __len__(self) -> int:
        return int(self._release_s.size) + len(self._single)

    def push(self, frame_s: float, q_xyzw) -> None:
        """Queue a measured frame (stamp s, quaternion (x, y, z, w))."""
        frame_s = float(frame_s)
        self._single.append((frame_s + self.latency_s, frame_s, _four_floats(q_xyzw)))

    def _merge(self) -> None:
        """The frames pushed one at a time, appended to the arrays (as :meth:`push_many` would have)."""
        single, self._single = self._single, []
        if single:
            release_s, frame_s, q = zip(*single)
            self._release_s = np.concatenate([self._release_s, release_s])
            self._frame_s = np.concatenate([self._frame_s, frame_s])
            self._q = np.concatenate([self._q, np.array(q).T], axis=1)
            self._ready = np.concatenate([self._ready, np.zeros(len(single), np.int64)])

    def push_many(self, frame_s, q_xyzw, not_before=None) -> None:
        """Queue measured frames in frame order (stamps ``(K,)`` s, quaternions ``(4, K)``); ``not_before``
        ``(K,)``: the index of the first stamp of the next :meth:`release_many` that may release each
        (the truth sample that completed it; default 0)."""
        self._merge()
        frame_s = np.asarray(frame_s, float).ravel()
        ready = np.zeros(frame_s.size, np.int64) if not_before is None else np.asarray(not_before, np.int64)
        self._release_s = np.concatenate([self._release_s, frame_s + self.latency_s])
        self._frame_s = np.concatenate([self._frame_s, frame_s])
        self._q = np.concatenate([self._q, np.asarray(q_xyzw, float).reshape(4, frame_s.size)], axis=1)
        self._ready = np.concatenate([self._ready, ready])
        self._held_back = self._held_back or bool(ready.any())

    def release(self, t_s: float) -> list:
        """The frames due at truth stamp ``t_s``: ``[(frame_s, q_xyzw), ...]``."""
        if not self._release_s.size:
            # Only frames pushed one at a time (a node's): each due once ``t_s`` reaches its release time, in
            # frame order — what :meth:`release_many` gives for one stamp, in plain floats.
            single, limit, count = self._single, t_s + RELEASE_TOLERANCE_S, 0
            while count < len(single) and single[count][0] <= limit:
                count += 1
            if not count:
                return []
            self._single = single[count:]
            return [(frame_s, q) for _, frame_s, q in single[:count]]
        self._merge()
        # Frames go in frame order: while the first is not due, none is (most truth stamps of a node), and
        # :meth:`release_many` would change nothing but the held-back marks, if any.
        if self._release_s[0] > t_s + RELEASE_TOLERANCE_S and not self._held_back:
            return []
        frame_s, q, _ = self.release_many(np.array([float(t_s)]))
        return list(zip(frame_s.tolist(), map(tuple, q.T.tolist())))

    def release_many(self, stamps_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The frames due at each of increasing truth stamps, as :meth:`release` called stamp by stamp.

        A frame is due at the first stamp it is no later than (within
        :data:`RELEASE_TOLERANCE_S`) and never before the one of a frame ahead of
        it. Returns (frame times ``(R,)``, quaternions ``(4, R)``, the index of the
        stamp each is released at ``(R,)``); the frames not due stay queued.
        """
        self._merge()
        stamps = np.asarray(stamps_s, float).ravel()
        if not self._release_s.size:
            return self._frame_s, self._q, self._ready
        due = np.searchsorted(stamps + RELEASE_TOLERANCE_S, self._release_s, side="left")
        due = np.maximum.accumulate(np.maximum(due, self._ready)) if due.size else due
        count = int(np.searchsorted(due, stamps.size, side="left"))
        released = self._frame_s[:count], self._q[:, :count], due[:count]
        self._release_s, self._frame_s, self._q = self._release_s[count:], self._frame_s[count:], self._q[:, count:]
        self._ready, self._held_back = np.zeros(self._release_s.size, np.int64), False
        return released

    def clear(self) -> int:
        """Drop every waiting frame (a new timeline); returns how many."""
        dropped = len(self)
        self._single = []
        self._release_s, self._frame_s = self._release_s[:0], self._frame_s[:0]
        self._q, self._ready, self._held_back = self._q[:, :0], self._ready[:0], False
        return dropped
