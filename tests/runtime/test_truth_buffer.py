"""The following sensor's truth buffer and the star tracker's frame grid, ROS-free (issue 12, items 3 and 8)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from pmv_ros.physics.star_tracker import FrameGrid
from pmv_ros.runtime.common.truth_buffer import DEFAULT_BRIDGE_S, PendingSamples, TruthAt, TruthBuffer

RATE_RAD_S = np.array([2e-3, -1e-3, 5e-4])  # a constant body rate, orbital components


def attitude(t_s) -> tuple:
    """A constant-rate turn from a tilted start: q(t) = exp(ω t) ⊗ q0 (scipy, independently of the core)."""
    start = Rotation.from_rotvec([0.01, -0.02, 0.3])
    return tuple((Rotation.from_rotvec(RATE_RAD_S * t_s) * start).as_quat())


def same_rotation(a, b, atol=1e-12) -> bool:
    return abs(abs(float(np.dot(a, b))) - 1.0) < atol


def test_between_samples_it_is_scipys_slerp_and_at_a_sample_the_sample():
    buffer = TruthBuffer(extrapolation_periods=2.0, max_gap_s=1.0)
    stamps = [10.0, 10.02, 10.04, 10.1]
    rng = np.random.default_rng(1)
    samples = [tuple(Rotation.from_rotvec(rng.normal(scale=0.05, size=3)).as_quat()) for _ in stamps]
    for t, q in zip(stamps, samples):
        buffer.add(t, q)
    reference = Slerp(stamps, Rotation.from_quat(samples))
    for t in (10.0, 10.005, 10.03, 10.07, 10.1):
        q, source = buffer.attitude_at(t)
        assert source is TruthAt.INTERPOLATED
        assert same_rotation(q, reference([t]).as_quat()[0], atol=1e-12), t
    assert buffer.attitude_at(10.02)[0] == samples[1]


def test_past_the_newest_the_last_rate_for_at_most_the_horizon_then_stale():
    buffer = TruthBuffer(extrapolation_periods=2.0, max_gap_s=1.0, bridge_s=0.0)
    for k in range(5):  # 50 Hz
        buffer.add(1.0 + 0.02 * k, attitude(1.0 + 0.02 * k))
    assert buffer.horizon_s() == pytest.approx(0.04)
    newest = 1.08
    for ahead in (0.001, 0.02, 0.04):
        q, source = buffer.attitude_at(newest + ahead)
        assert source is TruthAt.EXTRAPOLATED
        assert same_rotation(q, attitude(newest + ahead), atol=1e-12)  # a constant rate: exact
    assert buffer.attitude_at(newest + 0.0401) == (None, TruthAt.STALE)
    # Never further than max_gap_s, however slow the truth.
    slow = TruthBuffer(extrapolation_periods=10.0, max_gap_s=1.0)
    slow.add(0.0, attitude(0.0))
    slow.add(0.5, attitude(0.5))
    assert slow.horizon_s() == 1.0 and slow.attitude_at(1.6)[1] is TruthAt.STALE


def test_a_late_truth_sample_is_bridged_up_to_bridge_s_at_any_truth_rate_then_stale():
    # 50 Hz truth: two periods (40 ms) are routine extrapolation; up to the default 0.3 s past the
    # newest the last rate bridges a late sample (BRIDGED, usable); beyond it the truth is stale.
    for rate_hz in (50.0, 10.0, 200.0):
        buffer = TruthBuffer(extrapolation_periods=2.0, max_gap_s=1.0)
        for k in range(5):
            buffer.add(1.0 + k / rate_hz, attitude(1.0 + k / rate_hz))
        newest = 1.0 + 4 / rate_hz
        assert buffer.horizon_s() == pytest.approx(max(2.0 / rate_hz, DEFAULT_BRIDGE_S))
        assert buffer.attitude_at(newest + 1.5 / rate_hz)[1] is TruthAt.EXTRAPOLATED
        for ahead in (2.5 / rate_hz, 0.25, DEFAULT_BRIDGE_S - 1e-9):
            q, source = buffer.attitude_at(newest + ahead)
            assert source is (TruthAt.BRIDGED if ahead > 2.0 / rate_hz else TruthAt.EXTRAPOLATED) and source.usable
            assert same_rotation(q, attitude(newest + ahead), atol=1e-12)  # a constant rate: exact
        assert buffer.attitude_at(newest + DEFAULT_BRIDGE_S + 1e-3) == (None, TruthAt.STALE)
    # Never beyond max_gap_s.
    short = TruthBuffer(extrapolation_periods=2.0, max_gap_s=0.1, bridge_s=0.3)
    short.add(0.0, attitude(0.0))
    short.add(0.02, attitude(0.02))
    assert short.horizon_s() == 0.1 and short.attitude_at(0.13)[1] is TruthAt.STALE
    with pytest.raises(ValueError, match="bridge_s"):
        TruthBuffer(bridge_s=-0.1)


def test_what_it_does_not_know_it_does_not_give():
    buffer = TruthBuffer(extrapolation_periods=2.0, max_gap_s=1.0, capacity=4)
    assert buffer.attitude_at(1.0) == (None, TruthAt.NO_TRUTH)
    buffer.add(1.0, attitude(1.0))
    assert buffer.attitude_at(1.0)[1] is TruthAt.INTERPOLATED
    assert buffer.attitude_at(1.01) == (None, TruthAt.NO_TRUTH)  # one sample: no rate to carry on
    buffer.add(3.0, attitude(3.0))  # a 2 s gap
    assert buffer.attitude_at(2.0) == (None, TruthAt.TRUTH_GAP)
    assert buffer.attitude_at(3.0)[1] is TruthAt.INTERPOLATED
    assert buffer.attitude_at(3.01) == (None, TruthAt.TRUTH_GAP)  # no rate taken across the gap
    assert buffer.horizon_s() == 0.0
    for t in (3.1, 3.2, 3.3, 3.4):
        buffer.add(t, attitude(t))
    assert len(buffer) == 4  # bounded
    assert buffer.attitude_at(3.05) == (None, TruthAt.TOO_OLD)
    buffer.add(0.5, attitude(0.5))  # not after the newest: a new timeline
    assert len(buffer) == 1 and buffer.newest_stamp_s == 0.5
    with pytest.raises(ValueError, match="extrapolation_periods"):
        TruthBuffer(extrapolation_periods=-1.0)


def test_the_frame_grid_slerps_each_frame_between_the_truth_around_it():
    grid = FrameGrid(period_s=0.5, max_gap_s=5.0)
    got = []
    for k in range(1, 12):  # truth at 0.3 s steps: frames fall between samples
        t = 0.3 * k
        frames = grid.add_many(t, attitude(t))
        got += list(zip(frames.frame_s.tolist(), frames.attitude.T))
        for rate in frames.turn_rate_rad_s.T:
            np.testing.assert_allclose(rate, RATE_RAD_S, atol=1e-12)
    # The first sample starts the grid at 0.5 (the next multiple after 0.3); frames up to 3.3.
    assert [t for t, _ in got] == pytest.approx([0.5 * k for k in range(1, 7)])
    for t, q in got:
        assert same_rotation(q, attitude(t), atol=1e-12), t
    # A gap longer than max_gap_s restarts the grid: nothing across it.
    assert grid.add_many(10.0, attitude(10.0)).frame_s.tolist() == []
    assert grid.add_many(10.6, attitude(10.6)).frame_s.tolist() == pytest.approx([10.0, 10.5])


def test_due_times_wait_for_the_truth_that_covers_them_or_until_the_horizon_has_passed():
    buffer, waiting = TruthBuffer(extrapolation_periods=2.0, max_gap_s=1.0), PendingSamples()
    for k in range(3):  # 50 Hz truth up to 1.04 s
        buffer.add(1.0 + 0.02 * k, attitude(1.0 + 0.02 * k))
    waiting.add([1.02, 1.1, 1.2], 1.2)  # a clock step made three samples due at 1.2 s
    ready = waiting.ready(buffer, now_s=1.2)
    assert [(t, source) for t, _, source in ready] == [(1.02, TruthAt.INTERPOLATED)] and len(waiting) == 2
    for k in range(3, 9):  # the truth of the step arrives after the tick: up to 1.16 s
        buffer.add(1.0 + 0.02 * k, attitude(1.0 + 0.02 * k))
    ready = waiting.ready(buffer, now_s=1.2)
    assert [(t, source) for t, _, source in ready] == [(1.1, TruthAt.INTERPOLATED)]
    assert same_rotation(ready[0][1], attitude(1.1), atol=1e-12)
    # No more truth: 1.2 waits until the clock is the horizon (0.3 s) past it, then takes what there is.
    assert waiting.ready(buffer, now_s=1.2 + DEFAULT_BRIDGE_S - 0.01) == []
    (t_s, q, source), = waiting.ready(buffer, now_s=1.2 + DEFAULT_BRIDGE_S)
    assert t_s == 1.2 and source is TruthAt.BRIDGED and same_rotation(q, attitude(1.2), atol=1e-12)
    waiting.add([1.6], 1.65)
    assert waiting.ready(buffer, now_s=1.9) == []  # a clock that leapt ahead of the truth: not yet late
    assert waiting.ready(buffer, now_s=1.95)[0][1:] == (None, TruthAt.STALE) and len(waiting) == 0
