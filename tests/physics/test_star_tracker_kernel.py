"""The star tracker's compiled draws against scipy's laws (the frame kernel's normals and Poisson counts).

The kernel (pmv_ros/physics/star_tracker/kernel.py) draws its normals with Wichura's AS 241 and its Poisson counts
by summing the probabilities; the model drew them with scipy's ``ndtri`` and ``ceil(pdtrik)`` before. Both are
the same laws to rounding: a normal within 2e-15 relative (AS 241 is good to ≈ 1e-16, scipy's to its ulps), every
count equal (a count differs only for a uniform within rounding of a step of the CDF).
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtri, pdtrik

from pmv_ros.physics.star_tracker.draws import Draws


def test_normals_are_scipys_to_rounding():
    draws = Draws(7)
    u = np.concatenate([draws.uniform(3, np.arange(100_000), 0), [1e-300, 1e-20, 1e-10, 0.02425, 0.5, 1 - 1e-12]])
    z = Draws.normals_of(u)
    expected = ndtri(u)
    assert np.all(np.abs(z - expected) <= 2e-15 * np.maximum(np.abs(expected), 1.0))
    # Keyed: the same key gives the same normal, whatever else is drawn with it.
    assert draws.normal(0, [5, 6, 7], 11)[1] == draws.normal(0, 6, 11)


def test_poisson_counts_are_scipys():
    draws = Draws(3)
    rng = np.random.default_rng(1)
    mean = np.concatenate([np.exp(rng.uniform(np.log(1e-3), np.log(2e4), 50_000)), [0.0, -1.0, 43.6, 2000.0]])
    u = draws.uniform(4, np.arange(mean.size), 1)
    counts = draws.poisson(mean, 4, np.arange(mean.size), 1)
    expected = np.where(mean > 0, np.ceil(pdtrik(u, np.where(mean > 0, mean, 1.0))), 0).astype(np.int64)
    np.testing.assert_array_equal(counts, expected)
