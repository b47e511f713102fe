"""Typed domain records of the PMV topics (interfaces.md), independent of any message package.

Records hold SI units and radians; arc minutes appear only on the wire of
/pmv/error_statistics, which is meant for people (see :mod:`.conversions`).
Records are frozen; array fields are stored as read-only numpy copies, so
compare them with ``numpy.array_equal``/``allclose``, not ``==``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from pmv_ros.analysis.statistics import ChannelStatistics
from pmv_ros.runtime.common.frames import DEFAULT_FRAMES
from pmv_ros.runtime.common.records import Level

#: The default frame ids (interfaces.md "Frames"; their one home is :mod:`pmv_ros.runtime.common.frames`):
#: record defaults and a reader's expectations. A node stamps with its own ``frames.*`` parameters.
SENSOR_FRAME = DEFAULT_FRAMES.sensor
ORBITAL_FRAME = DEFAULT_FRAMES.orbital
ECI_FRAME = DEFAULT_FRAMES.eci
BODY_FRAME = DEFAULT_FRAMES.base_link


#: Tolerance on |line of sight| − 1 for a valid chord (float32 on the wire gives ~1e-7).
UNIT_VECTOR_TOLERANCE = 1e-4


def check_stamp(stamp_s: float) -> float:
    """The stamp as a float; ValueError unless it is finite and ≥ 0 (what every record requires)."""
    stamp = float(stamp_s)
    if not (math.isfinite(stamp) and stamp >= 0.0):
        raise ValueError(f"stamp_s = {stamp_s} must be finite and ≥ 0")
    return stamp


def _frozen_array(values, shape, name, dtype=float) -> np.ndarray:
    array = np.array(values, dtype=dtype)
    if array.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {array.shape}")
    array.flags.writeable = False
    return array


def checked_lines_of_sight(line_of_sight, valid) -> np.ndarray:
    """Lines of sight as :class:`HorizonCrossings` holds them, for one scan or a block of scans.

    Args:
        line_of_sight: ``(..., 4, 3)`` vectors, chords +X, +Y, −X, −Y.
        valid: ``(..., 4)`` bools: the chord saw a horizon.

    Returns:
        A new float array of the same shape with the rows of invalid chords
        set to NaN; ValueError if a valid row is not a unit vector.
    """
    vectors = np.array(line_of_sight, dtype=float)
    valid = np.asarray(valid, bool)
    if vectors.shape[-2:] != (4, 3) or valid.shape != vectors.shape[:-1]:
        raise ValueError(f"line_of_sight must have shape (..., 4, 3) and valid (..., 4), "
                         f"got {vectors.shape} and {valid.shape}")
    vectors[~valid] = np.nan
    norms = np.linalg.norm(vectors[valid], axis=-1)
    if not np.all(np.abs(norms - 1.0) <= UNIT_VECTOR_TOLERANCE):
        raise ValueError(f"valid lines of sight must be unit vectors, got norms {norms}")
    return vectors


@dataclass(frozen=True, eq=False)
class HorizonCrossings:
    """Lines of sight to the horizon crossings of the 4 chords (/pmv/horizon_crossings).

    Args:
        stamp_s: time of the scan, s.
        frame_id: frame of the vectors (the sensor frame).
        line_of_sight: ``(4, 3)`` unit vectors, chords +X, +Y, −X, −Y; rows of
            invalid chords are set to NaN.
        valid: ``(4,)`` bools: the chord saw a horizon.
    """

    stamp_s: float
    frame_id: str = SENSOR_FRAME
    line_of_sight: np.ndarray = field(default_factory=lambda: np.full((4, 3), np.nan))
    valid: np.ndarray = field(default_factory=lambda: np.zeros(4, bool))

    def __post_init__(self) -> None:
        object.__setattr__(self, "stamp_s", check_stamp(self.stamp_s))
        valid = _frozen_array(self.valid, (4,), "valid", bool)
        vectors = np.array(self.line_of_sight, dtype=float)
        if vectors.shape != (4, 3):
            raise ValueError(f"line_of_sight must have shape (4, 3), got {vectors.shape}")
        vectors = checked_lines_of_sight(vectors, valid)
        vectors.flags.writeable = False
        object.__setattr__(self, "valid", valid)
        object.__setattr__(self, "line_of_sight", vectors)


@dataclass(frozen=True)
class AttitudeAngles:
    """Roll and pitch of the sensor axis from the local vertical, rad (/pmv/attitude, /pmv/residual).

    Signs: :mod:`pmv_ros.physics.attitude`. For /pmv/residual the angles are sensor minus star tracker.
    """

    stamp_s: float
    frame_id: str = SENSOR_FRAME
    roll_rad: float = 0.0
    pitch_rad: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "stamp_s", check_stamp(self.stamp_s))
        object.__setattr__(self, "roll_rad", float(self.roll_rad))
        object.__setattr__(self, "pitch_rad", float(self.pitch_rad))


@dataclass(frozen=True, eq=False)
class AttitudeQuaternion:
    """Orientation of the body in the frame ``frame_id`` (the orbital frame), (x, y, z, w).

    For /attitude/truth and /star_tracker/attitude. Not normalised here: a
    consumer validates it (the monitor counts and rejects bad ones).
    """

    stamp_s: float
    frame_id: str = ORBITAL_FRAME
    q_xyzw: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0]))

    def __post_init__(self) -> None:
        object.__setattr__(self, "stamp_s", check_stamp(self.stamp_s))
        object.__setattr__(self, "q_xyzw", _frozen_array(self.q_xyzw, (4,), "q_xyzw"))


@dataclass(frozen=True, eq=False)
class OrbitState:
    """Spacecraft position (m) and velocity (m/s), both in ``frame_id`` (ECI) (/orbit/odometry).

    On the wire (nav_msgs' rules, :func:`pmv_msgs_shim.write_orbit_state`):
    the pose is the position in ``frame_id`` with the orientation of the
    orbital frame (``child_frame_id``), the twist is the velocity expressed
    in the orbital frame. The record holds the velocity in ``frame_id``.
    """

    stamp_s: float
    frame_id: str = ECI_FRAME
    child_frame_id: str = ORBITAL_FRAME
    position_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    velocity_m_s: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        object.__setattr__(self, "stamp_s", check_stamp(self.stamp_s))
        object.__setattr__(self, "position_m", _frozen_array(self.position_m, (3,), "position_m"))
        object.__setattr__(self, "velocity_m_s", _frozen_array(self.velocity_m_s, (3,), "velocity_m_s"))


@dataclass(frozen=True)
class ErrorStatistics:
    """The content of /pmv/error_statistics: one channel record
    (:class:`pmv_ros.analysis.statistics.ChannelStatistics`) per channel plus sample counters.

    ``counters`` are the monitor's counts by name (samples used, skipped per
    reason, rejected per stream and reason, ...).
    """

    stamp_s: float
    channels: tuple = ()
    counters: Mapping[str, int] = field(default_factory=dict)
    oblateness_removed: bool = True
    hardware_id: str = "pmv"

    def __post_init__(self) -> None:
        object.__setattr__(self, "stamp_s", check_stamp(self.stamp_s))
        channels = tuple(self.channels)
        names = [c.channel for c in channels]
        if len(set(names)) != len(names):
            raise ValueError(f"channels must be distinct, got {names}")
        object.__setattr__(self, "channels", channels)
        object.__setattr__(self, "counters", {str(k): int(v) for k, v in dict(self.counters).items()})
        object.__setattr__(self, "oblateness_removed", bool(self.oblateness_removed))

    def channel(self, name: str) -> ChannelStatistics:
        """The statistics of channel ``name``."""
        for statistics in self.channels:
            if statistics.channel == name:
                return statistics
        raise KeyError(name)

    @classmethod
    def from_summary(cls, summary, stamp_s: float, hardware_id: str = "pmv") -> "ErrorStatistics":
        """Build from a monitor summary (:class:`pmv_ros.runtime.monitor.core.MonitorSummary`)."""
        return cls(stamp_s, summary.channels, summary.counters, summary.oblateness_removed, hardware_id)


@dataclass(frozen=True)
class HealthStatus:
    """One health status for /diagnostics (a diagnostic_msgs/DiagnosticStatus).

    ``values`` are (key, value) string pairs, order kept; a mapping is accepted.
    """

    name: str
    level: Level = Level.OK
    message: str = ""
    hardware_id: str = "pmv"
    values: tuple = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "level", Level(self.level))
        pairs = self.values.items() if isinstance(self.values, Mapping) else self.values
        object.__setattr__(self, "values", tuple((str(k), str(v)) for k, v in pairs))


@dataclass(frozen=True)
class HealthReport:
    """A /diagnostics message: health statuses at one time."""

    stamp_s: float
    statuses: tuple = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "stamp_s", check_stamp(self.stamp_s))
        object.__setattr__(self, "statuses", tuple(self.statuses))
