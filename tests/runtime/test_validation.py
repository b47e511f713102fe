"""The input validators (pmv_ros.runtime.common.validation) and what they guarantee the statistics, property-based.

Hypothesis draws any float — NaN, ±Inf, ±1e308, subnormals, −0.0 — into the
validators and through the monitor core, and checks the promises: nothing
raises, what is accepted is finite and within its bound, and no statistic
ever becomes ±Inf.
"""

from __future__ import annotations

import math
import os
import threading

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.orbit.two_body import CircularOrbit
from pmv_ros.runtime.monitor.core import ErrorMonitor
from pmv_ros.runtime.monitor.records import MonitorConfig
from pmv_ros.runtime.common.validation import (
    QUATERNION_NORM_TOLERANCE,
    InputBounds,
    Jump,
    JumpDetector,
    FrameCheck,
    Rejection,
    StampCheck,
    check_angles,
    check_orbit_state,
    check_quaternion,
)
from pmv_ros.storage.files import read_text_file

ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True)
EXTREMES = st.sampled_from([0.0, -0.0, 5e-324, -5e-324, 1e-300, 1e308, -1e308, 1.7976931348623157e308,
                            math.inf, -math.inf, math.nan, 1.0, -1.0])
FLOATS = st.one_of(ANY_FLOAT, EXTREMES)
BOUNDS = InputBounds()
PROPERTY = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# ----------------------------------------------------------------------------- values

@PROPERTY
@given(st.lists(FLOATS, min_size=4, max_size=4))
def test_an_accepted_quaternion_is_finite_and_unit_whatever_came_in(components):
    q, rejection, normalised = check_quaternion(components)
    if rejection is None:
        assert np.all(np.isfinite(q)) and abs(float(np.linalg.norm(q)) - 1.0) < 1e-12
        assert abs(math.hypot(*components) - 1.0) <= QUATERNION_NORM_TOLERANCE
    else:
        assert q is None and rejection in (Rejection.NON_FINITE, Rejection.BAD_QUATERNION)


def test_quaternion_reasons():
    q = quaternion_from_roll_pitch_yaw(0.01, -0.02)
    assert check_quaternion(q)[1] is None and not check_quaternion(q)[2]
    assert check_quaternion(q * 1.005)[1] is None and check_quaternion(q * 1.005)[2]  # normalised, counted
    assert check_quaternion(q * 1.5)[1] is Rejection.BAD_QUATERNION
    assert check_quaternion([0.0, 0.0, 0.0, 0.0])[1] is Rejection.BAD_QUATERNION
    assert check_quaternion([1e308, 0.0, 0.0, 0.0])[1] is Rejection.BAD_QUATERNION  # no overflow to a NaN
    assert check_quaternion([0.0, math.nan, 0.0, 1.0])[1] is Rejection.NON_FINITE
    assert check_quaternion([0.0, 0.0, 1.0])[1] is Rejection.NON_FINITE


@PROPERTY
@given(FLOATS, FLOATS)
def test_accepted_angles_are_lost_or_finite_within_the_bound(roll, pitch):
    rejection = check_angles(roll, pitch, BOUNDS.max_abs_angle_rad, allow_nan=True)
    if rejection is None:
        for value in (roll, pitch):
            assert math.isnan(value) or abs(value) <= BOUNDS.max_abs_angle_rad
    strict = check_angles(roll, pitch, BOUNDS.max_abs_angle_rad, allow_nan=False)
    if strict is None:
        assert abs(roll) <= BOUNDS.max_abs_angle_rad and abs(pitch) <= BOUNDS.max_abs_angle_rad


def test_angle_reasons():
    limit = BOUNDS.max_abs_angle_rad
    assert limit == pytest.approx(math.radians(30.0))
    assert check_angles(1e308, 1e308, limit, allow_nan=True) is Rejection.IMPLAUSIBLE_ANGLE
    assert check_angles(0.0, math.inf, limit, allow_nan=True) is Rejection.NON_FINITE
    assert check_angles(math.nan, 0.01, limit, allow_nan=True) is None            # a lost chord pair
    assert check_angles(math.nan, 0.01, limit, allow_nan=False) is Rejection.NON_FINITE
    assert check_angles(limit, -limit, limit, allow_nan=False) is None


@PROPERTY
@given(st.lists(FLOATS, min_size=3, max_size=3), st.lists(FLOATS, min_size=3, max_size=3))
def test_an_accepted_orbit_state_is_a_bound_earth_orbit(position, velocity):
    if check_orbit_state(position, velocity, BOUNDS) is None:
        radius, speed = math.hypot(*position), math.hypot(*velocity)
        assert BOUNDS.min_orbit_radius_m <= radius <= BOUNDS.max_orbit_radius_m
        assert BOUNDS.min_orbit_speed_m_s <= speed <= BOUNDS.max_orbit_speed_m_s
        assert 0.5 * speed**2 - 3.986005e14 / radius < 0.0


def test_orbit_reasons():
    for altitude_m in (200e3, 500e3, 835e3, 35786e3):  # LEO to geostationary: all accepted
        r, v = CircularOrbit(altitude_m, math.radians(74.5)).state_eci(100.0)
        assert check_orbit_state(r, v, BOUNDS) is None, altitude_m
    r, v = CircularOrbit(500e3, math.radians(74.5)).state_eci(100.0)
    assert check_orbit_state(r / np.linalg.norm(r) * 1e3, v, BOUNDS) is Rejection.IMPLAUSIBLE_ORBIT  # |r| = 1 km
    assert check_orbit_state(r / np.linalg.norm(r) * 1e12, v, BOUNDS) is Rejection.IMPLAUSIBLE_ORBIT
    assert check_orbit_state(r, v * 1.5, BOUNDS) is Rejection.IMPLAUSIBLE_ORBIT  # above escape speed at 500 km
    assert check_orbit_state(r, [math.nan, 0.0, 0.0], BOUNDS) is Rejection.NON_FINITE


def test_a_state_with_no_angular_momentum_or_a_perigee_inside_the_earth_is_no_orbit():
    # Radius 6,871 km, 7.6 km/s along r: bound (v²/2 − GM/r < 0), inside every radius and speed bound, r × v = 0.
    radial = np.array([0.6, 0.0, 0.8])
    assert check_orbit_state(6.871e6 * radial, 7.6e3 * radial, BOUNDS) is Rejection.IMPLAUSIBLE_ORBIT
    assert check_orbit_state(6.871e6 * radial, -7.6e3 * radial, BOUNDS) is Rejection.IMPLAUSIBLE_ORBIT
    # A 1 m/s sideways push leaves r_p ≈ h²/2GM of a few cm: still a fall.
    assert check_orbit_state(6.871e6 * radial, 7.6e3 * radial + [0.0, 1.0, 0.0], BOUNDS) is Rejection.IMPLAUSIBLE_ORBIT
    # 500 km circular speed, flown 60° off horizontal: a = r, e ≈ 0.87, perigee ≈ 920 km from the centre.
    r = np.array([6.871e6, 0.0, 0.0])
    speed = math.sqrt(3.986004418e14 / 6.871e6)
    steep = speed * np.array([math.sin(math.radians(60.0)), math.cos(math.radians(60.0)), 0.0])
    assert check_orbit_state(r, steep, BOUNDS) is Rejection.IMPLAUSIBLE_ORBIT
    # An eccentric orbit whose perigee clears the surface (Molniya-like, r_p ≈ 7,000 km) is an orbit.
    r_p, r_a = 7.0e6, 4.6e7
    v_p = math.sqrt(3.986004418e14 * 2.0 * r_a / (r_p * (r_p + r_a)))
    assert check_orbit_state([r_p, 0.0, 0.0], [0.0, v_p, 0.0], BOUNDS) is None


# ----------------------------------------------------------------------------- stamps

@PROPERTY
@given(st.lists(st.tuples(FLOATS, st.one_of(st.none(), FLOATS)), max_size=60),
       st.sampled_from([0.0, 0.005, 0.1]))
def test_accepted_stamps_are_valid_ordered_and_never_faster_than_the_stream(events, min_interval_s):
    check = StampCheck(jump_threshold_s=1.0, future_tolerance_s=1.0, min_interval_s=min_interval_s)
    previous = None
    for stamp, now in events:
        rejection, jumped = check.check(stamp, now)
        if rejection is not None:
            assert not jumped
            continue
        assert math.isfinite(stamp) and stamp > 0.0
        if now is not None and math.isfinite(now):
            assert stamp <= now + 1.0
        if previous is not None and not jumped:
            assert stamp > previous and stamp - previous >= min_interval_s
        if jumped:
            assert stamp < previous - 1.0
        previous = stamp
        assert check.latest_s == stamp


def test_a_flood_stamping_faster_than_the_stream_is_thinned_to_its_rate():
    check = StampCheck(jump_threshold_s=1.0, future_tolerance_s=1.0, min_interval_s=1.0 / 200.0)
    accepted = [t for t in np.arange(1.0, 2.0, 1.0 / 5000.0) if check.check(float(t), now_s=2.0)[0] is None]
    # 5 kHz stamps against a 200 Hz limit: one in 25 passes, none closer than 5 ms.
    assert 190 <= len(accepted) <= 200 and np.min(np.diff(accepted)) >= 1.0 / 200.0 - 1e-12


def test_one_forged_jump_is_an_outlier_and_a_real_restart_is_one_jump():
    detector = JumpDetector(1.0)
    verdicts = [detector.observe(t) for t in (10.0, 10.1, 10.2, 3.0, 10.3, 10.4)]
    assert verdicts.count(Jump.OUTLIER) == 1 and Jump.CONFIRMED_BACK not in verdicts
    verdicts = [detector.observe(t) for t in (0.1, 0.1, 0.2, 0.3, 0.4)]
    assert verdicts == [Jump.SUSPECTED, Jump.SUSPECTED, Jump.CONFIRMED_BACK, Jump.NONE, Jump.NONE]
    clock = JumpDetector(1.0, forward_threshold_s=10.0)
    verdicts = [clock.observe(t) for t in (5.0, 5.5, 3.15e7, 6.0, 8.0, 500.0, 501.0)]
    assert verdicts == [Jump.NONE, Jump.NONE, Jump.SUSPECTED, Jump.OUTLIER, Jump.NONE, Jump.SUSPECTED,
                        Jump.CONFIRMED_FORWARD]


@PROPERTY
@given(st.lists(FLOATS, min_size=1, max_size=40))
def test_forged_stamps_among_a_clean_stream_never_reset_more_than_once_each(forged):
    # A clean 10 Hz stream with one forged stamp after each clean one: every forged stamp is
    # contradicted by the next clean stamp, so none may confirm a jump.
    check = StampCheck(jump_threshold_s=1.0, future_tolerance_s=1.0)
    jumps = 0
    for k, bad in enumerate(forged):
        t = 100.0 + 0.1 * k
        rejection, jumped = check.check(t, now_s=t)
        assert rejection is None and not jumped
        jumps += check.check(bad, now_s=t)[1]
    assert jumps == 0


# ------------------------------------------------------------------------------ files

def test_a_table_file_is_read(tmp_path):
    path = tmp_path / "table.csv"
    path.write_text("del_arcmin,pop_arcmin\n1,2\n3,4\n")
    assert read_text_file(path, "correction table").startswith("del_arcmin")


def _refusal(path, **options) -> str:
    with pytest.raises(ValueError) as error:
        read_text_file(path, "correction table", **options)
    message = str(error.value)
    assert "\n" not in message
    return message


def test_a_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    result = {}
    worker = threading.Thread(target=lambda: result.update(message=_refusal(fifo)), daemon=True)
    worker.start()
    worker.join(5.0)
    assert not worker.is_alive(), "reading a FIFO blocked"
    assert "a FIFO" in result["message"]


def test_devices_directories_huge_and_binary_files_are_refused(tmp_path):
    assert "a device" in _refusal("/dev/zero")
    assert "a directory" in _refusal(tmp_path)
    huge = tmp_path / "huge.csv"
    with open(huge, "wb") as handle:
        handle.truncate(1 << 30)  # sparse: 1 GiB that takes no disk
    assert "more than the" in _refusal(huge)
    binary = tmp_path / "binary.csv"
    binary.write_bytes(b"del_arcmin,pop_arcmin\n\x00\x01\x02")
    assert "binary" in _refusal(binary)
    latin = tmp_path / "latin.csv"
    latin.write_bytes(b"del_arcmin,pop_arcmin\n\xe9\xe9\n")
    assert "not UTF-8" in _refusal(latin)
    assert "No such file" in _refusal(tmp_path / "missing.csv")


def test_the_reason_never_echoes_the_file(tmp_path):
    from pmv_ros.physics.instrument.correction import CorrectionTable

    secret = tmp_path / "passwd"
    secret.write_text("root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1::/usr/sbin:/usr/sbin/nologin\n")
    with pytest.raises(ValueError) as error:
        CorrectionTable.from_csv(secret)
    assert "root" not in str(error.value).replace(str(tmp_path), "") and "\n" not in str(error.value)
    bad_row = tmp_path / "bad_row.csv"
    bad_row.write_text("del_arcmin,pop_arcmin\n1,2\nsecret-token,3\n")
    with pytest.raises(ValueError, match="line 3") as error:
        CorrectionTable.from_csv(bad_row)
    assert "secret" not in str(error.value).replace(str(tmp_path), "")


# ------------------------------------------------------------------------- statistics

def _monitor() -> ErrorMonitor:
    return ErrorMonitor(MonitorConfig.for_orbit(500e3, math.radians(74.5), max_truth_wait_s=5.0))


def _clean_stream(n: int):
    """(kind, stamp_s, payload) of a 10 Hz sensor with 2 Hz truth and odometry on a real orbit."""
    orbit = CircularOrbit(500e3, math.radians(74.5))
    rng = np.random.default_rng(11)
    events = []
    for k in range(1, n + 1):
        t = 10.0 + 0.1 * k
        r, v = orbit.state_eci(t)
        events.append(("odometry", t, (r.tolist(), v.tolist())))
        if k % 5 == 0:
            events.append(("truth", t, quaternion_from_roll_pitch_yaw(1e-3, -2e-3).tolist()))
        events.append(("sensor", t, (1e-3 + 3e-4 * rng.standard_normal(), -2e-3 + 3e-4 * rng.standard_normal())))
    return events


def _feed(monitor: ErrorMonitor, events) -> None:
    for kind, t, payload in events:
        if kind == "odometry":
            monitor.add_odometry(t, *payload, now_s=t)
        elif kind == "truth":
            monitor.add_truth_quaternion(t, payload, now_s=t)
        else:
            monitor.add_sensor(t, *payload, now_s=t, **monitor.orbit_at(t, 5.0))


def _statistics(monitor: ErrorMonitor):
    return [(c.count, c.mean_rad, c.sigma_rad, c.max_abs_rad, c.ground_sigma_m) for c in monitor.summary().channels]


def test_one_percent_of_1e308_angles_and_absurd_odometry_leave_the_statistics_of_the_clean_stream():
    clean = _clean_stream(3000)
    hostile = []
    rng = np.random.default_rng(5)
    for event in clean:
        hostile.append(event)
        kind, t, _ = event
        if kind == "sensor" and rng.random() < 0.01:
            hostile.append(("sensor", t + 0.05, (1e308, 1e308)))
        if kind == "odometry" and rng.random() < 0.05:
            absurd = rng.choice(3)
            position = [[1e3, 0.0, 0.0], [1e12, 0.0, 0.0], [7e6, 0.0, 0.0]][absurd]
            velocity = [[7.6e3, 0.0, 0.0], [7.6e3, 0.0, 0.0], [0.0, 2e4, 0.0]][absurd]  # r = 1 km, 1e12 m, escape
            hostile.append(("odometry", t + 0.01, (position, velocity)))
    reference, attacked = _monitor(), _monitor()
    _feed(reference, clean)
    _feed(attacked, hostile)
    assert _statistics(attacked) == _statistics(reference)
    counters = attacked.counters
    assert counters["rejected_sensor_implausible_angle"] > 15
    assert counters["rejected_odometry_implausible_orbit"] > 100
    assert all(math.isfinite(v) for row in _statistics(attacked) for v in row)


@PROPERTY
@given(st.lists(st.tuples(st.sampled_from(["sensor", "truth", "truth_q", "odometry"]), FLOATS, FLOATS, FLOATS,
                          FLOATS), max_size=80))
def test_no_statistic_ever_becomes_infinite(samples):
    monitor = ErrorMonitor(MonitorConfig(orbital_period_s=600.0, altitude_m=500e3,
                                         inclination_rad=math.radians(74.5), harmonic_bins=64))
    for kind, t, a, b, c in samples:
        if kind == "sensor":
            monitor.add_sensor(t, a, b, now_s=c, u_rad=a, altitude_m=c)
        elif kind == "truth":
            monitor.add_truth(t, a, b, now_s=c)
        elif kind == "truth_q":
            monitor.add_truth_quaternion(t, [a, b, c, 1.0], now_s=None)
        else:
            monitor.add_odometry(t, [a, b, c], [c, a, b], now_s=None)
    for channel in monitor.summary(oblateness_removed=False).channels + monitor.summary(True).channels:
        for value in (channel.mean_rad, channel.sigma_rad, channel.three_sigma_rad, channel.max_abs_rad,
                      channel.ground_mean_m, channel.ground_sigma_m, channel.ground_max_abs_m,
                      *channel.harmonics_rad.values()):
            assert not math.isinf(value)
        if channel.count:
            assert math.isfinite(channel.mean_rad) and math.isfinite(channel.max_abs_rad)


def test_a_quaternion_sample_moves_the_timeline_only_when_the_quaternion_is_valid():
    from pmv_ros.runtime.common.validation import StampCheck, check_quaternion_sample

    stamps = StampCheck(1.0, 1.0)
    bad = check_quaternion_sample(stamps, 10.0, (0.0, 0.0, 0.0, 0.0), None)
    assert bad.rejection is not None and bad.q_xyzw is None and stamps.latest_s is None
    good = check_quaternion_sample(stamps, 10.0, (0.0, 0.0, 0.0, 1.001), None)
    assert good.rejection is None and good.normalised and np.allclose(good.q_xyzw, [0, 0, 0, 1])
    assert stamps.latest_s == 10.0
    assert check_quaternion_sample(stamps, 10.0, (0.0, 0.0, 0.0, 1.0), None).rejection is not None  # duplicate


# ------------------------------------------------------------------------------ frames

def test_a_wrong_frame_is_refused_every_time_and_said_once_with_what_was_expected():
    # Issue 51: truth stamped `orbital` to a spacecraft in sat1, a thousand times.
    check = FrameCheck("star-tracker truth", "sat1/orbital")
    assert check.problem is None and check.take_log_line() is None
    lines = []
    for _ in range(1000):
        assert check.check("orbital") is Rejection.WRONG_FRAME
        lines.append(check.take_log_line())
    said = [line for line in lines if line]
    assert len(said) == 1 and said[0].startswith("star-tracker truth refused: expected sat1/orbital, got orbital")
    assert check.refused == 1000
    assert check.problem == "star-tracker truth refused: expected sat1/orbital, got orbital (1000 refused)"
    assert check.check("sat1/orbital") is None and check.problem is None  # fixed: nothing to say any more
    assert check.check("base_link") is Rejection.WRONG_FRAME and check.take_log_line() is None  # said once
    assert check.problem == "star-tracker truth refused: expected sat1/orbital, got base_link (1001 refused)"


@pytest.mark.parametrize("frame_id", ["x" * 1_000_000, "orb\x1b[2Jital", "", "two words", "é"])
def test_a_refused_frame_id_is_quoted_short_and_inert(frame_id):
    check = FrameCheck("odometry", "eci")
    assert check.check(frame_id) is Rejection.WRONG_FRAME
    line = check.take_log_line()
    assert len(line) < 300 and len(check.problem) < 200
    assert line.isprintable() and check.problem.isprintable()  # no control character reaches a terminal
    assert "got '" in check.problem  # not a bare id: a literal, cut where it is long

