"""The error monitor's runtime without ROS: inputs refused or fed, residuals, the statistics schedule, health."""

from __future__ import annotations

import math
from dataclasses import astuple

import numpy as np
import pytest
import yaml

from flights import REPO
from pmv_ros.analysis.statistics import CHANNELS
from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.orbit.two_body import CircularOrbit
from pmv_ros.runtime.flight import flight_values
from pmv_ros.runtime.monitor.runtime import STATISTICS_VECTORS, MonitorRuntime, oblateness_override
from pmv_ros.runtime.common.records import Level


def values_of(overrides: dict | None = None):
    document = yaml.safe_load((REPO / "config" / "kondor.yaml").read_text())
    return flight_values(document, overrides)


def test_the_oblateness_override_is_zero_only_when_the_sensor_removes_it_on_board():
    assert oblateness_override({"sensor.oblateness_compensation": False}) == {}
    assert oblateness_override({"sensor.oblateness_compensation": True}) == {
        "oblateness_roll_rad": 0.0, "oblateness_pitch_rad": 0.0}


def test_residuals_statistics_schedule_and_health_of_the_monitor():
    values = values_of({"statistics_rate_hz": 0.5}).monitor
    problems = []
    runtime = MonitorRuntime(values, source_problems=lambda: list(problems), source_counters=dict)
    frames = runtime.frames
    orbit = CircularOrbit(values["orbit.altitude_km"] * 1e3, math.radians(values["orbit.inclination_deg"]))
    # Refused before the monitor: another frame, or unreadable.
    runtime.add_sensor("eci", 1.0, 0.0, 0.0, 1.0)
    runtime.add_truth(frames.orbital, None, None, 1.0)
    runtime.add_odometry(frames.eci, "body", None, 1.0)
    assert runtime.rejected_messages == {**{k: 0 for k in runtime.rejected_messages},
                                         "rejected_sensor_wrong_frame": 1, "rejected_truth_unreadable": 1,
                                         "rejected_odometry_wrong_frame": 1}
    first = runtime.health(1.0)
    assert first.level is Level.WARN and "rejected input messages" in first.message
    assert "rejected input messages" not in runtime.health(1.0).message  # said once per new rejection
    offset_rad = 1.5 * ARCMIN_RAD
    residuals, statistics = [], []
    for k in range(100):
        t_s = 10.0 + 0.1 * k
        position, velocity = orbit.state_eci(t_s)
        runtime.add_odometry(frames.eci, frames.orbital, (t_s, position, velocity), t_s)
        truth = runtime.add_truth(frames.orbital, t_s, quaternion_from_roll_pitch_yaw(0.0, 0.0, 0.0), t_s)
        residuals += truth.residuals
        out = runtime.add_sensor(frames.sensor, t_s, offset_rad, -offset_rad, t_s)
        residuals += out.residuals
        if out.statistics is not None:
            statistics.append(out.statistics)
    assert len(residuals) >= 95
    np.testing.assert_allclose([r.residual_roll_rad for r in residuals], offset_rad, atol=1e-12)
    np.testing.assert_allclose([r.residual_pitch_rad for r in residuals], -offset_rad, atol=1e-12)
    stamps = [s.stamp_s for s in statistics]
    assert stamps[0] == 10.0 and np.allclose(np.diff(stamps), 2.0)  # 0.5 Hz of sample time
    last = statistics[-1]
    for name, statistic in STATISTICS_VECTORS.items():
        assert last.vectors[name] == tuple(getattr(last.summary.channel(c), statistic) for c in CHANNELS)
    problems.append("2 publishers of /pmv/attitude")
    health = runtime.health(20.0)
    assert health.level is Level.ERROR and health.values["used"] == runtime.monitor.counters["used"] > 0
    runtime.reconfigure(values)  # new statistics: the next sample publishes at once
    assert runtime.add_sensor(frames.sensor, 21.0, 0.0, 0.0, 21.0).statistics.stamp_s == 21.0


def _hostile_messages(runtime, seconds: float = 120.0):
    """The node's messages of a 10 Hz sensor with 2 Hz truth (0.25 s late), interleaved as a wake-up takes them,
    with refused and bad ones, a star-tracker outage, samples before the clock starts and a clock restart."""
    frames = runtime.frames
    values = runtime.values
    orbit = CircularOrbit(values["orbit.altitude_km"] * 1e3, math.radians(values["orbit.inclination_deg"]))
    rng = np.random.default_rng(5)
    events = []
    for k in range(int(seconds * 10)):
        clock = 100.0 + 0.1 * k - (40.0 if k >= 700 else 0.0)  # the clock restarts 40 s back at 70 s
        now = None if k < 3 else clock
        roll, pitch = 1e-3 * math.sin(clock / 30.0) + 1e-4 * rng.standard_normal(), -5e-4 + 1e-4 * rng.standard_normal()
        if k % 37 == 5:
            roll = math.nan
        if k % 41 == 9:
            roll, pitch = 1e3, 0.0
        position, velocity = orbit.state_eci(clock)
        sensor = ("add_sensor", (frames.sensor, clock, roll, pitch), now)
        odometry = ("add_odometry", (frames.eci, frames.orbital, (clock, position, velocity)), now)
        events += [sensor, odometry] if k % 2 else [odometry, sensor]
        if k % 5 == 2 and not 300 <= k < 450:  # truth at 2 Hz, 0.25 s late; an outage of 15 s
            stamp = clock - 0.25
            q = quaternion_from_roll_pitch_yaw(1e-3 * math.sin(stamp / 30.0), -5e-4, 0.01)
            events.insert(len(events) - int(rng.integers(0, 3)), ("add_truth", (frames.orbital, stamp, q), now))
        if k % 5 == 2 and 300 <= k < 450:  # the tracker says why it has no attitude in the outage
            events.append(("add_frame_status", (clock - 0.25, "exclusion" if k < 380 else "no_stars"), now))
        if k % 53 == 11:
            events += [("add_sensor", ("eci", clock, 0.0, 0.0), now),
                       ("add_sensor", (frames.sensor, None, None, None), now),
                       ("add_truth", (frames.orbital, None, None), now),
                       ("add_truth", ("eci", clock, (0, 0, 0, 1)), now),
                       ("add_odometry", (frames.eci, "body", None), now),
                       ("add_odometry", (frames.eci, frames.orbital, None), now),
                       ("add_frame_status", (None, None), now)]
    return events


def test_messages_cut_into_wake_up_batches_publish_what_one_at_a_time_does():
    """add_inputs (a wake-up's messages at once, the node's way) against the one-message inputs, on a hostile
    stream cut at random: the same residuals in the same order (bit for bit), the statistics at the same stamps
    with the same counters (their sums within 1e-9 arcmin: taken in another order), the same refusals."""
    from pmv_ros.runtime.monitor.records import Outcome
    from pmv_ros.runtime.monitor.runtime import MonitorStatistics

    values = values_of({"statistics_rate_hz": 1.0}).monitor
    one, cut = MonitorRuntime(values), MonitorRuntime(values)
    events = _hostile_messages(one)
    methods = {"add_sensor": one.add_sensor, "add_truth": one.add_truth, "add_odometry": one.add_odometry,
               "add_frame_status": one.add_frame_status}
    expected = [item for to, arguments, now in events for item in methods[to](*arguments, now).published]
    rng = np.random.default_rng(9)
    published, lo = [], 0
    while lo < len(events):
        hi = lo + int(rng.choice([1, 2, 3, 5, 30, 200]))
        published += cut.add_inputs(events[lo:hi]).published
        lo = hi
    assert [type(item) for item in published] == [type(item) for item in expected]
    residuals = [(a, b) for a, b in zip(published, expected) if type(a) is Outcome]
    same = [all(x == y or (x != x and y != y) for x, y in zip(astuple(a), astuple(b))) for a, b in residuals]
    assert len(residuals) > 700 and all(same)  # NaN where an angle is lost
    statistics = [(a, b) for a, b in zip(published, expected) if type(a) is MonitorStatistics]
    assert len(statistics) > 100
    for a, b in statistics:
        assert a.stamp_s == b.stamp_s and a.summary.counters == b.summary.counters
        for x, y in zip(a.summary.channels, b.summary.channels):
            assert x.count == y.count
            for name in ("mean_rad", "sigma_rad", "max_abs_rad", "ground_sigma_m"):
                assert getattr(x, name) == pytest.approx(getattr(y, name), abs=1e-9 * ARCMIN_RAD, rel=1e-9,
                                                         nan_ok=True)
    counters = one.monitor.counters
    assert counters == cut.monitor.counters and one.rejected_messages == cut.rejected_messages
    assert counters["clock_jumps"] == 1 and counters["skipped_stale_truth"]
    assert counters["rejected_sensor_implausible_angle"] and counters["used_one_angle"]
    assert all(one.rejected_messages.values())
    # The samples the outage left without truth, by the tracker's reason, whichever way the messages were cut.
    lost = one.truth_lost
    assert lost == cut.truth_lost and lost["truth_lost_exclusion"] > 50 and lost["truth_lost_no_stars"] > 50
    assert sum(lost.values()) == sum(counters[f"skipped_{s}"] for s in ("no_truth", "truth_gap", "stale_truth"))
    assert "truth_lost_exclusion" in one.health(None).values


def test_statistics_read_long_after_their_stamp_are_those_of_their_stamp():
    """A MonitorStatistics is made at its first read (the harmonic fit costs ≈ 1 ms once the ring holds an orbit,
    and in a private graph most statistics have no reader): over an orbit and a bit, statistics read only at the
    end are bit for bit those another runtime read as they came, harmonics included."""
    values = values_of({"statistics_rate_hz": 0.05}).monitor
    at_once, at_end = MonitorRuntime(values), MonitorRuntime(values)
    frames = at_once.frames
    orbit = CircularOrbit(values["orbit.altitude_km"] * 1e3, math.radians(values["orbit.inclination_deg"]))
    rng = np.random.default_rng(11)
    read, kept = [], []
    for k in range(int(1.05 * orbit.period_s)):
        t_s = 100.0 + k
        position, velocity = orbit.state_eci(t_s)
        roll = 1e-3 * math.sin(2.0 * math.pi * t_s / orbit.period_s) + 1e-5 * rng.standard_normal()
        events = [("add_odometry", (frames.eci, frames.orbital, (t_s, position, velocity)), t_s),
                  ("add_truth", (frames.orbital, t_s, quaternion_from_roll_pitch_yaw(0.0, 0.0, 0.0)), t_s),
                  ("add_sensor", (frames.sensor, t_s, roll, -5e-4), t_s)]
        for runtime, out in ((at_once, read), (at_end, kept)):
            statistics = runtime.add_inputs(events).statistics
            if statistics is not None:
                out.append((statistics.summary, statistics.vectors) if runtime is at_once else statistics)
    assert len(read) == len(kept) > 250
    assert kept[-1].summary.harmonics_full_orbit
    assert all(map(math.isfinite, kept[-1].summary.channel("roll").harmonics_rad.values()))
    assert [repr((s.summary, s.vectors)) for s in kept] == [repr(pair) for pair in read]


def test_truth_in_the_wrong_frame_is_said_once_with_what_was_expected_and_named_on_diagnostics():
    # Issue 51: truth stamped `orbital` to a spacecraft in sat1, a thousand times. Before: nothing on the log, and a
    # status that read "no star-tracker truth received yet".
    values = values_of({"frames.prefix": "sat1/"}).monitor
    runtime = MonitorRuntime(values)
    q = quaternion_from_roll_pitch_yaw(0.0, 0.0, 0.0)
    outputs = [runtime.add_inputs([("add_truth", ("orbital", 10.0 + 0.5 * k, q), 10.0 + 0.5 * k)] * 2)
               for k in range(500)]
    lines = [line for output in outputs for line in output.log]
    assert len(lines) == 1 and lines[0].level == "error"
    assert lines[0].text.startswith("star-tracker truth refused: expected sat1/orbital, got orbital")
    assert runtime.rejected_messages["rejected_truth_wrong_frame"] == 1000
    health = runtime.health(260.0)
    assert health.level is Level.WARN
    assert "star-tracker truth refused: expected sat1/orbital, got orbital (1000 refused)" in health.message
    assert "no star-tracker truth" not in health.message and health.values["rejected_truth_wrong_frame"] == 1000
    # Odometry names the frame of each part; once the truth comes in its frame, the status stops naming it.
    out = runtime.add_odometry("eci", "orbital", None, 260.0)
    assert [line.text.split(":")[0] for line in out.log] == ["odometry child frame refused"]
    assert "expected sat1/orbital, got orbital" in out.log[0].text
    assert not runtime.add_truth("sat1/orbital", 261.0, q, 261.0).log
    assert "star-tracker truth refused" not in runtime.health(261.0).message
    assert not runtime.add_truth("orbital", 262.0, q, 262.0).log  # said once, however often it comes back
