"""The one conversion between the paper and the REP-103 sign conventions (physics.md "Sign conventions")."""

import numpy as np
import pytest

from pmv_ros.physics.conventions import convert


def test_paper_is_ros_with_both_signs_reversed():
    assert convert(1.0, 2.0, "ros", "paper") == (-1.0, -2.0)
    assert convert(1.0, 2.0, "paper", "ros") == (-1.0, -2.0)
    assert convert(1.0, 2.0, "ros", "ros") == (1.0, 2.0)


def test_round_trip_on_arrays():
    roll, pitch = np.array([0.1, -0.3]), np.array([2.0, 0.0])
    back = convert(*convert(roll, pitch, "ros", "paper"), "paper", "ros")
    np.testing.assert_array_equal(back[0], roll)
    np.testing.assert_array_equal(back[1], pitch)


def test_unknown_convention_named():
    with pytest.raises(ValueError, match="'nasa'"):
        convert(0.0, 0.0, "nasa", "ros")
