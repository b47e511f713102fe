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
    # The node measures one 2 Hz frame at a time in plain floats; with the same seed it must
    # give what the array path gives for that frame: the same draws, outcome and quaternion.
    rng = np.random.default_rng(2)
    for _ in range(20):
        q = quaternion_from_roll_pitch_yaw(*rng.uniform(-0.1, 0.1, 3))
        one_tracker, array_tracker = _pair(seed=int(rng.integers(1000)), **options)
        for step in range(3):  # the random streams stay in step frame after frame
            one, outcome = one_tracker.measure(t_s + step, tuple(q.tolist()), rate)
            many, outcomes = array_tracker.measure(np.array([t_s + step]), q[:, None], np.array([rate]))
            assert outcome is Outcome(int(outcomes[0])) is expected
            np.testing.assert_allclose(one, many[:, 0], atol=1e-15)
            assert (outcome is Outcome.OK) == bool(np.all(np.isfinite(one)))


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
    rate = inertial_rate_of_nadir_pointing(1.1e-3, (1e-5, -2e-4, 3e-6))
    assert type(rate) is float
    assert rate == pytest.approx(float(inertial_rate_of_nadir_pointing(1.1e-3, np.array([1e-5, -2e-4, 3e-6]))),
                                 rel=1e-15)
