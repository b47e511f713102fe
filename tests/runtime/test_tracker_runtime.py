"""The star tracker's runtime without ROS: the truth it takes, the frames it releases, what it reports."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from flights import REPO
from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.runtime.flight import flight_values
from pmv_ros.runtime.common.records import Level
from pmv_ros.runtime.tracker.runtime import TrackerRuntime, track_stream


def values_of(overrides: dict | None = None):
    document = yaml.safe_load((REPO / "config" / "kondor.yaml").read_text())
    return flight_values(document, overrides)


def truth_stream(start_s: float, seconds: float, rate_hz: float = 10.0):
    t = start_s + np.arange(int(seconds * rate_hz)) / rate_hz
    q = np.array(quaternion_from_roll_pitch_yaw(5 * ARCMIN_RAD * np.sin(t / 50.0), np.full_like(t, -2 * ARCMIN_RAD),
                                                np.zeros_like(t)))
    return t, q


def test_checked_truth_gives_the_frames_of_the_frame_loop_and_bad_truth_changes_nothing():
    values = values_of().star_tracker
    t, q = truth_stream(10.0, 6.0)
    reference = track_stream(TrackerRuntime(values, 0.0), t, q)  # the campaign's path, a clean stream
    runtime = TrackerRuntime(values, 0.0)
    orbital = runtime.frames.orbital
    released, reports = [], []
    for k, (t_s, q_k) in enumerate(zip(t.tolist(), q.T)):
        if k % 7 == 3:  # bad messages between the good ones: counted, not seen by the frame loop
            assert runtime.receive_truth("eci", t_s, q_k, t_s).released == []
            assert runtime.receive_truth(orbital, None, q_k, t_s).released == []
            assert runtime.receive_truth(orbital, t_s, [np.nan, 0.0, 0.0, 1.0], t_s).released == []
        output = runtime.receive_truth(orbital, t_s, q_k, t_s)
        released += output.released
        if output.health is not None:
            reports.append((t_s, output.health))
    published = np.flatnonzero(reference.released_at >= 0)
    assert [frame_s for frame_s, _ in released] == reference.frame_s[published].tolist()
    # The node's check normalises a near-unit quaternion on the way in; the clean stream is taken as it is:
    # the two may part in the last bit, no more.
    np.testing.assert_allclose(np.array([q_m for _, q_m in released]).T, reference.q_measured[:, published],
                               rtol=0.0, atol=1e-15)
    bad = len(range(3, t.size, 7))
    counters = runtime.counters
    assert counters["rejected_truth_wrong_frame"] == bad and counters["rejected_truth_zero_stamp"] == bad
    assert sum(v for k, v in counters.items() if k.startswith("rejected_truth_")) == 3 * bad
    # Health at most once per second of truth time; the first report after new rejections says so.
    stamps = [stamp for stamp, _ in reports]
    assert len(stamps) >= 5 and min(np.diff(stamps)) >= 1.0 - 1e-9
    assert any("rejected /attitude/truth messages" in h.message for _, h in reports)
    assert all(h.values["release_queue"] <= math.ceil(runtime.delay_s / values["frame_period_s"]) + 1
               for _, h in reports)
    assert all(h.values["stars_in_field"] >= 0 and h.values["proton_hits"] >= 0 for _, h in reports)
    assert sum(v for k, v in counters.items() if k.startswith("frames_")) == reference.frame_s.size


def test_truth_in_another_frame_is_refused_said_once_and_named_on_diagnostics():
    """#51 item 9: expected sat1/orbital, got orbital — one log line, the refusal named while it lasts."""
    values = {**values_of().star_tracker, "frames.prefix": "sat1"}
    runtime = TrackerRuntime(values, 0.0)
    assert runtime.frames.orbital == "sat1/orbital"
    lines = []
    for k in range(5):
        output = runtime.receive_truth("orbital", 10.0 + k, (0.0, 0.0, 0.0, 1.0), 10.0 + k)
        lines += [line.text for line in output.log]
    assert lines == ["true attitude refused: expected sat1/orbital, got orbital: each such message is dropped "
                     "(counted on /diagnostics); this is said once"]
    health = runtime.health([])
    assert health.level is Level.WARN and "true attitude refused: expected sat1/orbital, got orbital (5 refused)" \
        in health.message
    assert runtime.counters["rejected_truth_wrong_frame"] == 5
    # A message in the right frame ends the refusal: /diagnostics stops naming it; the log stays quiet.
    output = runtime.receive_truth("sat1/orbital", 20.0, (0.0, 0.0, 0.0, 1.0), 20.0)
    assert not output.log and "refused: expected" not in runtime.health([]).message


def test_a_confirmed_jump_back_is_a_new_timeline_and_silence_is_a_stale_input():
    values = values_of().star_tracker
    problems = []
    runtime = TrackerRuntime(values, 100.0, source_problems=lambda: list(problems),
                             source_counters=lambda: {"other_source_attitude_truth": 2})
    orbital = runtime.frames.orbital
    assert runtime.stale_health(None) is None  # no clock yet: nothing to say
    assert runtime.stale_health(100.0 + values["max_truth_gap_s"] / 2) is None
    stale = runtime.stale_health(100.0 + values["max_truth_gap_s"] + 1.0)
    assert stale.level is Level.WARN and "no /attitude/truth received" in stale.message
    assert stale.values["other_source_attitude_truth"] == 2
    t, q = truth_stream(200.0, 3.0)
    for t_s, q_k in zip(t.tolist(), q.T):
        runtime.receive_truth(orbital, t_s, q_k, t_s)
    back = 200.0 - 10 * values["clock_jump_s"]
    runtime.receive_truth(orbital, back, q[:, 0], back)
    assert runtime.counters["clock_jumps"] == 0  # one stamp back: not believed yet
    runtime.receive_truth(orbital, back + 0.1, q[:, 1], back + 0.1)
    assert runtime.counters["clock_jumps"] == 1
    problems.append("2 publishers of /attitude/truth")
    assert runtime.health([]).level is Level.ERROR


def test_a_refused_reconfiguration_leaves_the_tracker_as_it_was():
    values = values_of().star_tracker
    runtime = TrackerRuntime(values, 0.0)
    tracker, stamps = runtime.tracker, runtime.stamps
    with pytest.raises(ValueError):
        runtime.reconfigure({**values, "frame_period_s": 0.2, "clock_jump_s": 1e-6})
    with pytest.raises(ValueError, match="exposure_s = 0.75 s is longer than frame_period_s = 0.5 s"):
        runtime.reconfigure({**values, "frame_period_s": 0.5})
    assert runtime.tracker is tracker and runtime.stamps is stamps and runtime.grid.period_s == values["frame_period_s"]


def test_truth_cut_into_wake_up_batches_publishes_what_one_message_at_a_time_does():
    """add_inputs (the node's messages of one executor wake-up, handed over at once) against receive_truth one
    message at a time, on a hostile stream with recognition failures made frequent: bad frames, unreadable stamps,
    NaN and near-unit quaternions, a duplicate, an outlier stamp, and a confirmed clock jump back. The same frames
    (bit for bit: the same draws), the same statuses in the same places, the same counters, whatever the cuts."""
    from pmv_ros.runtime.common.records import HealthAt
    from pmv_ros.runtime.tracker.runtime import ReleasedFrame

    values = values_of({"recognition.failure_at_3": 0.9, "recognition.failure_scale_stars": 8.0,
                        "frame_period_s": 0.25, "exposure_s": 0.25}).star_tracker
    t, q = truth_stream(10.0, 40.0)
    t[200:] -= 15.0  # the clock restarts (a jump back, confirmed by the next stamp)
    orbital = "orbital"
    events = []
    for k, (t_s, q_k) in enumerate(zip(t.tolist(), q.T.tolist())):
        events.append(("receive_truth", (orbital, t_s, q_k), t_s))
        if k % 13 == 5:
            events += [("receive_truth", ("eci", t_s + 0.05, q_k), t_s), ("receive_truth", (orbital, None, q_k), t_s),
                       ("receive_truth", (orbital, t_s + 0.05, [math.nan, 0.0, 0.0, 1.0]), t_s),
                       ("receive_truth", (orbital, t_s, q_k), t_s)]  # a duplicate
        if k % 29 == 7:
            events.append(("receive_truth", (orbital, t_s + 0.05, [c * (1 + 1e-4) for c in q_k]), t_s))
        if k == 120:
            events.append(("receive_truth", (orbital, t_s - 5.0, q_k), t_s))  # one stamp back: an outlier
    one, cut = TrackerRuntime(values, 0.0), TrackerRuntime(values, 0.0)
    expected = [item for to, arguments, now in events for item in one.receive_truth(*arguments, now).published]
    rng = np.random.default_rng(3)
    published, lo = [], 0
    while lo < len(events):
        hi = lo + int(rng.choice([1, 2, 3, 7, 40]))
        published += cut.add_inputs(events[lo:hi]).published
        lo = hi
    assert [type(item) for item in published] == [type(item) for item in expected]
    frames = [(a, b) for a, b in zip(published, expected) if type(a) is ReleasedFrame]
    assert len(frames) > 50 and all(a.frame_s == b.frame_s and np.array_equal(a.q_measured, b.q_measured,
                                                                               equal_nan=True) for a, b in frames)
    statuses = [(a, b) for a, b in zip(published, expected) if type(a) is HealthAt]
    assert len(statuses) > 20 and all(a == b for a, b in statuses)
    counters = one.counters
    assert counters == cut.counters and counters["clock_jumps"] == 1 and counters["clock_outliers"] == 1
    assert counters["frames_recognition_failure"] and counters["rejected_truth_duplicate"]


def test_the_tracker_flies_the_element_sets_orbit():
    """orbit.source tle: the tracker's orbit is the sensor's SGP4 propagation (the SAA, the Sun and the L-shell all
    depend on where it is), not the circular orbit of the orbit.* elements."""
    from pmv_ros.runtime.common.assembly import build_models

    document = yaml.safe_load((REPO / "config" / "meteor_m2_tle.yaml").read_text())
    values = flight_values(document)
    runtime = TrackerRuntime(values.star_tracker, 0.0)
    sensor_orbit, _, _ = build_models(values.sensor)
    t = np.linspace(0.0, 6000.0, 7)
    np.testing.assert_allclose(runtime.tracker.orbit.state_eci(t)[0], sensor_orbit.state_eci(t)[0], rtol=0, atol=1e-6)
    circular = TrackerRuntime({**values.star_tracker, "orbit.source": "circular"}, 0.0).tracker.orbit
    # The preset's orbit.* elements approximate the element set: still 10–25 km off along the orbit.
    assert np.max(np.abs(circular.state_eci(t)[0] - sensor_orbit.state_eci(t)[0])) > 1e4


def test_a_followed_orbit_is_the_users_odometry():
    """orbit.source follow: the frames are measured where orbit/odometry puts the spacecraft, those no odometry
    covers are no_orbit, and bad odometry is refused and counted, as the sensor refuses it."""
    from pmv_ros.physics.orbit.two_body import CircularOrbit

    values = {**values_of().star_tracker, "orbit.source": "follow"}
    user = CircularOrbit(700e3, math.radians(51.6), raan_rad=1.0)  # not the preset's orbit
    runtime, reference = TrackerRuntime(values, 0.0), TrackerRuntime({**values, "orbit.source": "circular"}, 0.0)
    orbital = runtime.frames.orbital
    t, q = truth_stream(10.0, 30.0)
    for k, (stamp, q_k) in enumerate(zip(t.tolist(), q.T)):
        if stamp >= 20.0:  # odometry from 20 s on, at 1 Hz: the frames before have no orbit
            if k % 10 == 0:
                position, velocity = user.state_eci(stamp)
                runtime.add_odometry(runtime.frames.eci, orbital, (stamp, position, velocity), stamp)
                runtime.add_odometry("orbital", orbital, (stamp, position, velocity), stamp)  # wrong frame
                runtime.add_odometry(runtime.frames.eci, orbital, (stamp + 0.05, position * 10.0, velocity), stamp)
        runtime.receive_truth(orbital, stamp, q_k, stamp)
        reference.receive_truth(orbital, stamp, q_k, stamp)
    counters = runtime.counters
    # 10 frames before the first state; 20 states, each with a wrong-frame and an implausible one beside it.
    assert counters["frames_no_orbit"] == 10 and counters["rejected_odometry_wrong_frame"] == 20
    assert counters["rejected_odometry_implausible_orbit"] == 20 and counters["frames_ok"] > 10
    runtime.reconfigure({**values, "processing_s": 0.3})  # a parameter change keeps the odometry heard
    followed = runtime.tracker.orbit.state_eci(25.0)[0]
    np.testing.assert_allclose(followed, user.state_eci(25.0)[0], rtol=0, atol=1e-3)
    # Measured on the user's orbit: another sky than the preset's circular one gives.
    stars = [runtime.tracker.measure(np.array([s]), q[:, :1], np.zeros((3, 1))).stars[0] for s in (25.0, 29.0)]
    others = [reference.tracker.measure(np.array([s]), q[:, :1], np.zeros((3, 1))).stars[0] for s in (25.0, 29.0)]
    assert stars != others
