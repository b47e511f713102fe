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
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from .attitude import quaternion_from_rotation_vector, quaternion_product, slerp
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
        self._tracker_axes_rows = self._tracker_axes.tolist()  # for the one-frame path in floats

    def in_outage(self, t_s):
        """True where ``t_s`` lies inside a scheduled outage window."""
        t = np.asarray(t_s, float)
        inside = np.zeros(t.shape, bool)
        for start, end in self.parameters.outages:
            inside |= (t >= start) & (t < end)
        return inside

    def measure(self, t_s, q_orbital_to_body, inertial_rate_rad_s):
        """Measured attitude for frames at ``t_s``.

        Args:
            t_s: frame times, s, ``(N,)`` or scalar.
            q_orbital_to_body: true attitude (x, y, z, w), ``(4,)`` or ``(4, N)``.
            inertial_rate_rad_s: magnitude of the body's inertial angular rate, rad/s, like ``t_s``.

        Returns:
            (q_measured, outcome): quaternions ``(4[, N])`` (NaN where there is no
            output) and :class:`Outcome` codes shaped like ``t_s``.
        """
        if np.ndim(t_s) == 0:
            return self._measure_one(float(t_s), q_orbital_to_body, float(inertial_rate_rad_s))
        t = np.atleast_1d(np.asarray(t_s, float))
        q_true = np.asarray(q_orbital_to_body, float).reshape(4, -1)
        q_true = np.broadcast_to(q_true, (4, t.size))
        rate = np.broadcast_to(np.atleast_1d(np.asarray(inertial_rate_rad_s, float)), t.shape)
        p = self.parameters

        norm = np.linalg.norm(q_true, axis=0)
        finite = np.all(np.isfinite(q_true), axis=0) & (norm > 0.5)
        # Draw every frame's noise and failure dice, used or not, so that one
        # frame's fate does not shift the random stream of the frames after it.
        noise = self._rng.standard_normal((3, t.size)) * np.array(
            [p.noise_cross_rad, p.noise_cross_rad, p.noise_boresight_rad])[:, None]
        failed = self._rng.random(t.size) < p.random_failure_probability

        outcome = np.full(t.shape, Outcome.OK, dtype=np.int8)
        outcome[failed] = Outcome.RANDOM_FAILURE
        outcome[rate > p.max_rate_rad_s] = Outcome.RATE_TOO_HIGH
        outcome[self.in_outage(t)] = Outcome.SCHEDULED_OUTAGE
        outcome[~finite] = Outcome.INVALID_TRUTH

        q_safe = np.where(finite, q_true / np.where(finite, norm, 1.0), np.array([[0.0], [0.0], [0.0], [1.0]]))
        # Noise is a small rotation in the tracker frame, applied on the body side.
        error_body = quaternion_from_rotation_vector(self._tracker_axes @ noise)
        measured = quaternion_product(q_safe, error_body)
        # Keep the sign of the true quaternion (q and −q are the same attitude).
        measured *= np.where(np.sum(measured * q_safe, axis=0) < 0.0, -1.0, 1.0)
        measured[:, outcome != Outcome.OK] = np.nan
        return measured, outcome

    def measure_frames(self, frames_s: list, attitudes: list, rate_rad_s: float) -> list:
        """Measure the frames one truth sample completes (:meth:`FrameGrid.add`), as star_tracker_node does.

        One frame (the usual case) in plain floats, several in one array call:
        the same random draws, in the same order, for any grouping.

        Returns:
            ``[(q_measured (4,) array, Outcome), ...]``, one per frame.
        """
        if len(frames_s) == 1:
            return [self.measure(frames_s[0], attitudes[0], rate_rad_s)]
        measured, outcomes = self.measure(np.array(frames_s), np.array(attitudes).T, np.full(len(frames_s), rate_rad_s))
        return [(measured[:, k], Outcome(int(code))) for k, code in enumerate(outcomes)]

    def _measure_one(self, t_s: float, q_orbital_to_body, rate_rad_s: float):
        """:meth:`measure` for one frame in plain floats (the node measures one 2 Hz frame at a time).

        The same random draws, in the same order, as the array path for one frame.
        """
        p = self.parameters
        noise = self._rng.standard_normal((3, 1))[:, 0].tolist()
        failed = bool(self._rng.random(1)[0] < p.random_failure_probability)
        q = [float(c) for c in np.asarray(q_orbital_to_body, float).ravel()]
        norm = math.sqrt(sum(c * c for c in q))
        finite = all(math.isfinite(c) for c in q) and norm > 0.5
        if not finite:
            outcome = Outcome.INVALID_TRUTH
        elif any(start <= t_s < end for start, end in p.outages):
            outcome = Outcome.SCHEDULED_OUTAGE
        elif rate_rad_s > p.max_rate_rad_s:
            outcome = Outcome.RATE_TOO_HIGH
        else:
            outcome = Outcome.RANDOM_FAILURE if failed else Outcome.OK
        if outcome is not Outcome.OK:
            return np.full(4, np.nan), outcome
        sigma = (p.noise_cross_rad, p.noise_cross_rad, p.noise_boresight_rad)
        scaled = [n * s for n, s in zip(noise, sigma)]
        error_tracker = tuple(sum(a * n for a, n in zip(row, scaled)) for row in self._tracker_axes_rows)
        q_true = tuple(c / norm for c in q)
        measured = quaternion_product(q_true, quaternion_from_rotation_vector(error_tracker))
        if sum(m * c for m, c in zip(measured, q_true)) < 0.0:
            measured = tuple(-m for m in measured)
        return np.array(measured), outcome


def inertial_rate_of_nadir_pointing(mean_motion_rad_s: float, relative_rate_rad_s=None):
    """Inertial angular rate magnitude, rad/s, of a body that follows the orbital frame.

    The orbital frame turns at the mean motion n about its Y axis; a body
    rotating relative to it at ``relative_rate_rad_s`` ``(3[, N])`` (orbital
    components) adds to that vectorially. A tuple of three floats gives a float.
    """
    if relative_rate_rad_s is None:
        return float(mean_motion_rad_s)
    if isinstance(relative_rate_rad_s, tuple):  # one rate, plain floats
        x, y, z = relative_rate_rad_s
        return math.sqrt(x * x + (y + mean_motion_rad_s) ** 2 + z * z)
    w = np.asarray(relative_rate_rad_s, float).copy()
    # The radial unit vector Z turns towards the velocity X at the rate n:
    # dZ/dt = n·X = ω × Z with ω = n·Y (Y = Z × X, the orbit normal).
    w[1] = w[1] + mean_motion_rad_s
    return np.linalg.norm(w, axis=0)


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
        """Take one truth sample (stamp s, unit quaternion); return the frames it completes.

        Returns:
            (frame times, true attitudes as (x, y, z, w) tuples, rate of the turn
            (3-tuple rad/s, orbital components; zeros when no frame)).
        """
        q = tuple(float(c) for c in q_xyzw)
        previous, self.previous = self.previous, (t_s, q)
        period = self.period_s
        if previous is None or self._next_frame_s is None or t_s - previous[0] > self.max_gap_s:
            self._next_frame_s = math.ceil(t_s / period) * period
            return [], [], (0.0, 0.0, 0.0)
        if self._next_frame_s > t_s + 1e-12:
            return [], [], (0.0, 0.0, 0.0)
        frames = np.arange(self._next_frame_s, t_s + 1e-12, period).tolist()
        if not frames:
            return [], [], (0.0, 0.0, 0.0)
        attitudes, rate = slerp(previous[0], previous[1], t_s, q, frames)
        self._next_frame_s = frames[-1] + period
        return frames, attitudes, rate


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
        self._queue = deque()  # (release_s, frame_s, q_xyzw)

    def __len__(self) -> int:
        return len(self._queue)

    def push(self, frame_s: float, q_xyzw) -> None:
        """Queue a measured frame (stamp s, quaternion (x, y, z, w))."""
        self._queue.append((frame_s + self.latency_s, frame_s, q_xyzw))

    def release(self, t_s: float) -> list:
        """The frames due at truth stamp ``t_s``: ``[(frame_s, q_xyzw), ...]``."""
        queue, released = self._queue, []
        while queue and queue[0][0] <= t_s + RELEASE_TOLERANCE_S:
            _, frame_s, q_xyzw = queue.popleft()
            released.append((frame_s, q_xyzw))
        return released

    def clear(self) -> int:
        """Drop every waiting frame (a new timeline); returns how many."""
        dropped = len(self._queue)
        self._queue.clear()
        return dropped
