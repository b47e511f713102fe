"""The radiance environment of the horizon: climatology, weather and layer heights.

What a chord sees behind its horizon depends on where on the rotating Earth the
tangent point lies and when. This module gives, at any Earth-fixed point and
time, the three quantities the horizon profile of physics.md §3 needs:

* the horizon radiance B_m, r.u. — a zonal latitude/season climatology
  (:func:`horizon_radiance_climatology`) times ``1 + η·a``, kept inside
  1 … 4 r.u., where ``a`` is a correlated random weather anomaly
  (:class:`WeatherField`): a synoptic band of zones (:class:`SynopticBandField`,
  the hump of the Meteor-M No.2-2 record) over a red exponential background,
  the covariance documented there (physics.md §3.2);
* the height h_w of the window-emitting layer, uniformly distributed with
  σ_h = 10 km about 40 km (half-width 17.3 km) and spatially correlated, by
  default like the weather, in flight on mesoscales
  (:class:`LayerHeightField`);
* the height of the CO₂ layer, ≈ 60 km, fixed unless a small spread is asked for.

:class:`RadianceEnvironment` assembles them from :class:`EnvironmentParameters`.
Together they make the latitude/season, weather and height errors of
physics.md §3.1 (models B, C, D) come out of one model, as in flight.

Coordinates: ``lat_rad``/``lon_rad`` are geocentric latitude and longitude in
the Earth-fixed frame, rad; points are placed on a sphere of the mean radius
(the geodetic/geocentric difference, ≤ 0.19° ≈ 21 km, is far below the
correlation radius). ``t_s`` is the simulation clock, s. All functions accept
scalars or arrays that broadcast together and return the broadcast shape.
NaN inputs give NaN outputs (nothing raises in array code).

The random fields are evaluated directly at the points asked for — a sum of
cosines of random wave vectors (spectral synthesis, "random Fourier features":
Shinozuka & Deodatis 1991; Rahimi & Recht 2007), or of sectoral spherical
harmonics about random axes for the synoptic band — so nothing is stored on a
global grid. The flight presets' values come from tools/calibrate_environment.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import legendre
from scipy.special import eval_legendre, gammaln, ndtr, ndtri

from .constants import EARTH_MEAN_RADIUS_M, SECONDS_PER_DAY
from .orbit import check_range
from .radiance import CO2_TOP_HEIGHT_M, MAX_EARTH_RADIANCE_RU, MIN_EARTH_RADIANCE_RU

#: Half-width of the uniform window-layer height spread, m: σ_h = 10 km (physics.md §3.2 item 4) → √3·σ_h.
WINDOW_HALF_RANGE_M = math.sqrt(3.0) * 10e3

# --------------------------------------------------------------------------
# 1. Climatology
# --------------------------------------------------------------------------

#: Length of the climatological year, days.
YEAR_DAYS = 365.25

#: Day of year of the northern-summer extreme of the seasonal cycle (≈ 15 July).
#: Assumption: tropospheric temperature lags the solstice by 3–4 weeks. The
#: southern-summer extreme falls half a year earlier, on day ≈ 13 — the
#: "southern summer" of the physics.md §3.1 example (day ≈ 15).
SEASON_PEAK_DAY = 196.0

#: Latitude, deg; radiance in mid-January (southern summer) and mid-July
#: (northern summer), r.u. The smooth climatology is fitted to these rows.
#:
#: Anchors (physics.md §3.1, model B — the largest real gradient, southern
#: summer, sub-satellite point 45° S at 500 km; the horizon points in the
#: meridian plane are 22.0° of arc either side): January 1.6 r.u. at 67° S,
#: 2.6 under the spacecraft at 45° S and 3.5 at 23° S.
#:
#: Everything else is our assumption, shaped after the 6–20 µm numbers of
#: physics.md §3 (≈ 1 r.u. over Antarctica in its winter, ≈ 4 r.u. over the dry
#: subtropics in summer, global mean ≈ 2.4 r.u.) and after the familiar
#: pattern of outgoing long-wave radiation: bright dry subtropics, a darker
#: cloudy band at the equator, a larger seasonal swing over the land-rich
#: northern hemisphere, a colder Antarctic than Arctic. A black body at 224 K
#: gives 1 r.u. in 6–20 µm and one at 299 K gives 4 r.u. (our Planck
#: integration), a sanity check on the range.
CLIMATOLOGY_TABLE = np.array([
    # lat_deg, January_ru, July_ru
    [-90.0, 1.30, 1.00],
    [-78.0, 1.38, 1.00],
    [-67.0, 1.60, 1.05],  # anchor (January)
    [-55.0, 2.05, 1.35],
    [-45.0, 2.60, 1.75],  # anchor (January)
    [-35.0, 3.10, 2.35],
    [-23.0, 3.50, 2.75],  # anchor (January)
    [-12.0, 2.80, 2.50],
    [0.0, 2.20, 2.20],
    [12.0, 2.40, 2.70],
    [23.0, 2.75, 3.80],
    [30.0, 2.55, 4.05],
    [40.0, 2.00, 3.45],
    [50.0, 1.60, 2.75],
    [60.0, 1.30, 2.35],
    [75.0, 1.10, 2.05],
    [90.0, 1.05, 1.95],
])
_ANCHOR_ROWS = (2, 4, 6)
#: The anchors weigh this much more than the assumed rows in the fit.
_ANCHOR_WEIGHT = 5.0
#: Degree of the Legendre series in sin(latitude).
CLIMATOLOGY_DEGREE = 10


def _fit_climatology():
    """Legendre coefficients (in sin lat) of the annual mean and of the seasonal amplitude, r.u.

    A series in sin(latitude) is a smooth function on the sphere (it depends on
    the polar coordinate z only, so it has no cusp at the poles). The fit
    smooths the table; it meets the anchors within 0.01 r.u. and stays within
    0.98 … 4.0 r.u. for every latitude and day (tests/physics/test_environment.py).
    """
    x = np.sin(np.radians(CLIMATOLOGY_TABLE[:, 0]))
    january, july = CLIMATOLOGY_TABLE[:, 1], CLIMATOLOGY_TABLE[:, 2]
    weights = np.ones_like(x)
    weights[list(_ANCHOR_ROWS)] = _ANCHOR_WEIGHT
    annual = legendre.legfit(x, 0.5 * (july + january), CLIMATOLOGY_DEGREE, w=weights)
    seasonal = legendre.legfit(x, 0.5 * (july - january), CLIMATOLOGY_DEGREE, w=weights)
    return annual, seasonal


_ANNUAL_COEFFS, _SEASONAL_COEFFS = _fit_climatology()
#: The same two series in powers of sin(lat), columns (annual, seasonal), for
#: one cheap evaluation (coefficients ≤ 10², so rounding stays ≈ 10⁻¹² r.u.).
_POWER_COEFFS = np.stack([legendre.leg2poly(_ANNUAL_COEFFS), legendre.leg2poly(_SEASONAL_COEFFS)], axis=1)


def horizon_radiance_climatology(lat_rad, day_of_year):
    """Climatological horizon radiance B_m at a latitude and day of year, r.u.

    B(φ, d) = A(sin φ) + S(sin φ)·cos(2π(d − 196)/365.25): an annual mean A
    and a seasonal amplitude S, each a degree-10 Legendre series in sin φ
    fitted to :data:`CLIMATOLOGY_TABLE` (anchors from physics.md §3.1, the rest
    assumed — see the table). Zonal: no longitude dependence (land/sea
    contrast is left to the weather field). Its global, annual mean is
    A's constant term, ≈ 2.46 r.u. (physics.md §3: ≈ 2.4).

    Args:
        lat_rad: geocentric latitude, rad (array-like).
        day_of_year: day of the year, days (1.0 = 1 January 00:00; fractional,
            any real — the cycle repeats every 365.25 days).

    Returns:
        Radiance, r.u. (1 r.u. = 2.5 mW/(cm²·sr)), broadcast shape of the inputs.
    """
    lat, day = np.broadcast_arrays(np.asarray(lat_rad, float), np.asarray(day_of_year, float))
    shape = lat.shape
    # Powers 1, x, x², … of x = sin φ, then both series in one product.
    x = np.sin(lat.ravel())
    powers = np.empty((_POWER_COEFFS.shape[0], x.size))
    powers[0] = 1.0
    for k in range(1, powers.shape[0]):
        np.multiply(powers[k - 1], x, out=powers[k])
    annual, seasonal = _POWER_COEFFS.T @ powers
    season = np.cos((2.0 * math.pi / YEAR_DAYS) * (day.ravel() - SEASON_PEAK_DAY))
    out = (annual + season * seasonal).reshape(shape)
    return out[()] if out.ndim == 0 else out


# --------------------------------------------------------------------------
# 2. Correlated random fields on the sphere
# --------------------------------------------------------------------------

#: Shortest wavelength kept in the spectral synthesis, m. The exponential
#: covariance has power at all scales; the few components drawn beyond this
#: (≈ 1 in 30 fields has one at 700 km) are clipped to it. The sensor's IFOV
#: spans tens of km at the horizon, and the clip changes the covariance only
#: within a few km of zero lag. It also keeps every phase below ≈ 4·10⁴ rad,
#: where float32 arithmetic is still good to ≈ 3·10⁻³ rad.
MIN_WAVELENGTH_M = 1000.0

#: Shortest wavelength of the flight environment's fields, m: the sensor's IFOV is 2γ = 2.2° wide across
#: its chord, ≈ 100 km of limb at the slant range of 500 km (≈ 130 km at 835 km), so structure finer than
#: this reaches the comparators averaged out. Components drawn beyond it are clipped to it (the variance,
#: e.g. σ_h = 10 km, is kept); it also bounds how fast a field can change along a chord's track, which lets
#: the sensor evaluate it on a coarse grid (pmv_ros/physics/sensor.py).
IFOV_MIN_WAVELENGTH_M = 100e3
#: Shortest wavelength of the flight weather, m: the weather is a horizon level per chord (physics.md §3.2
#: item 3), the level of the ≈ 1000 km of ground the comparators weigh, so finer weather would not act as
#: one. The synoptic band (zones ≥ 1600 km) is far above it; ≈ 10 % of the red background's variance is
#: moved up to it at R_b ≈ 1000 km.
WEATHER_MIN_WAVELENGTH_M = 300e3

#: Floating-point type of the flight environment's Gaussian fields (the weather's red background and the
#: layer heights; the synoptic band stays float32). The same instant reached on two clocks (a real-time
#: run's ≈ 1.7e9 s, a fast-time run's 0) differs by rounding only (≈ 10⁻⁷ s, 10⁻¹⁰ rad of Earth rotation);
#: in float32 such a difference flips roundings of phases of up to ≈ 400 rad (100 km waves; ULP 3·10⁻⁵
#: rad), and the sensed angles of the two runs part by ≈ 5·10⁻⁶′ (heights) and ≈ 7·10⁻⁷′ (weather at
#: η = 0.3); in float64 by ≈ 3·10⁻⁷′ (issue 22 asks 10⁻⁶′). Tried and dropped: a phase reduced to ±π in
#: float64 with a float32 cosine (9·10⁻⁷′), float32 offsets from float64 references every 16 points of a
#: track (2·10⁻⁶′). float64 costs ≈ 3× float32 and is most of the environment's cost in
#: benchmarks/bench_chain.py.
PRECISE_FIELD_DTYPE = np.float64

#: Elements of the (points × components) work array evaluated at a
#: time: ≈ 2 MB, so it stays in cache.
_BLOCK_ELEMENTS = 1 << 19


def _exponential_wavenumbers(probabilities):
    """Dimensionless wave numbers u = k·R_x at given CDF values of the 3-D exponential spectrum.

    The 3-D spectral density of the covariance exp(−r/R_x) is
    S(k) = R_x³ / (π² (1 + k²R_x²)²) (Fourier pair of the exponential in 3-D),
    so |k| has density (4/π) u²/(1 + u²)² in u = k·R_x and CDF
    F(u) = (2/π)(atan u − u/(1 + u²)). With u = tan(ψ/2) this is
    F = (ψ − sin ψ)/π, solved for ψ ∈ [0, π) by bisection (monotone).
    """
    target = math.pi * np.asarray(probabilities, float)
    low = np.zeros_like(target)
    high = np.full_like(target, math.pi)
    for _ in range(60):  # 2⁻⁶⁰·π: exact to double precision
        mid = 0.5 * (low + high)
        below = mid - np.sin(mid) < target
        low = np.where(below, mid, low)
        high = np.where(below, high, mid)
    return np.tan(0.25 * (low + high))


def _reference_phases(phase_rad: np.ndarray, frequency_rad_s: np.ndarray, t: np.ndarray):
    """A reference time of the batch ``t`` (s: its first finite time) and the components' phases there (float64).

    Phases are formed at the reference in float64 and reduced mod 2π, so a float32
    evaluation only ever sees times within the batch.
    """
    finite_t = t[np.isfinite(t)]
    t_ref = float(finite_t[0]) if finite_t.size else 0.0
    return t_ref, np.mod(phase_rad + frequency_rad_s * t_ref, 2.0 * math.pi)


def _phases_at_origin(phase_rad, frequency_rad_s, time_origin_s: float):
    """Phases (rad, in [0, 2π)) that make a field's clock read ``time_origin_s`` at t = 0: b + ω·t₀ mod 2π.

    Formed once in float64 (ω·t₀ ≲ 10⁵ rad for t₀ of decades, so the phase keeps ≈ 10⁻¹¹ rad).
    """
    t0 = check_range("time origin", time_origin_s, -1e10, 1e10, " s")
    if t0 == 0.0:
        return np.asarray(phase_rad, float)
    return np.mod(np.asarray(phase_rad, float) + np.asarray(frequency_rad_s, float) * t0, 2.0 * math.pi)


class GaussianSphereField:
    """A zero-mean, unit-variance random field on the rotating Earth, evaluated pointwise.

    Covariance between (x₁, t₁) and (x₂, t₂):
    exp(−|x₁ − x₂|/R_x) · exp(−((t₁ − t₂)/τ)²), with |x₁ − x₂| the chordal
    distance between the points on the sphere of the mean Earth radius (it
    equals the great-circle distance d to a relative 1 − d²/(24 R²): 0.05 % at
    700 km). Both R_x and τ are e-folding scales: correlation e⁻¹ at a
    separation R_x, or at a lag τ.

    Construction (spectral synthesis): f = √(2/M) Σⱼ cos(kⱼ·x + ωⱼ t + bⱼ).
    The wave vectors kⱼ are drawn from the 3-D spectral density of the
    exponential covariance (:func:`_exponential_wavenumbers`; isotropic
    directions, magnitudes stratified over the M quantiles to cut the sampling
    noise), the frequencies ωⱼ from N(0, 2/τ²) (also stratified; the Fourier
    pair of exp(−(Δt/τ)²)), and the phases bⱼ uniformly. The ensemble
    covariance is then the one above (except within a few km of zero lag, see
    :data:`MIN_WAVELENGTH_M`). One snapshot of the Earth is a small sample of
    it — about 2(R_E/R_x)² ≈ 170 independent patches at 700 km — so the
    variance and correlation measured over one snapshot scatter by ≈ 3 %
    between seeds; over independent epochs they converge. Each component's
    phase drifts in time, so the pattern evolves in place without a fast time
    scale. The marginal is a sum of M equal-amplitude cosines — Gaussian to
    within an excess kurtosis of −1.5/M.

    Evaluation is cos of an (N × M) float32 array: ≈ 1 ns per point and
    component (benchmarks/bench_environment.py); ≈ 3× that in float64.

    Args:
        correlation_radius_m: e-folding distance R_x, m (10 km … 6371 km).
        time_scale_s: e-folding time τ, s (≥ 60 s; ``math.inf`` freezes the field).
        n_components: number of cosines M (16 … 8192).
        seed: an int ≥ 0 or a ``numpy.random.SeedSequence``; the same seed
            gives the same field.
        min_wavelength_m: components of shorter wavelength are clipped to it, m
            (0.1 … 1000 km; :data:`MIN_WAVELENGTH_M` by default).
        time_origin_s: the field's own time at t = 0, s (|t₀| ≤ 10¹⁰ s): the field at (x, t) is the
            one of t₀ = 0 at (x, t₀ + t). The flight environment puts UTC here (seconds since J2000 at
            the simulation clock's zero), so the field is a function of absolute time (physics.md §3.2 item 6).
        dtype: float type of the evaluation (float32, fast; float64 where a 10⁻⁷ relative change of the
            inputs must not show, see :data:`PRECISE_FIELD_DTYPE`).
    """

    def __init__(self, correlation_radius_m: float = 700e3, time_scale_s: float = 86400.0,
                 n_components: int = 256, seed=0, min_wavelength_m: float = MIN_WAVELENGTH_M,
                 time_origin_s: float = 0.0, dtype=np.float32) -> None:
        self.correlation_radius_m = check_range(
            "correlation radius", correlation_radius_m / 1e3, 10.0, EARTH_MEAN_RADIUS_M / 1e3, " km") * 1e3
        self.time_scale_s = check_range("time scale", time_scale_s, 60.0, math.inf, " s")
        self.n_components = _check_count("number of spectral components", n_components, 16, 8192)
        rng = np.random.default_rng(_seed_sequence(seed))
        m = self.n_components

        # Isotropic directions.
        cos_polar = rng.uniform(-1.0, 1.0, m)
        azimuth = rng.uniform(0.0, 2.0 * math.pi, m)
        sin_polar = np.sqrt(1.0 - cos_polar**2)
        directions = np.array([sin_polar * np.cos(azimuth), sin_polar * np.sin(azimuth), cos_polar])
        # Magnitudes, one per quantile stratum of the radial spectrum.
        strata = (np.arange(m) + rng.uniform(0.0, 1.0, m)) / m
        wavenumber_rad_m = _exponential_wavenumbers(strata) / self.correlation_radius_m
        self.min_wavelength_m = check_range("shortest wavelength", min_wavelength_m / 1e3, 0.1, 1000.0, " km") * 1e3
        wavenumber_rad_m = np.minimum(wavenumber_rad_m, 2.0 * math.pi / self.min_wavelength_m)
        # Applied to unit position vectors: phase = (k·R_E)·n̂.
        wave_vectors = directions * (wavenumber_rad_m * EARTH_MEAN_RADIUS_M)
        # Frequencies, stratified over the Gaussian quantiles, shuffled so they
        # are not ordered with the wave numbers.
        if math.isinf(self.time_scale_s):
            frequency_rad_s = np.zeros(m)
        else:
            quantiles = (rng.permutation(m) + rng.uniform(0.0, 1.0, m)) / m
            frequency_rad_s = (math.sqrt(2.0) / self.time_scale_s) * ndtri(quantiles)
        phase_rad = _phases_at_origin(rng.uniform(0.0, 2.0 * math.pi, m), frequency_rad_s, time_origin_s)
        self.dtype = np.dtype(dtype)
        self._bank = _SpectralBank([(wave_vectors, frequency_rad_s, phase_rad)], self.dtype)

    def __call__(self, lat_rad, lon_rad, t_s):
        """Field value (dimensionless, zero mean, unit variance) at points and times.

        Args:
            lat_rad: geocentric latitude, rad (Earth-fixed).
            lon_rad: longitude, rad (Earth-fixed).
            t_s: simulation time, s.

        Returns:
            The field, broadcast shape of the inputs (NaN where an input is NaN).
        """
        lat, lon, t, shape = _flat_points(lat_rad, lon_rad, t_s)
        return _shaped(self._bank.evaluate(lat, lon, t)[:, 0], shape)

    @property
    def components(self):
        """The synthesis: wave vectors k·R_E ``(3, M)``, rad; frequencies ``(M,)``, rad/s; phases ``(M,)``, rad."""
        return self._bank.components[0]


class _SpectralBank:
    """Several independent spectral fields stacked so one cosine pass evaluates them all.

    Args:
        fields: list of (wave vectors k·R_E ``(3, M)``, frequencies ``(M,)``
            rad/s, phases ``(M,)`` rad), one tuple per field.
    """

    def __init__(self, fields, dtype=np.float32) -> None:
        self.components = list(fields)
        self.dtype = np.dtype(dtype)
        wave_vectors = np.hstack([f[0] for f in fields])
        self._frequency_rad_s = np.concatenate([f[1] for f in fields])
        self._phase_rad = np.concatenate([f[2] for f in fields])
        # Rows: the three direction cosines of the point and the time since the
        # batch's reference time; float32 for the fast cosine (see MIN_WAVELENGTH_M).
        self._design_weights = np.vstack([wave_vectors, self._frequency_rad_s]).astype(self.dtype)
        # Block-diagonal amplitudes √(2/M): column i sums field i's cosines.
        self._amplitudes = np.zeros((self._phase_rad.size, len(fields)), dtype=self.dtype)
        start = 0
        for column, field in enumerate(fields):
            m = field[2].size
            self._amplitudes[start:start + m, column] = math.sqrt(2.0 / m)
            start += m

    def evaluate(self, lat, lon, t):
        """All fields at flat arrays of latitude, longitude (rad) and time (s); ``(N, n_fields)``."""
        out = np.empty((lat.size, self._amplitudes.shape[1]))
        if lat.size == 0:
            return out
        t_ref, phase_ref = _reference_phases(self._phase_rad, self._frequency_rad_s, t)
        cos_lat = np.cos(lat)
        phase_ref = phase_ref.astype(self.dtype)
        design = np.empty((lat.size, 4), dtype=self.dtype)
        design[:, 0] = cos_lat * np.cos(lon)
        design[:, 1] = cos_lat * np.sin(lon)
        design[:, 2] = np.sin(lat)
        design[:, 3] = t - t_ref
        block_points = max(64, _BLOCK_ELEMENTS // self._phase_rad.size)
        work = np.empty((min(block_points, lat.size), self._phase_rad.size), dtype=self.dtype)
        for start in range(0, lat.size, block_points):
            stop = min(start + block_points, lat.size)
            block = work[: stop - start]
            np.matmul(design[start:stop], self._design_weights, out=block)
            block += phase_ref
            np.cos(block, out=block)
            out[start:stop] = block @ self._amplitudes
        return out


class SynopticBandField:
    """A zero-mean, unit-variance random field whose variance sits at synoptic scales: a band of degrees ℓ.

    Its angular power spectrum is flat over the spherical-harmonic degrees
    ℓ_lo … ℓ_hi and zero elsewhere, so its covariance at great-circle angle ψ is

        ρ(ψ) = (1/n) Σ_{ℓ = ℓ_lo … ℓ_hi} P_ℓ(cos ψ)     (:meth:`correlation`),

    a "hole-effect" covariance (it dips negative at about half a zone) whose
    spectrum along any great circle — a ground track — rises towards the band
    and stops above it: an isotropic degree-ℓ field sampled along a great
    circle has its power at orders m ≤ ℓ with density ≈ 1/√(ℓ² − m²), largest
    just below m = ℓ (for degrees 15 … 25, ≈ 1.6× more power per order at
    m = 15 … 25 than at m = 1 … 9; tests/physics/test_environment.py). A
    zone of length λ along a track is degree ℓ ≈ 2πR/λ (2000 km → ℓ ≈ 20).
    An isotropic covariance in 3-D (like :class:`GaussianSphereField`'s)
    cannot do this: its spectrum along a line is flat or falling up to any
    cut-off — "red", as physics.md §3.2 item 2 says.

    Construction: f(x, t) = Σⱼ aⱼ·Re[(x·wⱼ)^ℓⱼ · e^{i(ωⱼt + bⱼ)}] over M
    components, with wⱼ = e₁ⱼ + i·e₂ⱼ from a uniformly random orthonormal
    frame: (x·w)^ℓ is the sectoral harmonic Y_ℓ^ℓ about a random axis e₃ (a
    polynomial in x, smooth everywhere), so the sum is isotropic and stays in
    the degree-ℓ harmonics. Degrees are shared equally over the band,
    frequencies ωⱼ ~ N(0, 2/τ²) as in :class:`GaussianSphereField`, phases bⱼ
    uniform; aⱼ = √(2/(M·E_ℓ)) with E_ℓ = E[sin^{2ℓ}θ] = √π·ℓ!/(2Γ(ℓ + 3/2))
    gives unit variance.

    Args:
        degree_low: ℓ_lo (2 … 200).
        degree_high: ℓ_hi (ℓ_lo … 200).
        time_scale_s: e-folding time τ, s (≥ 60 s; ``math.inf`` freezes the field).
        n_components: number of sectoral components M (16 … 8192).
        seed: an int ≥ 0 or a ``numpy.random.SeedSequence``.
        time_origin_s: the field's own time at t = 0, s (see :class:`GaussianSphereField`).
    """

    def __init__(self, degree_low: int = 15, degree_high: int = 25, time_scale_s: float = 86400.0,
                 n_components: int = 128, seed=0, time_origin_s: float = 0.0) -> None:
        self.degree_low = _check_count("lowest synoptic degree", degree_low, 2, 200)
        self.degree_high = _check_count("highest synoptic degree", degree_high, self.degree_low, 200)
        self.time_scale_s = check_range("time scale", time_scale_s, 60.0, math.inf, " s")
        self.n_components = _check_count("number of spectral components", n_components, 16, 8192)
        rng = np.random.default_rng(_seed_sequence(seed))
        m = self.n_components
        # Random orthonormal frames: QR of Gaussian matrices, signs fixed so the law is Haar.
        gaussian = rng.standard_normal((m, 3, 3))
        q, r = np.linalg.qr(gaussian)
        q = q * np.sign(np.diagonal(r, axis1=1, axis2=2))[:, None, :]
        # (3, 2M): e₁ of every component, then e₂.
        self._frame = np.hstack([q[:, :, 0].T, q[:, :, 1].T]).astype(np.float32)
        band = np.arange(self.degree_low, self.degree_high + 1)
        self.degrees = band[rng.permutation(np.arange(m) % band.size)].astype(np.float32)
        mean_power = np.exp(0.5 * math.log(math.pi) + gammaln(self.degrees + 1.0)
                            - gammaln(self.degrees + 1.5) - math.log(2.0))
        self._amplitude = np.sqrt(2.0 / (m * mean_power)).astype(np.float32)
        if math.isinf(self.time_scale_s):
            self._frequency_rad_s = np.zeros(m)
        else:
            quantiles = (rng.permutation(m) + rng.uniform(0.0, 1.0, m)) / m
            self._frequency_rad_s = (math.sqrt(2.0) / self.time_scale_s) * ndtri(quantiles)
        self._phase_rad = _phases_at_origin(rng.uniform(0.0, 2.0 * math.pi, m), self._frequency_rad_s,
                                            time_origin_s)

    def correlation(self, angle_rad):
        """Ensemble correlation at great-circle angle ψ (rad): the band mean of P_ℓ(cos ψ)."""
        c = np.cos(np.asarray(angle_rad, float))
        band = np.arange(self.degree_low, self.degree_high + 1)
        return np.mean([eval_legendre(int(ell), c) for ell in band], axis=0)

    def __call__(self, lat_rad, lon_rad, t_s):
        """Field value (dimensionless, zero mean, unit variance) at points and times (NaN-propagating)."""
        lat, lon, t, shape = _flat_points(lat_rad, lon_rad, t_s)
        return _shaped(self.evaluate(lat, lon, t), shape)

    def evaluate(self, lat, lon, t):
        """The field at flat arrays of latitude, longitude (rad) and time (s); ``(N,)``."""
        out = np.empty(lat.size)
        if lat.size == 0:
            return out
        t_ref, phase_ref = _reference_phases(self._phase_rad, self._frequency_rad_s, t)
        phase_ref = phase_ref.astype(np.float32)
        cos_lat = np.cos(lat)
        unit = np.empty((lat.size, 3), dtype=np.float32)
        unit[:, 0] = cos_lat * np.cos(lon)
        unit[:, 1] = cos_lat * np.sin(lon)
        unit[:, 2] = np.sin(lat)
        dt = (t - t_ref).astype(np.float32)[:, None]
        frequency = self._frequency_rad_s.astype(np.float32)
        m = self.n_components
        half_degrees = 0.5 * self.degrees
        block_points = max(64, (_BLOCK_ELEMENTS // 2) // m)
        for start in range(0, lat.size, block_points):
            stop = min(start + block_points, lat.size)
            z = unit[start:stop] @ self._frame  # (n, 2M): the real and imaginary parts of x·w
            real, imag = z[:, :m], z[:, m:]
            angle = np.arctan2(imag, real)
            # |z|^ℓ = (|z|²)^(ℓ/2); the argument ℓ·arg z plus the drifting phase.
            np.multiply(real, real, out=real)
            np.multiply(imag, imag, out=imag)
            np.add(real, imag, out=real)
            magnitude = np.power(real, half_degrees, out=real)
            np.multiply(angle, self.degrees, out=angle)
            angle += phase_ref
            angle += dt[start:stop] * frequency
            np.cos(angle, out=angle)
            np.multiply(angle, magnitude, out=angle)
            out[start:stop] = angle @ self._amplitude
        return out


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
    band = float(np.mean([eval_legendre(ell, math.cos(psi)) for ell in range(degrees[0], degrees[1] + 1)]))
    target = (math.exp(-1.0) - w * band) / (1.0 - w) if w < 1.0 else -1.0
    radius = -chordal / math.log(target) if 0.0 < target < 1.0 else math.inf
    if not radius <= EARTH_MEAN_RADIUS_M:
        raise ValueError(f"a weather correlation radius of {correlation_radius_m / 1e3:g} km cannot be reached with "
                         f"{100 * w:g} % of the variance in degrees {degrees[0]} … {degrees[1]}: the synoptic fraction must "
                         "be lower")
    return float(radius)


def _flat_points(lat_rad, lon_rad, t_s):
    """Broadcast latitude, longitude and time; return them flattened (float) and the broadcast shape."""
    lat, lon, t = np.broadcast_arrays(np.asarray(lat_rad, float), np.asarray(lon_rad, float),
                                      np.asarray(t_s, float))
    return lat.ravel(), lon.ravel(), t.ravel(), lat.shape


def _shaped(values, shape):
    """Flat values reshaped to ``shape``; a numpy scalar when the shape is ()."""
    out = np.asarray(values).reshape(shape)
    return out[()] if out.ndim == 0 else out


def _seed_sequence(seed) -> np.random.SeedSequence:
    """A SeedSequence from an int ≥ 0 or a SeedSequence; ValueError otherwise."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed = {seed!r} must be an integer ≥ 0")
    return np.random.SeedSequence(int(seed))


def _check_count(name: str, value, low: int, high: int) -> int:
    """Return ``value`` as int, or raise ValueError naming it and the allowed range."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
        raise ValueError(f"{name} = {value!r} must be an integer in the allowed range {low} … {high}")
    return int(value)


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
                                            time_origin_s) \
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
        mean = np.asarray(mean_radiance_ru, float)
        low = np.minimum(MIN_EARTH_RADIANCE_RU, mean)
        high = np.maximum(MAX_EARTH_RADIANCE_RU, mean)
        return np.clip(mean * (1.0 + self.relative_variability * np.asarray(anomaly, float)), low, high)


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

    def __init__(self, mean_m: float = 40e3, half_range_m: float = WINDOW_HALF_RANGE_M, correlation_radius_m: float = 700e3,
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
        return self.mean_m + self.half_range_m * (2.0 * ndtr(gaussian) - 1.0)


# --------------------------------------------------------------------------
# 3. The assembled environment
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class EnvironmentParameters:
    """Configuration of the radiance environment (SI units; radiance in r.u.).

    Switches: ``climatology_enabled = False`` replaces the climatology by the
    uniform ``uniform_radiance_ru``; ``weather_enabled = False`` removes the
    weather anomaly; ``height_variation_enabled = False`` fixes the window
    layer at ``window_height_mean_m`` and the CO₂ layer at ``co2_height_m``.
    With all three off the environment is the uniform Earth of the
    calibration rig (model A with B(1) = B(2)).

    Fields:
        climatology_enabled: use the latitude/season climatology.
        uniform_radiance_ru: radiance when the climatology is off, r.u.
            (0.3 … 10; physics.md §3 mean 2.4).
        epoch_day_of_year: day of year at simulation time 0, days (0 … 367;
            default 15: the southern summer of the physics.md §3.1 example).
        weather_enabled: add the correlated weather anomaly.
        relative_variability: η, σ_B/B_mean at a point (0 … 1; physics.md §3.1: 0.2 at nadir,
            η′ = 0.15 after slant viewing and the IFOV at 500 km; §3.2: up to ≈ 0.3).
        correlation_radius_m: R_x, e-folding distance of the weather correlation, m
            (10 … 6371 km; 300 km theory, 700 km flight).
        synoptic_fraction: share w of the weather variance in the synoptic band (0 … 0.95;
            0 = the exponential weather of the modelling paper), see :class:`WeatherField`.
        synoptic_zone_m: length of the synoptic zones along the track, m (500 … 10000 km; 2000 km flight).
        synoptic_components: sectoral components of the band field (16 … 8192).
        min_wavelength_m: shortest wavelength of the layer-height fields, m (0.1 … 1000 km; default
            :data:`IFOV_MIN_WAVELENGTH_M`, what the IFOV resolves).
        weather_min_wavelength_m: shortest wavelength of the weather's background, m (0.1 … 1000 km;
            default :data:`WEATHER_MIN_WAVELENGTH_M`, what the line-of-sight sampling resolves).
        time_scale_s: e-folding time of weather and layer height, s
            (≥ 60 s, ``math.inf`` = frozen; default one day, an assumption).
        n_components: cosines per random field (16 … 8192).
        height_variation_enabled: let the window-layer height vary.
        window_height_mean_m: mean window-layer height, m (physics.md §3: 40 km).
        window_height_half_range_m: half-width of its uniform spread, m (√3·10 km = 17.3 km:
            σ_h = 10 km, physics.md §3.2 item 4 — 40 ± 20 km read as the ±2σ range).
        height_correlation_radius_m: e-folding radius of the (exponential) height field, m;
            ``None`` = the weather's. The flight environment uses mesoscale values
            (a few hundred km or less, physics.md §3.2 item 4); the height field is
            independent of the weather (our choice: the window-layer height is set by
            the humidity and temperature structure of the lower troposphere, which the
            6–20 µm radiance anomaly does not determine).
        co2_height_m: CO₂-layer height, m (20 … 120 km; physics.md §3: ≈ 60 km).
        co2_height_half_range_m: half-width of a uniform spread of the CO₂
            layer, m (0 … 1 km; physics.md §3: spread < 0.5 km; default 0 = fixed).
        seed: int ≥ 0; the weather, window-height and CO₂-height fields get
            independent streams spawned from it.
        field_time_origin_s: the random fields' time at simulation time 0, s (|t₀| ≤ 10¹⁰ s). The
            flight environment gives UTC, seconds since J2000.0 (2000-01-01 12:00 UTC) at the clock's
            zero, so weather and layer height are functions of position and absolute time (physics.md
            §3.2 item 6): campaign days see different weather, and a real-time and a fast-time run of
            one epoch see the same fields. 0 (the default): the fields run on the simulation clock.
    """

    climatology_enabled: bool = True
    uniform_radiance_ru: float = 2.4
    epoch_day_of_year: float = 15.0
    weather_enabled: bool = True
    relative_variability: float = 0.15
    correlation_radius_m: float = 700e3
    time_scale_s: float = SECONDS_PER_DAY
    n_components: int = 256
    synoptic_fraction: float = 0.0
    synoptic_zone_m: float = 2000e3
    synoptic_components: int = 128
    min_wavelength_m: float = IFOV_MIN_WAVELENGTH_M
    weather_min_wavelength_m: float = WEATHER_MIN_WAVELENGTH_M
    height_variation_enabled: bool = True
    window_height_mean_m: float = 40e3
    window_height_half_range_m: float = WINDOW_HALF_RANGE_M
    height_correlation_radius_m: float | None = None
    co2_height_m: float = CO2_TOP_HEIGHT_M
    co2_height_half_range_m: float = 0.0
    seed: int = 0
    field_time_origin_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("climatology_enabled", "weather_enabled", "height_variation_enabled"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise ValueError(f"{name} = {getattr(self, name)!r} must be true or false")
        check_range("uniform radiance", self.uniform_radiance_ru, 0.3, 10.0, " r.u.")
        check_range("epoch day of year", self.epoch_day_of_year, 0.0, 367.0)
        check_range("relative variability η′", self.relative_variability, 0.0, 1.0)
        check_range("correlation radius", self.correlation_radius_m / 1e3, 10.0, EARTH_MEAN_RADIUS_M / 1e3, " km")
        check_range("time scale", self.time_scale_s, 60.0, math.inf, " s")
        _check_count("number of spectral components", self.n_components, 16, 8192)
        check_range("synoptic fraction", self.synoptic_fraction, 0.0, 0.95)
        check_range("synoptic zone length", self.synoptic_zone_m / 1e3, 500.0, 10000.0, " km")
        _check_count("number of synoptic components", self.synoptic_components, 16, 8192)
        check_range("shortest wavelength", self.min_wavelength_m / 1e3, 0.1, 1000.0, " km")
        check_range("shortest weather wavelength", self.weather_min_wavelength_m / 1e3, 0.1, 1000.0, " km")
        if self.weather_enabled:
            background_radius_m(self.correlation_radius_m, self.synoptic_fraction,
                                synoptic_degrees(self.synoptic_zone_m))
        check_range("window layer height", self.window_height_mean_m / 1e3, 5.0, 150.0, " km")
        check_range("window layer half-range", self.window_height_half_range_m / 1e3, 0.0,
                    self.window_height_mean_m / 1e3, " km")
        if self.height_correlation_radius_m is not None:
            check_range("height correlation radius", self.height_correlation_radius_m / 1e3, 10.0,
                        EARTH_MEAN_RADIUS_M / 1e3, " km")
        check_range("CO2 layer height", self.co2_height_m / 1e3, 20.0, 120.0, " km")
        check_range("CO2 layer half-range", self.co2_height_half_range_m / 1e3, 0.0, 1.0, " km")
        check_range("field time origin", self.field_time_origin_s, -1e10, 1e10, " s")
        # The window layer lies under the CO₂ layer (physics.md §3 profile
        # order).
        top_of_window_km = (self.window_height_mean_m + self.window_height_half_range_m) / 1e3
        bottom_of_co2_km = (self.co2_height_m - self.co2_height_half_range_m) / 1e3
        check_range("top of the window layer", top_of_window_km, 0.0, bottom_of_co2_km, " km")
        _seed_sequence(self.seed)


@dataclass(frozen=True)
class HorizonEnvironmentSample:
    """The environment at a set of points: arrays of the points' broadcast shape.

    Fields:
        horizon_radiance_ru: radiance B_m of the lower atmosphere, r.u.
        window_height_m: height h_w of the window-emitting layer, m.
        co2_height_m: height of the CO₂ layer, m.
        mean_radiance_ru: the radiance without weather (climatology or uniform), r.u.
    """

    horizon_radiance_ru: np.ndarray
    window_height_m: np.ndarray
    co2_height_m: np.ndarray
    mean_radiance_ru: np.ndarray


class RadianceEnvironment:
    """The horizon radiance environment of physics.md §3: climatology, weather and layer heights.

    Args:
        parameters: an :class:`EnvironmentParameters` (defaults: everything on,
            η′ = 0.15, R_x = 700 km, τ = 1 day, h_w = 40 km with σ_h = 10 km, CO₂ at 60 km).
    """

    def __init__(self, parameters: EnvironmentParameters | None = None) -> None:
        p = EnvironmentParameters() if parameters is None else parameters
        self.parameters = p
        weather_seed, window_seed, co2_seed = np.random.SeedSequence(p.seed).spawn(3)
        height_radius_m = p.correlation_radius_m if p.height_correlation_radius_m is None \
            else p.height_correlation_radius_m
        self.weather = WeatherField(p.relative_variability, p.correlation_radius_m, p.time_scale_s,
                                    p.n_components, weather_seed, p.synoptic_fraction, p.synoptic_zone_m,
                                    p.synoptic_components, p.weather_min_wavelength_m, p.field_time_origin_s) \
            if p.weather_enabled else None
        self.window_layer = LayerHeightField(p.window_height_mean_m, p.window_height_half_range_m,
                                             height_radius_m, p.time_scale_s, p.n_components, window_seed,
                                             p.min_wavelength_m, p.field_time_origin_s) \
            if p.height_variation_enabled and p.window_height_half_range_m > 0.0 else None
        self.co2_layer = LayerHeightField(p.co2_height_m, p.co2_height_half_range_m, height_radius_m,
                                          p.time_scale_s, p.n_components, co2_seed, p.min_wavelength_m,
                                          p.field_time_origin_s) \
            if p.height_variation_enabled and p.co2_height_half_range_m > 0.0 else None

        # All random fields in one cosine pass (see sample()).
        self._fields = [f for f in (self.weather and self.weather.anomaly_field,
                                    self.window_layer and self.window_layer.gaussian_field,
                                    self.co2_layer and self.co2_layer.gaussian_field) if f is not None]
        self._bank = _SpectralBank([f.components for f in self._fields],
                                   max((f.dtype for f in self._fields), key=lambda d: d.itemsize)) \
            if self._fields else None
        # The weather alone, for points where only the radiance is wanted (sample(layers=False)).
        self._weather_bank = _SpectralBank([self.weather.anomaly_field.components], self.weather.anomaly_field.dtype) \
            if self.weather else None

    def day_of_year(self, t_s):
        """Day of year at simulation time ``t_s`` (s): epoch day + t/86400, days."""
        return self.parameters.epoch_day_of_year + np.asarray(t_s, float) / SECONDS_PER_DAY

    def mean_radiance_ru(self, lat_rad, t_s):
        """Radiance without weather, r.u.: the climatology, or the uniform value when it is off.

        Args:
            lat_rad: geocentric latitude, rad.
            t_s: simulation time, s (sets the day of year).
        """
        if self.parameters.climatology_enabled:
            return horizon_radiance_climatology(lat_rad, self.day_of_year(t_s))
        return self.parameters.uniform_radiance_ru + 0.0 * (np.asarray(lat_rad, float) + np.asarray(t_s, float))

    def sample(self, lat_rad, lon_rad, t_s, *, layers: bool = True) -> HorizonEnvironmentSample:
        """Everything the horizon profile needs at points and times (see :class:`HorizonEnvironmentSample`).

        One pass: the random fields share the trigonometry of the points and
        one cosine evaluation, so this is cheaper than the three methods below
        called one by one (and gives the same values).

        Args:
            lat_rad: geocentric latitude, rad (Earth-fixed).
            lon_rad: longitude, rad (Earth-fixed).
            t_s: simulation time, s.
            layers: False for points where only the radiance is wanted (the
                sensor's probe points inside the horizon): the layer-height
                fields are not evaluated and the heights come back NaN.
        """
        lat, lon, t, shape = _flat_points(lat_rad, lon_rad, t_s)
        bank = self._bank if layers else self._weather_bank
        values = bank.evaluate(lat, lon, t) if bank is not None else None
        column = iter(range(len(self._fields)))
        mean = self.mean_radiance_ru(lat, t) + 0.0 * lon
        if self.weather is not None:
            band = None if self.weather.band_field is None else self.weather.band_field.evaluate(lat, lon, t)
            radiance = self.weather.radiance_from_anomaly(mean, self.weather.combine(values[:, next(column)], band))
        else:
            radiance = mean
        heights = []
        for layer, constant_m in ((self.window_layer, self.parameters.window_height_mean_m),
                                  (self.co2_layer, self.parameters.co2_height_m)):
            if not layers:
                heights.append(np.full(lat.shape, np.nan))
            elif layer is not None:
                heights.append(layer.height_from_gaussian(values[:, next(column)]))
            else:
                heights.append(constant_m + 0.0 * (lat + lon + t))
        return HorizonEnvironmentSample(_shaped(radiance, shape), _shaped(heights[0], shape),
                                        _shaped(heights[1], shape), _shaped(mean, shape))

    def weather_parts(self, lat_rad, lon_rad, t_s):
        """The radiance without weather (r.u.) and the background anomaly g (σ = 1) at points: two flat arrays.

        With :meth:`synoptic_band` and :meth:`radiance_from_parts` this is
        :meth:`sample`'s radiance in pieces, for callers that evaluate the slow
        synoptic band on a coarser grid than the rest (pmv_ros.physics.sensor).
        g is zeros without weather.
        """
        lat, lon, t, _ = _flat_points(lat_rad, lon_rad, t_s)
        mean = self.mean_radiance_ru(lat, t) + 0.0 * lon
        if self.weather is None:
            return mean, np.zeros(lat.size)
        return mean, self._weather_bank.evaluate(lat, lon, t)[:, 0]

    def background_anomaly(self, lat_rad, lon_rad, t_s):
        """The weather's red background g (σ = 1) at points, flat; zeros without weather."""
        lat, lon, t, _ = _flat_points(lat_rad, lon_rad, t_s)
        if self.weather is None:
            return np.zeros(lat.size)
        return self._weather_bank.evaluate(lat, lon, t)[:, 0]

    def synoptic_band(self, lat_rad, lon_rad, t_s):
        """The synoptic band field s (σ = 1) at points, flat; None when the weather has no band."""
        if self.weather is None or self.weather.band_field is None:
            return None
        lat, lon, t, _ = _flat_points(lat_rad, lon_rad, t_s)
        return self.weather.band_field.evaluate(lat, lon, t)

    def radiance_from_parts(self, mean_radiance_ru, background, band):
        """Horizon radiance, r.u., from :meth:`weather_parts` and :meth:`synoptic_band` (band may be None).

        The parts broadcast: the sensor gives the climatology at every point of a chord's profile and
        the anomaly of its horizon point only (the weather as a horizon level, physics.md §3.2 item 3).
        """
        if self.weather is None:
            return np.asarray(mean_radiance_ru, float)
        return self.weather.radiance_from_anomaly(mean_radiance_ru, self.weather.combine(background, band))

    def horizon_radiance_ru(self, lat_rad, lon_rad, t_s):
        """Horizon radiance B_m with climatology and weather, r.u.

        Args:
            lat_rad: geocentric latitude, rad (Earth-fixed).
            lon_rad: longitude, rad (Earth-fixed).
            t_s: simulation time, s.
        """
        mean = self.mean_radiance_ru(lat_rad, t_s)
        if self.weather is None:
            return mean + 0.0 * np.asarray(lon_rad, float)
        return self.weather.radiance_ru(mean, lat_rad, lon_rad, t_s)

    def window_height_m(self, lat_rad, lon_rad, t_s):
        """Height of the window-emitting layer h_w, m.

        Args:
            lat_rad: geocentric latitude, rad (Earth-fixed).
            lon_rad: longitude, rad (Earth-fixed).
            t_s: simulation time, s.
        """
        return self._layer(self.window_layer, self.parameters.window_height_mean_m, lat_rad, lon_rad, t_s)

    def co2_height_m(self, lat_rad, lon_rad, t_s):
        """Height of the CO₂ layer, m (constant unless a spread is configured).

        Args:
            lat_rad: geocentric latitude, rad (Earth-fixed).
            lon_rad: longitude, rad (Earth-fixed).
            t_s: simulation time, s.
        """
        return self._layer(self.co2_layer, self.parameters.co2_height_m, lat_rad, lon_rad, t_s)

    @staticmethod
    def _layer(field, constant_m, lat_rad, lon_rad, t_s):
        """A layer's height from its field, or the constant (broadcast; NaN-propagating) when fixed."""
        if field is not None:
            return field.height_m(lat_rad, lon_rad, t_s)
        return constant_m + 0.0 * (np.asarray(lat_rad, float) + np.asarray(lon_rad, float) + np.asarray(t_s, float))
