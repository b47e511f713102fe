"""Error statistics of the sensor against a reference: running and harmonic, and the per-channel record.

All in radians (arcmin only where people read the output):

* :class:`RunningStatistics` — count, mean, σ (N − 1), 3σ and max |e| with
  Welford's update: O(1) memory whatever the run length.
* :func:`harmonic_amplitudes` and :class:`OrbitRing` — amplitudes of the
  harmonics of the orbital frequency (physics.md §5.1) of a series over one
  orbit. Samples may be unevenly spaced and have gaps: the amplitudes come
  from a least-squares fit (see :func:`harmonic_amplitudes` for the rules).
* :class:`ChannelStatistics` — one channel's figures, the record every layer
  above reports (:data:`CHANNELS` names the channels).

The published flight-test procedure built on them is :mod:`.flight_test`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np



#: Harmonics of the orbital frequency reported by default (physics.md §5.1):
#: k = 1 (roll oblateness), k = 2 (pitch oblateness), 15…25 (radiance zones).
ORBIT_HARMONICS = (1, 2) + tuple(range(15, 26))

#: Largest noise gain of a harmonic's amplitude for which it is reported: the standard error the orbit's coverage
#: gives it over the one an evenly covered orbit of as many samples gives (1 without gaps). Above it the gaps leave
#: the harmonic undetermined — reported pending, not a number. design/harmonic_gaps.py measures, on the star
#: tracker's real gap patterns, the gain against the amplitude error of a known signal.
MAX_NOISE_GAIN = 3.0

TWO_PI = 2.0 * math.pi


class RunningStatistics:
    """Running count, mean, sample σ (N − 1), 3σ and max |e| of a stream of values, O(1) memory.

    Welford's update, with Chan's pairwise merge for batches, so neither a
    long run nor a large offset loses precision. Non-finite values are not
    accumulated; they are counted in :attr:`non_finite`.
    """

    __slots__ = ("count", "mean", "_m2", "max_abs", "non_finite")

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget everything."""
        self.count = 0
        self.mean = math.nan
        self._m2 = 0.0
        self.max_abs = math.nan
        self.non_finite = 0

    def update(self, values) -> None:
        """Add one value or an array of values (any unit; the statistics keep it)."""
        if isinstance(values, float):
            if math.isfinite(values):
                self.add(values)
            else:
                self.non_finite += 1
            return
        data = np.asarray(values, float).ravel()
        finite = np.isfinite(data)
        if not finite.all():
            self.non_finite += int(data.size - finite.sum())
            data = data[finite]
        n_new = data.size
        if n_new == 0:
            return
        if n_new == 1:
            self.add(float(data[0]))
            return
        batch_mean = float(data.mean())
        self.merge(n_new, batch_mean, float(((data - batch_mean) ** 2).sum()), float(np.abs(data).max()))

    def merge(self, count: int, mean: float, m2: float, max_abs: float) -> None:
        """Take a batch of ``count`` finite values given by its mean, Σ(e − mean)² and max |e| (Chan's merge)."""
        if self.count == 0:
            self.count, self.mean, self._m2, self.max_abs = count, mean, m2, max_abs
            return
        total = self.count + count
        delta = mean - self.mean
        self.mean += delta * count / total
        self._m2 += m2 + delta * delta * self.count * count / total
        self.count = total
        self.max_abs = max(self.max_abs, max_abs)

    def add(self, value: float) -> None:
        """Welford's update with one finite float — the live monitor's per-sample path: no checks, no arrays."""
        count = self.count = self.count + 1
        if count == 1:
            self.mean, self._m2, self.max_abs = value, 0.0, abs(value)
            return
        delta = value - self.mean
        self.mean += delta / count
        self._m2 += delta * (value - self.mean)
        magnitude = abs(value)
        if magnitude > self.max_abs:
            self.max_abs = magnitude

    @property
    def variance(self) -> float:
        """Sample variance Σ(e − mean)²/(N − 1); NaN below two values."""
        return self._m2 / (self.count - 1) if self.count >= 2 else math.nan

    @property
    def sigma(self) -> float:
        """Sample standard deviation with N − 1 (physics.md §5, step 5); NaN below two values."""
        return math.sqrt(self.variance) if self.count >= 2 else math.nan

    @property
    def three_sigma(self) -> float:
        """3σ — the limit half-width for a normal law (physics.md §3.1, model C)."""
        return 3.0 * self.sigma

    @property
    def limit_low(self) -> float:
        """mean − 3σ."""
        return self.mean - self.three_sigma

    @property
    def limit_high(self) -> float:
        """mean + 3σ."""
        return self.mean + self.three_sigma


def update_rows(statistics, values) -> None:
    """Each :class:`RunningStatistics` of ``statistics`` takes the finite values of its row of ``values``
    ``(len(statistics), N)``: the rows' batch moments on the whole matrix at once, then Chan's merge per row
    (as :meth:`RunningStatistics.update` merges an array)."""
    values = np.asarray(values, float)
    finite = np.isfinite(values)
    counts = finite.sum(axis=1)
    if not counts.any():
        return
    with np.errstate(invalid="ignore", divide="ignore"):
        means = np.where(finite, values, 0.0).sum(axis=1) / counts
        deviations = np.where(finite, values - means[:, None], 0.0)
    m2s = (deviations * deviations).sum(axis=1)
    largest = np.where(finite, np.abs(values), -np.inf).max(axis=1)
    for stats, count, mean, m2, magnitude in zip(statistics, counts.tolist(), means.tolist(), m2s.tolist(),
                                                 largest.tolist()):
        if count:
            stats.merge(count, mean, m2, magnitude)


@dataclass(frozen=True)
class HarmonicFit:
    """Harmonic amplitudes of a series over one orbit, and what the orbit's coverage made of each (physics.md §5.1).

    ``harmonics`` the k asked for; ``coefficients`` ``(K,)`` or ``(K, C)`` complex a_k − i·b_k of
    a_k cos kφ + b_k sin kφ, in the unit of the values (linear in them), NaN where pending; ``noise_gain`` ``(K,)``
    each amplitude's standard error over that of an evenly covered orbit of as
    many samples (inf: not fitted); ``pending`` ``(K,)`` why each NaN is one ("" where reported);
    ``largest_hole_rad`` the longest stretch of orbital angle without samples; ``covered`` the share of the
    orbit's angle within half a median sample spacing of a sample.
    """

    harmonics: tuple
    coefficients: np.ndarray
    noise_gain: np.ndarray
    pending: tuple
    largest_hole_rad: float
    covered: float

    @property
    def amplitude(self) -> np.ndarray:
        """√(a_k² + b_k²): the half peak-to-peak of each harmonic, ``(K,)`` or ``(K, C)``, NaN where pending."""
        return np.abs(self.coefficients)

    @property
    def pending_note(self) -> str:
        """The pending harmonics and why, in one phrase ("" if none)."""
        groups = {}
        for k, why in zip(self.harmonics, self.pending):
            if why:
                groups.setdefault(why, []).append(int(k))
        return "; ".join(f"k = {_ranges(ks)}: {why}" for why, ks in groups.items())


def _ranges(ks) -> str:
    """1, 2, 15, 16, 17 → "1, 2, 15–17"."""
    parts, start = [], None
    for i, k in enumerate(ks):
        if start is None:
            start = k
        if i + 1 == len(ks) or ks[i + 1] != k + 1:
            parts.append(str(start) if start == k else f"{start}–{k}")
            start = None
    return ", ".join(parts)


def _fit(reduced: np.ndarray, data: np.ndarray, orders: list) -> tuple[np.ndarray, np.ndarray]:
    """Least squares of a constant and cos/sin of ``orders``: (a_k − i·b_k ``(len(orders), C)``, noise gains)."""
    o = np.asarray(orders, float)
    design = np.concatenate([np.ones((reduced.size, 1)), np.cos(np.outer(reduced, o)), np.sin(np.outer(reduced, o))],
                            axis=1)
    u, singular, vt = np.linalg.svd(design, full_matrices=False)
    count = len(orders)
    if singular[-1] <= singular[0] * 1e-12:  # singular: nothing is determined
        return np.full((count, data.shape[1]), np.nan + 0j), np.full(count, np.inf)
    coefficients = vt.T @ ((u.T @ data) / singular[:, None])
    # (XᵀX)⁻¹'s diagonal; an evenly covered orbit of n samples gives 2/n for each cosine and sine coefficient.
    variance = np.sum((vt / singular[:, None]) ** 2, axis=0)
    gain = np.sqrt((variance[1:1 + count] + variance[1 + count:]) / 2.0 * reduced.size / 2.0)
    return coefficients[1:1 + count] - 1j * coefficients[1 + count:], gain


def fit_harmonics(phase_rad, values, harmonics=ORBIT_HARMONICS, *, jointly=ORBIT_HARMONICS,
                  max_noise_gain: float = MAX_NOISE_GAIN) -> HarmonicFit:
    """Amplitudes of harmonics k of the orbital frequency in a series over one orbit, on the samples there are
    (physics.md §5.1).

    Least squares of a constant plus a_k cos kφ + b_k sin kφ: the amplitude of harmonic k is √(a_k² + b_k²) — the
    half peak-to-peak of that sinusoid, in the unit of ``values``. For evenly spaced samples over a whole orbit
    this is exactly the DFT amplitude (the harmonics are orthogonal, so power elsewhere does not leak in); uneven
    samples and gaps need no resampling.

    What is fitted together: the harmonics of ``jointly`` (by default those of §5.1 — the oblateness at k = 1, 2
    and the radiance zones at 15…25, where the power is) in one fit; any other k asked for in a fit of its own
    with them. Not every k at once, on purpose: with a gap, a fit of many neighbouring harmonics is nearly
    singular — sinusoids can cancel over the samples and swing freely in the gap (every k ≤ 40 at a 16 % gap:
    amplitudes of 10⁷′). Power at harmonics not fitted leaks in through a gap instead, by up to their amplitude
    at a gap of a sixth of the orbit (design/harmonic_gaps.py).

    A harmonic is reported when the orbit determines it, else NaN with the reason in ``pending``:

    * the samples reach it: k ≤ (n − 1)//2, n the number of distinct orbital angles (the Nyquist limit; e.g.
      16 samples an orbit resolve k ≤ 7 — and a harmonic above it aliases onto a lower one);
    * the gaps leave it determined: its noise gain — the standard error of its amplitude over that of an evenly
      covered orbit of as many samples, a property of the coverage alone — is at most ``max_noise_gain``.

    Args:
        phase_rad: ``(N,)`` orbital angle of each sample, rad — Ω·t or u; any origin, may span several orbits
            (it is the angle that matters).
        values: ``(N,)`` or ``(N, C)`` samples (C channels fitted together).
        harmonics: the k to report (positive integers).
        jointly: the k fitted together with each other (and with every other k asked for).
        max_noise_gain: the largest noise gain reported (≥ 1).
    """
    ks = [int(k) for k in np.asarray(harmonics, dtype=int).ravel()]
    base = sorted({int(k) for k in np.asarray(jointly, dtype=int).ravel()})
    if not ks or min(ks) < 1 or (base and min(base) < 1):
        raise ValueError(f"harmonics must be positive integers, got {ks} (jointly {base})")
    if not max_noise_gain >= 1.0:
        raise ValueError(f"max_noise_gain = {max_noise_gain} must be ≥ 1")
    phase = np.asarray(phase_rad, float).ravel()
    data = np.asarray(values, float)
    single = data.ndim == 1
    data = data[:, None] if single else data.reshape(phase.size, -1)
    if data.shape[0] != phase.size:
        raise ValueError(f"values have {data.shape[0]} samples for {phase.size} phases")
    coefficients = np.full((len(ks), data.shape[1]), np.nan + 0j)
    gain = np.full(len(ks), np.inf)
    finite = np.isfinite(phase) & np.all(np.isfinite(data), axis=1)
    # Phases reduced modulo 2π keep cos/sin of large arguments accurate.
    reduced = np.mod(phase[finite], TWO_PI)
    data = data[finite]
    angles = np.unique(np.round(reduced, 12))
    if angles.size < 3:
        why = "fewer than 3 distinct orbital angles"
        return HarmonicFit(tuple(ks), coefficients[:, 0] if single else coefficients, gain, (why,) * len(ks), TWO_PI,
                           0.0)
    holes = np.diff(np.append(angles, angles[0] + TWO_PI))
    spacing = float(np.median(holes))
    covered = float(np.minimum(holes, spacing).sum() / TWO_PI)
    nyquist = (angles.size - 1) // 2
    together = [k for k in base if k <= nyquist]
    found = {}
    if together:
        fitted, gains = _fit(reduced, data, together)
        found.update((k, (fitted[row], gains[row])) for row, k in enumerate(together))
    for k in dict.fromkeys(ks):
        if k <= nyquist and k not in found:
            fitted, gains = _fit(reduced, data, together + [k])
            found[k] = (fitted[-1], gains[-1])
    pending = []
    for i, k in enumerate(ks):
        if k > nyquist:
            pending.append(f"above the Nyquist limit of {angles.size} orbital angles")
            continue
        fitted, gain[i] = found[k]
        if gain[i] <= max_noise_gain:
            coefficients[i] = fitted
            pending.append("")
        else:
            pending.append(f"the gaps leave it undetermined (noise gain above {max_noise_gain:g}; largest hole "
                           f"{math.degrees(holes.max()):.0f}°)")
    return HarmonicFit(tuple(ks), coefficients[:, 0] if single else coefficients, gain, tuple(pending),
                       float(holes.max()), covered)


def harmonic_amplitudes(phase_rad, values, harmonics=ORBIT_HARMONICS, *, jointly=ORBIT_HARMONICS,
                        max_noise_gain: float = MAX_NOISE_GAIN):
    """The amplitudes of :func:`fit_harmonics`: ``(len(harmonics),)`` or ``(len(harmonics), C)``, NaN where
    pending."""
    return fit_harmonics(phase_rad, values, harmonics, jointly=jointly, max_noise_gain=max_noise_gain).amplitude


class OrbitRing:
    """A one-orbit ring of time bins for the harmonic analysis of a live series (physics.md §5.1).

    The orbit is cut into ``n_bins`` bins of equal duration; each keeps, per
    channel, the sum of the values, the sum of the time stamps and the count
    of the samples that fell in it during the last orbit. A bin is reused
    when its turn comes again one period later, so memory is fixed whatever
    the run length and the sample rate. The harmonics are fitted to the bin
    means at their mean time stamps (:func:`harmonic_amplitudes`): uneven
    sampling and empty bins (gaps) need no resampling. Averaging within a bin
    attenuates harmonic k by about sinc(πk/n_bins) — 0.1 % at k = 25 with the
    default 1024 bins.

    Args:
        period_s: orbital period, s.
        n_channels: number of parallel series (e.g. roll, pitch, meridional).
        n_bins: bins per orbit, at least 64 (k = 25 needs more than 51).
    """

    def __init__(self, period_s: float, n_channels: int, n_bins: int = 1024) -> None:
        if not (math.isfinite(period_s) and period_s > 0.0):
            raise ValueError(f"orbital period = {period_s} s must be a positive finite number")
        if not 64 <= int(n_bins) <= 1_000_000:
            raise ValueError(f"n_bins = {n_bins} is outside the allowed range 64 … 1000000")
        if int(n_channels) < 1:
            raise ValueError(f"n_channels = {n_channels} must be ≥ 1")
        self.period_s = float(period_s)
        self.n_bins = int(n_bins)
        self.n_channels = int(n_channels)
        self.bin_width_s = self.period_s / self.n_bins
        self._bin_index = np.empty(self.n_bins, dtype=np.int64)
        self._count = np.empty((self.n_bins, self.n_channels))
        self._time_sum = np.empty((self.n_bins, self.n_channels))
        self._value_sum = np.empty((self.n_bins, self.n_channels))
        self.clear()

    def clear(self) -> None:
        """Forget every sample (after a discontinuity of the time axis)."""
        self._bin_index.fill(np.iinfo(np.int64).min)
        self._count.fill(0.0)
        self._time_sum.fill(0.0)
        self._value_sum.fill(0.0)
        self._first_bin = None
        self._latest_bin = None
        self._time_origin_s = None

    @property
    def nbytes(self) -> int:
        """Memory held by the ring's arrays, bytes (constant for the ring's life)."""
        return sum(a.nbytes for a in (self._bin_index, self._count, self._time_sum, self._value_sum))

    def add(self, t_s: float, values) -> bool:
        """Add one sample at time ``t_s`` (s); NaN (or None) channels are skipped. False if older than the ring."""
        row = np.asarray(values, float).ravel()
        if row.size != self.n_channels:
            raise ValueError(f"expected {self.n_channels} values, got {row.size}")
        return self.add_many((float(t_s),), row[None, :]) == 1

    def add_many(self, t_s, values) -> int:
        """Add ``(N,)`` increasing stamps (s) and their ``(N, n_channels)`` values, each bin summed at once; NaN
        channels are skipped. Samples older than the ring are skipped too; returns how many were added.

        Time sums are kept relative to the first stamp, which keeps the bin means exact for large stamps.
        """
        t = np.asarray(t_s, float).ravel()
        data = np.asarray(values, float).reshape(t.size, self.n_channels)
        if t.size == 0:
            return 0
        if (t[1:] < t[:-1]).any():
            raise ValueError("add_many needs increasing stamps")
        if self._time_origin_s is None:
            self._time_origin_s = float(t[0])
        absolute = np.floor(t / self.bin_width_s).astype(np.int64)
        starts = np.flatnonzero(np.r_[True, absolute[1:] != absolute[:-1]])
        finite = np.isfinite(data)
        counts = np.add.reduceat(finite.astype(float), starts, axis=0)
        offsets = np.where(finite, (t - self._time_origin_s)[:, None], 0.0)
        time_sums = np.add.reduceat(offsets, starts, axis=0)
        value_sums = np.add.reduceat(np.where(finite, data, 0.0), starts, axis=0)
        sizes = np.diff(np.r_[starts, t.size]).tolist()
        added = 0
        for row, b in enumerate(absolute[starts].tolist()):  # one pass per bin (≈ n_bins per orbit)
            if self._latest_bin is not None and b <= self._latest_bin - self.n_bins:
                continue
            slot = b % self.n_bins
            if self._bin_index[slot] != b:
                if self._bin_index[slot] > b:
                    continue
                self._bin_index[slot] = b
                self._count[slot] = 0.0
                self._time_sum[slot] = 0.0
                self._value_sum[slot] = 0.0
            self._count[slot] += counts[row]
            self._time_sum[slot] += time_sums[row]
            self._value_sum[slot] += value_sums[row]
            if self._first_bin is None:
                self._first_bin = b
            self._latest_bin = b if self._latest_bin is None else max(self._latest_bin, b)
            added += sizes[row]
        return added

    @property
    def full_orbit(self) -> bool:
        """True once the ring has spanned a whole period since it was (re)started."""
        return self._first_bin is not None and self._latest_bin - self._first_bin >= self.n_bins - 1

    def amplitudes(self, harmonics=ORBIT_HARMONICS, *, max_noise_gain: float = MAX_NOISE_GAIN) -> np.ndarray:
        """Harmonic amplitudes over the last orbit, ``(len(harmonics), n_channels)``; NaN until a full orbit and
        where pending (:func:`fit_harmonics`)."""
        return self.amplitudes_later(harmonics, max_noise_gain=max_noise_gain)()

    def amplitudes_later(self, harmonics=ORBIT_HARMONICS, *,
                         max_noise_gain: float = MAX_NOISE_GAIN) -> Callable[[], np.ndarray]:
        """:meth:`amplitudes` of the orbit the ring holds now, fitted when the returned function is called."""
        fits = self.fits_later(harmonics, max_noise_gain=max_noise_gain)
        shape = (len(tuple(harmonics)), self.n_channels)

        def amplitudes() -> np.ndarray:
            result = np.full(shape, np.nan)
            for c, fit in enumerate(fits()):
                if fit is not None:
                    result[:, c] = fit.amplitude
            return result

        return amplitudes

    def fits_later(self, harmonics=ORBIT_HARMONICS, *,
                   max_noise_gain: float = MAX_NOISE_GAIN) -> Callable[[], list]:
        """Per channel, the :class:`HarmonicFit` of the orbit the ring holds now (None: no full orbit yet, or no
        sample of that channel), fitted when the returned function is called: the bins are copied now (≈ 150 kB
        with 1024 bins and 6 channels), the least-squares fit (≈ 1 ms) is left to the call, for a reader that may
        never come. The same numbers, bit for bit, whatever the ring takes meanwhile."""
        harmonics = tuple(harmonics)
        channels = self.n_channels
        if not self.full_orbit:
            return lambda: [None] * channels
        omega, oldest = TWO_PI / self.period_s, self._latest_bin - self.n_bins
        bin_index, count, time_sum, value_sum = (a.copy() for a in (self._bin_index, self._count, self._time_sum,
                                                                    self._value_sum))

        def fit() -> list:
            result = [None] * channels
            in_orbit = bin_index > oldest
            done = set()
            for c in range(channels):
                if c in done:
                    continue
                # Channels with the same samples in every bin are fitted together (one factorisation).
                group = [d for d in range(c, channels) if d not in done
                         and np.array_equal(count[in_orbit, d], count[in_orbit, c])
                         and np.array_equal(time_sum[in_orbit, d], time_sum[in_orbit, c])]
                done.update(group)
                mask = in_orbit & (count[:, c] > 0)
                if not mask.any():
                    continue
                counts = count[mask][:, group]
                mean_time = time_sum[mask][:, group[0]] / counts[:, 0]
                means = value_sum[mask][:, group] / counts
                together = fit_harmonics(omega * mean_time, means, harmonics, max_noise_gain=max_noise_gain)
                for column, d in enumerate(group):
                    result[d] = HarmonicFit(together.harmonics, together.coefficients[:, column], together.noise_gain,
                                            together.pending, together.largest_hole_rad, together.covered)
            return result

        return fit


CHANNELS = ("roll", "pitch", "meridional")

#: How a statistic reads where people and plotters read it while it is not defined yet (a harmonic before a whole
#: orbit, σ before two samples): this word, never "nan" — on /pmv/error_statistics and in pmv's tables alike.
PENDING = "pending"


def statistic_text(value, format_spec: str = "") -> str:
    """A statistic as text: ``format(value, format_spec)`` (``repr`` of the float without a spec), or
    :data:`PENDING` while it is not defined (NaN, ±inf or None)."""
    if value is None or not math.isfinite(value):
        return PENDING
    return format(value, format_spec) if format_spec else repr(float(value))


@dataclass(frozen=True)
class ChannelStatistics:
    """The statistics of one channel (roll, pitch or meridional), rad: the one record of the live monitor,
    of /pmv/error_statistics (the shim lays it out) and of the flight-test analysis
    (:class:`pmv_ros.analysis.flight_test.ChannelResult`).

    ``harmonics_rad`` maps k (multiple of the orbital frequency) to an amplitude, rad
    (NaN until there is a whole orbit, and where the orbit does not determine it: ``harmonics_pending`` says
    which and why, :attr:`HarmonicFit.pending_note`). ``ground_*`` is the residual as the ground
    error of a nadir imager, m (physics.md §7): cross-track for roll, along-track
    for pitch, circular for meridional; NaN where it is not computed.
    """

    channel: str
    count: int = 0
    mean_rad: float = math.nan
    sigma_rad: float = math.nan
    max_abs_rad: float = math.nan
    harmonics_rad: dict = field(default_factory=dict)
    ground_mean_m: float = math.nan
    ground_sigma_m: float = math.nan
    ground_max_abs_m: float = math.nan
    harmonics_pending: str = ""

    def __post_init__(self) -> None:
        if self.channel not in CHANNELS:
            raise ValueError(f"channel = {self.channel!r} must be one of {CHANNELS}")
        if int(self.count) != self.count or self.count < 0:
            raise ValueError(f"count = {self.count} must be a non-negative integer")
        object.__setattr__(self, "count", int(self.count))
        object.__setattr__(self, "harmonics_rad", {int(k): float(v) for k, v in dict(self.harmonics_rad).items()})

    @property
    def three_sigma_rad(self) -> float:
        """3σ (physics.md §5, step 5)."""
        return 3.0 * self.sigma_rad

    @property
    def limit_low_rad(self) -> float:
        """mean − 3σ."""
        return self.mean_rad - self.three_sigma_rad

    @property
    def limit_high_rad(self) -> float:
        """mean + 3σ."""
        return self.mean_rad + self.three_sigma_rad
