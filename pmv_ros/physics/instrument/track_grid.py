"""The coarse time grid on which the sensor evaluates the environment along each chord's track.

The fields of the environment change along a chord's track on scales of a hundred kilometres and more,
while a horizon point moves < 1 km between samples 0.1 s apart: the sensor evaluates them at a few grid
samples (:func:`grid_nodes`) and interpolates in time to the rest (:func:`interpolate_in_time`). The
grid's spacings come from the fields' scales (:class:`~pmv_ros.physics.instrument.sensor.RadianceConfig`).
"""

from __future__ import annotations

import math

import numpy as np

#: Longest spacing of the coarse time grid on which the environment is evaluated along each chord's
#: track, s (see :class:`~pmv_ros.physics.instrument.sensor.RadianceConfig`).
MAX_FIELD_GRID_S = 30.0
#: Grid spacing as a fraction of the time a horizon point takes to cross a field's shortest wavelength.
#: The fields are interpolated in time by cubic splines, which reproduce a wave sampled this densely to
#: ≈ (2π·fraction)⁴/384 ≈ 1.6 % of its amplitude — for the shortest waves of a field only. (The layer
#: height's Gaussian field is interpolated and mapped to its uniform law afterwards: the map makes
#: harmonics shorter than the field's own.)
FIELD_GRID_FRACTION = {"band": 0.25, "weather": 0.25, "height": 0.25}
#: Fewest grid intervals over a block of samples (a node's block is 512 samples, 51.2 s at 10 Hz): a short
#: block's grid is made denser until it has them, so that its spline is a cubic through ≥ 4 nodes, not a line.
#: The fields' own spacings (:data:`FIELD_GRID_FRACTION`) set the accuracy; more intervals only cost evaluations.
MIN_BLOCK_INTERVALS = 3
#: Most nodes of a spline formed from its slope operator (:func:`spline_slopes`: one dense m × m solve, cheaper
#: than scipy's set-up for the few nodes of a node's block); more: scipy's ``CubicSpline``.
DENSE_SPLINE_NODES = 64
#: Two clock readings closer than this, s, are the same instant for the track grid (float64 rounding of
#: a clock at ≈ 2·10⁹ s is ≈ 2·10⁻⁷ s; samples are ≥ 10 ms apart).
GRID_TIME_TOLERANCE_S = 1e-6
#: Ground speed of a horizon point along its track, m/s (the orbital rate on the Earth's surface,
#: ≈ 6.6 km/s at 500–835 km, plus up to 0.46 km/s of Earth rotation), rounded up.
HORIZON_POINT_SPEED_M_S = 7.2e3


def interpolate_in_time(t, nodes, values):
    """Values given at the samples ``nodes`` (last axis), interpolated in time to every sample of ``t``.

    A not-a-knot cubic spline through 4 nodes or more (scipy's ``CubicSpline``; through at most
    :data:`DENSE_SPLINE_NODES` nodes the same spline from its slopes, :func:`spline_slopes`), linear
    through 2 or 3.
    """
    if nodes.size == t.size:
        return values
    t_nodes = t[nodes]
    if nodes.size >= 4 and (t_nodes[1:] > t_nodes[:-1]).all():
        if nodes.size <= DENSE_SPLINE_NODES:
            return _hermite(t_nodes, values, values @ spline_slopes(t_nodes).T, t)
        # Imported here: scipy.interpolate costs ≈ 0.1 s of CPU at every start of a node process, and only blocks
        # longer than a real-time node's take this way.
        from scipy.interpolate import CubicSpline

        return CubicSpline(t_nodes, values, axis=-1)(t)
    j = np.clip(np.searchsorted(t_nodes, t, side="right") - 1, 0, nodes.size - 2)
    span = t_nodes[j + 1] - t_nodes[j]
    w = np.where(span > 0.0, (t - t_nodes[j]) / np.where(span > 0.0, span, 1.0), 0.0)
    return values[..., j] * (1.0 - w) + values[..., j + 1] * w


def spline_slopes(x):
    """The slopes of the not-a-knot cubic spline through nodes ``x`` as an operator: ``(m, m)``, s = S @ y.

    The spline is linear in the node values, so one operator serves every field of a grid. Its slopes
    solve the tridiagonal system scipy's ``CubicSpline`` solves, here by one dense solve (for a few nodes):
    interior rows from the continuity of the second derivative,
    dx_i·s_{i−1} + 2(dx_{i−1} + dx_i)·s_i + dx_{i−1}·s_{i+1} = 3(dx_i·d_{i−1} + dx_{i−1}·d_i) with the divided
    differences d_k = (y_{k+1} − y_k)/dx_k, the first and last rows from the continuity of the third
    (not-a-knot). Agrees with ``CubicSpline`` to rounding (tests/physics/test_track_grid.py).

    Args:
        x: ``(m,)`` increasing node times, s (m ≥ 4).
    """
    m = x.size
    dx = x[1:] - x[:-1]
    system = np.zeros((m, m))
    right = np.zeros((m, m))
    inner = np.arange(1, m - 1)
    before, after = dx[:-1], dx[1:]  # dx_{i−1}, dx_i of the inner rows
    system[inner, inner - 1] = after
    system[inner, inner] = 2.0 * (before + after)
    system[inner, inner + 1] = before
    right[inner, inner - 1] = -3.0 * after / before
    right[inner, inner] = 3.0 * (after / before - before / after)
    right[inner, inner + 1] = 3.0 * before / after
    first, last = x[2] - x[0], x[-1] - x[-3]
    system[0, :2] = dx[1], first
    a, b = (dx[0] + 2.0 * first) * dx[1] / (first * dx[0]), dx[0] ** 2 / (first * dx[1])  # of d_0, d_1
    right[0, :3] = -a, a - b, b
    system[-1, -2:] = last, dx[-2]
    a, b = dx[-1] ** 2 / (last * dx[-2]), (2.0 * last + dx[-1]) * dx[-2] / (last * dx[-1])  # of d_{m−3}, d_{m−2}
    right[-1, -3:] = -a, a - b, b
    return np.linalg.solve(system, right)


def _hermite(x, values, slopes, t):
    """The cubic Hermite interpolant of ``values`` and ``slopes`` at nodes ``x`` (last axis), at times ``t``.

    Outside ``x`` the end intervals' cubics are extrapolated.
    """
    j = np.searchsorted(x, t, side="right") - 1
    np.minimum(np.maximum(j, 0, out=j), x.size - 2, out=j)
    h = x[j + 1] - x[j]
    u = (t - x[j]) / h
    u2 = u * u
    level = u2 * (3.0 - 2.0 * u)
    return (values[..., j] * (1.0 - level) + values[..., j + 1] * level
            + slopes[..., j] * (h * u * (1.0 - u) ** 2) + slopes[..., j + 1] * (h * u2 * (u - 1.0)))


def spline_weights(x, t):
    """The not-a-knot spline through nodes ``x`` at times ``t`` as weights: ``(t.size, x.size)``, y(t) = W @ y(x)."""
    identity = np.eye(x.size)
    return _hermite(x, identity, spline_slopes(x).T, t).T


def grid_nodes(t, spacing_s, origin_s: float = 0.0):
    """Indices of the samples on which the environment is evaluated: all, or one per ``spacing_s`` (sorted times).

    The spacing is at most 1/:data:`MIN_BLOCK_INTERVALS` of the samples' span. With samples sparser than
    half the spacing, or unsorted, or fewer than 3: every sample. Otherwise the
    first, the last, and for each multiple of the spacing the first sample at or
    after it — a grid tied to the clock ``origin_s + t`` (the fields' clock), so
    successive long blocks of samples see the same nodes.
    """
    n = t.size
    if n < 3 or not (t[1:] >= t[:-1]).all():
        return np.arange(n)
    # At least MIN_BLOCK_INTERVALS intervals over the span: the spacing halved as often as needed (a discrete
    # set, so two clocks that read the same span to rounding pick the same spacing, and its multiples on a
    # clock at ≈ 10⁹ s stay the same instants).
    span = t[-1] - t[0]
    if span < MIN_BLOCK_INTERVALS * spacing_s:
        spacing_s = spacing_s / 2.0 ** math.ceil(math.log2(MIN_BLOCK_INTERVALS * spacing_s / span)) \
            if span > 0.0 else spacing_s
    if (t[-1] - t[0]) > 0.5 * spacing_s * (n - 1):
        return np.arange(n)
    # Multiples of the spacing on the fields' clock, as offsets from the block's start. A sample within
    # GRID_TIME_TOLERANCE_S before a multiple counts as on it: the same instant read on another clock
    # (real time: the node's start ≈ 1.7e9 s; fast time: 0) differs by rounding only.
    start = origin_s + t[0]
    multiples = np.arange(math.ceil(start / spacing_s - 1e-12), math.floor((origin_s + t[-1]) / spacing_s) + 1) \
        * spacing_s
    nodes = np.concatenate([[0], np.searchsorted(t - t[0], multiples - start - GRID_TIME_TOLERANCE_S, side="left"),
                            [n - 1]])
    np.minimum(nodes, n - 1, out=nodes)  # sorted: keep each index once
    keep = np.empty(nodes.size, bool)
    keep[0] = True
    np.greater(nodes[1:], nodes[:-1], out=keep[1:])
    return nodes[keep]
