"""Faults and bad input: the nodes keep working and lose nothing (issue 6, items 2–4).

* Sensor faults of the real instrument: the Sun or the Moon in a chord's
  field, and a chord that finds no horizon in its scan (large attitude
  excursion). Only that chord's pair angle is lost, the node says which chord
  and why on /diagnostics, and it recovers by itself.
* Bad messages: a stream with 10 % bad messages gives the monitor, the star
  tracker and the following sensor exactly the output of the clean stream,
  and every bad message is counted under its reason.
* Truth outages and discontinuities: hours without star-tracker truth, the
  clock jumping back and forward, a sensor and a star tracker restarted in a
  running graph.

In-process, as tests/nodes/test_nodes.py: nodes and test publishers share one
executor, drained after every publication; each test has its own context.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped, QuaternionStamped, Vector3Stamped
from rosgraph_msgs.msg import Clock

import pmv_msgs_shim as shim
from node_harness import probe
from pmv_ros.nodes.error_monitor_node import ErrorMonitorNode
from pmv_ros.nodes.pipeline import Pipeline
from pmv_ros.nodes.sensor_node import PARAMS as SENSOR_PARAMS
from pmv_ros.nodes.sensor_node import SensorNode
from pmv_ros.runtime.common.assembly import build_models
from pmv_ros.nodes.star_tracker_node import StarTrackerNode
from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.constants import ARCMIN_RAD, EARTH_MEAN_RADIUS_M
from pmv_ros.physics.orbit.ephemeris import Epoch, moon_direction_eci, sun_direction_from
from pmv_ros.physics.orbit.ephemeris import BODY_NAMES
from pmv_ros.physics.instrument.sensor import ChordStatus

#: A star tracker that tells the exact truth.
PERFECT_TRACKER = {"ideal": True}
#: Spherical Earth, uniform horizon: the sensor reads the attitude to a small fraction of an arcmin.
IDEAL_EARTH = {"sensor.earth_model": "sphere", "remove_oblateness": False}

#: An orbit whose plane holds the Sun: the 2024 March equinox (Sun at RA 0, Dec 0 within 0.01°) and the
#: ascending node at RA 0. Starting at u = 240°, orbital sunrise — the Sun rising over the limb straight
#: ahead, in the +X chord — comes about two minutes into the run.
SUNRISE = {"sim.epoch_utc": "2024-03-20T03:06:00Z", "orbit.raan_deg": 0.0, "orbit.u0_deg": 240.0}


# ------------------------------------------------------------------------------------------------ helpers

def health(messages, name_prefix: str) -> list:
    """(stamp_s, HealthStatus) of every /diagnostics status whose name starts with ``name_prefix``."""
    out = []
    for message in messages:
        report = shim.health_from_msg(message)
        out += [(report.stamp_s, status) for status in report.statuses if status.name.startswith(name_prefix)]
    return out


def values_of(status) -> dict:
    return dict(status.values)


def angles_msg(t_s, roll_rad, pitch_rad):
    return shim.write_attitude_angles(Vector3Stamped(), t_s, shim.SENSOR_FRAME, roll_rad, pitch_rad)


def quaternion_msg(t_s, q):
    """A QuaternionStamped with exactly the components given (NaN, zero norm and all)."""
    message = QuaternionStamped()
    shim.write_stamp(message.header.stamp, t_s)
    message.header.frame_id = shim.ORBITAL_FRAME
    message.quaternion.x, message.quaternion.y, message.quaternion.z, message.quaternion.w = (float(c) for c in q)
    return message


def sensor_values(**overrides) -> dict:
    values = {spec.name: spec.default for spec in SENSOR_PARAMS}
    values.update({"sim.fast_time": True, **overrides})
    return values


# ------------------------------------------------------------------------------- 3. sensor faults: Sun, Moon

def test_sun_in_a_chord_invalidates_that_chord_only_reports_it_and_recovers():
    # Orbital sunrise in the +X chord: pitch (±X) is lost while the Sun is in the field, roll (±Y) never is.
    with Pipeline(None, {**SUNRISE, "sensor.rate_hz": 1.0}, collect=False) as pipeline:
        got = probe(pipeline, {"/pmv/attitude": Vector3Stamped, "/pmv/horizon_crossings": PolygonStamped,
                               "/diagnostics": DiagnosticArray})
        pipeline.step(320)
    stamps = np.array([shim.time_from_msg(m.header.stamp) for m in got["/pmv/attitude"]])
    roll = np.array([m.vector.x for m in got["/pmv/attitude"]])
    pitch = np.array([m.vector.y for m in got["/pmv/attitude"]])
    valid = np.array([shim.horizon_crossings_from_msg(m).valid for m in got["/pmv/horizon_crossings"]])
    assert len(stamps) == valid.shape[0] == 320
    assert np.all(np.isfinite(roll)), "roll (±Y pair) must survive the Sun in +X"
    lost = np.flatnonzero(np.isnan(pitch))
    # One contiguous window of about two minutes (the Sun crosses 4.5° of scan arc + 2 × 3° exclusion
    # at the orbital rate of 3.8°/min), with valid pitch before and after it: recovery by itself.
    assert 90 <= lost.size <= 180, lost.size
    assert np.all(np.diff(lost) == 1)
    assert lost[0] > 60 and lost[-1] < 300
    assert np.all(~valid[lost, 0]) and np.all(valid[lost][:, 1:])  # only chord +X is invalid
    assert np.all(valid[: lost[0]]) and np.all(valid[lost[-1] + 1:])

    reports = health(got["/diagnostics"], "pmv_ros/sensor_node: horizon")
    during = [s for t, s in reports if stamps[lost[0]] <= t <= stamps[lost[-1]]]
    assert during, "no /diagnostics while the Sun was in the chord"
    assert during[0].level == shim.Level.WARN
    assert "chord +X" in during[0].message and "sun" in during[0].message, during[0].message
    assert values_of(during[0])["chord_+X"] == "sun_or_moon" and values_of(during[0])["chord_+Y"] == "valid"
    # Reported at once: the first report of the condition carries the first lost sample's stamp.
    assert any(t == pytest.approx(stamps[lost[0]]) for t, s in reports if "sun" in s.message)
    after = [(t, s) for t, s in reports if t > stamps[lost[-1]]]
    assert after and after[0][0] == pytest.approx(stamps[lost[-1] + 1])  # recovery reported at once, too
    assert after[0][1].level == shim.Level.OK and after[0][1].message == "all chords valid"
    assert int(values_of(after[-1][1])["sun_or_moon_+X"]) == lost.size


def test_sun_window_is_orbital_sunrise_and_the_exclusion_angle_sets_it():
    # Independent geometry: the chord is blinded from the moment the Sun clears the Earth's limb
    # (nadir angle asin(R/r)) until it is the exclusion angle beyond the scan start.
    values = sensor_values(**SUNRISE)
    orbit, profile, model = build_models(values)
    t = np.arange(0.0, 320.0, 0.5)
    reading = model.sense(t, profile.quaternion(t))
    blinded = reading.chord_status[0] == ChordStatus.SUN_OR_MOON
    assert np.all(reading.blinding_body[0][blinded] == BODY_NAMES.index("sun"))
    assert not np.any(reading.chord_status[1:] == ChordStatus.SUN_OR_MOON)

    position, _ = orbit.state_eci(t)
    epoch = model.config.epoch
    sun = sun_direction_from(position, epoch.julian_date_tt(t))
    sun_nadir_deg = np.degrees(np.arccos(-np.sum(sun * position, axis=0) / np.linalg.norm(position, axis=0)))
    limb_deg = np.degrees(np.arcsin(EARTH_MEAN_RADIUS_M / np.linalg.norm(position, axis=0)))
    scan_start_deg = np.degrees(model.scan_start_rad)
    first, last = np.flatnonzero(blinded)[[0, -1]]
    # 0.5 s steps move the Sun by 0.03°; the sphere-vs-ellipsoid limb and the β ≈ 0.02° out of plane add < 0.1°.
    assert sun_nadir_deg[first] == pytest.approx(limb_deg[first], abs=0.1)
    assert sun_nadir_deg[last] == pytest.approx(scan_start_deg + 3.0, abs=0.1)

    # With the check off nothing is flagged; a wider angle gives a longer window.
    reading_off = build_models({**values, "sensor.bright_body_exclusion_deg": 0.0})[2].sense(t, profile.quaternion(t))
    assert np.all(reading_off.chord_valid)
    reading_wide = build_models({**values, "sensor.bright_body_exclusion_deg": 6.0})[2].sense(t, profile.quaternion(t))
    assert (reading_wide.chord_status[0] == ChordStatus.SUN_OR_MOON).sum() > blinded.sum() + 60  # +3° ≈ 47 s


def test_moon_in_a_chord_is_named_as_the_moon():
    # A polar orbit whose plane holds the Moon (node at the Moon's right ascension) at first quarter,
    # when the Sun is 90° away: over one orbit the ±X chords see the Moon rise and set.
    epoch_utc = "2024-03-17T04:11:00Z"  # first quarter
    epoch = Epoch.from_utc(epoch_utc)
    moon = moon_direction_eci(epoch.julian_date_tt(0.0))
    raan_deg = math.degrees(math.atan2(moon[1], moon[0]))
    values = sensor_values(**{"sim.epoch_utc": epoch_utc, "orbit.inclination_deg": 90.0, "orbit.raan_deg": raan_deg})
    orbit, profile, model = build_models(values)
    t = np.arange(0.0, orbit.period_s, 2.0)
    reading = model.sense(t, profile.quaternion(t))
    by_moon = reading.blinding_body == BODY_NAMES.index("moon")
    assert by_moon[0].sum() > 10 and by_moon[2].sum() > 10  # rise ahead (+X) and set behind (−X)
    assert not np.any(by_moon[[1, 3]])
    assert np.all(reading.chord_status[by_moon] == ChordStatus.SUN_OR_MOON)
    assert np.all(np.isnan(reading.sensed_pitch_rad[np.any(by_moon, axis=0)]))
    assert np.all(np.isfinite(reading.sensed_roll_rad))


# ------------------------------------------------------------------- 3. sensor faults: Earth leaves the chord

def test_attitude_excursion_loses_the_chord_without_horizon_and_recovers():
    # A ±5° roll swing: past ≈ 2.9° the horizon of the chord on the side the Earth moves to lies beyond
    # the fixed scan start (3° margin), its scan starts inside the atmosphere and finds no horizon;
    # roll is lost, pitch is not, and both come back.
    overrides = {"attitude.roll_amplitude_arcmin": 300.0, "attitude.oscillation_period_s": 200.0,
                 "sensor.rate_hz": 1.0}
    with Pipeline(None, overrides, collect=False) as pipeline:
        got = probe(pipeline, {"/pmv/attitude": Vector3Stamped, "/pmv/horizon_crossings": PolygonStamped,
                               "/diagnostics": DiagnosticArray, "/attitude/truth": QuaternionStamped})
        pipeline.step(200)
    roll = np.array([m.vector.x for m in got["/pmv/attitude"]])
    pitch = np.array([m.vector.y for m in got["/pmv/attitude"]])
    valid = np.array([shim.horizon_crossings_from_msg(m).valid for m in got["/pmv/horizon_crossings"]])
    true_roll = 5.0 * np.sin(2 * np.pi * np.arange(1, 201) / 200.0)
    assert np.all(np.isfinite(pitch))
    lost = np.isnan(roll)
    assert np.array_equal(lost, ~(valid[:, 1] & valid[:, 3]))
    assert np.all(lost[np.abs(true_roll) > 3.1]) and not np.any(lost[np.abs(true_roll) < 2.7])
    assert np.all(valid[:, [0, 2]])
    # A positive roll (REP-103: right-hand about +X) puts the nadir on the body's −Y side, the Earth
    # moves there: −Y is lost, +Y stays valid, and the other way round.
    assert np.all(~valid[true_roll > 3.1, 3]) and np.all(valid[true_roll > 3.1, 1])
    assert np.all(~valid[true_roll < -3.1, 1]) and np.all(valid[true_roll < -3.1, 3])
    # Where roll is valid it is right: the chain reads the attitude to a few arcmin here.
    assert np.all(np.abs(np.degrees(roll[~lost]) - true_roll[~lost]) * 60.0 < 5.0)

    reports = health(got["/diagnostics"], "pmv_ros/sensor_node: horizon")
    messages = [s.message for _, s in reports]
    assert any("chord +Y: no horizon" in m for m in messages) and any("chord -Y: no horizon" in m for m in messages)
    last_lost_s = float(np.flatnonzero(lost)[-1] + 1)  # stamps are 1, 2, … s
    after = [s for t, s in reports if t > last_lost_s]
    assert after and after[0].message == "all chords valid" and after[0].level == shim.Level.OK
    assert int(values_of(reports[-1][1])["no_horizon_+Y"]) == int(np.sum(~valid[:, 1]))


# ------------------------------------------------------------------------------------ 2. bad messages

#: Length of the monitor's stream, s: one period of the truth's motion (60 s), 600 samples — each of the 14 kinds
#: of bad message comes 5 or 6 times (every ninth clean message is followed by one, the kinds in turn).
MONITOR_STREAM_S = 60


def _monitor_stream(bad: bool):
    """(kind, payload) of a 60 s stream: sensor at 10 Hz, truth at 2 Hz, /clock at 10 Hz; ~10 % bad if ``bad``.

    Truth: roll 5′ sin, pitch −2′ cos (period 60 s); the sensor reads 1.5′ more roll, 0.5′ less pitch
    plus 0.3′ noise. Bad messages of every kind are inserted between the clean ones (never instead of
    one, except near-unit quaternions, which replace their clean twin and must be normalised).
    """
    rng = np.random.default_rng(7)
    events, counts = [], {}
    bad_kinds = ("truth_nan", "truth_inf", "truth_norm", "truth_zero_norm", "truth_zero_stamp", "truth_future",
                 "truth_backwards", "truth_duplicate", "sensor_zero_stamp", "sensor_future", "sensor_backwards",
                 "sensor_duplicate", "sensor_inf", "sensor_unreadable")
    clean_count = 0
    last_truth = last_sensor = None
    for k in range(1, 10 * MONITOR_STREAM_S + 1):
        t = round(0.1 * k, 10)
        events.append(("clock", t))
        roll, pitch = 5 * ARCMIN_RAD * math.sin(2 * math.pi * t / 60), -2 * ARCMIN_RAD * math.cos(2 * math.pi * t / 60)
        clean = []
        if k % 5 == 0:
            q = np.array(quaternion_from_roll_pitch_yaw(roll, pitch, 0.0))
            if bad and k % 50 == 0:
                q = q * 1.005  # near-unit: normalised, not rejected
                counts["truth_quaternions_normalised"] = counts.get("truth_quaternions_normalised", 0) + 1
            clean.append(("truth", (t, q)))
            last_truth = (t, q)
        noise = rng.normal(0.0, 0.3 * ARCMIN_RAD, 2)
        clean.append(("sensor", (t, roll + 1.5 * ARCMIN_RAD + noise[0], pitch - 0.5 * ARCMIN_RAD + noise[1])))
        for event in clean:
            events.append(event)
            if event[0] == "sensor":
                last_sensor = event[1]
            clean_count += 1
            if bad and clean_count % 9 == 0 and last_truth is not None:
                kind = bad_kinds[(clean_count // 9) % len(bad_kinds)]
                counts[kind] = counts.get(kind, 0) + 1
                q_unit = quaternion_from_roll_pitch_yaw(0.01, 0.02, 0.0)
                events.append({
                    "truth_nan": ("truth", (t, [math.nan, 0.0, 0.0, 1.0])),
                    "truth_inf": ("truth", (t + 0.05, [0.0, math.inf, 0.0, 1.0])),
                    "truth_norm": ("truth", (t + 0.05, np.array(q_unit) * 1.5)),
                    "truth_zero_norm": ("truth", (t + 0.05, [0.0, 0.0, 0.0, 0.0])),
                    "truth_zero_stamp": ("truth", (0.0, q_unit)),
                    "truth_future": ("truth", (t + 50.0, q_unit)),
                    "truth_backwards": ("truth", (last_truth[0] - 0.35, q_unit)),
                    "truth_duplicate": ("truth", (last_truth[0], q_unit)),
                    "sensor_zero_stamp": ("sensor", (0.0, 0.1, 0.1)),
                    "sensor_future": ("sensor", (t + 50.0, 0.1, 0.1)),
                    "sensor_backwards": ("sensor", (last_sensor[0] - 0.25, 0.1, 0.1)),
                    "sensor_duplicate": ("sensor", (last_sensor[0], 0.1, 0.1)),
                    "sensor_inf": ("sensor", (t + 0.05, math.inf, 0.0)),
                    "sensor_unreadable": ("sensor_raw", -5),
                }[kind])
    events.append(("clock", MONITOR_STREAM_S + 1.5))  # let the 1 Hz diagnostics timer report the end
    return events, counts, clean_count


def _run_monitor(harness, events):
    h = harness(ErrorMonitorNode, {"remove_oblateness": False, "statistics_rate_hz": 1.0, "use_sim_time": True})
    residuals = h.record(Vector3Stamped, "/pmv/residual")
    statistics = h.record(DiagnosticArray, "/pmv/error_statistics")
    diagnostics = h.record(DiagnosticArray, "/diagnostics")
    sensor = h.publisher(Vector3Stamped, "/pmv/attitude")
    truth = h.publisher(QuaternionStamped, "/star_tracker/attitude")
    clock = h.publisher(Clock, "/clock")
    for kind, payload in events:
        if kind == "clock":
            clock.publish(shim.write_clock(Clock(), payload))
        elif kind == "truth":
            truth.publish(quaternion_msg(*payload))
        elif kind == "sensor":
            sensor.publish(angles_msg(*payload))
        else:  # a stamp the shim refuses: negative seconds
            message = angles_msg(1.0, 0.0, 0.0)
            message.header.stamp.sec = payload
            sensor.publish(message)
        h.drain()
    return residuals, statistics, diagnostics, h.node


def test_monitor_with_ten_percent_bad_messages_gives_the_clean_statistics_and_counts_each_reason(harness):
    clean_events, _, clean_count = _monitor_stream(bad=False)
    dirty_events, counts, _ = _monitor_stream(bad=True)
    bad_count = sum(v for k, v in counts.items() if k != "truth_quaternions_normalised")
    assert 0.09 <= bad_count / (clean_count + bad_count) <= 0.11
    assert all(counts.get(kind, 0) >= 5 for kind in ("truth_nan", "truth_future", "sensor_duplicate"))

    clean = _run_monitor(harness, clean_events)
    dirty = _run_monitor(harness, dirty_events)

    # Residuals: the same samples, the same values.
    clean_residuals = [(shim.time_from_msg(m.header.stamp), m.vector.x, m.vector.y) for m in clean[0]]
    dirty_residuals = [(shim.time_from_msg(m.header.stamp), m.vector.x, m.vector.y) for m in dirty[0]]
    assert len(clean_residuals) > 10 * MONITOR_STREAM_S - 50
    assert [r[0] for r in dirty_residuals] == [r[0] for r in clean_residuals]
    np.testing.assert_allclose(np.array(dirty_residuals), np.array(clean_residuals), rtol=0, atol=1e-15)
    # Statistics: published at the same stamps, with the same numbers (normalising a quaternion
    # scaled by 1.005 gives the same roll/pitch to rounding).
    clean_stats = [shim.error_statistics_from_msg(m) for m in clean[1]]
    dirty_stats = [shim.error_statistics_from_msg(m) for m in dirty[1]]
    assert [s.stamp_s for s in dirty_stats] == [s.stamp_s for s in clean_stats]
    for name in ("roll", "pitch", "meridional"):
        a, b = clean_stats[-1].channel(name), dirty_stats[-1].channel(name)
        assert b.count == a.count > 10 * MONITOR_STREAM_S - 50
        for field in ("mean_rad", "sigma_rad", "three_sigma_rad", "max_abs_rad"):
            assert getattr(b, field) == pytest.approx(getattr(a, field), rel=1e-12, abs=1e-18), (name, field)
    assert clean_stats[-1].channel("roll").mean_rad / ARCMIN_RAD == pytest.approx(1.5, abs=0.05)

    # Every bad message counted under its reason, on /diagnostics.
    report = values_of(health(dirty[2], "pmv_ros/error_monitor_node")[-1][1])
    expected = {
        "rejected_truth_non_finite": counts["truth_nan"] + counts["truth_inf"],
        "rejected_truth_bad_quaternion": counts["truth_norm"] + counts["truth_zero_norm"],
        "rejected_truth_zero_stamp": counts["truth_zero_stamp"],
        "rejected_truth_future_stamp": counts["truth_future"],
        "rejected_truth_backwards": counts["truth_backwards"],
        "rejected_truth_duplicate": counts["truth_duplicate"],
        "rejected_sensor_zero_stamp": counts["sensor_zero_stamp"],
        "rejected_sensor_future_stamp": counts["sensor_future"],
        "rejected_sensor_backwards": counts["sensor_backwards"],
        "rejected_sensor_duplicate": counts["sensor_duplicate"],
        "rejected_sensor_non_finite": counts["sensor_inf"],
        "rejected_sensor_unreadable": counts["sensor_unreadable"],
        "truth_quaternions_normalised": counts["truth_quaternions_normalised"],
    }
    assert {key: int(report.get(key, 0)) for key in expected} == expected
    assert sum(expected.values()) - counts["truth_quaternions_normalised"] == bad_count
    clean_report = values_of(health(clean[2], "pmv_ros/error_monitor_node")[-1][1])
    assert not any(key.startswith("rejected_") for key in clean_report)
    assert report["used"] == clean_report["used"]
    assert "clock_jumps" not in report  # backward stamps by less than clock_jump_s are not jumps


#: Length of the star tracker's stream, s: 60 frames at 2 Hz, with each of the 8 kinds of bad message 3 or 4 times
#: and 7 near-unit quaternions among its 300 truth samples.
TRACKER_STREAM_S = 30


def _tracker_stream(bad: bool):
    """Truth at 10 Hz for 30 s (a slow roll/pitch motion), with ~10 % bad messages of every kind if ``bad``.

    The last 2 s are clean, so that the last /diagnostics report (1 s of truth time apart) counts them all.
    """
    kinds = ("nan", "inf", "norm", "zero_norm", "zero_stamp", "future", "backwards", "duplicate")
    events, counts = [], dict.fromkeys(kinds, 0)
    counts["normalised"] = 0
    last = 10 * TRACKER_STREAM_S
    for k in range(1, last + 1):
        t = round(0.1 * k, 10)
        events.append(("clock", t))
        q = np.array(quaternion_from_roll_pitch_yaw(3 * ARCMIN_RAD * math.sin(t / 10), ARCMIN_RAD * t / 60, 0.0))
        if bad and k % 40 == 0 and k <= last - 20:
            q, counts["normalised"] = q * 0.995, counts["normalised"] + 1
        events.append(("truth", (t, q)))
        if bad and k % 9 == 0 and k <= last - 20:
            kind = kinds[(k // 9) % len(kinds)]
            counts[kind] += 1
            events.append(("truth", {
                "nan": (t + 0.05, [math.nan] * 4), "inf": (t + 0.05, [0.0, 0.0, -math.inf, 1.0]),
                "norm": (t + 0.05, q * 0.5), "zero_norm": (t + 0.05, [0.0] * 4), "zero_stamp": (0.0, q),
                "future": (t + 30.0, q), "backwards": (t - 0.3, q), "duplicate": (t, q)}[kind]))
    return events, counts


def test_star_tracker_drops_bad_truth_and_publishes_the_frames_of_the_clean_stream(harness):
    outputs = []
    for bad in (False, True):
        events, counts = _tracker_stream(bad)
        h = harness(StarTrackerNode, {"frame_period_s": 0.5, "processing_s": 0.25, "use_sim_time": True})
        measured = h.record(QuaternionStamped, "/star_tracker/attitude")
        diagnostics = h.record(DiagnosticArray, "/diagnostics")
        truth, clock = h.publisher(QuaternionStamped, "/attitude/truth"), h.publisher(Clock, "/clock")
        for kind, payload in events:
            if kind == "clock":
                clock.publish(shim.write_clock(Clock(), payload))
            else:
                truth.publish(quaternion_msg(*payload))
            h.drain()
        outputs.append(np.array([[shim.time_from_msg(m.header.stamp), m.quaternion.x, m.quaternion.y,
                                  m.quaternion.z, m.quaternion.w] for m in measured]))
    clean, dirty = outputs
    assert clean.shape[0] > 2 * TRACKER_STREAM_S - 10  # 2 Hz, minus the odd random failure
    assert np.array_equal(dirty[:, 0], clean[:, 0])
    np.testing.assert_allclose(dirty, clean, rtol=0, atol=1e-12)  # same frames, same seeded noise
    report = values_of(health(diagnostics, "pmv_ros/star_tracker_node")[-1][1])
    assert int(report["rejected_truth_non_finite"]) == counts["nan"] + counts["inf"]
    assert int(report["rejected_truth_bad_quaternion"]) == counts["norm"] + counts["zero_norm"]
    for kind in ("zero_stamp", "backwards", "duplicate"):
        assert int(report[f"rejected_truth_{kind}"]) == counts[kind] > 0, kind
    assert int(report["rejected_truth_future_stamp"]) == counts["future"] > 0
    assert int(report["truth_quaternions_normalised"]) == counts["normalised"] > 0
    assert int(report["clock_jumps"]) == 0


def test_following_sensor_drops_bad_truth_and_reads_the_clean_attitude(harness):
    # attitude.source = follow: the sensor takes its attitude from /attitude/truth.
    outputs = []
    for bad in (False, True):
        h = harness(SensorNode, {"attitude.source": "follow", "sim.fast_time": True, "sensor.rate_hz": 2.0,
                                 "sensor.detector": "ideal"}, external_drive=True)
        attitude = h.record(Vector3Stamped, "/pmv/attitude")
        diagnostics = h.record(DiagnosticArray, "/diagnostics")
        truth = h.publisher(QuaternionStamped, "/attitude/truth")
        rejected = 0
        for k in range(1, 121):
            t = 0.5 * k
            q = np.array(quaternion_from_roll_pitch_yaw(10 * ARCMIN_RAD * math.sin(t / 20), -4 * ARCMIN_RAD, 0.0))
            truth.publish(quaternion_msg(t, q))
            h.drain()
            if bad and k % 3 == 0 and k <= 116:  # the last 2 s clean: the last report (1 s apart) counts all
                # after the good sample: every kind of bad one (the follower must keep the good one)
                for stamp, bad_q in ((t, [math.nan, 0, 0, 1]), (t + 0.1, q * 2.0), (0.0, q), (t + 50.0, q),
                                     (t - 0.2, q * 0.0 + [0, 0, 0, 1]), (t, [0.0, 0.0, 0.0, 1.0])):
                    truth.publish(quaternion_msg(stamp, bad_q))
                    rejected += 1
                h.drain()
            h.node.step()
            h.drain()
        outputs.append(np.array([[m.vector.x, m.vector.y] for m in attitude]))
    clean, dirty = outputs
    assert clean.shape == dirty.shape == (120, 2)
    assert np.array_equal(dirty, clean)
    report = values_of(health(diagnostics, "pmv_ros/sensor_node: horizon")[-1][1])
    counted = sum(int(v) for key, v in report.items() if key.startswith("rejected_truth_"))
    assert counted == rejected
    for reason in ("non_finite", "bad_quaternion", "zero_stamp", "future_stamp", "backwards", "duplicate"):
        assert int(report[f"rejected_truth_{reason}"]) == rejected // 6, reason


def test_following_sensor_on_the_wall_clock_takes_truth_stamped_now(harness):
    # Real time (no fast time): "now" for the future-stamp check is the node clock, so truth
    # stamped now is read, and truth stamped a minute ahead is dropped as a future stamp.
    # Each tick samples the grid times (10 Hz) due since the last one: each lies within the
    # last 0.1 s, between truth samples or a few ms past the newest (the extrapolation horizon,
    # 0.25 s, covers a loaded machine).
    h = harness(SensorNode, {"attitude.source": "follow", "sim.fast_time": False, "sensor.rate_hz": 10.0,
                             "sensor.detector": "ideal"})
    attitude = h.record(Vector3Stamped, "/pmv/attitude")
    diagnostics = h.record(DiagnosticArray, "/diagnostics")
    truth = h.publisher(QuaternionStamped, "/attitude/truth")
    q = np.array(quaternion_from_roll_pitch_yaw(10 * ARCMIN_RAD, -4 * ARCMIN_RAD, 0.0))
    ticks = []
    for k in range(3):
        if k:
            time.sleep(0.11)  # more than a period: at least one new grid time is due
        now_s = h.node.get_clock().now().nanoseconds * 1e-9
        truth.publish(quaternion_msg(now_s + 60.0, q))
        if k == 0:  # a second sample: the rate to carry on
            truth.publish(quaternion_msg(now_s - 0.1, q))
        truth.publish(quaternion_msg(now_s, q))
        h.drain()
        h.node.tick()  # the timer's work, without waiting for it
        ticks.append(h.node.get_clock().now().nanoseconds * 1e-9)
        h.drain()
    stamps = np.array([shim.time_from_msg(m.header.stamp) for m in attitude])
    assert len(attitude) >= 3 and stamps[-1] <= ticks[-1] and np.all(np.diff(stamps) > 0.099)
    np.testing.assert_allclose([[m.vector.x, m.vector.y] for m in attitude],
                               [[10 * ARCMIN_RAD, -4 * ARCMIN_RAD]] * len(attitude), atol=0.05 * ARCMIN_RAD)
    # /diagnostics comes once a second or when the chords change: the first report already counts the first.
    report = values_of(health(diagnostics, "pmv_ros/sensor_node: horizon")[-1][1])
    assert int(report["rejected_truth_future_stamp"]) >= 1 and not any(k.startswith("skipped_") for k in report)


# ---------------------------------------------------------------------- 4. truth outages and discontinuities

def test_hours_long_star_tracker_outage_neither_stalls_nor_invents_truth():
    # Two hours without truth (a solar-flare outage, physics.md §6) in a 2¼ h run at 0.125 Hz. The cost is one
    # pipeline step a sample: 5 min before the outage fill the truth history (60 s) many times over, 10 min
    # after it show the alignment resumed for good, and an 8 s sample period stays clear of the monitor's
    # 10 s forward-jump threshold (max_truth_wait_s), so a step of the clock is never a suspected jump.
    start_s, duration_s, run_s, rate_hz = 300.0, 7200.0, 8100.0, 0.125
    overrides = {**PERFECT_TRACKER, "outage_start_s": [start_s], "outage_duration_s": [duration_s],
                 "sensor.rate_hz": rate_hz, "max_truth_gap_s": 10.0}
    with Pipeline(None, overrides) as pipeline:
        got = probe(pipeline, {"/diagnostics": DiagnosticArray})
        pending_max = truth_buffer_max = 0
        for _ in range(int(run_s * rate_hz)):
            pipeline.step()
            pending_max = max(pending_max, pipeline.monitor.monitor.pending_count)
            truth_buffer_max = max(truth_buffer_max, pipeline.monitor.monitor.truth_buffer_length)
        statistics = pipeline.monitor.publish_statistics(pipeline.sensor.sim_time_s)
        stamps = pipeline.collector.residual_array()[0]
    counters = statistics.counters
    # Samples give up after max_truth_wait_s = 10 s: 8 s apart, never more than 2 wait (3 at 0.2 Hz before).
    assert 1 <= pending_max <= 2
    assert truth_buffer_max <= 60.0 * 2.0 + 2  # truth_history_s at 2 Hz
    skipped = sum(v for k, v in counters.items() if k.startswith("skipped_"))
    assert abs(skipped - duration_s * rate_hz) <= 4, counters
    assert not np.any((stamps > start_s + 1.0) & (stamps < start_s + duration_s - 1.0))
    assert np.sum(stamps > start_s + duration_s) >= (run_s - start_s - duration_s) * rate_hz - 4  # resumed
    assert counters["used"] >= (run_s - duration_s) * rate_hz - 6
    assert counters["clock_jumps"] == 0
    monitor_reports = health(got["/diagnostics"], "pmv_ros/error_monitor_node")
    in_outage = [s for t, s in monitor_reports if start_s + 3600.0 < t < start_s + duration_s]
    assert in_outage and all("no star-tracker truth for" in s.message for s in in_outage)
    ages = [float(s.message.split("no star-tracker truth for ")[1].split(" s")[0]) for s in in_outage]
    assert min(ages) >= 3590.0 and max(ages) > duration_s - 600.0  # the age of the last truth, growing
    assert monitor_reports[-1][1].level == shim.Level.OK, monitor_reports[-1][1]
    tracker_reports = health(got["/diagnostics"], "pmv_ros/star_tracker_node")
    assert any("scheduled outage" in s.message for t, s in tracker_reports if start_s < t < start_s + duration_s)
    assert tracker_reports[-1][1].message == "attitude available"


def test_monitor_clock_jumps_reset_alignment_and_never_mix_timelines(harness):
    # Timeline 1: truth roll 5′; the clock jumps back (a restarted simulation) and timeline 2 has
    # truth 20′; then the clock jumps forward by an hour. The sensor always reads 1′ more than the
    # truth, so a residual other than 1′ would be truth of one timeline against a sample of another.
    h = harness(ErrorMonitorNode, {"remove_oblateness": False, "use_sim_time": True})
    residuals = h.record(Vector3Stamped, "/pmv/residual")
    diagnostics = h.record(DiagnosticArray, "/diagnostics")
    sensor = h.publisher(Vector3Stamped, "/pmv/attitude")
    truth = h.publisher(QuaternionStamped, "/star_tracker/attitude")
    clock = h.publisher(Clock, "/clock")

    def run(first_s, seconds, truth_arcmin):
        for k in range(int(seconds * 10)):
            t = round(first_s + 0.1 * k, 10)
            clock.publish(shim.write_clock(Clock(), t))
            h.drain()
            if k % 5 == 0:
                truth.publish(quaternion_msg(t, quaternion_from_roll_pitch_yaw(truth_arcmin * ARCMIN_RAD, 0.0)))
            sensor.publish(angles_msg(t, (truth_arcmin + 1.0) * ARCMIN_RAD, 0.0))
            h.drain()

    # Each timeline 15–30 s (150–300 samples): tens of truth frames each, and the jumps (30 s back, an hour
    # forward) far beyond clock_jump_s (1 s) and max_truth_wait_s (10 s).
    run(1.0, 30.0, 5.0)
    used_before = h.node.monitor.counters["used"]
    run(0.5, 15.0, 20.0)  # the clock went back by 30 s
    # A message of the old timeline still in flight: it is in the future now, and rejected.
    truth.publish(quaternion_msg(28.0, quaternion_from_roll_pitch_yaw(5 * ARCMIN_RAD, 0.0)))
    h.drain()
    run(3600.0, 15.0, 20.0)  # forward by an hour
    run(3615.0, 2.0, 20.0)
    counters = h.node.monitor.counters
    values = np.array([m.vector.x for m in residuals]) / ARCMIN_RAD
    stamps = np.array([shim.time_from_msg(m.header.stamp) for m in residuals])
    np.testing.assert_allclose(values, 1.0, atol=1e-9)
    assert counters["clock_jumps"] == 1 and counters["alignment_resets"] == 1
    # The old-timeline truth in flight — and the first truth of the hour-ahead timeline: a /clock jump sets the
    # node's time only once the next /clock message confirms it (README, "A hostile /clock"), so that truth
    # arrives while the node clock is still on the old timeline, in its future.
    assert counters["rejected_truth_future_stamp"] == 2
    assert used_before > 290 and counters["used"] > used_before + 140 + 150
    # Alignment resumed after the forward jump, and nothing across it was compared.
    after_jump_back = stamps[used_before:]
    assert np.all((after_jump_back <= 15.5) | (after_jump_back >= 3600.0))
    assert np.sum(after_jump_back >= 3600.0) > 150
    report = values_of(health(diagnostics, "pmv_ros/error_monitor_node")[-1][1])
    assert int(report["clock_jumps"]) == 1 and int(report["alignment_resets"]) == 1
    statistics = h.node.publish_statistics(3617.0)
    assert statistics.channel("roll").mean_rad / ARCMIN_RAD == pytest.approx(1.0, abs=1e-9)
    assert statistics.channel("roll").count == counters["used"]


def test_restarted_sensor_node_starts_a_new_timeline_that_is_never_mixed_with_the_old():
    # The sensor process restarts (its simulation clock starts over at 0) with a new roll offset:
    # truth of the old run against samples of the new one would show a residual of about 30′.
    overrides = {**PERFECT_TRACKER, **IDEAL_EARTH, "sensor.rate_hz": 2.0}
    with Pipeline(None, overrides) as pipeline:
        got = probe(pipeline, {"/star_tracker/attitude": QuaternionStamped})
        pipeline.step(200)
        used_before = pipeline.monitor.monitor.counters["used"]
        pipeline.stop_node("sensor")
        pipeline.start_node("sensor", {"attitude.roll_offset_arcmin": 30.0})
        pipeline.step(200)
        residuals = pipeline.collector.residual_array()
        counters = pipeline.monitor.monitor.counters
        tracker = pipeline.star_tracker.counters
    assert counters["clock_jumps"] == 1 and counters["alignment_resets"] == 1
    assert np.max(np.abs(residuals[1:])) / ARCMIN_RAD < 0.1
    stamps = residuals[0]
    restart = int(np.argmax(np.diff(stamps) < 0)) + 1
    assert restart > 150 and stamps[restart] < 5.0  # the second run starts again near 0
    assert counters["used"] - used_before > 180  # and is aligned again within a few samples
    assert tracker["clock_jumps"] == 1
    tracker_stamps = np.array([shim.time_from_msg(m.header.stamp) for m in got["/star_tracker/attitude"]])
    assert np.sum(np.diff(tracker_stamps) < 0) == 1  # the star tracker followed the new timeline once


def test_restarted_star_tracker_node_is_a_truth_gap_and_the_monitor_resumes():
    overrides = {**PERFECT_TRACKER, **IDEAL_EARTH, "sensor.rate_hz": 2.0}
    with Pipeline(None, overrides) as pipeline:
        got = probe(pipeline, {"/diagnostics": DiagnosticArray})
        pipeline.step(100)  # 50 s
        pipeline.stop_node("star_tracker")
        pipeline.step(60)  # 30 s without a star tracker
        pipeline.start_node("star_tracker")
        pipeline.step(100)
        statistics = pipeline.monitor.publish_statistics(pipeline.sensor.sim_time_s)
        stamps = pipeline.collector.residual_array()[0]
    counters = statistics.counters
    assert counters["clock_jumps"] == 0 and counters["alignment_resets"] == 0  # same clock: no reset needed
    assert not np.any((stamps > 51.0) & (stamps < 80.0))
    assert np.sum(stamps > 80.5) > 90  # resumed
    skipped = sum(v for k, v in counters.items() if k.startswith("skipped_"))
    assert 55 <= skipped <= 64
    messages = [s.message for t, s in health(got["/diagnostics"], "pmv_ros/error_monitor_node") if 62.0 < t < 80.0]
    assert messages and all("no star-tracker truth for" in m for m in messages)
