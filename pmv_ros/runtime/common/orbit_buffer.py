"""The orbit a sensor follows: the user's odometry at the sensor's own sample times, or none.

With ``orbit.source: follow`` the user's stack propagates the orbit and
publishes it on ``orbit/odometry`` at its own rate; the sensor samples at
its own times. :class:`OrbitBuffer` keeps the last states and answers "where
was the spacecraft at t?":

* between two states: the cubic Hermite curve through both positions with
  both velocities as its tangents (the velocity its derivative), unless
  they are further apart than ``max_gap_s``. Its error is ≈ h⁴·n⁴·r/384
  for states h apart on an orbit of mean motion n and radius r: ≈ 1e-5 m
  for h = 1 s in low orbit, ≈ 0.1 m for h = 10 s;
* beyond the newest: the two-body motion from the newest state as a
  third-order Taylor series (acceleration and jerk of the point mass) for
  at most ``extrapolation_s``. Its error is that of the series, ≈ dt⁴·n⁴·r/24
  (≈ 1e-5 m at dt = 2 s), plus the perturbations it leaves out: J2's
  ≈ 0.01 m/s² gives ≈ ½·0.01·dt² = 0.02 m at dt = 2 s — far below the
  ≈ 1 m at which a horizon sensor at a few hundred km could tell;
* later than that, or with no state yet: none — the sensor publishes
  nothing rather than an angle from an orbit nobody gave it.

:class:`FollowedOrbit` puts a buffer behind the orbit interface the sensor
model uses (:class:`pmv_ros.physics.orbit.two_body.StateOrbit`): asked for a time the
buffer cannot give, it raises :class:`OrbitUnavailable` naming why.

Memory is bounded (``capacity`` states); stamps are taken in increasing
order (the caller validates them; a stamp at or before the newest clears the
buffer: a new timeline). The states are the caller's: their frame, their
plausibility (:func:`pmv_ros.runtime.common.validation.check_orbit_state`).
"""

from __future__ import annotations

import bisect
import enum
import math
from collections import deque

import numpy as np

from ...physics.constants import EARTH_MEAN_RADIUS_M, GM_EARTH_M3_S2
from ...physics.orbit.two_body import StateOrbit


class OrbitAt(str, enum.Enum):
    """Where the state for a sample time came from, or why there is none (value: the counter name)."""

    INTERPOLATED = "interpolated"  #: between two states (or at one)
    EXTRAPOLATED = "extrapolated"  #: past the newest, within the horizon
    NO_ORBIT = "no_orbit"          #: no state yet
    TOO_OLD = "orbit_too_old"      #: before the oldest state kept
    ORBIT_GAP = "orbit_gap"        #: the bracketing states are further apart than max_gap_s
    STALE = "orbit_stale"          #: past the newest by more than the extrapolation horizon

    @property
    def usable(self) -> bool:
        """A state is given."""
        return self in (OrbitAt.INTERPOLATED, OrbitAt.EXTRAPOLATED)


#: States kept: 25 s of odometry at 10 Hz (a sensor samples within the last few).
DEFAULT_CAPACITY = 256

#: Stamps this close (s) are the same instant (float stamps from integer nanoseconds).
_SAME_INSTANT_S = 1e-9


class OrbitUnavailable(ValueError):
    """The followed orbit cannot give the state at a sample time; ``reason`` is an :class:`OrbitAt`."""

    def __init__(self, reason: OrbitAt, t_s: float):
        super().__init__(f"no orbit state at t = {t_s:.3f} s: {reason.value.replace('_', ' ')}")
        self.reason = reason


class OrbitBuffer:
    """The last ``capacity`` orbit states and the state at any time they cover.

    Args:
        extrapolation_s: how far past the newest state the two-body motion is carried, s.
        max_gap_s: no interpolation across two states further apart, s.
        capacity: states kept.
    """

    def __init__(self, extrapolation_s: float = 2.0, max_gap_s: float = 10.0, capacity: int = DEFAULT_CAPACITY):
        if not (0.0 <= extrapolation_s <= 60.0):
            raise ValueError(f"extrapolation_s = {extrapolation_s} is outside the allowed range 0 … 60 s")
        if not (0.0 < max_gap_s <= 600.0):
            raise ValueError(f"max_gap_s = {max_gap_s} is outside the allowed range (0, 600] s")
        self.extrapolation_s = float(extrapolation_s)
        self.max_gap_s = float(max_gap_s)
        self._stamps = deque(maxlen=capacity)
        self._states = deque(maxlen=capacity)

    def __len__(self) -> int:
        return len(self._stamps)

    @property
    def newest_stamp_s(self) -> float | None:
        """Stamp of the newest state, s (None when empty)."""
        return self._stamps[-1] if self._stamps else None

    def newest_state(self):
        """The newest (position m, velocity m/s) in the caller's frame; None when empty."""
        return self._states[-1] if self._states else None

    def clear(self) -> None:
        """Forget every state."""
        self._stamps.clear()
        self._states.clear()

    def take_states(self, other: "OrbitBuffer") -> None:
        """Keep the states of ``other`` (a buffer rebuilt while the odometry keeps coming)."""
        self._stamps.extend(other._stamps)
        self._states.extend(other._states)

    def add(self, t_s: float, position_m, velocity_m_s) -> None:
        """Keep one state: stamp (s), position (m) and velocity (m/s). A stamp not after the newest starts over."""
        if self._stamps and t_s <= self._stamps[-1]:
            self.clear()
        self._stamps.append(float(t_s))
        self._states.append((np.asarray(position_m, float).reshape(3).copy(),
                             np.asarray(velocity_m_s, float).reshape(3).copy()))

    def where(self, t_s: float) -> OrbitAt:
        """Where the state at ``t_s`` would come from (or why there is none), without computing it."""
        stamps = self._stamps
        if not stamps:
            return OrbitAt.NO_ORBIT
        newest = stamps[-1]
        if t_s > newest + _SAME_INSTANT_S:
            return OrbitAt.EXTRAPOLATED if t_s - newest <= self.extrapolation_s else OrbitAt.STALE
        if t_s < stamps[0] - _SAME_INSTANT_S:
            return OrbitAt.TOO_OLD
        after = bisect.bisect_left(stamps, t_s - _SAME_INSTANT_S)
        if abs(stamps[after] - t_s) <= _SAME_INSTANT_S or stamps[after] - stamps[after - 1] <= self.max_gap_s:
            return OrbitAt.INTERPOLATED
        return OrbitAt.ORBIT_GAP

    def state_at(self, t_s: float):
        """(position m, velocity m/s, :class:`OrbitAt`) at ``t_s``; (None, None, reason) when there is none."""
        reason = self.where(t_s)
        if not reason.usable:
            return None, None, reason
        stamps, states = self._stamps, self._states
        if reason is OrbitAt.EXTRAPOLATED:
            position, velocity = two_body_taylor(*states[-1], t_s - stamps[-1])
            return position, velocity, reason
        after = bisect.bisect_left(stamps, t_s - _SAME_INSTANT_S)
        if abs(stamps[after] - t_s) <= _SAME_INSTANT_S:
            position, velocity = states[after]
            return position.copy(), velocity.copy(), reason
        position, velocity = hermite_state(stamps[after - 1], states[after - 1], stamps[after], states[after], t_s)
        return position, velocity, reason


def hermite_state(t0_s: float, state0, t1_s: float, state1, t_s: float):
    """Position and velocity at ``t_s`` on the cubic Hermite curve between two states (position, velocity)."""
    (p0, v0), (p1, v1) = state0, state1
    h = t1_s - t0_s
    s = (t_s - t0_s) / h
    s2, s3 = s * s, s * s * s
    position = ((2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * h * v0
                + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * h * v1)
    velocity = ((6 * s2 - 6 * s) * p0 / h + (3 * s2 - 4 * s + 1) * v0
                + (-6 * s2 + 6 * s) * p1 / h + (3 * s2 - 2 * s) * v1)
    return position, velocity


def two_body_taylor(position_m, velocity_m_s, dt_s: float):
    """The point-mass two-body state ``dt_s`` after (position, velocity): Taylor series to the jerk term."""
    r = np.asarray(position_m, float)
    v = np.asarray(velocity_m_s, float)
    radius = math.sqrt(float(r @ r))
    mu_r3 = GM_EARTH_M3_S2 / radius**3
    acceleration = -mu_r3 * r
    jerk = -mu_r3 * (v - 3.0 * float(r @ v) / radius**2 * r)
    position = r + v * dt_s + 0.5 * acceleration * dt_s**2 + jerk * dt_s**3 / 6.0
    velocity = v + acceleration * dt_s + 0.5 * jerk * dt_s**2
    return position, velocity


class FollowedOrbit(StateOrbit):
    """The orbit of an :class:`OrbitBuffer` behind the interface of the sensor model's orbits.

    ``altitude_m`` is the nominal altitude the instrument's scan is set for
    (``orbit.altitude_km``: it places the scan start, not the spacecraft);
    every sample's geometry uses the followed state. ``period_s`` and
    ``mean_motion_rad_s`` are those of the newest state's osculating
    two-body orbit (vis-viva), or of the nominal altitude before the first.
    """

    def __init__(self, buffer: OrbitBuffer, nominal_altitude_m: float, epoch_s: float = 0.0):
        self.buffer = buffer
        self.altitude_m = float(nominal_altitude_m)
        self.epoch_s = float(epoch_s)

    @property
    def mean_motion_rad_s(self) -> float:
        """Mean motion of the newest state's osculating orbit, rad/s (the nominal altitude's before any state)."""
        newest = self.buffer.newest_state()
        if newest is None:
            a = EARTH_MEAN_RADIUS_M + self.altitude_m
        else:
            position, velocity = newest
            energy = 0.5 * float(velocity @ velocity) - GM_EARTH_M3_S2 / math.sqrt(float(position @ position))
            a = -GM_EARTH_M3_S2 / (2.0 * energy)
        return math.sqrt(GM_EARTH_M3_S2 / a**3)

    @property
    def period_s(self) -> float:
        """Period of the newest state's osculating orbit, s."""
        return 2.0 * math.pi / self.mean_motion_rad_s

    def state_eci(self, t_s):
        """Position (m) and velocity (m/s) at ``t_s``, ``(3,)`` or ``(3, N)``; OrbitUnavailable where none is given."""
        times = np.atleast_1d(np.asarray(t_s, float))
        positions = np.empty((3, times.size))
        velocities = np.empty((3, times.size))
        for k, t in enumerate(times):
            position, velocity, reason = self.buffer.state_at(float(t))
            if position is None:
                raise OrbitUnavailable(reason, float(t))
            positions[:, k], velocities[:, k] = position, velocity
        if np.ndim(t_s) == 0:
            return positions[:, 0], velocities[:, 0]
        return positions, velocities
