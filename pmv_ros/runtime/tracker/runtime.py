"""star_tracker_node's work without ROS: frames on its grid, the tracker's model, the publication queue.

One frame loop, array-first, for the node (one truth message: a batch of
one) and the campaign's flight (a whole truth stream: one batch): the truth
samples add the frames that fall before each (the true attitude slerped to
them, :meth:`FrameGrid.add_many`), the tracker measures them
(:meth:`StarTracker.measure`: the real sky, protons, exclusion; every draw
keyed by the frame's time, so the same frame time gives the same frame
whatever came before), and the good ones wait ``exposure_s/2 +
processing_s`` in the :class:`LatencyQueue`. Every frame's outcome — OK or
the reason it gives no attitude — is counted as ``/diagnostics`` shows it
(``frames_<reason>``), with the last frame's stars in the field and proton
hits; :class:`MeasuredFrames` carries them per frame.

The node's input side is here too (:meth:`TrackerRuntime.add_inputs`: the
messages the node queued in one executor wake-up, the good ones measured as one
batch; :meth:`TrackerRuntime.receive_truth`: one message, a batch of one), and
its ``/diagnostics`` status (:meth:`TrackerRuntime.health`).

Bad input (the checks are :mod:`pmv_ros.runtime.common.validation`): a truth message
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
from operator import itemgetter
from typing import Callable, NamedTuple

import numpy as np

from ...physics.star_tracker import FrameGrid, FrameMeasurement, LatencyQueue, Outcome, read_only
from .build import build_tracker
from ..common.assembly import orbit_bounds
from ..common.frames import Frames
from ..common.records import HealthAt, HealthSummary, Level, LogLine
from ..common.validation import (STAMP_REJECTIONS, TRUTH_REJECTIONS, FrameCheck, Rejection, StampCheck,
                                 check_odometry, check_quaternion_sample)

#: Why a truth message is dropped: the checks of the stream, and a frame other than the orbital one.
REJECTIONS = TRUTH_REJECTIONS + (Rejection.WRONG_FRAME,)
#: Why an orbit/odometry message (orbit.source follow) is dropped.
ODOMETRY_REJECTIONS = STAMP_REJECTIONS + (Rejection.IMPLAUSIBLE_ORBIT, Rejection.WRONG_FRAME)
#: The outcomes by code, and their reasons.
_OUTCOMES = tuple(Outcome)
_OK = Outcome.OK.value  # a plain int: numpy compares with an IntEnum member slowly
_REASONS = tuple(outcome.reason for outcome in Outcome)
#: The /diagnostics keys of the frame outcomes (in Outcome order) and of the refusals.
_FRAME_KEYS = tuple(f"frames_{outcome.reason}" for outcome in Outcome)
_REJECTED_KEYS = tuple(f"rejected_truth_{reason.value}" for reason in REJECTIONS)
_rejected_counts = itemgetter(*_REJECTED_KEYS)  # input counters → the refusals' counts


class FrameStatus(NamedTuple):
    """A frame as measured (``/star_tracker/frame_status``): its time (s), its outcome's reason (``"ok"``,
    ``"no_stars"``, …), the catalogue stars in the field and the proton hits."""

    frame_s: float
    reason: str
    stars: int
    hits: int


class ReleasedFrame(NamedTuple):
    """A measured frame whose latency has passed: its time (s) and the measured attitude (x, y, z, w)."""

    frame_s: float
    q_measured: tuple


@dataclass
class TrackerOutput:
    """What truth messages make the star tracker publish, in order: :class:`FrameStatus` items (every frame, when it
    is measured), :class:`ReleasedFrame` items (the frames with an attitude, when their delay has passed) and
    :class:`~pmv_ros.runtime.common.records.HealthAt` statuses (stamped with the truth sample's time); and ``log``
    lines for the node's log."""

    published: list = field(default_factory=list)
    log: list = field(default_factory=list)  #: :class:`~pmv_ros.runtime.common.records.LogLine` items

    @property
    def released(self) -> list[ReleasedFrame]:
        """The released frames, in frame order."""
        return [item for item in self.published if type(item) is ReleasedFrame]

    @property
    def health(self) -> HealthSummary | None:
        """The last /diagnostics status (None: none)."""
        statuses = [item.health for item in self.published if type(item) is HealthAt]
        return statuses[-1] if statuses else None


@dataclass(frozen=True)
class MeasuredFrames:
    """Frames measured from a batch of truth, in frame order: ``(M,)`` per frame unless said.

    ``frame_s`` stamps (the middle of the exposure), s; ``q_measured`` (4, M)
    (NaN without output); ``outcome`` :class:`~pmv_ros.physics.star_tracker.Outcome`
    codes (int8: OK, or why the frame gives no attitude); ``stars``
    catalogue stars registered in the field; ``hits`` proton hits;
    ``truth_index`` the truth sample of the batch that completed each.
    """

    frame_s: np.ndarray
    q_measured: np.ndarray
    outcome: np.ndarray
    stars: np.ndarray
    hits: np.ndarray
    truth_index: np.ndarray


#: What a batch that completes no frame gives (shared: its arrays are empty and read-only).
_NO_MEASURED_FRAMES = MeasuredFrames(read_only(np.empty(0)), read_only(np.empty((4, 0))),
                                     read_only(np.empty(0, np.int8)), read_only(np.empty(0, np.int64)),
                                     read_only(np.empty(0, np.int64)), read_only(np.empty(0, np.int64)))


class TrackerRuntime:
    """The star tracker fed with true attitude: one truth message at a time, or a stream of them at once.

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
        # /attitude/truth in another frame than the orbital one (an inertial quaternion, say): refused, said once.
        self.frame_check = FrameCheck("true attitude", self.frames.orbital)
        self._source_problems, self._source_counters = source_problems, source_counters
        self.stamps = StampCheck(1.0, 1.0)
        self.grid = FrameGrid(values["frame_period_s"], values["max_truth_gap_s"])
        self.queue = LatencyQueue(0.0)  # bounded by the delay × the frame rate
        self.tables = None  # the sky and the radiation grid, loaded once (no parameter change reads a file)
        self.outcomes = {outcome: 0 for outcome in Outcome}
        self.last_outcome = Outcome.OK
        self.last_stars, self.last_hits = 0, 0
        self.input_counts = {f"rejected_truth_{reason.value}": 0 for reason in REJECTIONS}
        self.input_counts.update(truth_quaternions_normalised=0, clock_jumps=0, clock_outliers=0,
                                 frames_dropped_at_clock_jump=0)
        if values["orbit.source"] == "follow":  # the user's orbit/odometry: the orbit the frames are measured on
            self.input_counts.update({f"rejected_odometry_{reason.value}": 0 for reason in ODOMETRY_REJECTIONS})
        self.odometry_stamps = StampCheck(1.0, 1.0)
        self.tracker = None
        self._rejected_reported = 0
        self._last_health_s = -math.inf
        # Stale input: measured by arrival on the node clock, so a source whose stamps are on another
        # clock is not "stale".
        self.last_arrival_s = None
        self.reconfigure(values)

    def reconfigure(self, values: dict) -> None:
        """New parameter values: a new tracker (the same draws for the same frame times), the grid's period and
        the publication delay (exposure_s/2 + processing_s).

        The checks first: a combination the ranges cannot check is refused (ValueError), and then nothing changed.
        """
        stamps = self.stamps.reconfigured(values["clock_jump_s"], values["future_tolerance_s"],
                                          1.0 / values["input.max_rate_hz"])
        odometry_stamps = self.odometry_stamps.reconfigured(values["clock_jump_s"], values["future_tolerance_s"],
                                                            1.0 / values["input.max_rate_hz"])
        previous, heard = self.tracker, self.orbit_buffer
        self.tracker, self.tables = build_tracker(values, self.start_s, self.tables)
        if previous is not None and heard is not None:  # orbit.source follow: the odometry heard so far stays
            self.orbit_buffer.take_states(heard)
        self._orbit_bounds = orbit_bounds(values)
        self.stamps, self.odometry_stamps, self.values = stamps, odometry_stamps, values
        self.grid.period_s, self.grid.max_gap_s = values["frame_period_s"], values["max_truth_gap_s"]
        self.queue.latency_s = self.delay_s

    @property
    def delay_s(self) -> float:
        """From a frame's time to its publication, s: half the exposure, then the readout and processing."""
        return self.tracker.parameters.exposure_s / 2.0 + self.values["processing_s"]

    def new_timeline(self) -> int:
        """The truth clock went back: restart the grid and drop the frames not yet released; how many."""
        self.grid.restart()
        return self.queue.clear()

    def add_truth_batch(self, t_s, q_xyzw) -> MeasuredFrames:
        """Truth samples in arrival order (stamps ``(N,)`` s, increasing; ``(4, N)`` (x, y, z, w); or one sample,
        a float stamp and its quaternion): the frames they complete, measured.

        The frames whose outcome is OK wait in the queue for :meth:`release_batch`, each from the truth sample
        that completed it on.
        """
        grid = self.grid.add_many(t_s, q_xyzw)
        if not grid.frame_s.size:
            return _NO_MEASURED_FRAMES
        frames = self._measure(grid)
        outcome = frames.outcome
        codes = outcome.tolist()
        if len(codes) == 1:  # a node's frame
            self.outcomes[_OUTCOMES[codes[0]]] += 1
            good = int(codes[0] == _OK)
        else:
            for code, count in enumerate(np.bincount(outcome).tolist()):
                if count:
                    self.outcomes[_OUTCOMES[code]] += count
            good = codes.count(_OK)
        self.last_outcome = _OUTCOMES[codes[-1]]
        self.last_stars, self.last_hits = frames.stars.item(-1), frames.hits.item(-1)
        if good == len(codes):  # every frame has an attitude: all wait for their release
            self.queue.push_many(grid.frame_s, frames.q_measured, grid.truth_index)
        elif good:
            ok = outcome == _OK
            self.queue.push_many(grid.frame_s[ok], frames.q_measured[:, ok], grid.truth_index[ok])
        return MeasuredFrames(grid.frame_s, frames.q_measured, outcome, frames.stars, frames.hits, grid.truth_index)

    @property
    def orbit_buffer(self):
        """The odometry states the frames are measured on (orbit.source follow), else None."""
        return None if self.tracker is None else getattr(self.tracker.orbit, "buffer", None)

    def _measure(self, grid):
        """The grid's frames measured; with a followed orbit, the frames whose time no odometry covers are
        NO_ORBIT (the attitude cannot be turned into the orbital frame without one)."""
        buffer = self.orbit_buffer
        if buffer is None:
            return self.tracker.measure(grid.frame_s, grid.attitude, grid.turn_rate_rad_s)
        known = np.array([buffer.where(t).usable for t in grid.frame_s.tolist()], bool)
        count = grid.frame_s.size
        if known.all():
            return self.tracker.measure(grid.frame_s, grid.attitude, grid.turn_rate_rad_s)
        q, outcome = np.full((4, count), np.nan), np.full(count, Outcome.NO_ORBIT.value, np.int8)
        stars, hits, used = (np.zeros(count, np.int64) for _ in range(3))
        if known.any():
            some = self.tracker.measure(grid.frame_s[known], grid.attitude[:, known], grid.turn_rate_rad_s[:, known])
            q[:, known], outcome[known], stars[known], hits[known], used[known] = (
                some.q_measured, some.outcome, some.stars, some.hits, some.used)
        return FrameMeasurement(q, outcome, stars, hits, used)

    def add_odometry(self, frame_id: str, child_frame_id: str, state, now_s: float | None) -> TrackerOutput:
        """orbit.source follow: one orbit/odometry message (pose in ECI, twist in the orbital frame; ``state``
        (stamp s, position m, velocity m/s) or None when unreadable): a valid state is kept for the frames, a bad
        one dropped and counted (``rejected_odometry_<reason>``). Without follow the tracker takes none."""
        return self.add_inputs([("add_odometry", (frame_id, child_frame_id, state), now_s)])

    def _take_odometry(self, frame_id: str, child_frame_id: str, state, now_s) -> None:
        buffer = self.orbit_buffer
        if buffer is None:
            return
        frames = self.frames
        rejection, jumped = check_odometry(frame_id, child_frame_id, state, frames.eci, frames.orbital,
                                           self._orbit_bounds, self.odometry_stamps, now_s)
        if jumped:
            buffer.clear()
        if rejection is not None:
            self.input_counts[f"rejected_odometry_{rejection.value}"] += 1
            return
        stamp_s, position, velocity = state
        buffer.add(stamp_s, position, velocity)

    def add_truth(self, t_s: float, q_xyzw) -> list[tuple[float, np.ndarray, Outcome]]:
        """One truth sample (a batch of one): (frame time s, measured (x, y, z, w), outcome) per frame it completes.

        A frame whose outcome is OK waits in the queue for :meth:`release`.
        """
        frames = self.add_truth_batch(float(t_s), q_xyzw)
        return [(frame_s, frames.q_measured[:, k], Outcome(code))
                for k, (frame_s, code) in enumerate(zip(frames.frame_s.tolist(), frames.outcome.tolist()))]

    def release(self, t_s: float) -> list[tuple[float, tuple]]:
        """Frames whose delay has passed at ``t_s``, in frame order: (frame time s, measured quaternion)."""
        frame_s, q_measured, _ = self.queue.release_many(t_s)
        return list(zip(frame_s.tolist(), map(tuple, q_measured.T.tolist())))

    def release_batch(self, t_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`release` at each of the increasing stamps ``t_s`` ``(N,)``: (frame times ``(R,)``, measured
        quaternions ``(4, R)``, the index of the stamp each is released at ``(R,)``), in frame order."""
        return self.queue.release_many(t_s)

    # -- the node's input and health ------------------------------------------------------------

    @property
    def counters(self) -> dict:
        """Frame outcomes and input counters (a copy), as on /diagnostics."""
        values = dict(zip(_FRAME_KEYS, self.outcomes.values()))
        values.update(self.input_counts)
        return values

    def receive_truth(self, frame_id: str, stamp_s: float | None, q_xyzw, now_s: float | None) -> TrackerOutput:
        """One /attitude/truth message (``stamp_s`` None: unreadable) at node clock ``now_s`` (None: unknown): a batch
        of one (:meth:`add_inputs`)."""
        return self.add_inputs([("receive_truth", (frame_id, stamp_s, q_xyzw), now_s)])

    def add_inputs(self, events) -> TrackerOutput:
        """/attitude/truth messages in arrival order, each ``("receive_truth", (frame id, stamp s or None when
        unreadable, (x, y, z, w)), node clock s or None)``: what they make the tracker publish, in order.

        A bad one is counted and changes nothing else; a good one adds frames and releases those due at its stamp,
        and a /diagnostics status comes at most once a second of truth time. The good messages between two
        statuses (or clock jumps) are measured as one batch (:meth:`add_truth_batch`, the same draws as one by one).
        """
        output, counts = TrackerOutput(), self.input_counts
        stamps, quaternions = [], []

        def measure() -> None:  # the good messages so far: their frames, then the releases at each stamp
            if stamps:
                # One message (most wake-ups): a float and a tuple, which the grid and the queue take as they are.
                one = len(stamps) == 1
                frames = self.add_truth_batch(stamps[0] if one else np.array(stamps),
                                              quaternions[0] if one else np.array(quaternions).T)
                released = self.queue.release_many(stamps[0] if one else np.array(stamps))  # release_batch
                if frames.frame_s.size or released[0].size:  # most messages fall between two frames
                    output.published += _in_order(frames, *released)
            stamps.clear()
            quaternions.clear()

        for to, arguments, now_s in events:
            if to == "add_odometry":  # before the truth that follows it, as it arrived
                self._take_odometry(*arguments, now_s)
                continue
            frame_id, stamp_s, q_xyzw = arguments
            rejection = self.frame_check.check(frame_id)  # an inertial quaternion, say
            if rejection is not None:
                line = self.frame_check.take_log_line()
                if line is not None:
                    output.log.append(LogLine("error", line))
            elif stamp_s is None:  # a negative or non-finite stamp
                rejection = Rejection.ZERO_STAMP
            if rejection is not None:
                counts[f"rejected_truth_{rejection.value}"] += 1
                continue
            self.last_arrival_s = now_s
            sample = check_quaternion_sample(self.stamps, stamp_s, q_xyzw, now_s)
            if sample.outliers:
                counts["clock_outliers"] += sample.outliers
            if sample.jumped:  # the truth clock went back: frames of the old timeline not yet released are dropped
                measure()
                counts["clock_jumps"] += 1
                counts["frames_dropped_at_clock_jump"] += self.new_timeline()
                self._last_health_s = -math.inf
            if sample.rejection is not None:
                counts[f"rejected_truth_{sample.rejection.value}"] += 1
                continue
            if sample.normalised:
                counts["truth_quaternions_normalised"] += 1
            stamps.append(stamp_s)
            quaternions.append(sample.q_xyzw)
            if stamp_s - self._last_health_s >= 1.0:
                measure()
                self._last_health_s = stamp_s
                last = self.last_outcome
                output.published.append(HealthAt(stamp_s, self.health(
                    [] if last == Outcome.OK else [f"star-tracker outage: {last.phrase}"])))
        measure()
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
        values.update(stars_in_field=self.last_stars, proton_hits=self.last_hits, release_queue=len(self.queue))
        rejected = sum(_rejected_counts(self.input_counts))
        if rejected > self._rejected_reported:
            problems = problems + ["rejected /attitude/truth messages"]
        self._rejected_reported = rejected
        if self.frame_check.problem is not None:  # what was expected, what came, while the refusals last
            problems = problems + [self.frame_check.problem]
        source_errors = self._source_problems()
        problems = source_errors + problems
        level = Level.ERROR if source_errors else Level.WARN if problems else Level.OK
        return HealthSummary(level, "; ".join(problems) or "attitude available", values)


def _in_order(frames: MeasuredFrames, frame_s, q_measured, released_at) -> list:
    """What a batch publishes, as one message at a time does: at each truth sample, the statuses of the frames it
    completes, then the frames it releases."""
    statuses = [FrameStatus(t, _REASONS[code], stars, hits) for t, code, stars, hits in zip(
        frames.frame_s.tolist(), frames.outcome.tolist(), frames.stars.tolist(), frames.hits.tolist())]
    releases = [ReleasedFrame(t, tuple(q)) for t, q in zip(frame_s.tolist(), q_measured.T.tolist())]
    if not releases or not statuses:  # each kind is in truth order already
        return statuses or releases
    items = [(i, 0, status) for i, status in zip(frames.truth_index.tolist(), statuses)]
    items += [(i, 1, release) for i, release in zip(released_at.tolist(), releases)]
    items.sort(key=lambda item: item[:2])  # stable: frames stay in their order
    return [item for _, _, item in items]


@dataclass(frozen=True)
class TrackerFrames:
    """Star-tracker frames of a truth stream, as star_tracker_node makes them: ``(M,)`` per frame unless said.

    ``frame_s`` stamps (mid-exposure), s; ``q_measured`` (4, M) (NaN without
    output); ``outcome`` :class:`~pmv_ros.physics.star_tracker.Outcome` codes
    (OK or the reason there is no attitude: ``Outcome(code).reason``);
    ``released_at`` the index of the truth sample at which each frame is
    published (-1: not published by the end, or no output); ``stars`` the
    catalogue stars registered in the field; ``hits`` the proton hits.

    A consumer that could not use a sample for want of truth finds why from
    the frames around the sample's stamp: the outcome of the frame nearest
    to it that gave none (:func:`reason_at`).
    """

    frame_s: np.ndarray
    q_measured: np.ndarray
    outcome: np.ndarray
    released_at: np.ndarray
    stars: np.ndarray
    hits: np.ndarray


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
    return TrackerFrames(frames.frame_s, frames.q_measured, frames.outcome.astype(np.int8), published,
                         frames.stars, frames.hits)


def reason_at(frames: TrackerFrames, t_s) -> np.ndarray:
    """The outcome code of the frame nearest to each of the stamps ``t_s`` ``(N,)`` (int8 ``(N,)``; OK where no
    frame is within one frame period): why a sample at ``t_s`` had, or had not, truth around it."""
    t = np.atleast_1d(np.asarray(t_s, float))
    frame_s = frames.frame_s
    if not frame_s.size:
        return np.zeros(t.shape, np.int8)
    after = np.minimum(np.searchsorted(frame_s, t), frame_s.size - 1)
    before = np.maximum(after - 1, 0)
    nearest = np.where(np.abs(frame_s[before] - t) <= np.abs(frame_s[after] - t), before, after)
    period = np.median(np.diff(frame_s)) if frame_s.size > 1 else np.inf
    return np.where(np.abs(frame_s[nearest] - t) <= period, frames.outcome[nearest], 0).astype(np.int8)
