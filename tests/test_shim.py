"""pmv_msgs_shim: records <-> standard messages, round trips without rclpy.init()."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PolygonStamped, Vector3Stamped

from pmv_msgs_shim import (
    ARCMIN_RAD,
    SAMPLES_STATUS_NAME,
    STATISTICS_STATUS_PREFIX,
    AttitudeAngles,
    AttitudeQuaternion,
    ChannelStatistics,
    ErrorStatistics,
    HealthReport,
    HealthStatus,
    HorizonCrossings,
    Level,
    OrbitState,
    attitude_angles_from_msg,
    attitude_quaternion_from_msg,
    error_statistics_from_msg,
    health_from_msg,
    horizon_crossings_from_msg,
    orbit_state_from_msg,
    time_from_msg,
    time_to_msg,
    to_msg,
)


def test_frame_ids_are_the_documented_names():
    from pmv_msgs_shim import BODY_FRAME, ECI_FRAME, ORBITAL_FRAME, SENSOR_FRAME

    assert (SENSOR_FRAME, ORBITAL_FRAME, ECI_FRAME, BODY_FRAME) == ("pmv_sensor", "orbital", "eci", "body")


def test_importing_the_shim_and_the_core_does_not_import_rclpy():
    code = ("import sys, pmv_msgs_shim, pmv_ros.core.monitor, pmv_ros.core.statistics, pmv_ros.core.ground_error;"
            "sys.exit(1 if 'rclpy' in sys.modules else 0)")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0
    code = ("import sys, pmv_ros.core.monitor, pmv_ros.core.statistics, pmv_ros.core.ground_error;"
            "sys.exit(1 if any(m.endswith('_msgs') or m == 'rclpy' for m in sys.modules) else 0)")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


@pytest.mark.parametrize("stamp", [0.0, 1.5, 12345.000000001, 1_700_000_000.123456])
def test_time_round_trip(stamp):
    msg = time_to_msg(stamp)
    assert 0 <= msg.nanosec < 1_000_000_000
    # Nanosecond rounding, and float64 resolves ~0.2 µs at 1.7e9 s.
    assert time_from_msg(msg) == pytest.approx(stamp, abs=max(1e-9, stamp * 2.3e-16))


def test_clock_round_trip():
    from pmv_msgs_shim import clock_from_msg, clock_to_msg

    msg = clock_to_msg(86400.25)
    assert (msg.clock.sec, msg.clock.nanosec) == (86400, 250_000_000)
    assert clock_from_msg(msg) == 86400.25


def test_time_carries_into_the_second_and_rejects_bad_stamps():
    msg = time_to_msg(1.9999999999)
    assert (msg.sec, msg.nanosec) == (2, 0)
    for bad in (-1.0, math.nan, math.inf, 2.0**31):
        with pytest.raises(ValueError, match="stamp_s"):
            time_to_msg(bad)


def test_horizon_crossings_round_trip_with_an_invalid_chord():
    rng = np.random.default_rng(5)
    vectors = rng.normal(size=(4, 3))
    vectors /= np.linalg.norm(vectors, axis=1)[:, None]
    record = HorizonCrossings(42.25, "pmv_sensor", vectors, [True, False, True, True])
    msg = to_msg(record)
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
    msg = to_msg(record)
    assert isinstance(msg, Vector3Stamped)
    assert (msg.vector.x, msg.vector.y, msg.vector.z) == (1.25e-3, -4.5e-4, 0.0)
    assert attitude_angles_from_msg(msg) == record


def test_attitude_quaternion_and_orbit_state_round_trip():
    q = AttitudeQuaternion(3.0, "orbital", [0.1, -0.2, 0.3, math.sqrt(1 - 0.14)])
    back = attitude_quaternion_from_msg(to_msg(q))
    assert back.frame_id == "orbital" and np.array_equal(back.q_xyzw, q.q_xyzw)
    state = OrbitState(9.0, "eci", "body", [6871e3, 1.5, -2.0], [0.1, 7612.0, 3.3])
    msg = to_msg(state)
    assert msg.child_frame_id == "body" and msg.pose.pose.orientation.w == 1.0
    back = orbit_state_from_msg(msg)
    assert np.array_equal(back.position_m, state.position_m) and np.array_equal(back.velocity_m_s, state.velocity_m_s)
    assert (back.stamp_s, back.frame_id, back.child_frame_id) == (9.0, "eci", "body")


def _statistics_record():
    roll = ChannelStatistics("roll", 120, 2.0 * ARCMIN_RAD, 0.5 * ARCMIN_RAD, 1.5 * ARCMIN_RAD, 3.25 * ARCMIN_RAD,
                             {1: 4.9 * ARCMIN_RAD, 2: 0.01 * ARCMIN_RAD, 20: math.nan}, -290.0, 72.5, 480.0)
    pitch = ChannelStatistics("pitch", 0, level=Level.WARN, message="no aligned samples yet")
    meridional = ChannelStatistics("meridional", 120, 2.1 * ARCMIN_RAD, 0.4 * ARCMIN_RAD, 1.2 * ARCMIN_RAD,
                                   3.3 * ARCMIN_RAD, {1: 0.2 * ARCMIN_RAD})
    counters = {"used": 120, "skipped_stale_truth": 7, "rejected_truth_duplicate": 2}
    return ErrorStatistics(100.0, (roll, pitch, meridional), counters, oblateness_removed=False)


def test_error_statistics_wire_layout_is_in_arcmin_for_people():
    msg = to_msg(_statistics_record())
    assert isinstance(msg, DiagnosticArray)
    names = [s.name for s in msg.status]
    assert names == [STATISTICS_STATUS_PREFIX + c for c in ("roll", "pitch", "meridional")] + [SAMPLES_STATUS_NAME]
    roll = {kv.key: kv.value for kv in msg.status[0].values}
    assert float(roll["mean_arcmin"]) == pytest.approx(2.0, abs=1e-12)
    assert float(roll["three_sigma_arcmin"]) == pytest.approx(1.5, abs=1e-12)
    assert float(roll["limit_high_arcmin"]) == pytest.approx(3.5, abs=1e-12)
    assert float(roll["limit_low_arcmin"]) == pytest.approx(0.5, abs=1e-12)
    assert float(roll["harmonic_k01_arcmin"]) == pytest.approx(4.9, abs=1e-12)
    assert roll["harmonic_k20_arcmin"] == "nan" and roll["count"] == "120"
    assert roll["ground_mean_m"] == "-290.0" and roll["oblateness_removed"] == "false"
    assert msg.status[1].level == DiagnosticStatus.WARN
    samples = {kv.key: kv.value for kv in msg.status[3].values}
    assert samples["skipped_stale_truth"] == "7"
    assert "120 used, 7 skipped, 2 rejected" == msg.status[3].message


def test_error_statistics_round_trip():
    record = _statistics_record()
    back = error_statistics_from_msg(to_msg(record))
    assert back.stamp_s == 100.0 and back.oblateness_removed is False and back.counters == record.counters
    for original, returned in zip(record.channels, back.channels):
        assert returned.channel == original.channel and returned.count == original.count
        assert returned.level == original.level and returned.message == original.message
        for name in ("mean_rad", "sigma_rad", "three_sigma_rad", "max_abs_rad", "ground_mean_m"):
            a, b = getattr(original, name), getattr(returned, name)
            assert (math.isnan(a) and math.isnan(b)) or b == pytest.approx(a, rel=1e-14), name
        assert set(returned.harmonics_rad) == set(original.harmonics_rad)
        for k, a in original.harmonics_rad.items():
            b = returned.harmonics_rad[k]
            assert (math.isnan(a) and math.isnan(b)) or b == pytest.approx(a, rel=1e-14)


def test_error_statistics_from_a_monitor_summary():
    from pmv_ros.core.monitor import ErrorMonitor, MonitorConfig

    monitor = ErrorMonitor(MonitorConfig(orbital_period_s=600.0, remove_oblateness=False))
    monitor.add_truth(1.0, 0.0, 0.0)
    monitor.add_truth(2.0, 0.0, 0.0)
    monitor.add_sensor(1.5, 3 * ARCMIN_RAD, -4 * ARCMIN_RAD)
    record = ErrorStatistics.from_summary(monitor.summary(), stamp_s=2.0)
    values = {kv.key: kv.value for kv in error_statistics_from_msg_status(to_msg(record), "meridional")}
    assert float(values["mean_arcmin"]) == pytest.approx(5.0, abs=1e-9)      # √(3² + 4²)
    assert record.counters["used"] == 1


def error_statistics_from_msg_status(msg, channel):
    return next(s for s in msg.status if s.name == STATISTICS_STATUS_PREFIX + channel).values


def test_health_round_trip_and_dispatch_errors():
    report = HealthReport(5.0, (HealthStatus("pmv sensor: chord +X", Level.ERROR, "horizon lost", "pmv",
                                             {"chord": "+X", "since_s": "4.5"}),
                                HealthStatus("pmv star tracker", Level.STALE, "outage")))
    msg = to_msg(report)
    assert msg.status[0].level == DiagnosticStatus.ERROR and msg.status[1].level == DiagnosticStatus.STALE
    back = health_from_msg(msg)
    assert back == report
    with pytest.raises(TypeError):
        to_msg(object())
    with pytest.raises(ValueError, match="channel"):
        ChannelStatistics("yaw")
