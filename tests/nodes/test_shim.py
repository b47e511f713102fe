"""pmv_msgs_shim: records <-> standard messages, round trips without rclpy.init()."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PolygonStamped, Quaternion, QuaternionStamped, Vector3, Vector3Stamped
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Header

from pmv_ros.analysis.statistics import ChannelStatistics
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_msgs_shim import (
    SAMPLES_STATUS_NAME,
    STATISTICS_STATUS_PREFIX,
    AttitudeAngles,
    AttitudeQuaternion,
    ErrorStatistics,
    HealthReport,
    HealthStatus,
    HorizonCrossings,
    Level,
    OrbitState,
    attitude_angles_from_msg,
    attitude_quaternion_from_msg,
    checked_lines_of_sight,
    error_statistics_from_msg,
    health_from_msg,
    horizon_crossings_from_msg,
    orbit_state_from_msg,
    read_attitude_angles,
    read_attitude_quaternion,
    read_orbit_state,
    time_from_msg,
    write_attitude_angles,
    write_attitude_quaternion,
    write_clock,
    write_error_statistics,
    write_health,
    write_horizon_crossings,
    write_orbit_state,
    write_stamp,
)

pytestmark = [pytest.mark.multi_process]


def test_frame_ids_are_the_documented_names():
    from pmv_msgs_shim import BODY_FRAME, ECI_FRAME, ORBITAL_FRAME, SENSOR_FRAME

    assert (SENSOR_FRAME, ORBITAL_FRAME, ECI_FRAME, BODY_FRAME) == ("pmv_sensor", "orbital", "eci", "base_link")


def test_importing_the_shim_and_the_core_does_not_import_rclpy():
    code = ("import sys, pmv_msgs_shim, pmv_ros.runtime.monitor.core, pmv_ros.analysis.statistics, "
            "pmv_ros.physics.ground_error;"
            "sys.exit(1 if 'rclpy' in sys.modules else 0)")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0
    code = ("import sys, pmv_ros.runtime.monitor.core, pmv_ros.analysis.statistics, pmv_ros.physics.ground_error;"
            "sys.exit(1 if any(m.endswith('_msgs') or m == 'rclpy' for m in sys.modules) else 0)")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


@pytest.mark.parametrize("stamp", [0.0, 1.5, 12345.000000001, 1_700_000_000.123456])
def test_time_round_trip(stamp):
    msg = write_stamp(Time(), stamp)
    assert 0 <= msg.nanosec < 1_000_000_000
    # Nanosecond rounding, and float64 resolves ~0.2 µs at 1.7e9 s.
    assert time_from_msg(msg) == pytest.approx(stamp, abs=max(1e-9, stamp * 2.3e-16))


def test_clock_round_trip():
    from pmv_msgs_shim import clock_from_msg

    msg = write_clock(Clock(), 86400.25)
    assert (msg.clock.sec, msg.clock.nanosec) == (86400, 250_000_000)
    assert clock_from_msg(msg) == 86400.25


def test_time_carries_into_the_second_and_rejects_bad_stamps():
    msg = write_stamp(Time(), 1.9999999999)
    assert (msg.sec, msg.nanosec) == (2, 0)
    for bad in (-1.0, math.nan, math.inf, 2.0**31):
        with pytest.raises(ValueError, match="stamp_s"):
            write_stamp(Time(), bad)


def test_horizon_crossings_round_trip_with_an_invalid_chord():
    rng = np.random.default_rng(5)
    vectors = rng.normal(size=(4, 3))
    vectors /= np.linalg.norm(vectors, axis=1)[:, None]
    record = HorizonCrossings(42.25, "pmv_sensor", vectors, [True, False, True, True])
    msg = write_horizon_crossings(PolygonStamped(), record.stamp_s, record.frame_id, record.line_of_sight.tolist())
    assert isinstance(msg, PolygonStamped) and len(msg.polygon.points) == 4
    assert all(math.isnan(c) for c in (msg.polygon.points[1].x, msg.polygon.points[1].y, msg.polygon.points[1].z))
    back = horizon_crossings_from_msg(msg)
    assert back.stamp_s == 42.25 and back.frame_id == "pmv_sensor"
    assert list(back.valid) == [True, False, True, True]
    # Point32 is float32: 1e-7 is its resolution on unit vectors.
    assert np.allclose(back.line_of_sight[record.valid], vectors[record.valid], atol=1e-7)
    assert np.all(np.isnan(back.line_of_sight[1]))


def test_horizon_crossings_validation():
    with pytest.raises(ValueError, match="unit"):
        HorizonCrossings(1.0, line_of_sight=np.ones((4, 3)), valid=[True] * 4)
    with pytest.raises(ValueError, match="shape"):
        HorizonCrossings(1.0, line_of_sight=np.ones((3, 3)), valid=[True] * 3)
    msg = PolygonStamped()
    with pytest.raises(ValueError, match="4 points"):
        horizon_crossings_from_msg(msg)
    record = HorizonCrossings(1.0)
    with pytest.raises(ValueError):
        record.valid[0] = True                  # frozen arrays


def test_attitude_angles_round_trip():
    record = AttitudeAngles(7.5, "pmv_sensor", 1.25e-3, -4.5e-4)
    msg = write_attitude_angles(Vector3Stamped(), record.stamp_s, record.frame_id, record.roll_rad, record.pitch_rad)
    assert isinstance(msg, Vector3Stamped)
    assert (msg.vector.x, msg.vector.y, msg.vector.z) == (1.25e-3, -4.5e-4, 0.0)
    assert attitude_angles_from_msg(msg) == record


def test_attitude_quaternion_and_orbit_state_round_trip():
    q = AttitudeQuaternion(3.0, "orbital", [0.1, -0.2, 0.3, math.sqrt(1 - 0.14)])
    back = attitude_quaternion_from_msg(write_attitude_quaternion(QuaternionStamped(), q.stamp_s, q.frame_id,
                                                                  q.q_xyzw.tolist()))
    assert back.frame_id == "orbital" and np.array_equal(back.q_xyzw, q.q_xyzw)
    state = OrbitState(9.0, "eci", "orbital", [6871e3, 1.5, -2.0], [0.1, 7612.0, 3.3])
    msg = write_orbit_state(Odometry(), state.stamp_s, state.frame_id, state.child_frame_id,
                            state.position_m.tolist(), state.velocity_m_s.tolist())
    assert msg.child_frame_id == "orbital"
    back = orbit_state_from_msg(msg)
    # Through the orbital frame and back: to rounding of a rotation (1e-12 relative).
    assert np.array_equal(back.position_m, state.position_m)
    np.testing.assert_allclose(back.velocity_m_s, state.velocity_m_s, rtol=0, atol=1e-9)
    assert (back.stamp_s, back.frame_id, back.child_frame_id) == (9.0, "eci", "orbital")


def _rotation_matrix(q):
    """Rotation matrix of a unit quaternion (x, y, z, w), written out here independently of the shim."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def test_odometry_follows_nav_msgs_frames_and_gives_the_eci_velocity_back():
    # nav_msgs/Odometry: pose in header.frame_id, twist in child_frame_id. The child frame is the
    # orbital frame (Z radial up, X towards the velocity in the orbit plane, Y = Z × X), so a
    # user rebuilds the ECI velocity as R(pose.orientation) · twist.linear — nothing else.
    rng = np.random.default_rng(3)
    for _ in range(20):
        position = rng.normal(size=3)
        position *= 6871e3 / np.linalg.norm(position)
        velocity = np.cross(rng.normal(size=3), position)
        velocity *= 7612.0 / np.linalg.norm(velocity)
        velocity += rng.normal(scale=50.0, size=3)  # not exactly circular
        msg = write_orbit_state(Odometry(), 1.0, "eci", "orbital", position, velocity)
        o = msg.pose.pose.orientation
        rotation = _rotation_matrix((o.x, o.y, o.z, o.w))
        twist = np.array([msg.twist.twist.linear.x, msg.twist.twist.linear.y, msg.twist.twist.linear.z])
        np.testing.assert_allclose(rotation @ twist, velocity, atol=1e-8)
        # The orientation means the orbital frame: its Z column is the radial direction, its X
        # column lies in the orbit plane ahead, so the twist has no component off the plane.
        np.testing.assert_allclose(rotation[:, 2], position / np.linalg.norm(position), atol=1e-12)
        assert abs(twist[1]) < 1e-8 and twist[0] > 0.0
        assert msg.twist.twist.angular.y == pytest.approx(
            np.linalg.norm(np.cross(position, velocity)) / np.linalg.norm(position) ** 2, rel=1e-12)
    unknown = Odometry()
    unknown.pose.pose.orientation.w = 0.0  # an all-zero quaternion: the twist's frame is unknown
    with pytest.raises(ValueError, match="orientation"):
        read_orbit_state(unknown)


def test_writers_fill_a_reused_message_exactly_as_a_fresh_one():
    # The hot paths reuse one message per topic: whatever the message held before, a write
    # must leave it equal to a fresh message written with the same values.
    rng = np.random.default_rng(11)
    vectors = rng.normal(size=(4, 3))
    vectors /= np.linalg.norm(vectors, axis=1)[:, None]
    crossings = HorizonCrossings(12.5, "pmv_sensor", vectors, [True, True, False, True])
    angles = AttitudeAngles(12.5, "pmv_sensor", 2.5e-4, -1.25e-4)
    quaternion = AttitudeQuaternion(12.5, "orbital", [0.1, -0.2, 0.3, math.sqrt(1 - 0.14)])
    state = OrbitState(12.5, "eci", "orbital", [6871e3, 1.5, -2.0], [0.1, 7612.0, 3.3])
    reused = {"crossings": PolygonStamped(), "angles": Vector3Stamped(), "quaternion": QuaternionStamped(),
              "state": Odometry(), "clock": Clock()}
    for round_ in range(2):  # the second round writes over the first one's values
        stamp = 12.5 + round_
        crossings_now = HorizonCrossings(stamp, "pmv_sensor", crossings.line_of_sight, crossings.valid)
        assert write_horizon_crossings(reused["crossings"], stamp, "pmv_sensor",
                                       crossings_now.line_of_sight.tolist()) is reused["crossings"]
        written = horizon_crossings_from_msg(reused["crossings"])
        built = horizon_crossings_from_msg(write_horizon_crossings(PolygonStamped(), stamp, "pmv_sensor",
                                                                   crossings_now.line_of_sight.tolist()))
        assert written.stamp_s == built.stamp_s and np.array_equal(written.valid, built.valid)
        assert np.array_equal(written.line_of_sight, built.line_of_sight, equal_nan=True)
        assert write_attitude_angles(reused["angles"], stamp, "pmv_sensor", angles.roll_rad * (1 + round_),
                                     angles.pitch_rad) == Vector3Stamped(
            header=Header(stamp=Time(sec=12 + round_, nanosec=500_000_000), frame_id="pmv_sensor"),
            vector=Vector3(x=angles.roll_rad * (1 + round_), y=angles.pitch_rad, z=0.0))
        assert write_attitude_quaternion(reused["quaternion"], stamp, "orbital", quaternion.q_xyzw.tolist()) == \
            QuaternionStamped(header=Header(stamp=Time(sec=12 + round_, nanosec=500_000_000), frame_id="orbital"),
                              quaternion=Quaternion(x=0.1, y=-0.2, z=0.3, w=math.sqrt(1 - 0.14)))
        assert write_orbit_state(reused["state"], stamp, "eci", "orbital", state.position_m.tolist(),
                                 (state.velocity_m_s * (1 + round_)).tolist()) == \
            write_orbit_state(Odometry(), stamp, "eci", "orbital", state.position_m, state.velocity_m_s * (1 + round_))
        assert write_clock(reused["clock"], stamp) == Clock(clock=Time(sec=12 + round_, nanosec=500_000_000))
    with pytest.raises(ValueError, match="stamp"):
        write_attitude_angles(Vector3Stamped(), -1.0, "pmv_sensor", 0.0, 0.0)


def test_readers_return_what_the_records_hold_and_check_the_stamp():
    quaternion = AttitudeQuaternion(3.25, "orbital", [0.1, -0.2, 0.3, math.sqrt(1 - 0.14)])
    stamp, q = read_attitude_quaternion(write_attitude_quaternion(QuaternionStamped(), quaternion.stamp_s,
                                                                  quaternion.frame_id, quaternion.q_xyzw.tolist()))
    assert stamp == 3.25 and q == tuple(quaternion.q_xyzw.tolist())
    assert read_attitude_angles(write_attitude_angles(Vector3Stamped(), 3.25, "pmv_sensor", 1e-3, -2e-3)) == \
        (3.25, 1e-3, -2e-3)
    state = OrbitState(3.25, "eci", "orbital", [6871e3, 1.5, -2.0], [0.1, 7612.0, 3.3])
    stamp, position, velocity = read_orbit_state(write_orbit_state(Odometry(), state.stamp_s, state.frame_id,
                                                                   state.child_frame_id, state.position_m.tolist(),
                                                                   state.velocity_m_s.tolist()))
    assert (stamp, position) == (3.25, (6871e3, 1.5, -2.0))
    np.testing.assert_allclose(velocity, (0.1, 7612.0, 3.3), rtol=0, atol=1e-9)
    negative = Vector3Stamped()
    negative.header.stamp.sec = -5
    for read in (read_attitude_angles, attitude_angles_from_msg):
        with pytest.raises(ValueError, match="stamp"):
            read(negative)


def test_lines_of_sight_of_a_block_are_checked_like_one_record():
    rng = np.random.default_rng(3)
    block = rng.normal(size=(6, 4, 3))
    block /= np.linalg.norm(block, axis=2)[:, :, None]
    valid = rng.random((6, 4)) > 0.3
    original = block.copy()
    checked = checked_lines_of_sight(block, valid)
    for k in range(6):
        one = HorizonCrossings(1.0, "pmv_sensor", block[k], valid[k]).line_of_sight
        assert np.array_equal(checked[k], one, equal_nan=True)
    assert np.isnan(checked[~valid]).all() and np.array_equal(block, original)  # a new array: the input stays
    block[2, 1] *= 1.01
    valid[2, 1] = True
    with pytest.raises(ValueError, match="unit"):
        checked_lines_of_sight(block, valid)
    with pytest.raises(ValueError, match="shape"):
        checked_lines_of_sight(block[:, :3], valid[:, :3])


def _statistics_record():
    roll = ChannelStatistics("roll", 120, 2.0 * ARCMIN_RAD, 0.5 * ARCMIN_RAD, 3.25 * ARCMIN_RAD,
                             {1: 4.9 * ARCMIN_RAD, 2: 0.01 * ARCMIN_RAD, 20: math.nan}, -290.0, 72.5, 480.0)
    pitch = ChannelStatistics("pitch", 0)  # no aligned samples yet: WARN on the wire
    meridional = ChannelStatistics("meridional", 120, 2.1 * ARCMIN_RAD, 0.4 * ARCMIN_RAD, 3.3 * ARCMIN_RAD,
                                   {1: 0.2 * ARCMIN_RAD})
    counters = {"used": 120, "skipped_stale_truth": 7, "rejected_truth_duplicate": 2}
    return ErrorStatistics(100.0, (roll, pitch, meridional), counters, oblateness_removed=False)


def test_error_statistics_wire_layout_is_in_arcmin_for_people():
    msg = write_error_statistics(DiagnosticArray(), _statistics_record())
    assert isinstance(msg, DiagnosticArray)
    names = [s.name for s in msg.status]
    assert names == [STATISTICS_STATUS_PREFIX + c for c in ("roll", "pitch", "meridional")] + [SAMPLES_STATUS_NAME]
    roll = {kv.key: kv.value for kv in msg.status[0].values}
    assert float(roll["mean_arcmin"]) == pytest.approx(2.0, abs=1e-12)
    assert float(roll["three_sigma_arcmin"]) == pytest.approx(1.5, abs=1e-12)
    assert float(roll["limit_high_arcmin"]) == pytest.approx(3.5, abs=1e-12)
    assert float(roll["limit_low_arcmin"]) == pytest.approx(0.5, abs=1e-12)
    assert float(roll["harmonic_k01_arcmin"]) == pytest.approx(4.9, abs=1e-12)
    assert roll["harmonic_k20_arcmin"] == "pending" and roll["count"] == "120"  # not defined yet: never "nan"
    assert roll["ground_mean_m"] == "-290.0" and roll["oblateness_removed"] == "false"
    assert msg.status[0].level == DiagnosticStatus.OK
    assert msg.status[1].level == DiagnosticStatus.WARN and msg.status[1].message == "no aligned samples yet"
    samples = {kv.key: kv.value for kv in msg.status[3].values}
    assert samples["skipped_stale_truth"] == "7"
    assert "120 used, 7 skipped, 2 rejected" == msg.status[3].message


def test_error_statistics_round_trip():
    record = _statistics_record()
    back = error_statistics_from_msg(write_error_statistics(DiagnosticArray(), record))
    assert back.stamp_s == 100.0 and back.oblateness_removed is False and back.counters == record.counters
    for original, returned in zip(record.channels, back.channels):
        assert returned.channel == original.channel and returned.count == original.count
        for name in ("mean_rad", "sigma_rad", "three_sigma_rad", "max_abs_rad", "ground_mean_m"):
            a, b = getattr(original, name), getattr(returned, name)
            assert (math.isnan(a) and math.isnan(b)) or b == pytest.approx(a, rel=1e-14), name
        assert set(returned.harmonics_rad) == set(original.harmonics_rad)
        for k, a in original.harmonics_rad.items():
            b = returned.harmonics_rad[k]
            assert (math.isnan(a) and math.isnan(b)) or b == pytest.approx(a, rel=1e-14)


def test_error_statistics_from_a_monitor_summary():
    from pmv_ros.runtime.monitor.core import ErrorMonitor
    from pmv_ros.runtime.monitor.records import MonitorConfig

    monitor = ErrorMonitor(MonitorConfig(orbital_period_s=600.0, remove_oblateness=False))
    monitor.add_truth(1.0, 0.0, 0.0)
    monitor.add_truth(2.0, 0.0, 0.0)
    monitor.add_sensor(1.5, 3 * ARCMIN_RAD, -4 * ARCMIN_RAD)
    record = ErrorStatistics.from_summary(monitor.summary(), stamp_s=2.0)
    msg = write_error_statistics(DiagnosticArray(), record)
    values = {kv.key: kv.value for kv in error_statistics_from_msg_status(msg, "meridional")}
    assert float(values["mean_arcmin"]) == pytest.approx(5.0, abs=1e-9)      # √(3² + 4²)
    assert record.counters["used"] == 1


def error_statistics_from_msg_status(msg, channel):
    return next(s for s in msg.status if s.name == STATISTICS_STATUS_PREFIX + channel).values


def test_diagnostics_writers_reuse_a_message_whatever_it_held():
    # /diagnostics and /pmv/error_statistics reuse one message each: statuses and keys that
    # change in number between publications must come out as a fresh message would.
    first = HealthReport(5.0, (HealthStatus("a", Level.WARN, "one", "hw", {"k1": "1", "k2": "2", "k3": "3"}),
                               HealthStatus("b", Level.OK, "two", "hw", {"x": "y"})))
    second = HealthReport(6.0, (HealthStatus("c", Level.ERROR, "three", "hw2", {"k1": "9"}),))
    third = HealthReport(7.0, (HealthStatus("d", Level.OK, "four", "hw3", {"z1": "7"}),))
    reused = DiagnosticArray()
    for report in (first, second, third, first):
        assert write_health(reused, report) is reused
        assert reused == write_health(DiagnosticArray(), report)
        assert health_from_msg(reused) == report
    statistics = _statistics_record()
    reused = write_health(DiagnosticArray(), first)
    for record in (statistics, ErrorStatistics(101.0, statistics.channels[:1], {"used": 3}, True)):
        assert write_error_statistics(reused, record) == write_error_statistics(DiagnosticArray(), record)


def test_health_round_trip_and_channel_errors():
    report = HealthReport(5.0, (HealthStatus("pmv sensor: chord +X", Level.ERROR, "horizon lost", "pmv",
                                             {"chord": "+X", "since_s": "4.5"}),
                                HealthStatus("pmv star tracker", Level.STALE, "outage")))
    msg = write_health(DiagnosticArray(), report)
    assert msg.status[0].level == DiagnosticStatus.ERROR and msg.status[1].level == DiagnosticStatus.STALE
    back = health_from_msg(msg)
    assert back == report
    with pytest.raises(ValueError, match="channel"):
        ChannelStatistics("yaw")
