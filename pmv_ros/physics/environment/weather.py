"""The weather and the emitting layers' heights: the random fields of :mod:`.fields` given their meaning.

:class:`WeatherField` is the relative anomaly of the horizon radiance, a synoptic
band over a red background (physics.md §3.2 item 2); :class:`LayerHeightField` the
uniformly distributed, spatially correlated height of an emitting layer
(physics.md §3.2 item 4).
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import elementwise
from ..constants import EARTH_MEAN_RADIUS_M
from ..orbit.two_body import check_range
from ..radiance import MAX_EARTH_RADIANCE_RU, MIN_EARTH_RADIANCE_RU
from .fields import MIN_WAVELENGTH_M, GaussianSphereField, SynopticBandField, _seed_sequence

#: Half-width of the uniform window-layer height spread, m: σ_h = 10 km (physics.md §3.2 item 4) → √3·σ_h.
WINDOW_HALF_RANGE_M = math.sqrt(3.0) * 10e3

#: Floating-point type of the flight environment's fields (the weather's red background and synoptic band,
#: the layer heights). The same instant reached on two clocks (a real-time run's ≈ 1.7e9 s, a fast-time
#: run's 0) differs by rounding only (≈ 10⁻⁷ s, 10⁻¹⁰ rad of Earth rotation); in float32 such a difference
#: flips roundings of phases of up to ≈ 400 rad (100 km waves; ULP 3·10⁻⁵ rad), and the sensed angles of
#: the two runs part by ≈ 5·10⁻⁶′ (heights) and ≈ 7·10⁻⁷′ (weather at η = 0.3); in float64 by ≈ 3·10⁻⁷′
#: (physics.md §3.2 item 6 asks 10⁻⁶′). Tried and dropped: a phase reduced to ±π in float64 with a float32
#: cosine (9·10⁻⁷′), float32 offsets from float64 references every 16 points of a track (2·10⁻⁶′). The fields'
#: own SIMD cosine (:func:`~pmv_ros.physics.environment.fields._cosine`) makes float64 cost about what numpy's
#: float32 cosine did; the layer height's is the largest item of the environment's cost
#: (benchmarks/bench_environment.py --profile).
PRECISE_FIELD_DTYPE = np.float64


@elementwise
def radiance_level(mean_radiance_ru, anomaly, relative_variability):
    """B_mean·(1 + η·a), r.u., kept inside 1 … 4 r.u. or the mean if that is outside
    (:meth:`WeatherField.radiance_from_anomaly`; the sensor's kernel calls it per chord)."""
    if math.isnan(mean_radiance_ru) or math.isnan(anomaly):  # (no ordered comparison with NaN: it would signal)
        return math.nan
    low = min(MIN_EARTH_RADIANCE_RU, mean_radiance_ru)
    high = max(MAX_EARTH_RADIANCE_RU, mean_radiance_ru)
    radiance = mean_radiance_ru * (1.0 + relative_variability * anomaly)
    if radiance < low:
        return low
    if radiance > high:
        return high
    return radiance


@elementwise
def uniform_height(gaussian, mean_m, half_range_m):
    """mean + half_range·(2Φ(g) − 1), m: a standard-normal value g mapped to the uniform law
    (:meth:`LayerHeightField.height_from_gaussian`; the sensor's kernel calls it per chord)."""
    return mean_m + half_range_m * (2.0 * (0.5 * math.erfc(-gaussian / math.sqrt(2.0))) - 1.0)


def synoptic_degrees(zone_length_m: float, relative_half_width: float = 0.25) -> tuple[int, int]:
    """The band of degrees ℓ for zones of a given length along the track, m: ℓ₀ = 2πR/λ, ℓ₀·(1 ± half-width).

    2000 km zones give ℓ₀ = 20 and the band 15 … 25 — the k = 15 … 25 of the
    Meteor-M harmonic analysis (physics.md §5.1), the track being a great circle.
    """
    check_range("synoptic zone length", zone_length_m / 1e3, 500.0, 10000.0, " km")
    centre = 2.0 * math.pi * EARTH_MEAN_RADIUS_M / zone_length_m
    return max(2, int(round(centre * (1.0 - relative_half_width)))), int(round(centre * (1.0 + relative_half_width)))


def background_radius_m(correlation_radius_m: float, synoptic_fraction: float, degrees: tuple[int, int]) -> float:
    """R_b of the red background that makes the whole weather correlation e⁻¹ at ``correlation_radius_m``.

    The weather correlation is w·ρ_band(ψ) + (1 − w)·exp(−c/R_b) (c the
    chordal distance, ψ the great-circle angle); physics.md §3.1 defines the
    correlation radius R_x by r(R_x) = e⁻¹ (the paper's sense). Given R_x and
    the synoptic share w this fixes R_b. ValueError when no R_b ≤ R_E can do it
    (the band alone already decorrelates too much or too little at R_x).
    """
    w = float(synoptic_fraction)
    psi = correlation_radius_m / EARTH_MEAN_RADIUS_M
    chordal = 2.0 * EARTH_MEAN_RADIUS_M * math.sin(0.5 * psi)
    if w == 0.0:
        return float(chordal)
    from scipy.special import eval_legendre  # imported where used, as in fields.py

    band = float(np.mean([eval_legendre(ell, math.cos(psi)) for ell in range(degrees[0], degrees[1] + 1)]))
    target = (math.exp(-1.0) - w * band) / (1.0 - w) if w < 1.0 else -1.0
    radius = -chordal / math.log(target) if 0.0 < target < 1.0 else math.inf
    if not radius <= EARTH_MEAN_RADIUS_M:
        raise ValueError(f"a weather correlation radius of {correlation_radius_m / 1e3:g} km cannot be reached with "
                         f"{100 * w:g} % of the variance in degrees {degrees[0]} … {degrees[1]}: "
                         "the synoptic fraction must "
                         "be lower")
    return float(radius)


class WeatherField:
    """Correlated random weather: relative anomalies of horizon radiance around the climatology.

    B = B_clim·(1 + η·a), kept inside 1 … 4 r.u. (:meth:`radiance_from_anomaly`),
    where a (zero mean, σ = 1) is the sum of two independent fields:

        a = √w·s + √(1 − w)·g,

    s a :class:`SynopticBandField` (degrees ℓ for zones of ``synoptic_zone_m``
    along the track, 15 … 25 for 2000 km) and g a red background
    :class:`GaussianSphereField` with exponential correlation exp(−c/R_b).
    The covariance of a is therefore

        C(ψ) = w·(1/n) Σ_ℓ P_ℓ(cos ψ) + (1 − w)·exp(−2R sin(ψ/2)/R_b),

    and R_b is chosen (:func:`background_radius_m`) so that C = e⁻¹ at the
    correlation radius R_x, physics.md §3.1's definition. Why this form
    (physics.md §3.2 item 2): the flight record of Meteor-M No.2-2 shows zones
    of ≈ 2000 km along the track, a hump at k = 15 … 25 that no exponential
    covariance makes; synoptic systems (fronts, cyclones) are such a band over
    a red background of larger, climatic anomalies. w = 0 is the exponential
    weather of the modelling paper (R_b = R_x).

    Defaults: η = 0.15 and R_x = 700 km (physics.md §3.1), w = 0; the presets
    fly the calibrated values (tools/calibrate_environment.py). τ = 1 day is
    our assumption: synoptic patterns renew within about a day; over one orbit
    the pattern a chord sweeps changes mostly because the spacecraft and the
    Earth move.

    Args:
        relative_variability: η = σ_B / B_mean at a point, dimensionless (0 … 1).
        correlation_radius_m: R_x, e-folding distance of C, m (10 km … 6371 km).
        time_scale_s: τ, s (≥ 60 s; ``math.inf`` freezes the weather).
        n_components: cosines of the background field (16 … 8192).
        seed: an int ≥ 0 or a ``numpy.random.SeedSequence``.
        synoptic_fraction: w, the share of the variance in the synoptic band (0 … 0.95).
        synoptic_zone_m: length λ of the synoptic zones along the track, m (500 … 10000 km).
        synoptic_components: sectoral components of the band field (16 … 8192).
        min_wavelength_m: shortest wavelength of the background, m (see :class:`GaussianSphereField`).
        time_origin_s: the fields' own time at t = 0, s (see :class:`GaussianSphereField`).
    """

    def __init__(self, relative_variability: float = 0.15, correlation_radius_m: float = 700e3,
                 time_scale_s: float = 86400.0, n_components: int = 256, seed=0,
                 synoptic_fraction: float = 0.0, synoptic_zone_m: float = 2000e3,
                 synoptic_components: int = 128, min_wavelength_m: float = MIN_WAVELENGTH_M,
                 time_origin_s: float = 0.0) -> None:
        self.relative_variability = check_range("relative variability η′", relative_variability, 0.0, 1.0)
        self.synoptic_fraction = check_range("synoptic fraction", synoptic_fraction, 0.0, 0.95)
        self.degrees = synoptic_degrees(synoptic_zone_m)
        check_range("correlation radius", correlation_radius_m / 1e3, 10.0, EARTH_MEAN_RADIUS_M / 1e3, " km")
        self._correlation_radius_m = float(correlation_radius_m)
        background_seed, band_seed = _seed_sequence(seed).spawn(2)
        self.background_radius_m = background_radius_m(correlation_radius_m, self.synoptic_fraction, self.degrees)
        self.anomaly_field = GaussianSphereField(max(self.background_radius_m, 10e3), time_scale_s, n_components,
                                                 background_seed, min_wavelength_m, time_origin_s,
                                                 PRECISE_FIELD_DTYPE)
        self.band_field = SynopticBandField(*self.degrees, time_scale_s, synoptic_components, band_seed,
                                            time_origin_s, PRECISE_FIELD_DTYPE) \
            if self.synoptic_fraction > 0.0 else None
        self._weights = (math.sqrt(1.0 - self.synoptic_fraction), math.sqrt(self.synoptic_fraction))

    @property
    def correlation_radius_m(self) -> float:
        """e-folding distance R_x of the whole weather correlation, m."""
        return self._correlation_radius_m

    @property
    def time_scale_s(self) -> float:
        """e-folding correlation time τ, s."""
        return self.anomaly_field.time_scale_s

    def correlation(self, angle_rad):
        """Ensemble correlation C(ψ) of the anomaly at great-circle angle ψ, rad (see the class docstring)."""
        psi = np.asarray(angle_rad, float)
        chordal = 2.0 * EARTH_MEAN_RADIUS_M * np.sin(0.5 * psi)
        out = (1.0 - self.synoptic_fraction) * np.exp(-chordal / self.background_radius_m)
        if self.band_field is not None:
            out = out + self.synoptic_fraction * self.band_field.correlation(psi)
        return out

    def combine(self, background, band):
        """The anomaly a from the background field's and the band field's values (band may be None)."""
        a = self._weights[0] * np.asarray(background, float)
        return a if band is None else a + self._weights[1] * np.asarray(band, float)

    def relative_anomaly(self, lat_rad, lon_rad, t_s):
        """Standardised weather anomaly a (zero mean, σ = 1, dimensionless) at points and times.

        Args:
            lat_rad: geocentric latitude, rad (Earth-fixed).
            lon_rad: longitude, rad (Earth-fixed).
            t_s: simulation time, s.
        """
        band = None if self.band_field is None else self.band_field(lat_rad, lon_rad, t_s)
        return self.combine(self.anomaly_field(lat_rad, lon_rad, t_s), band)

    def radiance_ru(self, mean_radiance_ru, lat_rad, lon_rad, t_s):
        """Horizon radiance with weather, B_mean·(1 + η·a) kept inside 1 … 4 r.u.

        Args:
            mean_radiance_ru: the radiance without weather (climatology), r.u.,
                broadcast against the points.
            lat_rad: geocentric latitude, rad (Earth-fixed).
            lon_rad: longitude, rad (Earth-fixed).
            t_s: simulation time, s.
        """
        return self.radiance_from_anomaly(mean_radiance_ru, self.relative_anomaly(lat_rad, lon_rad, t_s))

    def radiance_from_anomaly(self, mean_radiance_ru, anomaly):
        """B_mean·(1 + η·a), r.u., clipped to 1 … 4 r.u. (physics.md §3: L_min … L_max).

        The weather cannot make a horizon darker than the winter-Antarctic
        minimum nor brighter than the dry subtropics (physics.md §3.2 item 2:
        a dark horizon must not lose its chords to the weather factor). A mean
        already outside the range (a uniform test radiance) is not moved
        further out by the weather: the bounds widen to include it.
        """
        return radiance_level(mean_radiance_ru, anomaly, self.relative_variability)


class LayerHeightField:
    """Height of an emitting layer, uniformly distributed on mean ± half-range, spatially correlated.

    h = mean + half_range·(2Φ(g) − 1), where g is a :class:`GaussianSphereField`
    and Φ the standard normal CDF, so h is uniform on [mean − half_range,
    mean + half_range] (σ = half_range/√3). For the window layer physics.md §3.2
    item 4 gives σ_h = 10 km, half-width 17.3 km.

    Mapping through Φ changes the correlation: for Gaussian correlation ρ the
    uniform field has correlation (6/π)·asin(ρ/2) (Pearson 1907; Spearman's ρ
    of a bivariate normal), i.e. 0.353 instead of e⁻¹ = 0.368 at d = R_x —
    below exp(−d/R_x) by at most 4.5 % of its value.

    Args:
        mean_m: mean height, m (5 … 150 km).
        half_range_m: half-width of the uniform distribution, m (0 … mean).
        correlation_radius_m: e-folding radius of the underlying Gaussian field, m.
        time_scale_s: e-folding time, s (``math.inf`` freezes the layer).
        n_components: cosines in the spectral synthesis (16 … 8192).
        seed: an int ≥ 0 or a ``numpy.random.SeedSequence``.
        min_wavelength_m: shortest wavelength, m (see :class:`GaussianSphereField`).
        time_origin_s: the field's own time at t = 0, s (see :class:`GaussianSphereField`).
    """

    def __init__(self, mean_m: float = 40e3, half_range_m: float = WINDOW_HALF_RANGE_M,
                 correlation_radius_m: float = 700e3,
                 time_scale_s: float = 86400.0, n_components: int = 256, seed=1,
                 min_wavelength_m: float = MIN_WAVELENGTH_M, time_origin_s: float = 0.0) -> None:
        self.mean_m = check_range("layer height", mean_m / 1e3, 5.0, 150.0, " km") * 1e3
        self.half_range_m = check_range("layer height half-range", half_range_m / 1e3, 0.0,
                                        self.mean_m / 1e3, " km") * 1e3
        self.gaussian_field = GaussianSphereField(correlation_radius_m, time_scale_s, n_components, seed,
                                                  min_wavelength_m, time_origin_s, PRECISE_FIELD_DTYPE)

    def height_m(self, lat_rad, lon_rad, t_s):
        """Layer height above the surface at points and times, m.

        Args:
            lat_rad: geocentric latitude, rad (Earth-fixed).
            lon_rad: longitude, rad (Earth-fixed).
            t_s: simulation time, s.
        """
        return self.height_from_gaussian(self.gaussian_field(lat_rad, lon_rad, t_s))

    def height_from_gaussian(self, gaussian):
        """Height, m, from the standard-normal field value (dimensionless) through Φ to uniform."""
        return uniform_height(gaussian, self.mean_m, self.half_range_m)
