"""The error monitor without ROS: align the sensor with star-tracker truth, keep live statistics.

:class:`ErrorMonitor` is what ``error_monitor_node`` wraps. It takes truth
samples (t, roll, pitch) — or star-tracker quaternions — and sensor samples
(t, roll, pitch, plus the orbit position for the oblateness model), and for
each sensor sample returns an :class:`Outcome`: the residual sensor − truth,
or the reason it could not be used. Times are seconds (float) on the node
clock; angles radians.

Alignment (physics.md §6: truth has noise, latency and gaps)
    Truth is interpolated linearly in roll and pitch between the two truth
    samples that bracket the sensor stamp, never across a gap longer than
    ``max_truth_gap_s``. A sensor sample newer than the latest truth waits in
    a bounded pending queue until truth at or after its stamp arrives, so the
    residual of a sample comes out with the truth latency plus up to one
    truth interval of delay; a sample that waits longer than
    ``max_truth_wait_s`` (measured by the newer sensor stamps or by ``now_s``)
    is given up as ``stale_truth`` — that is what a star-tracker outage
    produces, and alignment resumes by itself when truth returns.

Validation (issues 6 and 15; the checks are :mod:`pmv_ros.runtime.validation`)
    Every incoming sample is checked before it touches any state: non-finite
    values, a zero (unset) or negative stamp, a stamp in the future of
    ``now_s``, a duplicate or backwards stamp, one stamped faster than the
    stream may be (``min_interval_s``), a quaternion far from unit norm
    (near-unit ones are normalised and counted), a sensor angle beyond the
    plausibility bound, an orbit state that is not a bound Earth orbit. So no
    statistic can become non-finite: every value that reaches one is finite
    and bounded.

Clock jumps (the rule of :class:`~pmv_ros.runtime.validation.JumpDetector`)
    A stamp that goes back by more than ``clock_jump_s`` — or a ``now_s``
    that does, or leaps ahead by more than ``max_truth_wait_s`` — is a *suspected* jump; the next
    observation decides. If it continues the new timeline the jump is real
    (simulation restarted, a node restarted on a new clock): the alignment
    state and the harmonic ring are reset once, so that nothing is
    interpolated or fitted across the discontinuity, while the running
    statistics, which are sums over valid residuals, carry on. If it is back
    on the old timeline the jump was a single outlier (a forged ``/clock``, a
    mis-stamped message): counted ``clock_outliers``, and the ring and the
    alignment are kept. While a jump of ``now_s`` is unconfirmed, the old
    clock is used. :meth:`ErrorMonitor.reset` clears everything.

Statistics
    Per channel roll, pitch, meridional, both with the oblateness model
    removed and kept (``remove_oblateness`` picks the one reported by
    default): running count, mean, σ (N − 1), 3σ, max |e|
    (:class:`~pmv_ros.analysis.statistics.RunningStatistics`); harmonic
    amplitudes over the last full orbit from a fixed-size ring
    (:class:`~pmv_ros.analysis.statistics.OrbitRing`); and the residual as the
    ground error of a nadir imager (physics.md §7): cross-track for roll,
    along-track for pitch, circular for meridional. Memory is bounded
    whatever the run length: fixed counters, fixed ring, truth buffer and
    pending queue capped.

Batches
    :meth:`ErrorMonitor.add_batch` takes a whole stretch of sensor, truth and
    odometry samples in arrival order (``pmv campaign`` flies a task through
    it): every input passes the same checks one by one, then the alignment
    and statistics run on arrays; a batch the array form cannot follow
    exactly (a clock jump, samples already pending, …) is fed sample by
    sample. Either way the outcome is the per-sample one.

Not thread-safe: call it from one executor thread.
"""

from __future__ import annotations

import bisect
import copy
import math
from collections import deque
from dataclasses import dataclass
from enum import Enum

import numpy as np

from ..physics.attitude import true_roll_pitch
from ..physics.constants import GM_EARTH_M3_S2
from ..physics.ground_error import nadir_ground_error
from ..physics.oblateness import closed_form_oblateness
from ..physics.orbit import CircularOrbit, orbit_angles_from_state
from .validation import (
    QUATERNION_NORM_TOLERANCE,
    STAMP_REJECTIONS,
    TRUTH_REJECTIONS,
    UNIT_ROUNDING,
    InputBounds,
    Jump,
    JumpDetector,
    Rejection,
    StampCheck,
    check_angles,
    check_orbit_state,
    check_quaternion,
)
from ..analysis.statistics import (
    CHANNELS,
    ChannelStatistics,
    DEFAULT_MAX_CONDITION,
    DEFAULT_MAX_GAP_FRACTION,
    ORBIT_HARMONICS,
    OrbitRing,
    RunningStatistics,
)


class Status(str, Enum):
    """What became of a valid sensor sample: ``ok`` or why it could not be aligned (the value is the counter name).

    A sample rejected by validation has a :class:`~pmv_ros.runtime.validation.Rejection` instead.
    """

    OK = "ok"
    # Alignment of a valid sensor sample with truth.
    NO_TRUTH = "no_truth"                  # no truth at or before the stamp since the (re)start
    TOO_OLD = "too_old"                    # older than the truth history kept (sensor far behind truth)
    TRUTH_GAP = "truth_gap"                # bracketing truth samples further apart than max_truth_gap_s
    STALE_TRUTH = "stale_truth"            # no truth covering the stamp arrived within max_truth_wait_s
    PENDING_OVERFLOW = "pending_overflow"  # pushed out of a full pending queue
    RESET = "reset"                        # still pending when a discontinuity reset the alignment
    NO_VALID_ANGLE = "no_valid_angle"      # the sensor reported neither roll nor pitch (both chord pairs lost)


#: Reasons a valid sensor sample could not be aligned with truth.
SKIP_REASONS = (Status.NO_VALID_ANGLE, Status.NO_TRUTH, Status.TOO_OLD, Status.TRUTH_GAP, Status.STALE_TRUTH,
                Status.PENDING_OVERFLOW, Status.RESET)

#: Reasons an incoming sample is rejected, per stream.
SENSOR_REJECTIONS = STAMP_REJECTIONS + (Rejection.IMPLAUSIBLE_ANGLE,)
ODOMETRY_REJECTIONS = STAMP_REJECTIONS + (Rejection.IMPLAUSIBLE_ORBIT,)


def _counter_names() -> tuple[str, ...]:
    names = ["sensor_received", "truth_received", "odometry_received", "used"]
    names += [f"skipped_{reason.value}" for reason in SKIP_REASONS]
    names += [f"rejected_sensor_{reason.value}" for reason in SENSOR_REJECTIONS]
    names += [f"rejected_truth_{reason.value}" for reason in TRUTH_REJECTIONS]
    names += [f"rejected_odometry_{reason.value}" for reason in ODOMETRY_REJECTIONS]
    names += ["used_one_angle", "truth_quaternions_normalised", "used_without_oblateness_model", "clock_jumps",
              "clock_outliers", "alignment_resets"]
    return tuple(names)


#: Every counter the monitor keeps (fixed: memory does not grow with new reasons).
COUNTER_NAMES = _counter_names()


def _positive(name: str, value: float, low: float = 0.0, high: float = math.inf) -> float:
    number = float(value)
    if not (math.isfinite(number) and low < number <= high):
        raise ValueError(f"{name} = {value} is outside the allowed range ({low:g}, {high:g}]")
    return number


@dataclass(frozen=True)
class MonitorConfig:
    """Parameters of :class:`ErrorMonitor` (SI, rad). Out-of-range values raise ValueError.

    Args:
        orbital_period_s: period for the harmonic ring, s (:meth:`for_orbit` derives it).
        altitude_m: default altitude for the oblateness model and the ground error, m (None: per sample only).
        inclination_rad: default inclination for the oblateness model, rad (None: per sample only).
        remove_oblateness: report the statistics with the oblateness model removed (both are kept).
        max_truth_gap_s: never interpolate truth across a gap longer than this, s.
        max_truth_wait_s: give a sensor sample up when no truth covers it after this long, s.
        truth_history_s: how far back truth is kept for late sensor samples, s.
        truth_capacity: hard cap on stored truth samples.
        max_pending: hard cap on sensor samples waiting for truth.
        clock_jump_s: a stamp (or now) going back by more than this is a clock jump, s
            (acted on once it is confirmed: see the module docstring).
        future_tolerance_s: a stamp later than now + this is rejected, s.
        min_interval_s: a stamp closer than this after the previous one of its stream is
            rejected as too fast (0: no limit), s.
        bounds: plausibility bounds of sensor angles and orbit states.
        harmonic_bins: bins of the one-orbit ring.
        harmonics: harmonics of the orbital frequency to report (physics.md §5.1).
        max_harmonic_gap_fraction: largest hole in the last orbit for which harmonics are reported.
        roll_offset_rad, pitch_offset_rad: known constant offsets (mounting) removed before the statistics.
    """

    orbital_period_s: float
    altitude_m: float | None = None
    inclination_rad: float | None = None
    remove_oblateness: bool = True
    max_truth_gap_s: float = 2.0
    max_truth_wait_s: float = 10.0
    truth_history_s: float = 60.0
    truth_capacity: int = 4096
    max_pending: int = 4096
    clock_jump_s: float = 1.0
    future_tolerance_s: float = 1.0
    min_interval_s: float = 0.0
    bounds: InputBounds = InputBounds()
    harmonic_bins: int = 1024
    harmonics: tuple = ORBIT_HARMONICS
    max_harmonic_gap_fraction: float = DEFAULT_MAX_GAP_FRACTION
    roll_offset_rad: float = 0.0
    pitch_offset_rad: float = 0.0

    def __post_init__(self) -> None:
        _positive("orbital_period_s", self.orbital_period_s, 0.0, 1e7)
        if self.altitude_m is not None:
            _positive("altitude_m", self.altitude_m, 0.0, 1e8)
        if self.inclination_rad is not None and not 0.0 <= self.inclination_rad <= math.pi:
            raise ValueError(f"inclination_rad = {self.inclination_rad} is outside the allowed range [0, π]")
        _positive("max_truth_gap_s", self.max_truth_gap_s, 0.0, 1e5)
        _positive("max_truth_wait_s", self.max_truth_wait_s, 0.0, 1e5)
        _positive("truth_history_s", self.truth_history_s, 0.0, 1e6)
        _positive("clock_jump_s", self.clock_jump_s, 0.0, 1e6)
        _positive("future_tolerance_s", self.future_tolerance_s, 0.0, 1e6)
        if not (math.isfinite(self.min_interval_s) and 0.0 <= self.min_interval_s < self.clock_jump_s):
            raise ValueError(f"min_interval_s = {self.min_interval_s} is outside the allowed range "
                             f"[0, clock_jump_s = {self.clock_jump_s})")
        _positive("max_harmonic_gap_fraction", self.max_harmonic_gap_fraction, 0.0, 1.0)
        for name in ("truth_capacity", "max_pending"):
            value = getattr(self, name)
            if int(value) != value or not 2 <= value <= 10_000_000:
                raise ValueError(f"{name} = {value} is outside the allowed range 2 … 10000000 (an integer)")
        if int(self.harmonic_bins) != self.harmonic_bins or not 64 <= self.harmonic_bins <= 1_000_000:
            raise ValueError(f"harmonic_bins = {self.harmonic_bins} is outside the allowed range 64 … 1000000")
        if not self.harmonics or any(int(k) != k or k < 1 for k in self.harmonics):
            raise ValueError(f"harmonics = {self.harmonics} must be a non-empty list of positive integers")
        for name in ("roll_offset_rad", "pitch_offset_rad"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} = {getattr(self, name)} must be finite")

    @classmethod
    def for_orbit(cls, altitude_m: float, inclination_rad: float, **options) -> "MonitorConfig":
        """A configuration for a circular orbit: the period comes from :class:`CircularOrbit`."""
        period = CircularOrbit(altitude_m, inclination_rad).period_s
        return cls(orbital_period_s=period, altitude_m=altitude_m, inclination_rad=inclination_rad, **options)


@dataclass(frozen=True)
class Outcome:
    """What became of one sensor sample: its residuals (rad) and ground error (m), or why it was skipped.

    ``status`` is :attr:`Status.OK`, a :class:`Status` skip reason, or the
    :class:`~pmv_ros.runtime.validation.Rejection` of an invalid sample.
    ``residual_*`` is sensor − truth, as published on /pmv/residual.
    ``roll_rad``/``pitch_rad``/``meridional_rad`` are the residuals that went
    into the reported statistics (offsets removed, oblateness model removed
    when configured). All NaN unless ``status`` is OK.
    """

    stamp_s: float
    status: Status | Rejection
    residual_roll_rad: float = math.nan
    residual_pitch_rad: float = math.nan
    roll_rad: float = math.nan
    pitch_rad: float = math.nan
    meridional_rad: float = math.nan
    along_track_m: float = math.nan
    cross_track_m: float = math.nan
    circular_m: float = math.nan

    @property
    def ok(self) -> bool:
        """True when the sample was aligned and used."""
        return self.status is Status.OK


@dataclass(frozen=True)
class MonitorSummary:
    """A snapshot of the monitor: channels roll, pitch, meridional and the sample counters."""

    oblateness_removed: bool
    channels: tuple
    counters: dict
    harmonics_full_orbit: bool

    def channel(self, name: str) -> ChannelStatistics:
        """The statistics of channel ``name``."""
        for summary in self.channels:
            if summary.channel == name:
                return summary
        raise KeyError(name)


@dataclass
class _Pending:
    stamp_s: float
    roll_rad: float
    pitch_rad: float
    oblateness_roll_rad: float
    oblateness_pitch_rad: float
    altitude_m: float


class _StatisticsSet:
    """Running statistics of roll, pitch, meridional and their ground errors."""

    def __init__(self) -> None:
        self.angles = [RunningStatistics() for _ in CHANNELS]
        self.ground = [RunningStatistics() for _ in CHANNELS]

    def reset(self) -> None:
        for stats in self.angles + self.ground:
            stats.reset()


def _ground_components(row, altitude_m: float) -> tuple[float, float, float]:
    """(cross-track, along-track, circular) ground error, m, of a (roll, pitch, meridional) residual row.

    Cross-track goes with roll, along-track with pitch, circular with
    meridional; a lost angle gives NaN in its own component (and in the
    circular one) only.
    """
    roll, pitch, meridional = row
    error = nadir_ground_error(0.0 if math.isnan(roll) else roll, 0.0 if math.isnan(pitch) else pitch, altitude_m)
    return (math.nan if math.isnan(roll) else error.cross_track_m,
            math.nan if math.isnan(pitch) else error.along_track_m,
            math.nan if math.isnan(meridional) else error.circular_m)


#: Status codes of :meth:`ErrorMonitor.add_batch`: a sample's code is its index here; PENDING_CODE while it waits.
BATCH_STATUSES = (Status.OK,) + SKIP_REASONS + SENSOR_REJECTIONS
PENDING_CODE = -1


@dataclass
class BatchOutcome:
    """What became of each sensor sample of a batch (:meth:`ErrorMonitor.add_batch`), ``(N,)`` arrays.

    ``status``: index into :data:`BATCH_STATUSES`, :data:`PENDING_CODE` for a
    sample still waiting for truth. The residuals are those of
    :class:`Outcome` (sensor − truth; and as they entered the reported
    statistics), NaN unless the sample was used.
    """

    status: np.ndarray
    residual_roll_rad: np.ndarray
    residual_pitch_rad: np.ndarray
    roll_rad: np.ndarray
    pitch_rad: np.ndarray
    meridional_rad: np.ndarray

    @classmethod
    def empty(cls, n: int) -> "BatchOutcome":
        """N samples, all pending."""
        return cls(np.full(n, PENDING_CODE, np.int8), *(np.full(n, np.nan) for _ in range(5)))

    def take(self, outcomes, index_of_stamp: dict) -> None:
        """Record per-sample outcomes by their stamps (the per-sample path of add_batch)."""
        for outcome in outcomes:
            i = index_of_stamp.get(outcome.stamp_s)
            if i is None:
                continue
            self.status[i] = BATCH_STATUSES.index(outcome.status)
            if outcome.ok:
                self.residual_roll_rad[i], self.residual_pitch_rad[i] = outcome.residual_roll_rad, outcome.residual_pitch_rad
                self.roll_rad[i], self.pitch_rad[i] = outcome.roll_rad, outcome.pitch_rad
                self.meridional_rad[i] = outcome.meridional_rad


def _element(value, index: int):
    """Element ``index`` of a per-sample argument (an array, a scalar for all, or None) as a float or None."""
    if value is None:
        return None
    array = np.asarray(value, float)
    return float(array) if array.ndim == 0 else float(array[index])


def _first_expired(clocks: np.ndarray, stamp: np.ndarray, wait_s: float) -> np.ndarray:
    """Per stamp, the first index of the non-decreasing ``clocks`` with ``clock − stamp > wait_s`` in floats —
    the test of ErrorMonitor._expire (a search on ``stamp + wait_s`` alone can be one value off by rounding)."""
    size = clocks.size
    first = np.searchsorted(clocks, stamp + wait_s, side="right")
    before = np.maximum(first - 1, 0)
    back = (first > 0) & (clocks[before] - stamp > wait_s) if size else np.zeros(stamp.shape, bool)
    first = np.where(back, np.searchsorted(clocks, clocks[before] if size else stamp, side="left"), first)
    at = np.minimum(first, max(size - 1, 0))
    on = (first < size) & ~(clocks[at] - stamp > wait_s) if size else np.zeros(stamp.shape, bool)
    return np.where(on, np.searchsorted(clocks, clocks[at] if size else stamp, side="right"), first)


def _ground_arrays(columns, altitude_m: float):
    """(cross-track, along-track, circular) ground errors, m, of (roll, pitch, meridional) residual arrays, as
    :func:`_ground_components` gives them row by row."""
    roll, pitch, meridional = columns
    error = nadir_ground_error(np.where(np.isnan(roll), 0.0, roll), np.where(np.isnan(pitch), 0.0, pitch), altitude_m)
    return (np.where(np.isnan(roll), np.nan, error.cross_track_m),
            np.where(np.isnan(pitch), np.nan, error.along_track_m),
            np.where(np.isnan(meridional), np.nan, error.circular_m))


def _orbit_record(t_s: float, position_eci_m, velocity_eci_m_s) -> tuple:
    """What the monitor keeps of an accepted odometry state: (stamp_s, u_rad, inclination_rad, altitude_m,
    mean motion rad/s) — the orbit of :meth:`ErrorMonitor.orbit_at`."""
    u, inclination, altitude = orbit_angles_from_state(position_eci_m, velocity_eci_m_s)
    radius = math.hypot(*(float(c) for c in position_eci_m))
    speed = math.hypot(*(float(c) for c in velocity_eci_m_s))
    return (t_s, u, inclination, altitude, speed / radius)


def _orbit_records(t_s: np.ndarray, position_eci_m: np.ndarray, velocity_eci_m_s: np.ndarray) -> np.ndarray:
    """:func:`_orbit_record` of ``(N,)`` stamps and ``(3, N)`` states: ``(5, N)``."""
    if not t_s.size:
        return np.empty((5, 0))
    u, inclination, altitude = orbit_angles_from_state(position_eci_m, velocity_eci_m_s)
    rate = np.linalg.norm(velocity_eci_m_s, axis=0) / np.linalg.norm(position_eci_m, axis=0)
    return np.vstack([t_s, u, inclination, altitude, rate])


class ErrorMonitor:
    """Align sensor roll/pitch with star-tracker truth and keep live error statistics (physics.md §5, §5.1, §6, §7).

    Feed it with :meth:`add_truth` (or :meth:`add_truth_quaternion`) and
    :meth:`add_sensor` in arrival order; each returns the outcomes of the
    sensor samples it settled (possibly none, possibly several). Call
    :meth:`poll` from a timer so that pending samples time out even when no
    message arrives, and :meth:`summary` to publish.
    """

    def __init__(self, config: MonitorConfig) -> None:
        self.config = config
        self._counters = dict.fromkeys(COUNTER_NAMES, 0)
        self._truth_t: list[float] = []
        self._truth_roll: list[float] = []
        self._truth_pitch: list[float] = []
        self._pending: deque[_Pending] = deque()
        self._sets = {True: _StatisticsSet(), False: _StatisticsSet()}
        # Ring columns: roll, pitch, meridional with the oblateness model removed, then kept.
        self._ring = OrbitRing(config.orbital_period_s, 2 * len(CHANNELS), config.harmonic_bins)
        self._settled: list[Outcome] = []
        self._stamps = {stream: StampCheck(config.clock_jump_s, config.future_tolerance_s, config.min_interval_s)
                        for stream in ("sensor", "truth", "odometry")}
        # Forward, the clock may leap as far as a sample may wait for truth before anyone need doubt it.
        self._clock = JumpDetector(config.clock_jump_s, forward_threshold_s=config.max_truth_wait_s)
        self._reset_alignment_state()

    # ----------------------------------------------------------------- state

    def _reset_alignment_state(self) -> None:
        self._truth_t.clear()
        self._truth_roll.clear()
        self._truth_pitch.clear()
        self._truth_pruned = False
        for check in self._stamps.values():
            check.reset()
        self._clock.reset()
        self._orbit = None  # (stamp_s, u_rad, inclination_rad, altitude_m, mean_motion_rad_s) from odometry
        self._ring.clear()

    def reset_alignment(self) -> list[Outcome]:
        """Start a new time axis: drop truth, pending samples (as RESET) and the harmonic ring; keep statistics."""
        outcomes = [self._skip(entry.stamp_s, Status.RESET) for entry in self._pending]
        self._pending.clear()
        self._reset_alignment_state()
        self._counters["alignment_resets"] += 1
        return outcomes

    def reset(self) -> None:
        """Forget everything: alignment, statistics and counters."""
        self._pending.clear()
        self._settled.clear()
        self._reset_alignment_state()
        for statistics in self._sets.values():
            statistics.reset()
        self._counters = dict.fromkeys(COUNTER_NAMES, 0)

    @property
    def counters(self) -> dict:
        """A copy of every counter (fixed keys: :data:`COUNTER_NAMES`)."""
        return dict(self._counters)

    @property
    def truth_buffer_length(self) -> int:
        """Truth samples held (≤ truth_capacity)."""
        return len(self._truth_t)

    @property
    def latest_truth_stamp_s(self) -> float | None:
        """Stamp of the latest accepted truth sample since the last alignment reset, s (None: none yet)."""
        return self._stamps["truth"].latest_s

    @property
    def pending_count(self) -> int:
        """Sensor samples waiting for truth (≤ max_pending)."""
        return len(self._pending)

    @property
    def ring_nbytes(self) -> int:
        """Memory of the harmonic ring, bytes (fixed)."""
        return self._ring.nbytes

    # ------------------------------------------------------------ validation

    def _observe_now(self, now_s) -> tuple[list[Outcome], float | None]:
        """Watch the node clock for jumps: (outcomes of a reset, the clock that times out waiting samples).

        While a jump of the clock is unconfirmed, waiting samples are timed
        by the old clock (a forged /clock a year ahead must not expire them);
        the future-stamp check takes the clock as it reads.
        """
        if now_s is None or not math.isfinite(now_s):
            return [], None
        now_s = float(now_s)
        verdict = self._clock.observe(now_s)
        outcomes = []
        if verdict is Jump.CONFIRMED_BACK:
            self._counters["clock_jumps"] += 1
            outcomes = self.reset_alignment()
            self._clock.observe(now_s)
        elif verdict is Jump.OUTLIER:
            self._counters["clock_outliers"] += 1
        return outcomes, self._clock.latest_s

    def _check_stamp(self, stream: str, t_s: float, now_s) -> tuple[Rejection | None, list[Outcome]]:
        """Check the stamp of a sample of ``stream`` whose values passed; a confirmed jump resets the alignment once."""
        check = self._stamps[stream]
        outliers = check.outliers
        rejection, jumped = check.check(t_s, now_s)
        self._counters["clock_outliers"] += check.outliers - outliers
        if not jumped:
            return rejection, []
        self._counters["clock_jumps"] += 1
        outcomes = self.reset_alignment()
        check.check(t_s, now_s)  # the first stamp of the new timeline
        return None, outcomes

    # ------------------------------------------------------------------ truth

    def add_truth(self, t_s: float, roll_rad: float, pitch_rad: float, *, now_s: float | None = None) -> list[Outcome]:
        """Add a truth sample (star-tracker roll, pitch in rad at stamp ``t_s`` in s).

        Args:
            now_s: the node clock now, s — enables the future-stamp check and
                clock-jump detection; None to skip both.

        Returns:
            Outcomes of the pending sensor samples this settled.
        """
        self._counters["truth_received"] += 1
        outcomes, clock_s = self._observe_now(now_s)
        t_s, roll_rad, pitch_rad = float(t_s), float(roll_rad), float(pitch_rad)
        if math.isfinite(roll_rad) and math.isfinite(pitch_rad):  # truth is complete, or it is no truth
            rejection, reset = self._check_stamp("truth", t_s, now_s)
            outcomes += reset
        else:
            rejection = Rejection.NON_FINITE
        if rejection is not None:
            self._counters[f"rejected_truth_{rejection.value}"] += 1
            return outcomes + self._expire(clock_s)
        self._truth_t.append(t_s)
        self._truth_roll.append(roll_rad)
        self._truth_pitch.append(pitch_rad)
        while self._pending and self._pending[0].stamp_s <= t_s:
            outcomes.append(self._align(self._pending.popleft()))
        outcomes += self._expire(clock_s)
        self._prune_truth()
        return outcomes

    def add_truth_quaternion(self, t_s: float, q_orbital_to_body, *, now_s: float | None = None) -> list[Outcome]:
        """Add a star-tracker quaternion (x, y, z, w), body in the orbital frame; validated, then as roll/pitch.

        The quaternion becomes the roll and pitch an ideal horizon sensor would
        read (:func:`pmv_ros.physics.attitude.true_roll_pitch`), so yaw cannot
        leak into the comparison.
        """
        q, rejection, normalised = check_quaternion(q_orbital_to_body)
        if rejection is not None:
            self._counters["truth_received"] += 1
            self._counters[f"rejected_truth_{rejection.value}"] += 1
            outcomes, clock_s = self._observe_now(now_s)
            return outcomes + self._expire(clock_s)
        if normalised:
            self._counters["truth_quaternions_normalised"] += 1
        roll, pitch = true_roll_pitch(q)
        return self.add_truth(t_s, float(roll), float(pitch), now_s=now_s)

    def _prune_truth(self) -> None:
        cutoff = self._truth_t[-1] - self.config.truth_history_s
        if self._pending:
            cutoff = min(cutoff, self._pending[0].stamp_s)
        # Keep the last sample at or before the cutoff: it brackets what comes after.
        drop = bisect.bisect_right(self._truth_t, cutoff) - 1
        drop = max(drop, len(self._truth_t) - self.config.truth_capacity)
        if drop > 0:
            del self._truth_t[:drop], self._truth_roll[:drop], self._truth_pitch[:drop]
            self._truth_pruned = True

    # ---------------------------------------------------------------- orbit

    def add_odometry(self, t_s: float, position_eci_m, velocity_eci_m_s, *,
                     now_s: float | None = None) -> Rejection | None:
        """Take the spacecraft's ECI state (m, m/s) at ``t_s`` for the oblateness model; the rejection, if any.

        A state that is not a bound Earth orbit within the bounds (|r| = 1 km,
        1e12 m, an escape speed) is rejected and counted, never used: the
        oblateness model and the ground error would be meaningless.
        """
        self._counters["odometry_received"] += 1
        outcomes, clock_s = self._observe_now(now_s)
        self._settled.extend(outcomes)
        rejection = check_orbit_state(position_eci_m, velocity_eci_m_s, self.config.bounds)
        if rejection is None:
            rejection, reset = self._check_stamp("odometry", float(t_s), now_s)
            self._settled.extend(reset)
        if rejection is not None:
            self._counters[f"rejected_odometry_{rejection.value}"] += 1
            return rejection
        self._orbit = _orbit_record(float(t_s), position_eci_m, velocity_eci_m_s)
        return None

    def orbit_at(self, t_s: float, max_age_s: float) -> dict:
        """``add_sensor`` keywords (u_rad, inclination_rad, altitude_m) at ``t_s`` from the latest accepted
        odometry no further than ``max_age_s`` from it (u advanced at the mean motion); {} if there is none."""
        orbit = self._orbit
        if orbit is None or not abs(t_s - orbit[0]) <= max_age_s:
            return {}
        stamp, u, inclination, altitude, rate = orbit
        return dict(u_rad=u + rate * (t_s - stamp), inclination_rad=inclination, altitude_m=altitude)

    @property
    def latest_orbit_stamp_s(self) -> float | None:
        """Stamp of the latest accepted odometry since the last alignment reset, s (None: none yet)."""
        return None if self._orbit is None else self._orbit[0]

    @property
    def odometry_period_s(self) -> float | None:
        """The orbital period the latest accepted odometry flies (2π / mean motion), s; None without odometry."""
        return None if self._orbit is None else 2.0 * math.pi / self._orbit[4]

    def take_settled(self) -> list[Outcome]:
        """Outcomes settled by a call that returns no outcomes (an odometry message that reset the alignment)."""
        outcomes, self._settled = self._settled, []
        return outcomes

    # ----------------------------------------------------------------- sensor

    def add_sensor(self, t_s: float, roll_rad: float, pitch_rad: float, *, u_rad: float | None = None,
                   altitude_m: float | None = None, inclination_rad: float | None = None,
                   oblateness_roll_rad: float | None = None, oblateness_pitch_rad: float | None = None,
                   now_s: float | None = None) -> list[Outcome]:
        """Add a sensor sample (roll, pitch in rad at stamp ``t_s`` in s).

        The oblateness model for this sample comes from, in order: the values
        passed (``oblateness_roll_rad``/``oblateness_pitch_rad``, e.g. what the
        sensor's on-board compensation used); or the published closed form
        (physics.md §2.1) at ``u_rad`` with ``altitude_m``/``inclination_rad``
        (per sample or from the configuration). Without either, the sample
        enters only the oblateness-kept statistics (counted in
        ``used_without_oblateness_model``).

        Args:
            u_rad: argument of latitude at ``t_s``, rad (see :func:`orbit_angles_from_state`).
            altitude_m: orbit altitude at ``t_s``, m (also used for the ground error).
            inclination_rad: orbit inclination, rad.
            now_s: the node clock now, s (see :meth:`add_truth`).

        Returns:
            Outcomes settled by this call: this sample's if it was rejected or
            could be aligned at once, and any pending samples that timed out.
        """
        self._counters["sensor_received"] += 1
        outcomes, clock_s = self._observe_now(now_s)
        t_s, roll_rad, pitch_rad = float(t_s), float(roll_rad), float(pitch_rad)
        rejection = check_angles(roll_rad, pitch_rad, self.config.bounds.max_abs_angle_rad, allow_nan=True)
        if rejection is None:
            rejection, reset = self._check_stamp("sensor", t_s, now_s)
            outcomes += reset
        if rejection is not None:
            self._counters[f"rejected_sensor_{rejection.value}"] += 1
            return outcomes + [Outcome(t_s, rejection)] + self._expire(clock_s)
        if math.isnan(roll_rad) and math.isnan(pitch_rad):
            return outcomes + [self._skip(t_s, Status.NO_VALID_ANGLE)] + self._expire(clock_s)
        altitude = self.config.altitude_m if altitude_m is None else float(altitude_m)
        model_roll, model_pitch = self._oblateness(u_rad, altitude, inclination_rad,
                                                   oblateness_roll_rad, oblateness_pitch_rad)
        entry = _Pending(t_s, roll_rad, pitch_rad, model_roll, model_pitch,
                         math.nan if altitude is None else altitude)
        if self._truth_t and self._truth_t[-1] >= t_s and not self._pending:
            outcomes.append(self._align(entry))
        else:
            self._pending.append(entry)
            if len(self._pending) > self.config.max_pending:
                outcomes.append(self._skip(self._pending.popleft().stamp_s, Status.PENDING_OVERFLOW))
        return outcomes + self._expire(clock_s)

    def _oblateness(self, u_rad, altitude, inclination_rad, model_roll, model_pitch) -> tuple[float, float]:
        if model_roll is not None and model_pitch is not None:
            return float(model_roll), float(model_pitch)
        inclination = self.config.inclination_rad if inclination_rad is None else float(inclination_rad)
        if u_rad is None or altitude is None or inclination is None:
            return math.nan, math.nan
        _, roll, pitch = closed_form_oblateness(float(u_rad), altitude, inclination)
        return float(roll), float(pitch)

    def poll(self, now_s: float | None = None) -> list[Outcome]:
        """Time out pending samples by the clock (call from a timer); returns their outcomes."""
        outcomes, clock_s = self._observe_now(now_s)
        return self.take_settled() + outcomes + self._expire(clock_s)

    def _expire(self, now_s) -> list[Outcome]:
        """Give up pending samples that have waited longer than max_truth_wait_s."""
        latest = self._stamps["sensor"].latest_s
        if now_s is not None and math.isfinite(now_s):
            latest = now_s if latest is None else max(latest, now_s)
        outcomes = []
        while self._pending and latest is not None and latest - self._pending[0].stamp_s > self.config.max_truth_wait_s:
            outcomes.append(self._skip(self._pending.popleft().stamp_s, Status.STALE_TRUTH))
        return outcomes

    # -------------------------------------------------------------- alignment

    def _skip(self, t_s: float, status: Status) -> Outcome:
        self._counters[f"skipped_{status.value}"] += 1
        return Outcome(t_s, status)

    def _align(self, entry: _Pending) -> Outcome:
        """Interpolate truth at the sample's stamp and account the residual, or say why not."""
        times = self._truth_t
        t = entry.stamp_s
        after = bisect.bisect_left(times, t)
        if after < len(times) and times[after] == t:
            truth_roll, truth_pitch = self._truth_roll[after], self._truth_pitch[after]
        elif after == 0:
            return self._skip(t, Status.TOO_OLD if self._truth_pruned else Status.NO_TRUTH)
        else:
            before = after - 1
            span = times[after] - times[before]
            if span > self.config.max_truth_gap_s:
                return self._skip(t, Status.TRUTH_GAP)
            weight = (t - times[before]) / span
            truth_roll = self._truth_roll[before] + weight * (self._truth_roll[after] - self._truth_roll[before])
            truth_pitch = self._truth_pitch[before] + weight * (self._truth_pitch[after] - self._truth_pitch[before])
        return self._account(entry, entry.roll_rad - truth_roll, entry.pitch_rad - truth_pitch)

    def _account(self, entry: _Pending, residual_roll: float, residual_pitch: float) -> Outcome:
        """Update both statistics sets and the ring with one residual; return the outcome.

        Runs once per sensor sample: plain floats, straight-line code.
        """
        counters = self._counters
        counters["used"] += 1
        if math.isnan(residual_roll) or math.isnan(residual_pitch):
            # One chord pair lost: the other angle counts; the meridional value does not exist.
            counters["used_one_angle"] += 1
        roll_kept = residual_roll - self.config.roll_offset_rad
        pitch_kept = residual_pitch - self.config.pitch_offset_rad
        kept = (roll_kept, pitch_kept, math.hypot(roll_kept, pitch_kept))
        has_model = math.isfinite(entry.oblateness_roll_rad) and math.isfinite(entry.oblateness_pitch_rad)
        if has_model:
            roll_removed = roll_kept - entry.oblateness_roll_rad
            pitch_removed = pitch_kept - entry.oblateness_pitch_rad
            removed = (roll_removed, pitch_removed, math.hypot(roll_removed, pitch_removed))
        else:
            counters["used_without_oblateness_model"] += 1
            removed = (math.nan, math.nan, math.nan)
        with_ground = math.isfinite(entry.altitude_m) and entry.altitude_m > 0.0
        grounds = {}
        for key, row in ((False, kept), (True, removed)):
            if key and not has_model:
                continue
            target = self._sets[key]
            for stats, value in zip(target.angles, row):
                if math.isfinite(value):
                    stats.add(value)
            if with_ground:
                ground = grounds[key] = _ground_components(row, entry.altitude_m)
                for stats, value in zip(target.ground, ground):
                    if math.isfinite(value):
                        stats.add(value)
        self._ring.add(entry.stamp_s, removed + kept)
        primary = self.config.remove_oblateness
        cross, along, circular = grounds.get(primary, (math.nan, math.nan, math.nan))
        return Outcome(entry.stamp_s, Status.OK, residual_roll, residual_pitch, *(removed if primary else kept),
                       along_track_m=along, cross_track_m=cross, circular_m=circular)

    # ------------------------------------------------------------------ batch

    def add_batch(self, sensor_t_s, sensor_roll_rad, sensor_pitch_rad, truth_t_s, q_truth, truth_arrival, *,
                  now_s=None, odometry=None, odometry_max_age_s: float = math.inf, u_rad=None,
                  altitude_m: float | None = None, inclination_rad: float | None = None,
                  oblateness_roll_rad=None, oblateness_pitch_rad=None) -> "BatchOutcome":
        """Many samples at once: what :meth:`add_truth_quaternion`, :meth:`add_odometry` and :meth:`add_sensor`,
        called in arrival order, would do — the same validation, alignment and statistics.

        Each input goes through the same checks (:mod:`pmv_ros.runtime.validation`) one by one, in
        arrival order; the alignment and the statistics then run on arrays. A batch the array form
        cannot follow exactly — a clock jump or outlier, samples already pending, truth that the
        history or the capacity would prune before use, a pending queue that would overflow — is fed
        sample by sample instead, so the result is always the per-sample one (up to the order of
        summation, ≈ 1e-15 relative).

        Arrival order, per sensor sample i: the truth samples with ``truth_arrival == i``, then the
        odometry at the sample's stamp (if given), then the sample.

        Args:
            sensor_t_s, sensor_roll_rad, sensor_pitch_rad: ``(N,)`` sensor samples (s, rad), in arrival order.
            truth_t_s: ``(M,)`` truth stamps, s, in arrival order; ``q_truth``: ``(4, M)`` quaternions (x, y, z, w).
            truth_arrival: ``(M,)`` non-decreasing ints: truth j arrives just before sensor sample
                ``truth_arrival[j]`` (N: after the last one).
            now_s: ``(N,)`` node clock when each sensor sample arrives (a truth arriving before sample i
                sees ``now_s[i]``; after the last, ``now_s[-1]``), s; None: no clock (see :meth:`add_truth`).
            odometry: ``(position_eci_m, velocity_eci_m_s)``, each ``(3, N)``: the spacecraft's state at each
                sensor stamp (what /orbit/odometry carries), for the oblateness model and the ground error
                as the node takes them (:meth:`orbit_at` with ``odometry_max_age_s``); None: the
                ``u_rad``/``altitude_m``/``inclination_rad`` of :meth:`add_sensor` instead
                (``u_rad`` ``(N,)``, the others scalars).
            oblateness_roll_rad, oblateness_pitch_rad: the model itself, ``(N,)`` or scalars, as in
                :meth:`add_sensor` (e.g. zeros when the sensor removes it on board).

        Returns:
            :class:`BatchOutcome`: per sensor sample, the status code and the residuals.
        """
        t = np.asarray(sensor_t_s, float).ravel()
        n = t.size
        roll = np.broadcast_to(np.asarray(sensor_roll_rad, float), (n,))
        pitch = np.broadcast_to(np.asarray(sensor_pitch_rad, float), (n,))
        truth_t = np.asarray(truth_t_s, float).ravel()
        q = np.asarray(q_truth, float).reshape(4, truth_t.size)
        arrival = np.asarray(truth_arrival, np.int64).ravel()
        if arrival.size != truth_t.size or (arrival.size and (np.any(np.diff(arrival) < 0) or arrival[0] < 0
                                                              or arrival[-1] > n)):
            raise ValueError("truth_arrival must give, for each truth sample, a non-decreasing sensor index 0 … N")
        now = None if now_s is None else np.broadcast_to(np.asarray(now_s, float), (n,))
        if odometry is not None:
            odometry = tuple(np.asarray(part, float).reshape(3, n) for part in odometry)
        given_model = oblateness_roll_rad is not None and oblateness_pitch_rad is not None
        inputs = dict(t=t, roll=roll, pitch=pitch, truth_t=truth_t, q=q, arrival=arrival, now=now,
                      odometry=odometry, max_age=float(odometry_max_age_s), u=u_rad, altitude=altitude_m,
                      inclination=inclination_rad,
                      model=(oblateness_roll_rad, oblateness_pitch_rad) if given_model else None)
        scan = None
        if not self._pending and n:
            scan = self._scan_clean_batch(inputs)
            if scan is None:
                scan = self._scan_batch(inputs)
        plan = None if scan is None else self._plan_batch(inputs, scan)
        if plan is not None:
            return self._apply_batch(t, scan, plan)
        return self._add_batch_per_sample(inputs)

    def _add_batch_per_sample(self, inputs) -> "BatchOutcome":
        """:meth:`add_batch` one call per sample: exact by definition."""
        t, roll, pitch, truth_t, q, arrival, now = (inputs[k] for k in ("t", "roll", "pitch", "truth_t", "q",
                                                                        "arrival", "now"))
        n = t.size
        result = BatchOutcome.empty(n)
        index_of_stamp = {}
        j = 0
        for i in range(n + 1):
            clock = None if now is None else float(now[min(i, n - 1)])
            while j < truth_t.size and arrival[j] == i:
                result.take(self.add_truth_quaternion(float(truth_t[j]), q[:, j], now_s=clock), index_of_stamp)
                j += 1
            if i == n:
                break
            if inputs["odometry"] is not None:
                position, velocity = inputs["odometry"]
                self.add_odometry(float(t[i]), position[:, i], velocity[:, i], now_s=clock)
                result.take(self.take_settled(), index_of_stamp)
                orbit = self.orbit_at(float(t[i]), inputs["max_age"])
            else:
                orbit = dict(u_rad=_element(inputs["u"], i), altitude_m=inputs["altitude"],
                             inclination_rad=inputs["inclination"])
            if inputs["model"] is not None:
                orbit.update(oblateness_roll_rad=_element(inputs["model"][0], i),
                             oblateness_pitch_rad=_element(inputs["model"][1], i))
            outcomes = self.add_sensor(float(t[i]), float(roll[i]), float(pitch[i]), now_s=clock, **orbit)
            own = [o for o in outcomes if isinstance(o.status, Rejection)]
            if own:
                result.status[i] = BATCH_STATUSES.index(own[0].status)
                outcomes = [o for o in outcomes if o is not own[0]]
            else:
                index_of_stamp[float(t[i])] = i
            result.take(outcomes, index_of_stamp)
        return result

    def _scan_clean_batch(self, inputs):
        """:meth:`_scan_batch` on arrays for a clean batch — every stamp on its stream's timeline, increasing
        at no more than the rate limit and not in the future, the node clock steady — else None.

        What a campaign's flight always is. Its verdicts are those of the sample-by-sample scan: the
        checks that can reject a clean stamp (angles, quaternions, orbit states) run on every sample; a
        batch in which any stamp or clock reading would need the jump rule goes the scalar way.
        """
        t, truth_t, arrival, now = inputs["t"], inputs["truth_t"], inputs["arrival"], inputs["now"]
        n, m = t.size, truth_t.size
        bounds = self.config.bounds
        clock, stamps = self._clock, self._stamps
        if clock.suspect_s is not None or any(check.jumps.suspect_s is not None for check in stamps.values()):
            return None
        counters = dict.fromkeys(COUNTER_NAMES, 0)
        # The node clock: every reading on the timeline (never back, never a forward jump), so each is "now".
        if now is not None:
            now = np.asarray(now, float)
            if not np.all(np.isfinite(now)) or np.any(np.diff(now) < 0.0):
                return None
            first = clock.latest_s
            if first is not None and not (first - clock.threshold_s <= now[0] <= first + clock.forward_threshold_s):
                return None
            if np.any(np.diff(now) > clock.forward_threshold_s):
                return None
            clock_now = now if first is None else np.maximum(now, first)
        truth_now = None if now is None else now[np.minimum(arrival, n - 1)]

        def stamps_clean(check, stamp, clock_at):
            """Whether ``check`` accepts every one of the increasing ``stamp`` as it stands, with no jump."""
            if stamp.size == 0:
                return True
            if not np.all(np.isfinite(stamp)) or np.any(stamp <= 0.0):
                return False
            if clock_at is not None and np.any(stamp > clock_at + check.future_tolerance_s):
                return False
            steps = np.diff(stamp)
            if np.any(steps <= 0.0) or np.any(steps < check.min_interval_s):
                return False
            latest = check.jumps.latest_s
            return latest is None or (stamp[0] > latest and stamp[0] - latest >= check.min_interval_s)

        # Truth: the quaternion check on each (exactly as check_quaternion), then the stamps of the good ones.
        q = inputs["q"]
        q_finite = np.all(np.isfinite(q), axis=0)
        norms = np.array([math.hypot(*c) if ok else math.nan for c, ok in zip(q.T.tolist(), q_finite.tolist())])
        truth_ok = q_finite & (np.abs(norms - 1.0) <= QUATERNION_NORM_TOLERANCE)
        counters["truth_received"] = m
        counters[f"rejected_truth_{Rejection.NON_FINITE.value}"] = int(m - np.count_nonzero(q_finite))
        counters[f"rejected_truth_{Rejection.BAD_QUATERNION.value}"] = int(np.count_nonzero(q_finite & ~truth_ok))
        counters["truth_quaternions_normalised"] = int(np.count_nonzero(
            truth_ok & (np.abs(norms - 1.0) > UNIT_ROUNDING)))
        if not stamps_clean(stamps["truth"], truth_t[truth_ok], None if now is None else truth_now[truth_ok]):
            return None
        q_ok = np.full((4, m), math.nan)
        q_ok[:, truth_ok] = q[:, truth_ok] / norms[truth_ok]
        # Odometry at each sensor stamp: plausible states (with a margin on every bound; a state near one
        # goes the scalar way), then the stamps.
        odometry = inputs["odometry"]
        odometry_ok = np.zeros(n, bool)
        if odometry is not None:
            position, velocity = odometry
            if not (np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))):
                return None
            radius = np.sqrt(np.sum(position * position, axis=0))
            speed = np.sqrt(np.sum(velocity * velocity, axis=0))
            margin = 1.0 + 1e-9
            plausible = ((bounds.min_orbit_radius_m * margin < radius) & (radius * margin < bounds.max_orbit_radius_m)
                         & (bounds.min_orbit_speed_m_s * margin < speed) & (speed * margin < bounds.max_orbit_speed_m_s)
                         & (0.5 * speed * speed * margin < GM_EARTH_M3_S2 / radius))
            if not np.all(plausible) or not stamps_clean(stamps["odometry"], t, now):
                return None
            counters["odometry_received"] = n
            odometry_ok[:] = True
        # Sensor: the angle check (NaN passes: a lost pair), then the stamps of the good ones.
        roll, pitch = inputs["roll"], inputs["pitch"]
        limit = bounds.max_abs_angle_rad  # check_angles looks at roll first, then pitch
        roll_infinite, roll_large = np.isinf(roll), ~np.isinf(roll) & (np.abs(roll) > limit)
        pitch_infinite, pitch_large = np.isinf(pitch), ~np.isinf(pitch) & (np.abs(pitch) > limit)
        roll_fine = ~roll_infinite & ~roll_large
        infinite = roll_infinite | (roll_fine & pitch_infinite)
        too_large = roll_large | (roll_fine & pitch_large)
        sensor_ok = ~infinite & ~too_large
        if not stamps_clean(stamps["sensor"], t[sensor_ok], None if now is None else now[sensor_ok]):
            return None
        sensor_code = np.full(n, PENDING_CODE, np.int8)
        sensor_code[infinite] = BATCH_STATUSES.index(Rejection.NON_FINITE)
        sensor_code[too_large] = BATCH_STATUSES.index(Rejection.IMPLAUSIBLE_ANGLE)
        counters["sensor_received"] = n
        counters[f"rejected_sensor_{Rejection.NON_FINITE.value}"] = int(np.count_nonzero(infinite))
        counters[f"rejected_sensor_{Rejection.IMPLAUSIBLE_ANGLE.value}"] = int(np.count_nonzero(too_large))
        # Events in arrival order: before sensor sample i, the truth samples arriving at i.
        sensor_event = np.arange(n) + np.searchsorted(arrival, np.arange(n), side="right")
        truth_event = np.arange(m) + arrival
        # What _expire compares with after each event: the newest accepted sensor stamp or the clock.
        newest = stamps["sensor"].latest_s
        accepted = np.where(sensor_ok, t, -math.inf)
        newest_after = np.maximum.accumulate(accepted) if n else accepted
        if newest is not None:
            newest_after = np.maximum(newest_after, newest)
        before = np.concatenate([[-math.inf if newest is None else newest], newest_after])  # before sample i
        expiry_clock = np.empty(n + m)
        expiry_clock[sensor_event] = newest_after
        expiry_clock[truth_event] = before[arrival]
        if now is not None:
            expiry_clock[sensor_event] = np.maximum(expiry_clock[sensor_event], clock_now)
            expiry_clock[truth_event] = np.maximum(expiry_clock[truth_event], clock_now[np.minimum(arrival, n - 1)])
        # The state after the batch, on copies, as the scalar scan leaves it.
        stamps = {stream: copy.deepcopy(check) for stream, check in stamps.items()}
        for stream, good in (("truth", truth_t[truth_ok]), ("sensor", t[sensor_ok]),
                             ("odometry", t if odometry is not None else t[:0])):
            if good.size:
                stamps[stream].jumps.latest_s = float(good[-1])
        clock = copy.deepcopy(clock)
        if now is not None and n:
            clock.latest_s = float(clock_now[-1])
        return dict(stamps=stamps, clock=clock, counters=counters, sensor_code=sensor_code,
                    sensor_event=sensor_event, truth_event=truth_event[truth_ok], truth_t=truth_t[truth_ok],
                    q_truth=q_ok[:, truth_ok], expiry_clock=expiry_clock, odometry_ok=odometry_ok)

    def _scan_batch(self, inputs):
        """Validate a batch in arrival order on copies of the stamp and clock state; None if the array form
        cannot follow it (a jump, an outlier, an unconfirmed stamp)."""
        stamps = {stream: copy.deepcopy(check) for stream, check in self._stamps.items()}
        clock = copy.deepcopy(self._clock)
        counters = dict.fromkeys(COUNTER_NAMES, 0)
        t, truth_t, arrival, now = inputs["t"], inputs["truth_t"], inputs["arrival"], inputs["now"]
        n, m = t.size, truth_t.size
        sensor_code = np.full(n, PENDING_CODE, np.int8)
        sensor_event = np.empty(n, np.int64)
        truth_event = np.empty(m, np.int64)
        truth_ok = np.zeros(m, bool)
        odometry_ok = np.zeros(n, bool)
        q_ok = np.empty((4, m))
        expiry_clock = []  # what _expire compares with after each event
        bounds = self.config.bounds
        t_list, roll_list, pitch_list = t.tolist(), inputs["roll"].tolist(), inputs["pitch"].tolist()
        truth_list, q_list, arrival_list = truth_t.tolist(), inputs["q"].T.tolist(), arrival.tolist()
        now_list = None if now is None else now.tolist()
        odometry = inputs["odometry"]
        states = None if odometry is None else list(zip(odometry[0].T.tolist(), odometry[1].T.tolist()))
        sensor_check, truth_check, odometry_check = stamps["sensor"], stamps["truth"], stamps["odometry"]

        def observe(value):
            if value is None or not math.isfinite(value):
                return True, None
            return clock.observe(value) is Jump.NONE, clock.latest_s

        def expiry(clock_s):
            latest = sensor_check.latest_s
            if clock_s is not None:
                latest = clock_s if latest is None else max(latest, clock_s)
            return -math.inf if latest is None else latest

        def stamp_verdict(check, stamp, now_i):
            outliers = check.outliers
            rejection, jumped = check.check(stamp, now_i)
            steady = not jumped and check.outliers == outliers and rejection is not Rejection.UNCONFIRMED_JUMP
            return steady, rejection

        j = event = 0
        for i in range(n + 1):
            now_i = None if now_list is None else now_list[min(i, n - 1)]
            while j < m and arrival_list[j] == i:
                counters["truth_received"] += 1
                steady, clock_s = observe(now_i)
                if not steady:
                    return None
                unit, rejection, normalised = check_quaternion(q_list[j])
                if rejection is None:
                    counters["truth_quaternions_normalised"] += normalised
                    steady, rejection = stamp_verdict(truth_check, truth_list[j], now_i)
                    if not steady:
                        return None
                if rejection is not None:
                    counters[f"rejected_truth_{rejection.value}"] += 1
                else:
                    truth_ok[j] = True
                    q_ok[:, j] = unit
                truth_event[j] = event
                expiry_clock.append(expiry(clock_s))
                event += 1
                j += 1
            if i == n:
                break
            if states is not None:  # add_odometry: the clock is observed, nothing expires
                counters["odometry_received"] += 1
                steady, _ = observe(now_i)
                if not steady:
                    return None
                rejection = check_orbit_state(*states[i], bounds)
                if rejection is None:
                    steady, rejection = stamp_verdict(odometry_check, t_list[i], now_i)
                    if not steady:
                        return None
                if rejection is not None:
                    counters[f"rejected_odometry_{rejection.value}"] += 1
                else:
                    odometry_ok[i] = True
            counters["sensor_received"] += 1
            steady, clock_s = observe(now_i)
            if not steady:
                return None
            rejection = check_angles(roll_list[i], pitch_list[i], bounds.max_abs_angle_rad, allow_nan=True)
            if rejection is None:
                steady, rejection = stamp_verdict(sensor_check, t_list[i], now_i)
                if not steady:
                    return None
            if rejection is not None:
                counters[f"rejected_sensor_{rejection.value}"] += 1
                sensor_code[i] = BATCH_STATUSES.index(rejection)
            sensor_event[i] = event
            expiry_clock.append(expiry(clock_s))
            event += 1
        return dict(stamps=stamps, clock=clock, counters=counters, sensor_code=sensor_code,
                    sensor_event=sensor_event, truth_event=truth_event[truth_ok], truth_t=truth_t[truth_ok],
                    q_truth=q_ok[:, truth_ok], expiry_clock=np.array(expiry_clock), odometry_ok=odometry_ok)

    def _batch_orbit(self, inputs, scan):
        """Per sensor sample: (u, inclination, altitude) as add_sensor takes them (NaN: none), and the
        orbit record the monitor keeps after the batch."""
        t, config = inputs["t"], self.config
        n = t.size
        if inputs["odometry"] is None:
            u = np.full(n, np.nan) if inputs["u"] is None else np.broadcast_to(np.asarray(inputs["u"], float), (n,))
            altitude = config.altitude_m if inputs["altitude"] is None else inputs["altitude"]
            inclination = config.inclination_rad if inputs["inclination"] is None else inputs["inclination"]
            return (u, np.full(n, np.nan if inclination is None else float(inclination)),
                    np.full(n, np.nan if altitude is None else float(altitude)), self._orbit)
        # orbit_at: the latest accepted odometry no further than max_age from the stamp, u advanced at its rate.
        ok = scan["odometry_ok"]
        records = _orbit_records(t[ok], inputs["odometry"][0][:, ok], inputs["odometry"][1][:, ok])
        if self._orbit is not None:
            records = np.c_[np.asarray(self._orbit, float)[:, None], records]
        latest = np.cumsum(ok) - 1 + (self._orbit is not None)  # index of the latest record at each sample
        have = latest >= 0
        stamp, u0, inclination0, altitude0, rate = (np.r_[column, np.nan][np.where(have, latest, -1)]
                                                    for column in records)
        fresh = have & (np.abs(t - stamp) <= inputs["max_age"])
        u = np.where(fresh, u0 + rate * (t - stamp), np.nan)
        inclination = np.where(fresh, inclination0, np.nan if config.inclination_rad is None else config.inclination_rad)
        altitude = np.where(fresh, altitude0, np.nan if config.altitude_m is None else config.altitude_m)
        orbit = self._orbit if not records.shape[1] else tuple(float(c) for c in records[:, -1])
        return u, inclination, altitude, orbit

    def _plan_batch(self, inputs, scan):
        """The alignment of a validated batch on arrays; None where the per-sample path could differ."""
        config = self.config
        t, roll, pitch = inputs["t"], inputs["roll"], inputs["pitch"]
        code = scan["sensor_code"]
        accepted = code == PENDING_CODE
        no_angle = accepted & np.isnan(roll) & np.isnan(pitch)
        valid = np.flatnonzero(accepted & ~no_angle)
        # Truth: what the buffer holds (arrived before the batch), then the batch's accepted samples.
        prior = len(self._truth_t)
        truth_t = np.r_[np.asarray(self._truth_t, float), scan["truth_t"]]
        if scan["truth_t"].size:
            new_roll, new_pitch = true_roll_pitch(scan["q_truth"])
        else:
            new_roll = new_pitch = np.empty(0)
        truth_roll = np.r_[np.asarray(self._truth_roll, float), np.atleast_1d(new_roll)]
        truth_pitch = np.r_[np.asarray(self._truth_pitch, float), np.atleast_1d(new_pitch)]
        truth_event = np.r_[np.full(prior, -1, np.int64), scan["truth_event"]]
        clocks = scan["expiry_clock"]
        events = clocks.size
        stamp = t[valid]
        arrive = scan["sensor_event"][valid]
        hi = np.searchsorted(truth_t, stamp, side="left")  # the first truth at or after each stamp
        have = hi < truth_t.size
        cover_event = np.where(have, np.r_[truth_event, 0][hi], events)
        at_once = have & (cover_event < arrive)
        # Given up: the first event from its arrival on whose clock is more than max_truth_wait_s past it.
        expire = np.maximum(_first_expired(clocks, stamp, config.max_truth_wait_s), arrive)
        stale = ~at_once & (expire < cover_event)
        aligned = ~stale & have
        waiting = ~at_once & ~stale & ~have
        settle = np.where(at_once, arrive, np.where(stale, expire, np.where(have, cover_event, events)))
        # The pending queue (samples not aligned on arrival) must never overflow.
        queued = ~at_once
        queued_settle = settle[queued]
        if queued_settle.size:
            if np.any(np.diff(queued_settle) < 0):
                return None
            length = np.arange(1, queued_settle.size + 1) - np.searchsorted(queued_settle, arrive[queued], "left")
            if length.max() > config.max_pending:
                return None
        # The bracketing truth must still be in the buffer when the sample is aligned (history, capacity).
        lo = hi - 1
        arrived = np.where(at_once, np.searchsorted(truth_event, arrive, side="left"),
                           np.minimum(hi + 1, truth_t.size))
        floor = arrived - config.truth_capacity - np.where(at_once, 0, 1)
        latest = truth_t[np.maximum(arrived - 1, 0)] if truth_t.size else np.zeros(stamp.size)
        kept_from = np.searchsorted(truth_t, latest - config.truth_history_s, side="right") - 1
        first = aligned & (hi == 0)
        if np.any(aligned & (hi > 0) & ((lo < floor) | (at_once & (lo < kept_from)))):
            return None
        if np.any(first & ((floor > 0) | (kept_from > 0))):
            return None
        exact = aligned & (np.r_[truth_t, np.nan][hi] == stamp)
        no_truth = aligned & ~exact & (hi == 0)
        span = np.r_[truth_t, np.nan][hi] - np.r_[np.nan, truth_t][hi]
        gap = aligned & ~exact & ~no_truth & (span > config.max_truth_gap_s)
        used = aligned & ~no_truth & ~gap
        # Truth at each used stamp: the sample itself, or linear between the bracketing samples.
        k = np.flatnonzero(used)
        h, low, hit = hi[k], np.maximum(hi[k] - 1, 0), exact[k]
        weight = (stamp[k] - truth_t[low]) / np.where(hit, 1.0, truth_t[h] - truth_t[low])
        at_roll = np.where(hit, truth_roll[h], truth_roll[low] + weight * (truth_roll[h] - truth_roll[low]))
        at_pitch = np.where(hit, truth_pitch[h], truth_pitch[low] + weight * (truth_pitch[h] - truth_pitch[low]))
        # The oblateness model and the altitude, as add_sensor takes them.
        u, inclination, altitude, orbit = self._batch_orbit(inputs, scan)
        if inputs["model"] is not None:
            model_roll, model_pitch = (np.broadcast_to(np.asarray(part, float), t.shape) for part in inputs["model"])
        else:
            model_roll, model_pitch = np.full(t.shape, np.nan), np.full(t.shape, np.nan)
            known = np.isfinite(u) & np.isfinite(inclination) & (altitude > 0.0) & np.isfinite(altitude)
            if known.any():
                _, model_roll[known], model_pitch[known] = closed_form_oblateness(u[known], altitude[known],
                                                                                  inclination[known])
        rows = valid[k]
        return dict(no_angle=np.flatnonzero(no_angle), stale=valid[stale], waiting=valid[waiting],
                    no_truth=valid[no_truth], gap=valid[gap], used=rows,
                    residual_roll=roll[rows] - at_roll, residual_pitch=pitch[rows] - at_pitch,
                    model_roll=model_roll, model_pitch=model_pitch, altitude=altitude, orbit=orbit,
                    truth=(truth_t, truth_roll, truth_pitch), roll=roll, pitch=pitch)

    def _apply_batch(self, t, scan, plan) -> "BatchOutcome":
        """Commit a planned batch: stamps, counters, statistics, ring, truth buffer, orbit and pending queue."""
        config = self.config
        self._stamps, self._clock, self._orbit = scan["stamps"], scan["clock"], plan["orbit"]
        counters = self._counters
        for name, value in scan["counters"].items():
            counters[name] += value
        result = BatchOutcome.empty(t.size)
        result.status[:] = scan["sensor_code"]
        for rows, status in ((plan["no_angle"], Status.NO_VALID_ANGLE), (plan["stale"], Status.STALE_TRUTH),
                             (plan["gap"], Status.TRUTH_GAP),
                             (plan["no_truth"], Status.TOO_OLD if self._truth_pruned else Status.NO_TRUTH)):
            result.status[rows] = BATCH_STATUSES.index(status)
            counters[f"skipped_{status.value}"] += int(rows.size)
        rows = plan["used"]
        result.status[rows] = BATCH_STATUSES.index(Status.OK)
        residual_roll, residual_pitch = plan["residual_roll"], plan["residual_pitch"]
        counters["used"] += int(rows.size)
        counters["used_one_angle"] += int(np.count_nonzero(np.isnan(residual_roll) | np.isnan(residual_pitch)))
        # _account on arrays.
        roll_kept = residual_roll - config.roll_offset_rad
        pitch_kept = residual_pitch - config.pitch_offset_rad
        kept = (roll_kept, pitch_kept, np.hypot(roll_kept, pitch_kept))
        model_roll, model_pitch = plan["model_roll"][rows], plan["model_pitch"][rows]
        has_model = np.isfinite(model_roll) & np.isfinite(model_pitch)
        counters["used_without_oblateness_model"] += int(np.count_nonzero(~has_model))
        roll_removed = np.where(has_model, roll_kept - model_roll, np.nan)
        pitch_removed = np.where(has_model, pitch_kept - model_pitch, np.nan)
        removed = (roll_removed, pitch_removed, np.hypot(roll_removed, pitch_removed))
        altitude = plan["altitude"][rows]
        with_ground = np.isfinite(altitude) & (altitude > 0.0)
        for key, columns in ((False, kept), (True, removed)):
            target = self._sets[key]
            for stats, values in zip(target.angles, columns):
                stats.update(values[np.isfinite(values)])
            if with_ground.any():
                grounds = _ground_arrays(tuple(c[with_ground] for c in columns), altitude[with_ground])
                for stats, values in zip(target.ground, grounds):
                    stats.update(values[np.isfinite(values)])
        self._ring.add_many(t[rows], np.column_stack(removed + kept))
        primary = removed if config.remove_oblateness else kept
        result.residual_roll_rad[rows], result.residual_pitch_rad[rows] = residual_roll, residual_pitch
        result.roll_rad[rows], result.pitch_rad[rows], result.meridional_rad[rows] = primary
        # What stays for the next call: the truth buffer (pruned as the per-sample path prunes) and the queue.
        truth_t, truth_roll, truth_pitch = plan["truth"]
        self._truth_t[:], self._truth_roll[:], self._truth_pitch[:] = (truth_t.tolist(), truth_roll.tolist(),
                                                                       truth_pitch.tolist())
        roll, pitch = plan["roll"], plan["pitch"]
        for i in plan["waiting"].tolist():
            self._pending.append(_Pending(float(t[i]), float(roll[i]), float(pitch[i]), float(plan["model_roll"][i]),
                                          float(plan["model_pitch"][i]), float(plan["altitude"][i])))
        if self._truth_t:
            self._prune_truth()
        return result

    # ---------------------------------------------------------------- summary

    def summary(self, oblateness_removed: bool | None = None) -> MonitorSummary:
        """The statistics for publication (default: the configured oblateness choice) and the counters.

        Harmonic amplitudes are fitted here (a few ms for the default ring),
        so call it at the publication rate, not per sample.
        """
        removed = self.config.remove_oblateness if oblateness_removed is None else bool(oblateness_removed)
        amplitudes = self._ring.amplitudes(self.config.harmonics,
                                           max_gap_fraction=self.config.max_harmonic_gap_fraction,
                                           max_condition=DEFAULT_MAX_CONDITION)
        first_column = 0 if removed else len(CHANNELS)
        channels = []
        for index, name in enumerate(CHANNELS):
            angle = self._sets[removed].angles[index]
            ground = self._sets[removed].ground[index]
            harmonics = {int(k): float(a) for k, a in zip(self.config.harmonics, amplitudes[:, first_column + index])}
            channels.append(ChannelStatistics(name, angle.count, angle.mean, angle.sigma, angle.max_abs, harmonics,
                                               ground.mean, ground.sigma, ground.max_abs))
        return MonitorSummary(removed, tuple(channels), self.counters, self._ring.full_orbit)
