"""Circular-orbit propagation and the orbital frame.

Vectors are ``(3,)`` or ``(3, N)`` (first axis is x, y, z); rotation matrices
are ``(3, 3)`` or ``(3, 3, N)``. Times are seconds on the simulation clock.

The orbital frame (interfaces.md): Z along the geocentric radius away from the
Earth, X in the orbit plane towards the velocity, Y = Z x X completing the
right-handed set. For a circular orbit Y is the orbit normal (angular momentum).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .constants import (
    EARTH_MEAN_RADIUS_M,
    EARTH_ROTATION_RATE_RAD_S,
    GM_EARTH_M3_S2,
    GRS80,
    J2_EARTH,
)

#: Allowed altitude range, m: low enough to stay above the emitting layers of
#: the horizon (≈ 60 km) with margin, high enough for geostationary studies.
MIN_ALTITUDE_M = 150e3
MAX_ALTITUDE_M = 40000e3


def check_range(name: str, value: float, low: float, high: float, unit: str = "") -> float:
    """Return ``value`` as float, or raise ValueError naming it and the allowed range."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not (low <= number <= high):
        raise ValueError(f"{name} = {value}{unit} is outside the allowed range {low} … {high}{unit}")
    return number


@dataclass(frozen=True)
class CircularOrbit:
    """A circular orbit given by its elements at an epoch.

    Args:
        altitude_m: height above the mean Earth radius (6371 km), m — the
            altitude H of the papers, which use the spherical mean radius.
        inclination_rad: inclination, rad (0 … π).
        raan_rad: right ascension of the ascending node at epoch, rad.
        arg_latitude_at_epoch_rad: argument of latitude u at epoch, rad.
        epoch_s: epoch on the simulation clock, s.
        j2_node_drift: apply the secular J2 drift of the node (and of u).
    """

    altitude_m: float
    inclination_rad: float
    raan_rad: float = 0.0
    arg_latitude_at_epoch_rad: float = 0.0
    epoch_s: float = 0.0
    j2_node_drift: bool = False

    def __post_init__(self) -> None:
        check_range("altitude", self.altitude_m / 1e3, MIN_ALTITUDE_M / 1e3, MAX_ALTITUDE_M / 1e3, " km")
        check_range("inclination", math.degrees(self.inclination_rad), 0.0, 180.0, " deg")
        for name in ("raan_rad", "arg_latitude_at_epoch_rad", "epoch_s"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)!r}")

    @property
    def radius_m(self) -> float:
        """Orbit radius, m."""
        return EARTH_MEAN_RADIUS_M + self.altitude_m

    @property
    def mean_motion_rad_s(self) -> float:
        """Keplerian mean motion n = sqrt(GM / r^3), rad/s (plus the J2 term on u when enabled)."""
        n = circular_mean_motion_rad_s(self.altitude_m)
        if self.j2_node_drift:
            # First-order secular J2 rates for e = 0: du/dt = dω/dt + dM/dt
            # = n [1 + 3/4 J2 (R/r)^2 ((4 - 5 sin^2 i) + (2 - 3 sin^2 i))].
            k = 0.75 * J2_EARTH * (GRS80.a_m / self.radius_m) ** 2
            s2 = math.sin(self.inclination_rad) ** 2
            n *= 1.0 + k * ((4.0 - 5.0 * s2) + (2.0 - 3.0 * s2))
        return n

    @property
    def period_s(self) -> float:
        """Orbital period 2π/n, s."""
        return 2.0 * math.pi / self.mean_motion_rad_s

    @property
    def raan_rate_rad_s(self) -> float:
        """Secular node drift dΩ/dt = −3/2 n J2 (a/r)^2 cos i, rad/s (0 without J2)."""
        if not self.j2_node_drift:
            return 0.0
        n = circular_mean_motion_rad_s(self.altitude_m)
        return -1.5 * n * J2_EARTH * (GRS80.a_m / self.radius_m) ** 2 * math.cos(self.inclination_rad)

    def argument_of_latitude(self, t_s):
        """Argument of latitude u(t) from the ascending node, rad (not wrapped)."""
        return self.arg_latitude_at_epoch_rad + self.mean_motion_rad_s * (np.asarray(t_s, float) - self.epoch_s)

    def raan(self, t_s):
        """Right ascension of the ascending node Ω(t), rad."""
        return self.raan_rad + self.raan_rate_rad_s * (np.asarray(t_s, float) - self.epoch_s)

    def time_of_argument_of_latitude(self, u_rad):
        """Simulation time at which the argument of latitude equals ``u_rad`` (first pass), s."""
        return self.epoch_s + (np.asarray(u_rad, float) - self.arg_latitude_at_epoch_rad) / self.mean_motion_rad_s

    def orbital_frame_eci(self, t_s):
        """Orbital-frame axes in ECI: matrix whose columns are X, Y, Z; ``(3, 3)`` or ``(3, 3, N)``."""
        return orbital_frame_from_angles(self.argument_of_latitude(t_s), self.inclination_rad, self.raan(t_s))

    def state_eci(self, t_s):
        """Position (m) and velocity (m/s) in ECI, each ``(3,)`` or ``(3, N)``."""
        frame = self.orbital_frame_eci(t_s)
        speed = self.radius_m * self.mean_motion_rad_s
        return self.radius_m * frame[:, 2], speed * frame[:, 0]


def circular_mean_motion_rad_s(altitude_m: float) -> float:
    """Keplerian mean motion sqrt(GM / r^3) of a circular orbit ``altitude_m`` above the mean radius, rad/s."""
    return math.sqrt(GM_EARTH_M3_S2 / (EARTH_MEAN_RADIUS_M + altitude_m) ** 3)


def orbital_frame_from_angles(u_rad, inclination_rad, raan_rad):
    """Orbital-frame axes (columns X, Y, Z) in ECI from u, i and Ω, rad; ``(3, 3[, N])``."""
    u = np.asarray(u_rad, float)
    raan = np.asarray(raan_rad, float)
    cu, su = np.cos(u), np.sin(u)
    co, so = np.cos(raan), np.sin(raan)
    ci, si = math.cos(inclination_rad), math.sin(inclination_rad)
    shape = np.broadcast(u, raan).shape
    # Radial unit vector Z and along-track unit vector X of a circular orbit.
    z_axis = np.array([co * cu - so * su * ci, so * cu + co * su * ci, su * si + 0.0 * co])
    x_axis = np.array([-co * su - so * cu * ci, -so * su + co * cu * ci, cu * si + 0.0 * co])
    z_axis = np.broadcast_to(z_axis, (3,) + shape)
    x_axis = np.broadcast_to(x_axis, (3,) + shape)
    y_axis = np.cross(z_axis, x_axis, axis=0)
    return np.stack([x_axis, y_axis, z_axis], axis=1)


def orbital_frame_from_state(position_m, velocity_m_s) -> tuple[tuple, tuple, tuple]:
    """Orbital-frame axes X, Y, Z in the frame of ``position_m``/``velocity_m_s``: three unit 3-tuples.

    Z along the radius away from the Earth, Y = r × v (the orbit normal),
    X = Y × Z (in the orbit plane, towards the velocity) — interfaces.md;
    for a circular orbit the axes of :func:`orbital_frame_from_angles`.
    Plain floats: the sensor's odometry writes one per sample.
    """
    rx, ry, rz = (float(c) for c in position_m)
    vx, vy, vz = (float(c) for c in velocity_m_s)
    r = math.sqrt(rx * rx + ry * ry + rz * rz)
    hx, hy, hz = ry * vz - rz * vy, rz * vx - rx * vz, rx * vy - ry * vx
    h = math.sqrt(hx * hx + hy * hy + hz * hz)
    if not (r > 0.0 and h > 0.0 and math.isfinite(r + h)):
        raise ValueError(f"position {position_m} and velocity {velocity_m_s} define no orbital frame")
    z = (rx / r, ry / r, rz / r)
    y = (hx / h, hy / h, hz / h)
    x = (y[1] * z[2] - y[2] * z[1], y[2] * z[0] - y[0] * z[2], y[0] * z[1] - y[1] * z[0])
    return x, y, z


def earth_rotation_angle(t_s, angle_at_epoch_rad: float = 0.0, epoch_s: float = 0.0):
    """Angle of the Greenwich meridian from the ECI x axis, rad: θ0 + ω_E (t − t0)."""
    return angle_at_epoch_rad + EARTH_ROTATION_RATE_RAD_S * (np.asarray(t_s, float) - epoch_s)


def eci_to_ecef(vectors, t_s, angle_at_epoch_rad: float = 0.0, epoch_s: float = 0.0):
    """Rotate ``(3[, N])`` ECI vectors into the Earth-fixed frame at time ``t_s``."""
    theta = earth_rotation_angle(t_s, angle_at_epoch_rad, epoch_s)
    c, s = np.cos(theta), np.sin(theta)
    v = np.asarray(vectors, float)
    return np.array([c * v[0] + s * v[1], -s * v[0] + c * v[1], v[2] + 0.0 * c])


def geocentric_latitude_longitude(r_m):
    """Geocentric latitude and longitude, rad, of ``(3[, N])`` position vectors (frame of the input)."""
    r = np.asarray(r_m, float)
    return np.arctan2(r[2], np.hypot(r[0], r[1])), np.arctan2(r[1], r[0])
