"""The sensor's track grid: where the environment is evaluated along a chord's track and how it is interpolated.

pmv_ros/physics/instrument/track_grid.py: the fields are evaluated at grid nodes and interpolated in time by
a not-a-knot cubic spline. For the few nodes of a node's block the spline is formed as a weight matrix
(spline_weights), the same spline scipy's CubicSpline makes; the accuracy of the grid against evaluation at
every sample is tests/physics/test_line_of_sight_sampling.py's.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from pmv_ros.physics.instrument.track_grid import (DENSE_SPLINE_NODES, MIN_BLOCK_INTERVALS, grid_nodes,
                                                   interpolate_in_time, spline_weights)


@pytest.mark.parametrize("nodes", [4, 5, 9, 16, DENSE_SPLINE_NODES])
def test_the_weight_matrix_is_scipys_not_a_knot_spline(nodes):
    # Uneven nodes (a block's first and last samples sit anywhere between two multiples of the spacing), samples
    # between and a little beyond them: scipy's CubicSpline (not-a-knot) to 1e-12 of values of order 1 — the
    # two solve the same system in another order, so they differ by rounding only (measured ≤ 4e-14).
    rng = np.random.default_rng(nodes)
    x = 1.7e3 + np.cumsum(rng.uniform(0.05, 6.0, nodes))
    t = np.sort(np.concatenate([x, rng.uniform(x[0] - 0.5, x[-1] + 0.5, 400)]))
    y = rng.standard_normal((3, 4, nodes))
    np.testing.assert_allclose(y @ spline_weights(x, t).T, CubicSpline(x, y, axis=-1)(t), rtol=0, atol=1e-12)


def test_a_cubic_is_reproduced_and_the_nodes_are_kept():
    # The not-a-knot spline reproduces any cubic exactly, and every node's value is its own.
    x = np.array([0.0, 0.4, 3.5, 7.0, 10.5, 12.0])
    t = np.linspace(0.0, 12.0, 121)
    w = spline_weights(x, t)
    cubic = lambda s: 0.3 - 1.2 * s + 0.05 * s**2 - 0.004 * s**3  # noqa: E731
    np.testing.assert_allclose(w @ cubic(x), cubic(t), rtol=0, atol=1e-12)
    np.testing.assert_allclose(spline_weights(x, x), np.eye(x.size), rtol=0, atol=1e-14)


def test_interpolation_picks_the_path_by_the_number_of_nodes():
    t = np.arange(600) * 0.1
    values = np.sin(t / 7.0)[None, :]
    for spacing in (3.0, 0.5):  # 21 nodes (the weight matrix) and 121 (scipy's CubicSpline)
        nodes = grid_nodes(t, spacing)
        out = interpolate_in_time(t, nodes, values[:, nodes])
        # a sine of period 44 s sampled every ≤ 3 s: the spline's error ≈ (2π·3/44)⁴/384 ≈ 1e-3 of its amplitude
        np.testing.assert_allclose(out, values, atol=2e-3)
        np.testing.assert_array_equal(out[:, nodes], values[:, nodes])


def test_a_short_block_gets_enough_intervals():
    # A node's block of 512 samples at 10 Hz (51.1 s) with a 30 s spacing: the spacing is halved until the block
    # has MIN_BLOCK_INTERVALS intervals — a cubic through ≥ 4 nodes, not a line.
    t = 1000.05 + np.arange(512) * 0.1
    nodes = grid_nodes(t, 30.0)
    assert nodes.size >= MIN_BLOCK_INTERVALS + 1
    assert nodes[0] == 0 and nodes[-1] == t.size - 1
    # and a dense enough grid is left as it is: one node per 3.5 s, first and last
    nodes = grid_nodes(t, 3.5)
    assert np.all(np.diff(t[nodes]) <= 3.5 + 1e-9)
    assert nodes.size <= 51.1 / 3.5 + 3
