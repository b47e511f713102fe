"""The star-tracker measurement model (physics.md §6): the one-frame path against the array path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.constants import ARCSEC_RAD
from pmv_ros.physics.star_tracker import Outcome, StarTracker, StarTrackerParameters, inertial_rate_of_nadir_pointing


def _pair(seed: int, **options):
    parameters = StarTrackerParameters(**options)
    return StarTracker(parameters, seed=seed), StarTracker(parameters, seed=seed)


@pytest.mark.parametrize("options, t_s, rate, expected", [
    ({}, 10.0, 1e-3, Outcome.OK),
    ({"noise_cross_rad": 0.0, "noise_boresight_rad": 0.0}, 10.0, 1e-3, Outcome.OK),
    ({"outages": ((5.0, 20.0),)}, 10.0, 1e-3, Outcome.SCHEDULED_OUTAGE),
    ({}, 10.0, 400.0 * ARCSEC_RAD, Outcome.RATE_TOO_HIGH),
    ({"random_failure_probability": 1.0}, 10.0, 1e-3, Outcome.RANDOM_FAILURE),
    ({"random_failure_probability": 1.0, "outages": ((5.0, 20.0),)}, 10.0, 1.0, Outcome.SCHEDULED_OUTAGE),
])
def test_one_frame_measures_like_the_array_path(options, t_s, rate, expected):
    # The node measures one 2 Hz frame at a time in plain floats; with the same seed it must give, bit for bit,
    # what the array path gives for the same frames measured as groups of one (the same draws, in the same order):
    # the same outcome and quaternion, the random streams in step frame after frame.
    rng = np.random.default_rng(2)
    for _ in range(20):
        q = quaternion_from_roll_pitch_yaw(*rng.uniform(-0.1, 0.1, 3))
        one_tracker, array_tracker = _pair(seed=int(rng.integers(1000)), **options)
        times = t_s + np.arange(3.0)
        singles = [one_tracker.measure(float(t), tuple(q.tolist()), rate) for t in times]
        many, outcomes = array_tracker.measure_groups(times, np.repeat(q[:, None], 3, axis=1), np.full(3, rate),
                                                      [1, 1, 1])  # three groups: the array path
        for k, (one, outcome) in enumerate(singles):
            assert outcome is Outcome(int(outcomes[k])) is expected
            np.testing.assert_array_equal(one, many[:, k])
            assert (outcome is Outcome.OK) == bool(np.all(np.isfinite(one)))


def test_one_frame_of_a_random_stream_is_the_array_path_bit_for_bit():
    # Many attitudes, rates about the limit and a failure rate that fails some: one frame at a time (the node)
    # against the same frames as groups of one in one array call (a campaign's groups).
    rng = np.random.default_rng(11)
    parameters = StarTrackerParameters(random_failure_probability=0.2, outages=((30.0, 40.0),),
                                       boresight_body=(0.3, -0.5, 0.8))  # oblique: every axis sums three terms
    one_tracker, array_tracker = StarTracker(parameters, seed=3), StarTracker(parameters, seed=3)
    n = 400
    times = np.arange(n) * 0.5
    q = np.array([quaternion_from_roll_pitch_yaw(*a) for a in rng.uniform(-3.0, 3.0, (n, 3))]).T
    q[:, 7] = np.nan  # invalid truth: no attitude, and the draws still taken
    rate = rng.uniform(0.0, 2.0, n) * parameters.max_rate_rad_s
    many, outcomes = array_tracker.measure_groups(times, q, rate, [1] * n)
    singles = [one_tracker.measure(float(times[k]), tuple(q[:, k].tolist()), float(rate[k])) for k in range(n)]
    np.testing.assert_array_equal(np.array([one for one, _ in singles]).T, many)
    assert [int(outcome) for _, outcome in singles] == outcomes.tolist()
    assert set(outcomes.tolist()) == {int(o) for o in Outcome}  # every outcome came up


def test_one_frame_with_invalid_truth_gives_no_attitude():
    tracker = StarTracker()
    for bad in ((0.0, 0.0, 0.0, 0.0), (math.nan, 0.0, 0.0, 1.0)):
        measured, outcome = tracker.measure(1.0, bad, 0.0)
        assert outcome is Outcome.INVALID_TRUTH and np.all(np.isnan(measured))


def test_noise_is_a_few_arcseconds_across_the_boresight_and_more_about_it():
    # physics.md §6: 3″ (1σ) across the boresight (+Z body), 20″ about it, one frame at a time.
    tracker = StarTracker(StarTrackerParameters(random_failure_probability=0.0), seed=4)
    q = (0.0, 0.0, 0.0, 1.0)
    errors = np.array([tracker.measure(float(k), q, 1e-3)[0][:3] * 2.0 for k in range(4000)])
    # Small angles: the vector part of q is half the rotation vector. 4000 frames give σ to ±1.1 %.
    sigma = errors.std(axis=0) / ARCSEC_RAD
    np.testing.assert_allclose(sigma, [3.0, 3.0, 20.0], rtol=0.05)


def test_inertial_rate_of_one_sample_is_a_float_equal_to_the_array_path():
    # Bit for bit (a node's one frame takes the float path, a campaign's frames the array path): (y + n)² as a
    # product, not a power — the C library's pow differed from numpy's square in about 1 draw in 4,000.
    rate = inertial_rate_of_nadir_pointing(1.1e-3, (1e-5, -2e-4, 3e-6))
    assert type(rate) is float
    assert rate == float(inertial_rate_of_nadir_pointing(1.1e-3, np.array([1e-5, -2e-4, 3e-6])))
    rng = np.random.default_rng(28)
    turns = rng.normal(0.0, 1e-3, (3, 20_000)) * rng.choice([1e-6, 1e-3, 1.0, 1e3], 20_000)
    mean_motion = np.abs(rng.normal(1.1e-3, 1e-4, 20_000))
    floats = [inertial_rate_of_nadir_pointing(n, tuple(w)) for n, w in zip(mean_motion.tolist(), turns.T.tolist())]
    arrays = [inertial_rate_of_nadir_pointing(n, w.reshape(3, 1))[0] for n, w in zip(mean_motion.tolist(), turns.T)]
    np.testing.assert_array_equal(floats, arrays)
    one_n = [inertial_rate_of_nadir_pointing(1.1e-3, tuple(w)) for w in turns.T.tolist()]  # and a whole stream
    np.testing.assert_array_equal(one_n, inertial_rate_of_nadir_pointing(1.1e-3, turns))
