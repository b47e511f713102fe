"""The radiance environment: climatology anchors, weather and layer-height statistics.

Reference values: physics.md §3 (radiance range, mean, layer heights) and §3.1
(model B anchors; model C η′ = 0.15, R_x = 300 km theory / 700 km flight).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from pmv_ros.physics.constants import EARTH_MEAN_RADIUS_M
from pmv_ros.physics.environment import (
    EnvironmentParameters,
    GaussianSphereField,
    LayerHeightField,
    RadianceEnvironment,
    SynopticBandField,
    WeatherField,
    horizon_radiance_climatology,
)

DAY_S = 86400.0
#: Southern summer of the physics.md §3.1 example (day of year ≈ 15).
SOUTHERN_SUMMER_DAY = 15.0
NORTHERN_SUMMER_DAY = 196.0


def random_points(rng, n):
    """Points uniform on the sphere: latitude, longitude, rad."""
    return np.arcsin(rng.uniform(-1.0, 1.0, n)), rng.uniform(-math.pi, math.pi, n)


def points_at_distance(rng, n, distance_m):
    """n pairs of points uniform on the sphere, each pair a great-circle distance apart in a random direction."""
    lat1, lon1 = random_points(rng, n)
    azimuth = rng.uniform(0.0, 2.0 * math.pi, n)
    arc = distance_m / EARTH_MEAN_RADIUS_M
    lat2 = np.arcsin(np.sin(lat1) * np.cos(arc) + np.cos(lat1) * np.sin(arc) * np.cos(azimuth))
    lon2 = lon1 + np.arctan2(np.sin(azimuth) * np.sin(arc) * np.cos(lat1),
                             np.cos(arc) - np.sin(lat1) * np.sin(lat2))
    return lat1, lon1, lat2, lon2


def epochs(n_points, n_epochs, spacing_s):
    """Times for n_points split into n_epochs groups, spacing_s apart."""
    return np.repeat(np.arange(n_epochs) * spacing_s, -(-n_points // n_epochs))[:n_points]


# Sampling plan for the statistics. One snapshot of the Earth holds only about
# 2(R_E/R_x)² ≈ 170 independent patches at R_x = 700 km, so one snapshot's
# sample η′ and correlation scatter by ≈ 0.03 between seeds (measured over 40
# seeds). The parameters are ensemble statistics: we sample 10 epochs 10 τ
# apart (independent weather), which brings the scatter to ≈ 0.01 — well
# inside the 0.1 and 10 % of the issue. We hold the statistics to 0.04 and
# 5 % (≈ 5 σ of that scatter over 30 seeds), which implies the limits
# and also fails for a radius 12 % off or a Gaussian covariance of the same
# e-folding (0.78 instead of 0.61 at R_x/2, 0.02 instead of 0.14 at 2 R_x).
N_PAIRS = 40000
N_EPOCHS = 10
CORRELATION_TOLERANCE = 0.04
ETA_RELATIVE_TOLERANCE = 0.05


# --------------------------------------------------------------------------
# Weather statistics
# --------------------------------------------------------------------------

@pytest.mark.parametrize("radius_m", [700e3, 300e3])
def test_weather_correlation_is_exponential_with_radius(radius_m):
    weather = WeatherField(correlation_radius_m=radius_m, seed=11)
    rng = np.random.default_rng(5)
    t = epochs(N_PAIRS, N_EPOCHS, 10 * weather.time_scale_s)
    for multiple in (0.5, 1.0, 2.0):
        lat1, lon1, lat2, lon2 = points_at_distance(rng, N_PAIRS, multiple * radius_m)
        b1 = weather.radiance_ru(2.4, lat1, lon1, t)
        b2 = weather.radiance_ru(2.4, lat2, lon2, t)
        measured = np.corrcoef(b1, b2)[0, 1]
        # Covariance is exp(−chord/R_x); the chord is 0.05 % shorter than the arc here.
        chord_m = 2.0 * EARTH_MEAN_RADIUS_M * math.sin(0.5 * multiple * radius_m / EARTH_MEAN_RADIUS_M)
        assert measured == pytest.approx(math.exp(-chord_m / radius_m), abs=CORRELATION_TOLERANCE), multiple


@pytest.mark.parametrize("fraction", [0.2, 0.5])
def test_synoptic_weather_has_the_documented_covariance(fraction):
    # WeatherField: C(ψ) = w·mean_ℓ P_ℓ(cos ψ) + (1 − w)·exp(−c/R_b), R_b such that C(R_x) = e⁻¹.
    # Measured over 10 independent epochs, as the exponential test above (same tolerance and reason).
    weather = WeatherField(correlation_radius_m=700e3, synoptic_fraction=fraction, seed=21)
    rng = np.random.default_rng(8)
    t = epochs(N_PAIRS, N_EPOCHS, 10 * weather.time_scale_s)
    for distance_m in (350e3, 700e3, 1000e3, 1500e3):
        lat1, lon1, lat2, lon2 = points_at_distance(rng, N_PAIRS, distance_m)
        measured = np.corrcoef(weather.relative_anomaly(lat1, lon1, t), weather.relative_anomaly(lat2, lon2, t))[0, 1]
        expected = float(weather.correlation(distance_m / EARTH_MEAN_RADIUS_M))
        assert measured == pytest.approx(expected, abs=CORRELATION_TOLERANCE), distance_m
    assert float(weather.correlation(700e3 / EARTH_MEAN_RADIUS_M)) == pytest.approx(math.exp(-1.0), abs=1e-9)
    lat, lon = random_points(rng, N_PAIRS)
    assert np.std(weather.relative_anomaly(lat, lon, t)) == pytest.approx(1.0, rel=ETA_RELATIVE_TOLERANCE)


def test_the_synoptic_band_peaks_along_a_ground_track():
    # Zones of 2000 km (degrees 15 … 25): along a great circle a degree-ℓ field has its power at orders
    # m ≤ ℓ with density ∝ 1/√(ℓ² − m²), so the band's spectrum rises towards m ≈ 15 … 25 (measured:
    # ≈ 1.6× the power per order of m = 1 … 9) and stops above 25; an exponential covariance's falls with
    # m. Power averaged over 40 circles of random orientation.
    def track_power(field):
        rng = np.random.default_rng(2)
        angle = np.linspace(0.0, 2.0 * math.pi, 512, endpoint=False)
        power = np.zeros(257)
        for _ in range(40):
            a, b = np.linalg.qr(rng.standard_normal((3, 3)))[0][:, :2].T
            circle = np.cos(angle)[:, None] * a + np.sin(angle)[:, None] * b
            power += np.abs(np.fft.rfft(field(np.arcsin(circle[:, 2]), np.arctan2(circle[:, 1], circle[:, 0]),
                                              0.0))) ** 2
        return power

    band = track_power(SynopticBandField(15, 25, time_scale_s=math.inf, seed=4))
    assert np.mean(band[15:26]) > 1.3 * np.mean(band[1:10])
    assert np.sum(band[27:]) < 1e-6 * np.sum(band)  # band-limited: nothing above ℓ_max
    red = track_power(GaussianSphereField(700e3, time_scale_s=math.inf, seed=4))
    assert np.mean(red[15:26]) < 0.5 * np.mean(red[1:10])


@pytest.mark.parametrize("radius_m", [700e3, 300e3])
def test_weather_relative_variability_matches_eta(radius_m):
    weather = WeatherField(relative_variability=0.15, correlation_radius_m=radius_m, seed=3)
    rng = np.random.default_rng(6)
    lat, lon = random_points(rng, N_PAIRS)
    radiance = weather.radiance_ru(2.4, lat, lon, epochs(N_PAIRS, N_EPOCHS, 10 * DAY_S))
    # η′ = σ_B / B_mean (physics.md §3.1).
    assert np.std(radiance) / np.mean(radiance) == pytest.approx(0.15, rel=ETA_RELATIVE_TOLERANCE)
    assert np.mean(radiance) == pytest.approx(2.4, rel=0.02)


def test_weather_with_climatology_keeps_eta_relative_to_the_local_mean():
    env = RadianceEnvironment(EnvironmentParameters(height_variation_enabled=False, seed=8))
    rng = np.random.default_rng(7)
    lat, lon = random_points(rng, N_PAIRS)
    t = epochs(N_PAIRS, N_EPOCHS, 10 * DAY_S)
    relative = env.horizon_radiance_ru(lat, lon, t) / env.mean_radiance_ru(lat, t) - 1.0
    assert np.std(relative) == pytest.approx(0.15, rel=ETA_RELATIVE_TOLERANCE)
    assert abs(np.mean(relative)) < 0.02


def test_weather_anomaly_is_close_to_standard_normal():
    field = GaussianSphereField(700e3, seed=4)
    rng = np.random.default_rng(8)
    lat, lon = random_points(rng, N_PAIRS)
    values = field(lat, lon, epochs(N_PAIRS, N_EPOCHS, 10 * DAY_S))
    assert np.mean(values) == pytest.approx(0.0, abs=0.05)
    assert np.std(values) == pytest.approx(1.0, rel=0.05)
    # 3σ events occur at the normal rate (0.27 %), not more than twice or less than half as often.
    assert 0.5 * 0.0027 < np.mean(np.abs(values) > 3.0) < 2.0 * 0.0027


@pytest.mark.parametrize("t_s", [0.0, 1.0e9 + 12.345])
def test_fast_synthesis_matches_a_float64_sum(t_s):
    # The float32 evaluation against the defining sum √(2/M) Σ cos(k·x + ωt + b)
    # in float64, also at a large clock value (≈ 32 years): phases are formed
    # relative to the batch time, so float32 never sees a large time.
    field = GaussianSphereField(700e3, seed=13)
    wave_vectors, frequency_rad_s, phase_rad = field.components
    rng = np.random.default_rng(19)
    lat, lon = random_points(rng, 3000)
    t = t_s + rng.uniform(0.0, 3600.0, lat.size)
    unit = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
    phase = unit.T @ wave_vectors + np.outer(t, frequency_rad_s) + phase_rad
    reference = math.sqrt(2.0 / field.n_components) * np.cos(phase).sum(axis=1)
    np.testing.assert_allclose(field(lat, lon, t), reference, atol=1e-3)


def test_weather_keeps_the_radiance_inside_1_to_4_ru():
    # physics.md §3.2 item 2: the horizon radiance stays inside L_min … L_max = 1 … 4 r.u.
    # whatever the weather does. η = 1 around 2.4 r.u. leaves the range for |a| > 0.58 or 0.67:
    # roughly half the points, split between the two bounds.
    weather = WeatherField(relative_variability=1.0, seed=2)
    lat, lon = random_points(np.random.default_rng(9), 5000)
    radiance = weather.radiance_ru(2.4, lat, lon, 0.0)
    assert radiance.min() == 1.0 and radiance.max() == 4.0
    assert 0.15 < np.mean(radiance == 1.0) < 0.4 and 0.15 < np.mean(radiance == 4.0) < 0.4
    # A (test) mean already below 1 r.u. is not pushed further out.
    assert weather.radiance_ru(0.5, lat, lon, 0.0).min() == 0.5


# --------------------------------------------------------------------------
# Time evolution
# --------------------------------------------------------------------------

def test_weather_evolves_slowly_in_time():
    time_scale_s = 2.0 * DAY_S
    field = GaussianSphereField(700e3, time_scale_s=time_scale_s, seed=12)
    lat, lon = random_points(np.random.default_rng(10), 20000)
    t0 = epochs(20000, N_EPOCHS, 10 * time_scale_s)
    now = field(lat, lon, t0)

    def lagged(lag_s):
        return np.corrcoef(now, field(lat, lon, t0 + lag_s))[0, 1]

    # Correlation exp(−(lag/τ)²): 0.9975 at τ/20 (an orbit is τ/30 at τ = 2 days).
    assert lagged(0.05 * time_scale_s) > 0.99
    assert lagged(time_scale_s) == pytest.approx(math.exp(-1.0), abs=0.1)
    assert abs(lagged(5.0 * time_scale_s)) < 0.1


def test_frozen_weather_does_not_change():
    field = GaussianSphereField(700e3, time_scale_s=math.inf, seed=12)
    lat, lon = random_points(np.random.default_rng(10), 1000)
    np.testing.assert_array_equal(field(lat, lon, 0.0), field(lat, lon, 30.0 * DAY_S))


def test_value_at_a_point_does_not_depend_on_the_batch():
    # The node evaluates a few points per chord in batches of any size and
    # time span: a point must get the same value (float32 synthesis: 1e-5).
    env = RadianceEnvironment(EnvironmentParameters(seed=21))
    rng = np.random.default_rng(11)
    lat, lon = random_points(rng, 5000)
    t = rng.uniform(0.0, 10.0 * DAY_S, 5000)
    whole = env.sample(lat, lon, t)
    for index in (0, 1234, 4999):
        alone = env.sample(lat[index], lon[index], t[index])
        assert alone.horizon_radiance_ru == pytest.approx(whole.horizon_radiance_ru[index], abs=1e-5)
        assert alone.window_height_m == pytest.approx(whole.window_height_m[index], abs=0.5)
    separately = env.horizon_radiance_ru(lat, lon, t)
    np.testing.assert_allclose(separately, whole.horizon_radiance_ru, atol=1e-5)


def test_radiance_without_the_layers_is_the_same_radiance():
    # The sensor's probe points inside the horizon need the radiance only; skipping the
    # layer-height synthesis there must not move it (float32 synthesis: 1e-5 r.u.).
    env = RadianceEnvironment(EnvironmentParameters(seed=4))
    rng = np.random.default_rng(12)
    lat, lon = random_points(rng, 3000)
    t = rng.uniform(0.0, 2.0 * DAY_S, 3000)
    full, radiance_only = env.sample(lat, lon, t), env.sample(lat, lon, t, layers=False)
    np.testing.assert_allclose(radiance_only.horizon_radiance_ru, full.horizon_radiance_ru, atol=1e-5)
    np.testing.assert_array_equal(radiance_only.mean_radiance_ru, full.mean_radiance_ru)
    assert np.all(np.isnan(radiance_only.window_height_m)) and np.all(np.isnan(radiance_only.co2_height_m))
    calm = RadianceEnvironment(EnvironmentParameters(weather_enabled=False, seed=4))
    np.testing.assert_array_equal(calm.sample(lat, lon, t, layers=False).horizon_radiance_ru,
                                  calm.sample(lat, lon, t).horizon_radiance_ru)


# --------------------------------------------------------------------------
# Layer heights
# --------------------------------------------------------------------------

def test_window_layer_height_is_uniform_with_sigma_10_km():
    # physics.md §3.2 item 4: σ_h = 10 km, 40 ± 20 km read as ±2σ of a uniform law: half-width 17.3 km.
    layer = LayerHeightField(seed=5)
    lat, lon = random_points(np.random.default_rng(12), N_PAIRS)
    height_km = layer.height_m(lat, lon, epochs(N_PAIRS, N_EPOCHS, 10 * DAY_S)) / 1e3
    low, width = 40.0 - 10.0 * math.sqrt(3.0), 20.0 * math.sqrt(3.0)
    assert height_km.min() >= low and height_km.max() <= low + width
    # Quantiles of U(22.7, 57.3) km within 1.5 km (seed-to-seed scatter ≈ 0.4 km).
    probabilities = np.array([0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 0.95])
    np.testing.assert_allclose(np.quantile(height_km, probabilities), low + width * probabilities, atol=1.5)
    assert np.std(height_km) == pytest.approx(10.0, rel=0.05)
    # The points are correlated, so a KS p-value means little; the distance
    # itself stays ≈ 0.012 ± 0.005 over seeds, and a normal of the same mean
    # and σ would give 0.06.
    assert stats.kstest((height_km - low) / width, "uniform").statistic < 0.04


def test_window_layer_height_is_correlated_like_the_weather():
    radius_m = 700e3
    layer = LayerHeightField(correlation_radius_m=radius_m, seed=6)
    lat1, lon1, lat2, lon2 = points_at_distance(np.random.default_rng(13), N_PAIRS, radius_m)
    t = epochs(N_PAIRS, N_EPOCHS, 10 * DAY_S)
    measured = np.corrcoef(layer.height_m(lat1, lon1, t), layer.height_m(lat2, lon2, t))[0, 1]
    # Through Φ a Gaussian correlation ρ becomes (6/π)·asin(ρ/2) = 0.353 at ρ = e⁻¹.
    assert measured == pytest.approx(6.0 / math.pi * math.asin(0.5 * math.exp(-1.0)), abs=0.05)


def test_co2_layer_is_fixed_by_default_and_nearly_fixed_when_asked():
    lat, lon = random_points(np.random.default_rng(14), 20000)
    fixed = RadianceEnvironment().co2_height_m(lat, lon, 0.0)
    np.testing.assert_array_equal(fixed, 60e3)
    # The window layer must stay below the lowest CO₂ layer: 40 ± 19.5 km.
    spread = RadianceEnvironment(EnvironmentParameters(co2_height_half_range_m=500.0,
                                                       window_height_half_range_m=19.5e3))
    height_m = spread.co2_height_m(lat, lon, epochs(20000, N_EPOCHS, 10 * DAY_S))
    assert 59.5e3 <= height_m.min() and height_m.max() <= 60.5e3
    assert np.std(height_m) == pytest.approx(500.0 / math.sqrt(3.0), rel=0.10)


# --------------------------------------------------------------------------
# Seeds and independence
# --------------------------------------------------------------------------

def test_same_seed_same_environment_other_seed_other_weather():
    lat, lon = random_points(np.random.default_rng(15), 5000)
    first = RadianceEnvironment(EnvironmentParameters(seed=7))
    again = RadianceEnvironment(EnvironmentParameters(seed=7))
    other = RadianceEnvironment(EnvironmentParameters(seed=8))
    np.testing.assert_array_equal(first.sample(lat, lon, 100.0).horizon_radiance_ru,
                                  again.sample(lat, lon, 100.0).horizon_radiance_ru)
    np.testing.assert_array_equal(first.sample(lat, lon, 100.0).window_height_m,
                                  again.sample(lat, lon, 100.0).window_height_m)
    # Another seed: unrelated weather and heights (|r| ≈ 0.03 by chance at this size).
    for a, b in ((first.weather.relative_anomaly, other.weather.relative_anomaly),
                 (first.window_height_m, other.window_height_m)):
        assert abs(np.corrcoef(a(lat, lon, 100.0), b(lat, lon, 100.0))[0, 1]) < 0.2


def test_weather_and_layer_height_are_independent():
    env = RadianceEnvironment(EnvironmentParameters(seed=9))
    lat, lon = random_points(np.random.default_rng(16), N_PAIRS)
    t = epochs(N_PAIRS, N_EPOCHS, 10 * DAY_S)
    anomaly = env.weather.relative_anomaly(lat, lon, t)
    assert abs(np.corrcoef(anomaly, env.window_height_m(lat, lon, t))[0, 1]) < 0.1


# --------------------------------------------------------------------------
# Climatology
# --------------------------------------------------------------------------

def horizon_offset_deg(altitude_m):
    """Arc from the sub-satellite point to the hard-Earth horizon point, deg (physics.md §2)."""
    return 90.0 - math.degrees(math.asin(EARTH_MEAN_RADIUS_M / (EARTH_MEAN_RADIUS_M + altitude_m)))


def climatology_deg(lat_deg, day):
    return horizon_radiance_climatology(np.radians(lat_deg), day)


def test_climatology_meets_the_model_b_anchors():
    # physics.md §3.1: southern summer, sub-satellite point 45° S at 500 km,
    # L(1) = 4 and L(2) = 8.75 mW/(cm² sr) = 1.6 and 3.5 r.u. at the two
    # horizons, 2.6 r.u. under the spacecraft. Tolerance 0.1 r.u.: 2.6 is a
    # rounded mean, and 0.1 r.u. is < 2° of latitude at the steepest anchor
    # (0.06 r.u./deg at 45° S), the precision to which the example fixes
    # where the horizons fall.
    offset = horizon_offset_deg(500e3)
    assert offset == pytest.approx(22.0, abs=0.1)
    assert climatology_deg(-45.0 + offset, SOUTHERN_SUMMER_DAY) == pytest.approx(3.5, abs=0.1)
    assert climatology_deg(-45.0, SOUTHERN_SUMMER_DAY) == pytest.approx(2.6, abs=0.1)
    assert climatology_deg(-45.0 - offset, SOUTHERN_SUMMER_DAY) == pytest.approx(1.6, abs=0.1)


def test_climatology_range_and_extremes():
    lat_deg = np.linspace(-90.0, 90.0, 361)[:, None]
    day = np.arange(0.0, 366.0, 1.0)[None, :]
    radiance = climatology_deg(lat_deg, day)
    # physics.md §3: between ≈ 1 (winter Antarctica) and ≈ 4 r.u. (dry subtropics in summer).
    assert radiance.min() >= 0.9 and radiance.max() <= 4.1
    antarctic_winter = climatology_deg(np.linspace(-90.0, -75.0, 16), NORTHERN_SUMMER_DAY)
    assert antarctic_winter == pytest.approx(1.0, abs=0.15)
    subtropical_summer_max = climatology_deg(np.linspace(15.0, 35.0, 21), NORTHERN_SUMMER_DAY).max()
    assert subtropical_summer_max == pytest.approx(4.0, abs=0.15)
    # Global annual mean ≈ 2.4 r.u. (physics.md §3), area-weighted.
    weights = np.cos(np.radians(lat_deg))
    assert float(np.sum(radiance * weights) / (np.sum(weights) * radiance.shape[1])) == pytest.approx(2.4, abs=0.1)


def test_climatology_is_smooth_in_latitude_and_season():
    lat_deg = np.linspace(-90.0, 90.0, 1801)[:, None]
    day = np.arange(0.0, 366.0, 1.0)[None, :]
    radiance = climatology_deg(lat_deg, day)
    # No fronts in the climatology (they are the weather's job): slope below
    # 0.15 r.u. per degree of latitude, i.e. ≥ 700 km for 1 r.u. (the steepest,
    # 0.10 r.u./deg, is the northern tropics' edge in July).
    assert np.abs(np.diff(radiance, axis=0)).max() < 0.015
    # An annual swing of ≤ 1.5 r.u. moves ≤ 0.013 r.u. a day.
    assert np.abs(np.diff(radiance, axis=1)).max() < 0.02
    # Periodic with the year.
    np.testing.assert_allclose(climatology_deg(lat_deg, 10.0), climatology_deg(lat_deg, 10.0 + 365.25), atol=1e-9)


def test_southern_summer_gradient_is_near_the_largest():
    # physics.md §3.1 calls the 45° S southern-summer case the largest real
    # gradient. Ours peaks at ≈ 50° S in mid-January (2.03 vs 1.90 r.u.):
    # require the anchor case within 10 % of the largest anywhere, any day.
    offset = horizon_offset_deg(500e3)
    sub_satellite = np.linspace(-68.0, 68.0, 137)[:, None]
    day = np.arange(0.0, 366.0, 2.0)[None, :]
    difference = np.abs(climatology_deg(sub_satellite + offset, day) - climatology_deg(sub_satellite - offset, day))
    anchor = climatology_deg(-45.0 + offset, SOUTHERN_SUMMER_DAY) - climatology_deg(-45.0 - offset,
                                                                                 SOUTHERN_SUMMER_DAY)
    assert anchor >= 0.9 * difference.max()
    largest = np.unravel_index(np.argmax(difference), difference.shape)
    assert sub_satellite[largest[0], 0] < 0.0  # in the southern hemisphere
    assert abs(day[0, largest[1]] - SOUTHERN_SUMMER_DAY) < 30.0  # in southern summer


# --------------------------------------------------------------------------
# Switches, shapes, NaN, errors
# --------------------------------------------------------------------------

def test_switches_turn_each_part_off():
    lat, lon = random_points(np.random.default_rng(17), 2000)
    t = 3600.0
    uniform = RadianceEnvironment(EnvironmentParameters(
        climatology_enabled=False, weather_enabled=False, height_variation_enabled=False))
    sample = uniform.sample(lat, lon, t)
    np.testing.assert_array_equal(sample.horizon_radiance_ru, 2.4)
    np.testing.assert_array_equal(sample.window_height_m, 40e3)
    np.testing.assert_array_equal(sample.co2_height_m, 60e3)

    climate_only = RadianceEnvironment(EnvironmentParameters(weather_enabled=False))
    expected = horizon_radiance_climatology(lat, SOUTHERN_SUMMER_DAY + t / DAY_S)
    np.testing.assert_allclose(climate_only.horizon_radiance_ru(lat, lon, t), expected, rtol=1e-12)

    weather_only = RadianceEnvironment(EnvironmentParameters(climatology_enabled=False,
                                                             height_variation_enabled=False))
    radiance = weather_only.horizon_radiance_ru(lat, lon, t)
    assert np.std(radiance) > 0.1 and np.mean(radiance) == pytest.approx(2.4, abs=0.2)
    np.testing.assert_array_equal(weather_only.window_height_m(lat, lon, t), 40e3)

    height_only = RadianceEnvironment(EnvironmentParameters(climatology_enabled=False, weather_enabled=False))
    np.testing.assert_array_equal(height_only.horizon_radiance_ru(lat, lon, t), 2.4)
    assert np.std(height_only.window_height_m(lat, lon, t)) > 5e3


def test_shapes_broadcast_and_nan_propagates():
    env = RadianceEnvironment()
    scalar = env.sample(-0.5, 1.0, 0.0)
    assert np.ndim(scalar.horizon_radiance_ru) == 0 and np.ndim(scalar.window_height_m) == 0
    grid = env.sample(np.zeros((3, 4)), np.linspace(0.0, 1.0, 4), 10.0)
    assert grid.horizon_radiance_ru.shape == (3, 4) and grid.co2_height_m.shape == (3, 4)
    lat = np.array([0.1, np.nan, -0.3])
    with np.errstate(all="raise"):
        values = env.sample(lat, np.array([0.2, 0.2, np.nan]), 0.0)
    assert np.isfinite(values.horizon_radiance_ru[0]) and np.isfinite(values.window_height_m[0])
    assert np.isnan(values.horizon_radiance_ru[1:]).all() and np.isnan(values.window_height_m[1:]).all()
    assert np.isnan(values.co2_height_m[1:]).all()
    assert values.horizon_radiance_ru[0] == pytest.approx(float(env.horizon_radiance_ru(0.1, 0.2, 0.0)), abs=1e-5)


@pytest.mark.parametrize("field, value, words", [
    ("relative_variability", -0.1, "relative variability"),
    ("relative_variability", 1.5, "relative variability"),
    ("correlation_radius_m", 1e3, "correlation radius"),
    ("correlation_radius_m", float("nan"), "correlation radius"),
    ("time_scale_s", 0.0, "time scale"),
    ("n_components", 8, "spectral components"),
    ("n_components", 64.5, "spectral components"),
    ("uniform_radiance_ru", 0.0, "uniform radiance"),
    ("epoch_day_of_year", 400.0, "day of year"),
    ("synoptic_fraction", 0.99, "synoptic fraction"),
    ("synoptic_fraction", 0.8, "cannot be reached"),  # 700 km is out of reach with 80 % in the band
    ("window_height_mean_m", 200e3, "window layer height"),
    ("window_height_half_range_m", 50e3, "window layer half-range"),
    ("co2_height_m", 50e3, "top of the window layer"),
    ("co2_height_half_range_m", 2e3, "CO2 layer half-range"),
    ("height_correlation_radius_m", 1e8, "height correlation radius"),
    ("seed", -1, "seed"),
    ("weather_enabled", "yes", "weather_enabled"),
])
def test_bad_parameters_raise_naming_value_and_range(field, value, words):
    with pytest.raises(ValueError) as error:
        EnvironmentParameters(**{field: value})
    message = str(error.value)
    assert words in message
    assert "allowed range" in message or "must be" in message


def test_field_classes_validate_too():
    with pytest.raises(ValueError, match="correlation radius"):
        WeatherField(correlation_radius_m=0.0)
    with pytest.raises(ValueError, match="relative variability"):
        WeatherField(relative_variability=2.0)
    with pytest.raises(ValueError, match="half-range"):
        LayerHeightField(mean_m=40e3, half_range_m=41e3)
    with pytest.raises(ValueError, match="seed"):
        GaussianSphereField(seed=1.5)
