"""Orbit propagation and the orbital frame: the circular orbit, an eccentric (Keplerian) one, and what any
orbit's state gives (argument of latitude, inclination, altitude, the orbital frame).

Vectors are ``(3,)`` or ``(3, N)`` (first axis is x, y, z); rotation matrices
are ``(3, 3)`` or ``(3, 3, N)``. Times are seconds on the simulation clock.

The orbital frame (interfaces.md): Z along the geocentric radius away from the
Earth, X in the orbit plane towards the velocity, Y = Z x X completing the
right-handed set. For a circular orbit Y is the orbit normal (angular momentum);
for any other orbit X is the along-track horizontal (the velocity without its
radial part) and Y still the orbit normal.

Every orbit the sensor flies offers the same interface (:class:`CircularOrbit`
is the reference): ``state_eci``, ``orbital_frame_eci``, ``argument_of_latitude``,
``orbit_angles`` (u, inclination and altitude at each sample — what the
closed-form oblateness model takes), and nominal elements for messages and the
instrument's fixed settings (``altitude_m``, ``inclination_rad``, ``raan_rad``,
``arg_latitude_at_epoch_rad``, ``period_s``, ``raan_rate_rad_s``, ``epoch_s``).
Orbits other than the circular one derive everything from their state
(:class:`StateOrbit`). The frame called ECI is the mean equator and mean
equinox of date (:mod:`pmv_ros.physics.orbit.ephemeris`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..compiled import kernel
from ..constants import (
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

    def orbit_angles(self, t_s):
        """Argument of latitude (rad, not wrapped), inclination (rad) and altitude above the mean radius (m) at
        ``t_s``: what the closed-form oblateness model takes; constant inclination and altitude here."""
        return self.argument_of_latitude(t_s), self.inclination_rad, self.altitude_m


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


@kernel
def orbit_angles(position_m, velocity_m_s):
    """:func:`orbit_angles_from_state` of one state (3-tuples): (u, inclination, altitude), rad, rad, m; NaN for a
    state with no angular momentum. The sensor's kernel calls it per sample."""
    rx, ry, rz = position_m
    vx, vy, vz = velocity_m_s
    hx, hy, hz = ry * vz - rz * vy, rz * vx - rx * vz, rx * vy - ry * vx
    h_norm = math.sqrt(hx * hx + hy * hy + hz * hz)
    if not (0.0 < h_norm < math.inf):
        return math.nan, math.nan, math.nan
    inclination = math.acos(max(-1.0, min(1.0, hz / h_norm)))
    nx, ny = -hy, hx  # node direction: z × h
    n_norm = math.hypot(nx, ny)
    if n_norm < 1e-12 * h_norm:
        nx, ny, n_norm = 1.0, 0.0, 1.0
    nx, ny = nx / n_norm, ny / n_norm
    # sin u = ((n × r) · h) / |h|, cos u = n · r
    cx, cy, cz = ny * rz, -nx * rz, nx * ry - ny * rx
    u = math.atan2((cx * hx + cy * hy + cz * hz) / h_norm, nx * rx + ny * ry)
    radius = math.sqrt(rx * rx + ry * ry + rz * rz)
    return u % (2.0 * math.pi), inclination, radius - EARTH_MEAN_RADIUS_M


@kernel
def _orbit_angles_each(position, velocity, out):
    for n in range(position.shape[1]):
        out[0, n], out[1, n], out[2, n] = orbit_angles((position[0, n], position[1, n], position[2, n]),
                                                       (velocity[0, n], velocity[1, n], velocity[2, n]))


def orbit_angles_from_state(position_eci_m, velocity_eci_m_s):
    """Argument of latitude u (rad), inclination (rad) and altitude above the mean radius (m) from r, v in ECI.

    For the oblateness model of an orbit known by its state (a monitor fed
    from /orbit/odometry, an orbit from an element set). u is the angle from
    the ascending node to r in the orbit plane (0 … 2π); for an equatorial
    orbit the node is undefined and u is measured from the ECI x axis. One
    state ((3,) or a tuple) gives floats, ``(3, N)`` arrays give ``(N,)`` arrays, both through the compiled
    :func:`orbit_angles`. ValueError for a state that is not finite or whose r and v are parallel.
    """
    if type(position_eci_m) is tuple or np.ndim(position_eci_m) == 1:
        state = tuple(map(float, position_eci_m)), tuple(map(float, velocity_eci_m_s))
        u, inclination, altitude = orbit_angles(*state)
        if math.isnan(inclination) or not all(map(math.isfinite, state[0] + state[1])):
            raise ValueError("position and velocity must be finite and not parallel")
        return u, inclination, altitude
    position = np.ascontiguousarray(position_eci_m, float)
    velocity = np.ascontiguousarray(velocity_eci_m_s, float)
    out = np.empty((3, position.shape[1]))
    _orbit_angles_each(position, velocity, out)
    if not (np.all(np.isfinite(position)) and np.all(np.isfinite(velocity)) and not np.any(np.isnan(out[1]))):
        raise ValueError("position and velocity must be finite and not parallel")
    return out[0], out[1], out[2]


@kernel
def orbital_axes(position_m, velocity_m_s):
    """:func:`orbital_axes_of_state` in the kernels: 3-tuples r (m), v (m/s) → the axes X, Y, Z (3-tuples)."""
    rx, ry, rz = position_m
    vx, vy, vz = velocity_m_s
    nan3 = (math.nan, math.nan, math.nan)
    radius = math.sqrt(rx * rx + ry * ry + rz * rz)
    if not 0.0 < radius < math.inf:
        return nan3, nan3, nan3
    zx, zy, zz = rx / radius, ry / radius, rz / radius
    radial = vx * zx + vy * zy + vz * zz
    xx, xy, xz = vx - radial * zx, vy - radial * zy, vz - radial * zz
    along = math.sqrt(xx * xx + xy * xy + xz * xz)
    if not 0.0 < along < math.inf:
        return nan3, nan3, nan3
    xx, xy, xz = xx / along, xy / along, xz / along
    return (xx, xy, xz), (zy * xz - zz * xy, zz * xx - zx * xz, zx * xy - zy * xx), (zx, zy, zz)


@kernel
def _orbital_axes_each(position, velocity, out):
    for n in range(position.shape[1]):
        axes = orbital_axes((position[0, n], position[1, n], position[2, n]),
                            (velocity[0, n], velocity[1, n], velocity[2, n]))
        for column in range(3):
            for row in range(3):
                out[row, column, n] = axes[column][row]


def orbital_axes_of_state(position_eci_m, velocity_eci_m_s) -> tuple[tuple, tuple, tuple]:
    """The orbital frame's axes X, Y, Z in ECI of one state, as 3-tuples of floats (the compiled
    :func:`orbital_axes`): Z along r, X the velocity without its radial part, Y = Z × X. NaN axes where r or
    its horizontal velocity is zero or not finite."""
    return orbital_axes(tuple(map(float, position_eci_m)), tuple(map(float, velocity_eci_m_s)))


def orbital_frame_from_state(position_eci_m, velocity_eci_m_s):
    """Orbital-frame axes (columns X, Y, Z) in ECI from ``(3[, N])`` r and v: ``(3, 3[, N])``.

    Z along r, X the velocity without its radial part (the along-track
    horizontal), Y = Z × X (the orbit normal); state by state (:func:`orbital_axes`).
    """
    r = np.asarray(position_eci_m, float)
    v = np.asarray(velocity_eci_m_s, float)
    shape = np.broadcast_shapes(r.shape, v.shape)[1:]
    out = np.empty((3, 3, int(np.prod(shape))))
    _orbital_axes_each(np.ascontiguousarray(np.broadcast_to(r, (3,) + shape).reshape(3, -1)),
                       np.ascontiguousarray(np.broadcast_to(v, (3,) + shape).reshape(3, -1)), out)
    return out.reshape((3, 3) + shape)


class StateOrbit:
    """What an orbit known by its state gives: the orbital frame, u, inclination and altitude at each sample.

    A subclass defines ``state_eci(t_s)`` (position m and velocity m/s in
    ECI, ``(3[, N])``); u is wrapped to 0 … 2π, the inclination is the
    osculating one (from the angular momentum) and the altitude is the
    geocentric radius minus the 6371 km mean radius — as the error monitor
    takes them from /orbit/odometry.
    """

    def state_eci(self, t_s):  # pragma: no cover - defined by subclasses
        raise NotImplementedError

    def orbital_frame_eci(self, t_s):
        """Orbital-frame axes in ECI: matrix whose columns are X, Y, Z; ``(3, 3)`` or ``(3, 3, N)``."""
        return orbital_frame_from_state(*self.state_eci(t_s))

    def orbit_angles(self, t_s):
        """Argument of latitude (rad, 0 … 2π), inclination (rad) and altitude above the mean radius (m) at ``t_s``."""
        position, velocity = self.state_eci(np.atleast_1d(np.asarray(t_s, float)))
        u, inclination, altitude = orbit_angles_from_state(position, velocity)
        if np.ndim(t_s) == 0:
            return float(u[0]), float(inclination[0]), float(altitude[0])
        return u, inclination, altitude

    def argument_of_latitude(self, t_s):
        """Argument of latitude u(t) from the ascending node, rad (0 … 2π)."""
        return self.orbit_angles(t_s)[0]

    def raan(self, t_s):
        """Right ascension of the osculating ascending node Ω(t), rad."""
        position, velocity = self.state_eci(np.atleast_1d(np.asarray(t_s, float)))
        h = np.cross(position, velocity, axis=0)
        node = np.arctan2(h[0], -h[1])
        return float(node[0]) if np.ndim(t_s) == 0 else node


def solve_kepler(mean_anomaly_rad, eccentricity: float):
    """Eccentric anomaly E from the mean anomaly M (rad, array-like) for e < 1: E − e sin E = M (Newton, 1e-15)."""
    m = np.mod(np.asarray(mean_anomaly_rad, float), 2.0 * np.pi)
    e_anomaly = m + eccentricity * np.sin(m)
    for _ in range(50):
        step = (e_anomaly - eccentricity * np.sin(e_anomaly) - m) / (1.0 - eccentricity * np.cos(e_anomaly))
        e_anomaly = e_anomaly - step
        if np.all(np.abs(step) < 1e-15):
            break
    return e_anomaly


@dataclass(frozen=True)
class KeplerOrbit(StateOrbit):
    """An eccentric orbit: two-body motion from osculating elements, optionally with the secular J2 drift.

    Args:
        perigee_altitude_m: perigee height above the 6371 km mean radius, m (≥ 150 km).
        eccentricity: 0 ≤ e < 1 (apogee ≤ 40000 km).
        inclination_rad: inclination, rad (0 … π).
        raan_rad: right ascension of the ascending node at epoch, rad.
        arg_perigee_rad: argument of perigee ω at epoch, rad.
        mean_anomaly_at_epoch_rad: mean anomaly M at epoch, rad.
        epoch_s: epoch on the simulation clock, s.
        j2_secular: apply the first-order secular J2 rates of Ω, ω and M.
    """

    perigee_altitude_m: float
    eccentricity: float
    inclination_rad: float
    raan_rad: float = 0.0
    arg_perigee_rad: float = 0.0
    mean_anomaly_at_epoch_rad: float = 0.0
    epoch_s: float = 0.0
    j2_secular: bool = False

    def __post_init__(self) -> None:
        check_range("perigee altitude", self.perigee_altitude_m / 1e3, MIN_ALTITUDE_M / 1e3, MAX_ALTITUDE_M / 1e3,
                    " km")
        check_range("eccentricity", self.eccentricity, 0.0, 0.99)
        check_range("inclination", math.degrees(self.inclination_rad), 0.0, 180.0, " deg")
        apogee = self.semi_major_axis_m * (1.0 + self.eccentricity) - EARTH_MEAN_RADIUS_M
        if apogee > MAX_ALTITUDE_M:
            raise ValueError(f"apogee altitude = {apogee / 1e3:g} km is outside the allowed range "
                             f"{MIN_ALTITUDE_M / 1e3:g} … {MAX_ALTITUDE_M / 1e3:g} km")
        for name in ("raan_rad", "arg_perigee_rad", "mean_anomaly_at_epoch_rad", "epoch_s"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)!r}")

    @property
    def semi_major_axis_m(self) -> float:
        """Semi-major axis a, m."""
        return (EARTH_MEAN_RADIUS_M + self.perigee_altitude_m) / (1.0 - self.eccentricity)

    @property
    def altitude_m(self) -> float:
        """Nominal altitude: a − 6371 km, m (the mean of the radius over the mean anomaly is a(1 + e²/2))."""
        return self.semi_major_axis_m - EARTH_MEAN_RADIUS_M

    def _rates(self) -> tuple[float, float, float]:
        """(dΩ/dt, dω/dt, dM/dt), rad/s: the Keplerian mean motion plus the first-order secular J2 terms."""
        a, e, i = self.semi_major_axis_m, self.eccentricity, self.inclination_rad
        n = math.sqrt(GM_EARTH_M3_S2 / a**3)
        if not self.j2_secular:
            return 0.0, 0.0, n
        p = a * (1.0 - e * e)
        k = 1.5 * n * J2_EARTH * (GRS80.a_m / p) ** 2
        s2 = math.sin(i) ** 2
        return (-k * math.cos(i), 0.5 * k * (4.0 - 5.0 * s2),
                n + 0.5 * k * math.sqrt(1.0 - e * e) * (2.0 - 3.0 * s2))

    @property
    def mean_motion_rad_s(self) -> float:
        """Rate of the argument of latitude averaged over an orbit, dω/dt + dM/dt, rad/s."""
        _, argp_rate, m_rate = self._rates()
        return argp_rate + m_rate

    @property
    def period_s(self) -> float:
        """Nodal period 2π / (dω/dt + dM/dt), s."""
        return 2.0 * math.pi / self.mean_motion_rad_s

    @property
    def raan_rate_rad_s(self) -> float:
        """Secular node drift dΩ/dt, rad/s (0 without J2)."""
        return self._rates()[0]

    @property
    def arg_latitude_at_epoch_rad(self) -> float:
        """Argument of latitude at the epoch, rad."""
        return float(self.argument_of_latitude(self.epoch_s))

    def state_eci(self, t_s):
        """Position (m) and velocity (m/s) in ECI, each ``(3,)`` or ``(3, N)``."""
        raan_rate, argp_rate, m_rate = self._rates()
        dt = np.asarray(t_s, float) - self.epoch_s
        a, e = self.semi_major_axis_m, self.eccentricity
        e_anomaly = solve_kepler(self.mean_anomaly_at_epoch_rad + m_rate * dt, e)
        cos_e, sin_e = np.cos(e_anomaly), np.sin(e_anomaly)
        root = math.sqrt(1.0 - e * e)
        # Perifocal position and velocity (P towards perigee, Q 90° ahead in the orbit plane).
        radius = a * (1.0 - e * cos_e)
        speed_scale = math.sqrt(GM_EARTH_M3_S2 * a) / radius
        p_pos, q_pos = a * (cos_e - e), a * root * sin_e
        p_vel, q_vel = -speed_scale * sin_e, speed_scale * root * cos_e
        argp = self.arg_perigee_rad + argp_rate * dt
        frame = orbital_frame_from_angles(argp, self.inclination_rad, self.raan_rad + raan_rate * dt)
        # Columns: X (90° ahead of Z in the plane) and Z (towards u = ω): the perifocal Q and P axes.
        p_axis, q_axis = frame[:, 2], frame[:, 0]
        return p_axis * p_pos + q_axis * q_pos, p_axis * p_vel + q_axis * q_vel
