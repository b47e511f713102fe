"""Correlated random fields on the rotating Earth, zero mean and unit variance, evaluated pointwise.

The random fields are evaluated directly at the points asked for — a sum of
cosines of random wave vectors (spectral synthesis, "random Fourier features":
Shinozuka & Deodatis 1991; Rahimi & Recht 2007), or of sectoral spherical
harmonics about random axes for the synoptic band — so nothing is stored on a
global grid.

:class:`GaussianSphereField` has an exponential covariance in space;
:class:`SynopticBandField` has its variance in a band of spherical-harmonic
degrees; ``_SpectralBank`` stacks spectral fields for one cosine pass. The
helpers at the end (points, seeds, counts) serve the whole environment package.
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import kernel
from ..constants import EARTH_MEAN_RADIUS_M
from ..orbit.two_body import check_range

#: Shortest wavelength kept in the spectral synthesis, m. The exponential
#: covariance has power at all scales; the few components drawn beyond this
#: (≈ 1 in 30 fields has one at 700 km) are clipped to it. The sensor's IFOV
#: spans tens of km at the horizon, and the clip changes the covariance only
#: within a few km of zero lag. It also keeps every phase below ≈ 4·10⁴ rad,
#: where float32 arithmetic is still good to ≈ 3·10⁻³ rad.
MIN_WAVELENGTH_M = 1000.0

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

    Evaluation is a compiled pass over the N × M phases with a SIMD cosine
    (:func:`_cosine_sums`): ≈ 3 ns per point and component in float64 (the
    phases are formed in the field's float type, the cosine in float64;
    benchmarks/bench_environment.py --points).

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
            from scipy.special import ndtri  # imported where used (see SynopticBandField.__init__)

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
        design = np.empty((lat.size, 4), dtype=self.dtype)
        design[:, 0] = cos_lat * np.cos(lon)
        design[:, 1] = cos_lat * np.sin(lon)
        design[:, 2] = np.sin(lat)
        design[:, 3] = t - t_ref
        _cosine_sums(design, self._design_weights, phase_ref.astype(self.dtype), self._amplitudes, out)
        return out


#: π in three parts for the cosine's argument reduction: its first 33 bits (so that n·HI is exact for the
#: half-turn counts n < 2²⁰ of phases below ≈ 3·10⁶ rad), the rest of the float64 π, and π − fl(π) = sin(fl(π))
#: — r = x − n·π to ≈ 10⁻²⁰ rad.
_PI_HI = math.ldexp(math.floor(math.ldexp(math.pi, 31)), -31)
_PI_MID = math.pi - _PI_HI
_PI_LO = math.sin(math.pi)
#: Taylor coefficients of cos in r² on |r| ≤ π/2: the first term left out, (π/2)²²/22!, is < 2·10⁻¹⁷.
_C0, _C1, _C2, _C3, _C4, _C5, _C6, _C7, _C8, _C9, _C10 = ((-1) ** i / math.factorial(2 * i) for i in range(11))


@kernel
def _cosine(x):
    """cos x (float64, |x| < 10⁶ rad) to ≈ 1 ulp: x = n·π + r with r in [−π/2, π/2], (−1)ⁿ times a polynomial in r².
    Branch-free, so a loop of them runs in SIMD lanes, several times faster than numpy's float64 cosine at
    phases of 10⁴ rad — the cost of the environment's fields (benchmarks/bench_environment.py --points)."""
    n = math.floor(x * (1.0 / math.pi) + 0.5)
    r = ((x - n * _PI_HI) - n * _PI_MID) - n * _PI_LO
    z = r * r
    c = _C0 + z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * (_C6 + z * (_C7 + z * (_C8 + z * (
        _C9 + z * _C10)))))))))
    odd = n - 2.0 * math.floor(0.5 * n)  # n mod 2, in floats (a float-to-integer conversion has no SIMD form)
    return -c if odd == 1.0 else c


@kernel
def _weighted_sum(weights, values):
    """Σ weights·values in four interleaved partial sums: four additions in flight, not one chain of them."""
    s0 = s1 = s2 = s3 = 0.0
    n = values.size
    j = 0
    while j + 4 <= n:
        s0 += weights[j] * values[j]
        s1 += weights[j + 1] * values[j + 1]
        s2 += weights[j + 2] * values[j + 2]
        s3 += weights[j + 3] * values[j + 3]
        j += 4
    while j < n:
        s0 += weights[j] * values[j]
        j += 1
    return (s0 + s1) + (s2 + s3)


@kernel
def _cosine_sums(design, weights, phase, amplitudes, out):
    """out[p, f] = Σⱼ amplitudes[j, f]·cos(design[p]·weights[:, j] + phase[j]): the spectral fields at the points
    (rows of ``design``: the point's direction cosines and its time from the reference), one pass per point
    (no points × components work array). The phase is formed in the bank's float type, the cosine in float64."""
    components = phase.size
    row = np.empty(components)
    for p in range(design.shape[0]):
        d0, d1, d2, d3 = design[p, 0], design[p, 1], design[p, 2], design[p, 3]
        for j in range(components):
            row[j] = _cosine(d0 * weights[0, j] + d1 * weights[1, j] + d2 * weights[2, j] + d3 * weights[3, j]
                             + phase[j])
        for f in range(out.shape[1]):
            out[p, f] = _weighted_sum(amplitudes[:, f], row)


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
        dtype: float type of the evaluation (see :class:`GaussianSphereField`).
    """

    def __init__(self, degree_low: int = 15, degree_high: int = 25, time_scale_s: float = 86400.0,
                 n_components: int = 128, seed=0, time_origin_s: float = 0.0, dtype=np.float32) -> None:
        self.degree_low = _check_count("lowest synoptic degree", degree_low, 2, 200)
        self.degree_high = _check_count("highest synoptic degree", degree_high, self.degree_low, 200)
        self.time_scale_s = check_range("time scale", time_scale_s, 60.0, math.inf, " s")
        self.n_components = _check_count("number of spectral components", n_components, 16, 8192)
        rng = np.random.default_rng(_seed_sequence(seed))
        m = self.n_components
        self.dtype = np.dtype(dtype)
        # Random orthonormal frames: QR of Gaussian matrices, signs fixed so the law is Haar.
        gaussian = rng.standard_normal((m, 3, 3))
        q, r = np.linalg.qr(gaussian)
        q = q * np.sign(np.diagonal(r, axis1=1, axis2=2))[:, None, :]
        band = np.arange(self.degree_low, self.degree_high + 1)
        self.degrees = band[rng.permutation(np.arange(m) % band.size)].astype(self.dtype)
        # scipy.special where the fields are built: ≈ 0.13 s of imports that a process without fields (the monitor,
        # the star tracker, a refused command line) does not need.
        from scipy.special import gammaln, ndtri

        mean_power = np.exp(0.5 * math.log(math.pi) + gammaln(self.degrees + 1.0)
                            - gammaln(self.degrees + 1.5) - math.log(2.0))
        self._amplitude = np.sqrt(2.0 / (m * mean_power)).astype(self.dtype)
        if math.isinf(self.time_scale_s):
            self._frequency_rad_s = np.zeros(m)
        else:
            quantiles = (rng.permutation(m) + rng.uniform(0.0, 1.0, m)) / m
            self._frequency_rad_s = (math.sqrt(2.0) / self.time_scale_s) * ndtri(quantiles)
        self._phase_rad = _phases_at_origin(rng.uniform(0.0, 2.0 * math.pi, m), self._frequency_rad_s,
                                            time_origin_s)
        # What every evaluation uses, in the evaluation's complex type: w = e₁ + i·e₂ and the degrees.
        self._complex = np.result_type(self.dtype, np.complex64)
        self._w = (q[:, :, 0].T + 1j * q[:, :, 1].T).astype(self._complex)
        self._w_re, self._w_im = np.ascontiguousarray(self._w.real), np.ascontiguousarray(self._w.imag)
        self._exponents = self.degrees.astype(np.int64) - 1  # (x·w)^ℓ = (x·w)·(x·w)^(ℓ − 1)

    def correlation(self, angle_rad):
        """Ensemble correlation at great-circle angle ψ (rad): the band mean of P_ℓ(cos ψ)."""
        c = np.cos(np.asarray(angle_rad, float))
        band = np.arange(self.degree_low, self.degree_high + 1)
        from scipy.special import eval_legendre  # imported where used, as in __init__

        return np.mean([eval_legendre(int(ell), c) for ell in band], axis=0)

    def __call__(self, lat_rad, lon_rad, t_s):
        """Field value (dimensionless, zero mean, unit variance) at points and times (NaN-propagating)."""
        lat, lon, t, shape = _flat_points(lat_rad, lon_rad, t_s)
        return _shaped(self.evaluate(lat, lon, t), shape)

    def evaluate(self, lat, lon, t):
        """The field at flat arrays of latitude, longitude (rad) and time (s); ``(N,)``.

        Re[(x·w)^ℓ·e^{iφ(t)}] summed with the amplitudes (:func:`_sectoral_sums`), the phase φ = ωt + b as
        e^{iφ} once per distinct time of the batch (a node's grid has a few times for its four chords).
        """
        out = np.empty(lat.size)
        if lat.size == 0:
            return out
        t_ref, phase_ref = _reference_phases(self._phase_rad, self._frequency_rad_s, t)
        cos_lat = np.cos(lat)
        unit = np.empty((lat.size, 3), dtype=self.dtype)
        unit[:, 0] = cos_lat * np.cos(lon)
        unit[:, 1] = cos_lat * np.sin(lon)
        unit[:, 2] = np.sin(lat)
        times, which = np.unique(t - t_ref, return_inverse=True)
        rotation = np.exp(1j * (phase_ref + times[:, None] * self._frequency_rad_s)).astype(self._complex)
        _sectoral_sums(unit, self._w_re, self._w_im, self._exponents, rotation, which.ravel(), self._amplitude, out)
        return out


@kernel
def _sectoral_sums(unit, w_re, w_im, exponents, rotation, which, amplitude, out):
    """out[p] = Σⱼ amplitude[j]·Re[zⱼ^(exponents[j] + 1)·rotation[which[p], j]] with zⱼ = unit[p]·(w_re + i·w_im)[:, j],
    one pass per point; the power by repeated squaring, bit by bit of the exponents over all components at once
    (a loop over components runs in SIMD lanes), in the float type of ``w``."""
    components = exponents.size
    top = 0
    while (np.max(exponents) >> top) > 0:
        top += 1
    base_re, base_im = np.empty(components, w_re.dtype), np.empty(components, w_re.dtype)
    power_re, power_im = np.empty(components, w_re.dtype), np.empty(components, w_re.dtype)
    row = np.empty(components)
    for p in range(unit.shape[0]):
        x0, x1, x2 = unit[p, 0], unit[p, 1], unit[p, 2]
        for j in range(components):
            base_re[j] = x0 * w_re[0, j] + x1 * w_re[1, j] + x2 * w_re[2, j]
            base_im[j] = x0 * w_im[0, j] + x1 * w_im[1, j] + x2 * w_im[2, j]
            power_re[j], power_im[j] = base_re[j], base_im[j]
        for bit in range(top):
            for j in range(components):
                br, bi, pr, pi = base_re[j], base_im[j], power_re[j], power_im[j]
                use = (exponents[j] >> bit) & 1
                power_re[j] = pr * br - pi * bi if use else pr
                power_im[j] = pr * bi + pi * br if use else pi
                base_re[j] = br * br - bi * bi
                base_im[j] = br * bi + bi * br
        turn = rotation[which[p]]
        for j in range(components):
            row[j] = power_re[j] * turn[j].real - power_im[j] * turn[j].imag
        out[p] = _weighted_sum(amplitude, row)


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
