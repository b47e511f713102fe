"""The star tracker's runtime: a truth stream fed as one batch is the stream fed message by message; the same frame
time gives the same frame, whenever the tracker started."""

from __future__ import annotations

import numpy as np
import pytest

from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.star_tracker import LatencyQueue, Outcome
from pmv_ros.physics.star_tracker.frames import _grid_times
from pmv_ros.runtime.common.assembly import STAR_TRACKER_PARAMS
from pmv_ros.runtime.common.parameters import preset_values
from pmv_ros.runtime.tracker.runtime import TrackerRuntime, track_stream

DEFAULTS = preset_values({}, "star_tracker_node", STAR_TRACKER_PARAMS)


def truth_stream(step_s: float, n: int = 400, seed: int = 3):
    """Stamps every ``step_s`` (jittered) with a 3 s gap in the middle (the grid restarts), and a wandering
    attitude."""
    rng = np.random.default_rng(seed)
    t = 5.0 + step_s * np.arange(n) + rng.uniform(0.0, 0.05, n)
    t[n // 2:] += 3.0
    angles = np.cumsum(rng.normal(0.0, 2e-4, (3, n)), axis=1)
    return t, np.array([quaternion_from_roll_pitch_yaw(*a) for a in angles.T]).T


def one_by_one(values: dict, t, q):
    """What the node does: add_truth, then release, per message."""
    runtime = TrackerRuntime(values, 0.0)
    frames, released = [], []
    for k in range(t.size):
        frames += [(s, m, int(o)) for s, m, o in runtime.add_truth(float(t[k]), tuple(q[:, k].tolist()))]
        released += [(k, s, m) for s, m in runtime.release(float(t[k]))]
    return runtime, frames, released


#: Kondor's orbit and a star-poor stretch of its sky: some frames fail to recognise, some find too few stars.
KONDOR = {"orbit.inclination_deg": 74.5, "sim.epoch_utc": "2013-09-10T00:00:00Z", "sim.fast_time": True}


@pytest.mark.parametrize("overrides, step_s", [
    ({"recognition.failure_at_3": 0.9, "recognition.failure_scale_stars": 8.0, "processing_s": 0.0,
      "exposure_s": 0.01, "frame_period_s": 0.5}, 0.3),  # frames between sparse truth, (almost) no delay
    ({"recognition.failure_at_3": 0.9, "recognition.failure_scale_stars": 8.0, "processing_s": 0.6,
      "frame_period_s": 0.25}, 0.37),  # several frames per sample
    ({"outage_start_s": [20.0, 100.0], "outage_duration_s": [30.0, 5.0], "processing_s": 1.3}, 0.9),
    ({"max_rate_arcsec_s": 200.0}, 0.25),  # the rate ceiling refuses frames (the orbital rate is 229″/s)
    ({}, 0.1),  # the campaign's 10 Hz
    ({"frame_period_s": 0.25, "field_of_view_deg": 3.0}, 0.9),  # three or four frames per sample; a small field
])
def test_a_stream_in_one_batch_is_the_stream_message_by_message(overrides, step_s):
    values = {**DEFAULTS, **KONDOR, **overrides}
    t, q = truth_stream(step_s)
    runtime, frames, released = one_by_one(values, t, q)
    batch_runtime = TrackerRuntime(values, 0.0)
    stream = track_stream(batch_runtime, t, q)
    assert stream.frame_s.tolist() == [s for s, _, _ in frames]  # the same frames, bit for bit
    assert stream.outcome.tolist() == [o for _, _, o in frames]
    np.testing.assert_array_equal(stream.q_measured, np.array([m for _, m, _ in frames]).T)
    published = np.flatnonzero(stream.released_at >= 0)
    assert stream.released_at[published].tolist() == [k for k, _, _ in released]
    assert stream.frame_s[published].tolist() == [s for _, s, _ in released]
    assert batch_runtime.outcomes == runtime.outcomes and batch_runtime.last_outcome == runtime.last_outcome
    assert len(batch_runtime.queue) == len(runtime.queue)
    assert len(set(stream.outcome.tolist())) > 1 or not overrides  # the case exercises what it names
    np.testing.assert_array_equal(batch_runtime.add_truth_batch(t[:0], q[:, :0]).frame_s, [])


def test_a_stream_split_into_batches_carries_the_grid_and_the_queue_across():
    values = {**DEFAULTS, **KONDOR, "processing_s": 0.8, "frame_period_s": 0.25}
    t, q = truth_stream(0.37)
    whole = TrackerRuntime(values, 0.0)
    expected = whole.add_truth_batch(t, q)
    _, _, expected_at = whole.release_batch(t)
    parts = TrackerRuntime(values, 0.0)
    got, got_at = [], []
    for lo, hi in ((0, 1), (1, 150), (150, 151), (151, 400)):
        got.append(parts.add_truth_batch(t[lo:hi], q[:, lo:hi]))
        got_at.append(parts.release_batch(t[lo:hi])[2] + lo)
    assert np.concatenate([g.frame_s for g in got]).tolist() == expected.frame_s.tolist()
    np.testing.assert_array_equal(np.concatenate([g.q_measured for g in got], axis=1), expected.q_measured)
    assert np.concatenate(got_at).tolist() == expected_at.tolist()
    assert parts.outcomes == whole.outcomes and len(parts.queue) == len(whole.queue)


def test_the_latency_queue_releases_in_frame_order_and_never_before_a_frame_exists():
    queue = LatencyQueue(0.5)
    queue.push_many(np.array([1.0, 1.5, 2.0]), np.zeros((4, 3)), not_before=np.array([0, 2, 2]))
    frame_s, _, at = queue.release_many(np.array([1.2, 1.6, 2.0, 2.4]))
    # 1.0 is due at 1.6; 1.5 at 2.0; 2.0 (due at 2.5) waits
    assert frame_s.tolist() == [1.0, 1.5] and at.tolist() == [1, 2] and len(queue) == 1
    queue.latency_s = 0.0
    queue.push_many(np.array([2.1]), np.zeros((4, 1)))  # due at once, but behind 2.0 (due at 2.5)
    assert queue.release_many(2.3)[0].tolist() == []
    assert queue.release_many(2.5)[0].tolist() == [2.0, 2.1]
    assert queue.clear() == 0 and Outcome.OK == 0


def test_the_latency_queue_releases_the_same_stamp_by_stamp_as_at_once():
    """A node's stamps, one float at a time (the queue's shortcuts: nothing due, everything due), against the
    same stamps as one array, with the latency changed between pushes (a frame pushed earlier may be due later)."""
    rng = np.random.default_rng(5)
    one, whole = LatencyQueue(0.0), LatencyQueue(0.0)
    frame_s, got, expected = 0.0, [], []
    for _ in range(80):
        for _ in range(int(rng.integers(0, 4))):  # frames 0.4 s apart, each with its own latency
            one.latency_s = whole.latency_s = float(rng.choice([0.0, 0.3, 1.7, 3.0]))
            frame_s += 0.4
            q = rng.normal(size=(4, 1))
            one.push_many(np.array([frame_s]), q)
            whole.push_many(np.array([frame_s]), q)
        stamps = frame_s + np.sort(rng.uniform(0.0, 2.0, 4))
        for stamp in stamps.tolist():
            released, q_released, at = one.release_many(stamp)
            got += [(stamp, t, tuple(c)) for t, c in zip(released.tolist(), q_released.T.tolist())]
            assert not at.any()
        released, q_released, at = whole.release_many(stamps)
        expected += [(stamps[i], t, tuple(c)) for i, t, c in zip(at.tolist(), released.tolist(),
                                                                q_released.T.tolist())]
        assert len(one) == len(whole)
    assert got == expected and len(got) > 40


def test_two_trackers_started_20_s_apart_give_the_same_frames_for_the_same_frame_times():
    """physics.md §6 item 9 (draws keyed by the frame's time): a tracker that starts 20 s of truth later (a late
    /clock, a respawn) gives, frame for frame, what the one running since the start gives — bit for bit."""
    values = {**DEFAULTS, **KONDOR, "recognition.failure_at_3": 0.9, "recognition.failure_scale_stars": 8.0}
    t, q = truth_stream(0.1, n=4000)
    early = track_stream(TrackerRuntime(values, 0.0), t, q)
    late_start = np.searchsorted(t, t[0] + 20.0)
    late = track_stream(TrackerRuntime(values, 0.0), t[late_start:], q[:, late_start:])
    common = np.isin(early.frame_s, late.frame_s)
    assert common.sum() == late.frame_s.size > 300
    assert early.frame_s[common].tolist() == late.frame_s.tolist()
    assert early.outcome[common].tolist() == late.outcome.tolist()
    np.testing.assert_array_equal(early.q_measured[:, common], late.q_measured)
    assert {Outcome.OK, Outcome.RECOGNITION_FAILURE} <= set(Outcome(int(o)) for o in late.outcome)


def test_frame_times_are_numpys_arange_value_for_value():
    rng = np.random.default_rng(5)
    for period in (0.5, 0.25, 1 / 3, 0.1, 1 / 7):
        for _ in range(2000):
            start = np.ceil(rng.uniform(0.0, 1e5) / period) * period
            stop = start + rng.uniform(-1e-12, 4.5) * period * rng.choice([1.0, 1e-13]) + 1e-12
            assert _grid_times(start, stop, period) == np.arange(start, stop, period).tolist()


def test_a_sample_without_truth_finds_the_reason_of_the_frame_nearest_to_it():
    """The record a consumer counts its lost samples by: the reason of the nearest frame (OK beyond a period)."""
    from pmv_ros.runtime.tracker.runtime import TrackerFrames, reason_at

    frames = TrackerFrames(np.array([10.0, 11.0, 12.0, 13.0]), np.full((4, 4), np.nan),
                           np.array([0, 3, 5, 0], np.int8), np.full(4, -1), np.zeros(4, np.int64),
                           np.array([0, 0, 170, 0]))
    got = reason_at(frames, [9.0, 10.9, 11.6, 12.4, 15.5])
    assert [Outcome(int(o)) for o in got] == [Outcome.OK, Outcome.NO_STARS, Outcome.BUFFER_OVERFLOW,
                                              Outcome.BUFFER_OVERFLOW, Outcome.OK]
