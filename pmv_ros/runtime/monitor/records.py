"""The error monitor's records and configuration: statuses, counters, outcomes, summaries, batch outcomes.

What :class:`pmv_ros.runtime.monitor.core.ErrorMonitor` takes and gives, in one
place for the monitor, its scan and alignment, its node and the campaign.
"""


from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from ...physics.ground_error import nadir_ground_error
from ...physics.orbit.two_body import CircularOrbit, orbit_angles_from_state
from ..common.validation import (
    STAMP_REJECTIONS,
    TRUTH_REJECTIONS,
    InputBounds,
    Rejection,
)
from ...analysis.statistics import (
    CHANNELS,
    ChannelStatistics,
    MAX_NOISE_GAIN,
    ORBIT_HARMONICS,
    RunningStatistics,
)



class Status(str, Enum):
    """What became of a valid sensor sample: ``ok`` or why it could not be aligned (the value is the counter name).

    A sample rejected by validation has a :class:`~pmv_ros.runtime.common.validation.Rejection` instead.
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
    IMPLAUSIBLE_RESIDUAL = "implausible_residual"  # sensor − truth beyond validation.MAX_PLAUSIBLE_RESIDUAL_RAD


#: Reasons a valid sensor sample could not be aligned with truth.
SKIP_REASONS = (Status.NO_VALID_ANGLE, Status.NO_TRUTH, Status.TOO_OLD, Status.TRUTH_GAP, Status.STALE_TRUTH,
                Status.PENDING_OVERFLOW, Status.RESET, Status.IMPLAUSIBLE_RESIDUAL)

#: Reasons an incoming sample is rejected, per stream.
SENSOR_REJECTIONS = STAMP_REJECTIONS + (Rejection.IMPLAUSIBLE_ANGLE,)
ODOMETRY_REJECTIONS = STAMP_REJECTIONS + (Rejection.IMPLAUSIBLE_ORBIT,)


def _empty(*shape, dtype=float):
    """A field that defaults to one shared, read-only empty array."""
    array = np.empty(shape, dtype)
    array.flags.writeable = False
    return field(default_factory=lambda: array)


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
        max_harmonic_noise_gain: the largest noise gain the last orbit's gaps may give a harmonic that is reported
            (:func:`~pmv_ros.analysis.statistics.fit_harmonics`; above it the harmonic is pending).
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
    max_harmonic_noise_gain: float = MAX_NOISE_GAIN
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
        _positive("max_harmonic_noise_gain", self.max_harmonic_noise_gain, 1.0 - 1e-12, 1e6)
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
    :class:`~pmv_ros.runtime.common.validation.Rejection` of an invalid sample.
    ``residual_*`` is sensor − truth, as published on /pmv/residual.
    ``roll_rad``/``pitch_rad``/``meridional_rad`` are the residuals that went
    into the reported statistics (offsets removed, oblateness model removed
    when configured); ``altitude_m`` the altitude they are seen from (NaN:
    unknown, no ground error). All NaN unless ``status`` is OK.
    """

    stamp_s: float
    status: Status | Rejection
    residual_roll_rad: float = math.nan
    residual_pitch_rad: float = math.nan
    roll_rad: float = math.nan
    pitch_rad: float = math.nan
    meridional_rad: float = math.nan
    altitude_m: float = math.nan

    @property
    def ok(self) -> bool:
        """True when the sample was aligned and used."""
        return self.status is Status.OK

    @property
    def ground_m(self) -> tuple[float, float, float]:
        """(cross-track, along-track, circular) ground error of a nadir imager, m (physics.md §7)."""
        return tuple(float(value) for value in
                     ground_components((self.roll_rad, self.pitch_rad, self.meridional_rad), self.altitude_m))

    @property
    def cross_track_m(self) -> float:
        return self.ground_m[0]

    @property
    def along_track_m(self) -> float:
        return self.ground_m[1]

    @property
    def circular_m(self) -> float:
        return self.ground_m[2]


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


#: The kinds of event in a :class:`Feed`'s ``order``.
TRUTH_EVENT, ODOMETRY_EVENT, SENSOR_EVENT, POLL_EVENT = range(4)


@dataclass
class Feed:
    """One input of :class:`ErrorMonitor`, in arrival order: sensor samples, truth, odometry, a poll.

    Before sensor sample i arrive the truth samples with ``truth_arrival == i``, then the odometry with
    ``odometry_arrival == i``; index N means after the last sample, and a poll (``poll_now_s``) comes last —
    unless ``order`` lists the events ``(kind, index)`` in arrival order itself (a node's messages: truth and
    odometry interleaved as they came). Times s, angles rad, ECI states m and m/s; ``*_now_s`` is the node clock
    at each arrival (None: none; an element None: none for that one). Columns are arrays, or — a node's few
    messages, which go event by event — lists, ``truth`` then a list of per-sample tuples and the odometry's
    states lists of 3-tuples.
    """

    t_s: np.ndarray
    roll_rad: np.ndarray
    pitch_rad: np.ndarray
    sensor_now_s: np.ndarray | None = None
    truth_t_s: np.ndarray = _empty(0)
    truth: np.ndarray = _empty(4, 0)               #: (4, M) quaternions x, y, z, w, or (2, M) roll and pitch
    truth_arrival: np.ndarray = _empty(0, dtype=np.int64)
    truth_now_s: np.ndarray | None = None
    odometry_t_s: np.ndarray = _empty(0)
    odometry_position_m: np.ndarray = _empty(3, 0)
    odometry_velocity_m_s: np.ndarray = _empty(3, 0)
    odometry_arrival: np.ndarray = _empty(0, dtype=np.int64)
    odometry_now_s: np.ndarray | None = None
    #: The sensor's orbit: from the odometry no older than this (s), or (None) from the columns below.
    odometry_max_age_s: float | None = None
    u_rad: np.ndarray | None = None           #: (N,) argument of latitude, NaN: unknown
    inclination_rad: np.ndarray | None = None
    altitude_m: np.ndarray | None = None
    model_roll_rad: np.ndarray | None = None  #: (N,) the oblateness model itself (None: from the orbit)
    model_pitch_rad: np.ndarray | None = None
    poll_now_s: float | None = None
    order: list | None = None  #: ``(kind, index)`` per event in arrival order (kinds: the scan's), or None


class StatisticsSet:
    """Running statistics of roll, pitch, meridional and their ground errors."""

    def __init__(self) -> None:
        self.angles = [RunningStatistics() for _ in CHANNELS]
        self.ground = [RunningStatistics() for _ in CHANNELS]

    def reset(self) -> None:
        for stats in self.angles + self.ground:
            stats.reset()


def ground_components(row, altitude_m):
    """(cross-track, along-track, circular) ground error, m, of (roll, pitch, meridional) residuals (rad) seen
    from ``altitude_m`` — floats or arrays.

    Cross-track goes with roll, along-track with pitch, circular with
    meridional; a lost angle gives NaN in its own component (and in the
    circular one) only; an unknown altitude (NaN, not positive) NaN in all.
    """
    roll, pitch, meridional = (np.asarray(value, float) for value in row)
    altitude = np.asarray(altitude_m, float)
    lost_roll, lost_pitch = np.isnan(roll), np.isnan(pitch)
    with np.errstate(invalid="ignore"):
        altitude = np.where(np.isfinite(altitude) & (altitude > 0.0), altitude, np.nan)
        error = nadir_ground_error(np.where(lost_roll, 0.0, roll), np.where(lost_pitch, 0.0, pitch), altitude)
    return (np.where(lost_roll, np.nan, error.cross_track_m), np.where(lost_pitch, np.nan, error.along_track_m),
            np.where(np.isnan(meridional), np.nan, error.circular_m))


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
    earlier: list = field(default_factory=list)  #: :class:`Outcome` of samples of earlier inputs it settled

    @classmethod
    def empty(cls, n: int) -> "BatchOutcome":
        """N samples, all pending."""
        return cls(np.full(n, PENDING_CODE, np.int8), *(np.full(n, np.nan) for _ in range(5)))


def orbit_record(t_s: float, position_eci_m, velocity_eci_m_s) -> tuple:
    """What the monitor keeps of an accepted odometry state: (stamp_s, u_rad, inclination_rad, altitude_m,
    mean motion rad/s) — the orbit of :meth:`ErrorMonitor.orbit_at`."""
    u, inclination, altitude = orbit_angles_from_state(position_eci_m, velocity_eci_m_s)
    (rx, ry, rz), (vx, vy, vz) = position_eci_m, velocity_eci_m_s
    radius, speed = math.hypot(float(rx), float(ry), float(rz)), math.hypot(float(vx), float(vy), float(vz))
    return (t_s, float(u), float(inclination), float(altitude), speed / radius)
