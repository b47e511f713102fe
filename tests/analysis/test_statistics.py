"""Running statistics, harmonic analysis (physics.md §5.1) and the flight-test procedure (§5)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmv_ros.analysis.flight_test import average_over_orbits, correct_reference_drift, flight_test_statistics
from pmv_ros.analysis.statistics import (
    ORBIT_HARMONICS,
    OrbitRing,
    RunningStatistics,
    harmonic_amplitudes,
)

# physics.md §5.1: Meteor-M, one orbit T = 101 min = 6060 s sampled every 4 s.
PERIOD_S = 6060.0
OMEGA = 2.0 * math.pi / PERIOD_S


def synthetic(t, amplitudes: dict, phases: dict | None = None):
    """Σ A_k cos(kΩt + φ_k)."""
    phases = phases or {}
    return sum(a * np.cos(k * OMEGA * t + phases.get(k, 0.3 * k)) for k, a in amplitudes.items())


# ------------------------------------------------------------------ running statistics

def test_running_statistics_match_a_two_pass_computation():
    rng = np.random.default_rng(1)
    data = 1e3 + rng.normal(0.0, 2.0, 5000)     # a large mean: Welford must not lose the small spread
    stats = RunningStatistics()
    stats.update(data[:10])
    for value in data[10:1000]:
        stats.update(value)
    stats.update(data[1000:])
    assert stats.count == data.size
    assert stats.mean == pytest.approx(np.mean(data), rel=1e-13)
    assert stats.sigma == pytest.approx(np.std(data, ddof=1), rel=1e-10)
    assert stats.three_sigma == pytest.approx(3 * np.std(data, ddof=1), rel=1e-10)
    assert stats.max_abs == np.max(np.abs(data))
    assert stats.limit_high - stats.limit_low == pytest.approx(6 * np.std(data, ddof=1), rel=1e-10)


def test_running_statistics_edge_cases():
    stats = RunningStatistics()
    assert stats.count == 0 and math.isnan(stats.mean) and math.isnan(stats.sigma)
    stats.update(-2.0)
    assert stats.mean == -2.0 and stats.max_abs == 2.0 and math.isnan(stats.sigma)   # N − 1 = 0
    stats.update([np.nan, 4.0, np.inf])
    assert stats.count == 2 and stats.non_finite == 2
    assert stats.sigma == pytest.approx(math.sqrt(18.0))   # values −2, 4: Σε² = 18, N − 1 = 1
    stats.reset()
    assert stats.count == 0 and stats.non_finite == 0


# ----------------------------------------------------------------------- harmonics

def test_harmonics_of_an_evenly_sampled_orbit_are_exact():
    t = np.arange(0.0, PERIOD_S, 4.0)
    amplitudes = {1: 5.0, 2: 9.0, 20: 0.7}
    # Other harmonics, listed or not, must not leak: they are orthogonal over a whole orbit.
    signal = synthetic(t, amplitudes | {5: 1.0, 40: 0.5}) + 3.0
    result = dict(zip(ORBIT_HARMONICS, harmonic_amplitudes(OMEGA * t, signal)))
    for k in ORBIT_HARMONICS:
        assert result[k] == pytest.approx(amplitudes.get(k, 0.0), abs=1e-9)


def test_harmonics_of_uneven_noisy_gappy_samples():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, PERIOD_S, 4.0) + rng.uniform(-1.0, 1.0, 1515)     # jittered 4 s sampling
    t = t[(t < 2000.0) | (t > 2000.0 + 0.05 * PERIOD_S)]                  # a 5 % outage
    amplitudes = {1: 5.0, 2: 9.0, 20: 1.0}
    spread = {k: 0.3 for k in range(3, 15)}                               # power between the listed harmonics
    signal = synthetic(t, amplitudes | spread) + rng.normal(0.0, 0.5, t.size)
    result = dict(zip(ORBIT_HARMONICS, harmonic_amplitudes(OMEGA * t, signal)))
    # Tolerance 0.2: noise alone gives σ(a_k) = 0.5·√(2/1440) ≈ 0.02, and leakage through a 5 % gap
    # is about 5 % of the neighbouring power — the worst of 20 trials of this kind was 0.15
    # (statistics.DEFAULT_MAX_GAP_FRACTION note).
    for k in (1, 2, 20):
        assert result[k] == pytest.approx(amplitudes[k], abs=0.2)
    assert max(result[k] for k in (15, 16, 17, 18, 19, 21, 22, 23, 24, 25)) < 0.2


def test_harmonics_beyond_nyquist_or_with_a_big_hole_are_nan():
    u = np.radians(np.arange(0.0, 360.0, 22.5))                          # Kondor: 16 samples an orbit
    values = 2.0 * np.cos(u) + 1.0 * np.cos(2 * u + 1.0)
    result = dict(zip(ORBIT_HARMONICS, harmonic_amplitudes(u, values)))
    assert result[1] == pytest.approx(2.0, abs=1e-12) and result[2] == pytest.approx(1.0, abs=1e-12)
    assert all(math.isnan(result[k]) for k in range(15, 26))              # k ≤ 7 only
    half_orbit = u < math.pi
    assert np.all(np.isnan(harmonic_amplitudes(u[half_orbit], values[half_orbit])))
    with pytest.raises(ValueError, match="harmonics"):
        harmonic_amplitudes(u, values, harmonics=(0, 1))


def test_orbit_ring_recovers_known_amplitudes_with_fixed_memory():
    ring = OrbitRing(PERIOD_S, n_channels=2, n_bins=1024)
    size = ring.nbytes
    amplitudes = {1: 3.0, 2: 1.5, 20: 0.5}
    t_all = np.arange(1.0, 5.25 * PERIOD_S, 4.0)
    for i, t in enumerate(t_all):
        ring.add(t, [synthetic(t, amplitudes), -synthetic(t, {20: 2.0})])
        if i == 100:
            # Not yet a full orbit: no harmonics.
            assert np.all(np.isnan(ring.amplitudes()))
    assert ring.nbytes == size                  # five orbits later: same memory
    result = ring.amplitudes()
    k = list(ORBIT_HARMONICS)
    # Bin averaging attenuates harmonic k by sinc(πk/1024): 0.06 % at k = 20; 0.2 % covers it.
    assert result[k.index(1), 0] == pytest.approx(3.0, rel=2e-3)
    assert result[k.index(2), 0] == pytest.approx(1.5, rel=2e-3)
    assert result[k.index(20), 0] == pytest.approx(0.5, rel=2e-3)
    assert result[k.index(20), 1] == pytest.approx(2.0, rel=2e-3)
    assert result[k.index(17), 0] < 1e-3 and result[k.index(1), 1] < 1e-3
    ring.clear()
    assert np.all(np.isnan(ring.amplitudes())) and ring.nbytes == size


def test_orbit_ring_fitted_later_fits_the_bins_of_its_moment():
    # amplitudes_later copies the bins when called and fits at its call (a reader that may never come): after
    # another third of an orbit, with every bin it fits overwritten or moved on, it still gives bit for bit what
    # amplitudes() gave at its moment.
    ring = OrbitRing(PERIOD_S, n_channels=2, n_bins=256)
    rng = np.random.default_rng(3)

    def fly(t):
        for stamp in t:
            ring.add(stamp, [synthetic(stamp, {1: 3.0, 20: 0.5}) + rng.normal(0.0, 0.1), rng.normal()])

    fly(np.arange(1.0, 1.5 * PERIOD_S, 4.0))
    at_once, later = ring.amplitudes(), ring.amplitudes_later()
    assert np.isfinite(at_once).all()
    fly(np.arange(1.5 * PERIOD_S, 1.85 * PERIOD_S, 4.0))
    assert not np.array_equal(ring.amplitudes(), at_once)
    np.testing.assert_array_equal(later(), at_once)
    fresh = OrbitRing(PERIOD_S, n_channels=2, n_bins=256).amplitudes_later()
    assert fresh().shape == (len(ORBIT_HARMONICS), 2) and np.isnan(fresh()).all()  # no orbit yet: NaN


def test_orbit_ring_sums_per_bin_whatever_the_order_and_when_it_is_read():
    # The bin being filled is summed in floats and written back later: reading the harmonics
    # mid-bin, a late sample for an earlier bin and NaN channels must not change what is fitted.
    period, n_bins = 640.0, 64
    rng = np.random.default_rng(8)
    t = np.sort(rng.uniform(0.0, 2.6 * period, 4000))
    late = rng.choice(t.size - 50, 40, replace=False)
    order = np.arange(t.size)
    for k in late:  # a few samples arrive 20 samples late (still inside the ring)
        order = np.insert(np.delete(order, np.where(order == k)[0]), np.where(order == k + 20)[0][0] + 1, k)
    values = np.column_stack([synthetic(t, {1: 2.0, 3: 0.5}), synthetic(t, {2: 1.0}), rng.normal(size=t.size)])
    values[rng.random(t.size) < 0.1, 2] = np.nan
    read_while_adding, read_at_end = OrbitRing(period, 3, n_bins), OrbitRing(period, 3, n_bins)
    for i, k in enumerate(order):
        assert read_while_adding.add(t[k], list(values[k])) == read_at_end.add(t[k], values[k])
        if i % 37 == 0:
            read_while_adding.amplitudes(harmonics=(1, 2))
    result = read_at_end.amplitudes(harmonics=(1, 2, 3))
    np.testing.assert_array_equal(read_while_adding.amplitudes(harmonics=(1, 2, 3)), result)
    # The same fit from sums made here, sample by sample, over the last n_bins bins.
    width = period / n_bins
    last = math.floor(t.max() / width)
    sums = {}
    for k in order:
        b = math.floor(t[k] / width)
        if b > last - n_bins:
            for c in range(3):
                if np.isfinite(values[k, c]):
                    entry = sums.setdefault((b, c), [0, 0.0, 0.0])
                    entry[0] += 1
                    entry[1] += t[k] - t[order[0]]
                    entry[2] += values[k, c]
    for c in range(3):
        bins = sorted(b for b, channel in sums if channel == c)
        mean_time = np.array([sums[b, c][1] / sums[b, c][0] for b in bins])
        means = np.array([sums[b, c][2] / sums[b, c][0] for b in bins])
        expected = harmonic_amplitudes(2.0 * math.pi / period * mean_time, means, (1, 2, 3))
        np.testing.assert_allclose(result[:, c], expected, rtol=1e-9, atol=1e-12)


def test_orbit_ring_takes_none_as_a_missing_value_and_any_array_shape():
    with_none, with_nan = OrbitRing(640.0, 2, 64), OrbitRing(640.0, 2, 64)
    for k in range(2000):
        t = 0.5 * k
        value = math.sin(2.0 * math.pi * t / 640.0)
        assert with_none.add(t, [value, None if k % 3 else value]) == with_nan.add(
            t, np.array([[value], [math.nan if k % 3 else value]]))
    np.testing.assert_array_equal(with_none.amplitudes(harmonics=(1, 2)), with_nan.amplitudes(harmonics=(1, 2)))
    assert with_none.amplitudes(harmonics=(1,))[0, 0] == pytest.approx(1.0, rel=1e-3)


def test_orbit_ring_rejects_bad_configuration():
    with pytest.raises(ValueError, match="n_bins"):
        OrbitRing(PERIOD_S, 1, n_bins=16)
    with pytest.raises(ValueError, match="period"):
        OrbitRing(-1.0, 1)


# ------------------------------------------------------------- flight-test procedure

def test_average_over_orbits_groups_equal_u_including_the_wrap():
    u = np.array([0.0, 2 * math.pi - 1e-12, math.pi, 3 * math.pi, 4 * math.pi])
    values = np.array([1.0, 3.0, 10.0, 20.0, 5.0])
    group_u, means, counts = average_over_orbits(u, values)
    assert list(counts) == [3, 2]
    assert means[0] == pytest.approx(3.0) and means[1] == pytest.approx(15.0)
    assert group_u[1] == pytest.approx(math.pi)


def test_step_5_meridional_statistics_by_hand():
    # Step 2–5 with the oblateness kept: offsets are the means; δβ_m = √(δβ_k² + δβ_t²).
    u = np.radians(np.arange(0.0, 360.0, 45.0))
    roll_dev = np.array([1.0, -2.0, 0.5, 0.0, 3.0, -1.5, -1.0, 0.0])
    pitch_dev = np.array([0.0, 1.0, -1.0, 2.0, -2.0, 0.5, 0.0, -0.5])
    roll, pitch = 7.0 + roll_dev, -4.0 + pitch_dev
    result = flight_test_statistics(np.concatenate([u, u + 2 * math.pi]), np.tile(roll, 2), np.tile(pitch, 2),
                                    500e3, math.radians(74.5), remove_oblateness=False)
    assert result.roll_offset_rad == pytest.approx(7.0) and result.pitch_offset_rad == pytest.approx(-4.0)
    meridional = np.hypot(roll_dev, pitch_dev)
    assert result.mo_rad == pytest.approx(meridional.mean())
    assert result.sigma_m_rad == pytest.approx(np.std(meridional, ddof=1))
    assert result.limit_high_rad == pytest.approx(meridional.mean() + 3 * np.std(meridional, ddof=1))
    assert result.orbits == 2 and list(result.samples_per_u) == [2] * 8


def test_reference_drift_correction_is_linear_in_elapsed_time():
    corrected = correct_reference_drift([1.0, 2.0, 3.0], [0.0, 10.0, 20.0], 0.1)
    assert np.allclose(corrected, [1.0, 1.0, 1.0])
