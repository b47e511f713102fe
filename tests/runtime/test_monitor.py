"""The pure error monitor: alignment with truth, outages, bad samples, discontinuities, bounded memory."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.orbit.two_body import CircularOrbit, orbit_angles_from_state
from pmv_ros.runtime.monitor.core import ErrorMonitor
from pmv_ros.runtime.monitor.records import COUNTER_NAMES, MonitorConfig, Status
from pmv_ros.runtime.common.validation import Rejection

KONDOR_ALTITUDE_M, KONDOR_INCLINATION = 500e3, math.radians(74.5)


def small_config(**options):
    """A short 'orbit' (600 s) so that tests cover whole orbits quickly."""
    return MonitorConfig(orbital_period_s=600.0, altitude_m=KONDOR_ALTITUDE_M, inclination_rad=KONDOR_INCLINATION,
                         **options)


def feed(monitor, events):
    """Deliver (arrival_s, kind, args) events in arrival order; return all outcomes."""
    outcomes = []
    for _, kind, args in sorted(events, key=lambda e: e[0]):
        if kind == "truth":
            outcomes += monitor.add_truth(*args)
        else:
            outcomes += monitor.add_sensor(*args)
    return outcomes


def test_truth_is_interpolated_between_bracketing_samples():
    monitor = ErrorMonitor(small_config(remove_oblateness=False))
    # Truth roll is a ramp: linear interpolation is exact, so the residual is the sensor's offset.
    assert monitor.add_truth(10.0, 0.010, -0.002) == []
    assert monitor.add_sensor(10.25, 0.0105 + 0.001, -0.002) == []        # newer than truth: waits
    assert monitor.pending_count == 1
    [outcome] = monitor.add_truth(11.0, 0.012, -0.002)
    assert outcome.status is Status.OK and outcome.stamp_s == 10.25
    assert outcome.residual_roll_rad == pytest.approx(0.001, abs=1e-15)
    assert outcome.residual_pitch_rad == pytest.approx(0.0, abs=1e-15)
    assert outcome.meridional_rad == pytest.approx(0.001, abs=1e-15)
    # A sample bracketed already is answered at once; one exactly on a truth stamp uses it.
    [outcome] = monitor.add_sensor(11.0, 0.012, -0.001)
    assert outcome.ok and outcome.residual_pitch_rad == pytest.approx(0.001)
    assert monitor.counters["used"] == 2


def test_sample_before_any_truth_is_counted_as_no_truth():
    monitor = ErrorMonitor(small_config())
    monitor.add_truth(5.0, 0.0, 0.0)
    [outcome] = monitor.add_sensor(4.0, 0.0, 0.0)
    assert outcome.status is Status.NO_TRUTH and monitor.counters["skipped_no_truth"] == 1


def test_star_tracker_outage_is_skipped_counted_and_the_monitor_resumes():
    config = small_config(max_truth_gap_s=2.0, max_truth_wait_s=10.0, remove_oblateness=False)
    monitor = ErrorMonitor(config)
    outage = (300.0, 420.0)                      # last truth before, first truth after
    truth_t = [t for t in np.arange(1.0, 900.0, 1.0) if not outage[0] < t < outage[1]]
    sensor_t = np.arange(1.25, 899.0, 0.5)
    offset = 2 * ARCMIN_RAD
    # Truth arrives 0.6 s late (latency), the sensor at its stamp.
    events = [(t + 0.6, "truth", (t, 1e-3 * math.sin(t / 50.0), 0.0)) for t in truth_t]
    events += [(t, "sensor", (t, 1e-3 * math.sin(t / 50.0) + offset, 0.0)) for t in sensor_t]
    outcomes = feed(monitor, events)
    outcomes += monitor.poll(now_s=1000.0)       # the last samples: their truth never comes
    in_gap = [t for t in sensor_t if outage[0] < t < outage[1]]
    after_end = [t for t in sensor_t if t > truth_t[-1]]
    counters = monitor.counters
    skipped = counters["skipped_stale_truth"] + counters["skipped_truth_gap"]
    assert skipped == len(in_gap) + len(after_end)
    # Early outage samples wait max_truth_wait_s and go stale; the last ones see the gap when truth returns.
    assert counters["skipped_stale_truth"] > 0 and counters["skipped_truth_gap"] > 0
    assert counters["used"] == len(sensor_t) - skipped
    assert len(outcomes) == len(sensor_t)        # every sample has exactly one outcome
    ok_after = [o for o in outcomes if o.ok and o.stamp_s > outage[1]]
    assert ok_after and ok_after[0].stamp_s == pytest.approx(outage[1] + 0.25)
    # Interpolated truth never crossed the gap: every residual is the offset (to interpolation error).
    residuals = np.array([o.residual_roll_rad for o in outcomes if o.ok])
    assert np.allclose(residuals, offset, atol=1e-3 * (1 / 50.0) ** 2)
    summary = monitor.summary()
    assert summary.channel("roll").count == counters["used"]
    assert summary.counters["skipped_stale_truth"] == counters["skipped_stale_truth"]


def test_bad_samples_are_dropped_or_normalised_and_counted_per_reason():
    monitor = ErrorMonitor(small_config())
    now = 100.0
    monitor.add_truth(50.0, 0.0, 0.0, now_s=now)
    monitor.add_truth(50.0, 0.0, 0.0, now_s=now)                     # duplicate
    monitor.add_truth(49.5, 0.0, 0.0, now_s=now)                     # backwards by less than clock_jump_s
    monitor.add_truth(0.0, 0.0, 0.0, now_s=now)                      # zero stamp (unset header)
    monitor.add_truth(150.0, 0.0, 0.0, now_s=now)                    # 50 s in the future
    monitor.add_truth(51.0, math.nan, 0.0, now_s=now)                # NaN
    q = quaternion_from_roll_pitch_yaw(0.01, -0.02)
    monitor.add_truth_quaternion(52.0, q * 1.005, now_s=now)         # near-unit: normalised and used
    monitor.add_truth_quaternion(53.0, q * 1.5, now_s=now)           # far from unit norm
    monitor.add_truth_quaternion(54.0, [0.0, math.inf, 0.0, 1.0], now_s=now)
    outcomes = monitor.add_sensor(51.0, math.inf, 0.0, now_s=now)  # malformed (NaN alone means a lost chord pair)
    outcomes += monitor.add_sensor(0.0, 0.0, 0.0, now_s=now)
    outcomes += monitor.add_sensor(52.0, 0.01, -0.02, now_s=now)     # against the normalised quaternion
    outcomes += monitor.add_sensor(52.0, 0.01, -0.02, now_s=now)     # duplicate
    counters = monitor.counters
    expected = {
        "rejected_truth_duplicate": 1, "rejected_truth_backwards": 1, "rejected_truth_zero_stamp": 1,
        "rejected_truth_future_stamp": 1, "rejected_truth_non_finite": 2, "rejected_truth_bad_quaternion": 1,
        "truth_quaternions_normalised": 1, "rejected_sensor_non_finite": 1, "rejected_sensor_zero_stamp": 1,
        "rejected_sensor_duplicate": 1, "used": 1, "truth_received": 9, "sensor_received": 4,
    }
    for name, value in expected.items():
        assert counters[name] == value, name
    assert [o.status for o in outcomes] == [Rejection.NON_FINITE, Rejection.ZERO_STAMP, Status.OK, Rejection.DUPLICATE]
    # The normalised truth quaternion reads back as roll 0.01, pitch −0.02 (attitude.py convention).
    assert outcomes[2].residual_roll_rad == pytest.approx(0.0, abs=1e-12)
    assert outcomes[2].residual_pitch_rad == pytest.approx(0.0, abs=1e-12)
    assert set(counters) == set(COUNTER_NAMES)


def test_clock_jump_back_resets_alignment_once_and_never_mixes_epochs():
    monitor = ErrorMonitor(small_config(remove_oblateness=False))
    for t in np.arange(1000.0, 1610.0, 2.0):     # a little over one 600 s orbit
        monitor.add_truth(t, 0.1, 0.0)           # old epoch: truth roll 0.1 rad
        monitor.add_sensor(t, 0.1, 0.0)
    assert monitor.summary().harmonics_full_orbit
    pending = monitor.add_sensor(1610.5, 0.1, 0.0)
    assert pending == [] and monitor.pending_count == 1
    used_before = monitor.counters["used"]
    # The simulation restarts: both clocks go back to a few seconds. The first stamp of the new
    # timeline is only a suspected jump (it could be a single bad stamp) ...
    assert monitor.add_truth(5.0, 0.0, 0.0) == []
    assert monitor.counters["rejected_truth_unconfirmed_jump"] == 1 and monitor.pending_count == 1
    # ... the next one on the new timeline confirms it: one reset.
    reset = monitor.add_truth(5.2, 0.0, 0.0)
    assert [o.status for o in reset] == [Status.RESET]
    outcomes = monitor.add_sensor(5.5, 0.0, 0.0)   # the first new sensor stamp: after the reset, accepted
    outcomes += monitor.add_truth(6.0, 0.0, 0.0)
    assert [o.status for o in outcomes] == [Status.OK]
    assert outcomes[0].residual_roll_rad == 0.0  # an old truth of 0.1 rad would give −0.1 rad here
    counters = monitor.counters
    assert counters["clock_jumps"] == 1 and counters["alignment_resets"] == 1 and counters["skipped_reset"] == 1
    summary = monitor.summary()
    assert summary.channel("roll").count == used_before + 1     # statistics carry on ...
    assert not summary.harmonics_full_orbit                      # ... the time-based ring starts again


def test_a_single_forged_stamp_or_clock_jump_is_an_outlier_and_keeps_the_ring():
    monitor = ErrorMonitor(small_config(remove_oblateness=False))
    for t in np.arange(1000.0, 1610.0, 2.0):
        monitor.add_truth(t, 0.0, 0.0, now_s=t)
        monitor.add_sensor(t, 1e-4, 0.0, now_s=t)
    assert monitor.summary().harmonics_full_orbit
    # One sensor stamp 900 s back, then the stream goes on where it was: an outlier.
    assert [o.status for o in monitor.add_sensor(700.0, 1e-4, 0.0, now_s=1610.0)] == [Rejection.UNCONFIRMED_JUMP]
    monitor.add_truth(1610.0, 0.0, 0.0, now_s=1610.0)
    assert [o.status for o in monitor.add_sensor(1610.0, 1e-4, 0.0, now_s=1610.0)] == [Status.OK]
    # One forged /clock an hour back, and one a year ahead, each contradicted by the next reading.
    for forged in (1610.0 - 3600.0, 1610.0 + 3.15e7):
        monitor.poll(now_s=forged)
        monitor.poll(now_s=1610.5)
    counters = monitor.counters
    assert counters["clock_outliers"] == 3
    assert counters["clock_jumps"] == 0 and counters["alignment_resets"] == 0
    assert monitor.summary().harmonics_full_orbit and monitor.truth_buffer_length > 2
    assert counters["skipped_stale_truth"] == 0  # the year-ahead clock timed nothing out


def test_a_summary_made_later_is_the_summary_of_its_moment():
    """summary_later() reads the statistics and copies the ring's bins when called and fits the harmonics only
    when its result is called (MonitorStatistics reads it so: in a private graph most statistics have no
    reader): after another half orbit its summary is bit for bit what summary() gave at its moment."""
    monitor = ErrorMonitor(small_config(remove_oblateness=False))
    rng = np.random.default_rng(5)

    def fly(start, stop):
        for t in np.arange(start, stop, 2.0):
            monitor.add_truth(t, 0.0, 0.0)
            monitor.add_sensor(t, 1e-4 * math.sin(2.0 * math.pi * t / 600.0) + 1e-5 * rng.standard_normal(),
                               1e-5 * rng.standard_normal())

    fly(1000.0, 1700.0)
    at_once, later = monitor.summary(), monitor.summary_later()
    assert at_once.harmonics_full_orbit and all(map(math.isfinite, at_once.channel("roll").harmonics_rad.values()))
    fly(1700.0, 2000.0)
    moved = monitor.summary()
    assert moved.channel("roll") != at_once.channel("roll") and moved.counters != at_once.counters
    assert repr(later()) == repr(at_once)


def test_clock_jump_of_now_rejects_stragglers_from_the_old_epoch():
    monitor = ErrorMonitor(small_config())
    monitor.add_truth(1000.0, 0.0, 0.0, now_s=1000.0)
    monitor.poll(now_s=3.0)                       # the node clock went back: suspected ...
    assert monitor.counters["clock_jumps"] == 0 and monitor.truth_buffer_length == 1
    monitor.poll(now_s=3.1)                       # ... and confirmed by the next reading: reset
    assert monitor.counters["clock_jumps"] == 1 and monitor.truth_buffer_length == 0
    monitor.add_truth(1001.0, 0.0, 0.0, now_s=3.1)                      # in flight before the jump
    assert monitor.counters["rejected_truth_future_stamp"] == 1


def test_memory_stays_bounded_over_many_orbits():
    config = small_config(truth_capacity=50, truth_history_s=1e5, max_pending=20, max_truth_wait_s=1e4)
    monitor = ErrorMonitor(config)
    ring_size = monitor.ring_nbytes
    for t in np.arange(1.0, 10 * config.orbital_period_s, 2.0):     # ten orbits
        monitor.add_truth(t, 0.0, 0.0)
        monitor.add_sensor(t + 1.0, 1e-4, 0.0)
        assert monitor.truth_buffer_length <= 50
    assert monitor.ring_nbytes == ring_size
    assert monitor.summary().harmonics_full_orbit
    # Truth stops; the pending queue is capped and the overflow counted.
    for t in np.arange(20000.0, 20100.0, 1.0):
        monitor.add_sensor(t, 0.0, 0.0)
    assert monitor.pending_count == 20 and monitor.counters["skipped_pending_overflow"] == 100 - 20
    assert len(monitor.counters) == len(COUNTER_NAMES)


def test_oblateness_removal_and_harmonics_over_a_kondor_orbit():
    config = MonitorConfig.for_orbit(KONDOR_ALTITUDE_M, KONDOR_INCLINATION)
    monitor = ErrorMonitor(config)
    orbit = CircularOrbit(KONDOR_ALTITUDE_M, KONDOR_INCLINATION)
    from pmv_ros.physics.instrument.oblateness import closed_form_oblateness

    ripple = 0.5 * ARCMIN_RAD
    for t in np.arange(4.0, 1.05 * orbit.period_s, 4.0):           # §5.1 sampling: every 4 s
        u = float(orbit.argument_of_latitude(t))
        _, model_roll, model_pitch = closed_form_oblateness(u, KONDOR_ALTITUDE_M, KONDOR_INCLINATION)
        monitor.add_truth(t, 0.0, 0.0)
        monitor.add_sensor(t, model_roll + ripple * math.cos(20 * u), model_pitch, u_rad=u)
    removed, kept = monitor.summary(), monitor.summary(oblateness_removed=False)
    assert removed.oblateness_removed and not kept.oblateness_removed and removed.harmonics_full_orbit
    # Oblateness removed: only the k = 20 ripple is left (bin averaging: < 0.1 % at k = 20).
    assert removed.channel("roll").harmonics_rad[20] == pytest.approx(ripple, rel=2e-3)
    assert removed.channel("roll").harmonics_rad[1] < 1e-3 * ARCMIN_RAD
    assert removed.channel("pitch").max_abs_rad < 1e-12
    assert removed.channel("roll").sigma_rad == pytest.approx(ripple / math.sqrt(2), rel=0.01)
    # Kept: the oblateness shows as roll at k = 1 and pitch at k = 2 (physics.md §2.1 table: 4.9′, 9.1′).
    assert kept.channel("roll").harmonics_rad[1] / ARCMIN_RAD == pytest.approx(4.9, abs=0.3)
    assert kept.channel("pitch").harmonics_rad[2] / ARCMIN_RAD == pytest.approx(9.1, abs=0.3)


def test_residual_as_ground_error():
    monitor = ErrorMonitor(MonitorConfig.for_orbit(KONDOR_ALTITUDE_M, KONDOR_INCLINATION, remove_oblateness=False))
    monitor.add_truth(1.0, 0.0, 0.0)
    [outcome] = monitor.add_sensor(1.0, ARCMIN_RAD, 0.0)
    # physics.md §7: 1′ ≈ 145 m from 500 km; a positive roll residual (REP-103: right-hand about +X)
    # moves the ground point to +Y.
    assert outcome.cross_track_m == pytest.approx(145.0, abs=1.0) and abs(outcome.along_track_m) < 1e-6
    assert monitor.summary().channel("meridional").ground_mean_m == pytest.approx(145.0, abs=1.0)


def test_without_an_oblateness_model_only_the_kept_statistics_grow():
    monitor = ErrorMonitor(MonitorConfig(orbital_period_s=600.0))
    monitor.add_truth(1.0, 0.0, 0.0)
    [outcome] = monitor.add_sensor(1.0, 1e-4, 0.0)
    assert outcome.ok and math.isnan(outcome.roll_rad) and math.isnan(outcome.circular_m)
    assert monitor.counters["used_without_oblateness_model"] == 1
    assert monitor.summary(oblateness_removed=True).channel("roll").count == 0
    assert monitor.summary(oblateness_removed=False).channel("roll").count == 1


def test_orbit_angles_from_an_eci_state():
    orbit = CircularOrbit(835e3, math.radians(98.8), raan_rad=1.1, arg_latitude_at_epoch_rad=0.4)
    for t in (0.0, 1234.0, 4000.0):
        r, v = orbit.state_eci(t)
        u, inclination, altitude = orbit_angles_from_state(r, v)
        assert u == pytest.approx(float(orbit.argument_of_latitude(t)) % (2 * math.pi), abs=1e-12)
        assert inclination == pytest.approx(math.radians(98.8), abs=1e-12)
        assert altitude == pytest.approx(835e3, abs=1e-6)


@pytest.mark.parametrize("options, word", [
    ({"orbital_period_s": -5.0}, "orbital_period_s"),
    ({"orbital_period_s": 600.0, "max_truth_gap_s": 0.0}, "max_truth_gap_s"),
    ({"orbital_period_s": 600.0, "truth_capacity": 1}, "truth_capacity"),
    ({"orbital_period_s": 600.0, "harmonic_bins": 10}, "harmonic_bins"),
    ({"orbital_period_s": 600.0, "inclination_rad": 4.0}, "inclination_rad"),
])
def test_bad_configuration_raises_naming_the_value(options, word):
    with pytest.raises(ValueError, match=word):
        MonitorConfig(**options)


def test_a_lost_chord_pair_keeps_the_other_angle():
    # The sensor sends NaN for the angle of a pair that lost a chord (Sun in the field,
    # no horizon); the other angle is still a measurement and must count.
    monitor = ErrorMonitor(MonitorConfig(orbital_period_s=6000.0, remove_oblateness=False))
    for k in range(1, 31):
        monitor.add_truth(float(k), 0.0, 0.0)
    outcomes = []
    for k in range(1, 21):
        roll = math.nan if k > 10 else 0.002
        pitch = math.nan if k == 20 else -0.001
        outcomes += monitor.add_sensor(k + 0.5, roll, pitch)
    counters = monitor.counters
    assert counters["used"] == 19 and counters["used_one_angle"] == 9
    assert counters["skipped_no_valid_angle"] == 1
    assert sum(v for k, v in counters.items() if k.startswith("rejected_")) == 0
    summary = monitor.summary()
    assert summary.channel("roll").count == 10 and summary.channel("roll").mean_rad == pytest.approx(0.002)
    assert summary.channel("pitch").count == 19 and summary.channel("pitch").mean_rad == pytest.approx(-0.001)
    assert summary.channel("meridional").count == 10
    assert [o.status for o in outcomes].count(Status.NO_VALID_ANGLE) == 1


def test_an_orbit_below_the_surface_gives_no_model_rather_than_an_error():
    # Odometry in km instead of m puts the spacecraft ~6,000 km under the surface: the sample
    # must still count (without the oblateness model and the ground error), not stop the monitor.
    monitor = ErrorMonitor(MonitorConfig.for_orbit(KONDOR_ALTITUDE_M, KONDOR_INCLINATION))
    for k in range(1, 6):
        monitor.add_truth(float(k), 0.0, 0.0)
    outcomes = monitor.add_sensor(2.5, 1e-4, -1e-4, u_rad=0.3, altitude_m=-6.36e6, inclination_rad=1.3)
    assert [o.status for o in outcomes] == [Status.OK]
    assert math.isnan(outcomes[0].roll_rad) and math.isnan(outcomes[0].cross_track_m)
    assert monitor.counters["used_without_oblateness_model"] == 1
    assert monitor.summary(oblateness_removed=False).channel("roll").count == 1


def _hostile_batch(jump: bool):
    """A 20-minute 10 Hz stream (truth at 2 Hz, 0.25 s late) with every kind of bad input in it.

    Bad sensor samples (a NaN stamp, a zero stamp, a duplicate, a backward one, a too-fast one, 1e3 rad, ±Inf,
    both angles lost), bad truth (a far-from-unit and a NaN quaternion, a near-unit one, a duplicate stamp), a
    bad odometry state, an outage of 30 s (stale samples) and, with ``jump``, the clock restarting at 100 s.
    """
    orbit = CircularOrbit(KONDOR_ALTITUDE_M, KONDOR_INCLINATION)
    rng = np.random.default_rng(7)
    clock = 100.0 + 0.1 * np.arange(1, 12001)  # the node clock at each sensor tick
    if jump:
        clock[6000:] -= 500.0
    t = clock.copy()
    roll = 1e-3 * np.sin(t / 300.0) + 2e-4 * rng.standard_normal(t.size)
    pitch = -5e-4 + 2e-4 * rng.standard_normal(t.size)
    for index, (r, p) in {50: (1e3, 0.0), 51: (math.inf, 0.0), 52: (math.nan, math.nan), 53: (math.nan, 1e-4)}.items():
        roll[index], pitch[index] = r, p
    t[60], t[70], t[80] = math.nan, 0.0, t[79]  # non-finite, zero and duplicate stamps
    t[90] = t[89] - 0.05  # backwards
    t[95] = t[94] + 1e-4  # faster than min_interval_s
    ticks = np.arange(0, t.size, 5)  # 2 Hz frames at the sensor ticks' times, released 3 ticks later
    ticks = ticks[(clock[ticks] < 300.0) | (clock[ticks] > 330.0)]  # an outage longer than max_truth_wait_s
    frames, arrival = clock[ticks], np.minimum(ticks + 3, t.size)
    q = quaternion_from_roll_pitch_yaw(1e-3 * np.sin(frames / 300.0), np.full(frames.size, -5e-4), 0.01)
    q[:, 10] *= 1.5
    q[:, 11] = np.nan
    q[:, 12] *= 1.0 + 1e-4
    frames[20] = frames[19]
    position, velocity = orbit.state_eci(clock - 100.0)
    position[:, 30] = 0.0  # inside the Earth
    return t, roll, pitch, frames, q, arrival, clock, (position, velocity)


def _message_by_message(monitor, t, roll, pitch, frames, q, arrival, now, position, velocity) -> dict:
    """Feed a batch's events one message at a time, as error_monitor_node does; what became of each sample:
    by stamp, or (its index, "own") for a sample refused on arrival."""
    status = {}
    j = 0
    for i in range(t.size):
        while j < frames.size and arrival[j] == i:
            status.update((o.stamp_s, o.status) for o in monitor.add_truth_quaternion(frames[j], q[:, j],
                                                                                     now_s=now[i]))
            j += 1
        monitor.add_odometry(t[i], position[:, i], velocity[:, i], now_s=now[i])
        status.update((o.stamp_s, o.status) for o in monitor.take_settled())
        for outcome in monitor.add_sensor(t[i], roll[i], pitch[i], now_s=now[i], odometry_max_age_s=5.0):
            status[(i, "own") if isinstance(outcome.status, Rejection) else outcome.stamp_s] = outcome.status
    return status


@pytest.mark.parametrize("jump", [False, True], ids=["one-timeline", "clock-jump"])
def test_one_batch_equals_the_same_input_message_by_message_with_bad_input(jump):
    """ErrorMonitor.add_batch on a whole stretch gives what one message at a time gives: outcomes, counters,
    statistics, the queue and the truth buffer — bad input included, and across a clock jump (two segments).

    Both go through the one path; what differs is where the input is cut (a batch of one event per message,
    one batch of 12,000 samples). 1e-9 arcmin: the same residuals summed in another order.
    """
    from pmv_ros.runtime.monitor.records import BATCH_STATUSES, PENDING_CODE

    t, roll, pitch, frames, q, arrival, now, (position, velocity) = _hostile_batch(jump)
    config = small_config(min_interval_s=0.002)
    live, batch = ErrorMonitor(config), ErrorMonitor(config)
    result = batch.add_batch(t, roll, pitch, frames, q, arrival, now_s=now, odometry=(position, velocity),
                             odometry_max_age_s=5.0)
    status = _message_by_message(live, t, roll, pitch, frames, q, arrival, now, position, velocity)
    for i in range(t.size):
        if (i, "own") in status:
            assert BATCH_STATUSES[result.status[i]] is status[(i, "own")], i
    counters = {k: v for k, v in live.counters.items() if v}
    assert counters == {k: v for k, v in batch.counters.items() if v}
    assert counters["used"] > 10000 and counters["skipped_stale_truth"] > 100 and counters["skipped_no_valid_angle"]
    assert counters["rejected_sensor_too_fast"] and counters["rejected_truth_bad_quaternion"]
    assert counters["rejected_odometry_implausible_orbit"] and counters["truth_quaternions_normalised"]
    assert bool(counters.get("clock_jumps")) == jump and not counters.get("clock_outliers")
    values, counts = np.unique(t, return_counts=True)
    once = set(values[counts == 1].tolist())  # after a jump back, a stamp can come twice: those are not compared
    accepted = [i for i in range(t.size) if not isinstance(BATCH_STATUSES[result.status[i]], Rejection)
                and result.status[i] != PENDING_CODE and t[i] in once]
    assert len(accepted) > 5000
    for i in accepted:
        assert BATCH_STATUSES[result.status[i]] is status[t[i]], i
    assert live.pending_count == batch.pending_count and live.truth_buffer_length == batch.truth_buffer_length
    a, b = live.summary(), batch.summary()
    for x, y in zip(a.channels, b.channels):
        assert x.count == y.count
        for name in ("mean_rad", "sigma_rad", "max_abs_rad", "ground_sigma_m"):
            assert getattr(y, name) == pytest.approx(getattr(x, name), abs=1e-9 * ARCMIN_RAD, rel=1e-9), name
        for k in x.harmonics_rad:
            assert y.harmonics_rad[k] == pytest.approx(x.harmonics_rad[k], abs=1e-9 * ARCMIN_RAD, nan_ok=True)


def _outcomes_message_by_message(monitor, t, roll, pitch, frames, q, arrival, now, position, velocity) -> dict:
    """Feed a batch's events one message at a time, as error_monitor_node does; each settled sample's outcome: by
    stamp, or by (its index, "own") for a sample refused on arrival."""
    outcomes = {}
    j = 0
    for i in range(t.size):
        while j < frames.size and arrival[j] == i:
            outcomes.update((o.stamp_s, o) for o in monitor.add_truth_quaternion(frames[j], q[:, j], now_s=now[i]))
            j += 1
        monitor.add_odometry(t[i], position[:, i], velocity[:, i], now_s=now[i])
        outcomes.update((o.stamp_s, o) for o in monitor.take_settled())
        for outcome in monitor.add_sensor(t[i], roll[i], pitch[i], now_s=now[i], odometry_max_age_s=5.0):
            outcomes[(i, "own") if isinstance(outcome.status, Rejection) else outcome.stamp_s] = outcome
    return outcomes


def test_the_array_scan_of_a_clean_batch_is_the_event_scan(monkeypatch):
    """scan.scan_clean (the campaign's path: a clean batch validated on arrays) against the event-by-event scan
    of the same events one message at a time, sample by sample.

    A clean stream but for the input the clean path checks itself (angles of 1e3 rad, ±Inf, lost pairs;
    far-from-unit, NaN and near-unit quaternions): the same verdicts, counters, timelines, queue and truth
    buffer, exactly; residuals within 1e-15 rad (the truth's roll and pitch from a quaternion array against
    one quaternion in floats, :func:`~pmv_ros.physics.attitude.true_roll_pitch`). A batch with a duplicate, a
    backward, a zero or a NaN stamp, or a clock jump is left to the event scan (the clean path says None,
    and leaves nothing behind), and so is a short one.
    """
    from pmv_ros.runtime.monitor import core
    from pmv_ros.runtime.monitor.records import BATCH_STATUSES, PENDING_CODE
    from pmv_ros.runtime.monitor.scan import MIN_ARRAY_SAMPLES, scan_clean

    scanned = []
    monkeypatch.setattr(core, "scan_clean", lambda monitor, feed: scanned.append(scan_clean(monitor, feed)) or
                        scanned[-1])
    t, roll, pitch, frames, q, arrival, now, odometry = _hostile_batch(jump=False)
    clean_t = now.copy()  # stamps on the clock, every one on the timeline
    frames_clean = frames.copy()  # frames as in the hostile batch, but no duplicate stamp
    frames_clean[20] = 0.5 * (frames_clean[19] + frames_clean[21])
    position, velocity = odometry
    position = position.copy()
    position[:, 30] = position[:, 29]  # a plausible state
    config = small_config(min_interval_s=0.002)
    for make in (lambda: ErrorMonitor(config), lambda: _monitor_with_history(config)):
        fast, slow = make(), make()
        scanned.clear()
        result = fast.add_batch(clean_t, roll, pitch, frames_clean, q, arrival, now_s=now,
                                odometry=(position, velocity), odometry_max_age_s=5.0)
        assert len(scanned) == 1 and scanned[0] is not None  # the array scan took the batch
        outcomes = _outcomes_message_by_message(slow, clean_t, roll, pitch, frames_clean, q, arrival, now,
                                                position, velocity)
        assert fast.counters == slow.counters
        counters = fast.counters
        assert counters["rejected_sensor_implausible_angle"] and counters["rejected_truth_non_finite"]
        assert counters["rejected_truth_bad_quaternion"] and counters["truth_quaternions_normalised"]
        assert counters["used"] > 10000 and counters["skipped_stale_truth"] > 100
        settled = 0
        for i in range(clean_t.size):
            status = result.status[i]
            if status == PENDING_CODE:
                assert clean_t[i] not in outcomes
                continue
            outcome = outcomes[(i, "own") if isinstance(BATCH_STATUSES[status], Rejection) else clean_t[i]]
            assert BATCH_STATUSES[status] is outcome.status, i
            for name in ("residual_roll_rad", "residual_pitch_rad", "roll_rad", "pitch_rad", "meridional_rad"):
                np.testing.assert_allclose(getattr(result, name)[i], getattr(outcome, name), rtol=0.0, atol=1e-15)
            settled += 1
        for earlier in result.earlier:  # a sample of the history, settled by this batch
            assert earlier == outcomes[earlier.stamp_s]
            settled += 1
        assert settled == len(outcomes) > 11000
        assert fast.timelines == slow.timelines and None not in fast.timelines.values()
        assert fast.pending_count == slow.pending_count and fast.truth_buffer_length == slow.truth_buffer_length
        fast_orbit, slow_orbit = fast.orbit_at(now[-1], 1.0), slow.orbit_at(now[-1], 1.0)
        assert fast_orbit.keys() == slow_orbit.keys() == {"u_rad", "inclination_rad", "altitude_m"}
        for name, value in fast_orbit.items():
            assert value == pytest.approx(slow_orbit[name], rel=1e-12, abs=0.0), name
    t, roll, pitch, frames, q, arrival, now, odometry = _hostile_batch(jump=False)  # bad stamps
    monitor = ErrorMonitor(config)
    assert scan_clean(monitor, monitor.batch_feed(t, roll, pitch, frames, q, arrival, now_s=now,
                                                  odometry=odometry)) is None
    t, roll, pitch, frames, q, arrival, now, odometry = _hostile_batch(jump=True)  # stamps on a jumping clock
    assert scan_clean(monitor, monitor.batch_feed(now, roll, pitch, frames, q, arrival, now_s=now,
                                                  odometry=odometry)) is None
    assert monitor.counters == ErrorMonitor(config).counters  # a refused batch leaves nothing behind
    assert set(monitor.timelines.values()) == {None}
    short = ErrorMonitor(config).batch_feed(clean_t[:MIN_ARRAY_SAMPLES - 1], roll[:MIN_ARRAY_SAMPLES - 1],
                                            pitch[:MIN_ARRAY_SAMPLES - 1], [], np.empty((4, 0)), [])
    assert scan_clean(ErrorMonitor(config), short) is None


def _monitor_with_history(config):
    """A monitor that has seen a little input already (its timelines start before the batch)."""
    monitor = ErrorMonitor(config)
    monitor.add_truth_quaternion(99.0, [0.0, 0.0, 0.0, 1.0], now_s=99.0)
    monitor.add_sensor(99.5, 0.0, 0.0, now_s=99.5, u_rad=0.0, altitude_m=5e5, inclination_rad=1.3)
    return monitor


@pytest.mark.parametrize("late_s", [0.0, 1.5], ids=["sensor-on-time", "sensor-late"])
def test_where_the_input_is_cut_changes_nothing(late_s):
    """The same events cut into batches of random sizes (1 … 300 samples: the event scan, the array scan, the
    open segment and the queue carried from call to call) give the statuses, counters, statistics, queue and
    truth buffer of one message at a time — with a short truth history, a small capacity and a small queue,
    so that samples are also pushed out of the queue (the outage), reset at the jump, and — with the sensor
    1.5 s late, truth then covering a sample on arrival — too old for the buffer. Statistics within 1e-9
    arcmin (sums in another order).
    """
    from pmv_ros.runtime.monitor.records import BATCH_STATUSES, PENDING_CODE

    t, roll, pitch, frames, q, arrival, now, (position, velocity) = _hostile_batch(jump=True)
    t = t - late_s
    config = small_config(min_interval_s=0.002, truth_history_s=1.0, truth_capacity=8, max_pending=20)
    live, cut = ErrorMonitor(config), ErrorMonitor(config)
    status = _message_by_message(live, t, roll, pitch, frames, q, arrival, now, position, velocity)
    rng = np.random.default_rng(11)
    cut_status = {}
    lo = 0
    while lo < t.size:
        hi = min(t.size, lo + int(rng.choice([1, 2, 5, 40, 300])))
        mine = (arrival >= lo) & ((arrival < hi) | ((hi == t.size) & (arrival == t.size)))
        result = cut.add_batch(t[lo:hi], roll[lo:hi], pitch[lo:hi], frames[mine], q[:, mine], arrival[mine] - lo,
                               now_s=now[lo:hi], odometry=(position[:, lo:hi], velocity[:, lo:hi]),
                               odometry_max_age_s=5.0)
        cut_status.update((o.stamp_s, o.status) for o in result.earlier)
        for k in range(hi - lo):
            if result.status[k] != PENDING_CODE:
                settled = BATCH_STATUSES[result.status[k]]
                cut_status[(lo + k, "own") if isinstance(settled, Rejection) else float(t[lo + k])] = settled
        lo = hi
    values, counts = np.unique(t, return_counts=True)
    once = set(values[counts == 1].tolist())  # after the jump back a stamp can come twice: not compared
    compared = [key for key in status if not isinstance(key, float) or key in once]
    assert len(compared) > 5000
    assert {key: status[key] for key in compared} == {key: cut_status.get(key) for key in compared}
    counters = {k: v for k, v in live.counters.items() if v}
    assert counters == {k: v for k, v in cut.counters.items() if v}
    assert counters["clock_jumps"] == 1 and counters["skipped_pending_overflow"] > 500
    assert counters.get("skipped_too_old", 0) > 100 if late_s else counters["skipped_reset"]
    assert live.pending_count == cut.pending_count and live.truth_buffer_length == cut.truth_buffer_length
    for x, y in zip(live.summary().channels, cut.summary().channels):
        assert x.count == y.count
        for name in ("mean_rad", "sigma_rad", "max_abs_rad", "ground_sigma_m"):
            assert getattr(y, name) == pytest.approx(getattr(x, name), abs=1e-9 * ARCMIN_RAD, rel=1e-9), name


def test_a_wait_runs_out_only_at_an_event_whose_clock_is_past_it():
    """alignment.first_expired: a clock that went back (the old reading left on the event of a reset)
    is searched run by run, from each sample's arrival on — never a timeout read off an event before it."""
    from pmv_ros.runtime.monitor.alignment import first_expired

    clocks = np.array([5.0, 1.0, 2.0, 9.0])  # event 0 kept the clock of before the reset
    stamps, arrivals = np.array([0.0, 0.0, 1.0, 8.0]), np.array([0, 1, 1, 1])
    assert first_expired(clocks, stamps, 3.0, arrivals).tolist() == [0, 3, 3, 4]
    assert first_expired(np.array([1.0, 2.0, 9.0]), np.array([0.0]), 3.0, np.array([0])).tolist() == [2]
