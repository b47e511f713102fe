"""The sensor node's own attitude model: constant offsets, slow oscillations and drift.

Angles follow the convention of :mod:`pmv_ros.physics.attitude`; rad and s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .attitude import quaternion_from_roll_pitch_yaw

#: Largest offset or oscillation amplitude accepted, rad: the sensor loses the
#: horizon on a chord long before this; beyond it the profile is surely a typo.
MAX_ANGLE_RAD = math.radians(45.0)


@dataclass(frozen=True)
class AttitudeProfile:
    """Body attitude relative to the orbital frame as a function of time.

    angle(t) = offset + amplitude · sin(2π t / period + phase) + drift · t,
    for each of roll, pitch and yaw (rad, rad, s, rad, rad/s).
    """

    roll_offset_rad: float = 0.0
    pitch_offset_rad: float = 0.0
    yaw_offset_rad: float = 0.0
    roll_amplitude_rad: float = 0.0
    pitch_amplitude_rad: float = 0.0
    yaw_amplitude_rad: float = 0.0
    oscillation_period_s: float = 600.0
    roll_drift_rad_s: float = 0.0
    pitch_drift_rad_s: float = 0.0
    yaw_drift_rad_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("roll_offset_rad", "pitch_offset_rad", "yaw_offset_rad",
                     "roll_amplitude_rad", "pitch_amplitude_rad", "yaw_amplitude_rad"):
            value = getattr(self, name)
            if not (math.isfinite(value) and abs(value) <= MAX_ANGLE_RAD):
                raise ValueError(f"{name} = {value} is outside the allowed range ±{MAX_ANGLE_RAD:.4f} rad")
        if not (math.isfinite(self.oscillation_period_s) and self.oscillation_period_s > 0.0):
            raise ValueError(f"oscillation_period_s = {self.oscillation_period_s} must be > 0 s")
        for name in ("roll_drift_rad_s", "pitch_drift_rad_s", "yaw_drift_rad_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and abs(value) <= 1e-3):
                raise ValueError(f"{name} = {value} is outside the allowed range ±0.001 rad/s")

    def _phase(self, t_s):
        return 2.0 * np.pi * np.asarray(t_s, float) / self.oscillation_period_s

    def roll_pitch_yaw(self, t_s):
        """(roll, pitch, yaw) in rad at times ``t_s`` (s), each shaped like ``t_s``."""
        t = np.asarray(t_s, float)
        wave = np.sin(self._phase(t))
        return (self.roll_offset_rad + self.roll_amplitude_rad * wave + self.roll_drift_rad_s * t,
                self.pitch_offset_rad + self.pitch_amplitude_rad * wave + self.pitch_drift_rad_s * t,
                self.yaw_offset_rad + self.yaw_amplitude_rad * wave + self.yaw_drift_rad_s * t)

    def quaternion(self, t_s):
        """Orientation of the body in the orbital frame (x, y, z, w), ``(4[, N])``."""
        return quaternion_from_roll_pitch_yaw(*self.roll_pitch_yaw(t_s))
