"""The sensor's roll and pitch as an estimator takes them: an orientation with its covariance, always finite.

``/pmv/attitude`` is the measurement as the contract states it (NaN for a
lost axis). An estimator — a MEKF, a robot_localization-style filter — wants
an orientation it can weight: ``/pmv/attitude_imu`` (``sensor_msgs/Imu``,
interfaces.md "Topics") carries the orientation of the sensor frame in the
orbital frame from the measured roll and pitch with yaw 0, and the
variances of the instrument's error model on its diagonal. Yaw is not
observable: its variance is :data:`UNOBSERVED_VARIANCE_RAD2`, and so is the
variance of an axis whose chord pair lost the horizon, whose angle is then
0 — the message stays finite and a filter gives that axis no weight.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from ...physics.constants import ARCMIN_RAD

#: Variance of an axis the sensor does not measure (yaw; a lost chord pair), rad². Against the
#: instrument's ≈ (5′)² ≈ 2·10⁻⁶ rad² it is 5·10¹¹ times larger: a Kalman gain of ≈ 10⁻¹² —
#: no information — while float64 arithmetic in a filter still adds it to arcminute variances
#: without overflow or loss of the other axes (1e6 + 2e-6 keeps 16 digits of the larger term only;
#: the filter's own states are not summed with it).
UNOBSERVED_VARIANCE_RAD2 = 1.0e6


class EstimatorOrientation(NamedTuple):
    """One sample for estimators: unit quaternion (x, y, z, w) of the sensor frame in the orbital frame and the
    roll, pitch, yaw variances, rad² (the diagonal of ``orientation_covariance``)."""

    q_xyzw: tuple
    variances_rad2: tuple


def variance_from_rms_arcmin(rms_arcmin: float) -> float:
    """The variance, rad², of an error whose root mean square is ``rms_arcmin`` arcmin."""
    return (rms_arcmin * ARCMIN_RAD) ** 2


def estimator_orientation(roll_rad: float, pitch_rad: float, roll_variance_rad2: float,
                          pitch_variance_rad2: float) -> EstimatorOrientation:
    """Roll and pitch (rad, REP-103; NaN: lost) as an orientation with variances for estimators.

    The quaternion is R = R_z(0)·R_y(pitch)·R_x(roll) (tf2's roll/pitch/yaw,
    README "Sign convention"), written out for yaw 0 — per sample in the
    sensor's publish path, so plain floats: q = (sin φ/2·cos θ/2,
    cos φ/2·sin θ/2, −sin φ/2·sin θ/2, cos φ/2·cos θ/2). A lost (non-finite)
    axis enters with angle 0 and :data:`UNOBSERVED_VARIANCE_RAD2`.
    """
    if not math.isfinite(roll_rad):
        roll_rad, roll_variance_rad2 = 0.0, UNOBSERVED_VARIANCE_RAD2
    if not math.isfinite(pitch_rad):
        pitch_rad, pitch_variance_rad2 = 0.0, UNOBSERVED_VARIANCE_RAD2
    sr, cr = math.sin(0.5 * roll_rad), math.cos(0.5 * roll_rad)
    sp, cp = math.sin(0.5 * pitch_rad), math.cos(0.5 * pitch_rad)
    return EstimatorOrientation((sr * cp, cr * sp, -sr * sp, cr * cp),
                                (roll_variance_rad2, pitch_variance_rad2, UNOBSERVED_VARIANCE_RAD2))
