"""Plain functions between the domain records and the standard ROS 2 messages of interfaces.md.

The one place that knows the wire layout. Every function is pure: no node, no
``rclpy.init()``. Naming: ``write_<record>(msg, …)`` fills a message,
``<record>_from_msg(msg)`` builds a record from one and ``read_<record>(msg)``
returns its plain values.

Wire layouts
    /pmv/horizon_crossings  PolygonStamped: 4 points (float32) = lines of sight,
                            chords +X, +Y, −X, −Y; an invalid chord is a NaN point.
    /pmv/attitude, /pmv/residual
                            Vector3Stamped: x = roll, y = pitch (rad), z = 0.
    /pmv/attitude_imu       Imu: orientation of header.frame_id (the sensor frame)
                            in the orbital frame (roll, pitch, yaw 0);
                            orientation_covariance row-major about x, y, z, the
                            roll, pitch, yaw variances on its diagonal;
                            angular_velocity_covariance[0] and
                            linear_acceleration_covariance[0] = −1 (not provided).
    /pmv/residual_mean, /pmv/residual_sigma, /pmv/residual_limit
                            Vector3Stamped: x = roll, y = pitch, z = meridional (rad).
    /attitude/truth, /star_tracker/attitude
                            QuaternionStamped: body in header.frame_id (orbital).
    /orbit/odometry         Odometry by nav_msgs' rules: pose.position = r and
                            pose.orientation = the orbital frame, in
                            header.frame_id (ECI); twist (linear = v, angular =
                            the frame's rate) in child_frame_id (orbital).
    /pmv/error_statistics   DiagnosticArray: one status per channel, named
                            ``pmv_error_monitor: roll|pitch|meridional``, then
                            ``pmv_error_monitor: samples`` with the counters.
                            Channel keys (arcmin for people, m for the ground):
                            count, mean_arcmin, sigma_arcmin, three_sigma_arcmin,
                            limit_low_arcmin, limit_high_arcmin (mean ∓ 3σ),
                            max_abs_arcmin, harmonic_kNN_arcmin (NN = 01…),
                            ground_mean_m, ground_sigma_m, ground_max_abs_m,
                            oblateness_removed. Numbers are Python ``repr`` of
                            floats; a statistic not defined yet (a harmonic
                            before a whole orbit, σ before two samples) is
                            "pending", never "nan".
    /diagnostics            DiagnosticArray of :class:`HealthStatus`.
    /clock                  rosgraph_msgs/Clock: simulation time.
    /tf, /tf_static         TransformStamped (in a tf2_msgs/TFMessage, which the node
                            builds: tf2_msgs may be absent): the child frame's pose in
                            the parent frame — translation (m) and rotation (x, y, z, w).

Writers and readers
    ``write_<record>(msg, stamp_s, frame_id, …)`` fills a message in place
    from plain values and returns it, so a publisher at 10 Hz or in fast time
    can reuse one message per topic (rclpy serialises at ``publish``, so the
    next write cannot touch what was sent); a fresh message
    (``write_clock(Clock(), t)``) is built the same way. The two diagnostics
    writers take their record (:class:`ErrorStatistics`, :class:`HealthReport`).
    ``read_<record>(msg)`` returns the plain values a ``*_from_msg`` record
    would hold, with the same stamp check, without building the record.
"""

from __future__ import annotations

import math
import re

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point32, PolygonStamped, QuaternionStamped, TransformStamped, Vector3Stamped
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu

from pmv_ros.analysis.statistics import CHANNELS, PENDING, ChannelStatistics, statistic_text
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.orbit.two_body import orbital_axes_of_state
from pmv_ros.physics.star_tracker.model import Outcome

from .records import (
    AttitudeAngles,
    AttitudeQuaternion,
    ErrorStatistics,
    HealthReport,
    HealthStatus,
    HorizonCrossings,
    Level,
    OrbitState,
    check_stamp,
)


#: Name prefix of the /pmv/error_statistics statuses.
STATISTICS_STATUS_PREFIX = "pmv_error_monitor: "
#: Name of the counters status of /pmv/error_statistics.
SAMPLES_STATUS_NAME = STATISTICS_STATUS_PREFIX + "samples"

_HARMONIC_KEY = re.compile(r"^harmonic_k(\d+)_arcmin$")
_INT32_MAX = 2**31 - 1


# ----------------------------------------------------------------------------- time

def _split_stamp(stamp_s: float) -> tuple[int, int]:
    stamp = float(stamp_s)
    if not (math.isfinite(stamp) and 0.0 <= stamp < _INT32_MAX + 1):
        raise ValueError(f"stamp_s = {stamp_s} is outside the allowed range [0, 2^31) s")
    seconds = math.floor(stamp)
    nanoseconds = round((stamp - seconds) * 1e9)
    if nanoseconds >= 1_000_000_000:
        seconds, nanoseconds = seconds + 1, nanoseconds - 1_000_000_000
    return int(seconds), int(nanoseconds)


def write_stamp(msg: Time, stamp_s: float) -> Time:
    """Set a builtin_interfaces/Time in place from seconds (rounded to the nanosecond; 0 ≤ stamp < 2³¹ s,
    ValueError otherwise); returns it."""
    msg.sec, msg.nanosec = _split_stamp(stamp_s)
    return msg


def time_from_msg(msg: Time) -> float:
    """Seconds from builtin_interfaces/Time."""
    return msg.sec + msg.nanosec * 1e-9


def write_clock(msg: Clock, stamp_s: float) -> Clock:
    """Fill a rosgraph_msgs/Clock for /clock (fast-time simulation) in place from seconds; returns it."""
    write_stamp(msg.clock, stamp_s)
    return msg


def clock_from_msg(msg: Clock) -> float:
    """Seconds from rosgraph_msgs/Clock."""
    return time_from_msg(msg.clock)


def _header(msg, stamp_s: float, frame_id: str) -> None:
    header = msg.header
    write_stamp(header.stamp, stamp_s)
    header.frame_id = frame_id


# --------------------------------------------------------------- horizon crossings

def write_horizon_crossings(msg: PolygonStamped, stamp_s: float, frame_id: str, line_of_sight) -> PolygonStamped:
    """Fill a PolygonStamped in place (see "Writers" above); returns it.

    ``line_of_sight``: 4 rows (x, y, z) of floats, chords +X, +Y, −X, −Y, NaN
    rows for invalid chords — as :class:`HorizonCrossings` holds them
    (:func:`~pmv_msgs_shim.records.checked_lines_of_sight` makes them).
    """
    if len(line_of_sight) != 4:
        raise ValueError(f"horizon crossings need 4 lines of sight (chords +X, +Y, -X, -Y), got {len(line_of_sight)}")
    _header(msg, stamp_s, frame_id)
    points = msg.polygon.points
    if len(points) != 4:
        points = [Point32() for _ in range(4)]
        msg.polygon.points = points
    for point, (x, y, z) in zip(points, line_of_sight):
        point.x, point.y, point.z = float(x), float(y), float(z)
    return msg


def horizon_crossings_from_msg(msg: PolygonStamped) -> HorizonCrossings:
    """HorizonCrossings from a PolygonStamped; a chord is valid when its point is finite."""
    points = msg.polygon.points
    if len(points) != 4:
        raise ValueError(f"horizon crossings need 4 points (chords +X, +Y, -X, -Y), got {len(points)}")
    vectors = np.array([[p.x, p.y, p.z] for p in points], float)
    valid = np.all(np.isfinite(vectors), axis=1)
    return HorizonCrossings(time_from_msg(msg.header.stamp), msg.header.frame_id, vectors, valid)


# ----------------------------------------------------------------------- attitude

def write_attitude_angles(msg: Vector3Stamped, stamp_s: float, frame_id: str, roll_rad: float,
                          pitch_rad: float) -> Vector3Stamped:
    """Fill a Vector3Stamped in place, x = roll, y = pitch (rad), z = 0 (yaw is not observable); returns it."""
    _header(msg, stamp_s, frame_id)
    vector = msg.vector
    vector.x, vector.y, vector.z = float(roll_rad), float(pitch_rad), 0.0
    return msg


def attitude_angles_from_msg(msg: Vector3Stamped) -> AttitudeAngles:
    """AttitudeAngles from a Vector3Stamped (z is ignored)."""
    return AttitudeAngles(time_from_msg(msg.header.stamp), msg.header.frame_id, msg.vector.x, msg.vector.y)


def read_attitude_angles(msg: Vector3Stamped) -> tuple[float, float, float]:
    """(stamp_s, roll_rad, pitch_rad) of a Vector3Stamped, checked as :class:`AttitudeAngles` checks them."""
    vector = msg.vector
    return check_stamp(time_from_msg(msg.header.stamp)), vector.x, vector.y


def write_attitude_quaternion(msg: QuaternionStamped, stamp_s: float, frame_id: str, q_xyzw) -> QuaternionStamped:
    """Fill a QuaternionStamped in place with the body orientation (x, y, z, w) in ``frame_id``; returns it."""
    _header(msg, stamp_s, frame_id)
    quaternion = msg.quaternion
    x, y, z, w = q_xyzw
    quaternion.x, quaternion.y, quaternion.z, quaternion.w = float(x), float(y), float(z), float(w)
    return msg


def write_attitude_imu(msg: Imu, stamp_s: float, frame_id: str, q_xyzw, variances_rad2) -> Imu:
    """Fill an Imu in place (see "Writers" above) from the orientation (x, y, z, w) and the roll, pitch, yaw
    variances (rad², the covariance's diagonal); angular velocity and linear acceleration are marked not
    provided (``covariance[0] = -1``, sensor_msgs/Imu); returns it."""
    _header(msg, stamp_s, frame_id)
    orientation = msg.orientation
    x, y, z, w = q_xyzw
    orientation.x, orientation.y, orientation.z, orientation.w = float(x), float(y), float(z), float(w)
    covariance = msg.orientation_covariance  # float64 (9,): off-diagonal terms stay 0
    covariance[0], covariance[4], covariance[8] = variances_rad2
    msg.angular_velocity_covariance[0] = msg.linear_acceleration_covariance[0] = -1.0
    return msg


def read_attitude_imu(msg: Imu) -> tuple[float, tuple, tuple]:
    """(stamp_s, (x, y, z, w), (roll, pitch, yaw variances in rad²)) of an Imu, the stamp checked."""
    q, covariance = msg.orientation, msg.orientation_covariance
    return (check_stamp(time_from_msg(msg.header.stamp)), (q.x, q.y, q.z, q.w),
            (float(covariance[0]), float(covariance[4]), float(covariance[8])))


def write_statistics_vector(msg: Vector3Stamped, stamp_s: float, frame_id: str, roll: float, pitch: float,
                            meridional: float) -> Vector3Stamped:
    """Fill a Vector3Stamped in place with one statistic per channel: x roll, y pitch, z meridional (rad)."""
    _header(msg, stamp_s, frame_id)
    vector = msg.vector
    vector.x, vector.y, vector.z = float(roll), float(pitch), float(meridional)
    return msg


def attitude_quaternion_from_msg(msg: QuaternionStamped) -> AttitudeQuaternion:
    """AttitudeQuaternion from a QuaternionStamped (not normalised: the consumer validates)."""
    q = msg.quaternion
    return AttitudeQuaternion(time_from_msg(msg.header.stamp), msg.header.frame_id, [q.x, q.y, q.z, q.w])


def read_attitude_quaternion(msg: QuaternionStamped) -> tuple[float, tuple]:
    """(stamp_s, (x, y, z, w)) of a QuaternionStamped, checked as :class:`AttitudeQuaternion` checks them."""
    q = msg.quaternion
    return check_stamp(time_from_msg(msg.header.stamp)), (q.x, q.y, q.z, q.w)


# -------------------------------------------------------------------------- orbit

def _quaternion_of_axes(x, y, z) -> tuple[float, float, float, float]:
    """(x, y, z, w) of the rotation whose matrix has columns x, y, z (orthonormal, right-handed)."""
    m00, m11, m22 = x[0], y[1], z[2]
    trace = m00 + m11 + m22
    if trace > 0.0:  # Shepperd's method: divide by the largest of the four candidates
        s = 2.0 * math.sqrt(trace + 1.0)
        return ((y[2] - z[1]) / s, (z[0] - x[2]) / s, (x[1] - y[0]) / s, 0.25 * s)
    if m00 >= m11 and m00 >= m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        return (0.25 * s, (y[0] + x[1]) / s, (z[0] + x[2]) / s, (y[2] - z[1]) / s)
    if m11 >= m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        return ((y[0] + x[1]) / s, 0.25 * s, (z[1] + y[2]) / s, (z[0] - x[2]) / s)
    s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
    return ((z[0] + x[2]) / s, (z[1] + y[2]) / s, 0.25 * s, (x[1] - y[0]) / s)


def _rotate(q, v) -> tuple[float, float, float]:
    """The vector v (3-tuple) rotated by the unit quaternion q = (x, y, z, w): R(q)·v."""
    qx, qy, qz, qw = q
    vx, vy, vz = v
    # t = 2 q_vec × v;  R v = v + w t + q_vec × t
    tx, ty, tz = 2.0 * (qy * vz - qz * vy), 2.0 * (qz * vx - qx * vz), 2.0 * (qx * vy - qy * vx)
    return (vx + qw * tx + qy * tz - qz * ty, vy + qw * ty + qz * tx - qx * tz, vz + qw * tz + qx * ty - qy * tx)


def write_orbit_state(msg: Odometry, stamp_s: float, frame_id: str, child_frame_id: str, position_m,
                      velocity_m_s) -> Odometry:
    """Fill an Odometry in place from ECI position and velocity, by nav_msgs' rules; returns it.

    nav_msgs/Odometry: the pose is in ``header.frame_id``, the twist in
    ``child_frame_id``. So: pose.position = the position in ``frame_id``
    (ECI); pose.orientation = the orbital frame's orientation in ``frame_id``
    (:func:`pmv_ros.physics.orbit.two_body.orbital_axes_of_state`) — the child frame, ``orbital``; twist.linear = the
    velocity expressed in the orbital frame ((|v|, 0, 0) on a circular
    orbit); twist.angular = the orbital frame's rate relative to ECI in its
    own axes, (0, |r × v|/|r|², 0). ECI velocity = R(orientation)·twist.linear.
    Covariances are left as they are (zero in a message made by ``Odometry()``).
    """
    x, y, z = orbital_axes_of_state(position_m, velocity_m_s)  # one state: plain floats
    if not all(map(math.isfinite, (*x, *y, *z))):
        raise ValueError(f"position {position_m} and velocity {velocity_m_s} define no orbital frame")
    q = _quaternion_of_axes(x, y, z)
    vx, vy, vz = (float(c) for c in velocity_m_s)
    rx, ry, rz = (float(c) for c in position_m)
    _header(msg, stamp_s, frame_id)
    msg.child_frame_id = child_frame_id
    pose, twist = msg.pose.pose, msg.twist.twist
    pose.position.x, pose.position.y, pose.position.z = rx, ry, rz
    o = pose.orientation
    o.x, o.y, o.z, o.w = q
    # Velocity in the orbital frame: its components along X, Y, Z.
    v_orbital = tuple(a[0] * vx + a[1] * vy + a[2] * vz for a in (x, y, z))
    twist.linear.x, twist.linear.y, twist.linear.z = v_orbital
    radius2 = rx * rx + ry * ry + rz * rz
    h = math.sqrt(sum(c * c for c in (ry * vz - rz * vy, rz * vx - rx * vz, rx * vy - ry * vx)))
    twist.angular.x, twist.angular.y, twist.angular.z = 0.0, h / radius2, 0.0
    return msg


def orbit_state_from_msg(msg: Odometry) -> OrbitState:
    """OrbitState from an Odometry: position in ``header.frame_id``, velocity turned into it from the child frame."""
    stamp_s, position, velocity = read_orbit_state(msg)
    return OrbitState(stamp_s, msg.header.frame_id, msg.child_frame_id, position, velocity)


def read_orbit_state(msg: Odometry) -> tuple[float, tuple, tuple]:
    """(stamp_s, position_m, velocity_m_s) in ``header.frame_id`` of an Odometry, by nav_msgs' rules.

    The twist is in ``child_frame_id``, whose orientation in ``header.frame_id``
    is the pose's: velocity = R(orientation)·twist.linear. A zero or
    non-finite orientation is a ValueError (an Odometry that says nothing
    about where its twist points).
    """
    pose, v = msg.pose.pose, msg.twist.twist.linear
    p, o = pose.position, pose.orientation
    x, y, z, w = o.x, o.y, o.z, o.w  # each field read once: a message field is a property
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not (math.isfinite(norm) and norm > 0.0):
        raise ValueError(f"odometry orientation ({x}, {y}, {z}, {w}) is not a rotation")
    q = (x / norm, y / norm, z / norm, w / norm)
    return check_stamp(time_from_msg(msg.header.stamp)), (p.x, p.y, p.z), _rotate(q, (v.x, v.y, v.z))


# --------------------------------------------------------------------- transforms

def write_transform(msg: TransformStamped, stamp_s: float, parent_frame: str, child_frame: str, translation_m,
                    q_xyzw) -> TransformStamped:
    """Fill a TransformStamped in place: the pose of ``child_frame`` in ``parent_frame`` (tf2's rule); returns it."""
    _header(msg, stamp_s, parent_frame)
    msg.child_frame_id = child_frame
    transform = msg.transform
    t, r = transform.translation, transform.rotation
    t.x, t.y, t.z = (float(c) for c in translation_m)
    r.x, r.y, r.z, r.w = (float(c) for c in q_xyzw)
    return msg


def write_orbital_transform(msg: TransformStamped, odometry: Odometry) -> TransformStamped:
    """Fill a TransformStamped in place with the ``eci → orbital`` transform an /orbit/odometry message holds.

    nav_msgs puts the pose of ``child_frame_id`` (orbital) in ``header.frame_id``
    (ECI): position and orientation are the transform's translation and
    rotation, with the odometry's stamp (see :func:`write_orbit_state`).
    """
    header, pose = odometry.header, odometry.pose.pose
    msg.header.stamp.sec, msg.header.stamp.nanosec = header.stamp.sec, header.stamp.nanosec
    msg.header.frame_id, msg.child_frame_id = header.frame_id, odometry.child_frame_id
    transform = msg.transform
    t, r, p, o = transform.translation, transform.rotation, pose.position, pose.orientation
    t.x, t.y, t.z = p.x, p.y, p.z
    r.x, r.y, r.z, r.w = o.x, o.y, o.z, o.w
    return msg


def read_transform(msg: TransformStamped) -> tuple[float, str, str, tuple, tuple]:
    """(stamp_s, parent_frame, child_frame, translation_m, q_xyzw) of a TransformStamped."""
    t, r = msg.transform.translation, msg.transform.rotation
    return (check_stamp(time_from_msg(msg.header.stamp)), msg.header.frame_id, msg.child_frame_id,
            (t.x, t.y, t.z), (r.x, r.y, r.z, r.w))


# ------------------------------------------------------------------- diagnostics

def _level_to_msg(level: Level) -> bytes:
    return bytes([int(level)])


def _level_from_msg(value) -> Level:
    return Level(value[0] if isinstance(value, (bytes, bytearray)) else int(value))


def _number(value: float) -> str:
    return repr(float(value))


def _statistic(value: float) -> str:
    """A statistic for /pmv/error_statistics: ``repr`` of the float, :data:`PENDING` while it is not defined."""
    return statistic_text(float(value))


def _read_statistic(text: str) -> float:
    """The float of a /pmv/error_statistics value, NaN for :data:`PENDING` (and for "nan" of older recordings)."""
    return math.nan if text == PENDING else float(text)


def _write_statuses(msg: DiagnosticArray, stamp_s: float, statuses) -> DiagnosticArray:
    """Fill a DiagnosticArray from (name, level, message, hardware_id, [(key, value), …]) tuples.

    The message's own DiagnosticStatus and KeyValue objects are reused where
    the counts match (the same keys come back at every publication), and made
    anew where they do not; a field already holding its text is not set again
    (a message's setter checks its type: ≈ 0.3 µs, and /pmv/error_statistics
    has some 120 keys, most of them, and many values, the same as last time).
    """
    write_stamp(msg.header.stamp, stamp_s)
    targets = msg.status
    if len(targets) != len(statuses):
        targets = [DiagnosticStatus() for _ in statuses]
        msg.status = targets
    for target, (name, level, message, hardware_id, values) in zip(targets, statuses):
        target.level, target.name, target.message, target.hardware_id = (_level_to_msg(level), name, message,
                                                                         hardware_id)
        pairs = target.values
        if len(pairs) != len(values):
            pairs = [KeyValue() for _ in values]
            target.values = pairs
        for pair, (key, value) in zip(pairs, values):
            key, value = str(key), str(value)
            if pair.key != key:
                pair.key = key
            if pair.value != value:
                pair.value = value
    return msg


def _channel_level(channel: ChannelStatistics) -> tuple[Level, str]:
    """A channel's status: WARN with a reason until it has aligned samples."""
    return (Level.OK, "") if channel.count > 0 else (Level.WARN, "no aligned samples yet")


def _channel_values(channel: ChannelStatistics, oblateness_removed: bool) -> list[tuple[str, str]]:
    values = [
        ("count", str(channel.count)),
        ("mean_arcmin", _statistic(channel.mean_rad / ARCMIN_RAD)),
        ("sigma_arcmin", _statistic(channel.sigma_rad / ARCMIN_RAD)),
        ("three_sigma_arcmin", _statistic(channel.three_sigma_rad / ARCMIN_RAD)),
        ("limit_low_arcmin", _statistic(channel.limit_low_rad / ARCMIN_RAD)),
        ("limit_high_arcmin", _statistic(channel.limit_high_rad / ARCMIN_RAD)),
        ("max_abs_arcmin", _statistic(channel.max_abs_rad / ARCMIN_RAD)),
    ]
    values += [(f"harmonic_k{k:02d}_arcmin", _statistic(a / ARCMIN_RAD))
               for k, a in sorted(channel.harmonics_rad.items())]
    values += [
        ("ground_mean_m", _statistic(channel.ground_mean_m)),
        ("ground_sigma_m", _statistic(channel.ground_sigma_m)),
        ("ground_max_abs_m", _statistic(channel.ground_max_abs_m)),
        ("oblateness_removed", "true" if oblateness_removed else "false"),
    ]
    return values


def write_error_statistics(msg: DiagnosticArray, record: ErrorStatistics) -> DiagnosticArray:
    """Fill a DiagnosticArray in place for /pmv/error_statistics: a status per channel, then the counters
    (layout above); returns it."""
    statuses = [(STATISTICS_STATUS_PREFIX + c.channel, *_channel_level(c), record.hardware_id,
                 _channel_values(c, record.oblateness_removed)) for c in record.channels]
    counters = record.counters
    used = counters.get("used", 0)
    skipped = sum(v for k, v in counters.items() if k.startswith("skipped_"))
    rejected = sum(v for k, v in counters.items() if k.startswith("rejected_"))
    statuses.append((SAMPLES_STATUS_NAME, Level.OK if used else Level.WARN,
                     f"{used} used, {skipped} skipped, {rejected} rejected", record.hardware_id,
                     [(k, str(v)) for k, v in counters.items()]
                     + [("oblateness_removed", "true" if record.oblateness_removed else "false")]))
    return _write_statuses(msg, record.stamp_s, statuses)


def error_statistics_from_msg(msg: DiagnosticArray) -> ErrorStatistics:
    """ErrorStatistics from a /pmv/error_statistics DiagnosticArray (derived keys — 3σ, the limits — and the
    channel levels, which follow from the counts, are not read)."""
    channels, counters, removed, hardware_id = [], {}, True, "pmv"
    for status in msg.status:
        if not status.name.startswith(STATISTICS_STATUS_PREFIX):
            continue
        values = {kv.key: kv.value for kv in status.values}
        hardware_id = status.hardware_id
        removed = values.get("oblateness_removed", "true") == "true"
        if status.name == SAMPLES_STATUS_NAME:
            counters = {k: int(v) for k, v in values.items() if k != "oblateness_removed"}
            continue
        channel = status.name[len(STATISTICS_STATUS_PREFIX):]
        if channel not in CHANNELS:
            continue

        def angle(key):
            return _read_statistic(values.get(key, PENDING)) * ARCMIN_RAD

        harmonics = {int(m.group(1)): _read_statistic(v) * ARCMIN_RAD
                     for k, v in values.items() if (m := _HARMONIC_KEY.match(k))}
        channels.append(ChannelStatistics(
            channel=channel, count=int(values.get("count", "0")), mean_rad=angle("mean_arcmin"),
            sigma_rad=angle("sigma_arcmin"), max_abs_rad=angle("max_abs_arcmin"), harmonics_rad=harmonics,
            ground_mean_m=_read_statistic(values.get("ground_mean_m", PENDING)),
            ground_sigma_m=_read_statistic(values.get("ground_sigma_m", PENDING)),
            ground_max_abs_m=_read_statistic(values.get("ground_max_abs_m", PENDING))))
    return ErrorStatistics(time_from_msg(msg.header.stamp), tuple(channels), counters, removed, hardware_id)


def write_health(msg: DiagnosticArray, record: HealthReport) -> DiagnosticArray:
    """Fill a DiagnosticArray in place for /diagnostics (see "Writers" above); returns it."""
    return _write_statuses(msg, record.stamp_s, [(s.name, s.level, s.message, s.hardware_id, s.values)
                                                 for s in record.statuses])


def health_from_msg(msg: DiagnosticArray) -> HealthReport:
    """HealthReport from a /diagnostics DiagnosticArray."""
    statuses = tuple(HealthStatus(s.name, _level_from_msg(s.level), s.message, s.hardware_id,
                                  tuple((kv.key, kv.value) for kv in s.values)) for s in msg.status)
    return HealthReport(time_from_msg(msg.header.stamp), statuses)


# --------------------------------------------------------------- star-tracker frames

#: Name of the status a /star_tracker/frame_status message carries.
FRAME_STATUS_NAME = "star_tracker: frame"
#: The reasons a frame status may give, its ``reason`` value: the star tracker's outcome codes (physics.md §6) by
#: name, "ok" for a frame that gave an attitude.
FRAME_REASONS = tuple(outcome.reason for outcome in Outcome)


def write_frame_status(msg: DiagnosticArray, stamp_s: float, reason: str, stars: int, hits: int,
                       hardware_id: str = "star_tracker") -> DiagnosticArray:
    """Fill a /star_tracker/frame_status DiagnosticArray in place: one status for one frame stamped with its time
    (the middle of the exposure): level OK with an attitude, WARN without; ``reason`` one of
    :data:`FRAME_REASONS`, the catalogue stars in the field and the proton hits as values. Returns it."""
    if reason not in FRAME_REASONS:
        raise ValueError(f"frame reason {reason!r} is not one of {FRAME_REASONS}")
    return _write_statuses(msg, stamp_s, [(FRAME_STATUS_NAME, Level.OK if reason == "ok" else Level.WARN,
                                           reason, hardware_id, (("reason", reason), ("stars_in_field", int(stars)),
                                                                 ("proton_hits", int(hits))))])


def frame_status_input(msg: DiagnosticArray) -> tuple:
    """(stamp s, reason) of a /star_tracker/frame_status message; (None, None) when it is not one (no status of
    that name, an unknown reason, a bad stamp)."""
    try:
        stamp = check_stamp(time_from_msg(msg.header.stamp))
    except ValueError:
        return None, None
    for status in msg.status:
        if status.name == FRAME_STATUS_NAME:
            for pair in status.values:
                if pair.key == "reason" and pair.value in FRAME_REASONS:
                    return stamp, pair.value
            break
    return None, None


# ------------------------------------------------------------------ node inputs
# What a node's subscription hands its runtime: the frame ids and the values, None where a message is unreadable
# (the runtime counts it); these never raise.

def angles_input(msg: Vector3Stamped) -> tuple:
    """(frame id, stamp s, roll rad, pitch rad) of a Vector3Stamped; None for the three when unreadable."""
    try:
        return (msg.header.frame_id, *read_attitude_angles(msg))
    except ValueError:  # a negative or non-finite stamp
        return msg.header.frame_id, None, None, None


def quaternion_input(msg: QuaternionStamped) -> tuple:
    """(frame id, stamp s, (x, y, z, w)) of a QuaternionStamped; None for both when unreadable."""
    try:
        return (msg.header.frame_id, *read_attitude_quaternion(msg))
    except ValueError:
        return msg.header.frame_id, None, None


def odometry_input(msg: Odometry) -> tuple:
    """(frame id, child frame id, (stamp s, position m, velocity m/s) or None) of an Odometry."""
    try:
        state = read_orbit_state(msg)
    except ValueError:  # an orientation that is no rotation, or a bad stamp
        state = None
    return msg.header.frame_id, msg.child_frame_id, state
