"""The coarse time grid on which the sensor evaluates the environment along each chord's track.

The fields of the environment change along a chord's track on scales of a hundred kilometres and more,
while a horizon point moves < 1 km between samples 0.1 s apart: the sensor evaluates them at a few grid
samples (:func:`grid_nodes`) and interpolates in time to the rest (:func:`interpolate_in_time`). The
grid's spacings come from the fields' scales (:class:`~pmv_ros.physics.instrument.sensor.RadianceConfig`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import CubicSpline

#: Longest spacing of the coarse time grid on which the environment is evaluated along each chord's
#: track, s (see :class:`~pmv_ros.physics.instrument.sensor.RadianceConfig`).
MAX_FIELD_GRID_S = 30.0
#: Grid spacing as a fraction of the time a horizon point takes to cross a field's shortest wavelength.
#: The fields are interpolated in time by cubic splines, which reproduce a wave sampled this densely to
#: ≈ (2π·fraction)⁴/384 ≈ 1.6 % of its amplitude — for the shortest waves of a field only. (The layer
#: height's Gaussian field is interpolated and mapped to its uniform law afterwards: the map makes
#: harmonics shorter than the field's own.)
FIELD_GRID_FRACTION = {"band": 0.25, "weather": 0.25, "height": 0.25}
#: Two clock readings closer than this, s, are the same instant for the track grid (float64 rounding of
#: a clock at ≈ 2·10⁹ s is ≈ 2·10⁻⁷ s; samples are ≥ 10 ms apart).
GRID_TIME_TOLERANCE_S = 1e-6
#: Ground speed of a horizon point along its track, m/s (the orbital rate on the Earth's surface,
#: ≈ 6.6 km/s at 500–835 km, plus up to 0.46 km/s of Earth rotation), rounded up.
HORIZON_POINT_SPEED_M_S = 7.2e3


def interpolate_in_time(t, nodes, values):
    """Values given at the samples ``nodes`` (last axis), interpolated in time to every sample of ``t``.

    A not-a-knot cubic spline through 4 nodes or more, linear through 2 or 3.
    """
    if nodes.size == t.size:
        return values
    t_nodes = t[nodes]
    if nodes.size >= 4 and np.all(np.diff(t_nodes) > 0.0):
        return CubicSpline(t_nodes, values, axis=-1)(t)
    j = np.clip(np.searchsorted(t_nodes, t, side="right") - 1, 0, nodes.size - 2)
    span = t_nodes[j + 1] - t_nodes[j]
    w = np.where(span > 0.0, (t - t_nodes[j]) / np.where(span > 0.0, span, 1.0), 0.0)
    return values[..., j] * (1.0 - w) + values[..., j + 1] * w


def grid_nodes(t, spacing_s, origin_s: float = 0.0):
    """Indices of the samples on which the environment is evaluated: all, or one per ``spacing_s`` (sorted times).

    The spacing is at most 1/8 of the samples' span. With samples sparser than
    half the spacing, or unsorted, or fewer than 3: every sample. Otherwise the
    first, the last, and for each multiple of the spacing the first sample at or
    after it — a grid tied to the clock ``origin_s + t`` (the fields' clock), so
    successive long blocks of samples see the same nodes.
    """
    n = t.size
    if n < 3 or not np.all(np.diff(t) >= 0.0):
        return np.arange(n)
    # At least 8 intervals over the span, so the spline of a short block is not all end conditions: the
    # spacing halved as often as needed (a discrete set, so two clocks that read the same span to rounding
    # pick the same spacing, and its multiples on a clock at ≈ 10⁹ s stay the same instants).
    span = t[-1] - t[0]
    if span < 8.0 * spacing_s:
        spacing_s = spacing_s / 2.0 ** math.ceil(math.log2(8.0 * spacing_s / span)) if span > 0.0 else spacing_s
    if (t[-1] - t[0]) > 0.5 * spacing_s * (n - 1):
        return np.arange(n)
    # Multiples of the spacing on the fields' clock, as offsets from the block's start. A sample within
    # GRID_TIME_TOLERANCE_S before a multiple counts as on it: the same instant read on another clock
    # (real time: the node's start ≈ 1.7e9 s; fast time: 0) differs by rounding only.
    start = origin_s + t[0]
    multiples = np.arange(math.ceil(start / spacing_s - 1e-12), math.floor((origin_s + t[-1]) / spacing_s) + 1) \
        * spacing_s
    nodes = np.searchsorted(t - t[0], multiples - start - GRID_TIME_TOLERANCE_S, side="left")
    nodes = np.unique(np.concatenate([[0], nodes, [n - 1]]))
    return nodes[nodes < n]
